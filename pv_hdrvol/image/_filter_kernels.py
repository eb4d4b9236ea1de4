"""numba kernels for :mod:`pv_hdrvol.image.filters`: arrays in, arrays out.

Nothing here validates or allocates; ``filters.py`` converts dtypes, builds the index
and weight tables and allocates every output and scratch array. Boundaries are
handled through those tables (a reflected index per padded position, a grid cell and
fraction per image row and column), so the inner loops are plain contiguous loops
that numba vectorises.

Written for numba 0.56 as well as current releases: explicit loops only.
"""
from __future__ import annotations

import numba
import numpy as np

from .._jit import kernel, parallel_kernel, uindex as _u


#: Tiles of :func:`convolve_columns`: 256 float64 (2 KiB) per row segment keeps the
#: ``2 r + 1`` input segments of a tile in L2 cache up to ``r`` of a few hundred.
_TILE_COLS = 256
_TILE_ROWS = 64


# -- separable convolution with a symmetric kernel ------------------------------------
@parallel_kernel
def convolve_rows(src, half, col_index, out):
    """Convolve each row of ``src`` (along axis 1) with a symmetric kernel into ``out``.

    ``half[k]`` is the weight at offsets ``+k`` and ``-k`` (``k = 0 .. r``);
    ``col_index[r + j]`` is the column that position ``j`` reads, for ``j`` in
    ``[-r, cols + r)`` (the boundary rule lives in that table). Taps are applied four
    at a time, so each output element is loaded and stored once per four taps. Only
    the first ``src.shape[1]`` columns of ``out`` are written.
    """
    rows, cols = src.shape
    r = half.shape[0] - 1
    w0 = half[0]
    for i in numba.prange(rows):
        s = src[i]
        o = out[i]
        for j in range(cols):
            o[j] = w0 * s[j]
        for k in range(1, r + 1, 4):
            n_taps = min(4, r + 1 - k)
            far = k + n_taps - 1
            # both neighbours of every tap of the group are inside for far <= j < cols - far
            lo = min(far, cols)
            hi = max(cols - far, lo)
            for t in range(n_taps):
                kt = k + t
                wt = half[kt]
                for j in range(lo):
                    o[j] += wt * (s[col_index[r + j - kt]] + s[col_index[r + j + kt]])
                for j in range(hi, cols):
                    o[j] += wt * (s[col_index[r + j - kt]] + s[col_index[r + j + kt]])
            if n_taps == 4:
                w1 = half[k]
                w2 = half[k + 1]
                w3 = half[k + 2]
                w4 = half[k + 3]
                # uint64 indices: numba emits no negative-index check, so LLVM vectorises
                for j in range(lo, hi):
                    o[_u(j)] += (w1 * (s[_u(j - k)] + s[_u(j + k)]) + w2 * (s[_u(j - k - 1)] + s[_u(j + k + 1)])
                                 + w3 * (s[_u(j - k - 2)] + s[_u(j + k + 2)])
                                 + w4 * (s[_u(j - k - 3)] + s[_u(j + k + 3)]))
            else:
                for t in range(n_taps):
                    kt = k + t
                    wt = half[kt]
                    for j in range(lo, hi):
                        o[_u(j)] += wt * (s[_u(j - kt)] + s[_u(j + kt)])


@parallel_kernel
def convolve_columns(src, half, row_index, out):
    """Convolve each column of ``src`` (along axis 0) with a symmetric kernel into ``out``.

    As :func:`convolve_rows` with ``row_index``. Row segments are combined whole, so
    the inner loop runs along contiguous memory, and the work is split into tiles of
    ``_TILE_ROWS x _TILE_COLS``: consecutive output rows of a tile share all but one of
    their ``2 r + 1`` input segments, which then stay in cache.
    """
    rows = src.shape[0]
    cols = out.shape[1]  # src may be wider (padded rows), see filters.gaussian_blur
    r = half.shape[0] - 1
    w0 = half[0]
    n_col_tiles = (cols + _TILE_COLS - 1) // _TILE_COLS
    n_row_tiles = (rows + _TILE_ROWS - 1) // _TILE_ROWS
    for tile in numba.prange(n_row_tiles * n_col_tiles):
        i0 = (tile // n_col_tiles) * _TILE_ROWS
        j0 = (tile % n_col_tiles) * _TILE_COLS
        j1 = min(j0 + _TILE_COLS, cols)
        for i in range(i0, min(i0 + _TILE_ROWS, rows)):
            o = out[i, j0:j1]
            s = src[i, j0:j1]
            m = j1 - j0
            for j in range(m):
                o[j] = w0 * s[j]
            for k in range(1, r + 1, 4):
                n_taps = min(4, r + 1 - k)
                if n_taps == 4:
                    w1 = half[k]
                    w2 = half[k + 1]
                    w3 = half[k + 2]
                    w4 = half[k + 3]
                    a1 = src[row_index[r + i - k], j0:j1]
                    b1 = src[row_index[r + i + k], j0:j1]
                    a2 = src[row_index[r + i - k - 1], j0:j1]
                    b2 = src[row_index[r + i + k + 1], j0:j1]
                    a3 = src[row_index[r + i - k - 2], j0:j1]
                    b3 = src[row_index[r + i + k + 2], j0:j1]
                    a4 = src[row_index[r + i - k - 3], j0:j1]
                    b4 = src[row_index[r + i + k + 3], j0:j1]
                    for j in range(m):
                        o[j] += (w1 * (a1[j] + b1[j]) + w2 * (a2[j] + b2[j]) + w3 * (a3[j] + b3[j])
                                 + w4 * (a4[j] + b4[j]))
                else:
                    for t in range(n_taps):
                        kt = k + t
                        wt = half[kt]
                        a = src[row_index[r + i - kt], j0:j1]
                        b = src[row_index[r + i + kt], j0:j1]
                        for j in range(m):
                            o[j] += wt * (a[j] + b[j])


# -- bilateral grid ----------------------------------------------------------------------
@parallel_kernel
def valid_range(values, ref, row_lo, row_hi, row_count, row_inf):
    """Per row: min and max of ``ref`` and the count over pixels where neither array is
    NaN nor infinite, and the count of pixels with an infinity in either array."""
    rows, cols = values.shape
    inf = np.inf
    for i in numba.prange(rows):
        v_row = values[i]
        e_row = ref[i]
        lo = inf
        hi = -inf
        count = 0
        n_inf = 0
        for j in range(cols):
            v = v_row[j]
            e = e_row[j]
            if (v - v) + (e - e) == 0.0:  # both finite (NaN for NaN or ±inf)
                lo = min(lo, e)
                hi = max(hi, e)
                count += 1
            else:
                n_inf += abs(v) == inf or abs(e) == inf
        row_lo[i] = lo
        row_hi[i] = hi
        row_count[i] = count
        row_inf[i] = n_inf


@parallel_kernel
def splat(values, ref, lo, inv_sigma_range, row_cell, row_frac, col_cell, col_frac, band_start, grid, scratch):
    """Add each pixel's ``(value, 1)`` into ``grid`` with trilinear weights.

    ``grid`` is C-contiguous ``(ny, nx, nz, 2)`` and zero on entry. The cell coordinate
    of pixel ``(i, j)`` is ``(row_cell[i] + row_frac[i], col_cell[j] + col_frac[j],
    (ref[i, j] - lo) * inv_sigma_range)``. NaN pixels (in ``values`` or ``ref``) are
    skipped. ``scratch`` is ``((n_bands + 1) // 2, nx * nz * 2)``.

    Each image row is first splatted in ``x`` and ``z`` into one small ``(nx, nz, 2)``
    slab that stays in L1 cache, which is then added to grid rows ``row_cell[i]`` and
    the next with weights ``1 - row_frac[i]`` and ``row_frac[i]``. Image rows with
    ``row_cell == t`` (band ``t``: rows ``band_start[t]`` up to ``band_start[t + 1]``)
    write only grid rows ``t`` and ``t + 1``, so all even bands run at once, then all
    odd ones: no races, no per-thread grid copies, and the same sums in the same
    order whatever the thread count.
    """
    cols = values.shape[1]
    _, nx, nz, _ = grid.shape
    flat = grid.reshape(grid.size)
    sx = 2 * nz
    sy = sx * nx
    n_bands = band_start.shape[0] - 1
    for parity in range(2):
        for h in numba.prange((n_bands - parity + 1) // 2):
            t = 2 * h + parity
            slab = scratch[h]
            for i in range(band_start[t], band_start[t + 1]):
                for k in range(sy):
                    slab[k] = 0.0
                v_row = values[i]
                e_row = ref[i]
                for j in range(cols):
                    v = v_row[j]
                    e = e_row[j]
                    if v != v or e != e:
                        continue
                    z = (e - lo) * inv_sigma_range
                    z0 = min(int(z), nz - 2)  # min: guards rounding at the top of the range
                    fz = z - z0
                    fx = col_frac[j]
                    q = _u(col_cell[j] * sx + 2 * z0)
                    _splat_cell_pair(slab, q, (1.0 - fx), fz, v)
                    _splat_cell_pair(slab, q + _u(sx), fx, fz, v)
                fy = row_frac[i]
                gy = 1.0 - fy
                base = row_cell[i] * sy
                for k in range(sy):
                    flat[_u(base + k)] += gy * slab[k]
                    flat[_u(base + sy + k)] += fy * slab[k]


@kernel
def _splat_cell_pair(slab, q, w, fz, v):
    """Add ``(w v, w)`` split between the range cells ``z0`` and ``z0 + 1`` (the four
    adjacent numbers from flat offset ``q``)."""
    w_hi = w * fz
    w_lo = w - w_hi
    slab[q] += w_lo * v
    slab[q + _u(1)] += w_lo
    slab[q + _u(2)] += w_hi * v
    slab[q + _u(3)] += w_hi


@parallel_kernel
def blur_grid(grid, half, tmp):
    """Blur ``grid`` (ny, nx, nz, 2) along all three axes with the symmetric kernel
    ``half``, taken as zero outside the grid (there is no data there). The result is
    left in ``tmp`` (same shape); ``grid`` is overwritten."""
    ny, nx, nz, _ = grid.shape
    r = half.shape[0] - 1
    w0 = half[0]
    line = 2 * nz
    for y in numba.prange(ny):
        g = grid[y].reshape(nx * line)
        o = tmp[y].reshape(nx * line)
        # along z, within each (y, x) line: grid -> tmp
        for x in range(nx):
            b = x * line
            for m in range(line):
                o[b + m] = w0 * g[b + m]
            for k in range(1, min(r, nz - 1) + 1):
                wk = half[k]
                for m in range(2 * k, line):  # m = 2 z + c; z - k >= 0
                    o[b + m] += wk * g[b + m - 2 * k]
                for m in range(line - 2 * k):  # z + k < nz
                    o[b + m] += wk * g[b + m + 2 * k]
        # along x, whole lines at a time: tmp -> grid
        for x in range(nx):
            b = x * line
            for m in range(line):
                g[b + m] = w0 * o[b + m]
            for k in range(1, r + 1):
                wk = half[k]
                if x - k >= 0:
                    for m in range(line):
                        g[b + m] += wk * o[b - k * line + m]
                if x + k < nx:
                    for m in range(line):
                        g[b + m] += wk * o[b + k * line + m]
    # along y, whole slabs at a time: grid -> tmp
    slab = nx * line
    for y in numba.prange(ny):
        g = grid.reshape(ny * slab)
        o = tmp[y].reshape(slab)
        b = y * slab
        for m in range(slab):
            o[m] = w0 * g[b + m]
        for k in range(1, r + 1):
            wk = half[k]
            if y - k >= 0:
                for m in range(slab):
                    o[m] += wk * g[b - k * slab + m]
            if y + k < ny:
                for m in range(slab):
                    o[m] += wk * g[b + k * slab + m]


@parallel_kernel
def slice_grid(values, ref, lo, inv_sigma_range, row_cell, row_frac, col_cell, col_frac, band_start, grid, scratch,
               out):
    """Read the blurred homogeneous grid (laid out as in :func:`splat`) back at each
    pixel's cell coordinate with trilinear interpolation and divide; NaN where
    ``values`` or ``ref`` is NaN.

    Per image row, grid rows ``row_cell[i]`` and the next are first interpolated into
    one ``(nx, nz, 2)`` slab of ``scratch`` (as in :func:`splat`), leaving a bilinear
    read per pixel. Work is split by pairs of bands (one slab each).
    """
    cols = values.shape[1]
    _, nx, nz, _ = grid.shape
    flat = grid.reshape(grid.size)
    sx = 2 * nz
    sy = sx * nx
    n_bands = band_start.shape[0] - 1
    nan = np.nan
    for h in numba.prange((n_bands + 1) // 2):
        slab = scratch[h]
        for i in range(band_start[2 * h], band_start[min(2 * h + 2, n_bands)]):
            fy = row_frac[i]
            base = row_cell[i] * sy
            for k in range(sy):
                g0 = flat[_u(base + k)]
                slab[k] = g0 + fy * (flat[_u(base + sy + k)] - g0)
            v_row = values[i]
            e_row = ref[i]
            o = out[i]
            for j in range(cols):
                v = v_row[j]
                e = e_row[j]
                if v != v or e != e:
                    o[j] = nan
                    continue
                z = (e - lo) * inv_sigma_range
                z0 = min(int(z), nz - 2)
                fz = z - z0
                fx = col_frac[j]
                q = _u(col_cell[j] * sx + 2 * z0)
                p = q + _u(sx)
                num0 = slab[q] + fx * (slab[p] - slab[q])
                den0 = slab[q + _u(1)] + fx * (slab[p + _u(1)] - slab[q + _u(1)])
                num1 = slab[q + _u(2)] + fx * (slab[p + _u(2)] - slab[q + _u(2)])
                den1 = slab[q + _u(3)] + fx * (slab[p + _u(3)] - slab[q + _u(3)])
                o[j] = (num0 + fz * (num1 - num0)) / (den0 + fz * (den1 - den0))
