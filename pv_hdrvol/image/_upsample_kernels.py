"""numba kernels of ``image/upsample.py``: arrays in, arrays out."""
from __future__ import annotations

import math

import numba

from .._jit import parallel_kernel


@parallel_kernel
def joint_bilateral(low, guide, factor, radius, inv_2ss, inv_2sr, out):
    """Joint bilateral upsampling (Kopf et al. 2007; Callahan & Silva 2009).

    ``low`` (h, w, c) float64; ``guide`` (H, W, k) float64, the full-resolution
    reference (normalised depth layers); ``out`` (H, W, c). Low-resolution pixel
    ``(i, j)`` has its centre at full-resolution coordinates ``((i + 1/2) f - 1/2,
    (j + 1/2) f - 1/2)`` and takes the guide of the nearest full-resolution pixel.
    Output pixel ``p`` averages the low pixels within ``radius`` (in low pixels) of
    its nearest one, weighted by ``exp(-|p - q|^2 inv_2ss - |G(p) - G(q)|^2 inv_2sr)``
    (distances in full-resolution pixels and in guide units). Where every weight
    underflows (a reference that matches no neighbour), the spatial weights alone are
    used.
    """
    h, w, nc = low.shape
    H, W, k = guide.shape
    for row in numba.prange(H):
        ci = int(math.floor((row + 0.5) / factor))
        for col in range(W):
            cj = int(math.floor((col + 0.5) / factor))
            i0 = max(ci - radius, 0)
            i1 = min(ci + radius, h - 1)
            j0 = max(cj - radius, 0)
            j1 = min(cj + radius, w - 1)
            for c in range(nc):
                out[row, col, c] = 0.0
            total = 0.0
            for i in range(i0, i1 + 1):
                qy = (i + 0.5) * factor - 0.5
                gy = min(max(int(qy + 0.5), 0), H - 1)
                for j in range(j0, j1 + 1):
                    qx = (j + 0.5) * factor - 0.5
                    gx = min(max(int(qx + 0.5), 0), W - 1)
                    dr = 0.0
                    for m in range(k):
                        diff = guide[row, col, m] - guide[gy, gx, m]
                        dr += diff * diff
                    wgt = math.exp(-((row - qy) ** 2 + (col - qx) ** 2) * inv_2ss - dr * inv_2sr)
                    total += wgt
                    for c in range(nc):
                        out[row, col, c] += wgt * low[i, j, c]
            if total > 1e-300:
                inv = 1.0 / total
                for c in range(nc):
                    out[row, col, c] *= inv
                continue
            for c in range(nc):
                out[row, col, c] = 0.0
            for i in range(i0, i1 + 1):
                qy = (i + 0.5) * factor - 0.5
                for j in range(j0, j1 + 1):
                    qx = (j + 0.5) * factor - 0.5
                    ws = math.exp(-((row - qy) ** 2 + (col - qx) ** 2) * inv_2ss)
                    total += ws
                    for c in range(nc):
                        out[row, col, c] += ws * low[i, j, c]
            inv = 1.0 / total
            for c in range(nc):
                out[row, col, c] *= inv


@parallel_kernel
def bilinear(low, factor, out):
    """Bilinear upsampling with the same pixel-centre convention (edges clamped)."""
    h, w, nc = low.shape
    H, W, _ = out.shape
    for row in numba.prange(H):
        y = min(max((row + 0.5) / factor - 0.5, 0.0), h - 1.0)
        i0 = min(int(y), max(h - 2, 0))
        fy = y - i0
        i1 = min(i0 + 1, h - 1)
        for col in range(W):
            x = min(max((col + 0.5) / factor - 0.5, 0.0), w - 1.0)
            j0 = min(int(x), max(w - 2, 0))
            fx = x - j0
            j1 = min(j0 + 1, w - 1)
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
