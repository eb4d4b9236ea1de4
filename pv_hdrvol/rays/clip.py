"""Clipping planes and a crop box as one interval of each ray.

The kept set of :class:`~pv_hdrvol.RenderOptions` ``clip_planes`` (half-spaces
``(x - origin) . normal >= 0``, VTK's convention) and ``crop_box`` is an intersection
of half-spaces: convex, so the ray ``o + t d`` (``t >= 0``) meets it in one interval
``[near, far]``, computed here in closed form per pixel. The ray casters start their
samples at ``near`` and end the last segment at ``far`` (its opacity corrected for the
segment's true length), so the cut is exact, not rounded to a sample; where the
interval is empty the ray composites nothing.

``far`` also takes the depth of opaque geometry (``GridPlan.execute(far=...)``): the
render's spans are the clip interval cut at that depth.
"""
from __future__ import annotations

import copy

import numpy as np

from .._validate import as_size
from . import _kernels as K


def with_clip(plan, clip_planes=None, crop_box=None):
    """``plan`` (a GridPlan or TetPlan, whose ``with_clip`` this is) with other
    ``clip_planes`` and ``crop_box`` (as :class:`~pv_hdrvol.RenderOptions`'; ``None``:
    none). A clip changes only each ray's interval, so the copy shares the tables and
    prepared arrays: dragging a plane re-renders without preparing again."""
    out = copy.copy(plan)
    out.options = plan.options.replace(clip_planes=clip_planes, crop_box=crop_box)
    return out


def has_clip(options):
    """Whether ``options`` (a :class:`~pv_hdrvol.RenderOptions`) cut anything."""
    return bool(options.clip_planes) or options.crop_box is not None


def _clip_arrays(planes, box):
    """The kernels' plane rows ``(origin, normal)`` and box (empty: none)."""
    rows = np.array([p.origin + p.normal for p in planes], dtype=np.float64).reshape(-1, 6)
    return rows, np.empty(0) if box is None else np.asarray(box, dtype=np.float64)


def clip_spans(origins, directions, planes=(), box=None, far=None):
    """``(near, far)``: per ray, the interval of ``t >= 0`` where ``o + t d`` is kept.

    Parameters
    ----------
    origins, directions : arrays (n, 3)
        The rays (world coordinates; ``t`` is in units of ``|d|``).
    planes : sequence of :class:`~pv_hdrvol.params.ClipPlane`
    box : (xmin, xmax, ymin, ymax, zmin, zmax) or None
    far : array (n,) or None
        An upper limit of ``t`` per ray (``inf``: none).

    Returns
    -------
    near, far : float64 arrays (n,)
        ``near >= 0``; ``far < near`` where nothing is kept. A ray parallel to a plane
        (``d . normal == 0``) is kept whole when its origin is on the kept side
        (``>= 0``), else not at all; one parallel to a face of the box, when it lies
        between the box's faces on that axis.
    """
    o = np.ascontiguousarray(origins, dtype=np.float64)
    d = np.ascontiguousarray(directions, dtype=np.float64)
    limit = np.empty(0) if far is None else np.ascontiguousarray(far, dtype=np.float64).reshape(o.shape[0])
    out = np.empty((o.shape[0], 2))
    rows, b = _clip_arrays(planes, box)
    K.clip_spans_of_rays(o, d, rows, b, limit, out)
    return out[:, 0], out[:, 1]


def ray_spans(rays_or_camera, size, options, far=None, near=None):
    """The ``(n, 2)`` array of ``[near, far]`` per pixel that the ray casters take
    (``far`` alone when ``options`` cut nothing; an empty ``(0, 2)`` array when there
    is neither a clip nor ``far``).

    ``rays_or_camera``: the render's :class:`~pv_hdrvol.Rays`, or the camera whose rays
    the kernel makes (``camera_ray``, bit for bit ``Camera.rays(size)``). ``far``: the
    checked flat ``far`` of the render (empty: none); ``near``: a flat array of where each
    ray starts (``None``: at 0), as the scenes of image and mesh blocks cut a mesh
    between the grids' boxes. A few milliseconds at 512 x 512: the spans are made by a
    parallel kernel, without the rays' arrays.
    """
    far = None if far is None or np.size(far) == 0 else np.asarray(far, dtype=np.float64).reshape(-1)
    if near is not None:
        near = np.asarray(near, dtype=np.float64).reshape(-1)
        far = np.full(near.size, np.inf) if far is None else far
    if not has_clip(options):
        if far is None:
            return np.empty((0, 2))
        start = np.zeros(far.size) if near is None else np.maximum(near, 0.0)
        return np.ascontiguousarray(np.column_stack([start, far]))
    rows, box = _clip_arrays(options.clip_planes, options.crop_box)
    limit = np.empty(0) if far is None else np.ascontiguousarray(far)
    if hasattr(rays_or_camera, "origins"):
        rays = rays_or_camera
        out = np.empty((rays.origins.shape[0], 2))
        K.clip_spans_of_rays(np.ascontiguousarray(rays.origins, dtype=np.float64),
                             np.ascontiguousarray(rays.directions, dtype=np.float64), rows, box, limit, out)
    else:
        width, height = as_size(size)
        out = np.empty((width * height, 2))
        K.clip_spans_of_camera(rays_or_camera.kernel_array((width, height)), width, height, rows, box, limit, out)
    if near is not None:
        np.maximum(out[:, 0], near, out=out[:, 0])
    return out
