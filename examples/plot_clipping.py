"""
Clipping planes and a crop box, cut exactly
===========================================

Users cut into volumes to see inside. ``clip_planes=`` (VTK's convention: the side the
normal points to is kept) and ``crop_box=`` cut grids, meshes and blocks alike; each
ray keeps one interval of the convex kept set, computed in closed form, so the cut is
where the plane is, not at the nearest sample:

1. the engine CT, whole;
2. the same cut by a plane through its centre, the near half removed;
3. cropped to a box around the crankcase;
4. the Blunt Fin, a tetrahedral mesh, cut by the same kind of plane: the walker starts
   inside the cells the plane cuts, with the scalar interpolated there.

Run::

    python3 examples/plot_clipping.py      # writes docs/images/clipping.png
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
DATA = Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data"))
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", REPO / "docs" / "images"))
SIZE = 320


def centre_and_eye(bounds, camera):
    centre = np.array([0.5 * (bounds[2 * i] + bounds[2 * i + 1]) for i in range(3)])
    return centre, np.asarray(camera.position) - centre


def main():
    fig, axes = plt.subplots(1, 4, figsize=(14, 4.0))
    engine = pv.read(DATA / "structured" / "engine_256x256x128_uint8.vti")
    tf = hv.TransferFunction([0, 60, 110, 180, 255], [[0.1, 0.1, 0.3], [0.2, 0.5, 1.0], [1.0, 0.8, 0.4],
                                                       [1.0, 0.3, 0.1], [1.0, 1.0, 1.0]],
                             [0.0, 0.0, 0.02, 0.3, 0.8])
    camera = hv.Camera.fit(engine.bounds, "iso")
    centre, towards = centre_and_eye(engine.bounds, camera)
    whole = hv.render(engine, tf, camera, SIZE, progress_bar=False)
    cut = hv.render(engine, tf, camera, SIZE, clip_planes=(tuple(centre), tuple(-towards)), progress_bar=False)
    box = (60.0, 200.0, 40.0, 220.0, 0.0, 100.0)
    cropped = hv.render(engine, tf, camera, SIZE, crop_box=box, progress_bar=False)
    for ax, img, title in ((axes[0], whole, "engine, whole"),
                           (axes[1], cut, "clip_planes=(centre, away from the eye)"),
                           (axes[2], cropped, f"crop_box={box}")):
        ax.imshow(img.tonemap("reinhard").rgb)
        ax.set_title(f"{title}\n{img.metadata['render_seconds']:.2f} s, {img.metadata['samples']:,} samples",
                     fontsize=8)
    fin = pv.read(DATA / "unstructured" / "bluntfin_187395tets.vtu")
    camera = hv.Camera.fit(fin.bounds, "iso")
    centre, towards = centre_and_eye(fin.bounds, camera)
    img = hv.render(fin, None, camera, SIZE, clip_planes=(tuple(centre), tuple(-towards)), progress_bar=False)
    axes[3].imshow(img.tonemap("reinhard").rgb)
    axes[3].set_title(f"Blunt Fin ({fin.n_cells:,} tets), cut inside its cells\n"
                      f"{img.metadata['render_seconds']:.2f} s", fontsize=8)
    for ax in axes:
        ax.set_axis_off()
    fig.tight_layout()
    OUT.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT / "clipping.png", dpi=90)
    print(f"wrote {OUT / 'clipping.png'}")


main()
