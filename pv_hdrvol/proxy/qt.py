"""A Qt window exploring a proxy folder without its volume: ``pv-hdrvol proxy view
FOLDER``, ``hv.view("run042.proxy")``.

Sliders set each intensity interval's extinction scale (log, 0.01-10, and 0 at the
left end: removed), the view's azimuth and elevation (within what the proxies hold),
the enhancement; check boxes relight the image and switch to the depth layers (each
with its opacity) with proxy ambient occlusion. Every change synthesises a new image
(:meth:`ProxySet.synthesize`) shortly after the last slider event; the status bar says
how long it took. Needs qtpy and a Qt binding (``pip install 'pv_hdrvol[gui]'``).
"""
from __future__ import annotations

import math
import time

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets

from ..image.hdr import HDRImage
from ..params import Light
from .proxies import MAX_ROTATION, ProxySet, load_proxies

#: slider positions per decade of an interval's scale
STEPS_PER_DECADE = 100
#: slider steps of an interval's scale: position 0 is k = 0, then log10 k from -2 to 1 in
#: steps of 1 / STEPS_PER_DECADE, so that every power of ten, k = 1 (the proxies' own
#: render, where the window opens) above all, is a position of its own, exactly
SCALE_STEPS = 1 + 3 * STEPS_PER_DECADE
#: the light of "relight": from the upper left, in front (world direction from the camera frame)
LIGHT_FROM = (-1.0, 1.0, 1.0)


def slider_scale(position):
    """Extinction scale of an interval slider ``position`` (0..SCALE_STEPS)."""
    if position <= 0:
        return 0.0
    # an integer numerator: position 1 + 2 * STEPS_PER_DECADE is 10.0 ** 0.0 == 1.0, not 1 - 1e-16
    return 10.0 ** ((int(position) - 1 - 2 * STEPS_PER_DECADE) / STEPS_PER_DECADE)


def scale_position(k):
    """The slider position of scale ``k`` (nearest; 0 for 0)."""
    if k <= 0:
        return 0
    return int(round(1 + (math.log10(min(max(k, 0.01), 10.0)) + 2.0) * STEPS_PER_DECADE))


class ProxyViewer(QtWidgets.QMainWindow):
    """The window; ``proxies`` a :class:`ProxySet` or a proxy folder."""

    def __init__(self, proxies, title=None, parent=None):
        super().__init__(parent)
        self.proxies = proxies if isinstance(proxies, ProxySet) else load_proxies(proxies)
        p = self.proxies
        self.setWindowTitle(title or "pv_hdrvol proxies")
        self.image = None  # the last HDRImage
        self.error = None
        self.seconds = 0.0
        self._fitted = None
        self.picture = QtWidgets.QLabel()
        self.picture.setAlignment(QtCore.Qt.AlignCenter)
        self.picture.setMinimumSize(*p.size)
        controls = QtWidgets.QWidget()
        form = QtWidgets.QVBoxLayout(controls)

        box = QtWidgets.QGroupBox("opacity per interval (extinction x k; left end removes it)")
        grid = QtWidgets.QGridLayout(box)
        self.interval_sliders = []
        shown = p.atten.reshape(p.intervals, -1).sum(axis=1) > 0
        for i in range(p.intervals):
            s = QtWidgets.QSlider(QtCore.Qt.Horizontal)
            s.setRange(0, SCALE_STEPS)
            s.setValue(scale_position(1.0))
            s.setEnabled(bool(shown[i]) and p.model is not None)
            s.valueChanged.connect(self._changed)
            grid.addWidget(QtWidgets.QLabel(f"{i}: {p.edges[i]:.3g} .. {p.edges[i + 1]:.3g}"), i, 0)
            grid.addWidget(s, i, 1)
            self.interval_sliders.append(s)
        form.addWidget(box)

        limit = MAX_ROTATION["multi" if p.multi_perspective else "single"]
        if p.model is None:
            limit = 0.0
        box = QtWidgets.QGroupBox(f"view (up to {limit:g} degrees)")
        grid = QtWidgets.QGridLayout(box)
        self.azimuth, self.elevation = (QtWidgets.QSlider(QtCore.Qt.Horizontal) for _ in range(2))
        for row, (name, s) in enumerate((("azimuth", self.azimuth), ("elevation", self.elevation))):
            s.setRange(-int(limit), int(limit))
            s.setValue(0)
            s.valueChanged.connect(self._changed)
            grid.addWidget(QtWidgets.QLabel(name), row, 0)
            grid.addWidget(s, row, 1)
        form.addWidget(box)

        box = QtWidgets.QGroupBox("shading")
        grid = QtWidgets.QGridLayout(box)
        self.relight = QtWidgets.QCheckBox("relight (a light from the upper left)")
        self.enhance = QtWidgets.QSlider(QtCore.Qt.Horizontal)
        self.enhance.setRange(0, 100)
        self.layers = QtWidgets.QCheckBox("depth layers instead of the volume")
        self.layers.setEnabled(p.n_layers > 0)
        self.occlusion = QtWidgets.QCheckBox("proxy ambient occlusion (layers)")
        for w in (self.relight, self.layers, self.occlusion):
            w.toggled.connect(self._changed)
        self.enhance.valueChanged.connect(self._changed)
        grid.addWidget(self.relight, 0, 0, 1, 2)
        grid.addWidget(QtWidgets.QLabel("enhancement"), 1, 0)
        grid.addWidget(self.enhance, 1, 1)
        grid.addWidget(self.layers, 2, 0, 1, 2)
        grid.addWidget(self.occlusion, 3, 0, 1, 2)
        self.layer_sliders = []
        for j, iso in enumerate(p.isovalues):
            s = QtWidgets.QSlider(QtCore.Qt.Horizontal)
            s.setRange(0, 100)
            s.setValue(100 if j == p.n_layers - 1 else 40)
            s.valueChanged.connect(self._changed)
            grid.addWidget(QtWidgets.QLabel(f"layer {j} ({iso:.3g}) opacity"), 4 + j, 0)
            grid.addWidget(s, 4 + j, 1)
            self.layer_sliders.append(s)
        form.addWidget(box)
        save = QtWidgets.QPushButton("Save image...")
        save.clicked.connect(self._save_dialog)
        form.addWidget(save)
        form.addStretch(1)

        central = QtWidgets.QWidget()
        row = QtWidgets.QHBoxLayout(central)
        row.addWidget(self.picture, 1)
        scroll = QtWidgets.QScrollArea()
        scroll.setWidget(controls)
        scroll.setWidgetResizable(True)
        scroll.setMinimumWidth(380)
        row.addWidget(scroll)
        self.setCentralWidget(central)
        self._timer = QtCore.QTimer(self)
        self._timer.setSingleShot(True)
        self._timer.setInterval(30)
        self._timer.timeout.connect(self.update_image)
        self.update_image()

    # -- state --------------------------------------------------------------------
    def settings(self):
        """The keywords of :meth:`ProxySet.synthesize` the controls stand for."""
        p = self.proxies
        kw = {"opacity_scale": [slider_scale(s.value()) if s.isEnabled() else 1.0 for s in self.interval_sliders]}
        az, el = self.azimuth.value(), self.elevation.value()
        kw["rotate"] = (float(az), float(el)) if (az or el) else None
        if self.relight.isChecked():
            right, up, fwd = p.camera.basis()
            kw["light"] = Light(tuple((LIGHT_FROM[0] * right + LIGHT_FROM[1] * up - LIGHT_FROM[2] * fwd).tolist()))
        if self.layers.isChecked() and p.n_layers:
            colors = [(0.95, 0.75, 0.6), (1.0, 1.0, 0.95), (0.6, 0.8, 1.0), (0.8, 1.0, 0.6)]
            kw["layers"] = {j: (colors[j % len(colors)], s.value() / 100.0) for j, s in enumerate(self.layer_sliders)}
            kw.pop("opacity_scale")
            if self.occlusion.isChecked():
                kw["ambient_occlusion"] = 1.0
            if "light" not in kw:
                kw["light"] = Light()
        elif self.enhance.value():
            kw["enhance"] = self.enhance.value() / 100.0
        return kw

    def _changed(self, *_):
        self._timer.start()

    def update_image(self):
        """Synthesise and show the image of the current settings now."""
        t0 = time.perf_counter()
        try:
            self.image = self.proxies.synthesize(**self.settings())
            self.error = None
        except (ValueError, TypeError) as exc:  # e.g. no colour model: say so, keep the last picture
            self.error = str(exc)
            self.statusBar().showMessage(self.error)
            return
        self.seconds = time.perf_counter() - t0
        if self._fitted is None:
            self._fitted = HDRImage(np.asarray(self.proxies.rgba, dtype=np.float32)).tonemap("reinhard").fitted
        rgb = self.image.tonemap("reinhard", fitted=self._fitted).rgb8
        h, w = rgb.shape[:2]
        self._rgb = np.ascontiguousarray(rgb)
        qimage = QtGui.QImage(self._rgb.data, w, h, 3 * w, QtGui.QImage.Format_RGB888)
        self.picture.setPixmap(QtGui.QPixmap.fromImage(qimage))
        self.statusBar().showMessage(f"synthesised in {self.seconds * 1e3:.0f} ms from the proxies alone")

    def save(self, path):
        """Write the current image: ``.exr``/``.npy`` linear, ``.png`` tone-mapped as shown."""
        path = str(path)
        if path.lower().endswith(".png"):
            self.image.save_png(path)
        else:
            self.image.save(path)

    def _save_dialog(self):
        path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save image", "proxy.exr",
                                                        "OpenEXR (*.exr);;PNG (*.png)")
        if path:
            self.save(path)


def view(proxies, title=None, *, block=None):
    """Open a :class:`ProxyViewer` on a :class:`ProxySet` or proxy folder. ``block``
    (default: unless an IPython event loop runs Qt) runs the Qt event loop until the
    window closes. Returns the window."""
    from ..viewer.qt import ipython_qt_loop

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    window = ProxyViewer(proxies, title=title)
    window.show()
    if block is None:
        block = not ipython_qt_loop()
    if block:
        app.exec_() if hasattr(app, "exec_") else app.exec()
    return window
