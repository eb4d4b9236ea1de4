"""How much of an HDR image's detail survives on an 8-bit display.

A visualization-oriented measure (HDR VolVis asks for one instead of perceptual
fidelity): of the local contrasts that exist in the data, what share can a viewer
still see, and see the right way round?
"""
from __future__ import annotations

import numpy as np

from .display import LUMINANCE_WEIGHTS


def display_levels(display):
    """8-bit luma codes (rows, cols), int, of a display image.

    ``display`` is a ``ToneMapped``, an (rows, cols, 3) uint8 array, or floats in
    [0, 1] (quantised to 8 bits as a display would). Luma is the Rec. 709 weighting of
    the encoded codes, rounded: the grey levels a viewer can tell apart.
    """
    rgb = getattr(display, "rgb8", display)
    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] < 3:
        raise ValueError(f"display must have shape (rows, cols, 3); got {rgb.shape}")
    if rgb.dtype != np.uint8:
        if not np.issubdtype(rgb.dtype, np.floating):
            raise TypeError(f"display must be uint8 or floats in [0, 1]; got dtype {rgb.dtype}")
        rgb = np.round(np.clip(np.nan_to_num(rgb[..., :3]), 0.0, 1.0) * 255.0)
    return np.round(rgb[..., :3].astype(np.float64) @ LUMINANCE_WEIGHTS).astype(np.int64)


def detail_preserved(reference, display, *, contrast=0.02, mask=None):
    r"""Share of the reference's visible local contrasts still visible, in order, on a display.

    Parameters
    ----------
    reference : HDRImage or ndarray (rows, cols)
        The HDR image (or its linear luminance), typically a float64 render.
    display : ToneMapped, ndarray (rows, cols, 3) uint8, or floats in [0, 1]
        What the screen shows (see :func:`display_levels`).
    contrast : float
        Weber contrast above which a difference in the data counts as detail
        (default 2%, about a just-noticeable luminance step).
    mask : ndarray of bool (rows, cols), optional
        Only pairs with both pixels inside.

    Returns
    -------
    float
        In [0, 1]; ``nan`` when the reference has no such contrast.

    Notes
    -----
    Over horizontally and vertically adjacent pixels ``p, q`` with luminances
    :math:`L_p, L_q > 0` and :math:`|L_p - L_q| > c \min(L_p, L_q)`, the pair is
    preserved when the displayed luma codes differ with the same sign:
    :math:`\operatorname{sign}(Y'_p - Y'_q) = \operatorname{sign}(L_p - L_q)`. The measure
    is the preserved share. It rewards keeping every local structure distinguishable
    wherever it lies in a wide range, and penalises both flattening (a clipped or
    crushed region) and reversal (halo artefacts).

    Examples
    --------
    >>> import numpy as np
    >>> ref = np.array([[1.0, 2.0, 4.0, 8.0]])
    >>> codes = np.array([[[10] * 3, [20] * 3, [20] * 3, [40] * 3]], np.uint8)
    >>> detail_preserved(ref, codes)  # the 2 -> 4 step is flattened
    0.6666666666666666
    """
    y = getattr(reference, "luminance", reference)
    y = np.asarray(y, dtype=np.float64)
    if y.ndim != 2:
        raise ValueError(f"reference must be an HDRImage or a (rows, cols) luminance; got shape {y.shape}")
    codes = display_levels(display)
    if codes.shape != y.shape:
        raise ValueError(f"display has shape {codes.shape[:2]}; the reference has {y.shape}")
    if not contrast > 0:
        raise ValueError(f"contrast must be > 0; got {contrast!r}")
    valid = np.isfinite(y) & (y > 0)
    if mask is not None:
        mask = np.asarray(mask)
        if mask.shape != y.shape or mask.dtype != np.bool_:
            raise ValueError(f"mask must be a bool array of shape {y.shape}")
        valid &= mask
    significant = 0
    preserved = 0
    for a, b in (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                 ((slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
        ya, yb, ca, cb = y[a], y[b], codes[a], codes[b]
        both = valid[a] & valid[b]
        with np.errstate(invalid="ignore"):
            sig = both & (np.abs(ya - yb) > contrast * np.minimum(ya, yb))
        significant += int(sig.sum())
        preserved += int((sig & (np.sign(ca - cb) == np.sign(ya - yb))).sum())
    return preserved / significant if significant else float("nan")
