"""Focus+context magnification of a transfer-function editor's data axis
(HDR VolVis, Yuan, Nguyen, Chen, Yan, Hu 2005, section 5 and Eq. 2;
../shared/notes/methods.md C.1.2).

The axis, normalised to [0, 1], is drawn on a screen of width 1. Focus ranges are
magnified by their factor ``M_j > 1``; across a transition on each side of a focus the
magnification falls linearly to the context's ``M_min``; the context takes what is
left, so the whole axis still fills the screen:

    M(x) = M_min + sum_j (M_j - M_min) w_j(x),      S(x) = int_0^x M(u) du,   S(1) = 1,

with ``w_j`` the focus's trapezoid (1 on the focus, linear ramps on the transitions,
0 elsewhere, clipped to [0, 1]) and ``W_j = int_0^1 w_j``:

    M_min = (1 - sum_j M_j W_j) / (1 - sum_j W_j).

This is exact for several foci and for transitions clipped at the axis's ends; with
one unclipped focus it is the paper's ``M_tr = (M_min + M_c) / 2`` shortcut. ``S`` maps
data to screen, :meth:`FocusContextAxis.inverse` maps screen (a mouse position) back
to data, in closed form.
"""
from __future__ import annotations

import numpy as np

from .._validate import as_real


class Focus:
    """One magnified range of the normalised axis.

    Parameters
    ----------
    centre, width : float
        The focus range ``[centre - width / 2, centre + width / 2]`` (within [0, 1]).
    magnification : float
        ``M_c > 1`` (default 4, as the paper's examples).
    transition : float, optional
        Width of the linear transition on each side (default ``width / 2``); ``0`` gives
        a step.
    """

    def __init__(self, centre, width, magnification=4.0, transition=None):
        self.centre = as_real("centre", centre, low=0.0, high=1.0)
        self.width = as_real("width", width, low=0.0, high=1.0, low_open=True)
        self.magnification = as_real("magnification", magnification, low=1.0, low_open=True)
        if self.centre - self.width / 2 < 0.0 or self.centre + self.width / 2 > 1.0:
            raise ValueError(f"the focus [{self.centre - self.width / 2:g}, {self.centre + self.width / 2:g}] must lie "
                             "within the axis [0, 1]")
        self.transition = (self.width / 2 if transition is None
                           else as_real("transition", transition, low=0.0, high=1.0))

    @property
    def knots(self):
        """``(a, b, c, d)``: the support starts at ``a``, the plateau spans ``[b, c]``,
        the support ends at ``d`` (not clipped)."""
        h = self.width / 2
        return (self.centre - h - self.transition, self.centre - h, self.centre + h, self.centre + h + self.transition)

    def weight(self, x):
        """``w(x)``: 1 on the focus, linear across the transitions, 0 elsewhere."""
        a, b, c, d = self.knots
        x = np.asarray(x, dtype=np.float64)
        t = self.transition
        if t == 0.0:
            return ((x >= b) & (x <= c)).astype(np.float64)
        return np.clip(np.minimum((x - a) / t, (d - x) / t), 0.0, 1.0)

    def integral(self, x):
        """``int_{-inf}^x w(u) du`` of the unclipped trapezoid."""
        a, b, c, d = self.knots
        t = self.transition
        x = np.asarray(x, dtype=np.float64)
        out = np.clip(x, b, c) - b  # the plateau
        if t > 0:
            out = out + (np.clip(x, a, b) - a) ** 2 / (2 * t)  # the rise: t / 2 once past b
            out = out + t / 2 - (d - np.clip(x, c, d)) ** 2 / (2 * t)  # the fall: 0 before c
        return out

    def __repr__(self):
        return (f"Focus(centre={self.centre!r}, width={self.width!r}, magnification={self.magnification!r}, "
                f"transition={self.transition!r})")


class FocusContextAxis:
    """The screen mapping of an axis with focus ranges (see the module's docstring).

    Parameters
    ----------
    foci : sequence of Focus
        Their supports (focus and transitions) must not overlap: merge overlapping
        foci first. No foci: the identity.

    Raises
    ------
    ValueError
        If the foci overlap, or magnify more than the screen holds
        (``sum_j M_j W_j >= 1`` would leave the context no room: ``M_min <= 0``).

    Examples
    --------
    The worked example of methods.md C.1.2: a focus of width 0.1 magnified 4 times,
    transitions of 0.05: ``M_min = 0.4 / 0.85``.

    >>> axis = FocusContextAxis([Focus(0.5, 0.1, 4.0, transition=0.05)])
    >>> round(axis.m_min, 6)
    0.470588
    >>> float(axis.forward(1.0))
    1.0
    """

    def __init__(self, foci=()):
        foci = list(foci)
        for i, f in enumerate(foci):
            if not isinstance(f, Focus):
                raise TypeError(f"foci[{i}] must be a Focus; got {type(f).__name__}")
        foci.sort(key=lambda f: f.centre)
        for f, g in zip(foci, foci[1:]):
            if f.knots[3] > g.knots[0]:
                raise ValueError(f"foci must not overlap (transitions included): {f!r} reaches {f.knots[3]:g}, "
                                 f"{g!r} starts at {g.knots[0]:g}")
        self.foci = tuple(foci)
        self._w = np.array([float(f.integral(1.0) - f.integral(0.0)) for f in foci])
        m = np.array([f.magnification for f in foci])
        used = float(m @ self._w)
        if used >= 1.0:
            raise ValueError(f"the foci magnify more than the axis holds: sum of magnification x weighted width = "
                             f"{used:.4g} must be < 1 (lower a magnification or narrow a focus)")
        self.m_min = (1.0 - used) / (1.0 - float(self._w.sum()))
        knots = [0.0, 1.0] + [min(max(k, 0.0), 1.0) for f in foci for k in f.knots]
        self._x = np.unique(np.array(knots))
        self._s = self.forward(self._x)
        # M is linear on each segment between knots: its value just inside the segment's
        # start and its slope, from two interior points (the ends may be steps)
        x0, x1 = self._x[:-1], self._x[1:]
        q1, q3 = x0 + 0.25 * (x1 - x0), x0 + 0.75 * (x1 - x0)
        m1, m3 = self.magnification(q1), self.magnification(q3)
        self._slope = (m3 - m1) / (q3 - q1)
        self._m0 = m1 - self._slope * (q1 - x0)

    def magnification(self, x):
        """``M(x)`` for data positions ``x`` in [0, 1]."""
        x = np.asarray(x, dtype=np.float64)
        out = np.full(x.shape, self.m_min)
        for f in self.foci:
            out = out + (f.magnification - self.m_min) * f.weight(x)
        return out

    def forward(self, x):
        """``S(x)``: screen positions (in [0, 1]) of data positions ``x`` in [0, 1]."""
        x = np.asarray(x, dtype=np.float64)
        out = self.m_min * x
        for f in self.foci:
            out = out + (f.magnification - self.m_min) * (f.integral(x) - f.integral(0.0))
        return out

    def inverse(self, s):
        """``S^{-1}(s)``: data positions of screen positions ``s`` in [0, 1] (closed form:
        ``S`` is linear on foci and context and quadratic on transitions)."""
        s = np.asarray(s, dtype=np.float64)
        k = np.clip(np.searchsorted(self._s, s, side="right") - 1, 0, self._x.size - 2)
        x0, x1, s0, m0, slope = self._x[k], self._x[k + 1], self._s[k], self._m0[k], self._slope[k]
        r = s - s0
        # slope / 2 u^2 + m0 u - r = 0, the root in the stable form
        u = 2.0 * r / (m0 + np.sqrt(np.maximum(m0 * m0 + 2.0 * slope * r, 0.0)))
        return np.clip(x0 + u, x0, x1)

    def __repr__(self):
        return f"FocusContextAxis({list(self.foci)!r}, m_min={self.m_min!r})"


class ValueAxis:
    """The editor's vertical axis for opacity or colour (HDR VolVis section 5;
    methods.md C.1.3): logarithmic by default, so values near zero can be edited, or
    linear. Only the display changes: the transfer function's values are kept as set.

    Parameters
    ----------
    scale : {"log", "linear"}
    floor : float
        The smallest value the log axis shows (default 1e-6: six decades below ``top``).
    top : float
        The value at the top of the axis (1 for opacity; the HDR maximum for colour).
    snap : float
        Screen height of the band at the bottom of a log axis that means exactly 0.

    Examples
    --------
    >>> axis = ValueAxis("log", floor=1e-6, top=1.0)
    >>> [round(float(v), 6) for v in axis.forward([1e-6, 1e-3, 1.0])]
    [0.0, 0.5, 1.0]
    >>> float(axis.inverse(0.5)), float(axis.inverse(0.0))
    (0.001, 0.0)
    """

    def __init__(self, scale="log", *, floor=1e-6, top=1.0, snap=0.02):
        from .._validate import as_choice

        self.scale = as_choice("scale", scale, ("log", "linear"))
        self.top = as_real("top", top, low=0.0, low_open=True)
        self.floor = as_real("floor", floor, low=0.0, high=self.top, low_open=True, high_open=True)
        self.snap = as_real("snap", snap, low=0.0, high=1.0, high_open=True)

    def forward(self, y):
        """Screen heights in [0, 1] of values ``y`` (values above ``top`` at 1; on a log
        axis, values at or below ``floor`` at 0)."""
        y = np.asarray(y, dtype=np.float64)
        if self.scale == "linear":
            return np.clip(y / self.top, 0.0, 1.0)
        lo, hi = np.log10(self.floor), np.log10(self.top)
        return np.clip((np.log10(np.maximum(y, self.floor)) - lo) / (hi - lo), 0.0, 1.0)

    def inverse(self, s):
        """Values of screen heights ``s`` (a log axis gives 0 in the snap band)."""
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
        if self.scale == "linear":
            return s * self.top
        lo, hi = np.log10(self.floor), np.log10(self.top)
        return np.where(s <= self.snap, 0.0, 10.0 ** (lo + s * (hi - lo)))
