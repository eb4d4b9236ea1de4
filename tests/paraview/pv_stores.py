"""Multiresolution stores in real ParaView (pvbatch): OpenDataFile of a ``*.ome.zarr``
directory gives one level (the reader's Level, Max Points), and HDR Volume Render of it
renders the whole store out of core: ``open_multiscale(...).render`` of the same camera
and colour map, bit for bit, with blocks finer than the level loaded.

ParaView's Python gets zarr from the site folder (``PV_HDRVOL_PARAVIEW_SITE``; .ci/run
installs it) and numpy.dtypes from the shim; the store is written here, in pvbatch.
Run by tests/paraview/run.py inside pvbatch (see there); not collected by the main suite.
"""
import importlib.util
import json
import os

import numpy as np
import pytest
from paraview import servermanager, simple

import pv_hdrvol as hv
from pv_render import _image, _set_color_map

SIZE = (48, 40)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    if importlib.util.find_spec("zarr") is None:
        message = "ParaView's Python has no zarr (docs/paraview.md; .ci/run installs it into .paraview-site)"
        if os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no"):
            pytest.fail(message + " (CI is set)", pytrace=False)
        pytest.skip(message)
    z, y, x = np.mgrid[0:70, 0:80, 0:90].astype(np.float64)
    values = (np.exp(-((x - 45) ** 2 + (y - 40) ** 2 + (z - 35) ** 2) / 500.0)
              + 0.3 * np.sin(x / 6.0) * np.cos(y / 7.0) ** 2).astype(np.float32)
    path = tmp_path_factory.mktemp("stores") / "blob.ome.zarr"
    hv.write_multiscale(values, path, spacing=(0.5, 0.75, 1.0), origin=(1.0, -2.0, 3.0), name="density",
                        progress_bar=False)
    return path


def test_open_data_file_gives_a_level_with_its_geometry(plugin, store):
    reader = simple.OpenDataFile(str(store))
    assert reader is not None and reader.GetXMLName() == "MultiscaleStoreReader"
    assert reader.Level == -1 and reader.MaxPoints == 64
    reader.UpdatePipeline()
    s = hv.MultiscaleStore(store)
    data = servermanager.Fetch(reader)
    assert data.GetDimensions() == s.levels[0].dims  # 504 000 points: level 0 within 64 Mi
    reader.Level = 1
    reader.UpdatePipeline()
    data = servermanager.Fetch(reader)
    spacing, origin = s.level_geometry(1)
    assert data.GetDimensions() == s.levels[1].dims
    np.testing.assert_allclose(data.GetSpacing(), spacing, rtol=1e-15)
    np.testing.assert_allclose(data.GetOrigin(), origin, rtol=1e-15)
    assert data.GetFieldData().GetAbstractArray("pv_hdrvol_store").GetValue(0) == str(store)
    np.testing.assert_allclose(reader.GetDataInformation().GetBounds(), [
        v for a in range(3) for v in (origin[a], origin[a] + (s.levels[1].dims[a] - 1) * spacing[a])])
    # the reader's FileName may name the store's zarr.json too (the folder is read)
    again = simple.OpenDataFile(str(store))
    again.FileName = str(store / "zarr.json")
    again.Level = 1
    again.UpdatePipeline()
    assert servermanager.Fetch(again).GetDimensions() == s.levels[1].dims
    again.Level = -1
    again.UpdatePipeline()
    assert servermanager.Fetch(again).GetDimensions() == s.levels[0].dims
    simple.Delete(again)
    simple.Delete(reader)


def test_hdr_volume_render_renders_the_store_out_of_core(plugin, store):
    reader = simple.OpenDataFile(str(store))
    reader.Level = 1
    reader.UpdatePipeline()
    lut, pwf, expected_tf = _set_color_map("density", 0.05, 1.2, log=False)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=list(SIZE), Camera="iso", LookupTable=lut,
                                       ScalarOpacityFunction=pwf)
    render.Scalars = ["POINTS", "density"]
    assert render.OutOfCore == 1 and render.ScreenError == 1.0 and render.CacheSize == 2048
    # the plugin marks a store's input: its out-of-core properties show in the panel
    assert render.InputIsStore == 1
    image = _image(render)

    volume = hv.open_multiscale(store)
    camera = hv.Camera.fit(volume.bounds, "iso")
    expected = volume.render(expected_tf, camera, SIZE)
    assert image.rgba[..., 3].max() > 0.2
    np.testing.assert_allclose(image.rgba, expected.rgba, rtol=1e-6, atol=1e-7)  # the colour map's rounding
    metadata = json.loads(servermanager.Fetch(render).GetFieldData().GetAbstractArray("hdrvol_metadata").GetValue(0))
    assert metadata["levels"][0] > 0, metadata["levels"]  # finer than the level loaded

    # Screen Error: the library's render with it
    render.ScreenError = 6.0
    image = _image(render)
    np.testing.assert_allclose(image.rgba, volume.render(expected_tf, camera, SIZE, screen_error=6.0).rgba,
                               rtol=1e-6, atol=1e-7)

    # Out Of Core off: the loaded level, in memory, as hv.render of it
    render.OutOfCore = 0
    image = _image(render)
    level = servermanager.Fetch(reader)
    in_memory = hv.render(level, expected_tf, hv.Camera.fit(level.GetBounds(), "iso"), SIZE, scalars="density",
                          progress_bar=False)  # "iso" frames the input's bounds
    np.testing.assert_allclose(image.rgba, in_memory.rgba, rtol=1e-6, atol=1e-7)
    assert np.abs(in_memory.rgba - expected.rgba).max() > 1e-3
    volume.close()
    simple.Delete(render)
    simple.Delete(reader)
