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

# curve codes (tonemap._CURVES)
PRECOMPUTED, LINEAR, REINHARD, DRAGO = 0, 1, 2, 3
# display encodings (tonemap._ENCODINGS)
ENC_LINEAR, ENC_SRGB, ENC_GAMMA = 0, 1, 2

# Rec. 709 luminance weights
WR, WG, WB = 0.2126, 0.7152, 0.0722

# sRGB is tabulated over u = sqrt(x): smooth there (x^(1/2.4) = u^(5/6)), so linear
# interpolation in 4096 steps is within 1e-7 of the formula.
SRGB_LUT_SIZE = 4096


def srgb_lut():
    """sRGB encoding sampled at ``u = i / (n - 1)`` for ``x = u**2``, float64, n + 1 entries."""
    u = np.linspace(0.0, 1.0, SRGB_LUT_SIZE)
    x = u * u
    enc = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.append(enc, enc[-1])  # guard entry: index n - 1 + 1 is safe


def kernel(fn):
    return numba.njit(nogil=True, cache=True, error_model="numpy")(fn)


def inline_kernel(fn):
    return numba.njit(nogil=True, cache=True, error_model="numpy", inline="always")(fn)


def parallel_kernel(fn):
    return numba.njit(nogil=True, cache=True, error_model="numpy", parallel=True)(fn)


@inline_kernel
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
    # DRAGO: p = (exposure / adaptation luminance, scaled max, log(bias)/log(0.5), scale,
    # peak): the formula falls again past its peak (near the max), so it is
    # held there to stay monotone for pixels brighter than the fitted maximum
    lw = min(y * p[0], p[4])
    if lw <= 0.0:
        return 0.0
    return p[3] * math.log1p(lw) / math.log(2.0 + 8.0 * math.exp(p[2] * math.log(lw / p[1])))


@inline_kernel
def _display_curve(y, code, p):
    """``curve`` for display values: Drago in float32 arithmetic (4 transcendental calls
    per pixel; float32's are ~2x faster, and their ~1e-7 relative error is below the
    float32 output's resolution) while its scaled maximum fits float32 (``p[1] < 1e30``)."""
    if code == DRAGO and p[1] < 1e30:
        lw = np.float32(min(y * p[0], p[4]))
        if lw <= np.float32(0.0):
            return 0.0
        bias = math.exp(np.float32(p[2]) * math.log(lw / np.float32(p[1])))
        return np.float64(np.float32(p[3]) * math.log1p(lw) / math.log(np.float32(2.0) + np.float32(8.0) * bias))
    return curve(y, code, p)


@inline_kernel
def _encode(x, enc, inv_gamma, lut):
    if not x > 0.0:  # also NaN
        return 0.0
    if x >= 1.0:
        return 1.0
    if enc == ENC_SRGB:
        t = math.sqrt(x) * (SRGB_LUT_SIZE - 1)
        i = int(t)
        f = t - i
        return lut[i] + f * (lut[i + 1] - lut[i])
    if enc == ENC_GAMMA:  # float32 powf: ~1e-7 relative, below the float32 output's resolution
        return np.float64(math.pow(np.float32(x), np.float32(inv_gamma)))
    return x


@parallel_kernel
def map_pixels(rgb, display_lum, code, p, saturation, enc, inv_gamma, lut, out):
    """Tone map ``rgb`` (n, >= 3; extra columns such as alpha are ignored) linear into ``out`` (n, 3) float32 display values in [0, 1].

    Display luminance ``Ld`` comes from ``curve(code, p)`` or, for ``PRECOMPUTED``, from
    ``display_lum`` (n,). Colour: ``out_c = (c / L)**saturation * Ld`` (plain
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
        ld = display_lum[i] if code == PRECOMPUTED else _display_curve(y, code, p)
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
        out[i, 0] = _encode(r, enc, inv_gamma, lut)
        out[i, 1] = _encode(g, enc, inv_gamma, lut)
        out[i, 2] = _encode(b, enc, inv_gamma, lut)


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
