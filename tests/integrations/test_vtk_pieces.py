"""HDRVolumeRenderer on pieces: each process (here a thread with its own pipeline and a
ThreadComm) reads only its extent of a .vti file, renders it, and piece 0 composites the
whole image. ParaView's processes do the same through tests/paraview/mpi_render.py."""
import numpy as np
import pytest
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonDataModel import vtkImageData
from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLImageDataWriter

import pv_hdrvol as hv
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer
from pv_hdrvol.integrations.vtk_pieces import piece_extent
from pv_hdrvol.raycast.grid import as_volume, resolve_transfer_function
from thread_comm import run_spmd

W, H = 40, 30
WHOLE = (-3, 26, 0, 22, 2, 19)  # an extent that does not start at 0, as files may have


@pytest.fixture(scope="module")
def vti(tmp_path_factory):
    z, y, x = np.mgrid[WHOLE[4]:WHOLE[5] + 1, WHOLE[2]:WHOLE[3] + 1, WHOLE[0]:WHOLE[1] + 1].astype(float)
    values = np.exp(-((x - 10) ** 2 + (y - 11) ** 2 + (z - 9) ** 2) / 30.0) \
        + 0.3 * np.random.default_rng(5).random(x.shape)
    image = vtkImageData()
    image.SetExtent(*WHOLE)
    image.SetSpacing(0.7, 0.9, 1.1)
    image.SetOrigin(2.0, -1.0, 0.5)
    array = numpy_to_vtk(values.reshape(-1), deep=True)
    array.SetName("density")
    image.GetPointData().SetScalars(array)
    path = str(tmp_path_factory.mktemp("pieces") / "volume.vti")
    writer = vtkXMLImageDataWriter()
    writer.SetInputData(image)
    writer.SetFileName(path)
    writer.Write()
    return path, image


def _run(path, n, tf, reader_class=vtkXMLImageDataReader, **options):
    """Render ``path`` (read by ``reader_class``) on ``n`` thread-processes; returns, per
    process, the output image (None where empty), the extent its reader read, and its
    error."""
    def process(comm):
        reader = reader_class()
        reader.SetFileName(path)
        renderer = HDRVolumeRenderer()
        renderer.SetInputConnection(reader.GetOutputPort())
        renderer.SetCommunicator(comm)
        renderer.SetImageSize(W, H)
        renderer.SetCamera("iso")
        if tf is not None:
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


@pytest.mark.parametrize("n, shade", [(2, False), (3, True)])
def test_each_process_reads_its_extent_and_piece_zero_holds_the_whole_render(vti, n, shade):
    path, image = vti
    tf = resolve_transfer_function(as_volume(image))
    results = _run(path, n, tf, Shade=shade)
    expected = hv.render(image, tf, "iso", (W, H), progress_bar=False, shade=shade)
    assert expected.rgba[..., 3].max() > 0.5
    got = results[0][0]
    np.testing.assert_allclose(got.rgba, expected.rgba, rtol=0, atol=1e-5)
    assert got.metadata["pieces"] == n
    assert all(r[0] is None and r[2] for r in results[1:])
    ghosts = 1 if shade else 0
    cells = np.prod(np.subtract(WHOLE[1::2], WHOLE[::2]))
    for rank, (_, extent, ok, error) in enumerate(results):
        assert ok and error is None
        # the reader read the extent translator's piece plus the ghost layer, nothing more
        assert extent == piece_extent(WHOLE, rank, n, ghosts), (rank, extent)
        assert np.prod(np.subtract(extent[1::2], extent[::2])) < 1.4 * cells / n


def test_without_a_transfer_function_piece_zero_reads_and_renders_everything(vti):
    """The default transfer function reads every value, so it is not made of pieces:
    piece 0 asks for the whole extent and renders alone; the others read nothing."""
    path, image = vti
    results = _run(path, 2, None)
    expected = hv.render(image, None, "iso", (W, H), progress_bar=False)
    np.testing.assert_array_equal(results[0][0].rgba, expected.rgba)
    assert results[0][1] == WHOLE and results[1][0] is None


def test_a_process_that_cannot_render_stops_every_process_with_the_reason(vti):
    path, image = vti
    tf = resolve_transfer_function(as_volume(image))
    results = _run(path, 2, tf, Scalars="no_such_array")
    errors = [r[3] for r in results]
    assert not any(r[2] for r in results)
    assert "no_such_array" in errors[0] and "no_such_array" in errors[1]


def test_set_communicator_refuses_what_is_not_one():
    with pytest.raises(TypeError, match="the communicator must have rank, size, gather, allgather, alltoall and "
                                        "bcast"):
        HDRVolumeRenderer().SetCommunicator(object())


@pytest.fixture(scope="module")
def vtr(tmp_path_factory):
    """A rectilinear grid graded 3x along x and 2x along y, on the same odd extent."""
    from vtkmodules.vtkCommonDataModel import vtkRectilinearGrid
    from vtkmodules.vtkIOXML import vtkXMLRectilinearGridWriter

    n = np.subtract(WHOLE[1::2], WHOLE[::2]) + 1
    axes = []
    for count, ratio in zip(n, (3.0, 2.0, 1.0)):
        s = np.linspace(-1.0, 1.0, count - 1)
        widths = 1.0 + (ratio - 1.0) * s * s
        axes.append(np.concatenate([[0.0], np.cumsum(widths)]) * 0.6)
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    values = np.exp(-((x - 9) ** 2 + (y - 10) ** 2 + (z - 6) ** 2) / 30.0) + 0.1 * np.sin(x)
    grid = vtkRectilinearGrid()
    grid.SetExtent(*WHOLE)
    for setter, a in zip((grid.SetXCoordinates, grid.SetYCoordinates, grid.SetZCoordinates), axes):
        setter(numpy_to_vtk(a, deep=True))
    array = numpy_to_vtk(values.reshape(-1), deep=True)
    array.SetName("density")
    grid.GetPointData().SetScalars(array)
    path = str(tmp_path_factory.mktemp("rect") / "volume.vtr")
    writer = vtkXMLRectilinearGridWriter()
    writer.SetInputData(grid)
    writer.SetFileName(path)
    writer.Write()
    return path, grid


@pytest.mark.parametrize("n, shade", [(2, False), (3, True)])
def test_a_rectilinear_grid_is_rendered_where_it_lives(vtr, n, shade):
    """Each process reads its extent of a .vtr and renders it on the whole grid's lattice
    (its rays, lookups, step and opacity unit in the whole grid's nominal frame): piece
    0's composite is the serial render to the early termination's 1e-6."""
    from vtkmodules.vtkIOXML import vtkXMLRectilinearGridReader

    path, grid = vtr
    tf = resolve_transfer_function(as_volume(grid))
    results = _run(path, n, tf, vtkXMLRectilinearGridReader, Precision="float64", Shade=shade)
    expected = hv.render(grid, tf, "iso", (W, H), progress_bar=False, precision="float64", shade=shade)
    assert expected.rgba[..., 3].max() > 0.5
    got = results[0][0]
    assert got.metadata["pieces"] == n
    np.testing.assert_allclose(got.rgba, expected.rgba, rtol=0, atol=2e-6)
    ghosts = 1 if shade else 0
    for rank, (_, extent, ok, error) in enumerate(results):
        assert ok and error is None
        assert extent == piece_extent(WHOLE, rank, n, ghosts), (rank, extent)
