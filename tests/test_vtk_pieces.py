"""HDRVolumeRenderer on pieces: each process (here a thread with its own pipeline and a
ThreadComm) reads only its extent of a .vti file, renders it, and piece 0 composites the
whole image. ParaView's processes do the same through tests/paraview/mpi_render.py."""
import numpy as np
import pytest
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonDataModel import vtkImageData
from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLImageDataWriter

import pv_hdrvol as hv
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer, _piece_extent
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


def _run(path, n, tf, **options):
    """Render ``path`` on ``n`` thread-processes; returns, per process, the output image
    (None where empty), the extent its reader read, and its error."""
    def process(comm):
        reader = vtkXMLImageDataReader()
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
        assert extent == _piece_extent(WHOLE, rank, n, ghosts), (rank, extent)
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
