"""
An HDR volume in a PyVista scene, and the editor's focus+context axis
=====================================================================

``plotter.hdrvol.add_volume(data, tf)`` draws our float render inside a PyVista
scene: VTK draws the meshes, their depth buffer becomes the distance at which each
pixel's ray stops, and the tone-mapped volume is composited over them. A mesh in
front of the volume hides it; a mesh inside it hides what lies behind the mesh only.

This example renders the hydrogen 3d_z² orbital (the demo data) with an opaque plane
through its middle and a small sphere in front of it, off screen (a script or a
notebook's static backend renders at full quality at once), and draws the transfer
function editor's picture: a log opacity axis with one focus range magnified four
times, over the data's log-count histogram.

Run::

    python3 examples/plot_interactive.py      # writes docs/images/scene_and_editor.png
"""
import os
import sys
from pathlib import Path

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pyvista as pv  # noqa: E402

try:
    ROOT = Path(__file__).resolve().parents[1]
except NameError:  # sphinx-gallery runs examples without __file__, in examples/
    ROOT = Path.cwd().resolve().parent
sys.path.insert(0, str(ROOT))

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.editor.model import TransferFunctionModel  # noqa: E402
from pv_hdrvol.viewer.notebook import editor_picture  # noqa: E402


# docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", ROOT / "docs" / "images"))


def main(out=OUT / "scene_and_editor.png"):
    grid = hv.datasets.hydrogen_orbital(size=96)
    volume = hv.volume_from_dataset(grid)
    tf = hv.datasets.demo_transfer_function()
    b = volume.bounds
    centre = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
    extent = b[1] - b[0]
    pictures = []
    for with_meshes in (False, True):
        pl = pv.Plotter(off_screen=True, window_size=(420, 420))
        pl.background_color = "black"
        if with_meshes:
            pl.add_mesh(pv.Plane(center=centre, direction=(1, 0, 0), i_size=extent, j_size=extent),
                        color="#3a6ea5", lighting=True)
            pl.add_mesh(pv.Sphere(radius=0.08 * extent, center=(centre[0] + 0.25 * extent, centre[1] - 0.3 * extent,
                                                               centre[2] + 0.1 * extent)), color="#c8c8c8")
        pl.hdrvol.add_volume(volume, tf, tonemap="reinhard")
        pl.camera_position = [(centre[0] + 2.2 * extent, centre[1] - 1.6 * extent, centre[2] + 0.9 * extent), centre,
                              (0, 0, 1)]
        pictures.append(pl.screenshot(return_img=True))
        pl.close()
    model = TransferFunctionModel(tf, volume.values)
    model.add_focus(0.55, 0.12, 4.0)
    curve = editor_picture(model, width=840, height=200)
    fig = plt.figure(figsize=(8.4, 6.4), dpi=100)
    grid = fig.add_gridspec(2, 2, height_ratios=[4.2, 2.0])
    for k, (picture, title) in enumerate(zip(pictures, ["the volume alone", "with a plane and a sphere"])):
        ax = fig.add_subplot(grid[0, k])
        ax.imshow(picture)
        ax.set_title(title, fontsize=10)
        ax.axis("off")
    ax = fig.add_subplot(grid[1, :])
    ax.imshow(curve)
    ax.set_title("the editor: log opacity axis, a focus magnified 4x (olive), log-count histogram, colour bar",
                 fontsize=9)
    ax.axis("off")
    fig.tight_layout()
    fig.savefig(out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
