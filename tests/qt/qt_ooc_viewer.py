"""The Qt viewer on a store larger than memory (issue 34, part 4), for real under Xvfb:
``hv.view("x.ome.zarr")`` and ``pv-hdrvol view x.ome.zarr`` open it out of core; the
first frame comes at a coarse level, frames refine as chunks arrive (the loader slowed on
purpose) until converged -- bit for bit the waiting render -- and the status bar says
which levels each frame drew; a drag renders coarse again, then refines; what the
out-of-core path cannot do yet (the lens, the probe's data value) is off and says so.

Run by tests/viewer/test_viewer_qt.py under xvfb-run (see tests/qt/qt_viewer.py).
"""
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from qtpy import QtCore

pytest.importorskip("zarr")

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # tests/: the shared helpers

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.outofcore.store import MultiscaleStore  # noqa: E402
from pv_hdrvol.viewer.qt import HDRViewer  # noqa: E402
from qt_viewer import _drag  # noqa: E402
from stores import write_store  # noqa: E402

WAIT_MS = 120_000


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return write_store(tmp_path_factory.mktemp("ooc_qt") / "smooth.ome.zarr")


@pytest.fixture
def gate(monkeypatch):
    """Reads of the finer levels wait until the gate opens (the coarsest level, which
    is read when the volume is first used, does not): frames come before their chunks
    however fast the renderer is."""
    opened = threading.Event()
    read = MultiscaleStore.read_chunk

    def held(self, level, index):
        if level < self.n_levels - 1:
            opened.wait(60)
        return read(self, level, index)
    monkeypatch.setattr(MultiscaleStore, "read_chunk", held)
    yield opened
    opened.set()


def _note(actor, seen, shown_before):
    """Note the frame level shown (and the status line) when it changes, from the first
    frame that is not ``shown_before``."""
    if actor.level is not None and actor.hdr is not shown_before and (not seen or seen[-1][0] != actor.level):
        seen.append((actor.level, actor.status))


def _until_refining(qtbot, window, seen, shown_before=None):
    """Wait until the window shows a refining frame (chunks held back), noting frames."""
    actor = window.actor

    def refining():
        assert actor.error is None, actor.error
        _note(actor, seen, shown_before)
        assert actor.level == "refining"
    qtbot.waitUntil(refining, timeout=WAIT_MS)


def _watch(qtbot, window, seen):
    """Wait until the window shows a converged frame of its present view, noting each
    frame level shown and the status bar's text then."""
    actor = window.actor

    def converged():
        assert actor.error is None, actor.error
        QtCore.QCoreApplication.processEvents()
        _note(actor, seen, None)
        assert actor.up_to_date
    qtbot.waitUntil(converged, timeout=WAIT_MS)
    qtbot.waitUntil(lambda: window.level_label.text().endswith("converged"), timeout=5000)


def _direct(window):
    camera = hv.Camera.from_pyvista(window.plotter.camera)
    size = window.actor.scene.GetSize()
    return hv.render(window.data, window.model.transfer_function(), camera, size, precision="float32",
                     global_alpha=window.model.global_alpha, progress_bar=False)


def test_a_store_opens_refines_to_converged_and_refines_again_after_a_drag(qtbot, store, gate):
    window = hv.view(str(store), block=False)
    qtbot.addWidget(window)
    assert isinstance(window, HDRViewer) and window.multiscale
    assert window.windowTitle() == "pv_hdrvol: smooth.ome.zarr"
    window.resize(700, 560)
    qtbot.waitExposed(window)
    seen = []
    _until_refining(qtbot, window, seen)  # the finer chunks held back: the coarsest level drawn
    assert window.actor.hdr.metadata["levels"][:-1] == [0, 0], seen
    assert "loading" in window.level_label.text() or "loading" in seen[-1][1], seen
    gate.set()
    _watch(qtbot, window, seen)
    levels = [level for level, _ in seen]
    # the coarse frame may be on screen for less than one poll on a loaded machine (the
    # renderer's own sequence, coarse first, is checked frame by frame in test_ooc_viewer)
    assert levels[0] in ("coarse", "refining") and levels[-1] == "full" and "refining" in levels, seen
    assert window.level_label.text().startswith("full: ") and "level 0" in window.level_label.text()
    np.testing.assert_array_equal(window.actor.hdr.rgba, _direct(window).rgba)
    # orbit to chunks not in memory (the cache dropped while the worker rests, the finer
    # reads held back again): coarse while dragging, refining at rest, then converged
    window.data.close()
    gate.clear()
    before = window.actor.hdr
    w, h = window.plotter.width(), window.plotter.height()
    _drag(window.plotter, (w / 2, h / 2), (w / 2 + 160, h / 2 + 40))
    seen = []
    _until_refining(qtbot, window, seen, shown_before=before)
    gate.set()
    _watch(qtbot, window, seen)
    levels = [level for level, _ in seen]
    assert window.actor.hdr is not before and levels[0] in ("coarse", "refining") and \
        levels[-2:] == ["refining", "full"], seen
    np.testing.assert_array_equal(window.actor.hdr.rgba, _direct(window).rgba)
    window.close()
    assert window.data._caches == {}  # the loader threads and the chunk cache released


def test_what_the_out_of_core_path_cannot_do_yet_is_off_and_said(qtbot, store):
    window = HDRViewer(hv.open_multiscale(store), precision="float32")
    qtbot.addWidget(window)
    window.resize(500, 420)
    window.show()
    qtbot.waitExposed(window)
    _watch(qtbot, window, [])
    lens = window.actions_by_name["Magnifier lens"]
    assert not lens.isEnabled() and "in-core" in lens.text()
    window.toggle_lens(True)
    assert not window.lens_mode and window.actor.lens is None
    assert "in-core image volumes only" in window.statusBar().currentMessage()
    # the probe: HDR values and depth, and says there is no data value
    cols, rows = window.actor.scene.GetSize()
    window.plotter.iren.interactor.SetEventPosition(cols // 2, rows // 2)
    window._mouse_moved()
    assert "HDR RGBA" in window.probe_label.text() and "no data value out of core" in window.probe_label.text()
    # the editor: a histogram (the coarsest level's), edits render again to a converged frame
    assert window.model.histogram() is not None
    window.model.set_global_alpha(0.5)
    _watch(qtbot, window, [])
    np.testing.assert_array_equal(window.actor.hdr.rgba, _direct(window).rgba)
    # the clip plane works out of core
    window.actions_by_name["Clip plane"].trigger()
    assert window.actor.renderer.options.clip_planes
    _watch(qtbot, window, [])
    window.close()


def test_the_view_command_opens_a_store(qtbot, store, monkeypatch):
    import pv_hdrvol.viewer.qt as qt
    from pv_hdrvol.integrations.cli import main

    opened = []

    def view(data, tf=None, **kwargs):  # the real window, without blocking in exec()
        window = qt.HDRViewer(data, tf, **kwargs)
        qtbot.addWidget(window)
        opened.append(window)
        return window

    monkeypatch.setattr(qt, "view", view)
    assert main(["view", str(store)]) == 0
    (window,) = opened
    window.resize(400, 320)
    window.show()
    qtbot.waitExposed(window)
    _watch(qtbot, window, [])
    assert window.windowTitle() == "pv_hdrvol: smooth.ome.zarr" and window.multiscale
    window.close()
