"""MultiscaleReader and HDRVolumeRenderer on multiresolution stores, in plain VTK: the
reader outputs one level with its world geometry and names the store; the renderer
renders the store out of core (equal to open_multiscale(...).render bit for bit, with
finer levels than the reader's), and the level in memory when told to or when the data
changed on its way."""
import doctest
import json

import numpy as np
import pytest

pytest.importorskip("zarr")

from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.vtkImagingCore import vtkImageShiftScale  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.integrations import vtk_multiscale  # noqa: E402
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer  # noqa: E402
from pv_hdrvol.integrations.vtk_multiscale import MultiscaleReader, default_level, store_of  # noqa: E402
from vtk_capture import CapturedErrors  # noqa: E402

SPACING, ORIGIN = (0.5, 0.75, 1.0), (1.0, -2.0, 3.0)
SIZE = (48, 40)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    z, y, x = np.mgrid[0:70, 0:80, 0:90].astype(np.float64)
    values = (np.exp(-((x - 45) ** 2 + (y - 40) ** 2 + (z - 35) ** 2) / 500.0)
              + 0.3 * np.sin(x / 6.0) * np.cos(y / 7.0) ** 2).astype(np.float32)
    path = tmp_path_factory.mktemp("stores") / "blob.ome.zarr"
    hv.write_multiscale(values, path, spacing=SPACING, origin=ORIGIN, name="density", progress_bar=False)
    return path, values


def _reader(path, **settings):
    reader = MultiscaleReader()
    reader.SetFileName(path)
    for name, value in settings.items():
        getattr(reader, f"Set{name}")(value)
    assert reader.Update()
    return reader


def _rgba(algorithm):
    out = algorithm.GetOutput()
    cols, rows, _ = out.GetDimensions()
    return vtk_to_numpy(out.GetPointData().GetArray("rgba")).reshape(rows, cols, 4)[::-1]


def test_reader_outputs_a_level_with_its_geometry_and_names_the_store(store):
    path, values = store
    s = hv.MultiscaleStore(path)
    assert s.n_levels == 2 and s.levels[1].shape == (35, 40, 45)
    for level in range(s.n_levels):
        reader = _reader(path, Level=level)
        out = reader.GetOutput()
        spacing, origin = s.level_geometry(level)
        assert out.GetDimensions() == s.levels[level].dims
        np.testing.assert_allclose(out.GetSpacing(), spacing, rtol=1e-15)
        np.testing.assert_allclose(out.GetOrigin(), origin, rtol=1e-15)
        got = vtk_to_numpy(out.GetPointData().GetArray("density")).reshape(s.levels[level].shape)
        np.testing.assert_array_equal(got, s.read_level(level))
        assert out.GetPointData().GetScalars().GetName() == "density"
        assert store_of(out) == (str(path), level, "density")
    np.testing.assert_array_equal(s.read_level(0), values)
    # level 1's point j lies at level-0 voxel 2j + 1/2
    np.testing.assert_allclose(s.level_geometry(1)[1], np.add(ORIGIN, 0.5 * np.array(SPACING)))


def test_default_level_is_the_finest_within_the_point_limit(store):
    path, _ = store
    s = hv.MultiscaleStore(path)
    n0, n1 = 70 * 80 * 90, 35 * 40 * 45
    assert default_level(s) == 0  # 504 000 points: well within 64 Mi
    assert [default_level(s, n) for n in (n0, n0 - 1, n1, n1 - 1, 1)] == [0, 1, 1, 1, 1]
    reader = _reader(path, MaxPoints=n0 - 1)
    assert reader.GetLevel() is None and reader.GetLevelRead() == 1
    assert reader.GetOutput().GetDimensions() == (45, 40, 35)
    # zarr.json names the store too (what a file dialog picks inside the folder)
    reader = _reader(path / "zarr.json", Level=1)
    assert reader.GetFileName() == str(path) and store_of(reader.GetOutput())[0] == str(path)


def test_reader_refuses_what_is_not_a_store(store, tmp_path):
    path, _ = store
    reader = MultiscaleReader()
    assert reader.CanReadFile(str(path)) == 1 and reader.CanReadFile(str(tmp_path)) == 0
    reader.SetFileName(tmp_path / "none.ome.zarr")
    with CapturedErrors():
        assert not reader.Update()
    assert "no multiresolution store at" in reader.GetLastError()
    reader = MultiscaleReader()
    reader.SetFileName(path)
    reader.SetLevel(5)
    with CapturedErrors():
        assert not reader.Update()
    assert reader.GetLastError() == f"ValueError: level must be 0 to 1 for {path}; got 5"
    with pytest.raises(TypeError, match="level must be an integer"):
        reader.SetLevel(1.5)


def test_renderer_renders_the_store_out_of_core(store):
    """The reader's coarse level in, the store rendered: open_multiscale(...).render's
    image bit for bit, with blocks at level 0 (finer than the level read)."""
    path, _ = store
    reader = _reader(path, Level=1)
    tf = hv.TransferFunction([0.0, 0.6, 1.3], [[0.1, 0.0, 0.3], [1.0, 0.5, 0.0], [1.0, 1.0, 1.0]],
                             [0.0, 0.3, 0.9])
    renderer = HDRVolumeRenderer()
    renderer.SetInputConnection(reader.GetOutputPort())
    renderer.SetImageSize(*SIZE)
    renderer.SetCamera("iso")
    renderer.SetTransferFunction(tf)
    assert renderer.GetOutOfCore() and renderer.GetScreenError() == 1.0
    assert renderer.Update()
    volume = hv.open_multiscale(path)
    camera = hv.Camera.fit(volume.bounds, "iso")
    expected = volume.render(tf, camera, SIZE)
    got = _rgba(renderer)
    assert got[..., 3].max() > 0.5
    np.testing.assert_array_equal(got, expected.rgba)
    metadata = json.loads(renderer.GetOutput().GetFieldData().GetAbstractArray("hdrvol_metadata").GetValue(0))
    assert metadata["levels"][0] > 0, metadata["levels"]  # blocks finer than the reader's level 1
    assert renderer.GetLastCamera() == camera

    # a coarser screen error: the same as the library's, coarser blocks
    renderer.SetScreenError(8.0)
    assert renderer.Update()
    np.testing.assert_array_equal(_rgba(renderer), volume.render(tf, camera, SIZE, screen_error=8.0).rgba)
    renderer.SetScreenError(1.0)

    # the store is opened once: a new camera reuses its volume (and its chunk cache)
    kept = renderer._state.stores[str(path)]
    renderer.SetCamera("xy")
    assert renderer.Update()
    assert renderer._state.stores[str(path)] is kept
    np.testing.assert_array_equal(_rgba(renderer), volume.render(tf, hv.Camera.fit(volume.bounds, "xy"), SIZE).rgba)
    volume.close()


def test_renderer_default_transfer_function_and_lookup_table(store):
    """The transfer functions the filter takes today apply out of core: the default one
    (the store's, shaped by cmap=) and a VTK lookup table with an opacity function."""
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    path, _ = store
    reader = _reader(path, Level=1)
    renderer = HDRVolumeRenderer()
    renderer.SetInputConnection(reader.GetOutputPort())
    renderer.SetImageSize(*SIZE)
    renderer.SetCamera("iso")
    renderer.SetCmap("viridis")
    assert renderer.Update()
    volume = hv.open_multiscale(path)
    camera = hv.Camera.fit(volume.bounds, "iso")
    np.testing.assert_array_equal(_rgba(renderer), volume.render(None, camera, SIZE, cmap="viridis").rgba)

    renderer.SetCmap(None)
    ctf = vtkColorTransferFunction()
    for x, r, g, b in ((0.0, 0.0, 0.0, 0.5), (0.7, 1.0, 0.3, 0.0), (1.3, 1.0, 1.0, 1.0)):
        ctf.AddRGBPoint(x, r, g, b)
    pwf = vtkPiecewiseFunction()
    pwf.AddPoint(0.0, 0.0)
    pwf.AddPoint(1.3, 0.8)
    renderer.SetLookupTable(ctf)
    renderer.SetScalarOpacityFunction(pwf)
    assert renderer.Update()
    expected = volume.render(transfer_function_from_vtk(ctf, pwf), camera, SIZE)
    np.testing.assert_array_equal(_rgba(renderer), expected.rgba)
    volume.close()


def test_renderer_renders_the_level_in_memory_when_told_or_when_the_data_changed(store):
    path, _ = store
    reader = _reader(path, Level=1)
    tf = hv.TransferFunction([0.0, 1.3], [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]], [0.0, 0.8])
    renderer = HDRVolumeRenderer()
    renderer.SetInputConnection(reader.GetOutputPort())
    renderer.SetImageSize(*SIZE)
    renderer.SetCamera(hv.Camera.fit(hv.MultiscaleStore(path).bounds, "iso"))
    renderer.SetTransferFunction(tf)
    renderer.SetOutOfCore(False)
    assert renderer.Update()
    in_memory = hv.render(reader.GetOutput(), tf, renderer.GetCamera(), SIZE, progress_bar=False)
    np.testing.assert_array_equal(_rgba(renderer), in_memory.rgba)
    renderer.SetOutOfCore(True)
    assert renderer.Update()
    assert np.abs(_rgba(renderer) - in_memory.rgba).max() > 1e-3  # the store's finer levels show

    # values changed on their way (scaled): the field data passes, the render is of the data
    scaled = vtkImageShiftScale()
    scaled.SetInputConnection(reader.GetOutputPort())
    scaled.SetScale(0.5)
    scaled.SetOutputScalarTypeToFloat()
    scaled.Update()
    renderer.SetInputConnection(scaled.GetOutputPort())
    assert renderer.Update()
    expected = hv.render(scaled.GetOutput(), tf, renderer.GetCamera(), SIZE, progress_bar=False)
    # the field data passed, with the array's name and the level's geometry: new values though
    assert scaled.GetOutput().GetFieldData().GetAbstractArray("pv_hdrvol_store") is not None
    assert store_of(scaled.GetOutput()) is None
    np.testing.assert_array_equal(_rgba(renderer), expected.rgba)


def test_out_of_core_refusals_are_clear(store):
    path, _ = store
    reader = _reader(path, Level=1)
    renderer = HDRVolumeRenderer()
    renderer.SetInputConnection(reader.GetOutputPort())
    renderer.SetImageSize(8, 8)
    renderer.SetShade(True)
    with CapturedErrors():
        assert not renderer.Update()
    assert "shade=True is not supported for it yet" in renderer.GetLastError()
    with pytest.raises(ValueError, match="screen_error must be > 0"):
        renderer.SetScreenError(0.0)


def test_docstring_example_runs():
    result = doctest.testmod(vtk_multiscale)
    assert result.attempted > 0 and result.failed == 0
