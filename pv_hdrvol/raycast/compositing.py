"""Compositing partial images: the one "over" of premultiplied RGBA layers.

Every renderer that makes an image of parts composites them here:

- :func:`composite_over` is the operator, front to back, over layers that each cover
  all of the output or a rectangle of it. ``hv.render_parallel`` composites its
  blocks' rectangles into its tiles with it
  (:func:`pv_hdrvol.parallel.composite.composite`).
- :func:`composite_in_order` composites whole images in a per-pixel order (where each
  image's part of the ray begins) through it, and tracks the depth: a composite
  dataset's blocks (:mod:`pv_hdrvol.raycast.blocks`), the pieces of a distributed
  volume or mesh (:func:`pv_hdrvol.parallel.pieces.composite_pieces`) and the passes of
  an out-of-core frame.
"""
from __future__ import annotations

import numpy as np

from ..image.hdr import HDRImage


def composite_over(layers, shape, dtype=np.float64, *, accumulate=np.float64, after_each=None):
    """Composite premultiplied RGBA layers front to back with the "over" operator.

    Parameters
    ----------
    layers : iterable of (where, rgba)
        The layers, front to back. ``rgba``: array (..., 4), linear, premultiplied
        alpha, any float dtype. ``where``: the part of the output it covers, a basic
        index of an array of ``shape`` (``...`` for all of it, a tuple of slices for a
        rectangle) whose result has ``rgba``'s shape less its last axis.
    shape : tuple of int
        The output's pixels: ``(rows, cols)``, or ``(n,)`` for pixels in a row.
    dtype : numpy dtype, default float64
        The output's dtype.
    accumulate : numpy dtype, default float64
        The precision the running sums are kept in. ``hv.render_parallel``'s tiles keep
        their image's precision (``accumulate=dtype``), as they always have: its images
        do not depend on the rank count, and have not changed.
    after_each : callable, optional
        ``after_each(j, total)`` after the ``j``-th layer, with the running sums
        (``shape + (4,)``, ``accumulate``; read them, do not write): where the
        accumulated opacity first crosses a threshold, say.

    Returns
    -------
    ndarray, ``shape + (4,)``, ``dtype``
        Premultiplied RGBA; transparent (zeros) where no layer covers a pixel.

    Raises
    ------
    ValueError
        A ``where`` that is not a basic index (an index array would composite into a
        copy).

    Notes
    -----
    From :math:`C = 0`, :math:`A = 0`, for each layer :math:`(c, a)` in turn, per pixel
    it covers:

    .. math:: C \\leftarrow C + (1 - A)\\,c, \\qquad A \\leftarrow A + (1 - A)\\,a

    in ``accumulate`` precision (float64 by default; each layer converted to it first),
    then cast once to ``dtype``. "Over" is associative, so any grouping of the layers
    gives the same composite to rounding; this one evaluation order makes the bits a
    function of the layers and their order alone.

    Examples
    --------
    >>> half = np.array([[0.5, 0.0, 0.0, 0.5]])  # red at half opacity, premultiplied
    >>> composite_over([(..., half), (..., half)], (1,)).tolist()
    [[0.75, 0.0, 0.0, 0.75]]
    """
    total = np.zeros(tuple(shape) + (4,), dtype=accumulate)
    for j, (where, rgba) in enumerate(layers):
        part = total[where]
        if part.base is not total and part is not total:
            raise ValueError(f"where must be a basic index of the output (..., slices); got {where!r}")
        part += (1 - part[..., 3:4]) * np.asarray(rgba).astype(accumulate, copy=False)
        if after_each is not None:
            after_each(j, total)
    return total.astype(dtype, copy=False)


def composite_in_order(images, entries, dtype=None):
    """Partial images composited per pixel, front to back in the order of ``entries``.

    Parameters
    ----------
    images : sequence of HDRImage
        Of one size; premultiplied RGBA and a depth image each.
    entries : ndarray, (n_images, rows * cols)
        Where each image's part of each pixel's ray begins (world distance; ``inf``:
        it has none). Ties keep the images' order.
    dtype : numpy dtype, optional
        The output's (default: the first image's).

    Returns
    -------
    HDRImage
        :func:`composite_over` of the images in each pixel's order, in float64, then
        ``dtype``. Depth: where the accumulated opacity first reaches the first image's
        depth threshold (that image's own depth there, or its entry). The first image's
        metadata, with the samples of all.
    """
    h, w = images[0].rgba.shape[:2]
    if any(im.rgba.shape[:2] != (h, w) for im in images) or entries.shape != (len(images), w * h):
        raise ValueError("the partial images and their entries must all have one size")
    n = w * h
    order = np.argsort(entries, axis=0, kind="stable")
    rgba = np.stack([np.asarray(im.rgba, dtype=np.float64).reshape(n, 4) for im in images])
    depths = np.stack([np.asarray(im.depth, dtype=np.float64).reshape(n) for im in images])
    pix = np.arange(n)
    depth = np.full(n, np.inf)
    threshold = images[0].metadata.get("depth_threshold", 0.5)

    def cross(j, total):  # the first image at whose end the opacity reaches the threshold
        k = order[j]
        crossed = (depth == np.inf) & (total[:, 3] >= threshold) & np.isfinite(entries[k, pix])
        depth[crossed] = np.where(np.isfinite(depths[k, pix]), depths[k, pix], entries[k, pix])[crossed]

    dtype = images[0].rgba.dtype if dtype is None else dtype
    total = composite_over(((..., rgba[order[j], pix]) for j in range(len(images))), (n,), dtype, after_each=cross)
    meta = dict(images[0].metadata)
    meta["samples"] = int(sum(im.metadata.get("samples", 0) for im in images))
    return HDRImage(total.reshape(h, w, 4), depth.reshape(h, w), metadata=meta)


__all__ = ["composite_in_order", "composite_over"]
