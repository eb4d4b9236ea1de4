"""View synthesis from proxy images: undistortion, reprojection, splatting.

A proxy pixel's surface point is recovered from its depth ``Z`` and distortion ``ds``
(paper Eqs. 3-4): the point lies ``ds`` inward of the pixel's point on the image plane,
towards the pole, and ``Z`` below it. Points are projected into the new (rotated)
parallel camera and splatted, each to its nearest pixel, behind a depth buffer; pixels
left empty inside a surface (cracks where the surface stretches) are filled from their
neighbours when most of their 8 neighbours are covered (never at a silhouette, whose
outside pixels see at most 5 covered neighbours on a straight edge).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .._validate import as_real

#: a hole is filled when at least this many of its 8 neighbours are covered
FILL_NEIGHBOURS = 6
#: hole-filling passes (a crack up to twice this wide closes)
FILL_PASSES = 2


def rotated_camera(camera, rotate):
    """``camera`` turned about its focal point by ``rotate = (azimuth, elevation)``
    degrees: azimuth about the view-up axis, then elevation about the right axis
    (VTK's ``Azimuth`` then ``Elevation``; positive azimuth moves the camera to its right)."""
    if rotate is None:
        return camera
    try:
        az, el = rotate
    except (TypeError, ValueError):
        raise TypeError(f"rotate must be (azimuth, elevation) in degrees; got {rotate!r}") from None
    az = as_real("rotate azimuth", az)
    el = as_real("rotate elevation", el)
    fp = np.asarray(camera.focal_point)
    right, up, fwd = camera.basis()
    offset = np.asarray(camera.position) - fp

    def turn(v, axis, degrees):
        a = math.radians(degrees)
        axis = axis / np.linalg.norm(axis)
        return v * math.cos(a) + np.cross(axis, v) * math.sin(a) + axis * np.dot(axis, v) * (1 - math.cos(a))

    offset = turn(offset, up, az)
    right = turn(right, up, az)
    offset = turn(offset, -right, el)
    new_up = turn(up, -right, el)
    return replace(camera, position=tuple((fp + offset).tolist()), view_up=tuple(new_up.tolist()))


def pixel_points(camera, size):
    """World points of the pixel centres on the image plane of a parallel ``camera``
    (rows, cols, 3), and the pitch (world units per pixel)."""
    w, h = size
    rays = camera.rays((w, h))
    return rays.origins.reshape(h, w, 3), 2.0 * camera.parallel_scale / h


def surface_points(camera, size, depth, dist=None):
    """World points of the finite pixels of a depth image (paper Eqs. 3-4) and their
    flat pixel indices: ``depth`` below the image plane, ``dist`` (the distortion)
    inward towards the pole line (which passes through ``camera.position``)."""
    plane, _ = pixel_points(camera, size)
    fwd = camera.basis()[2]
    ok = np.isfinite(depth)
    p = plane[ok]
    pts = p + depth[ok][:, None] * fwd
    if dist is not None:
        lateral = p - np.asarray(camera.position)
        d = np.linalg.norm(lateral, axis=1)
        unit = np.where(d[:, None] > 0, lateral / np.where(d > 0, d, 1.0)[:, None], 0.0)
        pts = pts - unit * dist[ok][:, None]
    return pts, np.flatnonzero(ok.reshape(-1))


def project(camera, size, points):
    """Continuous ``(col, row)`` and depth below the image plane of world ``points`` in a
    parallel ``camera`` (pixel centres at integer + 0.5)."""
    w, h = size
    right, up, fwd = camera.basis()
    rel = points - np.asarray(camera.position)
    pitch = 2.0 * camera.parallel_scale / h
    col = rel @ right / pitch + 0.5 * w
    row = 0.5 * h - rel @ up / pitch
    return col, row, rel @ fwd


def splat(size, col, row, z):
    """Depth buffer (rows, cols) of points splatted to their nearest pixel, ``inf``
    where nothing landed."""
    w, h = size
    c = np.floor(col).astype(np.int64)
    r = np.floor(row).astype(np.int64)
    inside = (c >= 0) & (c < w) & (r >= 0) & (r < h) & np.isfinite(z)
    zbuf = np.full(w * h, np.inf)
    np.minimum.at(zbuf, r[inside] * w + c[inside], z[inside])
    return zbuf.reshape(h, w)


def _neighbour_stack(z, fill=np.inf):
    """The 8 neighbours of every pixel, (8, rows, cols), ``fill`` outside."""
    h, w = z.shape
    pad = np.pad(z, 1, constant_values=fill)
    return np.stack([pad[1 + dr:1 + dr + h, 1 + dc:1 + dc + w] for dr in (-1, 0, 1) for dc in (-1, 0, 1)
                     if dr or dc])


def drop_leaks(zbuf, jump):
    """Empty the pixels of ``zbuf`` lying more than ``jump`` behind the nearest of their
    8 neighbours when most neighbours are nearer: a point of a surface facing away,
    showing through a crack of the surface in front of it."""
    stack = _neighbour_stack(zbuf)
    nearer = (stack < zbuf - jump).sum(axis=0)
    out = np.array(zbuf, dtype=np.float64)
    out[np.isfinite(zbuf) & (nearer >= FILL_NEIGHBOURS - 1)] = np.inf
    return out


def fill_holes(zbuf, passes=FILL_PASSES, jump=None):
    """Fill empty pixels (``inf``) that have at least ``FILL_NEIGHBOURS`` of 8 covered
    neighbours with the mean of the front-most ones (those within ``jump`` of the
    nearest; default: all)."""
    z = np.array(zbuf, dtype=np.float64)
    for _ in range(passes):
        stack = _neighbour_stack(z)
        finite = np.isfinite(stack)
        count = finite.sum(axis=0)
        hole = ~np.isfinite(z) & (count >= FILL_NEIGHBOURS)
        if not hole.any():
            break
        front = np.where(finite, stack, np.inf).min(axis=0)
        with np.errstate(invalid="ignore"):  # inf - inf where a pixel has no covered neighbour
            near = finite & ((stack - front) <= (np.inf if jump is None else jump))
        mean = np.where(near, stack, 0.0).sum(axis=0) / np.maximum(near.sum(axis=0), 1)
        z[hole] = mean[hole]
    return z


def warp_depth(camera, size, depth, dist, new_camera, jump=None):
    """A depth layer seen by ``new_camera``: undistort, reproject, splat, fill holes."""
    pts, _ = surface_points(camera, size, depth, dist)
    col, row, z = project(new_camera, size, pts)
    zbuf = splat(size, col, row, z)
    if jump is not None:
        zbuf = drop_leaks(zbuf, jump)
    return fill_holes(zbuf, jump=jump)


def depth_correlation(synthesized, truth):
    """Pearson correlation of two depth images over the pixels finite in both, and the
    coverage: the fraction of ``truth``'s finite pixels that are finite in ``synthesized``."""
    both = np.isfinite(synthesized) & np.isfinite(truth)
    n_truth = int(np.isfinite(truth).sum())
    coverage = both.sum() / n_truth if n_truth else 0.0
    if both.sum() < 3:
        return math.nan, float(coverage)
    a, b = synthesized[both], truth[both]
    if a.std() == 0 or b.std() == 0:
        return (1.0 if np.allclose(a, b) else math.nan), float(coverage)
    return float(np.corrcoef(a, b)[0, 1]), float(coverage)
