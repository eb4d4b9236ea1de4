"""numba kernel of :mod:`pv_hdrvol.proxy.lighting`: arrays in, arrays out.

Nothing here validates or allocates; ``lighting.py`` converts the depth image (NaN at
misses), forms the depth gradient, lists the disc's offsets and allocates the outputs.
Every argument has one type (C-contiguous float64 images, int64 offsets), so the
on-disk cache holds one compilation.

Written for numba 0.56 as well as current releases: explicit loops only.
"""
from __future__ import annotations

import numba

from .._jit import parallel_kernel


@parallel_kernel
def occlusion_sum(depth, grad_row, grad_col, off_row, off_col, ao, count):
    """The proxy ambient occlusion sum (paper Eq. 5) of every pixel into ``ao``.

    ``ao[i, j] = sum_q max(0, Z(p) + grad_row (q_r - p_r) + grad_col (q_c - p_c) - Z(q))``
    over the offsets ``(off_row[k], off_col[k])`` whose pixel ``q`` is inside the image
    and not NaN; ``count[i, j]`` is the number of those ``q``. NaN pixels of ``depth``
    get ``ao`` NaN and ``count`` 0. The gradient is in depth units per pixel.
    """
    rows, cols = depth.shape
    n_off = off_row.shape[0]
    for i in numba.prange(rows):
        for j in range(cols):
            zp = depth[i, j]
            if zp != zp:
                ao[i, j] = zp
                count[i, j] = 0.0
                continue
            gr = grad_row[i, j]
            gc = grad_col[i, j]
            s = 0.0
            n = 0.0
            for k in range(n_off):
                qi = i + off_row[k]
                qj = j + off_col[k]
                if qi < 0 or qi >= rows or qj < 0 or qj >= cols:
                    continue
                zq = depth[qi, qj]
                if zq != zq:
                    continue
                n += 1.0
                # the tangent plane's depth at q minus q's depth: > 0 where q is nearer
                t = (zp - zq) + (gr * off_row[k] + gc * off_col[k])
                if t > 0.0:
                    s += t
            ao[i, j] = s
            count[i, j] = n
