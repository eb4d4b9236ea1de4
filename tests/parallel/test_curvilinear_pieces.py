"""Pieces of a curvilinear grid become the serial render's tetrahedra where they live
(HDRVolumeRenderer's mesh path then moves them to boxes: tests/paraview/mpi_render.py).
Here, without MPI: extents cut at an odd index give together the whole grid's tets."""
import numpy as np

import pv_hdrvol as hv

W, H = 40, 30


# -- curvilinear grids: each process splits its extent into the serial render's tetrahedra --
def test_curvilinear_pieces_split_into_the_serial_tetrahedra():
    """A vtkStructuredGrid cut into extents at an odd index (the 5-tet split's parity is
    the global index's): the pieces' tetrahedra together are the serial split's, so
    their render equals the serial render of the whole grid (the mesh path then moves
    them to boxes: tests/paraview/mpi_render.py)."""
    import pyvista as pv
    from vtkmodules.vtkFiltersCore import vtkAppendFilter
    from vtkmodules.vtkFiltersExtraction import vtkExtractGrid

    from pv_hdrvol.integrations.vtk_pieces import tet_grid_of_structured

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
        tets = tet_grid_of_structured(extract.GetOutput())
        total += tets.GetNumberOfCells()
        append.AddInputData(tets)
    append.Update()
    assert total == tet_grid_of_structured(grid).GetNumberOfCells()
    tf = hv.TransferFunction([0.0, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1]], [0.0, 0.9])
    expected = hv.render(grid, tf, "iso", (W, H), progress_bar=False, precision="float64")
    assert expected.rgba[..., 3].max() > 0.5
    got = hv.render(pv.wrap(append.GetOutput()), tf, "iso", (W, H), progress_bar=False, precision="float64")
    np.testing.assert_allclose(got.rgba, expected.rgba, rtol=0, atol=1e-12)


def test_ghost_cells_of_a_curvilinear_piece_are_left_to_their_owner():
    """A piece read with a ghost level marks its neighbours' cells DUPLICATECELL: they
    make no tetrahedra here (their owner renders them), so nothing is counted twice."""
    import pyvista as pv
    from vtkmodules.util.numpy_support import numpy_to_vtk

    from pv_hdrvol.integrations.vtk_pieces import tet_grid_of_structured

    x, y, z = np.meshgrid(np.linspace(0, 1, 6), np.linspace(0, 1, 5), np.linspace(0, 1, 4), indexing="ij")
    grid = pv.StructuredGrid(x + 0.1 * y, y, z)
    grid["f"] = np.arange(grid.n_points, dtype=float)
    whole = tet_grid_of_structured(grid).GetNumberOfCells()
    ghost = np.zeros(grid.n_cells, dtype=np.uint8)
    ghost[:8] = 1  # DUPLICATECELL
    array = numpy_to_vtk(ghost, deep=True)
    array.SetName("vtkGhostType")
    grid.GetCellData().AddArray(array)
    assert tet_grid_of_structured(grid).GetNumberOfCells() == whole - 8 * 5
