"""
Shading: Blinn-Phong lighting by the data's gradient
====================================================

CT data composited without lighting looks flat: a surface shows only how much
material a ray crosses, not which way it faces. ``shade=True`` lights each sample by
the gradient of the field (the normal of its iso-surface there), with a headlight by
default: ``c (ambient + diffuse |n.l|) + specular (n.h)^p``, VTK's and PyVista's model
and defaults. The lighting fades in with the gradient, so homogeneous regions and noise
stay as they were; nothing is clamped, so highlights stay HDR.

Tetrahedral meshes are lit per cell: a tet's linear field has one gradient.

This example renders the engine, bonsai and CT-head volumes and the Blunt Fin mesh
without and with shading, tone mapped with Reinhard's operator.

Run::

    python3 examples/plot_shading.py      # writes docs/images/shading_gallery.png
"""
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_hdrvol as hv  # noqa: E402

try:
    REPO = Path(__file__).resolve().parents[1]
except NameError:  # sphinx-gallery runs examples without __file__, in examples/
    REPO = Path.cwd().resolve().parent
DATA = Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data"))
# the figures go to docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", REPO / "docs" / "images"))
SIZE = (320, 320)

SCENES = [
    ("structured/engine_256x256x128_uint8.vti", None, "engine CT",
     lambda: hv.TransferFunction([0, 60, 120, 200, 255], [[0.9, 0.5, 0.3], [0.9, 0.5, 0.3], [0.95, 0.8, 0.6],
                                                           [1, 1, 1], [1, 1, 1]], [0, 0, 0.03, 0.3, 0.8])),
    ("structured/bonsai_256x256x256_uint8.vti", None, "bonsai CT",
     lambda: hv.TransferFunction([0, 40, 70, 150, 255], [[0.4, 0.8, 0.3], [0.4, 0.8, 0.3], [0.5, 0.9, 0.4],
                                                          [0.8, 0.6, 0.4], [1, 1, 1]], [0, 0, 0.1, 0.5, 0.9])),
    ("structured/ct_head_120x120x130_uint8.vtk", None, "CT head",
     lambda: hv.TransferFunction([0, 70, 90, 150, 255], [[0.9, 0.6, 0.5], [0.9, 0.6, 0.5], [0.95, 0.75, 0.65],
                                                          [1, 1, 0.95], [1, 1, 1]], [0, 0, 0.04, 0.6, 0.9])),
    ("unstructured/bluntfin_187395tets.vtu", "Density", "Blunt Fin (tets), density", None),
]


def main():
    fig, axes = plt.subplots(2, len(SCENES), figsize=(3.2 * len(SCENES), 6.6))
    for col, (path, scalars, title, make_tf) in enumerate(SCENES):
        ds = pv.read(DATA / path)
        if make_tf is None:
            lo, hi = ds.get_data_range(scalars)
            tf = hv.TransferFunction.ramp(lo, hi, cmap="viridis", opacity=(0.0, 0.6))
        else:
            tf = make_tf()
        camera = hv.Camera.fit(ds.bounds, "iso")
        for row, shade in enumerate((False, True)):
            img = hv.render(ds, tf, camera, SIZE, scalars=scalars, shade=shade, progress_bar=False)
            ax = axes[row, col]
            ax.imshow(img.tonemap("reinhard").rgb8)
            ax.set_axis_off()
            ax.set_title(f"{title}\n{'shaded' if shade else 'unshaded'}", fontsize=9)
    fig.tight_layout()
    OUT.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT / "shading_gallery.png", dpi=90)
    print("wrote", OUT / "shading_gallery.png")


if __name__ == "__main__":
    main()
