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

import numpy as np


def has_clip(options):
    """Whether ``options`` (a :class:`~pv_hdrvol.RenderOptions`) cut anything."""
    return bool(options.clip_planes) or options.crop_box is not None


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
        ``near >= 0``; ``far < near`` (or both ``inf``) where nothing is kept. A ray
        lying in a plane (``d . normal == 0``) is kept whole when its origin is on the
        kept side (``>= 0``), else not at all.
    """
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    n = o.shape[0]
    near = np.zeros(n)
    stop = np.full(n, np.inf) if far is None else np.array(far, dtype=np.float64).reshape(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        for plane in planes:
            normal = np.asarray(plane.normal)
            s = (o - np.asarray(plane.origin)) @ normal  # signed distance of the origin (kept: >= 0)
            r = d @ normal
            t = -s / r
            ahead = r > 0.0   # entering the kept side at t
            behind = r < 0.0  # leaving it at t
            near = np.where(ahead, np.maximum(near, t), near)
            stop = np.where(behind, np.minimum(stop, t), stop)
            outside = (r == 0.0) & ~(s >= 0.0)
            stop = np.where(outside, -np.inf, stop)
        if box is not None:
            for axis in range(3):
                lo, hi = box[2 * axis], box[2 * axis + 1]
                oa, da = o[:, axis], d[:, axis]
                ta = (lo - oa) / da
                tb = (hi - oa) / da
                t_in = np.where(da != 0.0, np.minimum(ta, tb), -np.inf)
                t_out = np.where(da != 0.0, np.maximum(ta, tb), np.inf)
                outside = (da == 0.0) & ~((oa >= lo) & (oa <= hi))
                near = np.maximum(near, t_in)
                stop = np.where(outside, -np.inf, np.minimum(stop, t_out))
    return near, stop


def ray_spans(rays_or_camera, size, options, far=None):
    """The ``(n, 2)`` array of ``[near, far]`` per pixel that the ray casters take
    (``far`` alone when ``options`` cut nothing; an empty ``(0, 2)`` array when there
    is neither a clip nor ``far``).

    ``rays_or_camera``: the render's :class:`~pv_hdrvol.Rays`, or a camera whose rays
    (``Camera.rays(size)``) are the ones the kernel makes. ``far``: the checked flat
    ``far`` of the render (empty: none).
    """
    far = None if far is None or np.size(far) == 0 else np.asarray(far, dtype=np.float64).reshape(-1)
    if not has_clip(options):
        if far is None:
            return np.empty((0, 2))
        return np.ascontiguousarray(np.column_stack([np.zeros(far.size), far]))
    rays = rays_or_camera if hasattr(rays_or_camera, "origins") else rays_or_camera.rays(size)
    near, stop = clip_spans(rays.origins, rays.directions, options.clip_planes, options.crop_box, far)
    return np.ascontiguousarray(np.column_stack([near, stop]))
