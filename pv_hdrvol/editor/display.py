"""The transfer-function editor's display: how the model's function is drawn, never
the function itself.

The data axis is drawn through the function's scale (linear, log or symlog) and,
when magnification is on, through a focus+context magnification around focus ranges
(:class:`~pv_hdrvol.editor.axis.FocusContextAxis`); opacity and colour are drawn on
their own axes (:class:`~pv_hdrvol.editor.axis.ValueAxis`). :class:`EditorDisplay`
holds the screen mapping, the foci, picking and the sampled curves;
:class:`~pv_hdrvol.editor.model.TransferFunctionModel` is one, with the function and its
undo history.
"""
from __future__ import annotations

import numpy as np

from .._validate import as_int
from ..data.transfer import scale_inverse, scale_forward
from .axis import Focus, FocusContextAxis, ValueAxis


class EditorDisplay:
    """The drawing of an edited transfer function, in normalised screen coordinates
    (``x`` in [0, 1] across the editor, ``y`` in [0, 1] up the opacity or colour axis).

    What it draws from (the model provides them): ``range``, ``scale``, ``linthresh``,
    ``opacity_points``, ``color_points``, ``transfer_function()`` and ``_notify(what)``;
    what it keeps: ``axis`` (the foci), ``magnified``, ``opacity_axis`` and
    ``color_axis``. Changing the display calls ``_notify("display")``.
    """

    def to_axis(self, values):
        """Positions in [0, 1] of data ``values`` along the function's scaled axis."""
        b0, b1 = scale_forward(self.range, self.scale, self.linthresh)
        return np.clip((scale_forward(values, self.scale, self.linthresh) - b0) / (b1 - b0), 0.0, 1.0)

    def from_axis(self, x):
        """Data values at positions ``x`` in [0, 1] of the scaled axis."""
        b0, b1 = scale_forward(self.range, self.scale, self.linthresh)
        return scale_inverse(b0 + np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0) * (b1 - b0), self.scale,
                              self.linthresh)

    def screen_x(self, values):
        """Screen ``x`` in [0, 1] of data ``values`` (through the magnification when on)."""
        x = self.to_axis(values)
        return self.axis.forward(x) if self.magnified else x

    def value_at(self, sx):
        """Data values under screen ``x`` positions ``sx`` (the inverse of :meth:`screen_x`)."""
        sx = np.clip(np.asarray(sx, dtype=np.float64), 0.0, 1.0)
        return self.from_axis(self.axis.inverse(sx) if self.magnified else sx)

    def set_display(self, *, magnified=None, opacity_scale=None, color_scale=None, floor=None):
        """Switch the drawing: magnification on/off, ``"log"``/``"linear"`` opacity and
        colour axes, the log axes' ``floor``. The function does not change."""
        if magnified is not None:
            self.magnified = bool(magnified)
        o, c = self.opacity_axis, self.color_axis
        o_floor = o.floor if floor is None else floor
        c_floor = c.floor if floor is None else floor
        self.opacity_axis = ValueAxis(o.scale if opacity_scale is None else opacity_scale, floor=o_floor, top=o.top,
                                      snap=o.snap)
        self.color_axis = ValueAxis(c.scale if color_scale is None else color_scale, floor=c_floor, top=c.top,
                                    snap=c.snap)
        self._notify("display")

    def add_focus(self, centre, width=0.1, magnification=4.0, transition=None):
        """Magnify the screen-independent axis range ``[centre - width / 2, centre +
        width / 2]`` (positions in [0, 1] of the scaled axis) by ``magnification``. A
        focus overlapping another merges with it (the larger magnification); a
        magnification the screen cannot hold is lowered to the most it can. Returns the
        index of the focus."""
        new = Focus(centre, width, magnification, transition)
        foci = list(self.axis.foci)
        merged = True
        while merged:
            merged = False
            for f in foci:
                if f.knots[3] > new.knots[0] and new.knots[3] > f.knots[0]:
                    lo, hi = min(f.knots[1], new.knots[1]), max(f.knots[2], new.knots[2])
                    lo, hi = max(lo, 0.0), min(hi, 1.0)
                    new = Focus((lo + hi) / 2, hi - lo, max(f.magnification, new.magnification),
                                max(f.transition, new.transition))
                    foci.remove(f)
                    merged = True
                    break
        self.axis = self._fitted(foci, new)
        self._notify("display")
        return self.axis.foci.index(next(f for f in self.axis.foci if f.centre == new.centre))

    def _fitted(self, others, new):
        """The axis of ``others`` and ``new``, ``new``'s magnification lowered if the
        screen cannot hold it (``sum M_j W_j < 1``: at most 99 % of the screen)."""
        rest = FocusContextAxis(others)
        w_new = float(new.integral(1.0) - new.integral(0.0))
        used = float(np.dot([f.magnification for f in rest.foci], rest._w)) if rest.foci else 0.0
        most = (0.99 - used) / w_new
        if new.magnification > most:
            if most <= 1.0:
                raise ValueError(f"no room to magnify [{new.knots[1]:g}, {new.knots[2]:g}]: the other foci take "
                                 f"{used:.0%} of the screen (remove one or narrow this focus)")
            new = Focus(new.centre, new.width, most, new.transition)
        return FocusContextAxis(list(others) + [new])

    def move_focus(self, index, centre=None, width=None, magnification=None):
        """Change focus ``index`` (the foci in order along the axis)."""
        foci = list(self.axis.foci)
        index = as_int("index", index, low=0, high=len(foci) - 1) if foci else None
        if index is None:
            raise ValueError("there is no focus to move (add_focus() first)")
        f = foci.pop(index)
        width = f.width if width is None else width
        centre = f.centre if centre is None else min(max(float(centre), width / 2), 1.0 - width / 2)
        new = Focus(centre, width, f.magnification if magnification is None else magnification, f.transition
                    if width == f.width else None)
        self.axis = self._fitted(foci, new)
        self._notify("display")

    def remove_focus(self, index):
        foci = list(self.axis.foci)
        index = as_int("index", index, low=0, high=max(len(foci) - 1, 0))
        if not foci:
            raise ValueError("there is no focus to remove")
        foci.pop(index)
        self.axis = FocusContextAxis(foci)
        self._notify("display")

    def pick_opacity_point(self, sx, sy, radius=0.03):
        """The index of the opacity point nearest screen ``(sx, sy)`` within ``radius``
        (screen units), or ``None``."""
        v, a = self.opacity_points
        d = np.hypot(self.screen_x(v) - sx, self.opacity_axis.forward(a) - sy)
        i = int(np.argmin(d))
        return i if d[i] <= radius else None

    def pick_color_point(self, sx, radius=0.02):
        """The index of the colour point nearest screen ``x`` within ``radius``, or ``None``."""
        d = np.abs(self.screen_x(self.color_points[0]) - sx)
        i = int(np.argmin(d))
        return i if d[i] <= radius else None

    def pick_color_intensity(self, sx, sy, radius=0.03):
        """The index of the colour point whose intensity (largest channel, on the colour
        axis) is drawn nearest screen ``(sx, sy)`` within ``radius``, or ``None``."""
        v, c = self.color_points
        d = np.hypot(self.screen_x(v) - sx, self.color_axis.forward(c.max(axis=1)) - sy)
        i = int(np.argmin(d))
        return i if d[i] <= radius else None

    def color_intensity_curve(self, n=512):
        """The colour's intensity (largest channel) across the screen on the colour
        axis: ``(sx (n,), sy (n,))``."""
        n = as_int("n", n, low=2, high=1 << 20)
        sx = np.linspace(0.0, 1.0, n)
        return sx, self.color_axis.forward(self.transfer_function().color_at(self.value_at(sx)).max(axis=1))

    def opacity_curve(self, n=512):
        """The opacity drawn across the screen: ``(sx (n,), sy (n,))``, the function
        sampled at ``n`` evenly spaced screen positions (and so finely inside a focus)."""
        n = as_int("n", n, low=2, high=1 << 20)
        sx = np.linspace(0.0, 1.0, n)
        return sx, self.opacity_axis.forward(self.transfer_function().opacity_at(self.value_at(sx)))

    def color_strip(self, n=512):
        """The colours across the screen, ``(n, 3)`` linear RGB, for a colour bar
        (divided by the colour axis's top, so HDR emission fits a display)."""
        n = as_int("n", n, low=2, high=1 << 20)
        rgb = self.transfer_function().color_at(self.value_at(np.linspace(0.0, 1.0, n)))
        return np.clip(rgb / self.color_axis.top, 0.0, 1.0)


__all__ = ["EditorDisplay"]
