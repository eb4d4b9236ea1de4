"""numba kernels of view synthesis from proxies: arrays in, arrays out.

``predict_colors`` is one pass per pixel of what ``model.propagate_corrected``,
``model.nearest_centroid`` and ``ColorModel.predict`` do with numpy (they stay the
reference; tests compare): the opacity change propagated by the corrected slab model,
the nearest centroid, the cluster's linear colour. ``splat_slabs`` warps each
interval's slab (entry depth, own opacity, attenuation) into a turned view and fills
the cracks as ``synthesis.splat`` and ``fill_holes`` do for a depth layer, carrying the
own opacity and attenuation along with the depth.

Per-pixel scratch arrays live per chunk of pixels (one allocation per chunk, not per
pixel); ``prange`` runs over chunks, and over intervals for the splat (each interval's
depth buffer is written by one thread, so the nearest point wins deterministically:
the first in pixel order among equals).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import kernel, parallel_kernel
from ._kernels import _scaled

#: pixels per chunk of ``predict_colors``
CHUNK = 1024


@parallel_kernel
def predict_colors(atten, own, entry, scale, centroids, colors, jac, out_rgb, out_atten):
    """``atten``, ``own``, ``entry`` (L, n) float64; ``scale`` (L,); the colour model's
    ``centroids`` (K, L), ``colors`` (K, 3), ``jac`` (K, 3, L). Fills ``out_rgb`` (n, 3)
    and ``out_atten`` (L, n): the propagated attenuation."""
    n_int, n = atten.shape
    n_clusters = centroids.shape[0]
    n_chunks = (n + CHUNK - 1) // CHUNK
    for c in numba.prange(n_chunks):
        order = np.empty(n_int, dtype=np.int64)
        m1 = np.empty(n_int)
        mk = np.empty(n_int)
        a2 = np.empty(n_int)
        for pix in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            # front-to-back order by entry depth, ties by index (insertion sort: stable)
            for i in range(n_int):
                j = i
                e = entry[i, pix]
                while j > 0 and entry[order[j - 1], pix] > e:
                    order[j] = order[j - 1]
                    j -= 1
                order[j] = i
            t1 = 1.0
            tk = 1.0
            for m in range(n_int):
                i = order[m]
                b = own[i, pix]
                bk = _scaled(b, scale[i])
                m1[i] = b * t1
                mk[i] = bk * tk
                t1 *= 1.0 - b
                tk *= 1.0 - bk
            s = 0.0
            total = 0.0
            for i in range(n_int):
                if m1[i] > 0.0:
                    a2[i] = atten[i, pix] * mk[i] / m1[i]
                else:
                    a2[i] = mk[i]
                s += a2[i]
                total += mk[i]
            if s > 0.0:
                f = total / s
                for i in range(n_int):
                    a2[i] *= f
            alpha = 0.0
            for i in range(n_int):
                out_atten[i, pix] = a2[i]
                alpha += a2[i]
            if not alpha > 0.0:
                out_rgb[pix, 0] = 0.0
                out_rgb[pix, 1] = 0.0
                out_rgb[pix, 2] = 0.0
                continue
            best = 0
            best_d = math.inf
            for k in range(n_clusters):
                d = 0.0
                for i in range(n_int):
                    x = a2[i] - centroids[k, i]
                    d += x * x
                if d < best_d:
                    best_d = d
                    best = k
            for ch in range(3):
                v = colors[best, ch]
                for i in range(n_int):
                    v += jac[best, ch, i] * (a2[i] - centroids[best, i])
                out_rgb[pix, ch] = v


@kernel
def _neighbour(row, col, nb, height, width):
    """The pixel index of neighbour ``nb`` (0-8, row by row) of ``(row, col)`` in its 3 x 3
    neighbourhood; -1 for the pixel itself (4) or one outside the image."""
    dr = nb // 3 - 1
    dc = nb % 3 - 1
    r2 = row + dr
    c2 = col + dc
    if (dr == 0 and dc == 0) or r2 < 0 or c2 < 0 or r2 >= height or c2 >= width:
        return -1
    return r2 * width + c2


@parallel_kernel
def splat_slabs(plane, lateral, fwd, dist_scale, entry, own, atten, cam, width, height, fill_min, passes, jump,
                out_z, out_own, out_atten):
    """Warp each interval's slab into a turned parallel view.

    ``plane`` (n, 3): the source pixels' points on their image plane; ``lateral`` (n, 3):
    the unit vector from the pole towards each (zero at the pole); ``fwd`` the source view
    direction; a slab point is ``plane + z fwd - lateral z * dist_scale`` (``dist_scale``
    = 1 / pole_scale for multi-perspective proxies, 0 for plain ones) with ``z`` its
    entry depth (only where its own opacity is > 0). ``cam``: position, right, up,
    forward of the new camera and its pitch (13 values). Fills ``out_z`` (L, h*w, inf
    where nothing), ``out_own``, ``out_atten`` (L, h*w) from the nearest point of each
    pixel, then closes cracks: ``passes`` times, an empty pixel with at least
    ``fill_min`` of 8 covered neighbours takes the mean of those within ``jump`` of
    the nearest (depth, own opacity, attenuation alike).
    """
    n_int, n = entry.shape
    npix = width * height
    for i in numba.prange(n_int):
        z = out_z[i]
        o = out_own[i]
        a = out_atten[i]
        for p in range(npix):
            z[p] = math.inf
            o[p] = 0.0
            a[p] = 0.0
        for src in range(n):
            e = entry[i, src]
            if not (own[i, src] > 0.0 and e < math.inf):
                continue
            d = e * dist_scale
            x = plane[src, 0] + e * fwd[0] - lateral[src, 0] * d - cam[0]
            y = plane[src, 1] + e * fwd[1] - lateral[src, 1] * d - cam[1]
            w = plane[src, 2] + e * fwd[2] - lateral[src, 2] * d - cam[2]
            col = (x * cam[3] + y * cam[4] + w * cam[5]) / cam[12] + 0.5 * width
            row = 0.5 * height - (x * cam[6] + y * cam[7] + w * cam[8]) / cam[12]
            zn = x * cam[9] + y * cam[10] + w * cam[11]
            if not (col >= 0.0 and row >= 0.0):
                continue
            cc = int(col)
            rr = int(row)
            if cc >= width or rr >= height:
                continue
            q = rr * width + cc
            if zn < z[q]:
                z[q] = zn
                o[q] = own[i, src]
                a[q] = atten[i, src]
        for _ in range(passes):
            z0 = z.copy()
            o0 = o.copy()
            a0 = a.copy()
            changed = False
            for rr in range(height):
                for cc in range(width):
                    q = rr * width + cc
                    if z0[q] < math.inf:
                        continue
                    count = 0
                    front = math.inf
                    for nb in range(9):
                        q2 = _neighbour(rr, cc, nb, height, width)
                        if q2 < 0:
                            continue
                        v = z0[q2]
                        if v < math.inf:
                            count += 1
                            if v < front:
                                front = v
                    if count < fill_min:
                        continue
                    sz = 0.0
                    so = 0.0
                    sa = 0.0
                    m = 0
                    for nb in range(9):
                        q2 = _neighbour(rr, cc, nb, height, width)
                        if q2 < 0:
                            continue
                        v = z0[q2]
                        if v < math.inf and v - front <= jump:
                            sz += v
                            so += o0[q2]
                            sa += a0[q2]
                            m += 1
                    z[q] = sz / m
                    o[q] = so / m
                    a[q] = sa / m
                    changed = True
            if not changed:
                break
