"""
Every grid a simulation writes: rectilinear, curvilinear and multiblock
=======================================================================

``hv.render`` takes the datasets simulation codes and their readers produce, not only
uniform image data and tetrahedral meshes:

1. a rectilinear grid whose spacing varies 2x along two axes (as a CTH shock run
   writes it), sampled as the trilinear field of its own cells, no resampling;
2. the Blunt Fin, a curvilinear PLOT3D grid read with VTK's PLOT3D reader (a
   multiblock of one ``vtkStructuredGrid``), each hexahedron split into six
   tetrahedra for the exact tetrahedral ray caster;
3. a volume written as eight blocks (a ``.vtm`` of extent pieces) rendered as one
   scene, against the unsplit volume: the blocks are gathered onto their lattice, so
   the two images are equal bit for bit.

Run::

    python3 examples/plot_data_types.py      # writes docs/images/data_types.png
"""
import os
import tempfile
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


def graded_axis(n, lo, hi, ratio):
    """``n`` coordinates from ``lo`` to ``hi`` whose spacing grows by ``ratio`` from end to end."""
    widths = np.geomspace(1.0, ratio, n - 1)
    return lo + (hi - lo) * np.concatenate([[0.0], np.cumsum(widths)]) / widths.sum()


def shock():
    """A spherical shock front over ten decades of density on graded axes."""
    x = graded_axis(96, -1.0, 1.0, 2.0)
    y = graded_axis(80, -1.0, 1.0, 0.5)
    z = np.linspace(-0.8, 0.8, 64)
    grid = pv.RectilinearGrid(x, y, z)
    px, py, pz = grid.points.T
    r = np.sqrt(px**2 + 1.3 * py**2 + pz**2)
    grid["density"] = 1e-9 + np.exp(-((r - 0.6) / 0.04) ** 2) + 1e-3 * np.exp(-(r / 0.25) ** 2)
    return grid


def blunt_fin():
    from vtkmodules.vtkIOParallel import vtkMultiBlockPLOT3DReader

    folder = DATA / "unstructured" / "plot3d_original"
    reader = vtkMultiBlockPLOT3DReader()
    reader.SetXYZFileName(str(folder / "bluntfinxyz.bin"))
    reader.SetQFileName(str(folder / "bluntfinq.bin"))
    reader.SetAutoDetectFormat(1)
    reader.Update()
    return reader.GetOutput()  # a vtkMultiBlockDataSet of one curvilinear vtkStructuredGrid


def eight_blocks(folder):
    image = pv.ImageData(dimensions=(65, 65, 65), spacing=(1 / 64,) * 3)
    px, py, pz = image.points.T
    image["f"] = np.exp(-40 * ((px - 0.5) ** 2 + (py - 0.45) ** 2)) * (0.3 + pz) + 1e-6
    blocks = pv.MultiBlock()
    for k in (0, 32):
        for j in (0, 32):
            for i in (0, 32):
                blocks.append(image.extract_subset((i, i + 32, j, j + 32, k, k + 32)))
    blocks.save(Path(folder) / "eight.vtm")
    return image, pv.read(Path(folder) / "eight.vtm")


def main():
    fig, axes = plt.subplots(1, 4, figsize=(14, 4.0))
    grid = shock()
    # a log axis over eight decades, faint: the shell and the core's faint halo both show
    tf = hv.TransferFunction.ramp(1e-8, 1.0, scale="log", cmap="inferno", opacity=(0.0, 0.05))
    img = hv.render(grid, tf, "iso", SIZE, progress_bar=False)
    axes[0].imshow(img.tonemap("reinhard").rgb)
    axes[0].set_title(f"rectilinear {grid.dimensions}, spacing x2 along x and y\n"
                      f"{img.stats()['dynamic_range_decades']:.1f} decades", fontsize=8)
    fin = blunt_fin()
    img = hv.render(fin, None, "iso", SIZE, scalars="Density", progress_bar=False)
    axes[1].imshow(img.tonemap("reinhard").rgb)
    axes[1].set_title("Blunt Fin, PLOT3D (curvilinear 40x32x32)\n"
                      f"{img.metadata['blocks']['kind']}: 5 tets a hexahedron", fontsize=8)
    with tempfile.TemporaryDirectory() as folder:
        image, blocks = eight_blocks(folder)
        tf = hv.TransferFunction.ramp(0.0, 1.2, cmap="viridis", opacity=(0.0, 0.4))
        split = hv.render(blocks, tf, "iso", SIZE, precision="float64", progress_bar=False)
    whole = hv.render(image, tf, "iso", SIZE, precision="float64", progress_bar=False)
    axes[2].imshow(split.tonemap("reinhard").rgb)
    axes[2].set_title(f"8 blocks of a .vtm as one scene\n({split.metadata['blocks']['kind']})", fontsize=8)
    diff = np.abs(split.rgba - whole.rgba).max(axis=-1)
    im = axes[3].imshow(diff, cmap="magma", vmin=0.0, vmax=max(float(diff.max()), 1e-12))
    axes[3].set_title(f"|8 blocks - unsplit| (max {diff.max():.1e})", fontsize=8)
    fig.colorbar(im, ax=axes[3], fraction=0.046)
    for ax in axes:
        ax.set_axis_off()
    fig.tight_layout()
    OUT.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT / "data_types.png", dpi=90)
    print(f"wrote {OUT / 'data_types.png'}")


main()
