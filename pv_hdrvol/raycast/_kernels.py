"""numba kernels for image volumes: arrays in, arrays out.

Nothing here validates or allocates; ``raycast/grid.py`` does that. Modes are small
integer constants inside the ``GridParams`` tuple (kept in numba's on-disk cache,
unlike jitted callables passed as arguments).

The volume is stored in bricks of ``(8 + 1)**3`` points (one shared plane per
side), so a sample's eight neighbours sit in one small contiguous block of memory
whatever the view direction; a plain (z, y, x) array strides whole planes apart,
which on power-of-two volumes maps every plane to the same cache set.

Per ray: clip to the box, march a lattice of segments of length ``step`` (the last
one shortened to end exactly at the exit), sample each at its midpoint, classify
through one interleaved (N, 4) table (r, g, b, opacity per step), and composite (start /
accumulate / finish inside ``_march``).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

# precision codes (params.PRECISION_CODES)
F64, F32, F16, U8 = 0, 1, 2, 3
# transfer-function axis codes (data/transfer.SCALE_CODES)
LINEAR, LOG, SYMLOG = 0, 1, 2
# bricks of 2**BRICK_SHIFT cells a side (memory layout; independent of skip blocks)
BRICK_SHIFT = 3


def kernel(fn):
    """The one decorator every serial kernel uses: nogil, on-disk cache."""
    return numba.njit(nogil=True, cache=True, error_model="numpy")(fn)


def inline_kernel(fn):
    """For small per-sample helpers: inlined at numba IR level into their caller."""
    return numba.njit(nogil=True, cache=True, error_model="numpy", inline="always")(fn)


def parallel_kernel(fn):
    """As :func:`kernel`, with ``prange`` over pixels."""
    return numba.njit(nogil=True, cache=True, parallel=True, error_model="numpy")(fn)


class GridParams(NamedTuple):
    """Everything scalar a grid render needs, converted once by ``raycast/grid.py``.

    At most 15 fields: numba 0.56 on Python 3.11 rebuilds a NamedTuple used inside
    ``prange`` with a keyword call, which it cannot compile past 15 arguments.
    """

    step: float  # world units
    precision: int
    scale: int
    axis_lo: float  # transfer-function axis value of table entry 0
    axis_inv_range: float  # 1 / (axis_hi - axis_lo)
    linthresh: float
    alpha_stop: float  # stop once accumulated opacity reaches this (1 - termination)
    depth_alpha: float  # accumulated opacity that records depth
    block_shift: int  # log2(edge of an empty-space block, in cells)


# -- rounding that emulates a buffer's precision ---------------------------------------
@kernel
def round_half(x):
    """Round a float64 to the nearest IEEE half value (ties to even), as float64."""
    if x == 0.0 or x != x:
        return x
    ax = abs(x)
    if ax >= 65520.0:  # rounds to infinity in half
        return math.copysign(math.inf, x)
    m, e = math.frexp(ax)  # ax = m * 2**e, 0.5 <= m < 1
    ex = e - 1
    if ex < -14:
        ex = -14  # subnormal range: fixed quantum 2**-24
    q = math.ldexp(1.0, ex - 10)
    r = ax / q
    f = math.floor(r)
    d = r - f
    if d > 0.5 or (d == 0.5 and (f - 2.0 * math.floor(0.5 * f)) == 1.0):
        f += 1.0
    return math.copysign(f * q, x)


@kernel
def round_u8(x):
    """Round to the nearest multiple of 1/255 in [0, 1], as an 8-bit buffer stores it."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return math.floor(x * 255.0 + 0.5) / 255.0


@inline_kernel
def _round(x, precision):
    """Round to what an emulated ``float16`` or ``uint8`` buffer stores (else unchanged)."""
    if precision == F16:
        return round_half(x)
    if precision == U8:
        return round_u8(x)
    return x


@inline_kernel
def _kahan_add32(total, comp, x):
    """Compensated float32 ``total + x``: returns the new total and compensation."""
    y = x - comp
    t = total + y
    return t, (t - total) - y


# -- geometry --------------------------------------------------------------------------
@inline_kernel
def _slab(o, d, lo, hi, t0, t1):
    """Narrow ``[t0, t1]`` to where ``o + t d`` lies in ``[lo, hi]`` on one axis."""
    if d != 0.0:
        inv = 1.0 / d
        ta = (lo - o) * inv
        tb = (hi - o) * inv
        if ta > tb:
            ta, tb = tb, ta
        return max(t0, ta), min(t1, tb)
    if o < lo or o > hi:
        return 1.0, 0.0
    return t0, t1


@inline_kernel
def _ray_box(ox, oy, oz, dx, dy, dz, lo, hi):
    """Entry and exit distances of the ray ``o + t d`` (t >= 0) through the box.

    Returns ``(t0, t1)`` with ``t1 <= t0`` when it misses.
    """
    t0, t1 = _slab(ox, dx, lo[0], hi[0], 0.0, math.inf)
    t0, t1 = _slab(oy, dy, lo[1], hi[1], t0, t1)
    return _slab(oz, dz, lo[2], hi[2], t0, t1)


@inline_kernel
def _cell(x, x_max, n):
    """Cell index and fraction of voxel coordinate ``x`` on ``n >= 2`` points.

    Branch-free: ``x`` is clamped to ``[0, x_max = n - 1]`` and the index to ``n - 2``
    (so ``x = n - 1`` gives the last cell with fraction 1).
    """
    x = min(max(x, 0.0), x_max)
    i = min(int(x), n - 2)
    return i, x - i


@inline_kernel
def _trilinear(bricks, base, pitch, li, lj, lk, fx, fy, fz):
    """Trilinear interpolation inside one brick of ``pitch**3`` points, at ``base``."""
    q = base + (lk * pitch + lj) * pitch + li
    p2 = pitch * pitch
    v000 = np.float64(bricks[q])
    v100 = np.float64(bricks[q + 1])
    v010 = np.float64(bricks[q + pitch])
    v110 = np.float64(bricks[q + pitch + 1])
    v001 = np.float64(bricks[q + p2])
    v101 = np.float64(bricks[q + p2 + 1])
    v011 = np.float64(bricks[q + p2 + pitch])
    v111 = np.float64(bricks[q + p2 + pitch + 1])
    c00 = v000 + fx * (v100 - v000)
    c10 = v010 + fx * (v110 - v010)
    c01 = v001 + fx * (v101 - v001)
    c11 = v011 + fx * (v111 - v011)
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


# -- classification ---------------------------------------------------------------------
@inline_kernel
def table_position(v, p):
    """Position in [0, 1] of data value ``v`` on the table's axis (float64)."""
    if p.scale == LOG:
        if v > 0.0:
            a = math.log10(v)
        else:
            return 0.0
    elif p.scale == SYMLOG:
        a = math.copysign(math.log10(1.0 + abs(v) / p.linthresh), v)
    else:
        a = v
    u = (a - p.axis_lo) * p.axis_inv_range
    if u < 0.0:
        return 0.0
    if u > 1.0:
        return 1.0
    return u


@inline_kernel
def _table_index(v, n, p):
    """Entry ``i`` and fraction ``f`` of ``v`` in a table of ``n`` rows."""
    u = table_position(v, p)
    if p.precision == U8:
        # 8-bit pipeline: one of 256 entries, no interpolation
        return int(u * (n - 1) + 0.5), 0.0
    x = u * (n - 1)
    i = int(x)
    if i > n - 2:
        i = n - 2
    return i, x - i


# -- the ray -----------------------------------------------------------------------------
@inline_kernel
def _axis_exit(o, inv_d, b, radius, size):
    """Ray parameter at which ``o + t d`` leaves blocks ``b - radius + 1 .. b + radius - 1``
    along one axis (``inv_d = 1 / d``, 0 for a ray parallel to the axis)."""
    if inv_d > 0.0:
        return ((b + radius) * size - o) * inv_d
    if inv_d < 0.0:
        return ((b - radius + 1) * size - o) * inv_d
    return math.inf


@kernel
def _march(bricks, table, sigma, leap, grids, dims, ox, oy, oz, dx, dy, dz, lo, hi, p):
    """Composite one ray. Returns ``(r, g, b, alpha, depth, samples)``.

    ``grids`` holds the shapes (z, y, x) of the empty-space block grid, then of the
    brick grid. ``leap`` (flat over the block grid) is 0 for a block to sample, else the
    Chebyshev distance ``r`` (in blocks) to the nearest such block: the ray may leave
    the whole cube of blocks within ``r - 1`` at once (empty-space leaping).

    ``table`` rows are ``(r, g, b, a)`` with ``a`` the opacity of one full ``step``
    (opacity-corrected on the host), so full segments need no exponential; ``sigma``
    (extinction per world unit, same rows) serves the shorter last segment.

    Needs at least 2 points on every axis (a flat volume has no thickness and is not
    rendered: ``raycast/grid.py`` returns an empty image before calling).

    The ray ``o + t d`` is in voxel coordinates (point ``(i, j, k)`` at ``(i, j, k)``)
    with ``t`` in world units: ``d`` is the world direction divided by the spacing.

    Front to back, each sample adds ``w = (1 - A) a_i`` to the accumulated opacity
    ``A`` and ``w c_i`` to the colour. ``1 - a_i`` is never formed: in float32,
    1 - 1e-7 rounds to 1 - 1.19e-7, and multiplying transmittance by it loses 19% over
    4,096 samples; ``A`` itself is small there and sums exactly. float32 works in
    float32 arithmetic with compensated (Kahan) sums. ``float16``/``uint8`` apply the
    conventional ``over`` operator in that buffer precision, for comparison.
    """
    t0, t1 = _ray_box(ox, oy, oz, dx, dy, dz, lo, hi)
    depth = math.inf
    if not t1 > t0:
        return 0.0, 0.0, 0.0, 0.0, depth, 0
    nx = dims[0]
    ny = dims[1]
    nz = dims[2]
    x_max = nx - 1.0
    y_max = ny - 1.0
    z_max = nz - 1.0
    by, bx = grids[1], grids[2]  # empty-space blocks
    qy, qx = grids[4], grids[5]  # bricks
    shift = p.block_shift
    size = 1 << shift
    brick_mask = (1 << BRICK_SHIFT) - 1
    pitch = (1 << BRICK_SHIFT) + 1
    brick_len = pitch * pitch * pitch
    n_table = table.shape[0]
    prec = p.precision
    step = p.step
    rx = 1.0 / dx if dx != 0.0 else 0.0  # reciprocals for block exits (0: never exits)
    ry = 1.0 / dy if dy != 0.0 else 0.0
    rz = 1.0 / dz if dz != 0.0 else 0.0
    n_seg = int(math.ceil((t1 - t0) / step))
    if n_seg < 1:
        n_seg = 1
    # start: premultiplied colour and opacity (float64, and the emulations) ...
    cr = 0.0
    cg = 0.0
    cb = 0.0
    alpha = 0.0
    # ... and in float32, with Kahan compensations
    one32 = np.float32(1.0)
    r32 = np.float32(0.0)
    g32 = np.float32(0.0)
    b32 = np.float32(0.0)
    a32 = np.float32(0.0)
    er32 = np.float32(0.0)
    eg32 = np.float32(0.0)
    eb32 = np.float32(0.0)
    ea32 = np.float32(0.0)
    samples = 0
    k = 0
    while k < n_seg:
        ta = t0 + k * step
        last = k == n_seg - 1
        tm = 0.5 * (ta + t1) if last else ta + 0.5 * step
        xi, fx = _cell(ox + tm * dx, x_max, nx)
        yi, fy = _cell(oy + tm * dy, y_max, ny)
        zi, fz = _cell(oz + tm * dz, z_max, nz)
        ib = xi >> shift
        jb = yi >> shift
        kb = zi >> shift
        block = (kb * by + jb) * bx + ib
        radius = leap[block]
        if radius != 0:
            # empty: leave the cube of blocks within radius - 1 of this one, landing on the
            # first lattice segment whose midpoint lies past it
            te = min(_axis_exit(ox, rx, ib, radius, size), _axis_exit(oy, ry, jb, radius, size),
                     _axis_exit(oz, rz, kb, radius, size))
            kn = int(math.ceil((te - t0) / step - 0.5))
            k = kn if kn > k else k + 1
            continue
        k += 1
        brick = ((zi >> BRICK_SHIFT) * qy + (yi >> BRICK_SHIFT)) * qx + (xi >> BRICK_SHIFT)
        v = _trilinear(bricks, brick * brick_len, pitch, xi & brick_mask, yi & brick_mask, zi & brick_mask,
                       fx, fy, fz)
        if v != v:  # NaN in the stencil: empty
            continue
        samples += 1
        i, f = _table_index(v, n_table, p)
        a_i = table[i, 3] + f * (table[i + 1, 3] - np.float64(table[i, 3])) if f > 0.0 else np.float64(table[i, 3])
        if a_i <= 0.0:
            continue
        if f > 0.0:
            r = table[i, 0] + f * (table[i + 1, 0] - np.float64(table[i, 0]))
            g = table[i, 1] + f * (table[i + 1, 1] - np.float64(table[i, 1]))
            b = table[i, 2] + f * (table[i + 1, 2] - np.float64(table[i, 2]))
        else:
            r = np.float64(table[i, 0])
            g = np.float64(table[i, 1])
            b = np.float64(table[i, 2])
        if last:
            # the table holds the opacity of one full step; the last segment is shorter,
            # so take its opacity from the extinction (a_i may have rounded to 1)
            s = sigma[i] + f * (sigma[i + 1] - np.float64(sigma[i])) if f > 0.0 else np.float64(sigma[i])
            a_i = -math.expm1(-s * (t1 - ta))
        if prec == F64:
            # accumulate: plain float64 sums are accurate to ~n eps
            w = (1.0 - alpha) * a_i
            cr += w * r
            cg += w * g
            cb += w * b
            alpha += w
        elif prec == F32:
            # float32 arithmetic throughout, with compensated sums
            w32 = (one32 - a32) * np.float32(a_i)
            r32, er32 = _kahan_add32(r32, er32, w32 * np.float32(r))
            g32, eg32 = _kahan_add32(g32, eg32, w32 * np.float32(g))
            b32, eb32 = _kahan_add32(b32, eb32, w32 * np.float32(b))
            a32, ea32 = _kahan_add32(a32, ea32, w32)
            alpha = np.float64(a32)
        else:
            # the conventional `over` operator in a half-float or 8-bit buffer
            a_i = _round(a_i, prec)
            rest = _round(1.0 - alpha, prec)
            cr = _round(cr + _round(rest * _round(a_i * r, prec), prec), prec)
            cg = _round(cg + _round(rest * _round(a_i * g, prec), prec), prec)
            cb = _round(cb + _round(rest * _round(a_i * b, prec), prec), prec)
            alpha = _round(alpha + _round(rest * a_i, prec), prec)
        if depth == math.inf and alpha >= p.depth_alpha:
            depth = tm
        if alpha >= p.alpha_stop:
            break
    # finish
    if prec == F32:
        return np.float64(r32), np.float64(g32), np.float64(b32), np.float64(a32), depth, samples
    return cr, cg, cb, alpha, depth, samples


@parallel_kernel
def render_tiles(bricks, table, sigma, leap, grids, dims, origins, directions, width, height, tile, tile_rows, lanes,
                 lo, hi, p, out_rgba, out_depth, out_samples):
    """Fill the pixels of the tiles in the rows of tiles ``tile_rows``.

    Tiles of ``tile x tile`` rays walk nearly the same bricks, so they stay in cache
    (a row of rays sweeps a whole slab of the volume). Lane ``l`` renders tiles
    ``l, l + lanes, ...``; lanes are split among threads, so each thread's work is
    spread over the image (balanced without dynamic scheduling, which numba 0.56
    lacks).
    """
    tiles_x = (width + tile - 1) // tile
    n_tiles = tile_rows.shape[0] * tiles_x
    for lane in numba.prange(lanes):
        for t in range(lane, n_tiles, lanes):
            row0 = tile_rows[t // tiles_x] * tile
            col0 = (t % tiles_x) * tile
            for row in range(row0, min(row0 + tile, height)):
                for col in range(col0, min(col0 + tile, width)):
                    pix = row * width + col
                    r, g, b, a, dep, ns = _march(bricks, table, sigma, leap, grids, dims,
                                                 origins[pix, 0], origins[pix, 1], origins[pix, 2],
                                                 directions[pix, 0], directions[pix, 1], directions[pix, 2],
                                                 lo, hi, p)
                    out_rgba[pix, 0] = r
                    out_rgba[pix, 1] = g
                    out_rgba[pix, 2] = b
                    out_rgba[pix, 3] = a
                    out_depth[pix] = dep
                    out_samples[pix] = ns


@kernel
def make_bricks(values, shift, bz, by, bx, out):
    """Copy ``values`` (z, y, x) into a (bz, by, bx) grid of bricks of ``(size + 1)**3`` points.

    Brick ``(kb, jb, ib)`` holds points ``[b * size, b * size + size]`` on each axis (the
    last plane duplicates the next brick's first: trilinear interpolation never leaves
    a brick). Points past the volume's edge repeat the edge. ``out`` is flat, bricks in
    (kb, jb, ib) order, points z, y, x inside.
    """
    nz, ny, nx = values.shape
    size = 1 << shift
    pitch = size + 1
    q = 0
    for kb in range(bz):
        for jb in range(by):
            for ib in range(bx):
                for lk in range(pitch):
                    k = min(kb * size + lk, nz - 1)
                    for lj in range(pitch):
                        j = min(jb * size + lj, ny - 1)
                        for li in range(pitch):
                            i = min(ib * size + li, nx - 1)
                            out[q] = values[k, j, i]
                            q += 1


@kernel
def block_ranges(values, shift, out_min, out_max):
    """Min and max (NaN ignored) of the points each block's cells touch.

    Block ``b`` covers cells ``[b * size, (b + 1) * size)``, hence points
    ``[b * size, (b + 1) * size]``: neighbouring blocks share a plane of points. A
    block of NaN only gets ``min = +inf, max = -inf``.
    """
    nz, ny, nx = values.shape
    bz, by, bx = out_min.shape
    size = 1 << shift
    for kb in range(bz):
        for jb in range(by):
            for ib in range(bx):
                lo = math.inf
                hi = -math.inf
                for k in range(kb * size, min((kb + 1) * size + 1, nz)):
                    for j in range(jb * size, min((jb + 1) * size + 1, ny)):
                        for i in range(ib * size, min((ib + 1) * size + 1, nx)):
                            v = np.float64(values[k, j, i])
                            if v < lo:
                                lo = v
                            if v > hi:
                                hi = v
                out_min[kb, jb, ib] = lo
                out_max[kb, jb, ib] = hi
