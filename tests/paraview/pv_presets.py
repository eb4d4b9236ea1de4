"""Transfer functions move between ParaView and pv_hdrvol: ParaView imports a preset
file written by the editor and its colour and opacity functions equal ours; a
ParaView built-in preset read here evaluates as ParaView's own lookup (to the stated
sampling tolerance).

Run by tests/paraview/run.py inside pvbatch (see there); not collected by the main suite.
"""
import numpy as np
import pytest
from paraview import simple

import pv_hdrvol as hv
from pv_hdrvol.editor import presets as P
from pv_hdrvol.editor.model import TransferFunctionModel


def _colors(ctf, values):
    out = np.empty((len(values), 3))
    for row, x in zip(out, values):
        rgb = [0.0, 0.0, 0.0]
        ctf.GetColor(float(x), rgb)
        row[:] = rgb
    return out


def _space(lut):
    return str(lut.GetProperty("ColorSpace").GetData())


def _paraview_functions(name):
    lut = simple.GetColorTransferFunction(f"pv_hdrvol_{name}")
    pwf = simple.GetOpacityTransferFunction(f"pv_hdrvol_{name}")
    assert lut.ApplyPreset(name, False) and pwf.ApplyPreset(name, False)
    lut.Discretize = 0  # evaluate the function itself, not its 256-colour table
    lut.UpdateVTKObjects()
    return lut, pwf


def test_paraview_imports_an_exported_linear_function_exactly(tmp_path):
    model = TransferFunctionModel(hv.TransferFunction.ramp(-2.0, 7.0, cmap="viridis", opacity=(0.0, 0.1, 0.6)))
    model.add_opacity_point(1.5, 0.9)
    model.set_color_space("hsv")
    path = tmp_path / "exported.json"
    model.save_paraview_preset(path, "pv_hdrvol exact")
    simple.ImportPresets(str(path))
    lut, pwf = _paraview_functions("pv_hdrvol exact")
    preset = P.read_paraview_presets(path)[0]
    np.testing.assert_array_equal(np.asarray(lut.RGBPoints), preset["RGBPoints"])
    np.testing.assert_array_equal(np.asarray(pwf.Points), preset["Points"])
    assert _space(lut) == "HSV"
    # ParaView's evaluation equals ours
    tf = model.transfer_function()
    ctf, opacity = lut.GetClientSideObject(), pwf.GetClientSideObject()
    v = np.linspace(-2.0, 7.0, 2001)
    np.testing.assert_allclose(_colors(ctf, v), tf.color_at(v), rtol=0, atol=1e-6)
    np.testing.assert_allclose([opacity.GetValue(x) for x in v], tf.opacity_at(v), rtol=0, atol=1e-12)


def test_paraview_reads_an_exported_log_function_within_the_tolerance(tmp_path):
    tf = hv.TransferFunction.ramp(1e-3, 1e13, scale="log", cmap="magma", opacity=(0.0, 1e-4, 0.5))
    path = tmp_path / "log.json"
    TransferFunctionModel(tf).save_paraview_preset(path, "pv_hdrvol log")
    simple.ImportPresets(str(path))
    lut, pwf = _paraview_functions("pv_hdrvol log")
    ctf, opacity = lut.GetClientSideObject(), pwf.GetClientSideObject()
    v = np.geomspace(1e-3, 1e13, 4001)
    written = max(tf.colors.max(), 1.0)  # colours above 1 are written divided by the brightest
    assert np.max(np.abs(_colors(ctf, v) - tf.color_at(v) / written)) <= P.EXPORT_TOLERANCE
    assert np.max(np.abs(np.array([opacity.GetValue(x) for x in v]) - tf.opacity_at(v))) <= P.EXPORT_TOLERANCE


@pytest.mark.parametrize("name", ["Cool to Warm", "Blue Orange (divergent)", "Black-Body Radiation", "Rainbow Uniform"])
def test_builtin_presets_read_here_match_paraview(name, tmp_path):
    lut, pwf = _paraview_functions(name)
    points = np.asarray(lut.RGBPoints, dtype=np.float64)
    preset = {"Name": name, "ColorSpace": _space(lut), "RGBPoints": points.tolist(),
              "Points": np.asarray(pwf.Points, dtype=np.float64).tolist()}
    tf = TransferFunctionModel.from_paraview_preset(preset).transfer_function()
    ctf = lut.GetClientSideObject()
    v = np.linspace(points[0], points[-4], 3001)
    np.testing.assert_allclose(tf.color_at(v), _colors(ctf, v), rtol=0, atol=2e-4)
