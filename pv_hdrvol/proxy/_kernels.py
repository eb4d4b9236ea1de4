"""numba kernel of proxy generation: one pass along each ray, arrays in, arrays out.

Nothing here validates or allocates; ``proxy/generate.py`` does that. The samples are
the grid ray caster's (``raycast/_kernels``): the lattice of segments of length
``step`` from the box entry, sampled at their midpoints, the last one shortened to end
at the exit; full segments take their opacity from the table, the last from the
extinction. The proxy pass differs in what it keeps and in what it skips:

- no early ray termination and no empty-space leaping: an interval hidden behind an
  opaque one still gets its own opacity, which is what an opacity change reveals;
- per intensity interval ``i`` (uniform on the transfer function's axis): the
  accumulated attenuation ``a_i = sum over its samples of alpha_s T_s`` (``T_s`` the
  transmittance in front of sample ``s``, so the ``a_i`` sum to the pixel's alpha),
  its optical depth ``sum -log(1 - alpha_s)`` and the ray distance of its first
  sample with non-zero opacity;
- per isovalue: the ray distance where the value first reaches it, refined linearly
  between the two samples around the crossing.

``scale`` multiplies each interval's extinction: a sample's opacity ``alpha`` becomes
``1 - (1 - alpha)**k`` -- the ground truth of an opacity change, and the training
renders of the colour model.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import fused_parallel_kernel, inline_kernel
from ..culling._kernels import _trilinear
from ..raycast._kernels import _ray_box, pixel_ray_span, segment_count, sigma_at, table_position, table_row


@inline_kernel
def _scaled(alpha, k):
    """Opacity of a sample whose extinction is multiplied by ``k``."""
    if k == 1.0:
        return alpha
    if alpha >= 1.0:
        return 1.0 if k > 0.0 else 0.0
    return -math.expm1(k * math.log1p(-alpha))


@inline_kernel
def _add_sample(state, r, g, b, a_s, t, q, pix, out_atten, out_depth, out_entry):
    """Composite one sample of opacity ``a_s`` and colour ``r, g, b`` at ray distance
    ``t`` behind ``state = (r, g, b, alpha)``, booked to interval ``q``."""
    w = (1.0 - state[3]) * a_s
    out_atten[pix, q] += w
    if a_s < 1.0:
        out_depth[pix, q] -= math.log1p(-a_s)
    else:
        out_depth[pix, q] = math.inf
    if out_entry[pix, q] == math.inf:
        out_entry[pix, q] = t
    return state[0] + w * r, state[1] + w * g, state[2] + w * b, state[3] + w


@fused_parallel_kernel
def march_proxies(values, table, sigma, p, scale, iso, origins, directions, lo, hi, out_rgba, out_atten, out_depth,
                  out_entry, out_layers):
    """Fill the proxies of every pixel (one ray per row of ``origins``/``directions``,
    voxel coordinates with ``t`` in world units, as ``raycast/_kernels._march``).

    ``table`` (flat, 4 values per entry: r, g, b, opacity of one full step) and
    ``sigma`` (extinction per world unit) are the grid ray caster's; ``p`` its
    ``GridParams`` (step and axis); ``scale`` (float64, one per interval) multiplies
    the extinction of each interval; ``iso`` the isovalues of the depth layers.

    Outputs, all filled here (the caller passes zeros, and ``inf`` for entries and
    layers): ``out_rgba`` (n, 4), ``out_atten`` (n, intervals), ``out_depth`` (n,
    intervals: optical depth), ``out_entry`` (n, intervals: ray distance of the first
    sample with opacity), ``out_layers`` (n, isovalues: ray distance of the first
    crossing).
    """
    n = origins.shape[0]
    n_int = scale.shape[0]
    n_iso = iso.shape[0]
    n_table = table.shape[0] // 4
    step = p.step
    no_cam = np.empty(0)
    no_span = np.empty((0, 2))
    for pix in numba.prange(n):
        ox, oy, oz, dx, dy, dz, _, _ = pixel_ray_span(no_cam, origins, directions, no_span, pix, n, 1)
        t0, t1 = _ray_box(ox, oy, oz, dx, dy, dz, lo, hi, 0.0, math.inf)
        if not t1 > t0:
            continue
        n_seg = segment_count(t0, t1, step)
        state = (0.0, 0.0, 0.0, 0.0)
        prev_v = math.nan
        prev_t = t0
        found = 0
        for k in range(n_seg):
            last = k == n_seg - 1
            if last:
                ta = t0 + (n_seg - 1) * step
                tm = 0.5 * (ta + t1)
            else:
                tm = t0 + (k + 0.5) * step
            v = _trilinear(values, ox + tm * dx, oy + tm * dy, oz + tm * dz)
            if v != v:  # NaN in the stencil: empty, and no crossing through it
                prev_v = v
                continue
            if found < n_iso:
                for j in range(n_iso):
                    if out_layers[pix, j] == math.inf and v >= iso[j]:
                        if prev_v < iso[j]:  # False for NaN: a crossing at the first sample is not refined
                            out_layers[pix, j] = prev_t + (iso[j] - prev_v) / (v - prev_v) * (tm - prev_t)
                        else:
                            out_layers[pix, j] = tm
                        found += 1
            prev_v = v
            prev_t = tm
            u = table_position(v, p)
            r, g, b, a_i, i, f = table_row(table, 0, n_table, u, False)
            if a_i <= 0.0:
                continue
            if last:
                a_i = -math.expm1(-sigma_at(sigma, i, f) * (t1 - ta))
            q = int(u * n_int)
            if q > n_int - 1:
                q = n_int - 1
            a_s = _scaled(a_i, scale[q])
            if a_s <= 0.0:
                continue
            state = _add_sample(state, r, g, b, a_s, tm, q, pix, out_atten, out_depth, out_entry)
        out_rgba[pix, 0] = state[0]
        out_rgba[pix, 1] = state[1]
        out_rgba[pix, 2] = state[2]
        out_rgba[pix, 3] = state[3]
