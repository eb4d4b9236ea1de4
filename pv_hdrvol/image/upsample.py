"""Upsampling of low-resolution renders guided by full-resolution depth layers.

Callahan & Silva, "Accelerating unstructured volume rendering with joint bilateral
upsampling" (JGT 2009): render small, then upsample with a joint bilateral filter
whose range term compares full-resolution reference depth layers (the mesh boundary
peeled front to back, :func:`~pv_hdrvol.depth_layers`), so edges of the mesh stay sharp
while its interior is interpolated smoothly.
"""
from __future__ import annotations

import math

import numpy as np

from .._validate import as_choice, as_real
from . import _upsample_kernels as K
from .hdr import HDRImage

METHODS = ("joint_bilateral", "bilinear", "nearest")
_EXP_TABLE = K.exp_table()


def _inverse_two_squares(sigma):
    """``1 / (2 sigma^2)``, capped at 1e300 so that a tiny sigma (whose square underflows)
    still weighs equal guides fully and any difference as nothing (never ``0 * inf``)."""
    return min(0.5 / (sigma * sigma), 1e300) if sigma * sigma > 0.0 else 1e300


def upsample(image, layers=None, factor=None, *, method="joint_bilateral", support=None, sigma_range=0.01):
    """Upsample a low-resolution :class:`HDRImage` (or array) to the layers' resolution.

    Parameters
    ----------
    image : HDRImage or ndarray (h, w, c)
        Linear premultiplied RGBA (any channels are filtered alike).
    layers : DepthLayers or ndarray (H, W, k), optional
        The full-resolution guide (``DepthLayers.normalized()`` is used for
        DepthLayers). Required for ``"joint_bilateral"``.
    factor : float, optional
        Full-resolution pixels per low-resolution pixel; default ``H / h`` from the
        layers. ``1`` with layers of the image's own size is the denoising use (the
        paper's Fig. 5).
    method : {"joint_bilateral", "bilinear", "nearest"}
    support : float, optional
        The spatial filter's support Omega in full-resolution pixels; its Gaussian has
        sigma = Omega / 2. Default: ``factor`` (one low-resolution pixel), at least 2.
    sigma_range : float
        Sigma of the range Gaussian on the distance between guide vectors, in units of
        the normalised depth range (default 0.01, as the paper).

    Returns
    -------
    HDRImage or ndarray
        At the guide's size, in the input's float type: an HDRImage for an HDRImage
        (depth upsampled by nearest neighbour, metadata noting the method), else an
        array.
    """
    as_choice("method", method, METHODS)
    src_meta = {}
    if isinstance(image, HDRImage):
        low = image.rgba
        low_depth = image.depth
        src_meta = dict(image.metadata)
    else:
        low = np.asarray(image)
        low_depth = None
        if low.ndim != 3:
            raise ValueError(f"image must be an HDRImage or an array (rows, cols, channels); got shape {low.shape}")
    if not np.issubdtype(low.dtype, np.floating):
        raise TypeError(f"image must hold floats; got dtype {low.dtype}")
    h, w = low.shape[:2]
    guide = None
    if layers is not None:
        if hasattr(layers, "normalized"):
            guide = layers.normalized(layer_first=True)
        else:
            guide = np.asarray(layers, dtype=np.float64)
            if guide.ndim == 2:
                guide = guide[..., None]
            if guide.ndim != 3:
                raise ValueError(f"layers must be DepthLayers or an array (rows, cols, k); got shape {guide.shape}")
            if not np.all(np.isfinite(guide)):
                raise ValueError("layers must be finite (DepthLayers.normalized() encodes missing layers as 2)")
            guide = np.moveaxis(guide, -1, 0)
        guide = np.ascontiguousarray(guide, dtype=np.float64)  # (k, rows, cols)
    elif method == "joint_bilateral":
        raise ValueError("method='joint_bilateral' needs the full-resolution layers")
    if factor is None:
        if guide is None:
            raise ValueError("factor must be given when there are no layers")
        factor = guide.shape[1] / h
    factor = as_real("factor", factor, low=0.0, low_open=True)
    H, W = (guide.shape[1], guide.shape[2]) if guide is not None else (int(round(h * factor)), int(round(w * factor)))
    if abs(H - h * factor) > 0.5 or abs(W - w * factor) > 0.5:
        raise ValueError(f"layers of {W}x{H} pixels are not the image's {w}x{h} times factor {factor:g}")
    work = np.ascontiguousarray(low, dtype=np.float64)
    if method == "nearest":
        out = np.empty((H, W, low.shape[2]))
        K.nearest(work, factor, out)
    elif method == "bilinear":
        out = np.empty((H, W, low.shape[2]))
        K.bilinear(work, factor, out)
    else:
        omega = as_real("support", support, low=0.0, low_open=True) if support is not None else max(factor, 2.0)
        sigma_s = omega / 2.0
        sigma_range = as_real("sigma_range", sigma_range, low=0.0, low_open=True)
        radius = max(1, int(math.ceil(2.0 * sigma_s / factor)))
        nc = low.shape[2]
        groups = []
        for c0 in range(0, nc, 4):  # the kernel filters four channels at a time
            if nc - c0 >= 4:
                part = np.ascontiguousarray(work[..., c0:c0 + 4])
            else:
                part = np.zeros((h, w, 4))
                part[..., :nc - c0] = work[..., c0:]
            res = np.empty((H, W, 4))
            K.joint_bilateral(part, guide, factor, radius, _inverse_two_squares(sigma_s),
                              _inverse_two_squares(sigma_range), _EXP_TABLE, res)
            groups.append(res[..., :min(4, nc - c0)])
        out = groups[0] if len(groups) == 1 else np.concatenate(groups, axis=2)
    out = out.astype(low.dtype)
    depth = None
    if low_depth is not None:
        rows = np.minimum(((np.arange(H) + 0.5) / factor).astype(np.int64), h - 1)
        cols = np.minimum(((np.arange(W) + 0.5) / factor).astype(np.int64), w - 1)
        depth = low_depth[rows[:, None], cols[None, :]]
    if not isinstance(image, HDRImage):
        return out
    meta = dict(src_meta)
    meta["upsampled"] = {"method": method, "factor": factor, "from": [w, h]}
    return HDRImage(out, depth, metadata=meta)

