"""numba kernels for renders beyond plain emission-absorption: arrays in, arrays out.

- **Extended compositing** (``render_ext``): emission-absorption with any of
  gradient-magnitude opacity modulation, Blinn-Phong shading by the gradient,
  two-level rendering of labelled data (a transfer function and a blending mode per
  label), also on rays with a level of detail.
- **Levels of detail and projections** (``render_levels``): rays sparser than the
  camera's (a lens's level of detail, ``Rays.lod``) sample a mip-map in the one grid
  loop, ``_kernels._march``, whose stencil the mip-map's type chooses
  (``_kernels.stencil``); rays at level 0 run that loop unchanged, so their pixels are
  bit-identical to a plain render. Projections (maximum, minimum, average, additive)
  run the same loop with a projection's compositor (``_composite_kernels``).

Kept apart from ``_kernels.py`` so that a plain render compiles and runs none of this
("model only what a scene requires"). The compositing kernels take the precision's
marker (``_kernels._march``), so a first render compiles one precision's loops.

The mip-map (``pyr``) is one flat array of bricked levels, level ``L`` at offset
``pgeo[L, 0]`` with ``pgeo[L, 1:4]`` its points along x, y, z and ``pgeo[L, 4:6]`` its
brick grid (y, x); level ``L`` point ``i`` lies at voxel coordinate ``i * 2**L``.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from .._jit import fused_kernel, inline_kernel, kernel, parallel_kernel, uindex as _u
from ._composite_kernels import (
    COMPOSITE, LOG, MAXIMUM, MINIMUM, SYMLOG, _accumulate, _finish, _marker_precision, _opacity, _start, sigma_at,
    table_row,
)
from ._kernels import (
    BRICK_SHIFT, SCRATCH, _block, _leap_to, _march, _ray_box, eye_of, lane_pixel, lane_pixels,
    lit, midpoint_lattice, mip_sampler, mip_value, piece_segments, pixel_ray_span, probe, store_pixel,
    trilinear as _trilinear,
)


class ExtParams(NamedTuple):
    """Scalars of the extended renders, beside ``_kernels.GridParams``.

    ``unit``: the opacity unit distance (a maximum/minimum label's segment takes the
    transfer function's opacity over it). ``gradient``: 1 to scale extinction by a ramp of the gradient magnitude from
    ``g_lo`` (0) to ``g_lo + 1 / g_inv`` (1). ``lattice``/``midpoint``: whether any
    label uses a maximum/minimum (sampled at lattice points) or a compositing mode
    (sampled at segment midpoints). (Shading is the type of ``render_ext``'s ``light``.)
    """

    unit: float
    gradient: int
    g_lo: float
    g_inv: float
    n_levels: int
    labelled: int
    lattice: int
    midpoint: int


# -- sampling --------------------------------------------------------------------------------------
@kernel
def _lod_value(pyr, pgeo, n_levels, lod, x, y, z):
    """Value at fractional mip level ``lod``: linear between the two nearest levels."""
    return mip_value(pyr, mip_sampler(pgeo, lod, n_levels), x, y, z)


@fused_kernel
def _sample(bricks, offs, leap, g, pyr, pgeo, n_levels, lod, x, y, z):
    """``(radius, ib, jb, kb, v)`` as ``_kernels.probe``, the plain loop's stencil;
    mip-mapped where ``lod > 0``."""
    if lod == 0.0:
        return probe(bricks, offs, leap, g, x, y, z)
    radius, ib, jb, kb = _block(leap, g, x, y, z)
    if radius != 0:
        return radius, ib, jb, kb, math.nan
    return 0, ib, jb, kb, _lod_value(pyr, pgeo, n_levels, lod, x, y, z)


# -- labels ------------------------------------------------------------------------------------
@kernel
def _label_slot(slots, g, x, y, z):
    """Style slot of the grid point nearest to ``(x, y, z)`` (a label is not interpolated)."""
    nx, ny, nz, x_max, y_max, z_max, shift, by, bx, qy, qx = g
    i = int(min(max(x, 0.0), x_max) + 0.5)
    j = int(min(max(y, 0.0), y_max) + 0.5)
    k = int(min(max(z, 0.0), z_max) + 0.5)
    m = (1 << BRICK_SHIFT) - 1
    pitch = (1 << BRICK_SHIFT) + 1
    q = ((k >> BRICK_SHIFT) * qy + (j >> BRICK_SHIFT)) * qx + (i >> BRICK_SHIFT)
    return slots[_u(q * (pitch * pitch * pitch) + ((k & m) * pitch + (j & m)) * pitch + (i & m))]


# -- classification with explicit axis parameters (one transfer function per label) -----
@kernel
def _position(v, scale, lo, inv_range, linthresh):
    """``_kernels.table_position`` with the axis given explicitly."""
    if scale == LOG:
        if v > 0.0:
            a = math.log10(v)
        else:
            return 0.0
    elif scale == SYMLOG:
        a = math.copysign(math.log10(1.0 + abs(v) / linthresh), v)
    else:
        a = v
    u = (a - lo) * inv_range
    if u < 0.0:
        return 0.0
    if u > 1.0:
        return 1.0
    return u


@fused_kernel
def _row(tables, slot, n, axes, v, u8):
    """Interpolated ``(r, g, b, a_step)`` of label slot ``slot``, and entry and fraction.

    ``tables`` is flat, ``n`` rows of 4 per slot; ``axes[slot]`` holds the axis
    ``(scale, lo, 1 / range, linthresh)``. ``u8``: nearest entry, as the 8-bit pipeline.
    """
    u = _position(v, int(axes[slot, 0]), axes[slot, 1], axes[slot, 2], axes[slot, 3])
    return table_row(tables, 4 * slot * n, n, u, u8)


@kernel
def _sigma(sigmas, slot, n, i, f):
    """Interpolated extinction of slot ``slot`` at entry ``i``, fraction ``f`` (float64)."""
    return sigma_at(sigmas, slot * n + i, f)


@kernel
def _gradient_factor(gbricks, g, x, y, z, e):
    """Ramp in [0, 1] of the gradient magnitude at ``(x, y, z)`` (0 where it is NaN)."""
    gm = _trilinear(gbricks, 0, g[0], g[1], g[2], g[9], g[10], x, y, z)
    w = (gm - e.g_lo) * e.g_inv
    if not w > 0.0:  # also NaN
        return 0.0
    return min(w, 1.0)


@kernel
def grid_geometry(dims, grids, p):
    """The geometry tuple ``g`` the extended loops read: points along x, y, z, their
    last indices as floats, the brick shift and the block grid's (y, x) and the skip
    grid's (y, x) extents."""
    return (dims[0], dims[1], dims[2], dims[0] - 1.0, dims[1] - 1.0, dims[2] - 1.0, p.block_shift,
            grids[1], grids[2], grids[4], grids[5])


@kernel
def pixel_lod(lods, pix, n_pixels, n_levels):
    """``(lod, level)`` of pixel ``pix``: its ray's level of detail (0 without one: ``lods``
    holds one per pixel or none) and the lower of the mip-map's two levels it samples."""
    lod = lods[pix] if lods.shape[0] == n_pixels else 0.0
    return lod, min(int(lod), n_levels - 1) if lod > 0.0 else 0


# -- extended compositing -------------------------------------------------------------------
@kernel
def _close_segment(marker, prec, state, depth, tables, sigmas, axes, n_table, slot, value, t, u8, p, e):
    """Composite a finished maximum/minimum segment of label ``slot`` (its extreme
    ``value``, met at ``t``) as one sample of the label's opacity over the unit
    distance. Returns the new ``(state, depth)``."""
    r, gg, b, a, i, f = _row(tables, slot, n_table, axes, value, u8)
    a_seg = -math.expm1(-_sigma(sigmas, slot, n_table, i, f) * e.unit)
    if a_seg > 0.0:
        state = _accumulate(marker, prec, state, a_seg, r, gg, b)
        if depth == math.inf and _opacity(marker, state) >= p.depth_alpha:
            depth = t
    return state, depth


@fused_kernel
def _composite_ext(marker, prec, light, bricks, offs, leap, g, pyr, pgeo, lod, gbricks, slots, modes, tables, sigmas,
                   axes, ox, oy, oz, dx, dy, dz, t0, t1, p, e, k0, k1, last_owned):
    """Front-to-back compositing with gradient modulation, labels and mip sampling.

    Composite labels (and unlabelled renders) sample segment midpoints exactly as
    ``_kernels._march_plain``. A label with maximum (minimum) blending collects the
    extreme of its lattice points ``t0 + k step`` while the ray stays in it; when the
    ray leaves it, the segment is classified by that label's transfer function (its
    opacity over the unit distance) and composited as one sample: the two-level
    rendering of Hauser et al. (2001) as used by the Magic Volume Lens (Fig. 15).

    Segments ``k0 <= k < k1`` and, if ``last_owned``, the last one are composited
    (``_kernels.piece_segments``; a piece of a distributed volume has no labels).
    """
    step = p.step
    size = 1 << p.block_shift
    n_table = tables.shape[0] // (4 * modes.shape[0])
    u8 = p.precision == 3
    rx = 1.0 / dx if dx != 0.0 else 0.0
    ry = 1.0 / dy if dy != 0.0 else 0.0
    rz = 1.0 / dz if dz != 0.0 else 0.0
    n_seg = max(int(math.ceil((t1 - t0) / step)), 1)
    n_levels = e.n_levels
    state = _start(marker)
    depth = math.inf
    samples = 0
    seg_slot = -1  # label slot of the open maximum/minimum segment (-1: none)
    seg_best = -math.inf
    seg_sign = 1.0
    seg_t = 0.0
    k = k0
    k_stop = n_seg if last_owned else k1
    stopped = False
    # full segment k has its midpoint at (bx0, by0, bz0) + k (sx, sy, sz), as _kernels._march_plain
    bx0, by0, bz0, sx, sy, sz = midpoint_lattice(ox, oy, oz, dx, dy, dz, t0, step)
    eye = eye_of(light, dx, dy, dz)
    while k < k_stop and not stopped:
        ta = t0 + k * step
        last = k == n_seg - 1
        # the same arithmetic as _kernels._march_plain, so a composite ray gives the same bits
        tb = t1 if last else ta + step
        tm = 0.5 * (ta + t1) if last else t0 + (k + 0.5) * step
        if last:
            xm = ox + tm * dx
            ym = oy + tm * dy
            zm = oz + tm * dz
        else:
            kf = float(k)
            xm = bx0 + kf * sx
            ym = by0 + kf * sy
            zm = bz0 + kf * sz
        # one leap test per segment, at its midpoint (as the plain loop)
        radius, ib, jb, kb, v = _sample(bricks, offs, leap, g, pyr, pgeo, n_levels, lod, xm, ym, zm)
        if radius != 0:
            kn = _leap_to(k, t0, step, ox, oy, oz, rx, ry, rz, ib, jb, kb, radius, size)
            if seg_slot >= 0:
                # an empty stretch ends the open segment (values there are transparent anyway)
                state, depth = _close_segment(marker, prec, state, depth, tables, sigmas, axes, n_table, seg_slot,
                                              seg_sign * seg_best, seg_t, u8, p, e)
                seg_slot = -1
            k = kn
            continue
        if e.labelled and e.lattice:
            # the lattice point at the segment's start, for maximum/minimum labels
            xa = ox + ta * dx
            ya = oy + ta * dy
            za = oz + ta * dz
            sl = np.int64(_label_slot(slots, g, xa, ya, za))
            mode = modes[sl]
            if seg_slot >= 0 and sl != seg_slot:
                state, depth = _close_segment(marker, prec, state, depth, tables, sigmas, axes, n_table, seg_slot,
                                              seg_sign * seg_best, seg_t, u8, p, e)
                seg_slot = -1
            if mode == MAXIMUM or mode == MINIMUM:
                if lod == 0.0:
                    va = _trilinear(bricks, 0, g[0], g[1], g[2], g[9], g[10], xa, ya, za)
                else:
                    va = _lod_value(pyr, pgeo, n_levels, lod, xa, ya, za)
                if va == va:
                    if seg_slot < 0:
                        seg_slot = sl
                        seg_sign = 1.0 if mode == MAXIMUM else -1.0
                        seg_best = -math.inf
                    samples += 1
                    if seg_sign * va > seg_best:
                        seg_best = seg_sign * va
                        seg_t = ta
        k += 1
        if v != v:
            continue
        slot = 0
        if e.labelled:
            slot = np.int64(_label_slot(slots, g, xm, ym, zm))
            if modes[slot] != COMPOSITE:
                continue
            if seg_slot >= 0:
                # a composite sample after an open segment: that segment is over
                state, depth = _close_segment(marker, prec, state, depth, tables, sigmas, axes, n_table, seg_slot,
                                              seg_sign * seg_best, seg_t, u8, p, e)
                seg_slot = -1
        samples += 1
        r, gg, b, a_i, i, f = _row(tables, slot, n_table, axes, v, u8)
        if last or e.gradient:
            # a shortened last segment, or an extinction scaled by the gradient ramp
            sg = _sigma(sigmas, slot, n_table, i, f)
            if e.gradient:
                sg *= _gradient_factor(gbricks, g, xm, ym, zm, e)
            a_i = -math.expm1(-sg * (tb - ta))
        if a_i <= 0.0:
            continue
        # lit as _kernels._march_plain lights (``lit``: the same function), bit for bit
        r, gg, b = lit(light, eye, bricks, offs, g, xm, ym, zm, v, r, gg, b, int(axes[slot, 0]), axes[slot, 2],
                       axes[slot, 3])
        state = _accumulate(marker, prec, state, a_i, r, gg, b)
        alpha = _opacity(marker, state)
        if depth == math.inf and alpha >= p.depth_alpha:
            depth = tm
        if alpha >= p.alpha_stop:
            stopped = True
    if e.labelled and e.lattice and last_owned and not stopped:
        # the exit point ends the lattice, then the open segment
        xa = ox + t1 * dx
        ya = oy + t1 * dy
        za = oz + t1 * dz
        sl = np.int64(_label_slot(slots, g, xa, ya, za))
        if sl == seg_slot:
            if lod == 0.0:
                va = _trilinear(bricks, 0, g[0], g[1], g[2], g[9], g[10], xa, ya, za)
            else:
                va = _lod_value(pyr, pgeo, n_levels, lod, xa, ya, za)
            if va == va and seg_sign * va > seg_best:
                seg_best = seg_sign * va
                seg_t = t1
        elif seg_slot < 0 and (modes[sl] == MAXIMUM or modes[sl] == MINIMUM):
            va = _trilinear(bricks, 0, g[0], g[1], g[2], g[9], g[10], xa, ya, za) if lod == 0.0 else \
                _lod_value(pyr, pgeo, n_levels, lod, xa, ya, za)
            radius, ib, jb, kb = _block(leap, g, xa, ya, za)
            if va == va and radius == 0:
                seg_slot = sl
                seg_sign = 1.0 if modes[sl] == MAXIMUM else -1.0
                seg_best = seg_sign * va
                seg_t = t1
                samples += 1
        if seg_slot >= 0:
            state, depth = _close_segment(marker, prec, state, depth, tables, sigmas, axes, n_table, seg_slot,
                                          seg_sign * seg_best, seg_t, u8, p, e)
    cr, cg, cb, alpha = _finish(marker, state)
    return cr, cg, cb, alpha, depth, samples


@kernel
def _march_ext(marker, light, bricks, offs, leap, g, pyr, pgeo, lod, gbricks, slots, modes, tables, sigmas, axes, ox,
               oy, oz, dx, dy, dz, lo, hi, piece, p, e, t_near, t_far):
    """Clip the ray, keep the segments of ``piece`` (``_kernels._march``) and run
    ``_composite_ext`` in the precision of ``marker`` (only that one is compiled)."""
    t0, t1 = _ray_box(ox, oy, oz, dx, dy, dz, lo, hi, t_near, t_far)
    if not t1 > t0:
        return 0.0, 0.0, 0.0, 0.0, math.inf, 0
    k0, k1, last = piece_segments(ox, oy, oz, dx, dy, dz, hi, piece, t0, t1, p.step, t_far)
    if k1 <= k0 and not last:
        return 0.0, 0.0, 0.0, 0.0, math.inf, 0
    ox -= piece[6]
    oy -= piece[7]
    oz -= piece[8]
    return _composite_ext(marker, _marker_precision(marker, p), light, bricks, offs, leap, g, pyr, pgeo, lod, gbricks,
                          slots, modes, tables, sigmas, axes, ox, oy, oz, dx, dy, dz, t0, t1, p, e, k0, k1, last)


@parallel_kernel
def render_ext(marker, light, bricks, offs, leap, leap_lod, grids, dims, pyr, pgeo, lods, gbricks, slots, modes, tables,
               sigmas, axes, origins, directions, span, width, height, tile, tile_rows, lanes, lo, hi, piece, p, e,
               out_rgba, out_depth, out_samples):
    """Fill the pixels of the tiles in rows ``tile_rows`` with ``_composite_ext`` (labels,
    gradient-magnitude opacity, shading), in the one precision of ``marker`` and lit by
    ``light`` (0: unshaded; see ``_kernels._march``). A ray with a level of detail
    samples the mip-map and skips with ``leap_lod[L]``, ``L`` the lower of its two
    levels; it is lit from the gradient of the full-resolution field."""
    no_cam = np.empty(0)
    g = grid_geometry(dims, grids, p)
    for lane in numba.prange(lanes):
        for i in range(lane_pixels(lane, lanes, tile_rows, tile, width)):
            pix = lane_pixel(i, lane, lanes, tile_rows, tile, width, height)
            if pix < 0:
                continue
            ox, oy, oz, dx, dy, dz, t_near, t_far = pixel_ray_span(no_cam, origins, directions, span, pix,
                                                                   width, height)
            lod, level = pixel_lod(lods, pix, width * height, e.n_levels)
            r, gg, b, a, dep, ns = _march_ext(marker, light, bricks, offs, leap if lod == 0.0 else leap_lod[level],
                                              g, pyr, pgeo, lod, gbricks, slots, modes, tables, sigmas, axes, ox,
                                              oy, oz, dx, dy, dz, lo, hi, piece, p, e, t_near, t_far)
            store_pixel(out_rgba, out_depth, out_samples, pix, r, gg, b, a, dep, ns)


@parallel_kernel
def render_levels(marker, bricks, offs, leap, leap_lod, grids, dims, pyr, pgeo, n_levels, lods, table, sigma,
                  level_tables, level_steps, origins, directions, span, width, height, tile, tile_rows, lanes, lo, hi,
                  piece, p, out_rgba, out_depth, out_samples, out_value):
    """Fill the pixels of the tiles in rows ``tile_rows`` for rays with levels of detail
    (``lods``, one per ray; or one 0 for all) and nothing else extended, composited or
    projected as ``marker`` says (``_composite_kernels``: a precision, or a projection,
    whose values go to ``out_value``, one per pixel; a composite passes a placeholder of
    another length). A ray at level of detail 0
    goes through ``_kernels._march`` as a plain render does, so it is bit-identical to
    one; a ray with a level of detail runs the same loop with the mip-map ``pyr`` as its
    stencil (``mip_sampler``), the step ``level_steps[L]`` and the opacity table
    ``level_tables[L]``, and skips with ``leap_lod[L]`` (``grid._mip_leaps``), ``L`` the
    lower of its two levels."""
    no_cam = np.empty(0)
    for lane in numba.prange(lanes):
        scratch = np.empty(3 * SCRATCH)
        for i in range(lane_pixels(lane, lanes, tile_rows, tile, width)):
            pix = lane_pixel(i, lane, lanes, tile_rows, tile, width, height)
            if pix < 0:
                continue
            lod, level = pixel_lod(lods, pix, width * height, n_levels)
            ox, oy, oz, dx, dy, dz, t_near, t_far = pixel_ray_span(no_cam, origins, directions, span, pix,
                                                                   width, height)
            if lod == 0.0:
                r, gg, b, a, dep, ns, v = _march(marker, 0, 0, bricks, offs, table, sigma, leap, grids, dims, ox, oy,
                                                 oz, dx, dy, dz, lo, hi, piece, p, p.step, scratch, t_near, t_far)
            else:
                # the same loop, its stencil the mip-map's two levels (mip_sampler)
                r, gg, b, a, dep, ns, v = _march(marker, 0, 0, pyr, mip_sampler(pgeo, lod, n_levels),
                                                 level_tables[level], sigma, leap_lod[level], grids, dims, ox, oy, oz,
                                                 dx, dy, dz, lo, hi, piece, p, level_steps[level], scratch, t_near,
                                                 t_far)
            store_pixel(out_rgba, out_depth, out_samples, pix, r, gg, b, a, dep, ns)
            if out_value.shape[0] == out_rgba.shape[0]:
                out_value[pix] = v


# -- volumes derived once per dataset ---------------------------------------------------------
@kernel
def downsample(values, out):
    """Level ``L + 1`` of a mip-map from level ``L`` (both (z, y, x) point grids).

    Point ``i`` of ``out`` is level point ``2 i`` filtered by the tent ``[1, 2, 1] / 4``
    along each axis (edges repeated); NaN points are left out and the weights
    renormalised, so NaN survives only where every neighbour is NaN.
    """
    nz, ny, nx = values.shape
    mz, my, mx = out.shape
    w = (0.25, 0.5, 0.25)
    for k in range(mz):
        for j in range(my):
            for i in range(mx):
                total = 0.0
                weight = 0.0
                for a in range(3):
                    kk = min(max(2 * k + a - 1, 0), nz - 1)
                    for b in range(3):
                        jj = min(max(2 * j + b - 1, 0), ny - 1)
                        for c in range(3):
                            ii = min(max(2 * i + c - 1, 0), nx - 1)
                            v = np.float64(values[kk, jj, ii])
                            if v == v:
                                wt = w[a] * w[b] * w[c]
                                total += wt * v
                                weight += wt
                out[k, j, i] = total / weight if weight > 0.0 else math.nan


@inline_kernel
def _grid_gradient(values, k, j, i, sx, sy, sz):
    """``grad v`` at point ``(i, j, k)`` (world units, ``s*`` = 1 / spacing): central
    differences, one-sided at edges."""
    nz, ny, nx = values.shape
    k0 = max(k - 1, 0)
    k1 = min(k + 1, nz - 1)
    j0 = max(j - 1, 0)
    j1 = min(j + 1, ny - 1)
    i0 = max(i - 1, 0)
    i1 = min(i + 1, nx - 1)
    gx = (np.float64(values[k, j, i1]) - np.float64(values[k, j, i0])) * sx / max(i1 - i0, 1)
    gy = (np.float64(values[k, j1, i]) - np.float64(values[k, j0, i])) * sy / max(j1 - j0, 1)
    gz = (np.float64(values[k1, j, i]) - np.float64(values[k0, j, i])) * sz / max(k1 - k0, 1)
    return gx, gy, gz


@kernel
def gradient_magnitude(values, inv_spacing, out):
    """``|grad v|`` per point (world units), from ``_grid_gradient``."""
    nz, ny, nx = values.shape
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                gx, gy, gz = _grid_gradient(values, k, j, i, inv_spacing[0], inv_spacing[1], inv_spacing[2])
                out[k, j, i] = math.sqrt(gx * gx + gy * gy + gz * gz)


@kernel
def gradient_vectors(values, inv_spacing, out):
    """``grad v`` per point (world units) into ``out`` (3, nz, ny, nx), from ``_grid_gradient``."""
    nz, ny, nx = values.shape
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                gx, gy, gz = _grid_gradient(values, k, j, i, inv_spacing[0], inv_spacing[1], inv_spacing[2])
                out[0, k, j, i] = gx
                out[1, k, j, i] = gy
                out[2, k, j, i] = gz
