"""
Tetrahedral meshes: HDR ray casting, the boundary's depth layers, and upsampling
================================================================================

Finite-element and CFD results come as tetrahedral meshes. pv_hdrvol marches each ray
from cell to cell (exit faces decided by Plücker products that neighbouring cells
share, so no ray leaks), integrates every cell's segment exactly for the transfer
function's piecewise-linear extinction and colour, and composites in float32/float64
as for image volumes. Rendering small and upsampling with a joint bilateral filter
guided by the full-resolution depth layers of the mesh boundary (Callahan & Silva 2009)
trades accuracy for time.

This example uses the four meshes of ../shared/data/unstructured:

1. a gallery of the four meshes (tone mapped with Reinhard's operator), beside the
   number of boundary layers each pixel's ray crosses;
2. Blunt Fin at 512^2 from 64^2 (8x): full render, nearest, bilinear and joint
   bilateral upsampling, with their error maps against the full render.

Run::

    python3 examples/plot_tetrahedra.py      # writes docs/images/tets_gallery.png, tets_upsampling.png
"""
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
DATA = Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data")) / "unstructured"
# the figures go to docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", REPO / "docs" / "images"))
MESHES = [("spx_12936tets.vtk", "scalars", "SPX (12,936 tets)"),
          ("bluntfin_187395tets.vtu", "Density", "Blunt Fin (187,395 tets), density"),
          ("fea_bracket_56786tets.vtu", None, "FEA bracket (56,786 tets), von Mises stress"),
          ("post_513375tets.vtu", "VelocityMagnitude", "LOX post (513,375 tets), speed")]


def scene(name, scalars):
    mesh = hv.tetmesh_from_dataset(pv.read(DATA / name), scalars)
    lo, hi = mesh.value_range
    tf = hv.TransferFunction.ramp(lo, hi, cmap="viridis", opacity=(0.0, 0.3))
    return mesh, tf, hv.Camera.fit(mesh.bounds, "iso")


def gallery(size=384):
    fig, axes = plt.subplots(2, 4, figsize=(13, 6.6))
    for col, (name, scalars, title) in enumerate(MESHES):
        mesh, tf, cam = scene(name, scalars)
        img = hv.render(mesh, tf, cam, size, precision="float32", progress_bar=False)
        axes[0, col].imshow(img.tonemap("reinhard").rgb)
        axes[0, col].set_title(f"{title}\n{img.metadata['render_seconds']:.2f} s, "
                               f"{img.stats()['dynamic_range_decades']:.1f} decades", fontsize=8)
        layers = hv.depth_layers(mesh, cam, size, max_layers=8)
        im = axes[1, col].imshow(layers.counts, cmap="magma", vmin=0, vmax=max(layers.layers_needed, 2),
                                 interpolation="nearest")
        axes[1, col].set_title(f"boundary crossings per pixel (up to {layers.layers_needed})", fontsize=8)
        fig.colorbar(im, ax=axes[1, col], fraction=0.046)
    for ax in axes.ravel():
        ax.set_axis_off()
    fig.tight_layout()
    OUT.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT / "tets_gallery.png", dpi=90)
    print(f"wrote {OUT / 'tets_gallery.png'}")


def upsampling(size=512, factor=8):
    mesh, tf, cam = scene(MESHES[1][0], MESHES[1][1])
    tf = hv.TransferFunction.ramp(*mesh.value_range, cmap="viridis", opacity=(0.0, 1.0))
    full = hv.render(mesh, tf, cam, size, precision="float64", progress_bar=False)
    low = hv.render(mesh, tf, cam, size // factor, precision="float64", progress_bar=False)
    layers = hv.depth_layers(mesh, cam, size)
    results = [("full render", full)]
    for method in ("nearest", "bilinear"):
        results.append((method, hv.upsample(low, layers, factor, method=method)))
    results.append(("joint bilateral, layers (paper)", hv.upsample(low, layers, factor, guide="layers")))
    results.append(("joint bilateral, thickness", hv.upsample(low, layers, factor, guide="thickness")))
    fig, axes = plt.subplots(2, 5, figsize=(16, 6.6))
    ref = full.tonemap("reinhard")
    for col, (title, img) in enumerate(results):
        mapped = img.tonemap("reinhard", fitted=ref.fitted)
        axes[0, col].imshow(mapped.rgb)
        if col:
            rmse = float(np.sqrt(np.mean((img.rgba.astype(np.float64) - full.rgba) ** 2)))
            title += f" from {size // factor}² (RMSE {rmse:.2e})"
            err = np.abs(mapped.rgb.astype(np.float64) - ref.rgb).max(axis=2)
            axes[1, col].imshow(err, cmap="inferno", vmin=0, vmax=0.25)
            axes[1, col].set_title("|displayed - full| (0 to 0.25)", fontsize=8)
        else:
            axes[1, col].imshow(layers.normalized_thickness(), cmap="gray")
            axes[1, col].set_title("reference: ray length inside the mesh", fontsize=8)
        axes[0, col].set_title(title, fontsize=8)
    for ax in axes.ravel():
        ax.set_axis_off()
    fig.tight_layout()
    fig.savefig(OUT / "tets_upsampling.png", dpi=90)
    print(f"wrote {OUT / 'tets_upsampling.png'}")


if __name__ == "__main__":
    gallery()
    upsampling()
