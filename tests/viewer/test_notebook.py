"""The notebook widgets through their model (issue 21, part 5): the image is the
render of the sliders' camera and the model's function, bit for bit; each control
edits the model as it says; tone mapping re-maps without rendering."""
import re
import time
import warnings

import numpy as np
import pytest

pytest.importorskip("ipywidgets")

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.viewer.notebook import TransferFunctionEditor, editor_picture  # noqa: E402


def _volume():
    z, y, x = np.mgrid[0:20, 0:22, 0:24].astype(np.float64)
    return hv.volume_from_array(np.exp(-((x - 12) ** 2 + (y - 11) ** 2 + (z - 10) ** 2) / 30.0))


def _tf():
    return hv.TransferFunction([0.0, 0.3, 1.0], [[0.1, 0.2, 1.0], [1.0, 1.0, 1.0], [1.0, 0.3, 0.0]], [0.0, 0.05, 0.4])


def _png(data):
    import imageio.v3 as iio

    return iio.imread(data)[..., :3]


def _editor(**kwargs):
    return TransferFunctionEditor(_volume(), _tf(), size=(48, 40), live=False, precision="float64", **kwargs)


def _direct(ed):
    return hv.render(_volume(), ed.model.transfer_function(), ed.camera(), (48, 40), precision="float64",
                     global_alpha=ed.model.global_alpha)


def test_the_image_is_the_render_of_the_sliders_camera_tone_mapped():
    ed = _editor()
    hdr = ed.refresh()
    np.testing.assert_array_equal(hdr.rgba, _direct(ed).rgba)
    np.testing.assert_array_equal(_png(ed.image.value), hv.tonemap(hdr, "reinhard", key=0.18).rgb8)
    ed.azimuth.value = 90.0
    ed.elevation.value = 20.0
    ed.zoom.value = 2.0
    base, camera = ed._base, ed.camera()
    f = np.asarray(base.focal_point)
    assert np.linalg.norm(np.asarray(camera.position) - f) == pytest.approx(
        np.linalg.norm(np.asarray(base.position) - f) / 2.0, rel=1e-12)
    np.testing.assert_array_equal(ed.refresh().rgba, _direct(ed).rgba)


def test_the_point_controls_edit_the_model_and_undo_reverts():
    ed = _editor()
    before = ed.model.to_dict()
    ed.point.value = 1
    ed.opacity.value = 0.2
    assert ed.model.opacity_points[1][1] == pytest.approx(0.2)
    ed.position.value = 0.5  # halfway along the (linear) axis
    assert ed.model.opacity_points[0][1] == pytest.approx(0.5)
    np.testing.assert_array_equal(ed.refresh().rgba, _direct(ed).rgba)
    ed.add.click()
    assert ed.model.opacity_points[0].size == 4 and ed.point.value == 2
    ed.remove.click()
    assert ed.model.opacity_points[0].size == 3
    for _ in range(4):
        ed.undo.click()
    assert ed.model.to_dict() == before


def test_tone_mapping_re_maps_the_kept_render_and_global_alpha_renders_again():
    ed = _editor()
    hdr = ed.refresh()
    picture = ed.picture.copy()
    ed.tone.value = "linear"
    ed.stops.value = 2.0
    assert ed.hdr is hdr and not np.array_equal(ed.picture, picture)
    np.testing.assert_array_equal(_png(ed.image.value), hv.tonemap(hdr, "linear", exposure_stops=2.0).rgb8)
    ed.global_alpha.value = 0.05
    assert ed.model.global_alpha == pytest.approx(0.05)
    np.testing.assert_array_equal(ed.refresh().rgba, _direct(ed).rgba)
    ed.preset.value = "viridis"
    assert ed.preset.value == "(colours)" and ed.model.color_points[0].size > 3


def test_live_frames_arrive_from_the_worker():
    ed = TransferFunctionEditor(_volume(), _tf(), size=(48, 40), precision="float64")
    try:
        end = time.monotonic() + 120
        while not (ed.level == "full" and ed.hdr is not None) and time.monotonic() < end:
            time.sleep(0.02)
        assert ed.level == "full"
        np.testing.assert_array_equal(ed.hdr.rgba, _direct(ed).rgba)
    finally:
        ed.close()


def test_the_editor_picture_draws_the_points_where_the_model_puts_them():
    ed = _editor()
    picture = editor_picture(ed.model, width=200, height=120)
    assert picture.shape == (120, 200, 3)
    values, opacities = ed.model.opacity_points
    for v, a in zip(values, opacities):
        col = int(round(float(ed.model.screen_x(v)) * 199))
        row = int(round((1 - float(ed.model.opacity_axis.forward(a))) * 99))
        assert tuple(picture[row, col]) == (255, 200, 0)


def _wait_for_full(ed, seconds=120):
    end = time.monotonic() + seconds
    while not (ed.level == "full" and ed.hdr is not None) and time.monotonic() < end:
        time.sleep(0.02)
    assert ed.level == "full"


def test_an_empty_render_on_the_worker_is_said_in_the_widget_not_in_later_calls():
    # opacity 0 everywhere: every render is empty. The worker's EmptyRenderWarning used to go
    # through the process-wide warnings machinery, into whatever the main thread ran next
    # (a later notebook cell, an unrelated pytest.warns or catch_warnings block)
    blank = hv.TransferFunction([0.0, 1.0], [[1.0, 1.0, 1.0]] * 2, [0.0, 0.0])
    message = "the transfer function's opacity is 0 over the whole data range"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ed = TransferFunctionEditor(_volume(), blank, size=(48, 40), precision="float64")
        try:
            _wait_for_full(ed)
            ed.azimuth.value = 30.0  # a second request, a second empty render
            _wait_for_full(ed)
            time.sleep(0.2)
        finally:
            ed.close()
    assert [str(w.message) for w in caught if issubclass(w.category, hv.EmptyRenderWarning)] == []
    assert message in ed.status.value  # shown where the render is
    # rendered here (refresh), the warning is the caller's, and the status says it too
    ed = TransferFunctionEditor(_volume(), blank, size=(48, 40), live=False, precision="float64")
    with pytest.warns(hv.EmptyRenderWarning, match=re.escape(message)):
        ed.refresh()
    assert message in ed.status.value
