"""The Qt viewer: ``pv-hdrvol view FILE`` and :func:`view` (issue 21, part 3).

A window built on pyvistaqt/qtpy: the volume in a PyVista scene
(:func:`~pv_hdrvol.viewer.scene.add_hdr_volume`, progressive: coarse while the
camera moves, full when it rests, renders on a worker thread so the window never
freezes), the focus+context transfer-function editor
(:class:`TransferFunctionEditorWidget`, a view over
:class:`~pv_hdrvol.editor.model.TransferFunctionModel`), tone-mapping controls (the
HDR render is kept: re-mapping is instant), a probe in the status bar (the HDR RGBA,
depth and data value under the cursor), a draggable magnifier lens, and saving to
EXR and PNG. Every action is in a menu with its shortcut; Help > Shortcuts lists them.

The widgets only draw the model and send it events; everything they do is a method
of the model or of the scene's actor, tested without a display.

A volume larger than memory (:class:`~pv_hdrvol.MultiscaleVolume`, ``pv-hdrvol view
store.ome.zarr``) renders out of core: coarse levels of detail while the camera moves,
finer ones as their chunks arrive when it rests, until converged; the status bar says
which levels the frame drew and how many chunks are loading. What the out-of-core path
cannot do yet is off, and says so: the magnifier lens (disabled), the probe's data value
(the HDR values and depth are shown), and the editor's histogram is that of the
coarsest level (the only values read without reading the volume).
"""
from __future__ import annotations

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets

from ..data.transfer import SCALES
from ..editor.model import (PRESETS, TransferFunctionModel, global_alpha_from_slider,
                            slider_from_global_alpha)
from ..image.tonemap import EXPOSURE_PARAMETERS
from ..rays.lenses import Magnifier
from .scene import add_hdr_volume

TONEMAPS = EXPOSURE_PARAMETERS
_PICK_RADIUS = 8  # pixels


class TransferFunctionEditorWidget(QtWidgets.QWidget):
    """Draws a :class:`TransferFunctionModel` and edits it with the mouse.

    - the opacity curve over the data's log-count histogram, with its points;
      drag a point (the ends move only up and down), click empty space to add one,
      right-click a point to remove it;
    - the colour bar below, with its points: drag one along the axis, double-click to
      pick its colour, click empty bar to add one, right-click to remove;
    - each colour point's intensity (its largest channel) as an orange diamond on the
      colour axis, over a dashed curve: drag it up or down to brighten or dim the
      colour (HDR emission up to 4 times the brightest point);
    - Shift+click the curve to magnify a focus range there (Shift+drag moves it, the
      wheel over it changes its magnification, Shift+right-click removes it);
    - keys: L log/linear opacity axis, C log/linear colour axis, M magnification on/off,
      Delete removes the selected point.
    """

    STRIP = 18  # colour bar height, pixels
    MARGIN = 6

    def __init__(self, model, parent=None):
        super().__init__(parent)
        self.model = model
        self.setMinimumSize(320, 160)
        self.setFocusPolicy(QtCore.Qt.StrongFocus)
        self.setMouseTracking(True)
        self._drag = None  # ("opacity" | "color" | "focus", index)
        self._gesture = None
        self.selected = None
        model.observe(lambda what: self.update())
        self.setToolTip("Drag points; click to add; right-click to remove; orange diamonds: colour intensity; "
                        "Shift+click to magnify a range; L: log opacity axis, C: log colour axis, M: magnification")

    # -- geometry ----------------------------------------------------------------------
    def _plot_rect(self):
        m = self.MARGIN
        return QtCore.QRectF(m, m, self.width() - 2 * m, self.height() - 3 * m - self.STRIP)

    def _strip_rect(self):
        r = self._plot_rect()
        return QtCore.QRectF(r.left(), r.bottom() + self.MARGIN, r.width(), self.STRIP)

    def to_widget(self, sx, sy):
        """Widget pixel of normalised screen ``(sx, sy)`` of the curve's area."""
        r = self._plot_rect()
        return r.left() + sx * r.width(), r.bottom() - sy * r.height()

    def from_widget(self, x, y):
        r = self._plot_rect()
        return (min(max((x - r.left()) / r.width(), 0.0), 1.0), min(max((r.bottom() - y) / r.height(), 0.0), 1.0))

    def color_intensity_position(self, index):
        """Widget pixel of colour point ``index``'s intensity (largest channel) on the colour axis."""
        v, c = self.model.color_points
        return self.to_widget(float(self.model.screen_x(v[index])),
                              float(self.model.color_axis.forward(c[index].max())))

    def opacity_point_position(self, index):
        """Widget pixel of opacity point ``index`` (for tests and tools)."""
        v, a = self.model.opacity_points
        return self.to_widget(float(self.model.screen_x(v[index])), float(self.model.opacity_axis.forward(a[index])))

    # -- drawing -------------------------------------------------------------------------
    def paintEvent(self, event):
        p = QtGui.QPainter(self)
        p.setRenderHint(QtGui.QPainter.Antialiasing)
        p.fillRect(self.rect(), QtGui.QColor(32, 32, 36))
        r = self._plot_rect()
        m = self.model
        # foci: the magnified ranges, shaded
        if m.magnified:
            for f in m.axis.foci:
                x0 = self.to_widget(float(m.axis.forward(max(f.knots[1], 0.0))), 0)[0]
                x1 = self.to_widget(float(m.axis.forward(min(f.knots[2], 1.0))), 0)[0]
                p.fillRect(QtCore.QRectF(x0, r.top(), x1 - x0, r.height()), QtGui.QColor(70, 70, 40))
        # histogram: log10(1 + count) per bin, drawn through the magnification
        hist = m.histogram()
        if hist is not None and hist[1].max() > 0:
            edges, counts = hist[0], np.log10(1.0 + hist[1])
            xs = m.axis.forward(edges) if m.magnified else edges
            top = counts.max()
            p.setPen(QtCore.Qt.NoPen)
            p.setBrush(QtGui.QColor(90, 90, 100))
            for i in np.nonzero(counts)[0]:
                x0 = r.left() + xs[i] * r.width()
                x1 = r.left() + xs[i + 1] * r.width()
                h = counts[i] / top * r.height()
                p.drawRect(QtCore.QRectF(x0, r.bottom() - h, max(x1 - x0, 1.0), h))
        # the opacity curve, sampled finely across the screen
        sx, sy = m.opacity_curve(max(int(r.width()), 2))
        path = QtGui.QPainterPath()
        for i, (x, y) in enumerate(zip(sx, sy)):
            px, py = self.to_widget(x, y)
            path.moveTo(px, py) if i == 0 else path.lineTo(px, py)
        p.setPen(QtGui.QPen(QtGui.QColor(240, 240, 240), 1.5))
        p.setBrush(QtCore.Qt.NoBrush)
        p.drawPath(path)
        # the colour's intensity (largest channel) on the colour axis, dashed, with its points
        cx, cy = m.color_intensity_curve(max(int(r.width()), 2))
        path = QtGui.QPainterPath()
        for i, (x, y) in enumerate(zip(cx, cy)):
            px, py = self.to_widget(x, y)
            path.moveTo(px, py) if i == 0 else path.lineTo(px, py)
        p.setPen(QtGui.QPen(QtGui.QColor(255, 150, 60), 1.0, QtCore.Qt.DashLine))
        p.drawPath(path)
        p.setPen(QtGui.QPen(QtGui.QColor(255, 150, 60), 1.0))
        for i in range(m.color_points[0].size):
            x, y = self.color_intensity_position(i)
            size = 4.0 if m.color_points[0].size <= 24 else 2.0
            p.setBrush(QtGui.QColor(255, 200, 0) if self.selected == ("intensity", i) else QtGui.QColor(255, 150, 60))
            p.drawPolygon(QtGui.QPolygonF([QtCore.QPointF(x, y - size), QtCore.QPointF(x + size, y),
                                           QtCore.QPointF(x, y + size), QtCore.QPointF(x - size, y)]))
        p.setPen(QtGui.QPen(QtGui.QColor(240, 240, 240), 1.5))
        for i in range(m.opacity_points[0].size):
            x, y = self.opacity_point_position(i)
            selected = self.selected == ("opacity", i)
            p.setBrush(QtGui.QColor(255, 200, 0) if selected else QtGui.QColor(255, 255, 255))
            p.drawEllipse(QtCore.QPointF(x, y), 4, 4)
        # the colour bar and its points
        s = self._strip_rect()
        n = max(int(s.width()), 2)
        rgb = np.ascontiguousarray((m.color_strip(n) ** (1 / 2.2) * 255).astype(np.uint8)[None].repeat(2, 0))
        image = QtGui.QImage(rgb.data, n, 2, 3 * n, QtGui.QImage.Format_RGB888)
        p.drawImage(s, image)
        values, colors = m.color_points
        half = 4 if values.size <= 24 else 1.5  # a colormap's many points: slim marks
        for i, v in enumerate(values):
            x = s.left() + float(m.screen_x(v)) * s.width()
            tri = QtGui.QPolygonF([QtCore.QPointF(x, s.top() + (0 if half > 2 else s.height() / 2)),
                                   QtCore.QPointF(x - half, s.bottom()), QtCore.QPointF(x + half, s.bottom())])
            p.setBrush(QtGui.QColor(255, 200, 0) if self.selected == ("color", i) else QtGui.QColor(255, 255, 255))
            p.drawPolygon(tri)
        p.end()

    # -- mouse ---------------------------------------------------------------------------
    def _in_strip(self, pos):
        return self._strip_rect().adjusted(0, -4, 0, 4).contains(pos)

    def _pick(self, pos):
        """``("opacity" | "intensity" | "color", index)`` under widget position ``pos``
        (opacity points first, then colour intensities), or None."""
        if self._in_strip(pos):
            s = self._strip_rect()
            i = self.model.pick_color_point((pos.x() - s.left()) / s.width(), radius=_PICK_RADIUS / s.width())
            return None if i is None else ("color", i)
        r = self._plot_rect()
        sx, sy = self.from_widget(pos.x(), pos.y())
        radius = _PICK_RADIUS / max(min(r.width(), r.height()), 1.0)
        i = self.model.pick_opacity_point(sx, sy, radius=radius)
        if i is not None:
            return ("opacity", i)
        i = self.model.pick_color_intensity(sx, sy, radius=radius)
        return None if i is None else ("intensity", i)

    def mousePressEvent(self, event):
        pos = _pos(event)
        shift = bool(event.modifiers() & QtCore.Qt.ShiftModifier)
        hit = self._pick(pos)
        sx, sy = self.from_widget(pos.x(), pos.y())
        if event.button() == QtCore.Qt.RightButton:
            if shift:
                self._remove_focus_at(sx)
            elif hit is not None:
                self._remove(hit)
            return
        if event.button() != QtCore.Qt.LeftButton:
            return
        if shift and not self._in_strip(pos):
            x = float(self.model.axis.inverse(sx)) if self.model.magnified else sx
            index = self._focus_at(sx)
            if index is None:
                index = self.model.add_focus(min(max(x, 0.05), 0.95), 0.1)
            self._drag = ("focus", index)
            return
        self._gesture = self.model.gesture()
        self._gesture.__enter__()
        try:
            if hit is None:
                value = float(self.model.value_at(sx))
                lo, hi = self.model.range
                if lo < value < hi:
                    if self._in_strip(pos):
                        hit = ("color", self.model.add_color_point(value))
                    else:
                        hit = ("opacity", self.model.add_opacity_point(value,
                                                                      float(self.model.opacity_axis.inverse(sy))))
        except ValueError:
            hit = None
        self.selected = self._drag = hit
        self.setFocus()
        self.update()

    def mouseMoveEvent(self, event):
        if self._drag is None:
            return
        pos = _pos(event)
        sx, sy = self.from_widget(pos.x(), pos.y())
        kind, index = self._drag
        m = self.model
        try:
            if kind == "focus":
                x = float(m.axis.inverse(sx)) if m.magnified else sx
                m.move_focus(index, centre=x)
            elif kind == "opacity":
                n = m.opacity_points[0].size
                value = None if index in (0, n - 1) else _between(m, m.opacity_points[0], index, sx)
                m.move_opacity_point(index, value=value, opacity=float(m.opacity_axis.inverse(sy)))
            elif kind == "intensity":  # up and down only: the colour's brightness, HDR above 1
                m.move_color_point(index, intensity=float(m.color_axis.inverse(sy)))
            else:
                n = m.color_points[0].size
                if index not in (0, n - 1):
                    m.move_color_point(index, value=_between(m, m.color_points[0], index, sx))
        except ValueError:
            pass  # a position the point cannot take: it stays where it was

    def mouseReleaseEvent(self, event):
        self._drag = None
        if self._gesture is not None:
            gesture, self._gesture = self._gesture, None
            gesture.__exit__(None, None, None)

    def mouseDoubleClickEvent(self, event):
        hit = self._pick(_pos(event))
        if hit is not None and hit[0] == "color":
            rgb = self.model.color_points[1][hit[1]]
            peak = max(float(rgb.max()), 1e-12)
            start = QtGui.QColor.fromRgbF(*(np.clip(rgb / max(peak, 1.0), 0, 1)))
            color = QtWidgets.QColorDialog.getColor(start, self, "Colour of the point")
            if color.isValid():
                new = np.array([color.redF(), color.greenF(), color.blueF()]) * max(peak, 1.0)
                self.model.move_color_point(hit[1], color=new)

    def wheelEvent(self, event):
        sx = self.from_widget(_pos(event).x(), 0)[0]
        index = self._focus_at(sx)
        if index is not None:
            f = self.model.axis.foci[index]
            factor = 1.25 if event.angleDelta().y() > 0 else 0.8
            self.model.move_focus(index, magnification=max(1.01, f.magnification * factor))

    def keyPressEvent(self, event):
        key = event.key()
        m = self.model
        if key == QtCore.Qt.Key_L:
            m.set_display(opacity_scale="linear" if m.opacity_axis.scale == "log" else "log")
        elif key == QtCore.Qt.Key_M:
            m.set_display(magnified=not m.magnified)
        elif key == QtCore.Qt.Key_C:
            m.set_display(color_scale="linear" if m.color_axis.scale == "log" else "log")
        elif key in (QtCore.Qt.Key_Delete, QtCore.Qt.Key_Backspace) and self.selected is not None:
            self._remove(self.selected)
        else:
            super().keyPressEvent(event)

    def _remove(self, hit):
        kind, index = hit
        try:
            (self.model.remove_opacity_point if kind == "opacity" else self.model.remove_color_point)(index)
        except ValueError:
            return  # an end point
        self.selected = None

    def _focus_at(self, sx):
        m = self.model
        for i, f in enumerate(m.axis.foci):
            lo, hi = (m.axis.forward(max(f.knots[0], 0.0)), m.axis.forward(min(f.knots[3], 1.0))) if m.magnified \
                else (f.knots[0], f.knots[3])
            if lo <= sx <= hi:
                return i
        return None

    def _remove_focus_at(self, sx):
        index = self._focus_at(sx)
        if index is not None:
            self.model.remove_focus(index)


def _between(model, values, index, sx):
    """The data value under ``sx``, kept strictly between the point's neighbours."""
    value = float(model.value_at(sx))
    lo, hi = values[index - 1], values[index + 1]
    span = hi - lo
    return min(max(value, lo + 1e-9 * span), hi - 1e-9 * span)


def _pos(event):
    return event.position() if hasattr(event, "position") else QtCore.QPointF(event.pos())


class ToneMapPanel(QtWidgets.QWidget):
    """Operator, exposure (stops) and global opacity (log slider) controls."""

    def __init__(self, viewer, parent=None):
        super().__init__(parent)
        self.viewer = viewer
        layout = QtWidgets.QFormLayout(self)
        self.operator = QtWidgets.QComboBox()
        self.operator.addItems(list(TONEMAPS))
        self.operator.setToolTip("Tone-mapping operator (the HDR render is kept: changing it renders nothing)")
        self.exposure = QtWidgets.QSlider(QtCore.Qt.Horizontal)
        self.exposure.setRange(-40, 40)  # quarter stops
        self.exposure.setToolTip("Exposure, in stops (quarter-stop steps)")
        self.alpha = QtWidgets.QSlider(QtCore.Qt.Horizontal)
        self.alpha.setRange(0, 1000)
        self.alpha.setValue(int(round(1000 * slider_from_global_alpha(viewer.model.global_alpha))))
        self.alpha.setToolTip("Global opacity, log scale from 1e-4 to 1")
        self.preset = QtWidgets.QComboBox()
        self.preset.addItems(["(colour preset)"] + list(PRESETS))
        self.scale = QtWidgets.QComboBox()
        self.scale.addItems(list(SCALES))
        self.scale.setCurrentText(viewer.model.scale)
        self.scale.setToolTip("The data axis the function interpolates on (changes the function between its points)")
        self.log_axis = QtWidgets.QCheckBox("log opacity axis (L)")
        self.log_axis.setChecked(viewer.model.opacity_axis.scale == "log")
        self.log_color = QtWidgets.QCheckBox("log colour axis (C)")
        self.log_color.setChecked(viewer.model.color_axis.scale == "log")
        self.magnify = QtWidgets.QCheckBox("magnify foci (M)")
        self.magnify.setChecked(viewer.model.magnified)
        self.hsv = QtWidgets.QCheckBox("HSV colour interpolation")
        self.hsv.setChecked(viewer.model.color_space == "hsv")
        layout.addRow("tone map", self.operator)
        layout.addRow("exposure", self.exposure)
        layout.addRow("global opacity", self.alpha)
        layout.addRow("colours", self.preset)
        layout.addRow("data axis", self.scale)
        layout.addRow(self.log_axis)
        layout.addRow(self.log_color)
        layout.addRow(self.magnify)
        layout.addRow(self.hsv)
        self.operator.currentTextChanged.connect(self._tonemap)
        self.exposure.valueChanged.connect(self._tonemap)
        self.alpha.valueChanged.connect(lambda v: viewer.model.set_global_alpha(global_alpha_from_slider(v / 1000)))
        self.preset.activated.connect(self._preset)
        self.scale.currentTextChanged.connect(self._scale)
        self.log_axis.toggled.connect(lambda on: viewer.model.set_display(opacity_scale="log" if on else "linear"))
        self.log_color.toggled.connect(lambda on: viewer.model.set_display(color_scale="log" if on else "linear"))
        self.magnify.toggled.connect(lambda on: viewer.model.set_display(magnified=on))
        self.hsv.toggled.connect(lambda on: viewer.model.set_color_space("hsv" if on else "rgb"))
        viewer.model.observe(self._sync)

    def _tonemap(self, *_):
        name = self.operator.currentText()
        stops = self.exposure.value() / 4.0
        self.viewer.actor.tonemap_params = {}
        self.viewer.actor.set_tonemap(name, **TONEMAPS[name](stops))

    def _preset(self, index):
        if index > 0:
            self.viewer.model.apply_colormap(self.preset.itemText(index))
            self.preset.setCurrentIndex(0)

    def _scale(self, name):
        m = self.viewer.model
        if name == m.scale:
            return
        try:
            m.set_scale(name)
        except ValueError as error:
            self.viewer.statusBar().showMessage(str(error), 8000)
            self.scale.blockSignals(True)
            self.scale.setCurrentText(m.scale)
            self.scale.blockSignals(False)

    def _sync(self, what):
        m = self.viewer.model
        if self.scale.currentText() != m.scale:
            self.scale.blockSignals(True)
            self.scale.setCurrentText(m.scale)
            self.scale.blockSignals(False)
        for box, on in ((self.log_axis, m.opacity_axis.scale == "log"), (self.log_color, m.color_axis.scale == "log"),
                        (self.magnify, m.magnified),
                        (self.hsv, m.color_space == "hsv")):
            if box.isChecked() != on:
                box.blockSignals(True)
                box.setChecked(on)
                box.blockSignals(False)
        position = int(round(1000 * slider_from_global_alpha(m.global_alpha)))
        if what == "global_alpha" and self.alpha.value() != position:
            self.alpha.blockSignals(True)
            self.alpha.setValue(position)
            self.alpha.blockSignals(False)


class HDRViewer(QtWidgets.QMainWindow):
    """The viewer window (see the module's docstring).

    Parameters
    ----------
    data : image volume or tetrahedral mesh
        Anything :func:`pv_hdrvol.render` takes.
    tf : TransferFunction, optional
        Default: the renderer's default for the data.
    title : str
    scalars, preference
        Which array of a dataset, as :func:`pv_hdrvol.render`.
    **render_kwargs
        As :func:`pv_hdrvol.render`: render options (``precision=``, ``step=``...) and
        PyVista's ``cmap=``, ``clim=``, ``opacity=``, ``scale=``, which shape the
        default transfer function the editor starts from
        (:func:`~pv_hdrvol.raycast.grid.resolve_render_options`).
    """

    def __init__(self, data, tf=None, *, title="pv_hdrvol", scalars=None, preference="point", **render_kwargs):
        from pyvistaqt import QtInteractor

        super().__init__()
        self.setWindowTitle(title)
        from ..outofcore.render import MultiscaleVolume

        #: whether the data is a MultiscaleVolume (rendered out of core: see the module)
        self.multiscale = isinstance(data, MultiscaleVolume)
        self.plotter = QtInteractor(self)
        self.setCentralWidget(self.plotter)
        self.plotter.set_background("black")
        # the editor beside the view is the colour bar (and its opacity), so no scalar bar. The
        # scene gets the dataset itself (blocks gathered or merged there, once), so that its box
        # and the view names frame the dataset's bounds, as hv.render does
        self.actor = add_hdr_volume(self.plotter, data, tf, progressive=True, show_scalar_bar=False,
                                    scalars=scalars, preference=preference, **render_kwargs)
        renderer = self.actor.renderer
        #: the volume or mesh rendered (a MultiscaleVolume as given)
        self.data = renderer.data
        # the editor starts from the function tf= or the words made, and renders what it holds
        self.model = TransferFunctionModel.for_data(self.data, renderer.tf, global_alpha=renderer.options.global_alpha)
        self.actor.set_transfer_function(self.model.transfer_function())
        self.plotter.view_isometric()
        self.editor = TransferFunctionEditorWidget(self.model)
        self.panel = ToneMapPanel(self)
        # out of core the histogram is the coarsest level's (all that is read without reading the volume)
        editor_title = "Transfer function (histogram of the coarsest level)" if self.multiscale else "Transfer function"
        for name, widget, area in ((editor_title, self.editor, QtCore.Qt.BottomDockWidgetArea),
                                   ("Display", self.panel, QtCore.Qt.RightDockWidgetArea)):
            dock = QtWidgets.QDockWidget(name, self)
            dock.setWidget(widget)
            self.addDockWidget(area, dock)
        self.probe_label = QtWidgets.QLabel("")
        self.statusBar().addWidget(self.probe_label, 1)
        #: the frame's levels of detail and loading state (out of core; empty in core)
        self.level_label = QtWidgets.QLabel("")
        self.statusBar().addPermanentWidget(self.level_label)
        self._level_timer = QtCore.QTimer(self)
        self._level_timer.timeout.connect(self._show_levels)
        if self.multiscale:
            self._level_timer.start(100)
        self.model.observe(self._model_changed)
        self.lens_mode = False
        self._lens_drag = False
        self._clip_plane = self._crop_box = None
        self._style = None
        self._make_actions()
        iren = self.plotter.iren.interactor
        iren.AddObserver("MouseMoveEvent", self._mouse_moved, 1.0)
        iren.AddObserver("LeftButtonPressEvent", self._lens_press, 2.0)
        iren.AddObserver("LeftButtonReleaseEvent", self._lens_release, 2.0)
        self.resize(1000, 760)

    # -- actions (menus with their shortcuts) ---------------------------------------------
    def _make_actions(self):
        menus = {}
        self.actions_by_name = {}
        spec = [
            ("File", "Save HDR image (EXR)...", "Ctrl+S", self.save_exr_dialog),
            ("File", "Save picture (PNG)...", "Ctrl+Shift+S", self.save_png_dialog),
            ("File", "Save transfer function...", "Ctrl+T", self.save_tf_dialog),
            ("File", "Load transfer function...", "Ctrl+O", self.load_tf_dialog),
            ("File", "Close", "Ctrl+W", self.close),
            ("Edit", "Undo", "Ctrl+Z", self.model.undo),
            ("Edit", "Redo", "Ctrl+Shift+Z", self.model.redo),
            ("View", "Magnifier lens", "Ctrl+L", self.toggle_lens),
            ("View", "Clip plane", "Ctrl+K", self.toggle_clip_plane),
            ("View", "Crop box", "Ctrl+B", self.toggle_crop_box),
            ("View", "Reset camera", "Ctrl+R", self._reset_camera),
            ("Help", "Shortcuts", "F1", self.show_shortcuts),
        ]
        for menu, text, keys, slot in spec:
            if menu not in menus:
                menus[menu] = self.menuBar().addMenu(menu)
            action = QtWidgets.QAction(text, self)
            action.setShortcut(QtGui.QKeySequence(keys))
            action.triggered.connect(lambda checked=False, slot=slot: slot())
            menus[menu].addAction(action)
            self.actions_by_name[text] = action
        for name in ("Magnifier lens", "Clip plane", "Crop box"):
            self.actions_by_name[name].setCheckable(True)
        if self.multiscale:
            lens = self.actions_by_name["Magnifier lens"]
            lens.setEnabled(False)
            lens.setText("Magnifier lens (in-core volumes only)")
        self._shortcut_text = "\n".join(f"{keys:14s} {text}" for _, text, keys, _ in spec) + (
            "\n\nEditor: drag points; click to add; right-click removes; double-click a colour point to pick its"
            " colour;\ndrag a colour's orange diamond up or down for its intensity (HDR above 1);\nShift+click"
            " magnifies a range (wheel: magnification); L log opacity axis; C log colour axis; M magnification;"
            " Delete"
            "\nView: drag to orbit, wheel to zoom; with the lens on, drag to move the lens; the clip plane keeps"
            " the side its arrow points to: drag the plane to move it, the arrow to turn it; drag the crop box's"
            " faces")

    def show_shortcuts(self):
        QtWidgets.QMessageBox.information(self, "Shortcuts", self._shortcut_text)

    def _reset_camera(self):
        self.plotter.view_isometric()

    # -- the model drives the render ------------------------------------------------------
    def _model_changed(self, what):
        if what in ("function", "global_alpha"):
            self.actor.set_transfer_function(self.model.transfer_function(), global_alpha=self.model.global_alpha)

    # -- probe ------------------------------------------------------------------------------
    def _event_pixel(self):
        x, y = self.plotter.iren.interactor.GetEventPosition()
        cols, rows = self.actor.scene.GetSize()
        return int(x), int(rows - 1 - y)

    def _mouse_moved(self, *_):
        col, row = self._event_pixel()
        if self.lens_mode and self._lens_drag:
            self._move_lens(col, row)
        found = self.actor.probe(col, row)
        if found is None:
            self.probe_label.setText("")
            return
        r, g, b, a = found["rgba"]
        text = f"({col}, {row})  HDR RGBA {r:.4g} {g:.4g} {b:.4g} {a:.4g}"
        if np.isfinite(found["depth"]):
            text += f"  depth {found['depth']:.4g}"
        if found["value"] is not None:
            text += f"  value {found['value']:.6g}"
        elif self.multiscale:
            text += "  (no data value out of core)"
        if found["level"] in ("coarse", "refining"):
            text += f"  ({found['level']})"
        self.probe_label.setText(text)

    def _show_levels(self):
        text = self.actor.status
        if self.actor.error is not None:
            text = f"render failed: {self.actor.error}"
        if self.level_label.text() != text:
            self.level_label.setText(text)

    # -- lens -------------------------------------------------------------------------------
    def toggle_lens(self, on=None):
        """Switch the magnifier lens on or off; while on, dragging in the view moves it."""
        from vtkmodules.vtkInteractionStyle import vtkInteractorStyleUser

        on = not self.lens_mode if on is None else bool(on)
        if on and self.actor.renderer.tets:
            self.statusBar().showMessage("the magnifier lens works on image volumes only", 8000)
            on = False
        elif on and self.multiscale:
            self.statusBar().showMessage("the magnifier lens works on in-core image volumes only (not yet out of "
                                         "core)", 8000)
            on = False
        self.lens_mode = on
        self.actions_by_name["Magnifier lens"].setChecked(on)
        iren = self.plotter.iren.interactor
        if on:
            self._style = iren.GetInteractorStyle()
            iren.SetInteractorStyle(vtkInteractorStyleUser())
            cols, rows = self.actor.scene.GetSize()
            self._move_lens(cols // 2, rows // 2)
        else:
            if self._style is not None:
                iren.SetInteractorStyle(self._style)
            self.actor.set_lens(None)

    def toggle_clip_plane(self, on=None):
        """Show or remove an interactive clipping plane through the volume's centre
        (``HDRVolumeActor.add_clip_plane_widget``): dragging it cuts the volume."""
        on = self._clip_plane is None if on is None else bool(on)
        if on and self._clip_plane is None:
            self._clip_plane = self.actor.add_clip_plane_widget("x")
        elif not on and self._clip_plane is not None:
            self.actor.remove_clip_widget(self._clip_plane)
            self._clip_plane = None
        self.actions_by_name["Clip plane"].setChecked(on)

    def toggle_crop_box(self, on=None):
        """Show or remove an interactive crop box around the volume
        (``HDRVolumeActor.add_crop_box_widget``): dragging its faces crops it."""
        on = self._crop_box is None if on is None else bool(on)
        if on and self._crop_box is None:
            self._crop_box = self.actor.add_crop_box_widget()
        elif not on and self._crop_box is not None:
            self.actor.remove_clip_widget(self._crop_box)
            self._crop_box = None
        self.actions_by_name["Crop box"].setChecked(on)

    def _move_lens(self, col, row):
        cols, rows = self.actor.scene.GetSize()
        radius = max(8.0, min(cols, rows) / 6.0)
        self.actor.set_lens(Magnifier(center=(float(col), float(row)), radius=radius, factor=2.5))

    def _lens_press(self, *_):
        if self.lens_mode:
            self._lens_drag = True
            self._move_lens(*self._event_pixel())

    def _lens_release(self, *_):
        self._lens_drag = False

    # -- saving -----------------------------------------------------------------------------
    def save_exr(self, path):
        """Write the last full render (the HDR image, not the screen) to ``path``."""
        if self.actor.hdr is None:
            raise ValueError("nothing rendered yet")
        self.actor.hdr.save(path)

    def save_png(self, path):
        """Write the picture shown (the composite, tone-mapped) to ``path``."""
        from ..image.io import write_png

        write_png(path, self.actor.composite)

    def _file_dialog(self, caption, pattern, save=True):
        get = QtWidgets.QFileDialog.getSaveFileName if save else QtWidgets.QFileDialog.getOpenFileName
        path, _ = get(self, caption, "", pattern)
        return path or None

    def save_exr_dialog(self):
        path = self._file_dialog("Save HDR image", "OpenEXR (*.exr)")
        if path:
            self.save_exr(path)

    def save_png_dialog(self):
        path = self._file_dialog("Save picture", "PNG (*.png)")
        if path:
            self.save_png(path)

    def save_tf_dialog(self):
        path = self._file_dialog("Save transfer function", "pv_hdrvol editor (*.json);;ParaView preset (*.json)")
        if path:
            self.model.save(path)

    def load_tf_dialog(self):
        path = self._file_dialog("Load transfer function", "JSON (*.json)", save=False)
        if path:
            # a ParaView preset is rescaled onto the data's range, as ParaView's ApplyPreset
            self.model.set_function(TransferFunctionModel.load(path, self.model._values).transfer_function())

    def closeEvent(self, event):
        self._level_timer.stop()
        self.actor.close()
        if self.multiscale:
            self.data.close()  # the loader threads and the chunk cache (made again if it is used again)
        self.plotter.close()
        super().closeEvent(event)


def view(data, tf=None, *, block=None, **kwargs):
    """Open :class:`HDRViewer` on ``data``. ``block`` (default: unless an IPython event
    loop runs Qt) runs the Qt event loop until the window closes. Returns the window."""
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    viewer = HDRViewer(data, tf, **kwargs)
    viewer.show()
    if block is None:
        block = not ipython_qt_loop()
    if block:
        app.exec_() if hasattr(app, "exec_") else app.exec()
    return viewer


def ipython_qt_loop():
    """Whether the code runs in an IPython kernel whose Qt event loop is on (``%gui qt``):
    a window then shows without ``exec()`` blocking the notebook."""
    import sys

    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    shell = ipython.get_ipython()
    return shell is not None and getattr(shell, "active_eventloop", None) in ("qt", "qt5", "qt6")
