"""The transfer-function editor's model: what the Qt and notebook editors draw and edit
(HDR VolVis section 5; ../shared/notes/methods.md C.1.1-C.1.4), without a display.

Colour and opacity have control points of their own, as in ParaView's editor; the model
merges them into the one :class:`~pv_hdrvol.TransferFunction` the renderer uses, at
full table resolution. The data axis may be magnified around focus ranges
(:class:`~pv_hdrvol.editor.axis.FocusContextAxis`) and the opacity and colour axes
drawn on log scales (:class:`~pv_hdrvol.editor.axis.ValueAxis`): these change only the
drawing, never the function. Edits of the function can be undone and redone; a drag
is one edit (:meth:`TransferFunctionModel.gesture`).
"""
from __future__ import annotations

import contextlib
import json
import math
import os
from typing import NamedTuple

import numpy as np

from .._validate import as_choice, as_int, as_real
from ..data.transfer import (COLOR_SPACES, DEFAULT_TABLE_SIZE, SCALES, TransferFunction, TransferFunctionFamily,
                             scale_inverse, colormap_rgb, scale_forward)
from .axis import Focus, FocusContextAxis, ValueAxis
from .display import EditorDisplay
from .presets import (_export_points, _pick, _simplify, data_range, read_json, read_paraview_presets,
                      transfer_function_from_preset, write_paraview_presets)

#: Colormaps offered as presets (any matplotlib name works in :meth:`~TransferFunctionModel.apply_colormap`).
PRESETS = ("magma", "inferno", "viridis", "plasma", "cividis", "turbo", "coolwarm", "gray")
#: The global opacity's log slider spans this many decades below 1 (the paper's
#: examples use 0.5, 0.05 and 0.005).
GLOBAL_ALPHA_DECADES = 4
#: Undo keeps this many edits.
UNDO_DEPTH = 100
#: Control points whose removal changes the function by at most this (relative to the
#: largest colour, or in opacity) are dropped when a function is loaded.
SIMPLIFY_TOLERANCE = 1e-12
_FORMAT = "pv_hdrvol.transfer_function_editor"
#: the state's fields of each list of points
_LISTS = {"opacity": ("opacity_values", "opacities"), "colour": ("color_values", "colors")}


class _State(NamedTuple):
    """One version of the edited function (immutable: undo keeps these)."""

    color_values: tuple
    colors: tuple  # of (r, g, b)
    opacity_values: tuple
    opacities: tuple
    scale: str
    linthresh: float
    color_space: str
    global_alpha: float


def global_alpha_from_slider(position, decades=GLOBAL_ALPHA_DECADES):
    """The global opacity at ``position`` in [0, 1] of a log slider: ``10**(decades *
    (position - 1))`` (1 at the right end, ``10**-decades`` at the left)."""
    position = as_real("position", position, low=0.0, high=1.0)
    return 10.0 ** (decades * (position - 1.0))


def slider_from_global_alpha(alpha, decades=GLOBAL_ALPHA_DECADES):
    """The log slider's position of global opacity ``alpha`` (clipped to the slider)."""
    alpha = as_real("global_alpha", alpha, low=0.0, high=1.0, low_open=True)
    return min(max(1.0 + math.log10(alpha) / decades, 0.0), 1.0)


def coarsest_values(volume):
    """The values of a :class:`~pv_hdrvol.MultiscaleVolume`'s coarsest level, (z, y, x):
    what the editor's histogram and a preset's rescaling see of a volume larger than
    memory (the default transfer function is chosen from them too)."""
    return np.asarray(volume.store.read_level(volume.n_levels - 1))


class TransferFunctionModel(EditorDisplay):
    """The edited transfer function, its display axes and its undo history (the
    drawing: :class:`~pv_hdrvol.editor.display.EditorDisplay`).

    Parameters
    ----------
    tf : TransferFunction
        The function to start from (not a :class:`~pv_hdrvol.TransferFunctionFamily`).
        Its control points become both the colour and the opacity points; interior
        points that are linear interpolations of their neighbours are dropped (the
        function does not change, to 1e-12). Its table keeps its size if one was set,
        else has the full 65,536 entries, whatever the edits.
    values : array_like, optional
        The data, for the histogram behind the curve (non-finite values are ignored).
    global_alpha : float
        The render's global opacity multiplier, in (0, 1].
    bins : int
        Histogram bins over the data axis.

    Notes
    -----
    Screen coordinates are normalised: ``x`` in [0, 1] across the editor, ``y`` in
    [0, 1] up the opacity (or colour) axis. ``x`` of data value ``v`` is ``S(g(v))``:
    ``g`` maps the function's axis (linear, log or symlog) onto [0, 1], ``S`` is the
    focus+context magnification (identity when :attr:`magnified` is off).

    Examples
    --------
    >>> import pv_hdrvol as hv
    >>> model = hv.TransferFunctionModel(hv.TransferFunction.ramp(1e-3, 1e3, scale="log", cmap="gray"))
    >>> i = model.add_opacity_point(1.0, 0.25)
    >>> float(model.transfer_function().opacity_at(1.0))
    0.25
    >>> model.undo()
    True
    >>> float(model.transfer_function().opacity_at(1.0))
    0.5
    """

    def __init__(self, tf, values=None, *, global_alpha=1.0, bins=256):
        if isinstance(tf, TransferFunctionFamily):
            raise TypeError("the editor edits one TransferFunction; a TransferFunctionFamily is edited through its "
                            "bases (edit each basis, then TransferFunction.family(bases, k))")
        if not isinstance(tf, TransferFunction):
            raise TypeError(f"tf must be a TransferFunction; got {type(tf).__name__}")
        axis = scale_forward(tf.values, tf.scale, tf.linthresh)
        peak = max(float(tf.colors.max()), 1e-300)
        ci = _simplify(axis, tf.colors / peak, SIMPLIFY_TOLERANCE) if tf.color_space == "rgb" else \
            np.arange(axis.size)  # HSV interpolation is not linear in RGB: keep every point
        oi = _simplify(axis, tf.opacities, SIMPLIFY_TOLERANCE)
        self._state = _State(tuple(tf.values[ci].tolist()), tuple(map(tuple, tf.colors[ci].tolist())),
                             tuple(tf.values[oi].tolist()), tuple(tf.opacities[oi].tolist()), tf.scale,
                             float(tf.linthresh), tf.color_space,
                             as_real("global_alpha", global_alpha, low=0.0, high=1.0, low_open=True))
        #: the table's entries, the same for every edit (so an edit changes the table only
        #: where it changes the function): the given function's own size if it was set,
        #: else the full resolution, :data:`~pv_hdrvol.data.transfer.DEFAULT_TABLE_SIZE`
        self.table_size = DEFAULT_TABLE_SIZE if tf.table_size_auto else tf.table_size
        self._undo, self._redo = [], []
        self._gesture = None  # the state before a gesture's first edit, while one runs
        self._tf = None
        self._listeners = []
        self._values = None
        self._bins = as_int("bins", bins, low=2, high=1 << 16)
        self._histogram = None
        #: the display (never the function): foci, magnification on or off, opacity and colour axes
        self.axis = FocusContextAxis()
        self.magnified = True
        self.opacity_axis = ValueAxis("log")
        # emission may be raised 4x above the brightest point (HDR colours above 1)
        self.color_axis = ValueAxis("linear", top=4.0 * max(1.0, peak))
        if values is not None:
            self.set_data(values)

    @classmethod
    def for_data(cls, data, tf=None, **kwargs):
        """A model for an image volume or tetrahedral mesh (anything
        :func:`pv_hdrvol.render` takes): ``tf`` or the renderer's default transfer function
        for it, and the histogram of its values. A volume larger than memory
        (:class:`~pv_hdrvol.MultiscaleVolume`) gives the values of its coarsest level,
        the only ones read without reading the volume: the histogram's shape, not its
        counts."""
        from ..data.kinds import as_renderable
        from ..outofcore.render import MultiscaleVolume
        from ..raycast.grid import resolve_transfer_function

        if isinstance(data, MultiscaleVolume):
            tf = data.default_transfer_function() if tf is None else tf
            return cls(tf, coarsest_values(data), **kwargs)
        volume = as_renderable(data)
        return cls(resolve_transfer_function(volume, tf), np.asarray(volume.values), **kwargs)

    # -- observers --------------------------------------------------------------------
    def observe(self, callback):
        """Call ``callback(what)`` after every change: ``what`` is ``"function"`` (the
        transfer function), ``"global_alpha"``, ``"display"`` or ``"data"``. Returns
        ``callback`` (to pass to :meth:`unobserve`)."""
        if not callable(callback):
            raise TypeError(f"callback must be callable; got {type(callback).__name__}")
        self._listeners.append(callback)
        return callback

    def unobserve(self, callback):
        self._listeners.remove(callback)

    def _notify(self, what):
        for callback in list(self._listeners):
            callback(what)

    # -- the function -----------------------------------------------------------------
    scale = property(lambda self: self._state.scale, doc="The function's axis: linear, log or symlog.")
    linthresh = property(lambda self: self._state.linthresh, doc="A symlog axis's linear threshold.")
    color_space = property(lambda self: self._state.color_space, doc="Where colours interpolate: rgb or hsv.")
    global_alpha = property(lambda self: self._state.global_alpha, doc="The opacity's overall multiplier.")

    @property
    def range(self):
        """``(vmin, vmax)`` of the function, in data units."""
        return self._state.color_values[0], self._state.color_values[-1]

    @property
    def color_points(self):
        """``(values (n,), colors (n, 3))`` as float64 copies."""
        return np.array(self._state.color_values), np.array(self._state.colors, dtype=np.float64).reshape(-1, 3)

    @property
    def opacity_points(self):
        """``(values (n,), opacities (n,))`` as float64 copies."""
        return np.array(self._state.opacity_values), np.array(self._state.opacities)

    def transfer_function(self):
        """The edited :class:`~pv_hdrvol.TransferFunction` (a new object after each edit,
        the same object between edits). Colour and opacity points are merged: each list
        is interpolated at the other's points, as the function interpolates between
        them, so the merge changes nothing."""
        if self._tf is None:
            self._tf = self._build(self._state)
        return self._tf

    def _build(self, s):
        cv, cc = np.array(s.color_values), np.array(s.colors, dtype=np.float64).reshape(-1, 3)
        ov, oa = np.array(s.opacity_values), np.array(s.opacities)
        values = np.union1d(cv, ov)
        colour_only = TransferFunction(cv, cc, np.zeros(cv.size), scale=s.scale, linthresh=s.linthresh,
                                       color_space=s.color_space, table_size=256)
        colors = colour_only.color_at(values)
        colors[np.searchsorted(values, cv)] = cc  # the control points themselves, exactly
        axis = scale_forward(values, s.scale, s.linthresh)
        opacities = np.interp(axis, scale_forward(ov, s.scale, s.linthresh), oa)
        opacities[np.searchsorted(values, ov)] = oa
        return TransferFunction(values, np.maximum(colors, 0.0), np.clip(opacities, 0.0, 1.0), scale=s.scale,
                                linthresh=s.linthresh, color_space=s.color_space, table_size=self.table_size)

    # -- edits (undoable) -------------------------------------------------------------
    def _commit(self, state, what="function"):
        if state == self._state:
            return
        # built first: an edit the function cannot take raises here and changes nothing
        tf = self._build(state) if state[:7] != self._state[:7] else self._tf
        if self._gesture is None:
            self._undo.append(self._state)
            del self._undo[:-UNDO_DEPTH]
            self._redo.clear()
        self._state, self._tf = state, tf
        self._notify(what)

    @contextlib.contextmanager
    def gesture(self):
        """Group the edits made inside (a drag) into one undo step.

        >>> import pv_hdrvol as hv
        >>> model = TransferFunctionModel(hv.TransferFunction.ramp(0, 1, cmap="gray"))
        >>> with model.gesture():
        ...     for a in (0.2, 0.3, 0.4):
        ...         model.move_opacity_point(1, opacity=a)
        >>> model.undo()
        True
        >>> model.opacity_points[1].tolist()
        [0.0, 1.0]
        """
        if self._gesture is not None:  # nested: the outer gesture owns the undo step
            yield self
            return
        before = self._state
        self._gesture = before
        try:
            yield self
        finally:
            self._gesture = None
            if self._state != before:
                self._undo.append(before)
                del self._undo[:-UNDO_DEPTH]
                self._redo.clear()

    def undo(self):
        """Return to the function before the last edit (or gesture). Returns whether
        there was one."""
        if not self._undo:
            return False
        self._redo.append(self._state)
        self._restore(self._undo.pop())
        return True

    def redo(self):
        """Re-apply the last undone edit. Returns whether there was one."""
        if not self._redo:
            return False
        self._undo.append(self._state)
        self._restore(self._redo.pop())
        return True

    @property
    def can_undo(self):
        return bool(self._undo)

    @property
    def can_redo(self):
        return bool(self._redo)

    def _restore(self, state):
        function_changed = state[:7] != self._state[:7]
        alpha_changed = state.global_alpha != self._state.global_alpha
        self._state = state
        if function_changed:
            self._tf = None
            self._notify("function")
        if alpha_changed:
            self._notify("global_alpha")

    def _check_value(self, value, values, index=None):
        """``value`` as a float strictly inside the range and not on another point."""
        value = as_real("value", value)
        lo, hi = self.range
        if not lo < value < hi:
            raise ValueError(f"value must lie inside the function's range ({lo:g}, {hi:g}); got {value!r} (the end "
                             "points stay: set_range() moves them)")
        if index is not None:
            left, right = values[index - 1], values[index + 1]
            if not left < value < right:
                raise ValueError(f"point {index} must stay between its neighbours ({left:g}, {right:g}); got {value!r}")
        return value

    def add_opacity_point(self, value, opacity):
        """Add an opacity point at data ``value`` (inside the range); returns its index."""
        value = self._check_value(value, self._state.opacity_values)
        return self._insert("opacity", value, as_real("opacity", opacity, low=0.0, high=1.0))

    def move_opacity_point(self, index, value=None, opacity=None):
        """Move opacity point ``index`` to data ``value`` (between its neighbours; the end
        points keep theirs) and/or set its ``opacity``."""
        s = self._state
        n = len(s.opacity_values)
        index = as_int("index", index, low=0, high=n - 1)
        values, opacities = list(s.opacity_values), list(s.opacities)
        if value is not None:
            if index in (0, n - 1):
                raise ValueError("the end points of the opacity function keep their values; set_range() moves them")
            values[index] = self._check_value(value, s.opacity_values, index)
        if opacity is not None:
            opacities[index] = as_real("opacity", opacity, low=0.0, high=1.0)
        self._commit(s._replace(opacity_values=tuple(values), opacities=tuple(opacities)))

    def remove_opacity_point(self, index):
        """Remove an interior opacity point (the ends stay)."""
        self._remove("opacity", index)

    def _insert(self, kind, value, item):
        """Commit the state with point ``(value, item)`` added to the ``kind`` list
        (``value`` checked already); returns its index."""
        names = _LISTS[kind]
        s = self._state
        values, items = getattr(s, names[0]), getattr(s, names[1])
        if value in values:
            raise ValueError(f"a{'n' if kind == 'opacity' else ''} {kind} point already lies at {value!r}")
        i = int(np.searchsorted(values, value))
        self._commit(s._replace(**{names[0]: values[:i] + (value,) + values[i:],
                                   names[1]: items[:i] + (item,) + items[i:]}))
        return i

    def _remove(self, kind, index):
        names = _LISTS[kind]
        s = self._state
        values, items = getattr(s, names[0]), getattr(s, names[1])
        n = len(values)
        index = as_int("index", index, low=0, high=n - 1)
        if index in (0, n - 1):
            raise ValueError(f"the end points of the {kind} function cannot be removed; got index {index}")
        self._commit(s._replace(**{names[0]: values[:index] + values[index + 1:],
                                   names[1]: items[:index] + items[index + 1:]}))

    def add_color_point(self, value, color=None):
        """Add a colour point at data ``value``: ``color`` (linear RGB >= 0, may exceed 1),
        or the function's present colour there. Returns its index."""
        value = self._check_value(value, self._state.color_values)
        rgb = self._check_color(color) if color is not None else \
            tuple(self.transfer_function().color_at(np.array([value]))[0].tolist())
        return self._insert("colour", value, rgb)

    @staticmethod
    def _check_color(color):
        rgb = np.asarray(color, dtype=np.float64).reshape(-1)
        if rgb.shape != (3,) or not np.all(np.isfinite(rgb)) or np.any(rgb < 0):
            raise ValueError(f"color must be three finite values >= 0 (linear RGB); got {color!r}")
        return tuple(rgb.tolist())

    def move_color_point(self, index, value=None, color=None, intensity=None):
        """Move colour point ``index`` to data ``value`` (interior points), give it
        ``color``, or scale its colour to ``intensity`` (its largest channel; the hue and
        saturation stay: HDR emission brighter than 1 is allowed)."""
        s = self._state
        n = len(s.color_values)
        index = as_int("index", index, low=0, high=n - 1)
        values, colors = list(s.color_values), list(s.colors)
        if value is not None:
            if index in (0, n - 1):
                raise ValueError("the end points of the colour function keep their values; set_range() moves them")
            values[index] = self._check_value(value, s.color_values, index)
        if color is not None:
            colors[index] = self._check_color(color)
        if intensity is not None:
            intensity = as_real("intensity", intensity, low=0.0)
            rgb = np.array(colors[index])
            peak = rgb.max()
            colors[index] = tuple((rgb * (intensity / peak) if peak > 0 else np.full(3, intensity)).tolist())
        self._commit(s._replace(color_values=tuple(values), colors=tuple(colors)))

    def remove_color_point(self, index):
        """Remove an interior colour point (the ends stay)."""
        self._remove("colour", index)

    def set_range(self, vmin, vmax):
        """Stretch every point onto ``[vmin, vmax]``, keeping its place along the scaled
        axis (as ParaView's "rescale")."""
        vmin, vmax = as_real("vmin", vmin), as_real("vmax", vmax)
        if not vmax > vmin:
            raise ValueError(f"vmax must be > vmin; got vmin={vmin!r}, vmax={vmax!r}")
        s = self._state
        if s.scale == "log" and vmin <= 0:
            raise ValueError(f"scale='log' needs vmin > 0; got vmin={vmin!r}")
        self._commit(s._replace(color_values=self._rescaled(s.color_values, vmin, vmax, s),
                                opacity_values=self._rescaled(s.opacity_values, vmin, vmax, s)))

    @staticmethod
    def _rescaled(values, vmin, vmax, s):
        a = scale_forward(np.array(values), s.scale, s.linthresh)
        b0, b1 = scale_forward([vmin, vmax], s.scale, s.linthresh)
        out = scale_inverse(b0 + (a - a[0]) / (a[-1] - a[0]) * (b1 - b0), s.scale, s.linthresh)
        out[0], out[-1] = vmin, vmax
        return tuple(out.tolist())

    def set_scale(self, scale, linthresh=None):
        """Interpolate on another data axis (``linear``, ``log``, ``symlog``): this
        changes the function between its points (the points keep their data values)."""
        scale = as_choice("scale", scale, SCALES)
        s = self._state
        linthresh = s.linthresh if linthresh is None else as_real("linthresh", linthresh, low=0.0, low_open=True)
        if scale == "log" and s.color_values[0] <= 0:
            raise ValueError(f"scale='log' needs a positive range; the function starts at {s.color_values[0]!r} "
                             "(set_range() first)")
        self._commit(s._replace(scale=scale, linthresh=float(linthresh)))

    def set_color_space(self, color_space):
        """Interpolate colours in ``"rgb"`` or ``"hsv"`` (hue the short way round)."""
        self._commit(self._state._replace(color_space=as_choice("color_space", color_space, COLOR_SPACES)))

    def set_global_alpha(self, alpha):
        """The render's global opacity multiplier, in (0, 1] (undoable; the function's
        table does not change)."""
        alpha = as_real("global_alpha", alpha, low=0.0, high=1.0, low_open=True)
        self._commit(self._state._replace(global_alpha=alpha), "global_alpha")

    def apply_colormap(self, cmap, n_colors=32):
        """Replace the colour points by ``n_colors`` samples of a matplotlib colormap,
        evenly along the scaled axis (linear runs merged). The opacity stays."""
        n = as_int("n_colors", n_colors, low=2, high=4096)
        s = self._state
        b0, b1 = scale_forward(self.range, s.scale, s.linthresh)
        axis = np.linspace(b0, b1, n)
        values = scale_inverse(axis, s.scale, s.linthresh)
        values[0], values[-1] = self.range
        colors = colormap_rgb(cmap, np.linspace(0.0, 1.0, n))
        keep = _simplify(axis, colors, SIMPLIFY_TOLERANCE) if s.color_space == "rgb" else np.arange(n)
        self._commit(s._replace(color_values=tuple(values[keep].tolist()),
                                colors=tuple(map(tuple, colors[keep].tolist()))))

    def set_function(self, tf):
        """Replace the whole function by ``tf`` (undoable), e.g. a loaded one."""
        other = TransferFunctionModel(tf, global_alpha=self.global_alpha)
        self.table_size = other.table_size
        self._commit(other._state._replace(global_alpha=self.global_alpha))

    # -- the data's histogram ---------------------------------------------------------
    def set_data(self, values):
        """The data behind the curve: finite values are binned along the scaled axis."""
        v = np.asarray(getattr(values, "values", values))
        if v.dtype.kind not in "biuf":
            raise TypeError(f"values must be numeric; got dtype {v.dtype}")
        v = v.reshape(-1)
        self._values = v
        self._histogram = None
        self._notify("data")

    def histogram(self):
        """``(edges, counts, below, above)``: ``counts`` (int64, ``bins``) of the finite
        data in equal parts of the scaled axis (``edges``, ``bins + 1`` positions in [0,
        1]), and how many finite values lie below and above the range (a log axis puts
        values <= 0 below). ``None`` without data. Draw ``log10(1 + counts)``."""
        if self._values is None:
            return None
        key = (self.range, self.scale, self.linthresh)
        if self._histogram is None or self._histogram[0] != key:
            v = self._values
            b0, b1 = scale_forward(self.range, self.scale, self.linthresh)
            with np.errstate(invalid="ignore"):
                a = scale_forward(v[np.isfinite(v)], self.scale, self.linthresh)
            x = (a - b0) / (b1 - b0)
            inside = (x >= 0.0) & (x <= 1.0)
            counts = np.bincount(np.minimum((x[inside] * self._bins).astype(np.int64), self._bins - 1),
                                 minlength=self._bins)
            self._histogram = key, (np.linspace(0.0, 1.0, self._bins + 1), counts, int(np.sum(x < 0.0)),
                                    int(np.sum(x > 1.0)))
        return self._histogram[1]

    # -- saving ------------------------------------------------------------------------
    def to_dict(self):
        """The editor's state as plain values (JSON): the colour and opacity points as
        edited, axis, colour space, global opacity, table size, and the display (foci,
        axes). :meth:`from_dict` restores it; floats survive JSON exactly."""
        s = self._state
        return {
            "format": _FORMAT, "version": 1,
            "color_points": {"values": list(s.color_values), "colors": [list(c) for c in s.colors]},
            "opacity_points": {"values": list(s.opacity_values), "opacities": list(s.opacities)},
            "scale": s.scale, "linthresh": s.linthresh, "color_space": s.color_space,
            "global_alpha": s.global_alpha, "table_size": self.table_size,
            "display": {
                "magnified": self.magnified,
                "foci": [{"centre": f.centre, "width": f.width, "magnification": f.magnification,
                          "transition": f.transition} for f in self.axis.foci],
                "opacity_axis": {"scale": self.opacity_axis.scale, "floor": self.opacity_axis.floor},
                "color_axis": {"scale": self.color_axis.scale, "floor": self.color_axis.floor,
                               "top": self.color_axis.top},
            },
        }

    @classmethod
    def from_dict(cls, data, values=None):
        """The model of :meth:`to_dict`'s form. A plain transfer function's dict
        (:meth:`TransferFunction.to_dict`) is accepted too."""
        if not hasattr(data, "keys"):
            raise TypeError(f"expected a dict; got {type(data).__name__}")
        if data.get("format") != _FORMAT:
            return cls(TransferFunction.from_dict(data), values)
        if data.get("version") != 1:
            raise ValueError(f"unknown editor file version {data.get('version')!r}; this version reads 1")
        try:
            cp, op = data["color_points"], data["opacity_points"]
            state = _State(tuple(map(float, cp["values"])), tuple(tuple(map(float, c)) for c in cp["colors"]),
                           tuple(map(float, op["values"])), tuple(map(float, op["opacities"])), str(data["scale"]),
                           float(data["linthresh"]), str(data["color_space"]), float(data["global_alpha"]))
            display = data.get("display", {})
        except (KeyError, TypeError) as error:
            raise ValueError(f"not a valid editor file: {error!r}") from None
        if state.color_values[0] != state.opacity_values[0] or state.color_values[-1] != state.opacity_values[-1]:
            raise ValueError("the colour and opacity points must share their end values")
        table_size = data.get("table_size")
        model = cls(TransferFunction(state.color_values, state.colors, np.zeros(len(state.color_values)),
                                     scale=state.scale, linthresh=state.linthresh, color_space=state.color_space,
                                     table_size=table_size), values, global_alpha=state.global_alpha)
        model._state = state
        model.transfer_function()  # validates the whole state
        model.magnified = bool(display.get("magnified", True))
        model.axis = FocusContextAxis([Focus(**f) for f in display.get("foci", [])])
        if "opacity_axis" in display:
            model.opacity_axis = ValueAxis(**display["opacity_axis"])
        if "color_axis" in display:
            model.color_axis = ValueAxis(**display["color_axis"])
        return model

    def save(self, path):
        """Write :meth:`to_dict` as JSON to ``path``."""
        with open(os.fspath(path), "w", encoding="utf-8") as fh:
            json.dump(self.to_dict(), fh, indent=1)

    @classmethod
    def load(cls, path, values=None, *, rescale=None):
        """Read a file written by :meth:`save`, a transfer function's JSON, or a
        ParaView preset file (a JSON list: its first preset, ``rescale`` as
        :meth:`from_paraview_preset`: onto ``values``' range by default).

        Raises
        ------
        FileNotFoundError
            No file at ``path``.
        ValueError
            The file is not JSON (truncated, say) or not one of those; the message
            names it.
        """
        data = read_json(path, "truncated or not a transfer function file: save it again")
        if isinstance(data, list):
            first = data[0] if data and hasattr(data[0], "get") else {}
            return cls.from_paraview_preset(data, first.get("Name"), values, rescale=rescale)
        return cls.from_dict(data, values)

    def save_paraview_preset(self, path, name="pv_hdrvol"):
        """Write the function as a ParaView preset file (see
        :mod:`pv_hdrvol.editor.presets`; ParaView: ``ImportPresets(path)``)."""
        write_paraview_presets(path, paraview_preset(self, name))

    @classmethod
    def from_paraview_preset(cls, source, name=None, values=None, *, rescale=None):
        """The model of ParaView preset ``name`` in ``source`` (a preset file, its JSON
        text, a dict or a list of dicts; ``name`` may be omitted when it holds one).
        A preset written by :meth:`save_paraview_preset` and not edited since comes back
        exactly; ParaView's own presets on a linear axis (see
        :mod:`pv_hdrvol.editor.presets`).

        ``rescale``: ParaView stores its presets on 0--1 (or -1--1) and rescales them to
        the data on ``ApplyPreset``; so does the default, ``None``: a ParaView preset is
        mapped onto the finite range of ``values`` (kept as stored without ``values``),
        while a preset written by :meth:`save_paraview_preset` keeps its own range (it is
        in data units already). ``True``: rescale any preset onto ``values``' range;
        ``False``: keep the stored range; ``(low, high)``: rescale onto that range.
        """
        preset = _pick(read_paraview_presets(source), name)
        if rescale is None or isinstance(rescale, (bool, np.bool_)):
            if rescale is False or (rescale is None and (values is None or _own_state(preset) is not None)):
                target = None
            elif values is None:
                raise ValueError("rescale=True rescales the preset onto the data's range: pass values (the data), "
                                 "or rescale=(low, high)")
            else:
                target = data_range(values)
        else:
            target = rescale
        tf, stored = transfer_function_from_preset(preset, rescale=target)
        state = None if stored is None else _own_state(preset)
        return cls.from_dict(state, values) if state is not None else cls(tf, values)

    def __repr__(self):
        s = self._state
        return (f"TransferFunctionModel({len(s.color_values)} colour points, {len(s.opacity_values)} opacity points, "
                f"range [{s.color_values[0]:.6g}, {s.color_values[-1]:.6g}], scale={s.scale!r}, "
                f"global_alpha={s.global_alpha:g}, foci={len(self.axis.foci)})")


def paraview_preset(source, name="pv_hdrvol"):
    """``source`` (a :class:`~pv_hdrvol.TransferFunction` or a
    :class:`TransferFunctionModel`) as one ParaView preset dict (see
    :mod:`pv_hdrvol.editor.presets` for the format and the accuracy on log axes); the
    editor's state rides along under ``pv_hdrvol``."""
    if isinstance(source, TransferFunctionModel):
        model = source
    elif isinstance(source, TransferFunction):
        model = TransferFunctionModel(source)
    else:
        raise TypeError(f"expected a TransferFunction or TransferFunctionModel; got {type(source).__name__}")
    if not isinstance(name, str) or not name:
        raise TypeError(f"name must be a non-empty string; got {name!r}")
    tf = model.transfer_function()
    if tf.scale == "linear":
        # the colour and opacity points as edited, each list on its own (as ParaView keeps them)
        cx, cc = model.color_points
        ox, oa = model.opacity_points
    else:
        x = _export_points(tf)
        cx, cc, ox, oa = x, tf.color_at(x), x, tf.opacity_at(x)
    peak = float(cc.max())
    if peak > 1.0:
        cc = cc / peak
    space = "HSV" if tf.color_space == "hsv" and tf.scale == "linear" else "RGB"
    preset = {
        "Name": name,
        "ColorSpace": space,
        "RGBPoints": np.column_stack([cx, cc]).reshape(-1).tolist(),
        "Points": np.column_stack([ox, oa, np.full(ox.size, 0.5), np.zeros(ox.size)]).reshape(-1).tolist(),
        "pv_hdrvol": model.to_dict(),
    }
    return preset


def _own_state(preset):
    """The editor state this package stored in ``preset``, if the preset's points are
    still the ones written from it (not edited since, in ParaView or by hand)."""
    state = preset.get("pv_hdrvol")
    if not hasattr(state, "keys"):
        return None
    try:
        again = paraview_preset(TransferFunctionModel.from_dict(state), preset.get("Name") or "x")
    except (TypeError, ValueError):
        return None
    same = all(np.array_equal(np.asarray(again[k], dtype=np.float64),
                              np.asarray(preset.get(k, []), dtype=np.float64)) for k in ("RGBPoints", "Points"))
    return state if same and again["ColorSpace"] == preset.get("ColorSpace", "RGB") else None
