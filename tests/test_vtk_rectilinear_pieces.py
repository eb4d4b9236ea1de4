"""HDRVolumeRenderer on pieces of a rectilinear grid: each thread-process reads only its
extent of a .vtr file (graded axes), renders it in the whole grid's frame, and piece 0's
composite is the serial render of the whole grid. Pieces of a curvilinear grid become the
serial render's tetrahedra where they live (the mesh path, under MPI: mpi_render.py)."""
import numpy as np
import pytest
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonDataModel import vtkRectilinearGrid
from vtkmodules.vtkIOXML import vtkXMLRectilinearGridReader, vtkXMLRectilinearGridWriter

import pv_hdrvol as hv
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer, _piece_extent
from pv_hdrvol.raycast.grid import as_volume, resolve_transfer_function
from thread_comm import run_spmd

W, H = 40, 30
WHOLE = (2, 24, 0, 16, -4, 15)


def _grid(x, y, z):
    grid = vtkRectilinearGrid()
    grid.SetExtent(*WHOLE)
    for setter, c in zip((grid.SetXCoordinates, grid.SetYCoordinates, grid.SetZCoordinates), (x, y, z)):
        setter(numpy_to_vtk(np.asarray(c, dtype=np.float64), deep=True))
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    values = np.exp(-((xx - 2) ** 2 + yy ** 2 + (zz - 1) ** 2) / 2.0) + 0.3 * np.random.default_rng(3).random(xx.shape)
    array = numpy_to_vtk(values.reshape(-1), deep=True)
    array.SetName("density")
    grid.GetPointData().SetScalars(array)
    return grid


@pytest.fixture(scope="module")
def vtr(tmp_path_factory):
    x = np.cumsum(np.r_[0.0, 0.2 * 1.12 ** np.arange(22)]) - 1.0
    y = np.linspace(-1, 1, 17) ** 3 * 1.5 + np.linspace(-1, 1, 17)
    z = np.r_[np.linspace(0, 1, 8), 1 + np.geomspace(0.05, 1.5, 12)]
    out = {}
    for name, axes in (("graded", (x, y, z)), ("even", (np.linspace(-1, 3, 23), np.linspace(-2, 2, 17),
                                                          np.linspace(0, 2.5, 20)))):
        grid = _grid(*axes)
        path = str(tmp_path_factory.mktemp("rect") / f"{name}.vtr")
        writer = vtkXMLRectilinearGridWriter()
        writer.SetInputData(grid)
        writer.SetFileName(path)
        writer.Write()
        out[name] = (path, grid)
    return out


def _run(path, n, tf, **options):
    def process(comm):
        reader = vtkXMLRectilinearGridReader()
        reader.SetFileName(path)
        renderer = HDRVolumeRenderer()
        renderer.SetInputConnection(reader.GetOutputPort())
        renderer.SetCommunicator(comm)
        renderer.SetImageSize(W, H)
        renderer.SetCamera("iso")
        renderer.SetTransferFunction(tf)
        for name, value in options.items():
            getattr(renderer, "Set" + name)(value)
        ok = renderer.UpdatePiece(comm.rank, comm.size, 0)
        out = renderer.GetOutput()
        return (hv.HDRImage.from_pyvista(out) if out.GetNumberOfPoints() else None,
                reader.GetOutput().GetExtent(), ok, renderer.GetLastError())

    results, errors = run_spmd(n, process)
    assert errors == [None] * n, errors
    return results


@pytest.mark.parametrize("name, n, shade", [("graded", 2, False), ("graded", 3, True), ("even", 3, False)])
def test_each_process_reads_its_extent_of_a_rectilinear_grid_and_piece_zero_holds_the_whole_render(vtr, name, n,
                                                                                                   shade):
    path, grid = vtr[name]
    volume = as_volume(grid)
    assert (volume.axes is None) == (name == "even")  # an evenly spaced grid renders as its image
    tf = resolve_transfer_function(volume)
    results = _run(path, n, tf, Shade=shade)
    expected = hv.render(grid, tf, "iso", (W, H), progress_bar=False, shade=shade)
    assert expected.rgba[..., 3].max() > 0.5
    got = results[0][0]
    # float32 (the default precision), composited per piece: measured 6e-8 (float64: 8e-16)
    np.testing.assert_allclose(got.rgba, expected.rgba, rtol=0, atol=1e-5)
    assert got.metadata["pieces"] == n
    assert all(r[0] is None and r[2] and r[3] is None for r in results[1:])
    ghosts = 1 if shade else 0
    for rank, (_, extent, ok, error) in enumerate(results):
        assert extent == _piece_extent(WHOLE, rank, n, ghosts), (rank, extent)


# -- curvilinear grids: each process splits its extent into the serial render's tetrahedra --
def test_curvilinear_pieces_split_into_the_serial_tetrahedra():
    """A vtkStructuredGrid cut into extents at an odd index (the 5-tet split's parity is
    the global index's): the pieces' tetrahedra together are the serial split's, so
    their render equals the serial render of the whole grid (the mesh path then moves
    them to boxes: tests/paraview/mpi_render.py)."""
    import pyvista as pv
    from vtkmodules.vtkFiltersCore import vtkAppendFilter
    from vtkmodules.vtkFiltersExtraction import vtkExtractGrid

    from pv_hdrvol.integrations.vtk_algorithm import _tet_grid_of_structured

    r, th, z = np.linspace(1, 2, 9), np.linspace(0, 1.2, 11), np.linspace(0, 1, 7)
    rr, tt, zz = np.meshgrid(r, th, z, indexing="ij")
    grid = pv.StructuredGrid(rr * np.cos(tt), rr * np.sin(tt), zz + 0.1 * rr ** 2)
    grid["f"] = np.exp(-((grid.points[:, 0] - 1.2) ** 2 + (grid.points[:, 1] - 0.8) ** 2) / 0.3)
    nx, ny, nz = grid.dimensions
    append = vtkAppendFilter()
    total = 0
    for voi in ((0, 3, 0, ny - 1, 0, nz - 1), (3, nx - 1, 0, ny - 1, 0, nz - 1)):
        extract = vtkExtractGrid()
        extract.SetInputData(grid)
        extract.SetVOI(*voi)
        extract.Update()
        tets = _tet_grid_of_structured(extract.GetOutput())
        total += tets.GetNumberOfCells()
        append.AddInputData(tets)
    append.Update()
    assert total == _tet_grid_of_structured(grid).GetNumberOfCells()
    tf = hv.TransferFunction([0.0, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1]], [0.0, 0.9])
    expected = hv.render(grid, tf, "iso", (W, H), progress_bar=False, precision="float64")
    assert expected.rgba[..., 3].max() > 0.5
    got = hv.render(pv.wrap(append.GetOutput()), tf, "iso", (W, H), progress_bar=False, precision="float64")
    np.testing.assert_allclose(got.rgba, expected.rgba, rtol=0, atol=1e-12)
