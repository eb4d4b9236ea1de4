"""HDR Tone Map, HDR Upsample and the EXR/Radiance reader and writers in real ParaView
(pvbatch): each equals the Python API bit for bit.

Run by tests/paraview/run.py inside pvbatch (see there); not collected by the main suite.
"""
import importlib.util
import os

import numpy as np
import pytest
from paraview import servermanager, simple
from vtkmodules.util.numpy_support import vtk_to_numpy

import pv_hdrvol as hv
from pv_render import ENGINE, _reader


@pytest.fixture(scope="module")
def openexr():
    if importlib.util.find_spec("OpenEXR") is None:
        message = "ParaView's Python has no OpenEXR package (docs/paraview.md: pv-hdrvol paraview --openexr)"
        if os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no"):
            pytest.fail(message + " (CI is set)", pytrace=False)
        pytest.skip(message)


@pytest.fixture(scope="module")
def rendered(plugin, shared_data):
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[40, 32], Camera="iso",
                                       TransferFunction="pv_hdrvol default")
    render.Scalars = ["POINTS", array]
    render.UpdatePipeline()
    yield reader, render, hv.HDRImage.from_pyvista(servermanager.Fetch(render))
    simple.Delete(render)


def _flipped(rgb8):
    """(rows, cols, 3), row 0 at the top -> VTK's point order (row 0 at the bottom)."""
    return np.ascontiguousarray(rgb8[::-1]).reshape(-1, 3)


@pytest.mark.parametrize("operator, parameters, text", [
    ("drago", {"bias": 0.7}, "bias=0.7"),
    ("reinhard", {"key": 0.3, "local": True}, "key=0.3, local=true"),
    ("linear", {"exposure_stops": 1.5}, "exposure_stops=1.5"),
])
def test_tone_map_equals_python_api(plugin, rendered, operator, parameters, text):
    _, render, image = rendered
    tone = plugin["HDRToneMap"](Input=render, Operator=operator, Parameters=text)
    tone.UpdatePipeline()
    out = servermanager.Fetch(tone)
    got = vtk_to_numpy(out.GetPointData().GetArray("tonemapped"))
    expected = hv.tonemap(image, operator, **parameters).rgb8
    np.testing.assert_array_equal(got, _flipped(expected))
    simple.Delete(tone)


def test_tone_map_rejects_unknown_parameters(plugin, rendered):
    _, render, _ = rendered
    tone = plugin["HDRToneMap"](Input=render, Operator="drago", Parameters="key=0.2")
    tone.UpdatePipeline()
    assert "drago takes parameters" in tone.GetClientSideObject().GetLastError()
    simple.Delete(tone)


def test_exr_written_by_paraview_reads_back_bit_for_bit(plugin, rendered, openexr, tmp_path):
    _, render, image = rendered
    path = tmp_path / "frame.exr"
    simple.SaveData(str(path), proxy=render)
    back = hv.load(path)
    np.testing.assert_array_equal(back.rgba, image.rgba)
    np.testing.assert_array_equal(back.depth, image.depth.astype(np.float32))
    assert back.settings().camera == image.settings().camera
    # and ParaView opens it again as an image, with its channels as arrays
    reader = simple.OpenDataFile(str(path))
    assert reader.GetXMLName() == "HDRImageReader"
    reader.UpdatePipeline()
    again = hv.HDRImage.from_pyvista(servermanager.Fetch(reader))
    np.testing.assert_array_equal(again.rgba, image.rgba)
    simple.Delete(reader)


def test_radiance_written_by_paraview_equals_python(plugin, rendered, tmp_path):
    _, render, image = rendered
    simple.SaveData(str(tmp_path / "paraview.hdr"), proxy=render)
    image.save(tmp_path / "python.hdr")
    assert (tmp_path / "paraview.hdr").read_bytes() == (tmp_path / "python.hdr").read_bytes()


def test_upsample_equals_python_api(plugin, shared_data):
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[16, 12], Camera="iso",
                                       TransferFunction="pv_hdrvol default")
    render.Scalars = ["POINTS", array]
    up = plugin["HDRUpsample"](Input=render, Dataset=reader, Factor=2)
    up.UpdatePipeline()
    got = hv.HDRImage.from_pyvista(servermanager.Fetch(up))
    low = hv.HDRImage.from_pyvista(servermanager.Fetch(render))
    settings = low.settings()
    data = servermanager.Fetch(reader)
    layers = hv.depth_layers(data, settings.camera, (32, 24), scalars=array, tf=settings.tf,
                             options=settings.options)
    expected = hv.upsample(low, layers, 2)
    assert got.shape == (24, 32)
    np.testing.assert_array_equal(got.rgba, expected.rgba)
    simple.Delete(up)
    simple.Delete(render)
