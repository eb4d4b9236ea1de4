"""The transfer-function editor's model without a display (HDR VolVis section 5;
methods.md C.1.1-C.1.4, T-HDR-2 to T-HDR-4): the merged function equals what was
edited, edits change only what they should, display toggles never change the
function, undo, JSON and ParaView preset round trips, the histogram, clear errors."""
import json

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.editor import presets as P
from pv_hdrvol.editor.model import (GLOBAL_ALPHA_DECADES, UNDO_DEPTH, TransferFunctionModel, paraview_preset,
                                    global_alpha_from_slider, slider_from_global_alpha)

pytestmark = pytest.mark.core


def _log_tf():
    return hv.TransferFunction.ramp(1e-3, 1e13, scale="log", cmap="gray", opacity=(0.0, 1e-7, 0.5), n_colors=65)


def _grid(tf, n=20001):
    a0, a1 = tf.axis_range
    from pv_hdrvol.data.transfer import scale_inverse
    v = scale_inverse(np.linspace(a0, a1, n), tf.scale, tf.linthresh)
    v[0], v[-1] = tf.vmin, tf.vmax
    return v


def _same_function(a, b, atol=1e-12):
    v = _grid(a)
    np.testing.assert_allclose(b.color_at(v), a.color_at(v), rtol=0, atol=atol * max(1.0, a.colors.max()))
    np.testing.assert_allclose(b.opacity_at(v), a.opacity_at(v), rtol=0, atol=atol)


@pytest.mark.parametrize("color_space", ["rgb", "hsv"])
def test_the_model_keeps_the_function_it_was_given(color_space):
    """16 decades, an opacity of 1e-7 on a log axis: the merged function is the given one
    to 1e-12 (interior points on a straight line are dropped: 3 opacity points stay of 65)."""
    base = _log_tf()
    tf = hv.TransferFunction(base.values, base.colors * 5.0, base.opacities, scale="log", color_space=color_space)
    model = TransferFunctionModel(tf)
    _same_function(tf, model.transfer_function())
    assert model.transfer_function().table_size == 65536  # full resolution, fixed for every edit
    explicit = TransferFunctionModel(hv.TransferFunction(base.values, base.colors, base.opacities, scale="log",
                                                         table_size=4096))
    explicit.add_opacity_point(1.0, 0.5)
    assert explicit.transfer_function().table_size == 4096
    assert model.opacity_points[0].size == 3  # 0 -> 1e-7 -> 0.5 in two straight pieces
    assert model.color_points[0].size == (2 if color_space == "rgb" else tf.values.size)


def test_an_opacity_edit_changes_the_opacity_between_its_neighbours_only():
    model = TransferFunctionModel(hv.TransferFunction.ramp(0.0, 10.0, cmap="viridis", opacity=(0.0, 0.4)))
    before = model.transfer_function()
    model.add_opacity_point(2.0, 0.3)
    model.add_opacity_point(6.0, 0.05)
    after = model.transfer_function()
    v = np.linspace(0.0, 10.0, 10001)
    # colour untouched (re-interpolated at the new opacity points: to rounding)
    np.testing.assert_allclose(after.color_at(v), before.color_at(v), rtol=0, atol=1e-15)
    middle = model.transfer_function()
    model.move_opacity_point(2, opacity=1e-6)  # the point at 6.0: neighbours 2.0 and 10.0
    changed = np.abs(model.transfer_function().opacity_at(v) - middle.opacity_at(v)) > 0
    assert changed.any() and v[changed].min() > 2.0 and v[changed].max() < 10.0
    assert float(model.transfer_function().opacity_at(6.0)) == 1e-6


def test_a_colour_edit_leaves_the_opacity_alone():
    model = TransferFunctionModel(hv.TransferFunction.ramp(1.0, 1e6, scale="log", cmap="gray", opacity=(0, 0.2)))
    before = model.transfer_function()
    i = model.add_color_point(1e3)
    v = _grid(before)
    np.testing.assert_allclose(model.transfer_function().color_at(v), before.color_at(v), rtol=0, atol=1e-15)
    model.move_color_point(i, color=(4.0, 0.0, 0.0))  # HDR emission above 1
    model.move_color_point(i, value=1e2)
    model.move_color_point(i, intensity=8.0)
    # (re-interpolated at the colour points: to rounding)
    np.testing.assert_allclose(model.transfer_function().opacity_at(v), before.opacity_at(v), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(model.transfer_function().color_at([1e2])[0], [8.0, 0.0, 0.0])


def test_display_toggles_never_change_the_function():
    model = TransferFunctionModel(_log_tf())
    tf, state = model.transfer_function(), json.dumps(model.to_dict()["color_points"])
    seen = []
    model.observe(seen.append)
    model.add_focus(0.4, 0.1, 6.0)
    model.set_display(magnified=False, opacity_scale="linear", color_scale="log", floor=1e-8)
    model.set_display(magnified=True, opacity_scale="log")
    model.move_focus(0, centre=0.6)
    assert model.transfer_function() is tf  # the same object: no rebuild, no new table
    assert json.dumps(model.to_dict()["color_points"]) == state
    assert seen == ["display"] * 4 and not model.can_undo


def test_undo_redo_and_gestures():
    model = TransferFunctionModel(hv.TransferFunction.ramp(0.0, 1.0, cmap="gray"))
    states = [model.to_dict()]
    model.add_opacity_point(0.5, 0.1)
    states.append(model.to_dict())
    with model.gesture():  # a drag: one undo step
        for a in np.linspace(0.1, 0.9, 17):
            model.move_opacity_point(1, value=0.3 + 0.2 * a, opacity=a)
    states.append(model.to_dict())
    model.set_global_alpha(0.05)
    states.append(model.to_dict())
    for expected in reversed(states[:-1]):
        assert model.undo()
        assert model.to_dict() == expected
    assert not model.undo()
    assert model.redo() and model.to_dict() == states[1]
    model.set_color_space("hsv")  # a new edit forgets what was undone
    assert not model.can_redo
    for _ in range(UNDO_DEPTH + 5):
        model.set_global_alpha(0.5 if model.global_alpha != 0.5 else 0.25)
    assert len(model._undo) == UNDO_DEPTH


def test_a_rejected_edit_changes_nothing():
    model = TransferFunctionModel(hv.TransferFunction.ramp(1.0, 100.0, scale="log", cmap="gray"))
    before = model.to_dict()
    with pytest.raises(ValueError, match=r"value must lie inside the function's range \(1, 100\); got 0.5"):
        model.add_opacity_point(0.5, 0.2)
    with pytest.raises(ValueError, match="the end points of the opacity function keep their values"):
        model.move_opacity_point(0, value=2.0)
    with pytest.raises(ValueError, match="the end points of the colour function cannot be removed; got index 1"):
        model.remove_color_point(1)
    with pytest.raises(ValueError, match=r"color must be three finite values >= 0 \(linear RGB\); got \(1, -1, 0\)"):
        model.add_color_point(10.0, (1, -1, 0))
    with pytest.raises(ValueError, match="opacity must be"):
        model.add_opacity_point(10.0, 1.5)
    with pytest.raises(ValueError, match=r"scale='log' needs vmin > 0; got vmin=0.0"):
        model.set_range(0.0, 10.0)
    i = model.add_opacity_point(10.0, 0.5)
    model.add_opacity_point(50.0, 0.5)
    with pytest.raises(ValueError, match=r"point 1 must stay between its neighbours \(1, 50\); got 60.0"):
        model.move_opacity_point(i, value=60.0)
    model.undo()
    model.undo()
    assert model.to_dict() == before
    with pytest.raises(TypeError, match="a TransferFunctionFamily is edited through its bases"):
        TransferFunctionModel(hv.TransferFunction.family([hv.TransferFunction.ramp(0, 1)]))


def test_screen_positions_round_trip_through_a_magnified_log_axis():
    """T-HDR-2 through the model: data -> screen -> data to 1e-12 (relative) on a
    16-decade log axis with two foci; picking a point where it is drawn finds it."""
    model = TransferFunctionModel(_log_tf())
    model.add_focus(0.2, 0.05, 8.0)
    model.add_focus(0.7, 0.1, 3.0)
    v = np.geomspace(1e-3, 1e13, 100_001)
    sx = model.screen_x(v)
    assert np.all(np.diff(sx) > 0)
    np.testing.assert_allclose(model.value_at(sx), v, rtol=1e-12)
    values, opacities = model.opacity_points
    i = 1  # the 1e-7 point: at the bottom of a linear axis, a sixth up the log one
    sy = float(model.opacity_axis.forward(opacities[i]))
    assert sy == pytest.approx((np.log10(1e-7) + 6) / 6 if opacities[i] >= 1e-6 else 0.0)
    assert model.pick_opacity_point(float(model.screen_x(values[i])), sy) == i
    assert model.pick_opacity_point(0.5, 0.5, radius=0.01) is None


def test_focus_overlap_merges_and_magnification_is_capped():
    model = TransferFunctionModel(hv.TransferFunction.ramp(0.0, 1.0))
    model.add_focus(0.3, 0.1, 2.0)
    model.add_focus(0.36, 0.1, 3.0)  # overlaps the first: one focus, the larger magnification
    (f,) = model.axis.foci
    assert f.magnification == 3.0 and f.knots[1] == pytest.approx(0.25) and f.knots[2] == pytest.approx(0.41)
    model.add_focus(0.8, 0.2, 50.0)  # the screen cannot hold that: lowered to fill 99 %
    w = model.axis._w
    m = np.array([g.magnification for g in model.axis.foci])
    assert float(m @ w) == pytest.approx(0.99)
    assert model.axis.forward(1.0) == pytest.approx(1.0, abs=1e-15)


def test_hsv_interpolation():
    """T-HDR-4: red to blue through magenta (the short arc), a constant hue stays constant,
    colours stay in gamut."""
    model = TransferFunctionModel(hv.TransferFunction([0.0, 1.0], [[1, 0, 0], [0, 0, 1]], [0.5, 0.5]))
    model.set_color_space("hsv")
    tf = model.transfer_function()
    np.testing.assert_allclose(tf.color_at([0.5])[0], [1.0, 0.0, 1.0], atol=1e-12)
    rgb = tf.color_at(np.linspace(0, 1, 1001))
    assert rgb.min() >= 0.0 and rgb.max() <= 1.0 + 1e-12
    model.move_color_point(1, color=(0.2, 0.0, 0.0))  # dark red: same hue as the start
    from pv_hdrvol.data.transfer import _rgb_to_hsv
    hue = _rgb_to_hsv(model.transfer_function().color_at(np.linspace(0, 1, 101)))[:, 0]
    np.testing.assert_allclose(hue, 0.0, atol=1e-12)


def test_json_round_trip_is_exact(tmp_path):
    model = TransferFunctionModel(_log_tf(), global_alpha=0.05)
    model.add_opacity_point(1e4, 3e-5)
    model.add_color_point(1e9, (2.5, 1.0, 0.0))
    model.add_focus(0.5, 0.1)
    model.set_display(opacity_scale="log", floor=1e-9)
    model.save(tmp_path / "tf.json")
    back = TransferFunctionModel.load(tmp_path / "tf.json")
    assert back.to_dict() == model.to_dict()
    a, b = model.transfer_function(), back.transfer_function()
    for x, y in zip(a.table(np.float64, 0.05), b.table(np.float64, 0.05)):
        np.testing.assert_array_equal(x, y)
    plain = TransferFunctionModel.from_dict(json.loads(json.dumps(a.to_dict())))  # a plain function's JSON
    _same_function(a, plain.transfer_function())
    with pytest.raises(ValueError, match="unknown editor file version 7; this version reads 1"):
        TransferFunctionModel.from_dict({**model.to_dict(), "version": 7})


def test_the_histogram_bins_the_finite_data_along_the_axis():
    rng = np.random.default_rng(3)
    data = np.concatenate([10 ** rng.uniform(-5, 14, 50_000), [0.0, -1.0, np.nan, np.inf]])
    model = TransferFunctionModel(_log_tf(), data, bins=64)
    edges, counts, below, above = model.histogram()
    x = (np.log10(data[np.isfinite(data) & (data > 0)]) + 3) / 16
    expected, _ = np.histogram(x[(x >= 0) & (x <= 1)], bins=64, range=(0, 1))
    np.testing.assert_array_equal(counts, expected)
    assert below == int(np.sum(x < 0)) + 2 and above == int(np.sum(x > 1))  # 0 and -1 lie below a log axis
    model.set_range(1.0, 1e10)
    assert model.histogram()[1].sum() == int(np.sum((data >= 1) & (data <= 1e10)))


def test_global_alpha_log_slider():
    assert global_alpha_from_slider(1.0) == 1.0
    assert global_alpha_from_slider(0.0) == pytest.approx(10.0 ** -GLOBAL_ALPHA_DECADES)
    for a in (0.5, 0.05, 0.005):  # the paper's Fig. 3 settings
        assert global_alpha_from_slider(slider_from_global_alpha(a)) == pytest.approx(a, rel=1e-14)
    model = TransferFunctionModel(hv.TransferFunction.ramp(0, 1))
    tf = model.transfer_function()
    model.set_global_alpha(0.005)
    assert model.transfer_function() is tf and model.global_alpha == 0.005


def test_colormap_presets_replace_the_colours_only():
    model = TransferFunctionModel(hv.TransferFunction.ramp(1.0, 1e4, scale="log", cmap="gray", opacity=(0, 0.3)))
    before = model.transfer_function()
    model.apply_colormap("viridis", n_colors=33)
    tf = model.transfer_function()
    from pv_hdrvol.data.transfer import colormap_rgb
    positions = np.linspace(0, 4, 33)
    np.testing.assert_allclose(tf.color_at(10 ** positions), colormap_rgb("viridis", positions / 4), atol=1e-12)
    v = _grid(tf)
    np.testing.assert_allclose(tf.opacity_at(v), before.opacity_at(v), atol=1e-15)
    with pytest.raises(ValueError, match="cmap 'nope' is not a matplotlib colormap name"):
        model.apply_colormap("nope")


# -- ParaView presets (ParaView's own reading of them: tests/paraview/pv_presets.py) --------
def test_a_linear_function_goes_to_paraview_and_back_exactly():
    tf = hv.TransferFunction.ramp(-2.0, 7.0, cmap="viridis", opacity=(0.0, 0.1, 0.6))
    preset = paraview_preset(tf, "mine")
    assert P.export_error(tf, preset) == (0.0, 0.0) or max(P.export_error(tf, preset)) < 1e-15
    del preset["pv_hdrvol"]  # as ParaView writes it: its points only
    back = TransferFunctionModel.from_paraview_preset([preset]).transfer_function()
    _same_function(tf, back, atol=1e-15)


def test_a_log_function_is_sampled_for_paraview_within_the_tolerance():
    tf = _log_tf()
    preset = paraview_preset(tf, "log")
    color_error, opacity_error = P.export_error(tf, preset)
    assert max(color_error, opacity_error) <= P.EXPORT_TOLERANCE
    assert len(preset["RGBPoints"]) // 4 <= P.EXPORT_MAX_POINTS
    # our own state rides along: read back here, exactly
    model = TransferFunctionModel(tf)
    assert TransferFunctionModel.from_paraview_preset(paraview_preset(model, "log")).to_dict() == model.to_dict()


def test_an_edited_preset_is_read_from_its_points_not_from_the_stale_state(tmp_path):
    model = TransferFunctionModel(hv.TransferFunction.ramp(0.0, 1.0, cmap="gray"))
    path = tmp_path / "p.json"
    model.save_paraview_preset(path, "p")
    data = json.loads(path.read_text())
    data[0]["RGBPoints"][1:4] = [1.0, 0.0, 0.0]  # edited in ParaView: the start is red now
    back = TransferFunctionModel.from_paraview_preset(data, "p").transfer_function()
    np.testing.assert_array_equal(back.color_at([0.0])[0], [1.0, 0.0, 0.0])


def test_hdr_colours_are_divided_by_the_brightest_for_paraview():
    tf = hv.TransferFunction([0.0, 1.0], [[0, 0, 0], [4.0, 2.0, 0.0]], [0.0, 1.0])
    preset = paraview_preset(tf)
    assert max(preset["RGBPoints"][5:8]) == 1.0 and preset["RGBPoints"][5:8] == [1.0, 0.5, 0.0]


RGB_PRESET = {"Name": "Blue to Red", "ColorSpace": "RGB", "RGBPoints": [0, 0, 0, 1, 0.25, 0, 1, 0, 1, 1, 0, 0],
              "Points": [0.0, 0.0, 0.5, 0.0, 0.5, 0.2, 0.5, 0.0, 1.0, 1.0, 0.5, 0.0]}


def test_a_paraview_preset_lands_on_the_data_range_as_applypreset_puts_it():
    """ParaView stores presets on 0-1 and rescales them to the data on ApplyPreset: with
    data 0-255 the stored point at 0.25 moves to 63.75 and x maps as 255 x. Kept with
    rescale=False or without data; (low, high) picks the range; the caller's preset
    (numpy points too) is not changed."""
    preset = {**RGB_PRESET, "RGBPoints": np.array(RGB_PRESET["RGBPoints"], dtype=float)}
    before = preset["RGBPoints"].copy()
    values = np.array([[0.0, 17.0], [255.0, np.nan]])
    model = TransferFunctionModel.from_paraview_preset(preset, values=values)
    tf = model.transfer_function()
    assert model.range == (0.0, 255.0)
    x = np.linspace(0.0, 1.0, 101)
    stored = TransferFunctionModel.from_paraview_preset(preset, rescale=False).transfer_function()
    np.testing.assert_allclose(tf.color_at(255.0 * x), stored.color_at(x), rtol=0, atol=1e-12)
    np.testing.assert_allclose(tf.opacity_at(255.0 * x), stored.opacity_at(x), rtol=0, atol=1e-12)
    assert tf.opacity_at(127.5) == pytest.approx(0.2) and tf.color_at(63.75).tolist() == [0.0, 1.0, 0.0]
    assert TransferFunctionModel.from_paraview_preset(preset).range == (0.0, 1.0)  # no data
    assert TransferFunctionModel.from_paraview_preset(preset, values=values, rescale=False).range == (0.0, 1.0)
    assert TransferFunctionModel.from_paraview_preset(preset, rescale=(-2, 6)).range == (-2, 6)
    np.testing.assert_array_equal(preset["RGBPoints"], before)
    with pytest.raises(ValueError, match=r"rescale=True rescales the preset onto the data's range: pass values"):
        TransferFunctionModel.from_paraview_preset(preset, rescale=True)
    with pytest.raises(ValueError, match=r"rescale must be a finite range with high > low; got \(3, 3\)"):
        TransferFunctionModel.from_paraview_preset(preset, rescale=(3, 3))
    with pytest.raises(ValueError, match="the data have no finite value to rescale the preset to"):
        TransferFunctionModel.from_paraview_preset(preset, values=np.full(4, np.nan))


def test_our_own_preset_keeps_its_data_range_and_a_file_is_rescaled_on_load(tmp_path):
    """A preset written by save_paraview_preset is in data units: it keeps them (and its
    exact editor state) under data of another range unless rescale=True. load() of a
    ParaView preset file rescales onto the data given (pv-hdrvol view --tf, the viewer's
    Load)."""
    model = TransferFunctionModel(hv.TransferFunction.ramp(10.0, 1e4, scale="log"))
    path = tmp_path / "ours.json"
    model.save_paraview_preset(path, "ours")
    values = np.linspace(0.0, 50.0, 11)
    back = TransferFunctionModel.load(path, values).to_dict()
    assert {k: back[k] for k in ("color_points", "opacity_points", "scale")} == \
        {k: model.to_dict()[k] for k in ("color_points", "opacity_points", "scale")}
    assert TransferFunctionModel.load(path, values, rescale=True).range == (0.0, 50.0)
    theirs = tmp_path / "theirs.json"
    theirs.write_text(json.dumps([RGB_PRESET]))
    assert TransferFunctionModel.load(theirs, values).range == (0.0, 50.0)
    assert TransferFunctionModel.load(theirs).range == (0.0, 1.0)
    assert TransferFunctionModel.load(theirs, np.full(3, 7.0)).range == (6.5, 7.5)


def test_paraview_colour_spaces_and_curves_are_read_as_vtk_interpolates_them():
    vtk = pytest.importorskip("vtkmodules.vtkRenderingCore")
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    preset = {"Name": "Cool to Warm", "ColorSpace": "Diverging",
              "RGBPoints": [0, 0.23137, 0.29804, 0.75294, 0.5, 0.865, 0.865, 0.865, 1, 0.70588, 0.01569, 0.14902],
              "Points": [0.0, 0.0, 0.5, 0.0, 0.3, 0.02, 0.3, 0.6, 1.0, 0.8, 0.5, 0.0]}
    tf = TransferFunctionModel.from_paraview_preset(preset).transfer_function()
    ctf = vtk.vtkColorTransferFunction()
    ctf.SetColorSpaceToDiverging()
    for x, r, g, b in np.reshape(preset["RGBPoints"], (-1, 4)):
        ctf.AddRGBPoint(x, r, g, b)
    pwf = vtkPiecewiseFunction()
    for x, a, m, s in np.reshape(preset["Points"], (-1, 4)):
        pwf.AddPoint(x, a, m, s)
    v = np.linspace(0.0, 1.0, 4001)
    np.testing.assert_allclose(tf.color_at(v), [ctf.GetColor(x) for x in v], atol=2e-4)
    np.testing.assert_allclose(tf.opacity_at(v), [pwf.GetValue(x) for x in v], atol=2e-4)


def test_bad_presets_get_clear_errors():
    with pytest.raises(ValueError, match="the file holds 2 presets; name one of \\['a', 'b'\\]"):
        TransferFunctionModel.from_paraview_preset([{"Name": "a"}, {"Name": "b"}])
    with pytest.raises(ValueError, match="no preset named 'c'"):
        TransferFunctionModel.from_paraview_preset([{"Name": "a"}], "c")
    with pytest.raises(ValueError, match="preset 'k' is categorical"):
        TransferFunctionModel.from_paraview_preset({"Name": "k", "IndexedColors": [1, 0, 0], "Annotations": ["0", "a"]})
    with pytest.raises(ValueError, match="preset 'x': unknown ColorSpace 'CMYK'"):
        TransferFunctionModel.from_paraview_preset({"Name": "x", "ColorSpace": "CMYK", "RGBPoints": [0, 0, 0, 0]})
    with pytest.raises(ValueError, match="preset 'x': RGBPoints must be a flat list of numbers, 4 per point"):
        TransferFunctionModel.from_paraview_preset({"Name": "x", "RGBPoints": [0, 1, 2]})
    with pytest.raises(ValueError, match="preset 'x' spans no range"):
        TransferFunctionModel.from_paraview_preset({"Name": "x", "RGBPoints": [1, 0, 0, 0]})


def test_colour_intensity_is_drawn_and_picked_on_the_colour_axis():
    """HDR emission: the colour axis reaches 4x the brightest point; a point's intensity
    (largest channel) is picked where it is drawn, and the curve is the function's."""
    tf = hv.TransferFunction([0.0, 1.0, 2.0], [[0.5, 0.25, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0, 0.5, 1.0])
    model = TransferFunctionModel(tf)
    assert model.color_axis.top == 8.0
    sx, sy = float(model.screen_x(1.0)), float(model.color_axis.forward(2.0))
    assert sy == 0.25 and model.pick_color_intensity(sx, sy) == 1
    xs, ys = model.color_intensity_curve(5)
    np.testing.assert_allclose(ys, tf.color_at(model.value_at(xs)).max(axis=1) / 8.0, rtol=0, atol=1e-15)
    model.set_display(color_scale="log")
    assert model.transfer_function() is model.transfer_function() and model.pick_color_intensity(
        sx, float(model.color_axis.forward(2.0))) == 1


def test_load_reads_the_editors_json_and_paraview_preset_files(tmp_path):
    model = TransferFunctionModel(_log_tf())
    model.save(tmp_path / "editor.json")
    model.save_paraview_preset(tmp_path / "preset.json", "p")
    assert TransferFunctionModel.load(tmp_path / "editor.json").to_dict() == model.to_dict()
    assert TransferFunctionModel.load(tmp_path / "preset.json").to_dict() == model.to_dict()
    (tmp_path / "empty.json").write_text("[]")
    with pytest.raises(ValueError, match="the file holds 0 presets"):
        TransferFunctionModel.load(tmp_path / "empty.json")


def test_the_editor_model_is_a_public_name():
    assert hv.TransferFunctionModel is TransferFunctionModel and "TransferFunctionModel" in hv.__all__


def test_a_truncated_preset_file_names_itself_and_the_fix(tmp_path):
    """from_paraview_preset(path) of a cut file: a ValueError naming it (was a raw
    JSONDecodeError without the path; load(path) already named it)."""
    import re

    path = tmp_path / "cut.json"
    path.write_text(json.dumps([RGB_PRESET])[:40])
    with pytest.raises(ValueError, match=re.escape(f"{str(path)!r} is not valid JSON (truncated or not a ParaView "
                                                   "preset file: export it again from ParaView's Choose Preset "
                                                   "dialog): ")):
        TransferFunctionModel.from_paraview_preset(path)
    with pytest.raises(ValueError, match=r"the preset text is not valid JSON: "):
        TransferFunctionModel.from_paraview_preset('[{"Name": "x", ')
