"""numba kernels of ``image/upsample.py``: arrays in, arrays out."""
from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import inline_kernel, kernel, parallel_kernel, uindex as _u


#: exp(-x) is read from a table of EXP_STEPS entries per unit over [0, EXP_RANGE]
#: (linear interpolation: relative error below 2e-6); weights past EXP_RANGE (e^-40 =
#: 4e-18) count as 0: the table ends in two zeros, and larger arguments read them
EXP_RANGE = 40.0
EXP_STEPS = 256
_EXP_LAST = int(EXP_RANGE * EXP_STEPS)  # the first of the two zero entries


def exp_table():
    """``exp(-i / EXP_STEPS)`` for ``i = 0 .. EXP_RANGE * EXP_STEPS - 1``, then two zeros."""
    import numpy as np

    table = np.exp(-np.arange(_EXP_LAST + 2) / EXP_STEPS)
    table[_EXP_LAST:] = 0.0
    return table


@inline_kernel
def _exp_neg(table, e):
    """``exp(-e / EXP_STEPS)`` for ``e >= 0`` from ``table`` (0 past the range and for NaN,
    e.g. ``0 * inf`` from a vanishing ``sigma_range``), without a branch (a select)."""
    if not e < _EXP_LAST:
        e = float(_EXP_LAST)
    n = int(e)
    q = _u(n)
    return table[q] + (e - n) * (table[q + _u(1)] - table[q])


@parallel_kernel
def joint_bilateral(low, guide, factor, radius, inv_2ss, inv_2sr, table, out):
    """Joint bilateral upsampling (Kopf et al. 2007; Callahan & Silva 2009).

    ``low`` (h, w, 4) float64 (fewer channels are padded by the caller); ``guide``
    (k, H, W) float64, the full-resolution reference (normalised depth layers, layer
    first); ``out`` (H, W, 4). Low-resolution pixel ``(i, j)`` has its centre at
    full-resolution coordinates ``((i + 1/2) f - 1/2, (j + 1/2) f - 1/2)`` and takes the
    guide of the nearest full-resolution pixel. Output pixel ``p`` averages the low
    pixels within ``radius`` (in low pixels) of its nearest one, weighted by
    ``exp(-|p - q|^2 inv_2ss - |G(p) - G(q)|^2 inv_2sr)`` (distances in full-resolution
    pixels and in guide units). Where every weight underflows (a reference that matches
    no neighbour), the spatial weights alone are used. ``table``: ``exp_table()``.

    The guide at the low pixels' centres is gathered once into a (h, w, k) array, so a
    neighbour's k values are adjacent; weights come from ``table`` without a branch.
    """
    h, w, _ = low.shape
    k, H, W = guide.shape
    at_low = np.empty((h, w, k))
    for i in numba.prange(h):
        gy = min(max(int((i + 0.5) * factor - 0.5 + 0.5), 0), H - 1)
        for j in range(w):
            gx = min(max(int((j + 0.5) * factor - 0.5 + 0.5), 0), W - 1)
            for m in range(k):
                at_low[i, j, m] = guide[m, gy, gx]
    for row in numba.prange(H):
        ci = int(math.floor((row + 0.5) / factor))
        i0 = max(ci - radius, 0)
        i1 = min(ci + radius, h - 1)
        for col in range(W):
            cj = int(math.floor((col + 0.5) / factor))
            j0 = max(cj - radius, 0)
            j1 = min(cj + radius, w - 1)
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            a3 = 0.0
            total = 0.0
            for i in range(i0, i1 + 1):
                qy = (i + 0.5) * factor - 0.5
                dy2 = (row - qy) * (row - qy)
                for j in range(j0, j1 + 1):
                    qx = (j + 0.5) * factor - 0.5
                    dr = 0.0
                    for m in range(k):
                        diff = guide[m, row, col] - at_low[i, j, m]
                        dr += diff * diff
                    wgt = _exp_neg(table, ((dy2 + (col - qx) * (col - qx)) * inv_2ss + dr * inv_2sr) * EXP_STEPS)
                    total += wgt
                    a0 += wgt * low[i, j, 0]
                    a1 += wgt * low[i, j, 1]
                    a2 += wgt * low[i, j, 2]
                    a3 += wgt * low[i, j, 3]
            if not total > 1e-300:
                # no neighbour matches the reference: spatial weights alone
                for i in range(i0, i1 + 1):
                    qy = (i + 0.5) * factor - 0.5
                    for j in range(j0, j1 + 1):
                        qx = (j + 0.5) * factor - 0.5
                        wgt = _exp_neg(table, ((row - qy) * (row - qy) + (col - qx) * (col - qx)) * inv_2ss
                                       * EXP_STEPS)
                        total += wgt
                        a0 += wgt * low[i, j, 0]
                        a1 += wgt * low[i, j, 1]
                        a2 += wgt * low[i, j, 2]
                        a3 += wgt * low[i, j, 3]
            inv = 1.0 / total
            out[row, col, 0] = a0 * inv
            out[row, col, 1] = a1 * inv
            out[row, col, 2] = a2 * inv
            out[row, col, 3] = a3 * inv


@kernel
def _bilinear_taps(n_out, n_low, factor, stride, lo, hi, frac):
    """For each of ``n_out`` output positions along an axis, the two low-resolution
    pixels bilinear interpolation reads (times ``stride``) and the fraction between them
    (as ``bilinear``)."""
    for q in range(n_out):
        x = min(max((q + 0.5) / factor - 0.5, 0.0), n_low - 1.0)
        j0 = min(int(x), max(n_low - 2, 0))
        lo[q] = j0 * stride
        hi[q] = min(j0 + 1, n_low - 1) * stride
        frac[q] = x - j0


@parallel_kernel
def joint_bilinear(low, guide, factor, inv_2sr, table, out):
    """Joint bilateral upsampling with bilinear spatial weights: output pixel ``p`` averages
    the four low-resolution pixels around it (the ones bilinear interpolation reads, with
    the same pixel-centre convention as ``bilinear``), each weighted by its bilinear
    weight times ``exp(-|G(p) - G(q)|^2 inv_2sr)``.

    With a flat guide this is bilinear interpolation; where the guide changes it leans
    towards the neighbours whose guide matches. ``low`` (h, w, 4), ``guide`` (k, H, W),
    ``out`` (H, W, 4) of any float type, all C-contiguous; the guide at a low pixel is
    that of the full-resolution pixel nearest its centre (as ``joint_bilateral``). Where
    every range weight underflows, bilinear weights alone are used. ``table``:
    ``exp_table()``. Arrays are read flat with unsigned offsets from per-row and
    per-column tables (no index arithmetic or wraparound checks per tap).

    An output pixel whose four low pixels are all zero (the background, most often)
    is zero whatever the weights, and is written without computing them.
    """
    h, w, _ = low.shape
    k, H, W = guide.shape
    lo = low.reshape(-1)
    g = guide.reshape(-1)
    res = out.reshape(-1)
    at_low = np.empty(h * w * k)
    for i in numba.prange(h):
        gy = min(max(int((i + 0.5) * factor - 0.5 + 0.5), 0), H - 1)
        for j in range(w):
            gx = min(max(int((j + 0.5) * factor - 0.5 + 0.5), 0), W - 1)
            for m in range(k):
                at_low[(i * w + j) * k + m] = guide[m, gy, gx]
    r0 = np.empty(H, dtype=np.uint64)
    r1 = np.empty(H, dtype=np.uint64)
    fr = np.empty(H)
    _bilinear_taps(H, h, factor, w, r0, r1, fr)  # low pixel index of the row
    c0 = np.empty(W, dtype=np.uint64)
    c1 = np.empty(W, dtype=np.uint64)
    fc = np.empty(W)
    _bilinear_taps(W, w, factor, 1, c0, c1, fc)
    # per low pixel: whether it and the three after it that bilinear taps read with it
    # (clamped at the last row and column, as _bilinear_taps) are all zero
    zero = np.empty(h * w, dtype=np.bool_)
    for i in numba.prange(h):
        i1 = min(i + 1, h - 1)
        for j in range(w):
            j1 = min(j + 1, w - 1)
            z = True
            for c in range(4):
                z = z and low[i, j, c] == 0.0 and low[i, j1, c] == 0.0 and low[i1, j, c] == 0.0 \
                    and low[i1, j1, c] == 0.0
            zero[i * w + j] = z
    scale = inv_2sr * EXP_STEPS
    plane = _u(H * W)
    kk = _u(k)
    four = _u(4)
    for row in numba.prange(H):
        fy = fr[row]
        for col in range(W):
            fx = fc[col]
            q00 = r0[row] + c0[col]
            q01 = r0[row] + c1[col]
            q10 = r1[row] + c0[col]
            q11 = r1[row] + c1[col]
            p = _u(row * W + col)
            if zero[q00]:
                o = p * four
                for c in range(4):
                    res[o + _u(c)] = 0.0
                continue
            d00 = 0.0
            d01 = 0.0
            d10 = 0.0
            d11 = 0.0
            for m in range(k):
                gp = g[_u(m) * plane + p]
                e = gp - at_low[q00 * kk + _u(m)]
                d00 += e * e
                e = gp - at_low[q01 * kk + _u(m)]
                d01 += e * e
                e = gp - at_low[q10 * kk + _u(m)]
                d10 += e * e
                e = gp - at_low[q11 * kk + _u(m)]
                d11 += e * e
            s00 = (1.0 - fy) * (1.0 - fx)
            s01 = (1.0 - fy) * fx
            s10 = fy * (1.0 - fx)
            s11 = fy * fx
            if d00 + d01 + d10 + d11 == 0.0:
                # a flat guide (the background, most often): the weights are the spatial ones,
                # as exp(-0) = table[0] = 1 would give
                w00 = s00
                w01 = s01
                w10 = s10
                w11 = s11
            else:
                w00 = s00 * _exp_neg(table, d00 * scale)
                w01 = s01 * _exp_neg(table, d01 * scale)
                w10 = s10 * _exp_neg(table, d10 * scale)
                w11 = s11 * _exp_neg(table, d11 * scale)
            total = w00 + w01 + w10 + w11
            if not total > 1e-300:
                # no neighbour matches the reference: bilinear weights alone
                w00 = s00
                w01 = s01
                w10 = s10
                w11 = s11
                total = s00 + s01 + s10 + s11
            inv = 1.0 / total
            o = p * four
            for c in range(4):
                uc = _u(c)
                res[o + uc] = (w00 * lo[q00 * four + uc] + w01 * lo[q01 * four + uc] + w10 * lo[q10 * four + uc]
                               + w11 * lo[q11 * four + uc]) * inv


@parallel_kernel
def normalize_depths(depth, missing, out):
    """``out = (depth - near) / (far - near)`` over the finite values of ``depth``
    (``span = 1`` when they are all equal), ``missing`` elsewhere; both flat (the guide
    of ``DepthLayers.normalized``, in two parallel passes)."""
    n = depth.shape[0]
    chunks = 64
    size = (n + chunks - 1) // chunks
    lows = np.full(chunks, np.inf)
    highs = np.full(chunks, -np.inf)
    for c in numba.prange(chunks):
        lo = np.inf
        hi = -np.inf
        for i in range(c * size, min(n, (c + 1) * size)):
            v = depth[i]
            if v - v == 0.0:  # finite
                lo = min(lo, v)
                hi = max(hi, v)
        lows[c] = lo
        highs[c] = hi
    near = lows.min()
    far = highs.max()
    span = far - near if far > near else 1.0
    for i in numba.prange(n):
        v = depth[i]
        out[i] = (v - near) / span if v - v == 0.0 else missing


@parallel_kernel
def bilinear(low, factor, out):
    """Bilinear upsampling with the same pixel-centre convention (edges clamped); the
    taps of each row and column come from ``_bilinear_taps``, computed once."""
    h, w, nc = low.shape
    H, W, _ = out.shape
    r0 = np.empty(H, dtype=np.int64)
    r1 = np.empty(H, dtype=np.int64)
    fr = np.empty(H)
    _bilinear_taps(H, h, factor, 1, r0, r1, fr)
    c0 = np.empty(W, dtype=np.int64)
    c1 = np.empty(W, dtype=np.int64)
    fc = np.empty(W)
    _bilinear_taps(W, w, factor, 1, c0, c1, fc)
    for row in numba.prange(H):
        i0 = r0[row]
        i1 = r1[row]
        fy = fr[row]
        for col in range(W):
            j0 = c0[col]
            j1 = c1[col]
            fx = fc[col]
            for c in range(nc):
                top = low[i0, j0, c] + fx * (low[i0, j1, c] - low[i0, j0, c])
                bottom = low[i1, j0, c] + fx * (low[i1, j1, c] - low[i1, j0, c])
                out[row, col, c] = top + fy * (bottom - top)


@parallel_kernel
def nearest(low, factor, out):
    """Each output pixel takes the low-resolution pixel whose area holds its centre."""
    h, w, nc = low.shape
    H, W, _ = out.shape
    for row in numba.prange(H):
        i = min(int((row + 0.5) / factor), h - 1)
        for col in range(W):
            j = min(int((col + 0.5) / factor), w - 1)
            for c in range(nc):
                out[row, col, c] = low[i, j, c]
