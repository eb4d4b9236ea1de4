"""VTK colour and opacity functions (ParaView's colour maps) as a :class:`TransferFunction`.

ParaView's Color Map Editor edits a ``vtkPVDiscretizableColorTransferFunction`` (the
colours, their colour space and the log-scale switch) and a ``vtkPiecewiseFunction``
(the opacities). :func:`transfer_function_from_vtk` turns such a pair (or any
``vtkColorTransferFunction`` and ``vtkPiecewiseFunction``) into the renderer's
transfer function. Pure VTK: no ParaView import.
"""
from __future__ import annotations

import numpy as np

from ..data.transfer import TransferFunction, scale_inverse, scale_forward

#: Where VTK's functions are not linear on the transfer function's axis (colour spaces
#: other than RGB, midpoints and sharpness, an opacity function on the other axis),
#: segments are halved until the midpoint of each is within this much (colour or
#: opacity) of its linear interpolation: the same tolerance as the lookup table's
#: (:data:`~pv_hdrvol.data.transfer.TABLE_TOLERANCE`).
TOLERANCE = 1e-4
#: At most this many rounds of halving: enough to halve any segment down to adjacent
#: floats (a segment with no float between its ends is not halved: a step in VTK's
#: function is followed to the float). Only segments still off are halved again.
MAX_BISECTIONS = 2100
#: At most this many control points: a function that needs more is refused.
MAX_POINTS = 2**16


def _nodes(function, width):
    """Control points of a VTK colour (width 6) or opacity (width 4) function, (n, width)."""
    out = np.empty((function.GetSize(), width))
    node = [0.0] * width
    for i in range(out.shape[0]):
        function.GetNodeValue(i, node)
        out[i] = node
    return out


def _is_log(function):
    """Whether a VTK colour or opacity function interpolates on log10 of the data."""
    if hasattr(function, "GetScale"):  # vtkColorTransferFunction: VTK_CTF_LOG10 == 1
        return function.GetScale() == 1
    return bool(getattr(function, "GetUseLogScale", lambda: 0)())


def _continuous_copy(colors):
    """A plain ``vtkColorTransferFunction`` equal to ``colors``: it evaluates the
    continuous function (ParaView's subclass returns its discretised table's colours
    when Discretize is on). ``DeepCopy`` leaves the below- and above-range colours
    out (VTK 9), which ``GetColor`` uses when clamping: they are copied by hand."""
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

    continuous = vtkColorTransferFunction()
    continuous.DeepCopy(colors)
    if continuous.GetSize() != colors.GetSize():  # pragma: no cover - DeepCopy copies the nodes
        raise RuntimeError("copying the colour map lost control points")
    for name in ("Clamping", "Scale", "UseBelowRangeColor", "BelowRangeColor", "UseAboveRangeColor",
                 "AboveRangeColor"):
        if hasattr(colors, "Get" + name) and hasattr(continuous, "Set" + name):
            getattr(continuous, "Set" + name)(getattr(colors, "Get" + name)())
    return continuous


def _beside(x, side, scale, linthresh):
    """The value nearest ``x`` on ``side`` (-1 below, +1 above) that the axis tells
    apart from ``x``: the other end of a step at ``x``."""
    a = scale_forward(x, scale, linthresh)
    step = float(np.spacing(abs(x))) if x != 0 else float(np.spacing(0.0))
    for _ in range(2200):
        g = x + side * step
        if (scale_forward(g, scale, linthresh) - a) * side > 0:
            return float(g)
        step *= 2.0
    raise RuntimeError(f"no value beside {x!r} on the {scale} axis")  # pragma: no cover


def _too_many(values, check, error, scale):
    worst = check[np.argmax(error)]
    raise ValueError(f"following VTK's colour map and opacity function within {TOLERANCE} needs more than "
                     f"{MAX_POINTS} control points (still {float(error.max()):.3g} off between "
                     f"{float(values[worst])!r} and {float(values[worst + 1])!r} on a {scale} axis): put the "
                     f"opacity function on the colour map's axis (UseLogScale) or use fewer control points")


def transfer_function_from_vtk(colors, opacity=None, *, table_size=None):
    """A :class:`~pv_hdrvol.TransferFunction` equal to VTK's (ParaView's) colour map.

    Parameters
    ----------
    colors : vtkColorTransferFunction
        ParaView's lookup table (``vtkPVDiscretizableColorTransferFunction``, from
        ``GetColorTransferFunction(name)``), or any ``vtkColorTransferFunction``. Its
        control points set the colour range; its log-scale switch (``UseLogScale`` in
        ParaView) gives ``scale="log"`` (or ``"symlog"``, below). The continuous
        function is used, not the 256-colour table ParaView discretises for surfaces
        (``Discretize``). Its clamping and below/above-range colours are followed.
    opacity : vtkPiecewiseFunction, optional
        The opacities (ParaView's ``GetOpacityTransferFunction(name)``), on a linear or
        log axis (``UseLogScale``), clamped or not; ``None``: opacity 1 everywhere.
        Opacities are reached over ``opacity_unit_distance``
        (:class:`~pv_hdrvol.RenderOptions`), as over ParaView's ``Scalar Opacity Unit
        Distance``.
    table_size : int, optional
        As :class:`~pv_hdrvol.TransferFunction`.

    Returns
    -------
    TransferFunction
        Control points at every colour and opacity control point (the opacity
        function's own range may be wider than the colour map's); its range is the
        union of both. Beyond that range VTK's functions are constant (the end
        colours, black with clamping off, the below/above-range colours; the end
        opacities, 0 with clamping off), and so is the transfer function. Where VTK's
        functions step (clamping off, range colours, at a range end) a second control
        point right beside the end (the adjacent float on the axis) makes the step.
        Where VTK's functions are linear on the transfer function's axis (RGB colour
        space, default midpoints and sharpness, the opacity on the same axis as the
        colours) it is equal to them there and in between; otherwise segments are
        halved until the linear interpolation is within :data:`TOLERANCE` of them at
        each segment's midpoint.

        The axis: ``"linear"`` for a linear colour map. For a log colour map
        ``"log"``, which gives every value <= 0 the transfer function's first entry;
        VTK gives such values the colour below the range and the opacity function's
        value there, which differ from the first entry when a linear opacity function
        has points at or below 0 and varies between them and the smallest positive
        control point (a log colour map over [1, 255] with opacities from 0 at 0):
        then ``"symlog"`` with ``linthresh`` the colour map's first value, on which 0
        and negative values have their own entries, and the colours (log-interpolated
        by VTK) are followed within the tolerance.

    Raises
    ------
    TypeError
        ``colors`` is not a VTK colour transfer function, or ``opacity`` not a
        piecewise function.
    ValueError
        Fewer than two colour control points; a categorical (indexed) colour map; a
        log colour map whose range is not positive (VTK then interpolates linearly:
        turn its log scale off); a log opacity function with a point at or below 0
        (VTK evaluates it as NaN there); more than :data:`MAX_POINTS` control points
        needed to stay within the tolerance; a NaN from either function.
    """
    color_nodes, log = _color_nodes(colors, opacity)
    lo, hi = float(color_nodes[0, 0]), float(color_nodes[-1, 0])
    continuous = _continuous_copy(colors)
    opacity_nodes = _opacity_nodes(opacity)
    evaluate = _evaluator(continuous, opacity)
    nodes = np.unique(np.concatenate([color_nodes[:, 0], opacity_nodes]))
    scale, linthresh, nodes = _axis(nodes, lo, log, evaluate)
    # steps at the ends of the colour map and of the opacity function (clamping off,
    # below/above-range colours): a control point at the float beside each end
    ends = {lo, hi} | ({float(opacity_nodes[0]), float(opacity_nodes[-1])} if opacity_nodes.size else set())
    values = np.unique(np.concatenate([nodes, _step_guards(nodes, ends, scale, linthresh, evaluate)]))
    values, rgba = _bisect(values, scale, linthresh, evaluate)
    rgb, alpha = rgba[:, :3], rgba[:, 3]
    return TransferFunction(values, np.clip(rgb, 0.0, None), np.clip(alpha, 0.0, 1.0), scale=scale,
                            linthresh=linthresh, table_size=table_size)


def _color_nodes(colors, opacity):
    """Check the pair of VTK functions; the colour map's control points (n, 6) and whether
    it is on a log axis."""
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

    if not isinstance(colors, vtkColorTransferFunction):
        raise TypeError(f"colors must be a vtkColorTransferFunction (a ParaView lookup table); "
                        f"got {type(colors).__name__}")
    if opacity is not None and not isinstance(opacity, vtkPiecewiseFunction):
        raise TypeError(f"opacity must be a vtkPiecewiseFunction or None; got {type(opacity).__name__}")
    if getattr(colors, "GetIndexedLookup", lambda: 0)():
        raise ValueError("the colour map is categorical (Interpret Values As Categories): an HDR volume "
                         "rendering needs a continuous one")
    color_nodes = _nodes(colors, 6)
    if color_nodes.shape[0] < 2:
        raise ValueError(f"the colour map needs at least 2 control points; it has {color_nodes.shape[0]}")
    lo, hi = float(color_nodes[0, 0]), float(color_nodes[-1, 0])
    if not hi > lo:
        raise ValueError(f"the colour map's range must be increasing; got [{lo!r}, {hi!r}]")
    log = _is_log(colors)
    if log and lo <= 0:
        raise ValueError(f"the colour map uses a log scale but its range [{lo!r}, {hi!r}] is not positive (VTK "
                         f"then interpolates it linearly): turn its log scale off (SetScale(0); ParaView: "
                         f"UseLogScale = 0) or move its first point above 0")
    return color_nodes, log


def _opacity_nodes(opacity):
    """The values of the opacity function's control points (none for ``None``), checked
    for a log axis."""
    opacity_nodes = _nodes(opacity, 4)[:, 0] if opacity is not None else np.empty(0)
    opacity_log = opacity is not None and _is_log(opacity)
    if opacity_log and opacity_nodes.size and opacity_nodes[0] <= 0:
        raise ValueError(f"the opacity function uses a log scale but its range [{float(opacity_nodes[0])!r}, "
                         f"{float(opacity_nodes[-1])!r}] is not positive (VTK evaluates it as NaN there): move its "
                         f"points above 0 or turn its log scale off (SetUseLogScale(0); ParaView: the opacity "
                         f"function's UseLogScale = 0)")
    return opacity_nodes


def _evaluator(continuous, opacity):
    """``evaluate(x)``: VTK's colour and opacity at the values ``x``, (n, 4) RGBA; a NaN or
    inf from either function raises ``ValueError``."""
    def evaluate(x):
        x = np.atleast_1d(np.asarray(x, dtype=np.float64))
        rgba = np.empty((x.size, 4))
        out = [0.0, 0.0, 0.0]
        for i, v in enumerate(x):
            continuous.GetColor(float(v), out)
            rgba[i, :3] = out
            rgba[i, 3] = 1.0 if opacity is None else opacity.GetValue(float(v))
        bad = ~np.isfinite(rgba)
        if bad.any():
            i, c = np.argwhere(bad)[0]
            which = "opacity function" if c == 3 else "colour map"
            raise ValueError(f"VTK's {which} evaluates to {rgba[i, c]!r} at {float(x[i])!r}: give it finite "
                             f"control points")
        return rgba

    return evaluate


def _axis(nodes, lo, log, evaluate):
    """The transfer function's axis ``(scale, linthresh)`` and the control points it keeps
    of ``nodes``: a log colour map gives ``"log"`` (without the nodes <= 0), or
    ``"symlog"`` from ``lo`` where VTK's functions vary at or below 0."""
    scale, linthresh = ("log" if log else "linear"), 1.0
    if log and nodes[0] <= 0:
        # A linear opacity function reaches 0 or below. A log axis gives every value
        # <= 0 the first entry: right only if VTK's functions are constant up to the
        # smallest positive control point (they are linear in x in between).
        positive = float(nodes[nodes > 0][0])
        probes = np.concatenate([nodes[nodes <= 0], [_beside(float(nodes[0]), -1, "linear", 1.0), 0.0,
                                                      positive * 1e-9, _beside(positive, -1, "log", 1.0),
                                                      positive]])
        if np.abs(evaluate(probes) - evaluate(positive)).max() > TOLERANCE:
            scale, linthresh = "symlog", lo
        else:
            nodes = nodes[nodes > 0]
    return scale, linthresh, nodes


def _step_guards(nodes, ends, scale, linthresh, evaluate):
    """The floats beside each of ``ends`` (that is a control point) where VTK's functions
    step: the control points that make the step."""
    guards = []
    for end in sorted(e for e in ends if e in set(nodes.tolist())):
        inside = evaluate(end)
        for side in (-1, 1):
            beside = _beside(end, side, scale, linthresh)
            if np.abs(evaluate(beside) - inside).max() > TOLERANCE:
                guards.append(beside)
    return guards


def _bisect(values, scale, linthresh, evaluate):
    """The control points ``values`` with segments halved until VTK's functions are
    within :data:`TOLERANCE` of the linear interpolation at each midpoint; the points
    and their RGBA."""
    # Between control points VTK's functions are linear on our axis only for RGB colours
    # with default midpoints and an opacity on the same axis: elsewhere, bisect each
    # segment until the midpoint's linear interpolation is within TOLERANCE (a segment
    # with no float between its ends, a step, is left as it is).
    rgba = evaluate(values)
    pending = np.ones(values.size - 1, dtype=bool)  # segments not yet checked
    for _ in range(MAX_BISECTIONS):
        axis = scale_forward(values, scale, linthresh)
        mid = scale_inverse(0.5 * (axis[:-1] + axis[1:]), scale, linthresh)
        check = np.flatnonzero(pending & (mid > values[:-1]) & (mid < values[1:]))
        if check.size == 0:
            break
        mid_rgba = evaluate(mid[check])
        error = np.abs(mid_rgba - 0.5 * (rgba[check] + rgba[check + 1])).max(axis=1)
        split = error > TOLERANCE
        if not split.any():
            break
        if values.size + int(split.sum()) > MAX_POINTS:
            _too_many(values, check, error, scale)
        at = check[split]
        values = np.insert(values, at + 1, mid[at])
        rgba = np.insert(rgba, at + 1, mid_rgba[split], axis=0)
        pending = np.zeros(values.size - 1, dtype=bool)
        left = at + np.arange(at.size)  # the halves of each split segment
        pending[left] = pending[left + 1] = True
    else:  # pragma: no cover - MAX_BISECTIONS halvings reach adjacent floats first
        _too_many(values, check, error, scale)
    return values, rgba


__all__ = ["TOLERANCE", "transfer_function_from_vtk"]
