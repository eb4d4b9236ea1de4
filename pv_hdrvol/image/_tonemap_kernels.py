"""numba kernels for tone mapping: one fused pass per pixel, arrays in and arrays out.

``map_pixels`` applies a global tone curve (chosen by a small integer code) or a
precomputed display luminance, carries colour by the luminance ratio with a saturation
exponent, and encodes for the display, writing float32 in [0, 1]. Fusing these keeps a
1024² image to one read and one write (numpy needs ~10 full-size temporaries).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import helper_kernel, parallel_kernel
from .display import srgb_encode

# curve codes (tonemap._CURVES)
PRECOMPUTED, LINEAR, REINHARD, DRAGO, KNEE = 0, 1, 2, 3, 4
# display encodings (tonemap._ENCODINGS)
ENC_LINEAR, ENC_TABLE = 0, 1

# Rec. 709 luminance weights
WR, WG, WB = 0.2126, 0.7152, 0.0722

# Display encodings (sRGB, or a gamma x**(1/g)) are tabulated over u = sqrt(x): smooth
# there (sRGB: u**(5/6)), so linear interpolation in 4096 steps is within 1e-7 of the
# formula for sRGB; a gamma > 2 has u**(2/g) with an infinite slope at 0: measured max
# error 2e-5 (gamma 2.2) and 1.6e-4 (2.6, 1/25 of an 8-bit step) next to black, and
# below 4e-7 above x = 1e-4.
ENCODING_LUT_SIZE = 4096
# Drago's display curve is tabulated over t = ln(L_w), DRAGO_TABLE_DECADES below its peak
DRAGO_TABLE_SIZE = 16384
DRAGO_TABLE_DECADES = 30.0


def encoding_lut(gamma=None):
    """Encoded values at ``x = u**2``, ``u = i / (n - 1)``: sRGB, or ``x**(1/gamma)``; n + 1 entries."""
    u = np.linspace(0.0, 1.0, ENCODING_LUT_SIZE)
    x = u * u
    if gamma is None:
        enc = srgb_encode(x)
    else:
        enc = np.power(x, 1.0 / gamma)
    return np.append(enc, enc[-1])  # guard entry: index n - 1 + 1 is safe


@helper_kernel
def curve(y, code, p):
    """Display luminance of world luminance ``y >= 0`` under the global curve ``code``.

    ``p`` (float64 array) holds the fitted parameters, see ``tonemap``'s operators.
    """
    if code == LINEAR:
        return y * p[0]
    if code == REINHARD:
        # p = (key / log-average, 1 / white**2)
        lm = y * p[0]
        return lm * (1.0 + lm * p[1]) / (1.0 + lm)
    if code == KNEE:
        # p = (2**exposure, knee): the identity up to the knee, then a shoulder
        # knee + (1 - knee)(1 - exp(-(x - knee) / (1 - knee))), slope 1 at the knee,
        # approaching 1 (map_pixels applies it to the largest channel)
        x = y * p[0]
        if x <= p[1]:
            return x
        room = 1.0 - p[1]
        return p[1] + room * -math.expm1(-(x - p[1]) / room)
    # DRAGO: p = (exposure / adaptation luminance, scaled max, log(bias)/log(0.5), scale,
    # peak): the formula falls again past its peak (near the max), so it is
    # held there to stay monotone for pixels brighter than the fitted maximum
    lw = min(y * p[0], p[4])
    if lw <= 0.0:
        return 0.0
    return p[3] * math.log1p(lw) / math.log(2.0 + 8.0 * math.exp(p[2] * math.log(lw / p[1])))


@helper_kernel
def _display_curve(y, code, p, table):
    """``curve`` for display values. Drago (four transcendental functions) is read from
    ``table``, its curve sampled over ``t = ln(L_w)`` from ``p[5]`` in steps of
    ``1 / p[6]`` up to the peak: one log and a lerp, within 2e-6 relative (steps of
    0.004 in t); below the table the formula is used."""
    if code == DRAGO and table.shape[0] > 0:
        lw = min(y * p[0], p[4])
        if lw <= 0.0:
            return 0.0
        x = (math.log(lw) - p[5]) * p[6]
        if x < 0.0:
            return curve(y, code, p)
        i = min(int(x), table.shape[0] - 2)
        f = x - i
        return table[i] + f * (table[i + 1] - table[i])
    return curve(y, code, p)


@helper_kernel
def _encode(x, enc, lut):
    if not x > 0.0:  # also NaN
        return 0.0
    if x >= 1.0:
        return 1.0
    if enc == ENC_TABLE:
        t = math.sqrt(x) * (ENCODING_LUT_SIZE - 1)
        i = int(t)
        f = t - i
        return lut[i] + f * (lut[i + 1] - lut[i])
    return x


@parallel_kernel
def map_pixels(rgb, display_lum, code, p, table, saturation, enc, lut, out):
    """Tone map ``rgb`` (n, >= 3; extra columns such as alpha are ignored) linear into ``out`` (n, 3) float32 display values in [0, 1].

    ``KNEE`` maps the largest channel through its curve and scales the three alike (hue
    and chroma kept). Otherwise display luminance ``Ld`` comes from ``curve(code, p)`` (Drago: from ``table``, see
    ``_display_curve``) or, for ``PRECOMPUTED``, from ``display_lum`` (n,). Encoding:
    ``ENC_TABLE`` reads ``lut`` (``encoding_lut``), ``ENC_LINEAR`` clips. Colour: ``out_c = (c / L)**saturation * Ld`` (plain
    ``c * Ld / L`` for saturation 1). ``L = 0`` or NaN gives black; ``L = inf`` white.
    """
    n = rgb.shape[0]
    for i in numba.prange(n):
        r = max(np.float64(rgb[i, 0]), 0.0)
        g = max(np.float64(rgb[i, 1]), 0.0)
        b = max(np.float64(rgb[i, 2]), 0.0)
        y = WR * r + WG * g + WB * b
        if not y > 0.0:  # black, or NaN in any channel
            out[i, 0] = 0.0
            out[i, 1] = 0.0
            out[i, 2] = 0.0
            continue
        if y == math.inf:
            out[i, 0] = 1.0
            out[i, 1] = 1.0
            out[i, 2] = 1.0
            continue
        if code == KNEE:  # the largest channel through the curve, the colour's ratios kept
            m = max(r, max(g, b))
            s = curve(m, code, p) / m
            out[i, 0] = _encode(r * s, enc, lut)
            out[i, 1] = _encode(g * s, enc, lut)
            out[i, 2] = _encode(b * s, enc, lut)
            continue
        ld = display_lum[i] if code == PRECOMPUTED else _display_curve(y, code, p, table)
        if saturation == 1.0:
            s = ld / y
            r *= s
            g *= s
            b *= s
        else:
            inv = 1.0 / y
            r = math.pow(r * inv, saturation) * ld
            g = math.pow(g * inv, saturation) * ld
            b = math.pow(b * inv, saturation) * ld
        out[i, 0] = _encode(r, enc, lut)
        out[i, 1] = _encode(g, enc, lut)
        out[i, 2] = _encode(b, enc, lut)


@parallel_kernel
def map_luminance(y, code, p, out):
    """``out[i] = curve(y[i])`` for a flat luminance array (NaN stays NaN, inf stays inf)."""
    for i in numba.prange(y.shape[0]):
        v = y[i]
        if v != v or v == math.inf:
            out[i] = v
        elif v <= 0.0:
            out[i] = 0.0
        else:
            out[i] = curve(v, code, p)


@parallel_kernel
def luminance(rgb, out):
    """Rec. 709 luminance of the first three columns of ``rgb`` (n, >= 3) into ``out`` (n,) float64."""
    for i in numba.prange(rgb.shape[0]):
        out[i] = WR * np.float64(rgb[i, 0]) + WG * np.float64(rgb[i, 1]) + WB * np.float64(rgb[i, 2])


@parallel_kernel
def log_stats(y, weights, out):
    """Per chunk of ``y`` (flat): sum of ln y, count and max over pixels with finite
    ``y > 0`` (and ``weights > 0`` when ``weights`` is not empty). ``out`` is
    (chunks, 3) float64; the caller adds the chunks up."""
    chunks = out.shape[0]
    n = y.shape[0]
    size = (n + chunks - 1) // chunks
    use_w = weights.shape[0] > 0
    for c in numba.prange(chunks):
        s = 0.0
        k = 0.0
        m = 0.0
        for i in range(c * size, min(n, (c + 1) * size)):
            v = y[i]
            if v > 0.0 and v < math.inf and (not use_w or weights[i] > 0.0):
                s += math.log(v)
                k += 1.0
                if v > m:
                    m = v
        out[c, 0] = s
        out[c, 1] = k
        out[c, 2] = m
