"""numba helpers of Blinn-Phong shading, shared by the grid and the tetrahedral ray casters.

A sample (grid) or a cell (tetrahedra) is lit from its gradient: the normal is the
gradient's direction turned towards the eye (two-sided lighting), each light adds
``I (diffuse max(n.l, 0) c + specular max(n.h, 0)^p)`` to ``ambient c``, ``h`` the half
vector of the light and the eye. The lit colour is therefore ``m c + k`` per channel,
``m`` and ``k`` depending only on the normal and the view: ``light_factors`` returns
them, already blended towards no lighting (``m = 1, k = 0``) by the fade weight.

The settings travel as one float64 array (``SH_*`` entries, ``shading.shading_arrays``)
and the lights as a ``(n, LIGHT_COLUMNS)`` float64 array.
"""
from __future__ import annotations

import math

from .._jit import inline_kernel

# entries of the ``shading`` array
SH_AMBIENT, SH_DIFFUSE, SH_SPECULAR, SH_POWER, SH_FADE, SH_SAMPLED, SH_SPACING, SH_INV_SPACING = 0, 1, 2, 3, 4, 5, 6, 9
SHADING_SIZE = 12
# columns of the ``lights`` array: direction (world, towards the light), intensity, headlight flag
LIGHT_COLUMNS = 7
# transfer-function axis codes (data/transfer.SCALE_CODES)
_LOG, _SYMLOG = 1, 2


@inline_kernel
def fade_weight(grad_norm, v, scale, inv_range, linthresh, fade):
    """How much of the lighting a sample gets, in [0, 1]: the gradient magnitude
    ``grad_norm`` (data units per world unit) on the transfer function's axis
    (``scale``, ``1 / range``, ``linthresh``) at value ``v``, times ``fade`` (the
    smallest cell size over ``shade_threshold``), capped at 1. 0 where it is NaN."""
    if scale == _LOG:
        slope = 1.0 / (v * math.log(10.0)) if v > 0.0 else 0.0
    elif scale == _SYMLOG:
        slope = 1.0 / ((linthresh + abs(v)) * math.log(10.0))
    else:
        slope = 1.0
    w = grad_norm * slope * inv_range * fade
    if not w > 0.0:  # also NaN
        return 0.0
    return min(w, 1.0)


@inline_kernel
def light_factors(gx, gy, gz, ex, ey, ez, w, shading, lights):
    """``(mr, mg, mb, kr, kg, kb)``: the lit colour is ``m c + k`` per channel.

    ``(gx, gy, gz)`` is the gradient (any non-zero length), ``(ex, ey, ez)`` the unit
    vector towards the eye (world), ``w`` the fade weight: ``m = 1 + w (m_lit - 1)``,
    ``k = w k_lit``, so ``w = 0`` leaves the colour as it is, exactly.
    """
    if not w > 0.0:
        return 1.0, 1.0, 1.0, 0.0, 0.0, 0.0
    mag = math.sqrt(gx * gx + gy * gy + gz * gz)
    nx = gx / mag
    ny = gy / mag
    nz = gz / mag
    if nx * ex + ny * ey + nz * ez < 0.0:
        nx = -nx
        ny = -ny
        nz = -nz
    dr = 0.0
    dg = 0.0
    db = 0.0
    sr = 0.0
    sg = 0.0
    sb = 0.0
    power = shading[SH_POWER]
    ks = shading[SH_SPECULAR]
    for k in range(lights.shape[0]):
        if lights[k, 6] != 0.0:
            lx = ex
            ly = ey
            lz = ez
        else:
            lx = lights[k, 0]
            ly = lights[k, 1]
            lz = lights[k, 2]
        ndl = nx * lx + ny * ly + nz * lz
        if ndl <= 0.0:
            continue
        dr += lights[k, 3] * ndl
        dg += lights[k, 4] * ndl
        db += lights[k, 5] * ndl
        if ks == 0.0:
            continue
        hx = lx + ex
        hy = ly + ey
        hz = lz + ez
        hl = math.sqrt(hx * hx + hy * hy + hz * hz)
        if hl > 0.0:
            ndh = (nx * hx + ny * hy + nz * hz) / hl
            if ndh > 0.0:
                s = ndh ** power
                sr += lights[k, 3] * s
                sg += lights[k, 4] * s
                sb += lights[k, 5] * s
    ka = shading[SH_AMBIENT]
    kd = shading[SH_DIFFUSE]
    return (1.0 + w * (ka + kd * dr - 1.0), 1.0 + w * (ka + kd * dg - 1.0), 1.0 + w * (ka + kd * db - 1.0),
            w * ks * sr, w * ks * sg, w * ks * sb)
