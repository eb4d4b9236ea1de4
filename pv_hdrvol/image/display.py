"""The default display mapping: exposure, clamp, sRGB encoding.

A baseline only; tone-mapping operators live elsewhere.
"""
from __future__ import annotations

import numpy as np

#: Rec. 709 / sRGB luminance weights of linear RGB.
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])


def luminance(rgb):
    """Linear luminance ``0.2126 R + 0.7152 G + 0.0722 B`` of an (..., >=3) array."""
    rgb = np.asarray(rgb)
    return rgb[..., 0] * 0.2126 + rgb[..., 1] * 0.7152 + rgb[..., 2] * 0.0722


def srgb_encode(linear):
    """IEC 61966-2-1 sRGB transfer function of linear values in [0, 1]."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_decode(encoded):
    """Inverse of :func:`srgb_encode`."""
    x = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


def screen_lab(display_values):
    """CIELAB (D65, CIE 1976) of display values in [0, 1] (..., 3), read as an sRGB
    screen shows them: the measure of how far two pictures look apart (a mean
    Delta E = ``norm(lab1 - lab2)`` of about 2 is barely visible)."""
    xyz = srgb_decode(display_values) @ np.array([[0.4124564, 0.3575761, 0.1804375],
                                                   [0.2126729, 0.7151522, 0.0721750],
                                                   [0.0193339, 0.1191920, 0.9503041]]).T
    xyz = xyz / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], -1)


def colour_difference(shown, reference, mask):
    """``(mean Delta E, chroma ratio)`` of two pictures of display values in [0, 1]
    (..., 3), over the pixels of ``mask``: the mean CIE76 difference of their
    :func:`screen_lab` colours, and the mean chroma of ``shown`` over that of
    ``reference`` (below 1: ``shown`` is paler)."""
    lab, lab_reference = screen_lab(shown), screen_lab(reference)
    delta_e = np.linalg.norm(lab - lab_reference, axis=-1)[mask].mean()
    chroma = np.hypot(lab[..., 1], lab[..., 2])[mask].mean()
    return float(delta_e), float(chroma / np.hypot(lab_reference[..., 1], lab_reference[..., 2])[mask].mean())


def auto_exposure(rgb, percentile=99.0):
    """Stops that bring the ``percentile`` of non-zero luminance to 1.0 (0 if all black)."""
    y = luminance(rgb)
    y = y[np.isfinite(y) & (y > 0)]
    if y.size == 0:
        return 0.0
    ref = float(np.percentile(y, percentile))
    return float(-np.log2(ref)) if ref > 0 else 0.0


def display(rgba, exposure_stops=None, *, background=(0.0, 0.0, 0.0)):
    """Map linear premultiplied RGBA to 8-bit sRGB.

    Parameters
    ----------
    rgba : ndarray, shape (rows, cols, 4)
        Linear, premultiplied.
    exposure_stops : float or None
        Scale by ``2**exposure_stops`` before clamping; ``None``: :func:`auto_exposure`.
    background : 3 floats
        Linear colour shown through transparent pixels.

    Returns
    -------
    ndarray, shape (rows, cols, 3), uint8
    """
    rgba = np.asarray(rgba, dtype=np.float64)
    if rgba.ndim != 3 or rgba.shape[2] != 4:
        raise ValueError(f"rgba must have shape (rows, cols, 4); got {rgba.shape}")
    if exposure_stops is None:
        exposure_stops = auto_exposure(rgba)
    bg = np.asarray(background, dtype=np.float64).reshape(1, 1, 3)
    lin = rgba[..., :3] * (2.0 ** float(exposure_stops)) + (1.0 - rgba[..., 3:4]) * bg
    lin = np.nan_to_num(lin, nan=0.0, posinf=1.0, neginf=0.0)
    return np.round(srgb_encode(lin) * 255.0).astype(np.uint8)
