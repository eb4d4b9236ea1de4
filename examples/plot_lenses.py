"""
Magic volume lenses and rendering modes: look closer without losing the context
===============================================================================

The Magic Volume Lens (Wang, Zhao, Mueller, Kaufman 2005) magnifies part of a volume
rendering while the surround stays visible, compressed into a transition band. In
pv_hdrvol a lens is a *ray generator*: ``lens.rays(camera, size)`` moves where rays
start (a magnifier scales the ray start points about the focal plane's lens centre, as
a camera dolly toward it would), and the renderer composites them as any other rays.
Where a lens makes rays sparser than the camera's (the compressed band), the rays
carry a level of detail and sample a mip-map of the volume instead of aliasing (the
paper's Eq. 4).

This example renders the engine CT from ../shared/data

1. with no lens, a circular magnifier (x3), a square one, a feature lens that takes the
   projected shape of the engine's dense parts, a sampling-rate lens (a cubic ray
   density, the paper's §3.3) and a 270-degree fisheye from a camera inside the block
   (the paper's virtual-colonoscopy view, §3.4) -- the paper's Figs. 3, 10 and 12;
2. in the other rendering modes: maximum intensity projection, an X-ray (additive),
   gradient-magnitude opacity, and two-level rendering of the CT head segmented at a
   bone threshold, bone by MIP and skin by emission-absorption (the paper's Fig. 15).

Run::

    python3 examples/plot_lenses.py          # writes docs/images/lenses_gallery.png, modes_gallery.png
"""
import dataclasses
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_hdrvol as hv  # noqa: E402

try:
    REPO = Path(__file__).resolve().parents[1]
except NameError:  # sphinx-gallery runs examples without __file__, in examples/
    REPO = Path.cwd().resolve().parent
DATA = Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data")) / "structured"
# the figures go to docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", REPO / "docs" / "images"))
SIZE = 320


def engine_tf():
    return hv.TransferFunction([0, 60, 100, 160, 255],
                               [[0, 0, 0], [0.3, 0.5, 0.9], [0.9, 0.8, 0.5], [1.0, 0.5, 0.2], [1, 1, 1]],
                               [0.0, 0.0, 0.01, 0.15, 0.6])


def show(ax, img, title, exposure=None):
    ax.imshow(img.tonemap("reinhard").rgb if exposure is None else img.to_display(exposure))
    ax.set_title(title, fontsize=9)
    ax.set_axis_off()


def lens_gallery():
    engine = hv.volume_from_dataset(pv.read(DATA / "engine_256x256x128_uint8.vti"))
    tf = engine_tf()
    cam = hv.Camera.fit(engine, "iso", zoom=1.3)
    c = (0.45 * SIZE, 0.56 * SIZE)  # over the cylinder bores
    inside = hv.Camera((128.0, 40.0, 64.0), (128.0, 200.0, 64.0), (0, 0, 1), view_angle=60.0)
    lenses = [
        ("no lens", None, cam),
        ("magnifier, circle, x3", hv.Magnifier(c, radius=70, transition=25, factor=3.0), cam),
        ("magnifier, square, x3", hv.Magnifier(c, radius=70, transition=25, factor=3.0, shape="square"), cam),
        ("feature lens (values > 160), x2",
         hv.FeatureLens.from_range(engine, 160, 255, transition=20, factor=2.0), cam),
        ("sampling-rate lens, cubic", hv.SamplingRateLens(c, radius=90, factor=6.0), cam),
        ("fisheye 270°, camera inside", hv.Fisheye(270.0), inside),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(11, 7.6))
    for ax, (title, lens, camera) in zip(axes.ravel(), lenses):
        img = hv.render(engine, tf, camera, SIZE, lens=lens, progress_bar=False)
        show(ax, img, title)
        circular = isinstance(lens, hv.SamplingRateLens) or (isinstance(lens, hv.Magnifier) and lens.shape == "circle")
        if circular:  # the lens's outer edge (pixel centres sit at +0.5 in lens coordinates)
            ax.add_patch(plt.Circle((c[0] - 0.5, c[1] - 0.5), lens.radius, fill=False, ls=":", lw=0.6, color="w"))
    fig.suptitle("Magic volume lenses on the engine CT (tone-mapped with Reinhard)", fontsize=11)
    fig.tight_layout()
    fig.savefig(OUT / "lenses_gallery.png", dpi=90)


def modes_gallery():
    engine = hv.volume_from_dataset(pv.read(DATA / "engine_256x256x128_uint8.vti"))
    head = hv.volume_from_dataset(pv.read(DATA / "ct_head_120x120x130_uint8.vtk"))
    cam = hv.Camera.fit(engine, "iso", zoom=1.3)
    gray = hv.TransferFunction.ramp(0, 255, cmap="gray", opacity=(0.0, 0.3))
    tf = engine_tf()
    skin = hv.TransferFunction([0, 30, 60, 100], [[0.9, 0.6, 0.5]] * 4, [0.0, 0.0, 0.006, 0.006])
    bone = hv.TransferFunction([0, 100, 255], [[0.0, 0.0, 0.0], [0.9, 0.9, 0.8], [1.0, 1.0, 1.0]], [0.0, 0.0, 1.0])
    labels = (head.values > 100).astype(np.uint8)
    hcam = dataclasses.replace(hv.Camera.fit(head, "yz", zoom=1.2), view_up=(0.0, 0.0, -1.0))  # slices run downwards
    panels = [
        ("emission-absorption", hv.render(engine, tf, cam, SIZE, progress_bar=False)),
        ("maximum intensity projection", hv.render(engine, gray, cam, SIZE, blending="maximum", progress_bar=False)),
        ("X-ray (additive)", hv.render(engine, gray, cam, SIZE, blending="additive", progress_bar=False)),
        ("gradient-magnitude opacity", hv.render(engine, tf, cam, SIZE, gradient_opacity=(0.0, 40.0),
                                                  progress_bar=False)),
        ("CT head: emission-absorption", hv.render(head, skin, hcam, SIZE, progress_bar=False)),
        ("CT head, two-level: bone by MIP", hv.render(head, skin, hcam, SIZE, labels=labels,
                                                       label_styles={1: (bone, "maximum")}, progress_bar=False)),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(11, 7.6))
    for ax, (title, img) in zip(axes.ravel(), panels):
        show(ax, img, title)
    fig.suptitle("Rendering modes (tone-mapped with Reinhard)", fontsize=11)
    fig.tight_layout()
    fig.savefig(OUT / "modes_gallery.png", dpi=90)


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    lens_gallery()
    modes_gallery()
    print("wrote", OUT / "lenses_gallery.png", "and", OUT / "modes_gallery.png")
