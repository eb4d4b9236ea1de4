"""ParaView's colour-map and opacity presets (the JSON of its "Choose Preset" dialog),
read and written, so transfer functions move between ParaView and pv_hdrvol.

A preset is a dict: ``Name``; ``ColorSpace`` (``RGB``, ``HSV``, ``Lab``,
``Diverging``, ``Lab/CIEDE2000``, ``Step``); ``RGBPoints``, flat ``x, r, g, b, ...``;
optionally ``Points``, flat ``x, opacity, midpoint, sharpness, ...`` (ParaView's
piecewise function: ``midpoint`` 0.5 and ``sharpness`` 0 are linear). A file holds a
list of them. ParaView interpolates between points in data units (linear axis) and
clamps beyond the ends.

Reading: RGB and HSV colours, and linear opacity segments, are taken exactly; colour
spaces we do not interpolate in (Lab, Diverging, Step) and curved opacity segments
(midpoint, sharpness) are sampled with VTK's own ``vtkColorTransferFunction`` /
``vtkPiecewiseFunction`` (:data:`SAMPLES` points, then thinned where linear
interpolation stays within :data:`SAMPLED_TOLERANCE`; needs VTK, which ParaView and
PyVista have). Noticed: ParaView 5.11's VTK (9.1) interpolates some "Diverging"
presets of nearly equal neighbouring colours (its matplotlib maps, e.g. "Viridis
(matplotlib)") through a full turn of hue between two points 1/255 apart; read inside
ParaView, that loop is sampled at 16 points (a newer VTK, as PyVista's, has no loop).
ParaView's own display hides it in its 256-colour table.

Writing: a function on a linear axis is written exactly. On a log or symlog axis,
where ParaView would interpolate linearly in data units between our points, the
function is sampled densely enough along its own axis that ParaView's interpolation
stays within :data:`EXPORT_TOLERANCE` of it (at most :data:`EXPORT_MAX_POINTS`
points). HDR colours above 1 are divided by the brightest (ParaView's colours lie in
[0, 1]). The editor's exact state rides along under the key ``pv_hdrvol``, which
ParaView ignores: a preset written here reads back here exactly.
"""
from __future__ import annotations

import json
import os

import numpy as np

from .._validate import as_int
from ..data.transfer import TransferFunction, scale_inverse

#: Points sampled over the range for colour spaces and opacity curves read through VTK.
SAMPLES = 4096
#: Of those, points that linear interpolation of their neighbours reproduces within this
#: (colour relative to the brightest, opacity absolute) are dropped.
SAMPLED_TOLERANCE = 1e-4
#: Largest difference (colour relative to the brightest, opacity absolute) between
#: ParaView's reading of an exported log/symlog function and the function.
EXPORT_TOLERANCE = 1e-3
EXPORT_MAX_POINTS = 4097
_EXACT_SPACES = {"RGB": "rgb", "HSV": "hsv"}
_VTK_SPACES = ("Lab", "Diverging", "Lab/CIEDE2000", "Step")


def _simplify(axis, values, tolerance):
    """Indices of the points of the piecewise-linear ``values`` (rows) over ``axis`` to
    keep: an interior point goes when the line between the last kept point and the next
    one reproduces it, and every point dropped since, within ``tolerance`` (the ends
    stay)."""
    values = values.reshape(axis.size, -1)
    keep = [0]
    for i in range(1, axis.size - 1):
        j, k = keep[-1], i + 1
        f = ((axis[j + 1:k] - axis[j]) / (axis[k] - axis[j]))[:, None]
        line = values[j] * (1.0 - f) + values[k] * f
        if np.max(np.abs(line - values[j + 1:k])) > tolerance:
            keep.append(i)
    keep.append(axis.size - 1)
    return np.array(keep)


def read_json(path, fix):
    """The JSON of the file at ``path``; a file that is not JSON (truncated, say, or not
    text) is a ``ValueError`` naming it, with ``fix`` (what the user can do) in it."""
    name = os.fspath(path)
    with open(name, encoding="utf-8") as fh:
        try:
            return json.load(fh)
        except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError: name the file, not only the line
            raise ValueError(f"{name!r} is not valid JSON ({fix}): {exc}") from None


def read_paraview_presets(source):
    """The presets in ``source``: a path to ParaView's JSON, a JSON string, a dict (one
    preset) or a list of them. Returns a list of dicts."""
    if isinstance(source, (str, os.PathLike)) and not str(source).lstrip().startswith(("[", "{")):
        data = read_json(source, "truncated or not a ParaView preset file: export it again from ParaView's "
                                 "Choose Preset dialog")
    elif isinstance(source, str):
        try:
            data = json.loads(source)
        except json.JSONDecodeError as exc:
            raise ValueError(f"the preset text is not valid JSON: {exc}") from None
    else:
        data = source
    presets = [data] if hasattr(data, "keys") else data
    if not isinstance(presets, list) or not all(hasattr(p, "keys") for p in presets):
        raise ValueError("a ParaView preset file holds a list of presets (JSON objects)")
    return presets


def _pick(presets, name):
    if name is None:
        if len(presets) != 1:
            names = [p.get("Name") for p in presets]
            raise ValueError(f"the file holds {len(presets)} presets; name one of {names}")
        return presets[0]
    for p in presets:
        if p.get("Name") == name:
            return p
    raise ValueError(f"no preset named {name!r}; the file holds {[p.get('Name') for p in presets]}")


def _flat(preset, key, width):
    values = preset.get(key)
    try:
        a = np.array(values, dtype=np.float64).reshape(-1, width)  # a copy: the caller's preset stays as it is
    except (TypeError, ValueError):
        raise ValueError(f"preset {preset.get('Name')!r}: {key} must be a flat list of numbers, {width} per point; "
                         f"got {values!r:.200}") from None
    if a.shape[0] < 1 or not np.all(np.isfinite(a)):
        raise ValueError(f"preset {preset.get('Name')!r}: {key} needs at least one point of finite numbers")
    if np.any(np.diff(a[:, 0]) < 0):
        raise ValueError(f"preset {preset.get('Name')!r}: the x values of {key} must not decrease")
    return a


def _deduplicate(x, rows):
    """Points with equal ``x`` (a step) become two points 1e-9 of the range apart: our
    functions need strictly increasing positions."""
    x = x.copy()
    span = max(x[-1] - x[0], 1e-300)
    for i in range(1, x.size):
        if x[i] <= x[i - 1]:
            x[i] = x[i - 1] + 1e-9 * span
    return x, rows


def _vtk_colors(points, space, x):
    try:
        from vtkmodules.vtkRenderingCore import vtkColorTransferFunction
    except ImportError:  # pragma: no cover - VTK comes with pyvista and ParaView
        raise ValueError(f"reading a preset in colour space {space!r} needs VTK (its interpolation is VTK's)") \
            from None
    ctf = vtkColorTransferFunction()
    getattr(ctf, {"Lab": "SetColorSpaceToLab", "Diverging": "SetColorSpaceToDiverging",
                  "Lab/CIEDE2000": "SetColorSpaceToLabCIEDE2000", "Step": "SetColorSpaceToStep"}[space])()
    for px, r, g, b in points:
        ctf.AddRGBPoint(px, r, g, b)
    out = np.array([ctf.GetColor(float(v)) for v in x])
    # at a point itself, its own colour: VTK's Diverging space misses it there by up to
    # 0.02 (evaluated at the end of the segment before), and only there
    at = np.searchsorted(x, points[:, 0])
    hit = (at < x.size) & (x[np.minimum(at, x.size - 1)] == points[:, 0])
    out[at[hit]] = points[hit, 1:]
    return out


def _vtk_opacity(points, x):
    try:
        from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    except ImportError:  # pragma: no cover
        raise ValueError("reading a preset's curved opacity (midpoint or sharpness) needs VTK") from None
    pwf = vtkPiecewiseFunction()
    for px, a, mid, sharp in points:
        pwf.AddPoint(px, a, mid, sharp)
    return np.array([pwf.GetValue(float(v)) for v in x])


def transfer_function_from_preset(preset, *, samples=SAMPLES, rescale=None):
    """The :class:`~pv_hdrvol.TransferFunction` of one ParaView preset (a dict), on a
    linear axis as ParaView's. Without ``Points`` the opacity ramps linearly from 0 to 1
    (ParaView's default). ``rescale=(low, high)`` maps the preset's range (its first
    to its last point, colour or opacity) affinely onto ``[low, high]`` first, as
    ParaView's ``ApplyPreset`` does onto the data's range; ``None`` keeps the stored
    points. Returns ``(tf, stored_state)``: ``stored_state`` is the dict this package
    stored under ``pv_hdrvol`` (``None`` for ParaView's own presets or once rescaled),
    not checked here against the points (an edit in ParaView keeps the key but changes
    the points): :meth:`~pv_hdrvol.editor.model.TransferFunctionModel.from_paraview_preset`
    takes it only when the points are still the ones written from it."""
    samples = as_int("samples", samples, low=2, high=1 << 20)
    if preset.get("IndexedColors") is not None or preset.get("Annotations") is not None:
        if "RGBPoints" not in preset:
            raise ValueError(f"preset {preset.get('Name')!r} is categorical (IndexedColors/Annotations): it has no "
                             "continuous transfer function")
    if "RGBPoints" not in preset:
        raise ValueError(f"preset {preset.get('Name')!r} has no RGBPoints")
    space = preset.get("ColorSpace", "RGB")
    if space not in _EXACT_SPACES and space not in _VTK_SPACES:
        raise ValueError(f"preset {preset.get('Name')!r}: unknown ColorSpace {space!r}; ParaView's are "
                         f"{list(_EXACT_SPACES) + list(_VTK_SPACES)}")
    colors = _flat(preset, "RGBPoints", 4)
    opacity = _flat(preset, "Points", 4) if preset.get("Points") is not None else None
    lo = colors[0, 0] if opacity is None else min(colors[0, 0], opacity[0, 0])
    hi = colors[-1, 0] if opacity is None else max(colors[-1, 0], opacity[-1, 0])
    if not hi > lo:
        raise ValueError(f"preset {preset.get('Name')!r} spans no range: its points all lie at {lo!r}")
    stored = preset.get("pv_hdrvol")
    state = stored if hasattr(stored, "keys") else None
    if rescale is not None:
        new_lo, new_hi = _check_range(rescale)
        if (new_lo, new_hi) != (lo, hi):
            state = None  # the editor state holds the old range
            for points in (colors,) if opacity is None else (colors, opacity):  # copies (_flat)
                x = points[:, 0]
                # the ends land exactly on the new range's
                points[:, 0] = np.where(x == hi, new_hi, np.clip(new_lo + (x - lo) * ((new_hi - new_lo) / (hi - lo)),
                                                                 new_lo, new_hi))
            lo, hi = new_lo, new_hi
    if opacity is None:
        opacity = np.array([[lo, 0.0, 0.5, 0.0], [hi, 1.0, 0.5, 0.0]])
    curved = np.any(opacity[:-1, 2] != 0.5) or np.any(opacity[:-1, 3] != 0.0)
    x_dense = np.linspace(lo, hi, samples)
    if space in _EXACT_SPACES and not curved:
        # exact: the union of both lists' points, each interpolated at the other's (ParaView
        # clamps beyond the ends)
        cx, cc = _deduplicate(colors[:, 0], colors[:, 1:])
        ox, oa = _deduplicate(opacity[:, 0], opacity[:, 1])
        x = np.unique(np.concatenate([cx, ox, [lo, hi]]))
        if cx.size == 1:
            rgb = np.repeat(cc, x.size, axis=0)
        else:
            rgb = TransferFunction(cx, np.clip(cc, 0, None), np.zeros(cx.size), color_space=_EXACT_SPACES[space],
                                   table_size=256).color_at(x)
        alpha = np.interp(x, ox, oa)
        color_space = _EXACT_SPACES[space]
    else:
        # and each opacity segment's midpoint, where ParaView's curve bends most
        middles = opacity[:-1, 0] + opacity[:-1, 2] * np.diff(opacity[:, 0])
        x = np.unique(np.concatenate([x_dense, colors[:, 0], opacity[:, 0], middles]))
        if space in _EXACT_SPACES:
            cx, cc = _deduplicate(colors[:, 0], colors[:, 1:])
            rgb = TransferFunction(cx, np.clip(cc, 0, None), np.zeros(cx.size), color_space=_EXACT_SPACES[space],
                                   table_size=256).color_at(x) if cx.size > 1 else np.repeat(cc, x.size, axis=0)
            color_space = _EXACT_SPACES[space]
        else:
            rgb = _vtk_colors(colors, space, x)
            color_space = "rgb"
        alpha = _vtk_opacity(opacity, x) if curved else np.interp(x, *_deduplicate(opacity[:, 0], opacity[:, 1]))
        rows = np.column_stack([rgb / max(float(rgb.max()), 1e-300), alpha])
        keep = _simplify(x, rows, SAMPLED_TOLERANCE) if color_space == "rgb" else np.arange(x.size)
        x, rgb, alpha = x[keep], rgb[keep], alpha[keep]
    tf = TransferFunction(x, np.clip(rgb, 0.0, None), np.clip(alpha, 0.0, 1.0), color_space=color_space)
    return tf, state


def _check_range(rescale):
    """``(low, high)`` floats of a ``rescale=`` range, validated."""
    try:
        low, high = (float(v) for v in rescale)
    except (TypeError, ValueError):
        raise TypeError(f"rescale must be (low, high) numbers; got {rescale!r}") from None
    if not (np.isfinite(low) and np.isfinite(high) and high > low):
        raise ValueError(f"rescale must be a finite range with high > low; got {rescale!r}")
    return low, high


def data_range(values):
    """The finite ``(min, max)`` of ``values`` that a preset is rescaled onto, as
    ParaView's "Rescale to data range": a constant field gets ``(v - 0.5, v + 0.5)``
    (ParaView widens a one-value range too). ``ValueError`` when nothing is finite."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    v = v[np.isfinite(v)]
    if v.size == 0:
        raise ValueError("the data have no finite value to rescale the preset to; pass rescale=(low, high) "
                         "or rescale=False")
    low, high = float(v.min()), float(v.max())
    return (low - 0.5, high + 0.5) if high == low else (low, high)


def _export_points(tf, tolerance=EXPORT_TOLERANCE, most=EXPORT_MAX_POINTS):
    """Data positions at which ``tf`` is written: its own points on a linear axis; on a
    log/symlog axis, evenly spaced positions along that axis (plus its points), doubled
    until linear interpolation in data units reproduces the function within
    ``tolerance`` at 15 points evenly along the axis inside every interval (the largest
    difference lies near an interval's logarithmic mean, not its middle)."""
    if tf.scale == "linear":
        return tf.values.copy()
    a0, a1 = tf.axis_range
    peak = max(float(tf.colors.max()), 1e-300)
    n = 65
    f = np.linspace(0.0, 1.0, 17)[1:-1]
    while True:
        axis = np.unique(np.concatenate([np.linspace(a0, a1, n), tf._axis]))
        x = scale_inverse(axis, tf.scale, tf.linthresh)
        x[0], x[-1] = tf.vmin, tf.vmax
        inner = scale_inverse((axis[:-1, None] * (1 - f) + axis[1:, None] * f), tf.scale, tf.linthresh)
        w = (inner - x[:-1, None]) / (x[1:, None] - x[:-1, None])  # ParaView's weights, in data units
        rgb, alpha = tf.color_at(x), tf.opacity_at(x)
        lin_rgb = rgb[:-1, None] * (1 - w)[..., None] + rgb[1:, None] * w[..., None]
        lin_alpha = alpha[:-1, None] * (1 - w) + alpha[1:, None] * w
        error = max(float(np.max(np.abs(lin_rgb - tf.color_at(inner.reshape(-1)).reshape(lin_rgb.shape)))) / peak,
                    float(np.max(np.abs(lin_alpha - tf.opacity_at(inner.reshape(-1)).reshape(lin_alpha.shape)))))
        if error <= tolerance or x.size >= most:
            return x
        n = 2 * n - 1


def write_paraview_presets(path, presets):
    """Write presets (dicts from :func:`paraview_preset`) as a ParaView preset file
    (``ImportPresets(path)`` in ParaView, or the preset dialog's Import)."""
    presets = [presets] if hasattr(presets, "keys") else list(presets)
    names = [p.get("Name") for p in presets]
    if len(set(names)) != len(names):
        raise ValueError(f"preset names must differ; got {names}")
    with open(os.fspath(path), "w", encoding="utf-8") as fh:
        json.dump(presets, fh, indent=1)


def export_error(tf, preset):
    """The largest difference between ParaView's reading of ``preset`` (linear
    interpolation in data units, colours as written) and ``tf``, sampled at 100,001
    points evenly along ``tf``'s axis: ``(colour relative to the brightest, opacity)``."""
    a0, a1 = tf.axis_range
    v = scale_inverse(np.linspace(a0, a1, 100_001), tf.scale, tf.linthresh)
    v[0], v[-1] = tf.vmin, tf.vmax
    c = np.asarray(preset["RGBPoints"], dtype=np.float64).reshape(-1, 4)
    o = np.asarray(preset["Points"], dtype=np.float64).reshape(-1, 4)
    peak = max(float(tf.colors.max()), 1e-300)
    scale_back = peak if peak > 1.0 else 1.0
    if preset["ColorSpace"] == "HSV":
        pv = TransferFunction(c[:, 0], c[:, 1:], np.zeros(len(c)), color_space="hsv", table_size=256).color_at(v)
    else:
        pv = np.stack([np.interp(v, c[:, 0], c[:, k]) for k in (1, 2, 3)], axis=-1)
    color = float(np.max(np.abs(pv * scale_back - tf.color_at(v)))) / peak
    opacity = float(np.max(np.abs(np.interp(v, o[:, 0], o[:, 1]) - tf.opacity_at(v))))
    return color, opacity


__all__ = ["EXPORT_TOLERANCE", "SAMPLES", "export_error", "read_json", "read_paraview_presets",
           "transfer_function_from_preset", "write_paraview_presets"]
