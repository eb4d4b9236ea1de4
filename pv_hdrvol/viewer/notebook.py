"""The transfer-function editor and a live image as Jupyter widgets (ipywidgets).

``hv_editor = TransferFunctionEditor(grid)`` in a notebook cell shows:

- the image, re-rendered progressively (a coarse frame at once, the full frame after)
  on a worker thread when the camera or the function changes;
- camera sliders (azimuth, elevation, zoom) -- orbiting by dragging the image would
  need a mouse-event widget this package does not depend on;
- the editor's picture (histogram, opacity curve on a log axis, colour bar) and its
  controls: the selected opacity point's position and opacity (a log slider), add and
  remove points, undo and redo, colour presets, HSV interpolation, the log axis
  toggle, and a focus range magnified around the selected point;
- tone mapping: operator and exposure (the HDR render is kept: re-mapping renders
  nothing), and the global opacity on a log slider.

A :class:`~pv_hdrvol.MultiscaleVolume` (a store larger than memory) renders out of core:
live, coarse levels first and finer ones as their chunks arrive (the status says which
levels the frame drew, and whether it has converged); the histogram is its coarsest
level's.

Everything the widgets do goes through :class:`~pv_hdrvol.editor.model.TransferFunctionModel`
(:attr:`TransferFunctionEditor.model`) and
:class:`~pv_hdrvol.viewer.progressive.ProgressiveRenderer`: the same model the Qt
viewer edits, tested without a notebook. :meth:`TransferFunctionEditor.refresh`
renders synchronously (scripts, tests).
"""
from __future__ import annotations

import html
import io
import math
import threading

import numpy as np

from ..editor.model import PRESETS, TransferFunctionModel
from ..image.tonemap import EXPOSURE_PARAMETERS
from ..image.tonemap import tonemap as _tonemap
from ..rays.camera import Camera, fit_camera
from .progressive import ProgressiveRenderer, level_text

TONEMAPS = {name: EXPOSURE_PARAMETERS[name] for name in ("reinhard", "drago", "linear")}


def _png(rgb_u8):
    from ..image.io import write_png

    buffer = io.BytesIO()
    write_png(buffer, np.ascontiguousarray(rgb_u8))
    return buffer.getvalue()


def editor_picture(model, width=480, height=160):
    """The editor drawn as an RGB uint8 array (height, width, 3): histogram (grey),
    opacity curve (white) and points (yellow) on the model's axes, foci (olive), and
    the colour bar below (20 rows)."""
    strip = 20
    h = height - strip
    out = np.zeros((height, width, 3), dtype=np.uint8)
    out[:h] = (32, 32, 36)
    if model.magnified:
        for f in model.axis.foci:
            x0 = int(model.axis.forward(max(f.knots[1], 0.0)) * (width - 1))
            x1 = int(model.axis.forward(min(f.knots[2], 1.0)) * (width - 1))
            out[:h, x0:x1 + 1] = (70, 70, 40)
    hist = model.histogram()
    if hist is not None and hist[1].max() > 0:
        edges, counts = hist[0], np.log10(1.0 + hist[1])
        xs = model.axis.forward(edges) if model.magnified else edges
        columns = np.clip((xs * (width - 1)).astype(int), 0, width - 1)
        for i in np.nonzero(counts)[0]:
            top = h - int(round(counts[i] / counts.max() * (h - 1)))
            out[top:h, columns[i]:max(columns[i + 1], columns[i] + 1)] = (90, 90, 100)
    sx, sy = model.opacity_curve(width)
    rows = np.clip(((1.0 - sy) * (h - 1)).round().astype(int), 0, h - 1)
    for col in range(width):
        lo, hi = sorted((rows[col], rows[col - 1] if col else rows[col]))
        out[lo:hi + 1, col] = (240, 240, 240)
    values, opacities = model.opacity_points
    half = 2 if values.size <= 24 else 1  # many points (a sampled curve): small marks
    for v, a in zip(values, opacities):
        c = int(round(float(model.screen_x(v)) * (width - 1)))
        r = int(round((1.0 - float(model.opacity_axis.forward(a))) * (h - 1)))
        out[max(r - half, 0):r + half + 1, max(c - half, 0):c + half + 1] = (255, 200, 0)
    rgb = model.color_strip(width) ** (1 / 2.2)
    out[h:] = (np.clip(rgb, 0, 1) * 255).astype(np.uint8)[None]
    for v in model.color_points[0]:
        c = int(round(float(model.screen_x(v)) * (width - 1)))
        out[h:h + 5, max(c - 1, 0):c + 2] = (255, 255, 255)
    return out


class TransferFunctionEditor:
    """The editor and a live image as notebook widgets (see the module's docstring).

    Parameters
    ----------
    data : image volume or tetrahedral mesh
        What the editor's image renders: anything :func:`pv_hdrvol.render` takes.
    tf : TransferFunction, optional
        The function the editor starts from (default: the one ``pv_hdrvol.render``
        chooses for the data).
    size : (width, height)
        The image's size.
    live : bool
        Render on a worker thread as the widgets change (default). ``False``: only
        :meth:`refresh` renders (scripts, tests).
    scalars, preference
        Which array of a dataset, as :func:`pv_hdrvol.render`.
    **render_kwargs
        As :func:`pv_hdrvol.render`: render options (``precision=``...) and PyVista's
        ``cmap=``, ``clim=``, ``opacity=``, ``scale=``, which shape the default
        transfer function the editor starts from
        (:func:`~pv_hdrvol.raycast.grid.resolve_render_options`).

    Attributes
    ----------
    model : TransferFunctionModel
    widget : ipywidgets.VBox
        What the notebook shows (also shown by displaying this object).
    hdr : HDRImage or None
        The last render shown.
    """

    def __init__(self, data, tf=None, *, size=(512, 384), live=True, scalars=None, preference="point",
                 **render_kwargs):
        import ipywidgets as w

        self.size = (int(size[0]), int(size[1]))
        self.live = bool(live)
        self._lock = threading.Lock()
        # the renderer resolves tf, the transfer function's words and the options; the editor
        # starts from that function and renders what it holds
        self.renderer = ProgressiveRenderer(data, tf, on_frame=self._on_frame if live else None, scalars=scalars,
                                            preference=preference, **render_kwargs)
        self.model = TransferFunctionModel.for_data(self.renderer.data, self.renderer.tf,
                                                    global_alpha=self.renderer.options.global_alpha)
        self.renderer.set_scene(self.model.transfer_function())
        self._base = fit_camera(self.renderer.bounds, "iso")  # the dataset's bounds, as hv.render frames it
        self.hdr = self.level = None
        self.said = ()  # the renderer's warnings of the frame shown
        self.operator, self.exposure = "reinhard", 0.0
        # widgets
        # pixel for pixel: a fixed size, not stretched to the row beside it
        self.image = w.Image(format="png", layout=w.Layout(width=f"{self.size[0]}px", height=f"{self.size[1]}px",
                                                           min_width=f"{self.size[0]}px", object_fit="none"))
        self.curve = w.Image(format="png", layout=w.Layout(width="480px", height="160px", min_width="480px",
                                                           object_fit="none"))
        self.azimuth = w.FloatSlider(0.0, min=-180, max=180, step=1, description="azimuth")
        self.elevation = w.FloatSlider(0.0, min=-89, max=89, step=1, description="elevation")
        self.zoom = w.FloatLogSlider(1.0, base=10, min=-1, max=1, step=0.01, description="zoom")
        self.point = w.Dropdown(description="point")
        self.position = w.FloatSlider(0.5, min=0.0, max=1.0, step=0.001, description="position",
                                      readout_format=".3f")
        self.opacity = w.FloatLogSlider(0.1, base=10, min=-6, max=0, step=0.01, description="opacity")
        self.add = w.Button(description="add point")
        self.remove = w.Button(description="remove point")
        self.undo = w.Button(description="undo")
        self.redo = w.Button(description="redo")
        self.preset = w.Dropdown(options=["(colours)"] + list(PRESETS), description="colours")
        self.hsv = w.Checkbox(self.model.color_space == "hsv", description="HSV interpolation")
        self.log_axis = w.Checkbox(True, description="log opacity axis")
        self.focus = w.FloatSlider(1.0, min=1.0, max=16.0, step=0.5, description="magnify")
        self.global_alpha = w.FloatLogSlider(self.model.global_alpha, base=10, min=-4, max=0, step=0.01,
                                             description="global α")
        self.tone = w.Dropdown(options=list(TONEMAPS), value="reinhard", description="tone map")
        self.stops = w.FloatSlider(0.0, min=-10, max=10, step=0.25, description="exposure")
        self.status = w.HTML("")
        self._syncing = False
        self._sync_points()
        for slider in (self.azimuth, self.elevation, self.zoom):
            slider.observe(lambda change: self.request(), names="value")
        self.point.observe(lambda change: self._sync_point_sliders(), names="value")
        self.position.observe(self._point_moved, names="value")
        self.opacity.observe(self._point_moved, names="value")
        self.add.on_click(lambda b: self._add_point())
        self.remove.on_click(lambda b: self._remove_point())
        self.undo.on_click(lambda b: self.model.undo())
        self.redo.on_click(lambda b: self.model.redo())
        self.preset.observe(self._preset, names="value")
        self.hsv.observe(lambda c: self.model.set_color_space("hsv" if c["new"] else "rgb"), names="value")
        self.log_axis.observe(lambda c: self.model.set_display(opacity_scale="log" if c["new"] else "linear"),
                              names="value")
        self.focus.observe(self._focus, names="value")
        self.global_alpha.observe(lambda c: self.model.set_global_alpha(c["new"]), names="value")
        self.tone.observe(self._retone, names="value")
        self.stops.observe(self._retone, names="value")
        self.model.observe(self._model_changed)
        self.widget = w.VBox([
            w.HBox([self.image, w.VBox([self.azimuth, self.elevation, self.zoom, self.tone, self.stops,
                                        self.global_alpha, self.status])]),
            w.HBox([self.curve, w.VBox([self.point, self.position, self.opacity,
                                        w.HBox([self.add, self.remove]), w.HBox([self.undo, self.redo]),
                                        self.preset, self.hsv, self.log_axis, self.focus])]),
        ])
        self._draw_curve()
        if live:
            self.request()

    def _ipython_display_(self):
        from IPython.display import display

        display(self.widget)

    # -- the camera ------------------------------------------------------------------------
    def camera(self):
        """The camera of the sliders: the iso view turned by azimuth (about its view-up)
        and elevation, moved ``1 / zoom`` times as far."""
        base = self._base
        f = np.asarray(base.focal_point)
        v = np.asarray(base.position) - f
        up = np.asarray(base.view_up) / np.linalg.norm(base.view_up)
        v = _turn(v, up, self.azimuth.value)
        right = np.cross(v, up)
        v = _turn(v, right / np.linalg.norm(right), self.elevation.value)
        up2 = _turn(up, right / np.linalg.norm(right), self.elevation.value)
        return Camera(tuple(f + v / self.zoom.value), tuple(f), tuple(up2), view_angle=base.view_angle)

    # -- rendering -------------------------------------------------------------------------
    def request(self):
        """Render the present view and function (on the worker thread when live)."""
        if self.live:
            self.renderer.request(self.camera(), self.size)
        else:
            self.refresh()

    def refresh(self, coarse=False):
        """Render here, now: the full frame (and the coarse one first if ``coarse``, and
        out of core the refining ones); returns the full frame's HDRImage."""
        frames = self.renderer.frames(self.camera(), self.size, coarse=coarse, refine=coarse)
        for frame in frames:
            self._show(frame)
        return self.hdr

    def _on_frame(self, frame):  # worker thread: widget values may be set from here
        self._show(frame)

    def _show(self, frame):
        with self._lock:
            self.hdr, self.level = frame.image, frame.level
            # what the renderer warned (why the image is empty): said here, with the image
            self.said = tuple(dict.fromkeys(map(str, frame.warnings)))
        self._retone()

    def _retone(self, *_):
        self.operator, self.exposure = self.tone.value, self.stops.value
        hdr = self.hdr
        if hdr is None:
            return
        mapped = _tonemap(hdr, self.operator, **TONEMAPS[self.operator](self.exposure))
        self.picture = mapped.rgb8
        self.image.value = _png(self.picture)
        a = hdr.rgba[..., 3]
        self.status.value = (f"{self.level} frame, {hdr.metadata.get('render_seconds', 0.0):.2f} s; "
                             f"opacity max {float(a.max()):.3g}"
                             + (f"<br>{html.escape(level_text(hdr, self.level))}" if "levels" in hdr.metadata else "")
                             + "".join(f"<br>warning: {html.escape(message, quote=False)}" for message in self.said))

    # -- the model ---------------------------------------------------------------------------
    def _model_changed(self, what):
        if what in ("function", "global_alpha"):
            self.renderer.set_scene(self.model.transfer_function(), global_alpha=self.model.global_alpha)
            self._sync_points()
            if self.live:
                self.request()
        if what == "global_alpha" and not math.isclose(self.global_alpha.value, self.model.global_alpha):
            self._syncing = True
            self.global_alpha.value = self.model.global_alpha
            self._syncing = False
        self._draw_curve()

    def _draw_curve(self):
        self.curve.value = _png(editor_picture(self.model))

    def _sync_points(self):
        values, _ = self.model.opacity_points
        options = [(f"{i}: {v:.4g}", i) for i, v in enumerate(values)]
        self._syncing = True
        keep = self.point.value if self.point.value is not None and self.point.value < len(options) else \
            min(1, len(options) - 1)
        self.point.options = options
        self.point.value = keep
        self._syncing = False
        self._sync_point_sliders()

    def _sync_point_sliders(self):
        i = self.point.value
        if i is None:
            return
        values, opacities = self.model.opacity_points
        self._syncing = True
        self.position.value = float(self.model.to_axis(values[i]))
        self.opacity.value = max(float(opacities[i]), 1e-6)
        self._syncing = False

    def _point_moved(self, change):
        if self._syncing:
            return
        i = self.point.value
        n = self.model.opacity_points[0].size
        value = None
        if 0 < i < n - 1:
            values = self.model.opacity_points[0]
            lo, hi = self.model.to_axis(values[i - 1]), self.model.to_axis(values[i + 1])
            x = min(max(self.position.value, lo + 1e-6), hi - 1e-6)
            value = float(self.model.from_axis(x))
        opacity = self.opacity.value if self.opacity.value > 1.0001e-6 else 0.0
        try:
            self.model.move_opacity_point(i, value=value, opacity=opacity)
        except ValueError as error:
            self.status.value = str(error)

    def _add_point(self):
        values, _ = self.model.opacity_points
        i = self.point.value or 0
        j = min(i + 1, values.size - 1)
        middle = float(self.model.from_axis(0.5 * (self.model.to_axis(values[j - 1]) + self.model.to_axis(values[j]))))
        index = self.model.add_opacity_point(middle, float(self.model.transfer_function().opacity_at(middle)))
        self.point.value = index

    def _remove_point(self):
        try:
            self.model.remove_opacity_point(self.point.value)
        except ValueError as error:
            self.status.value = str(error)

    def _preset(self, change):
        if change["new"] in PRESETS:
            self.model.apply_colormap(change["new"])
            self.preset.value = "(colours)"

    def _focus(self, change):
        """One focus, 0.1 of the axis wide, around the selected point, magnified by the
        slider (1: none; lowered to what the screen holds)."""
        for i in range(len(self.model.axis.foci))[::-1]:
            self.model.remove_focus(i)
        if change["new"] > 1.0:
            x = float(self.position.value)
            self.model.add_focus(min(max(x, 0.075), 0.925), 0.1, change["new"])

    def close(self):
        self.renderer.close()
        self.widget.close()


def _turn(v, axis, degrees):
    a = math.radians(degrees)
    return v * math.cos(a) + np.cross(axis, v) * math.sin(a) + axis * np.dot(axis, v) * (1 - math.cos(a))

