"""VTK colour and opacity functions (ParaView's colour maps) as a :class:`TransferFunction`.

ParaView's Color Map Editor edits a ``vtkPVDiscretizableColorTransferFunction`` (the
colours, their colour space and the log-scale switch) and a ``vtkPiecewiseFunction``
(the opacities). :func:`transfer_function_from_vtk` turns such a pair (or any
``vtkColorTransferFunction`` and ``vtkPiecewiseFunction``) into the renderer's
transfer function. Pure VTK: no ParaView import.
"""
from __future__ import annotations

import numpy as np

from ..data.transfer import TransferFunction

#: Where VTK's functions are not linear on the transfer function's axis (colour spaces
#: other than RGB, midpoints and sharpness, an opacity function on the other axis),
#: segments are halved until the midpoint of each is within this much (colour or
#: opacity) of its linear interpolation: the same tolerance as the lookup table's
#: (:data:`~pv_hdrvol.data.transfer.TABLE_TOLERANCE`).
TOLERANCE = 1e-4
#: At most this many halvings (2**12 points per original segment).
MAX_BISECTIONS = 12


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


def transfer_function_from_vtk(colors, opacity=None, *, table_size=None):
    """A :class:`~pv_hdrvol.TransferFunction` equal to VTK's (ParaView's) colour map.

    Parameters
    ----------
    colors : vtkColorTransferFunction
        ParaView's lookup table (``vtkPVDiscretizableColorTransferFunction``, from
        ``GetColorTransferFunction(name)``), or any ``vtkColorTransferFunction``. Its
        control points set the range; its log-scale switch (``UseLogScale`` in
        ParaView) gives ``scale="log"``. The continuous function is used, not the
        256-colour table ParaView discretises for surfaces (``Discretize``).
    opacity : vtkPiecewiseFunction, optional
        The opacities (ParaView's ``GetOpacityTransferFunction(name)``); ``None``:
        opacity 1 everywhere. Opacities are reached over ``opacity_unit_distance``
        (:class:`~pv_hdrvol.RenderOptions`), as over ParaView's ``Scalar Opacity
        Unit Distance``.
    table_size : int, optional
        As :class:`~pv_hdrvol.TransferFunction`.

    Returns
    -------
    TransferFunction
        Control points at every colour and opacity control point. Where VTK's
        functions are linear on the transfer function's axis (RGB colour space, default
        midpoints and sharpness, the opacity on the same axis as the colours) it is
        equal to them there and in between; otherwise segments are halved until the
        linear interpolation is within :data:`TOLERANCE` of them at each segment's
        midpoint.

    Raises
    ------
    TypeError
        ``colors`` is not a VTK colour transfer function, or ``opacity`` not a
        piecewise function.
    ValueError
        Fewer than two colour control points, a categorical (indexed) colour map, or
        a log scale with a range that is not positive.
    """
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
        raise ValueError(f"the colour map uses a log scale but its range [{lo!r}, {hi!r}] is not positive")
    # a plain vtkColorTransferFunction evaluates the continuous function (ParaView's
    # subclass returns its discretised table's colours when Discretize is on)
    continuous = vtkColorTransferFunction()
    continuous.DeepCopy(colors)
    if continuous.GetSize() != color_nodes.shape[0]:  # pragma: no cover - DeepCopy copies the nodes
        raise RuntimeError("copying the colour map lost control points")

    opacity_nodes = _nodes(opacity, 4) if opacity is not None else np.empty((0, 4))
    values = np.unique(np.concatenate([color_nodes[:, 0],
                                       opacity_nodes[(opacity_nodes[:, 0] > lo) & (opacity_nodes[:, 0] < hi), 0]]))

    def evaluate(x):
        rgba = np.empty((x.size, 4))
        out = [0.0, 0.0, 0.0]
        for i, v in enumerate(x):
            continuous.GetColor(float(v), out)
            rgba[i, :3] = out
            rgba[i, 3] = 1.0 if opacity is None else opacity.GetValue(float(v))
        return rgba

    # Between control points VTK's functions are linear on our axis only for RGB colours
    # with default midpoints and an opacity on the same axis: elsewhere, bisect each
    # segment until the midpoint's linear interpolation is within TOLERANCE.
    to_axis = np.log10 if log else (lambda v: v)
    rgba = evaluate(values)
    for _ in range(MAX_BISECTIONS):
        axis = to_axis(values)
        mid_axis = 0.5 * (axis[:-1] + axis[1:])
        mid = 10.0 ** mid_axis if log else mid_axis
        keep = (mid > values[:-1]) & (mid < values[1:])  # segments that can still be split
        if not keep.any():
            break
        mid_rgba = evaluate(mid[keep])
        error = np.abs(mid_rgba - 0.5 * (rgba[:-1][keep] + rgba[1:][keep])).max(axis=1)
        split = error > TOLERANCE
        if not split.any():
            break
        order = np.argsort(np.concatenate([values, mid[keep][split]]), kind="stable")
        values = np.concatenate([values, mid[keep][split]])[order]
        rgba = np.concatenate([rgba, mid_rgba[split]])[order]
    rgb, alpha = rgba[:, :3], rgba[:, 3]
    return TransferFunction(values, np.clip(rgb, 0.0, None), np.clip(alpha, 0.0, 1.0),
                            scale="log" if log else "linear", table_size=table_size)


__all__ = ["TOLERANCE", "transfer_function_from_vtk"]
