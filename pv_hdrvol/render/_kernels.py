"""numba kernels for image volumes: arrays in, arrays out.

Nothing here validates or allocates; ``render/grid.py`` does that. Modes are small
integer constants inside the ``GridParams`` tuple (kept in numba's on-disk cache,
unlike jitted callables passed as arguments).

Per ray: clip to the box, march a lattice of segments of length ``step`` (the last
one shortened to end exactly at the exit), sample each at its midpoint, classify, and
composite. Traversal (``_march``) is kept apart from per-sample work (``_classify``)
and compositing (start / accumulate / finish).
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


def kernel(fn):
    """The one decorator every serial kernel uses: nogil, on-disk cache."""
    return numba.njit(nogil=True, cache=True, error_model="numpy")(fn)


def parallel_kernel(fn):
    """As :func:`kernel`, with ``prange`` over pixels."""
    return numba.njit(nogil=True, cache=True, parallel=True, error_model="numpy")(fn)


class GridParams(NamedTuple):
    """Everything scalar a grid render needs, converted once by ``render/grid.py``."""

    origin_x: float
    origin_y: float
    origin_z: float
    inv_sx: float  # 1 / spacing
    inv_sy: float
    inv_sz: float
    spacing_x: float
    spacing_y: float
    spacing_z: float
    step: float  # world units
    precision: int
    scale: int
    axis_lo: float  # transfer-function axis value of table entry 0
    axis_inv_range: float  # 1 / (axis_hi - axis_lo)
    linthresh: float
    tau_stop: float  # stop once optical depth exceeds this (-ln termination)
    depth_alpha: float  # accumulated opacity that records depth
    block_shift: int  # log2(block size in cells)
    skip_empty: bool


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


@kernel
def _round(x, precision):
    if precision == F32:
        return np.float64(np.float32(x))
    if precision == F16:
        return round_half(x)
    if precision == U8:
        return round_u8(x)
    return x


# -- geometry --------------------------------------------------------------------------
@kernel
def _ray_box(o, d, lo, hi):
    """Entry and exit distances of the ray ``o + t d`` (t >= 0) through the box.

    Returns ``(t0, t1)`` with ``t1 <= t0`` when it misses.
    """
    t0 = 0.0
    t1 = math.inf
    for a in range(3):
        if d[a] != 0.0:
            inv = 1.0 / d[a]
            ta = (lo[a] - o[a]) * inv
            tb = (hi[a] - o[a]) * inv
            if ta > tb:
                ta, tb = tb, ta
            if ta > t0:
                t0 = ta
            if tb < t1:
                t1 = tb
        elif o[a] < lo[a] or o[a] > hi[a]:
            return 1.0, 0.0
    return t0, t1


@kernel
def _cell(x, n):
    """Cell index and fraction of continuous voxel coordinate ``x`` on ``n`` points."""
    if x <= 0.0:
        return 0, 0.0
    if n < 2:
        return 0, 0.0
    if x >= n - 1:
        return n - 2, 1.0
    i = int(x)
    if i > n - 2:
        i = n - 2
    return i, x - i


@kernel
def _trilinear(values, i, j, k, fx, fy, fz):
    nz, ny, nx = values.shape
    i1 = i + 1 if nx > 1 else i
    j1 = j + 1 if ny > 1 else j
    k1 = k + 1 if nz > 1 else k
    c00 = values[k, j, i] + fx * (values[k, j, i1] - np.float64(values[k, j, i]))
    c10 = values[k, j1, i] + fx * (values[k, j1, i1] - np.float64(values[k, j1, i]))
    c01 = values[k1, j, i] + fx * (values[k1, j, i1] - np.float64(values[k1, j, i]))
    c11 = values[k1, j1, i] + fx * (values[k1, j1, i1] - np.float64(values[k1, j1, i]))
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


# -- classification ---------------------------------------------------------------------
@kernel
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


@kernel
def _classify(v, rgb, sigma, p):
    """Extinction and colour of data value ``v`` (linear interpolation in the table)."""
    u = table_position(v, p)
    n = sigma.shape[0]
    if p.precision == U8:
        # 8-bit pipeline: the value is quantised to one of 256 entries, no interpolation.
        i = int(u * (n - 1) + 0.5)
        return np.float64(sigma[i]), np.float64(rgb[i, 0]), np.float64(rgb[i, 1]), np.float64(rgb[i, 2])
    x = u * (n - 1)
    i = int(x)
    if i > n - 2:
        i = n - 2
    f = x - i
    s = sigma[i] + f * (sigma[i + 1] - np.float64(sigma[i]))
    r = rgb[i, 0] + f * (rgb[i + 1, 0] - np.float64(rgb[i, 0]))
    g = rgb[i, 1] + f * (rgb[i + 1, 1] - np.float64(rgb[i, 1]))
    b = rgb[i, 2] + f * (rgb[i + 1, 2] - np.float64(rgb[i, 2]))
    return s, r, g, b


# -- the ray -----------------------------------------------------------------------------
@kernel
def _block_exit(o, d, ib, jb, kb, p):
    """Distance at which the ray leaves block (ib, jb, kb)."""
    size = 1 << p.block_shift
    lo_x = p.origin_x + ib * size * p.spacing_x
    lo_y = p.origin_y + jb * size * p.spacing_y
    lo_z = p.origin_z + kb * size * p.spacing_z
    t = math.inf
    if d[0] > 0.0:
        t = min(t, (lo_x + size * p.spacing_x - o[0]) / d[0])
    elif d[0] < 0.0:
        t = min(t, (lo_x - o[0]) / d[0])
    if d[1] > 0.0:
        t = min(t, (lo_y + size * p.spacing_y - o[1]) / d[1])
    elif d[1] < 0.0:
        t = min(t, (lo_y - o[1]) / d[1])
    if d[2] > 0.0:
        t = min(t, (lo_z + size * p.spacing_z - o[2]) / d[2])
    elif d[2] < 0.0:
        t = min(t, (lo_z - o[2]) / d[2])
    return t


@kernel
def _march(values, rgb, sigma, active, o, d, lo, hi, p):
    """Composite one ray. Returns ``(r, g, b, alpha, depth, samples)``.

    ``float64``/``float32`` accumulate optical depth ``tau`` and colour with
    compensated (Kahan) sums, each operation rounded to the precision: the
    transmittance ``exp(-tau)`` and opacity ``-expm1(-tau)`` stay accurate when each
    sample's opacity is far below the precision's epsilon. ``float16``/``uint8``
    apply the conventional ``over`` operator in that buffer precision.
    """
    t0, t1 = _ray_box(o, d, lo, hi)
    depth = math.inf
    if not t1 > t0:
        return 0.0, 0.0, 0.0, 0.0, depth, 0
    nz, ny, nx = values.shape
    prec = p.precision
    step = p.step
    n_seg = int(math.ceil((t1 - t0) / step))
    if n_seg < 1:
        n_seg = 1
    # start: accumulators (value, Kahan compensation)
    cr = 0.0
    cg = 0.0
    cb = 0.0
    tau = 0.0
    er = 0.0
    eg = 0.0
    eb = 0.0
    et = 0.0
    alpha = 0.0  # accumulated opacity for the `over` emulations
    samples = 0
    k = 0
    while k < n_seg:
        ta = t0 + k * step
        tb = ta + step
        if tb > t1 or k == n_seg - 1:
            tb = t1
        seg = tb - ta
        tm = 0.5 * (ta + tb)
        xi, fx = _cell((o[0] + tm * d[0] - p.origin_x) * p.inv_sx, nx)
        yi, fy = _cell((o[1] + tm * d[1] - p.origin_y) * p.inv_sy, ny)
        zi, fz = _cell((o[2] + tm * d[2] - p.origin_z) * p.inv_sz, nz)
        ib = xi >> p.block_shift
        jb = yi >> p.block_shift
        kb = zi >> p.block_shift
        if active[kb, jb, ib] == 0:
            if p.skip_empty:
                # jump to the first lattice segment whose midpoint lies past this block
                te = _block_exit(o, d, ib, jb, kb, p)
                kn = int(math.ceil((te - t0) / step - 0.5))
                k = kn if kn > k else k + 1
            else:
                k += 1
            continue
        k += 1
        v = _trilinear(values, xi, yi, zi, fx, fy, fz)
        if v != v:  # NaN in the stencil: empty
            continue
        s, r, g, b = _classify(v, rgb, sigma, p)
        samples += 1
        if s <= 0.0:
            continue
        tau_i = s * seg
        if prec == F64 or prec == F32:
            # accumulate
            a_i = _round(-math.expm1(-tau_i), prec)
            w = _round(_round(math.exp(-tau), prec) * a_i, prec)
            y = _round(_round(w * r, prec) - er, prec)
            t = _round(cr + y, prec)
            er = _round(_round(t - cr, prec) - y, prec)
            cr = t
            y = _round(_round(w * g, prec) - eg, prec)
            t = _round(cg + y, prec)
            eg = _round(_round(t - cg, prec) - y, prec)
            cg = t
            y = _round(_round(w * b, prec) - eb, prec)
            t = _round(cb + y, prec)
            eb = _round(_round(t - cb, prec) - y, prec)
            cb = t
            y = _round(tau_i - et, prec)
            t = _round(tau + y, prec)
            et = _round(_round(t - tau, prec) - y, prec)
            tau = t
            if depth == math.inf and -math.expm1(-tau) >= p.depth_alpha:
                depth = tm
            if tau > p.tau_stop:
                break
        else:
            a_i = _round(-math.expm1(-tau_i), prec)
            rest = _round(1.0 - alpha, prec)
            cr = _round(cr + _round(rest * _round(a_i * r, prec), prec), prec)
            cg = _round(cg + _round(rest * _round(a_i * g, prec), prec), prec)
            cb = _round(cb + _round(rest * _round(a_i * b, prec), prec), prec)
            alpha = _round(alpha + _round(rest * a_i, prec), prec)
            if depth == math.inf and alpha >= p.depth_alpha:
                depth = tm
            if alpha >= 1.0 or -math.log(1.0 - alpha) > p.tau_stop:
                break
    # finish
    if prec == F64 or prec == F32:
        alpha = _round(-math.expm1(-tau), prec)
    return cr, cg, cb, alpha, depth, samples


@parallel_kernel
def render_rows(values, rgb, sigma, active, origins, directions, width, rows, lanes, lo, hi, p,
                out_rgba, out_depth, out_samples):
    """Fill the pixels of ``rows`` (indices into the image), ``lanes`` rays in flight.

    Lane ``l`` renders rows ``rows[l::lanes]``; lanes are split among threads, so every
    thread's work is spread over the whole image (balanced without dynamic scheduling,
    which numba 0.56 lacks).
    """
    n_rows = rows.shape[0]
    for lane in numba.prange(lanes):
        for jr in range(lane, n_rows, lanes):
            row = rows[jr]
            for c in range(width):
                pix = row * width + c
                r, g, b, a, dep, ns = _march(values, rgb, sigma, active, origins[pix], directions[pix],
                                             lo, hi, p)
                out_rgba[pix, 0] = r
                out_rgba[pix, 1] = g
                out_rgba[pix, 2] = b
                out_rgba[pix, 3] = a
                out_depth[pix] = dep
                out_samples[pix] = ns


@kernel
def block_ranges(values, shift, out_min, out_max):
    """Min and max (NaN ignored) of the points each block's cells touch.

    Block ``b`` covers cells ``[b * size, (b + 1) * size)``, hence points
    ``[b * size, (b + 1) * size]``: neighbouring blocks share a plane of points.
    A block of NaN only gets ``min = +inf, max = -inf``.
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
