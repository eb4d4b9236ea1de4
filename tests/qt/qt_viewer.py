"""The Qt viewer for real: a window under Xvfb driven by synthetic mouse and key
events (pytest-qt), asserting on the rendered pixels.

Run by tests/viewer/test_viewer_qt.py under xvfb-run (see there); not collected otherwise
(file names qt_*.py). By hand: ``xvfb-run -a python -m pytest -c /dev/null --rootdir .
tests/qt/qt_viewer.py`` (pyproject.toml's options switch pytest-qt off for the main
suite). Renders in float32, the viewer's default, whose kernels the main suite compiles
anyway.
"""
import warnings

import numpy as np
import pytest
from qtpy import QtCore, QtGui, QtWidgets

import pv_hdrvol as hv
from pv_hdrvol.viewer.qt import HDRViewer

FULL_WAIT_MS = 120_000


def _volume():
    """Two blobs: A (left, values up to 0.3) and B (right, values up to 0.9)."""
    z, y, x = np.mgrid[0:24, 0:24, 0:40].astype(np.float64)
    a = 0.3 * np.exp(-((x - 10) ** 2 + (y - 12) ** 2 + (z - 12) ** 2) / 12.0)
    b = 0.9 * np.exp(-((x - 30) ** 2 + (y - 12) ** 2 + (z - 12) ** 2) / 12.0)
    return hv.volume_from_array(a + b)


def _tf():
    return hv.TransferFunction([0.0, 0.2, 0.5, 0.7, 1.0], [[0.2, 0.4, 1.0], [0.5, 0.8, 1.0], [1.0, 1.0, 1.0],
                                                         [1.0, 0.6, 0.2], [1.0, 0.2, 0.1]],
                               [0.0, 0.05, 0.1, 0.2, 0.3])


def _wait_full(qtbot, viewer):
    actor = viewer.actor

    def shown():
        assert actor.error is None, actor.error
        assert actor.up_to_date
    qtbot.waitUntil(shown, timeout=FULL_WAIT_MS)


def _direct(viewer, **kwargs):
    camera = hv.Camera.from_pyvista(viewer.plotter.camera)
    size = viewer.actor.scene.GetSize()
    return hv.render(_volume(), viewer.model.transfer_function(), camera, size, precision="float32",
                     global_alpha=viewer.model.global_alpha, **kwargs)


def _mouse(widget, kind, pos, button=QtCore.Qt.LeftButton, buttons=None, modifiers=QtCore.Qt.NoModifier):
    types = {"press": QtCore.QEvent.MouseButtonPress, "move": QtCore.QEvent.MouseMove,
             "release": QtCore.QEvent.MouseButtonRelease}
    buttons = button if buttons is None else buttons
    point = QtCore.QPointF(*pos)
    try:
        event = QtGui.QMouseEvent(types[kind], point, widget.mapToGlobal(point.toPoint()).toPointF()
                                  if hasattr(QtCore.QPoint, "toPointF") else point,
                                  button if kind != "move" else QtCore.Qt.NoButton, buttons, modifiers)
    except TypeError:  # Qt 5 signature
        event = QtGui.QMouseEvent(types[kind], point, button if kind != "move" else QtCore.Qt.NoButton, buttons,
                                  modifiers)
    QtWidgets.QApplication.sendEvent(widget, event)
    QtWidgets.QApplication.processEvents()


def _drag(widget, start, end, steps=6, modifiers=QtCore.Qt.NoModifier):
    _mouse(widget, "press", start, modifiers=modifiers)
    for f in np.linspace(0, 1, steps)[1:]:
        _mouse(widget, "move", (start[0] + f * (end[0] - start[0]), start[1] + f * (end[1] - start[1])),
               modifiers=modifiers)
    _mouse(widget, "release", end, buttons=QtCore.Qt.NoButton, modifiers=modifiers)


@pytest.fixture
def viewer(qtbot):
    window = HDRViewer(_volume(), _tf(), precision="float32")
    qtbot.addWidget(window)
    window.resize(900, 700)
    window.show()
    qtbot.waitExposed(window)
    _wait_full(qtbot, window)
    yield window
    window.close()


def test_the_refined_frame_equals_a_direct_render(viewer):
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, _direct(viewer).rgba)
    assert viewer.actor.hdr.rgba[..., 3].max() > 0.3


def test_orbiting_with_the_mouse_renders_the_new_view(qtbot, viewer):
    before = np.array(viewer.plotter.camera.position)
    first = viewer.actor.hdr
    w, h = viewer.plotter.width(), viewer.plotter.height()
    _drag(viewer.plotter, (w / 2, h / 2), (w / 2 + 120, h / 2 + 40))
    assert np.linalg.norm(np.array(viewer.plotter.camera.position) - before) > 1e-3
    _wait_full(qtbot, viewer)
    assert viewer.actor.hdr is not first
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, _direct(viewer).rgba)


def test_dragging_an_opacity_point_changes_the_image_where_and_only_where_it_should(qtbot, viewer):
    """The point at 0.7 rules opacity over (0.5, 1): only rays that meet values above 0.5
    (blob B) change; rays through blob A alone (values up to 0.3) keep every bit."""
    before = viewer.actor.hdr.rgba.copy()
    values, _ = viewer.model.opacity_points
    index = int(np.argmin(np.abs(values - 0.7)))
    x, y = viewer.editor.opacity_point_position(index)
    _drag(viewer.editor, (x, y), (x, y - 30))
    assert viewer.model.opacity_points[1][index] > 0.2
    assert viewer.model.can_undo and len(viewer.model._undo) == 1  # the drag is one edit
    _wait_full(qtbot, viewer)
    after = viewer.actor.hdr.rgba
    np.testing.assert_array_equal(after, _direct(viewer).rgba)
    # which rays meet values above 0.5: a maximum-intensity projection tells (its samples
    # lie elsewhere along the ray than compositing's midpoints: a margin of 0.05)
    peak = np.nan_to_num(_direct(viewer, blending="maximum").value)
    high, low = peak > 0.55, peak <= 0.45
    assert high.sum() > 50 and low.sum() > 50
    np.testing.assert_array_equal(after[low], before[low])
    assert np.any(after[high] != before[high])
    viewer.actions_by_name["Undo"].trigger()
    _wait_full(qtbot, viewer)
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, before)


def test_the_lens_follows_the_mouse_and_changes_only_its_disc(qtbot, viewer):
    plain = viewer.actor.hdr.rgba.copy()
    viewer.actions_by_name["Magnifier lens"].trigger()
    cols, rows = viewer.actor.scene.GetSize()
    target = (cols // 2 + 60, rows // 2 - 20)
    _drag(viewer.plotter, (cols // 2, rows // 2), target)
    lens = viewer.actor.lens
    assert lens is not None and tuple(lens.center) == (float(target[0]), float(target[1]))
    _wait_full(qtbot, viewer)
    rgba = viewer.actor.hdr.rgba
    r, c = np.mgrid[0:rows, 0:cols]
    outside = np.hypot(c + 0.5 - lens.center[0], r + 0.5 - lens.center[1]) > lens.radius + 1
    np.testing.assert_array_equal(rgba[outside], plain[outside])
    assert np.any(rgba[~outside] != plain[~outside])
    viewer.actions_by_name["Magnifier lens"].trigger()  # off again: the plain render
    _wait_full(qtbot, viewer)
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, plain)


def test_the_probe_shows_the_hdr_values_under_the_cursor(qtbot, viewer):
    rgba = viewer.actor.hdr.rgba
    row, col = np.unravel_index(np.argmax(rgba[..., 3]), rgba.shape[:2])
    _mouse(viewer.plotter, "move", (col, row), buttons=QtCore.Qt.NoButton)
    text = viewer.probe_label.text()
    r, g, b, a = rgba[row, col]
    assert f"({col}, {row})  HDR RGBA {r:.4g} {g:.4g} {b:.4g} {a:.4g}" in text
    assert "depth" in text and "value" in text
    found = viewer.actor.probe(col, row)
    assert 0.0 < found["value"] <= 0.9


def test_tone_mapping_is_instant_and_saving_keeps_the_hdr_image(qtbot, viewer, tmp_path):
    hdr = viewer.actor.hdr
    shown = viewer.actor.composite.copy()
    viewer.panel.operator.setCurrentText("linear")
    viewer.panel.exposure.setValue(8)  # +2 stops
    qtbot.waitUntil(lambda: not np.array_equal(viewer.actor.composite, shown), timeout=10_000)
    assert viewer.actor.hdr is hdr  # re-mapped, not rendered
    viewer.save_exr(tmp_path / "v.exr")
    np.testing.assert_array_equal(hv.load(tmp_path / "v.exr").rgba, hdr.rgba.astype(np.float32))
    viewer.save_png(tmp_path / "v.png")
    import imageio.v3 as iio
    np.testing.assert_array_equal(iio.imread(tmp_path / "v.png")[..., :3], viewer.actor.composite)


def _key_and_modifiers(keys):
    """The first key of ``QKeySequence(keys)`` as (key, modifiers), Qt 6 or Qt 5."""
    combo = QtGui.QKeySequence(keys)[0]
    if hasattr(combo, "key"):  # Qt 6: a QKeyCombination
        return combo.key(), combo.keyboardModifiers()
    mask = int(QtCore.Qt.KeyboardModifierMask)
    return QtCore.Qt.Key(combo & ~mask), QtCore.Qt.KeyboardModifiers(combo & mask)


def test_the_help_lists_exactly_the_shortcuts_the_window_answers(qtbot, viewer):
    """The help's shortcut lines ("KEYS  what") against the window's own bindings, found
    in the widget tree (every QAction and QShortcut with a key, in a menu or not), both
    ways; then each listed key, pressed, triggers the action of that name (the actions'
    slots are swapped for a recorder: Ctrl+W would close the window, Ctrl+S open a
    dialog)."""
    listed = {}
    for line in viewer._shortcut_text.partition("\n\n")[0].splitlines():
        keys, text = line.split(None, 1)
        listed[text.strip()] = keys
    bound = {}
    for action in viewer.findChildren(QtWidgets.QAction):
        if not action.shortcut().isEmpty():
            bound[action.text()] = action.shortcut().toString()
    for shortcut in viewer.findChildren(QtWidgets.QShortcut):
        bound[shortcut.whatsThis() or repr(shortcut)] = shortcut.key().toString()
    assert len(bound) >= 10 and bound == listed
    in_menus = {a.text() for menu in viewer.menuBar().findChildren(QtWidgets.QMenu) for a in menu.actions()}
    assert set(listed) <= in_menus  # reachable from the menus too

    # Qt's shortcut map answers for the active window only, and under Xvfb no window
    # manager makes it active
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        QtWidgets.QApplication.setActiveWindow(viewer)
    viewer.setFocus()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activeWindow() is viewer, timeout=10_000)
    pressed = []
    for action in viewer.findChildren(QtWidgets.QAction):
        if not action.shortcut().isEmpty():
            action.triggered.disconnect()
            action.triggered.connect(lambda checked=False, text=action.text(): pressed.append(text))
    for text, keys in listed.items():
        key, modifiers = _key_and_modifiers(keys)
        qtbot.keyClick(viewer, key, modifiers)
        QtWidgets.QApplication.processEvents()
        assert pressed[-1:] == [text], (keys, text, pressed)
    assert pressed == list(listed)


def test_the_editor_keys_do_what_the_help_says(qtbot, viewer):
    """The help's editor line ("L log opacity axis; C log colour axis; M magnification;
    Delete"): each key, pressed on the editor, does that."""
    help_text = " ".join(viewer._shortcut_text.split())
    m, editor = viewer.model, viewer.editor
    for claim, key, state in (("L log opacity axis", QtCore.Qt.Key_L, lambda: m.opacity_axis.scale),
                              ("C log colour axis", QtCore.Qt.Key_C, lambda: m.color_axis.scale),
                              ("M magnification", QtCore.Qt.Key_M, lambda: m.magnified)):
        assert claim in help_text, claim
        before = state()
        qtbot.keyClick(editor, key)
        assert state() != before, claim
        if claim.endswith("axis"):
            assert {before, state()} == {"linear", "log"}, claim
        qtbot.keyClick(editor, key)
        assert state() == before, claim
    # Delete removes the selected point (a click selects it)
    assert "Delete" in help_text
    values = m.opacity_points[0].copy()
    index = int(np.argmin(np.abs(values - 0.5)))
    x, y = editor.opacity_point_position(index)
    _mouse(editor, "press", (x, y))
    _mouse(editor, "release", (x, y), buttons=QtCore.Qt.NoButton)
    assert editor.selected == ("opacity", index)
    qtbot.keyClick(editor, QtCore.Qt.Key_Delete)
    np.testing.assert_array_equal(m.opacity_points[0], np.delete(values, index))


def test_the_view_command_opens_the_file_with_its_transfer_function(qtbot, tmp_path, monkeypatch):
    """``pv-hdrvol view FILE --tf preset.json``: the window's function is the file's."""
    import pv_hdrvol.viewer.qt as qt
    from pv_hdrvol.editor.model import TransferFunctionModel
    from pv_hdrvol.integrations.cli import main

    opened = []

    def view(data, tf=None, **kwargs):  # the real window, without blocking in exec()
        window = qt.HDRViewer(data, tf, **kwargs)
        qtbot.addWidget(window)
        opened.append(window)
        return window

    monkeypatch.setattr(qt, "view", view)
    grid = _volume()
    import pyvista as pv
    image = pv.ImageData(dimensions=grid.dims, spacing=grid.spacing, origin=grid.origin)
    image.point_data["density"] = grid.values.reshape(-1)
    image.save(tmp_path / "blobs.vti")
    TransferFunctionModel(_tf()).save_paraview_preset(tmp_path / "preset.json", "mine")
    assert main(["view", str(tmp_path / "blobs.vti"), "--tf", str(tmp_path / "preset.json")]) == 0
    (window,) = opened
    assert window.windowTitle() == "pv_hdrvol: blobs.vti"
    np.testing.assert_array_equal(window.model.transfer_function().opacities, _tf().opacities)
    window.close()


def test_hv_view_opens_a_file_and_a_function_file_as_the_view_command_does(qtbot, tmp_path):
    """``hv.view("blobs.vti", tf="preset.json")`` (it used to say "got str"): the
    command's window, title and function, refined to the direct render."""
    from pv_hdrvol.editor.model import TransferFunctionModel
    import pyvista as pv

    grid = _volume()
    image = pv.ImageData(dimensions=grid.dims, spacing=grid.spacing, origin=grid.origin)
    image.point_data["density"] = grid.values.reshape(-1)
    image.save(tmp_path / "blobs.vti")
    TransferFunctionModel(_tf()).save_paraview_preset(tmp_path / "preset.json", "mine")
    window = hv.view(str(tmp_path / "blobs.vti"), tf=str(tmp_path / "preset.json"), block=False)
    qtbot.addWidget(window)
    assert isinstance(window, HDRViewer) and window.windowTitle() == "pv_hdrvol: blobs.vti"
    np.testing.assert_array_equal(window.model.transfer_function().opacities, _tf().opacities)
    window.resize(600, 500)
    qtbot.waitExposed(window)
    _wait_full(qtbot, window)
    np.testing.assert_array_equal(window.actor.hdr.rgba, _direct(window).rgba)
    window.close()


def test_a_background_plotter_draws_the_volume_behind_its_mesh(qtbot):
    """pyvistaqt's BackgroundPlotter: the volume arrives progressively on its window and
    a mesh in front of it hides it exactly; the full frame is the direct render with the
    rays stopped there."""
    import pyvista as pv
    from pyvistaqt import BackgroundPlotter

    pl = BackgroundPlotter(window_size=(320, 240), title="pv_hdrvol test")
    try:
        pl.set_background("black")
        pl.add_mesh(pv.Plane(center=(10, 12, 30), direction=(0, 0, 1), i_size=10, j_size=10), color="red",
                    lighting=False)
        pl.camera_position = [(20, 12, 90), (20, 12, 12), (0, 1, 0)]
        actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float32")
        assert actor.progressive
        pl.render()
        qtbot.waitUntil(lambda: actor.up_to_date, timeout=FULL_WAIT_MS)
        red = np.all(actor.composite == [255, 0, 0], axis=-1)
        assert red.sum() > 200
        assert np.all(actor.hdr.rgba[red] == 0) and np.all(np.isfinite(actor.far[red]))
        free = hv.render(_volume(), _tf(), hv.Camera.from_pyvista(pl.camera), actor.hdr.shape[::-1],
                         precision="float32")
        assert free.rgba[red][:, 3].max() > 0.05  # the plane does hide some of the volume
        np.testing.assert_array_equal(actor.hdr.rgba[~red & ~np.isfinite(actor.far)],
                                      free.rgba[~red & ~np.isfinite(actor.far)])
    finally:
        pl.close()


def test_the_data_axis_switch_changes_the_function_or_says_why_not(qtbot, viewer):
    viewer.panel.scale.setCurrentText("symlog")
    assert viewer.model.scale == "symlog"
    _wait_full(qtbot, viewer)
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, _direct(viewer).rgba)
    viewer.panel.scale.setCurrentText("log")  # the range starts at 0: no log axis
    assert viewer.model.scale == "symlog" and viewer.panel.scale.currentText() == "symlog"
    assert "scale='log' needs a positive range" in viewer.statusBar().currentMessage()


def test_a_tetrahedral_mesh_opens_and_refines_to_its_direct_render(qtbot):
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from meshes import box_mesh

    points, tets, values = box_mesh((3, 3, 3), field=lambda p: 1.0 + p[:, 0] * p[:, 1])
    mesh = hv.tetmesh_from_arrays(points, tets, values)
    tf = hv.TransferFunction.ramp(1.0, 10.0, cmap="viridis", opacity=(0.05, 0.5))
    window = HDRViewer(mesh, tf, precision="float32")
    qtbot.addWidget(window)
    window.resize(700, 560)
    window.show()
    qtbot.waitExposed(window)
    _wait_full(qtbot, window)
    camera = hv.Camera.from_pyvista(window.plotter.camera)
    direct = hv.render(mesh, window.model.transfer_function(), camera, window.actor.scene.GetSize(),
                       precision="float32")
    np.testing.assert_array_equal(window.actor.hdr.rgba, direct.rgba)
    assert window.actor.hdr.rgba[..., 3].max() > 0.2
    window.toggle_lens(True)  # image volumes only: refused, saying why
    assert not window.lens_mode and window.actor.lens is None
    assert window.statusBar().currentMessage() == "the magnifier lens works on image volumes only"
    window.close()


def test_pyvistas_words_open_the_viewer_on_their_function_framed_as_hv_render_frames(qtbot):
    """hv.view(data, cmap=, clim=, opacity=, scale=, global_alpha=): the editor starts from
    the function hv.render makes of the words, and a CTH-like rectilinear grid of cell
    data is framed on its bounds (the cells' corners), as hv.render frames it."""
    import sys
    from pathlib import Path

    from pv_hdrvol.editor.model import TransferFunctionModel
    from pv_hdrvol.raycast.grid import resolve_render_options
    from pv_hdrvol.rays.camera import fit_camera

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from meshes import cth_like_grid

    rect = cth_like_grid()
    words = dict(cmap="bone", clim=(-0.5, 1.0), opacity="sigmoid", scale="linear")
    window = HDRViewer(rect, precision="float32", global_alpha=0.5, **words)
    qtbot.addWidget(window)
    window.resize(900, 700)
    window.show()
    qtbot.waitExposed(window)
    _wait_full(qtbot, window)
    tf, options = resolve_render_options(hv.volume_from_dataset(rect), **words, global_alpha=0.5)
    assert window.model.to_dict() == TransferFunctionModel(tf, global_alpha=0.5).to_dict()
    assert options.global_alpha == window.model.global_alpha == 0.5
    camera, expected = hv.Camera.from_pyvista(window.plotter.camera), fit_camera(rect, "iso")
    for name in ("position", "focal_point", "view_up"):
        np.testing.assert_allclose(getattr(camera, name), getattr(expected, name), rtol=0, atol=1e-6)
    direct = hv.render(rect, window.model.transfer_function(), camera, window.actor.scene.GetSize(),
                       precision="float32", global_alpha=0.5)
    np.testing.assert_array_equal(window.actor.hdr.rgba, direct.rgba)
    assert window.actor.hdr.rgba[..., 3].max() > 0.05
    window.close()


def test_dragging_a_colour_intensity_brightens_that_colour(qtbot, viewer):
    """The orange diamond of a colour point sits at its largest channel on the colour
    axis; dragging it up scales the colour (hue kept) and the render follows."""
    before = viewer.actor.hdr.rgba.copy()
    index = 2  # the white point at 0.5
    rgb = viewer.model.color_points[1][index].copy()
    x, y = viewer.editor.color_intensity_position(index)
    target = y - 25
    _drag(viewer.editor, (x, y), (x, target))
    after_rgb = viewer.model.color_points[1][index]
    expected = float(viewer.model.color_axis.inverse(viewer.editor.from_widget(x, target)[1]))
    np.testing.assert_allclose(after_rgb, rgb * expected / rgb.max(), rtol=1e-12)
    assert after_rgb.max() > rgb.max()
    assert viewer.model.opacity_points[1].tolist() == _tf().opacities.tolist()  # opacity untouched
    _wait_full(qtbot, viewer)
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, _direct(viewer).rgba)
    np.testing.assert_array_equal(viewer.actor.hdr.rgba[..., 3], before[..., 3])  # colour only
    assert viewer.actor.hdr.rgba[..., :3].sum() > before[..., :3].sum()


def _screen_point(viewer, point):
    """Where world ``point`` is drawn in the plotter widget (Qt's pixels, top left)."""
    renderer = viewer.plotter.renderer
    renderer.SetWorldPoint(*point, 1.0)
    renderer.WorldToDisplay()
    x, y, _ = renderer.GetDisplayPoint()
    scale = viewer.plotter.devicePixelRatioF() if hasattr(viewer.plotter, "devicePixelRatioF") else 1.0
    return x / scale, viewer.plotter.height() - y / scale


def test_the_clip_plane_from_the_menu_cuts_where_it_is_dragged(qtbot, viewer):
    """View > Clip plane puts a plane through the centre (normal +x: the right blob is
    kept); dragging the plane with the mouse pushes it along its normal, and the
    refined frame is the direct render with that plane; unchecking gives the whole
    volume back."""
    menu = next(m for m in viewer.menuBar().findChildren(QtWidgets.QMenu) if m.title() == "View")
    next(a for a in menu.actions() if a.text() == "Clip plane").trigger()
    assert viewer.actions_by_name["Clip plane"].isChecked()
    _wait_full(qtbot, viewer)
    plane = viewer.actor.renderer.options.clip_planes[0]
    assert plane.normal == (1.0, 0.0, 0.0) and plane.origin == pytest.approx((19.5, 11.5, 11.5))
    widget = viewer._clip_plane
    widget.Off()  # its handles are scene geometry in front of the volume: off for the comparison, then on again
    _wait_full(qtbot, viewer)
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, _direct(viewer, clip_planes=(plane.origin, plane.normal)).rgba)
    widget.On()
    # press on the plane away from its centre handle and drag: it moves along its normal
    start = _screen_point(viewer, (19.5, 3.0, 20.0))
    end = _screen_point(viewer, (27.0, 3.0, 20.0))
    _drag(viewer.plotter, start, end, steps=8)
    moved = viewer.actor.renderer.options.clip_planes[0]
    assert moved.normal == pytest.approx((1.0, 0.0, 0.0)) and moved.origin[0] > 21.0, moved
    widget.Off()
    _wait_full(qtbot, viewer)
    clipped = _direct(viewer, clip_planes=(moved.origin, moved.normal))
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, clipped.rgba)
    viewer.actions_by_name["Clip plane"].trigger()
    assert not viewer.actions_by_name["Clip plane"].isChecked() and viewer.actor.renderer.options.clip_planes == ()
    _wait_full(qtbot, viewer)
    whole = _direct(viewer)
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, whole.rgba)
    assert np.abs(whole.rgba - clipped.rgba).max() > 0.05


def test_the_crop_box_from_the_menu_crops_to_it(qtbot, viewer):
    viewer.actions_by_name["Crop box"].trigger()
    assert viewer.actor.renderer.options.crop_box == pytest.approx((0, 39, 0, 23, 0, 23))
    viewer._crop_box.Off()
    viewer.actor.set_clip(None, (0, 20, 0, 23, 0, 23))  # as dragging the +x face to x = 20 sets it
    _wait_full(qtbot, viewer)
    np.testing.assert_array_equal(viewer.actor.hdr.rgba, _direct(viewer, crop_box=(0, 20, 0, 23, 0, 23)).rgba)
    viewer.actions_by_name["Crop box"].trigger()
    assert viewer.actor.renderer.options.crop_box is None
