"""The proxy viewer in a real window under Xvfb (pytest-qt): each control gives the
image ProxySet.synthesize gives for the settings it stands for, bit for bit.

Run by tests/viewer/test_viewer_qt.py under xvfb-run (see there).
"""
import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.proxy.qt import SCALE_STEPS, ProxyViewer, scale_position, slider_scale


@pytest.fixture(scope="module")
def proxies():
    z, y, x = np.mgrid[0:24, 0:24, 0:24].astype(np.float64)
    values = np.exp(-((x - 11.5) ** 2 / 40 + (y - 11.5) ** 2 / 25 + (z - 11.5) ** 2 / 30))
    tf = hv.TransferFunction([0.0, 0.2, 0.5, 0.8, 1.0], [[0.2, 0.4, 1.0], [0.5, 0.8, 1.0], [1.0, 1.0, 1.0],
                                                         [1.0, 0.6, 0.2], [1.0, 0.2, 0.1]], [0.0, 0.05, 0.1, 0.2, 0.3])
    return hv.make_proxies(hv.volume_from_array(values), "iso", 48, tf, intervals=8, layers=[0.3, 0.7],
                           multi_perspective=True, training=2, clusters=4)


def _shown(qtbot, viewer, expected):
    def same():
        assert viewer.error is None, viewer.error
        np.testing.assert_array_equal(viewer.image.rgba, expected.rgba)
    qtbot.waitUntil(same, timeout=20_000)


def test_slider_mapping():
    assert slider_scale(0) == 0.0
    assert slider_scale(1) == 0.01
    assert slider_scale(SCALE_STEPS) == 10.0
    assert slider_scale(scale_position(1.0)) == 1.0  # was 0.9923: the window opened on the colour model's guess
    assert [scale_position(slider_scale(p)) for p in range(SCALE_STEPS + 1)] == list(range(SCALE_STEPS + 1))


def test_every_control_shows_what_synthesize_gives(qtbot, proxies, tmp_path):
    viewer = ProxyViewer(proxies)
    qtbot.addWidget(viewer)
    viewer.show()
    assert viewer.settings()["opacity_scale"] == [1.0] * proxies.intervals
    _shown(qtbot, viewer, proxies.synthesize())  # the first image is the proxies' own render
    base = [1.0] * proxies.intervals
    shown = [i for i, s in enumerate(viewer.interval_sliders) if s.isEnabled()]
    assert shown
    viewer.interval_sliders[shown[0]].setValue(0)  # remove the outermost visible interval
    scale = list(base)
    scale[shown[0]] = 0.0
    _shown(qtbot, viewer, proxies.synthesize(scale))
    viewer.azimuth.setValue(25)
    _shown(qtbot, viewer, proxies.synthesize(scale, rotate=(25.0, 0.0)))
    viewer.enhance.setValue(50)
    _shown(qtbot, viewer, proxies.synthesize(scale, rotate=(25.0, 0.0), enhance=0.5))
    viewer.layers.setChecked(True)
    viewer.occlusion.setChecked(True)
    kw = viewer.settings()
    assert set(kw["layers"]) == {0, 1} and kw["ambient_occlusion"] == 1.0 and kw["rotate"] == (25.0, 0.0)
    _shown(qtbot, viewer, proxies.synthesize(**kw))
    assert "synthesised in" in viewer.statusBar().currentMessage()
    viewer.save(tmp_path / "shown.exr")
    np.testing.assert_allclose(hv.load(tmp_path / "shown.exr").rgba, viewer.image.rgba, rtol=1e-6, atol=1e-7)


def test_a_folder_opens_through_hv_view(qtbot, proxies, tmp_path):
    folder = proxies.save(tmp_path / "p.proxy")
    viewer = hv.view(str(folder), block=False)
    qtbot.addWidget(viewer)
    assert isinstance(viewer, ProxyViewer)
    np.testing.assert_array_equal(viewer.proxies.model.lut(), proxies.model.lut())
