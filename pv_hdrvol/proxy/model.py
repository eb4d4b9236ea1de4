"""Opacity changes and colour prediction from accumulated-attenuation proxy images.

Two client-side steps of the paper's transfer-function exploration (§6.2-6.3), which run
on proxy images alone, without the volume:

* :func:`propagate` estimates the per-interval attenuation ``a'`` after the opacity of
  some intensity intervals changed (our slab model; the paper cites "[31]" without
  details);
* :class:`ColorModel` is the paper's TF model proxy: k-means clusters of the training
  attenuation vectors, each with a centroid ``a_k``, a colour ``c_k`` and a 3 x L
  Jacobian ``J_k``, which predict a colour ``c = c_k + J_k (a - a_k)`` from the
  nearest centroid (:func:`nearest_centroid`).

Arrays: ``atten`` is ``(L, rows, cols)`` (or ``(L, N)``), float64, one plane per
intensity interval; colours are linear premultiplied RGB ``(rows, cols, 3)`` (HDR:
values may exceed 1). numpy and scipy only.
"""
from __future__ import annotations

import inspect
import numbers
import warnings

import numpy as np
from scipy.cluster.vq import kmeans2

from .._validate import as_choice, as_int

__all__ = ["ColorModel", "nearest_centroid", "propagate", "propagate_corrected", "propagate_own", "ORDERS",
           "RIDGE_RELATIVE"]

#: Front-to-back orders of the intervals understood by :func:`propagate`.
ORDERS = ("depth", "ascending", "descending")

#: Regularisation of the per-cluster Jacobian fit (methods.md B.1.6 step 3): directions
#: of the centred attenuation with variance ``s**2 <= lambda_r = RIDGE_RELATIVE *
#: trace(A^T A) / L`` are left out (a spectral cut-off at the ridge's lambda_r, which
#: unlike ridge shrinkage leaves well-determined directions unbiased).
RIDGE_RELATIVE = 1e-6

#: Lower clamp of the transmittance in front of a slab when recovering its opacity;
#: also the transmittance below which a slab that saturates the ray counts as opaque.
_MIN_TRANSMITTANCE = 1e-12
#: How far above 1 the attenuation of a pixel may sum (float32 proxies round).
_SUM_TOLERANCE = 1e-5
#: Lloyd iterations of k-means (scipy's default is 10).
_KMEANS_ITERATIONS = 20
#: Pixels per block of the nearest-centroid search and of prediction.
_CHUNK = 8192


# --------------------------------------------------------------------------- checks


def _real_array(name, value):
    """``value`` as a float64 array (no copy when it already is one), or TypeError."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of real numbers; got {type(value).__name__}") from None
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must be an array of real numbers; got dtype {arr.dtype}")
    return arr.astype(np.float64, copy=False)


def _finite(name, arr):
    if not np.all(np.isfinite(arr)):
        bad = int(np.size(arr) - np.count_nonzero(np.isfinite(arr)))
        raise ValueError(f"{name} must be finite; found {bad} NaN or infinite value(s)")
    return arr


def _attenuation(name, value, *, min_ndim=1):
    """Validated accumulated attenuation: float64 ``(L, ...)``, finite, >= 0, sums <= 1."""
    a = _real_array(name, value)
    if a.ndim < min_ndim or a.shape[0] == 0:
        need = "(L, N) or (L, rows, cols)" if min_ndim > 1 else "(L, ...)"
        raise ValueError(f"{name} must have shape {need} with L >= 1 intervals on axis 0; got shape {a.shape}")
    _finite(name, a)
    if a.size and a.min() < 0:
        raise ValueError(f"{name} must be >= 0; found {float(a.min())!r}")
    if a.size:
        total = a.sum(axis=0).max()
        if total > 1.0 + _SUM_TOLERANCE:
            raise ValueError(f"{name} must sum to at most 1 over its intervals (axis 0: the pixel alpha); "
                             f"found a pixel summing to {float(total)!r}")
    return a


def _opacity(name, value, shape):
    """Validated own opacity: float64 of ``shape``, in [0, 1]."""
    o = _real_array(name, value)
    if o.shape != shape:
        raise ValueError(f"{name} must have the shape of atten {shape}; got {o.shape}")
    _finite(name, o)
    if o.size and (o.min() < 0 or o.max() > 1):
        raise ValueError(f"{name} must lie in [0, 1]; found values in [{float(o.min())!r}, {float(o.max())!r}]")
    return o


def _scale(value, intervals):
    """Extinction scale per interval, float64 ``(intervals,)``, finite and >= 0."""
    if isinstance(value, dict):
        k = np.ones(intervals)
        for key, factor in value.items():
            if isinstance(key, (bool, np.bool_)) or not isinstance(key, numbers.Integral):
                raise TypeError(f"scale keys must be interval indices (int); got {key!r}")
            if not 0 <= key < intervals:
                raise ValueError(f"scale: interval {key!r} is out of range; the attenuation has {intervals} "
                                 f"intervals, 0..{intervals - 1}")
            if isinstance(factor, (bool, np.bool_)) or not isinstance(factor, numbers.Real):
                raise TypeError(f"scale of interval {key} must be a real number; got {factor!r}")
            k[int(key)] = float(factor)
    else:
        k = _real_array("scale", value)
        if k.shape != (intervals,):
            raise ValueError(f"scale must have one entry per interval ({intervals}) or be a dict "
                             f"{{interval: k}}; got shape {k.shape}")
    bad = np.flatnonzero(~np.isfinite(k) | (k < 0))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"scale of interval {i} must be finite and >= 0; got {float(k[i])!r}")
    return k


def _scaled_opacity(beta, k):
    """``1 - (1 - beta)**k`` for opacities ``beta`` in [0, 1] and scales ``k`` >= 0
    (a scalar or broadcast), accurate for tiny ``beta``; ``k == 0`` gives 0 and
    ``k == 1`` returns ``beta`` unchanged."""
    if np.ndim(k) == 0:
        if k == 1:
            return beta
        if k == 0:
            return np.zeros_like(beta)
    with np.errstate(divide="ignore", invalid="ignore"):
        # beta == 1 -> log1p(-1) = -inf -> expm1(-inf) = -1: stays 1 for k > 0
        out = -np.expm1(k * np.log1p(-beta))
    out = np.where(k == 1, beta, out)
    out = np.where(k == 0, 0.0, out)
    return np.clip(out, 0.0, 1.0)


# --------------------------------------------------------------------------- propagation


def propagate_own(own, scale):
    """Scale the interval's own opacity: ``o'_i = 1 - (1 - o_i)**k_i``.

    Parameters
    ----------
    own : array_like, shape (L, ...)
        Own opacity ``o_i = 1 - prod_{s in i} (1 - alpha_s)`` of each interval along
        each pixel's ray (the ``iop`` proxy channel), in [0, 1].
    scale : array_like of shape (L,) or dict of {int: float}
        Extinction scale ``k_i >= 0`` per interval; in a dict, intervals not named
        keep ``k = 1``.

    Returns
    -------
    numpy.ndarray, float64, shape of ``own``
        The new own opacities. ``k_i = 0`` gives 0, ``o_i = 1`` stays 1 for ``k_i > 0``.

    Notes
    -----
    Scaling the extinction of every sample of an interval by ``k`` scales its optical
    depth ``-ln(1 - o)`` by ``k``, whatever the samples' order.

    Examples
    --------
    >>> propagate_own([[0.5], [0.75]], {1: 0.5}).ravel().tolist()
    [0.5, 0.5]
    """
    o = _real_array("own", own)
    if o.ndim < 1 or o.shape[0] == 0:
        raise ValueError(f"own must have shape (L, ...) with L >= 1 intervals on axis 0; got shape {o.shape}")
    o = _opacity("own", o, o.shape)
    k = _scale(scale, o.shape[0]).reshape((-1,) + (1,) * (o.ndim - 1))
    return _scaled_opacity(o, k)


def propagate(atten, scale, *, own=None, entry=None, order="depth"):
    """Accumulated attenuation after scaling the extinction of intensity intervals.

    Each pixel's intervals are modelled as slabs crossed front to back; the opacity of
    each slab is scaled and the slabs are composited again.

    Parameters
    ----------
    atten : array_like, shape (L, rows, cols) or (L, N)
        Accumulated attenuation ``a_i`` of each of the ``L`` intensity intervals,
        ``a_i = sum_{s in i} alpha_s prod_{j<s} (1 - alpha_j)``, >= 0; over axis 0 it
        sums to the pixel's alpha (at most 1).
    scale : array_like of shape (L,) or dict of {int: float}
        Extinction scale ``k_i >= 0`` per interval (``k = 0`` removes the interval,
        ``k = 1`` keeps it). In a dict, intervals not named keep ``k = 1``.
    own : array_like, shape of ``atten``, optional
        Own opacity ``o_i = 1 - prod_{s in i} (1 - alpha_s)`` of each interval (proxy
        channel ``iop``). When given it is the slab opacity, so the new total alpha is
        exact for any geometry; otherwise slab opacities are recovered from ``atten``.
    entry : array_like, shape of ``atten``, optional
        World depth at which each pixel's ray first meets a sample of interval ``i``
        with non-zero opacity (``inf`` if never, NaN not allowed). Orders the slabs.
    order : {"depth", "ascending", "descending"}
        Front-to-back order of the slabs. ``"depth"``: by ``entry`` (ties and ``inf``
        by interval index); without ``entry`` it is the same as ``"ascending"``.
        ``"ascending"``/``"descending"``: by interval index (intensity), for data in
        which intensity is monotone along the rays; ``entry`` must then be None.

    Returns
    -------
    numpy.ndarray, float64, shape of ``atten``
        The new attenuation ``a'``. The inputs are not modified.

    Raises
    ------
    ValueError
        Shapes that differ, NaN, negative attenuation or opacity outside [0, 1], a
        scale that is negative or not finite, a dict key out of ``0..L-1``.
    TypeError
        Non-numeric arrays or dict keys that are not ints.

    Notes
    -----
    This replaces the method the paper cites for this step ("[31]", not described;
    methods.md B.1.7). With ``pi`` the front-to-back order of a pixel's intervals,
    the slab opacities are ``beta_i = o_i`` when ``own`` is given, else

    .. math:: \\beta_{\\pi(m)} = a_{\\pi(m)} / \\max\\bigl(1 - \\textstyle\\sum_{n<m} a_{\\pi(n)},\\ 10^{-12}\\bigr)

    clipped to [0, 1]. Scaling extinction by ``k_i`` gives
    ``beta'_i = 1 - (1 - beta_i)^{k_i}`` (computed as ``-expm1(k log1p(-beta))``) and

    .. math:: a'_{\\pi(m)} = \\beta'_{\\pi(m)} \\prod_{n<m} \\bigl(1 - \\beta'_{\\pi(n)}\\bigr).

    This is exact when each ray crosses each interval in one contiguous run in the
    order ``pi`` (a stack of planar layers). With ``own`` the new total alpha
    ``1 - prod_i (1 - o_i)^{k_i}`` is exact for any geometry; only its split across
    the intervals depends on the order. Closed shells crossed twice by a ray are not
    modelled exactly without ``own``.

    Two numerical details of the path without ``own``: slabs in front of a pixel's
    first slab with ``k != 1`` keep ``a`` bit for bit (so ``k = 1`` everywhere returns
    ``atten`` exactly, whatever the clamp), and a slab that saturates the ray (the
    transmittance ``1 - sum a`` behind it at most 1e-12, or 8 ulp of a float32
    ``atten``) counts as opaque, ``beta = 1``, when ``k < 1``: its recovered
    ``1 - beta`` is rounding noise, which ``(1 - beta)^k`` would turn into light
    leaking through opaque surfaces.

    References
    ----------
    .. [1] "Visualization by Proxy", §6.1 Eq. (7) and §6.3 step 1 (proxy images for
       deferred interaction with volume data); ../shared/papers/visualization_by_proxy.txt.

    Examples
    --------
    Two slabs of opacity 0.5 each: ``a = (0.5, 0.25)``. Removing the front one
    leaves the back one unoccluded.

    >>> propagate([[0.5], [0.25]], {0: 0.0}, order="ascending").ravel().tolist()
    [0.0, 0.5]
    """
    a = _attenuation("atten", atten)
    # the rounding of the stored attenuation (float32 proxies) limits how close to 1 a
    # recovered slab opacity can be told apart from 1
    dtype = getattr(atten, "dtype", np.dtype(np.float64))
    eps = np.finfo(dtype).eps if np.issubdtype(dtype, np.floating) else np.finfo(np.float64).eps
    opaque_below = max(_MIN_TRANSMITTANCE, 8.0 * float(eps))
    shape = a.shape
    intervals = shape[0]
    k = _scale(scale, intervals)
    order = as_choice("order", order, ORDERS)
    o = None if own is None else _opacity("own", own, shape)
    a2 = a.reshape(intervals, -1)
    o2 = None if o is None else o.reshape(intervals, -1)
    pixels = a2.shape[1]
    out = np.empty((intervals, pixels))
    if entry is not None:
        if order != "depth":
            raise ValueError(f"entry orders the intervals by depth; it cannot be combined with order={order!r}")
        e = _real_array("entry", entry)
        if e.shape != shape:
            raise ValueError(f"entry must have the shape of atten {shape}; got {e.shape}")
        if np.isnan(e).any():
            raise ValueError("entry must not contain NaN (use inf for an interval the ray never meets)")
        # stable: equal depths (and the inf of intervals never met) keep index order
        perm = np.argsort(e.reshape(intervals, -1), axis=0, kind="stable")
        flat = perm * pixels
        flat += np.arange(pixels)
        a_slab = np.take(a2, flat)
        o_slab = None if o2 is None else np.take(o2, flat)
        for m, row in enumerate(_recomposite(a_slab, o_slab, k[perm], opaque_below)):
            np.put(out, flat[m], row)
    else:
        step = -1 if order == "descending" else 1  # views in slab order, no copies
        rows = _recomposite(a2[::step], None if o2 is None else o2[::step], k[::step], opaque_below)
        for i, row in zip(range(intervals)[::step], rows):
            out[i] = row
    return out.reshape(shape)


def propagate_corrected(atten, scale, *, own, entry=None):
    """The slab model with own opacities, corrected by its own error at no change: what
    :class:`~pv_hdrvol.ProxySet` uses.

    With ``M_k`` the slab model's attenuation for the scales ``k`` (:func:`propagate`
    with ``own``; ``M_1`` for no change), each interval keeps its stored share of the
    light and takes the model's relative change:

    .. math:: a'_i = a_i \\, M_{k,i} / M_{1,i} \\quad (M_{1,i} > 0), \\qquad a'_i = M_{k,i} \\quad (M_{1,i} = 0)

    (an interval the model sees hidden takes the model's value: what removing an
    occluder reveals), then the ``a'`` are scaled to sum to the exact new alpha
    ``1 - prod_i (1 - o_i)^{k_i}``.

    No change returns ``atten`` (to rounding); where the slab model is exact (each ray
    crosses each interval once, in depth order) the result is the slab model's. On
    closed shells, which a ray crosses twice, the plain slab model misplaces the back
    crossing's light in front (docs/proxy.md measures both).

    Examples
    --------
    >>> a = [[0.5], [0.25]]; o = [[0.5], [0.5]]; e = [[1.0], [2.0]]
    >>> propagate_corrected(a, {0: 0.0}, own=o, entry=e).ravel().tolist()
    [0.0, 0.5]
    """
    a = _attenuation("atten", atten)
    k = _scale(scale, a.shape[0])
    o = _opacity("own", own, a.shape)
    m1 = propagate(a, np.ones(a.shape[0]), own=o, entry=entry)
    mk = propagate(a, k, own=o, entry=entry)
    seen = m1 > 0
    out = np.where(seen, a * mk / np.where(seen, m1, 1.0), mk)
    total = -np.expm1(np.sum(k.reshape((-1,) + (1,) * (a.ndim - 1)) * np.log1p(-np.minimum(o, 1.0 - 1e-300)),
                             axis=0))
    total = np.where(np.any((o >= 1.0) & (k.reshape((-1,) + (1,) * (a.ndim - 1)) > 0), axis=0), 1.0, total)
    s = out.sum(axis=0)
    return np.where(s > 0, out * (total / np.where(s > 0, s, 1.0)), out)


def _recomposite(a_slab, o_slab, k_slab, opaque_below):
    """Yield the new attenuation of each slab front to back (methods.md B.1.7).

    ``a_slab`` (L, P) is the attenuation in slab order, ``o_slab`` the own opacity or
    None, ``k_slab`` (L,) or (L, P) the scale. One slab at a time keeps the working
    set in cache; the running sums are plain left-to-right sums.

    Without ``o_slab``, the slabs in front of a pixel's first changed slab (k != 1)
    keep their attenuation bit for bit, and that slab sees the transmittance
    ``1 - sum a`` of the old attenuation in front of it: the same values in exact
    arithmetic, but neither rounding nor the clamp of the denominator can then alter
    what does not change (``k = 1`` everywhere returns ``atten`` itself).

    A recovered slab opacity after which the ray's transmittance ``1 - sum a`` is at
    most ``opaque_below`` is set to 1 where ``k < 1``: its ``1 - beta`` is then
    rounding noise of the sums, which ``(1 - beta)**k`` with ``k < 1`` would amplify
    into light leaking through opaque surfaces."""
    pixels = a_slab.shape[1]
    transmittance = np.ones(pixels)  # prod of (1 - beta') in front of the slab
    if o_slab is not None:
        for m in range(a_slab.shape[0]):
            beta_new = _scaled_opacity(o_slab[m], k_slab[m])
            yield beta_new * transmittance
            transmittance *= 1.0 - beta_new
        return
    front = np.zeros(pixels)  # sum of the old attenuation in front of the slab
    changed = np.zeros(pixels, dtype=bool)  # a slab with k != 1 is in front or here
    for m in range(a_slab.shape[0]):
        a_m, k_m = a_slab[m], k_slab[m]
        before = 1.0 - front
        np.copyto(transmittance, before, where=~changed)
        np.logical_or(changed, k_m != 1, out=changed)
        front += a_m
        if not changed.any():
            yield a_m
            continue
        beta = a_m / np.maximum(before, _MIN_TRANSMITTANCE)
        np.clip(beta, 0.0, 1.0, out=beta)
        if np.any(k_m < 1):
            beta[(before > opaque_below) & (1.0 - front <= opaque_below) & (k_m < 1)] = 1.0
        beta_new = _scaled_opacity(beta, k_m)
        yield np.where(changed, beta_new * transmittance, a_m)
        transmittance *= 1.0 - beta_new


# --------------------------------------------------------------------------- nearest centroid


def _nearest_block(block, centroids, dist, best, work):
    """Nearest-centroid index for the columns of ``block`` (L, n): squared Euclidean
    distances from exact differences (no |a|^2 - 2 a.c + |c|^2 cancellation), first
    index on ties. ``dist``/``best`` (n,) and ``work`` (L, n) are scratch arrays."""
    label = np.zeros(block.shape[1], dtype=np.intp)
    for k in range(centroids.shape[0]):
        np.subtract(block, centroids[k][:, None], out=work)
        np.multiply(work, work, out=work)
        np.sum(work, axis=0, out=best if k == 0 else dist)
        if k == 0:
            continue
        closer = dist < best  # strict: an equal distance keeps the lower index
        np.copyto(best, dist, where=closer)
        label[closer] = k
    return label


def _blocks(a_ln, centroids):
    """Yield ``(start, stop, block (L, n) contiguous, labels (n,))`` over the pixels."""
    intervals, total = a_ln.shape
    size = min(_CHUNK, max(total, 1))
    dist, best = np.empty(size), np.empty(size)
    work = np.empty((intervals, size))
    for start in range(0, total, size):
        stop = min(start + size, total)
        n = stop - start
        block = np.ascontiguousarray(a_ln[:, start:stop])
        yield start, stop, block, _nearest_block(block, centroids, dist[:n], best[:n], work[:, :n])


def nearest_centroid(atten, centroids):
    """Index of the centroid nearest (Euclidean) to each attenuation vector, Eq. (10).

    Parameters
    ----------
    atten : array_like, shape (N, L)
        Attenuation vectors, one per row, finite.
    centroids : array_like, shape (K, L)
        Centroids, one per row, finite, ``K >= 1``.

    Returns
    -------
    numpy.ndarray of intp, shape (N,)
        ``argmin_k ||atten[n] - centroids[k]||``; among equal distances the lowest
        ``k`` (as :func:`numpy.argmin`).

    Notes
    -----
    The distances are sums of squared differences (not ``|a|^2 - 2 a.c + |c|^2``, whose
    cancellation would misorder near-coincident centroids), computed over blocks of
    pixels, so memory stays ``O(L * block)`` for any ``N`` and ``K``.

    References
    ----------
    .. [1] "Visualization by Proxy", §6.3 Eq. (10).

    Examples
    --------
    >>> nearest_centroid([[0.0, 0.1], [0.5, 0.5], [1.0, 0.9]], [[0.0, 0.0], [1.0, 1.0]]).tolist()
    [0, 0, 1]
    """
    a = _finite("atten", _real_array("atten", atten))
    c = _finite("centroids", _real_array("centroids", centroids))
    if a.ndim != 2:
        raise ValueError(f"atten must have shape (N, L); got {a.shape}")
    if c.ndim != 2 or c.shape[0] == 0:
        raise ValueError(f"centroids must have shape (K, L) with K >= 1; got {c.shape}")
    if a.shape[1] != c.shape[1]:
        raise ValueError(f"atten has {a.shape[1]} intervals per row but centroids have {c.shape[1]}")
    labels = np.empty(a.shape[0], dtype=np.intp)
    for start, stop, _, lab in _blocks(a.T, c):
        labels[start:stop] = lab
    return labels


# --------------------------------------------------------------------------- colour model


def _training_pixels(atten, colors):
    """Stack training images into ``X`` (N, L) and ``Y`` (N, 3), dropping pixels whose
    attenuation sums to 0."""
    if isinstance(atten, (list, tuple)):
        if not isinstance(colors, (list, tuple)):
            raise TypeError(f"atten is a list of {len(atten)} images, so colors must be a list too; "
                            f"got {type(colors).__name__}")
        if len(atten) != len(colors):
            raise ValueError(f"atten and colors must list the same number of images; got {len(atten)} and "
                             f"{len(colors)}")
        if not atten:
            raise ValueError("atten must hold at least one training image; got an empty list")
        pairs = list(zip(atten, colors))
    else:
        pairs = [(atten, colors)]
    xs, ys = [], []
    intervals = None
    for i, (a_i, c_i) in enumerate(pairs):
        tag = "" if len(pairs) == 1 else f"[{i}]"
        a = _attenuation(f"atten{tag}", a_i, min_ndim=2)
        c = _finite(f"colors{tag}", _real_array(f"colors{tag}", c_i))
        if intervals is None:
            intervals = a.shape[0]
        elif a.shape[0] != intervals:
            raise ValueError(f"atten{tag} has {a.shape[0]} intervals but atten[0] has {intervals}")
        if c.shape != a.shape[1:] + (3,):
            raise ValueError(f"colors{tag} must have shape {a.shape[1:] + (3,)} (RGB per pixel of atten{tag} "
                             f"{a.shape}); got {c.shape}")
        x = a.reshape(intervals, -1).T
        y = c.reshape(-1, 3)
        used = x.sum(axis=1) > 0
        xs.append(x[used])
        ys.append(y[used])
    x = np.concatenate(xs) if len(xs) > 1 else np.ascontiguousarray(xs[0])
    y = np.concatenate(ys) if len(ys) > 1 else np.ascontiguousarray(ys[0])
    if x.shape[0] == 0:
        raise ValueError("no training pixel has non-zero attenuation (every pixel of atten sums to 0)")
    return x, y


def _kmeans(sample, clusters, rng):
    """scipy's k-means++ / Lloyd on ``sample`` (n, L) with the Generator ``rng``."""
    # scipy >= 1.15 names the argument rng= (seed= still works, deprecated later);
    # both treat a Generator the same way
    name = "rng" if "rng" in inspect.signature(kmeans2).parameters else "seed"
    with warnings.catch_warnings():
        # empty clusters are dropped after the final assignment (ColorModel.fit)
        warnings.filterwarnings("ignore", message="One of the clusters is empty")
        centroids, _ = kmeans2(sample, clusters, iter=_KMEANS_ITERATIONS, minit="++", missing="warn",
                               check_finite=False, **{name: rng})
    return np.asarray(centroids, dtype=np.float64)


def _fit_jacobian(a_centred, c_centred):
    """Least-squares ``J`` (3, L) of ``a_centred @ J.T ~= c_centred``, with directions of
    ``a_centred`` whose variance ``s**2 <= lambda_r = RIDGE_RELATIVE * trace(A^T A) / L``
    left out (truncated SVD; zero-variance intervals get zero columns).

    One Householder QR of ``[A | C]`` (no Q formed) gives ``R = R11`` and ``Q^T C =
    R12``; the SVD of the small ``R`` then solves the problem as accurately as an SVD of
    the tall ``A`` (no squared condition number as with the normal equations)."""
    intervals = a_centred.shape[1]
    jac = np.zeros((3, intervals))
    used = np.any(a_centred != 0, axis=0)  # constant intervals: exactly zero columns
    n_used = int(np.count_nonzero(used))
    if n_used == 0:
        return jac
    r = np.linalg.qr(np.concatenate([a_centred[:, used], c_centred], axis=1), mode="r")
    if r.shape[0] < n_used:  # fewer members than intervals: pad R with zero rows
        r = np.concatenate([r, np.zeros((n_used - r.shape[0], r.shape[1]))])
    u, s, vt = np.linalg.svd(r[:n_used, :n_used])
    # trace(A^T A) = sum s**2; lambda_r is relative to the mean over all L intervals
    keep = s * s > RIDGE_RELATIVE * float(np.sum(s * s)) / intervals
    coef = (u[:, keep].T @ r[:n_used, n_used:]) / s[keep, None]  # (rank, 3)
    jac[:, used] = (vt[keep].T @ coef).T
    return jac


class ColorModel:
    """The paper's transfer-function model proxy: colour from accumulated attenuation.

    ``K`` clusters of attenuation vectors, each with a centroid ``a_k`` (L), a colour
    ``c_k`` (3) and a Jacobian ``J_k`` (3 x L). A pixel's colour is predicted from the
    nearest centroid: ``c = c_k + J_k (a - a_k)``.

    Build one with :meth:`fit` (from training renders) or :meth:`from_lut`; the
    constructor takes the arrays themselves.

    Parameters
    ----------
    centroids : array_like, shape (K, L)
        Cluster centroids ``a_k``.
    colors : array_like, shape (K, 3)
        Linear premultiplied RGB ``c_k`` at each centroid.
    jacobians : array_like, shape (K, 3, L)
        ``J_k``: row ``j`` holds the derivatives of colour channel ``j``.
    residuals : array_like, shape (K,), optional
        RMS error of the fit on each cluster's training pixels (None when unknown,
        e.g. after :meth:`from_lut`).
    counts : array_like of int, shape (K,), optional
        Number of training pixels in each cluster (None when unknown).
    requested_clusters : int, optional
        The ``K`` asked of :meth:`fit`; defaults to ``K``.

    Attributes
    ----------
    centroids, colors, jacobians : numpy.ndarray
        Read-only float64 copies of the arrays above.
    residuals, counts : numpy.ndarray or None
        Read-only copies, or None.
    requested_clusters : int
        ``clusters`` as requested; :attr:`clusters` is smaller when k-means left
        clusters empty or the training set had fewer distinct attenuation vectors.

    Notes
    -----
    The renderer is viewed as a map ``f: R^L -> R^3`` from a pixel's attenuation to
    its colour, linearised around each cluster centroid, Eq. (8):

    .. math:: c \\approx c_k + J_k (a - a_k), \\qquad
              k = \\arg\\min_i \\lVert a - a_i \\rVert \\quad \\text{(Eq. 10)}.

    The model is exact for ``K = 1`` when each interval has one colour and there is no
    shading (``c = sum_i C_i a_i``); it holds only for "over" compositing (not MIP or
    additive).

    References
    ----------
    .. [1] "Visualization by Proxy", §6.2 (Eqs. 8-9, the ((3+1)L+3) x K table) and §6.3
       (Eq. 10); ../shared/papers/visualization_by_proxy.txt.

    Examples
    --------
    Colours that are linear in attenuation are reproduced by one cluster:

    >>> import numpy as np
    >>> a = np.random.default_rng(1).uniform(0, 0.3, (3, 500))  # (L, N)
    >>> rgb = a.T @ np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 2.0]])
    >>> model = ColorModel.fit(a, rgb, clusters=1)
    >>> bool(np.allclose(model.predict([[0.1], [0.2], [0.3]]), [[0.1, 0.2, 0.6]]))
    True
    >>> model.lut().shape  # (4L + 3, K)
    (15, 1)
    """

    def __init__(self, centroids, colors, jacobians, *, residuals=None, counts=None, requested_clusters=None):
        cen = _finite("centroids", _real_array("centroids", centroids))
        if cen.ndim != 2 or cen.shape[0] == 0 or cen.shape[1] == 0:
            raise ValueError(f"centroids must have shape (K, L) with K >= 1 and L >= 1; got {cen.shape}")
        n_clusters, intervals = cen.shape
        col = _finite("colors", _real_array("colors", colors))
        if col.shape != (n_clusters, 3):
            raise ValueError(f"colors must have shape (K, 3) = {(n_clusters, 3)}; got {col.shape}")
        jac = _finite("jacobians", _real_array("jacobians", jacobians))
        if jac.shape != (n_clusters, 3, intervals):
            raise ValueError(f"jacobians must have shape (K, 3, L) = {(n_clusters, 3, intervals)}; got {jac.shape}")
        self.centroids = self._frozen(cen)
        self.colors = self._frozen(col)
        self.jacobians = self._frozen(jac)
        self.residuals = None
        if residuals is not None:
            res = _real_array("residuals", residuals)
            if res.shape != (n_clusters,):
                raise ValueError(f"residuals must have shape (K,) = ({n_clusters},); got {res.shape}")
            self.residuals = self._frozen(res)
        self.counts = None
        if counts is not None:
            cnt = np.asarray(counts)
            if cnt.dtype.kind not in "iu" or cnt.shape != (n_clusters,):
                raise ValueError(f"counts must be {n_clusters} integers; got dtype {cnt.dtype}, shape {cnt.shape}")
            self.counts = self._frozen(cnt.astype(np.int64))
        self.requested_clusters = (n_clusters if requested_clusters is None
                                   else as_int("requested_clusters", requested_clusters, low=1))

    @staticmethod
    def _frozen(arr):
        out = np.array(arr, copy=True)
        out.setflags(write=False)
        return out

    # ------------------------------------------------------------------ properties

    @property
    def clusters(self):
        """int: the number ``K`` of clusters in the model."""
        return self.centroids.shape[0]

    @property
    def intervals(self):
        """int: the number ``L`` of attenuation intervals."""
        return self.centroids.shape[1]

    def __repr__(self):
        shrunk = "" if self.requested_clusters == self.clusters else f" (of {self.requested_clusters} requested)"
        fit = ""
        if self.residuals is not None and self.counts is not None and self.counts.sum() > 0:
            rms = float(np.sqrt(np.sum(self.counts * self.residuals ** 2) / self.counts.sum()))
            fit = f", fit_rms={rms:.3g}"
        return f"ColorModel(clusters={self.clusters}{shrunk}, intervals={self.intervals}{fit})"

    # ------------------------------------------------------------------ fitting

    @classmethod
    def fit(cls, atten, colors, clusters=24, *, seed=0, max_fit_samples=200_000):
        """Fit the model to training renders (the paper's pre-processing, Fig. 11).

        Parameters
        ----------
        atten : array_like or list of array_like
            Accumulated attenuation of the training pixels, ``(L, N)``, or one
            ``(L, rows, cols)`` array per training image (a list). Pixels whose
            attenuation sums to 0 (empty space) are not used.
        colors : array_like or list of array_like
            Their linear premultiplied RGB: ``(N, 3)``, or one ``(rows, cols, 3)``
            array per image, matching ``atten``.
        clusters : int
            ``K`` (paper: 24; 48 for turbulent data). Fewer are kept when k-means
            leaves some empty or there are fewer distinct attenuation vectors.
        seed : int
            Seeds k-means++ and the subsample: the same seed and data give the same
            model, bit for bit.
        max_fit_samples : int
            With more usable pixels, the centroids are fitted on this many drawn at
            random (without replacement); every pixel is then assigned and used for
            the colours and Jacobians.

        Returns
        -------
        ColorModel

        Notes
        -----
        1. k-means (Euclidean, k-means++ seeding, :func:`scipy.cluster.vq.kmeans2`)
           on the attenuation vectors; every pixel is assigned to its nearest centroid
           (Eq. 10) and clusters left without pixels are dropped.
        2. Per cluster, with the member means ``m_a``, ``m_c``, Eq. (9) is solved by
           least squares on the centred members, ``(A - m_a) J^T = (C - m_c)``,
           leaving out directions of attenuation with variance at most
           ``lambda_r = 1e-6 trace(A_c^T A_c) / L`` (so intervals unused in a cluster
           get zero columns instead of noise).
        3. The colour at the centroid is ``c_k = m_c + J_k (a_k - m_a)``: the mean
           member colour when the centroid is the members' mean (converged
           k-means), and in any case the fitted colour at ``a_k``, so that
           ``c_k + J_k (a - a_k)`` is the least-squares fit with intercept.
        """
        clusters = as_int("clusters", clusters, low=1)
        seed = as_int("seed", seed, low=0)
        max_fit_samples = as_int("max_fit_samples", max_fit_samples, low=1)
        x, y = _training_pixels(atten, colors)
        n_pixels, intervals = x.shape
        rng = np.random.default_rng(seed)
        if n_pixels > max_fit_samples:
            sample = x[np.sort(rng.choice(n_pixels, size=max_fit_samples, replace=False))]
        else:
            sample = x
        distinct = np.unique(sample, axis=0)
        if distinct.shape[0] <= clusters:
            # k-means++ cannot seed more centroids than distinct points
            centroids = distinct
        else:
            centroids = _kmeans(sample, clusters, rng)
        labels = nearest_centroid(x, centroids)
        counts = np.bincount(labels, minlength=centroids.shape[0])
        kept = counts > 0
        # an empty cluster is nobody's nearest, so dropping it changes no assignment
        centroids, counts = centroids[kept], counts[kept]
        labels = (np.cumsum(kept) - 1)[labels]
        n_clusters = centroids.shape[0]
        members = np.argsort(labels, kind="stable")
        bounds = np.concatenate([[0], np.cumsum(counts)])
        col = np.empty((n_clusters, 3))
        jac = np.empty((n_clusters, 3, intervals))
        res = np.empty(n_clusters)
        for k in range(n_clusters):
            idx = members[bounds[k]:bounds[k + 1]]
            a_k, c_k = x[idx], y[idx]
            mean_a, mean_c = a_k.mean(axis=0), c_k.mean(axis=0)
            jac[k] = _fit_jacobian(a_k - mean_a, c_k - mean_c)
            col[k] = mean_c + jac[k] @ (centroids[k] - mean_a)
            fitted = col[k] + (a_k - centroids[k]) @ jac[k].T
            res[k] = np.sqrt(np.mean((fitted - c_k) ** 2))
        return cls(centroids, col, jac, residuals=res, counts=counts, requested_clusters=clusters)

    # ------------------------------------------------------------------ prediction

    def predict(self, atten):
        """Predict colours from attenuation (the paper's §6.3 steps 2-3).

        Parameters
        ----------
        atten : array_like, shape (L, rows, cols) or (L, N)
            Accumulated attenuation (e.g. from :func:`propagate`), >= 0, finite.

        Returns
        -------
        numpy.ndarray, float64, shape (rows, cols, 3) or (N, 3)
            Linear premultiplied RGB ``c = c_k + J_k (a - a_k)`` with ``k`` the nearest
            centroid (Eq. 10, lowest index on ties); 0 where ``atten`` sums to 0.
        """
        a = _attenuation("atten", atten)
        if a.shape[0] != self.intervals:
            raise ValueError(f"atten has {a.shape[0]} intervals (axis 0) but the model has {self.intervals}")
        a_ln = a.reshape(self.intervals, -1)
        out = np.zeros((a_ln.shape[1], 3))
        for start, stop, block, lab in _blocks(a_ln, self.centroids):
            offset = block.T - self.centroids[lab]
            rgb = self.colors[lab] + np.einsum("nij,nj->ni", self.jacobians[lab], offset)
            rgb[block.sum(axis=0) == 0] = 0.0
            out[start:stop] = rgb
        return out.reshape(a.shape[1:] + (3,))

    # ------------------------------------------------------------------ the table

    def lut(self):
        """The model as the paper's look-up table, float64 ``((3 + 1) L + 3, K)``.

        Column ``k`` holds ``J_k`` channel by channel (``J_k[0, :]``, ``J_k[1, :]``,
        ``J_k[2, :]``: 3L values), then the centroid ``a_k`` (L), then the colour
        ``c_k`` (3): 67 x 24 for L = 16, K = 24. :meth:`from_lut` inverts it exactly.
        """
        n_clusters = self.clusters
        return np.ascontiguousarray(np.concatenate(
            [self.jacobians.reshape(n_clusters, 3 * self.intervals), self.centroids, self.colors], axis=1).T)

    @classmethod
    def from_lut(cls, lut):
        """Rebuild a model from :meth:`lut` (bit for bit).

        Parameters
        ----------
        lut : array_like, shape ((3 + 1) L + 3, K)
            One column per cluster. Residuals and counts are not part of the table:
            they are None on the result.

        Returns
        -------
        ColorModel
        """
        table = _finite("lut", _real_array("lut", lut))
        if table.ndim != 2 or table.shape[1] == 0 or table.shape[0] < 7 or (table.shape[0] - 3) % 4:
            raise ValueError(f"lut must have shape ((3 + 1) L + 3, K), i.e. 4L + 3 rows (7, 11, 15, ... 67 for "
                             f"L = 16) and one column per cluster; got {table.shape}")
        intervals = (table.shape[0] - 3) // 4
        cols = table.T
        jac = cols[:, :3 * intervals].reshape(-1, 3, intervals)
        centroids = cols[:, 3 * intervals:4 * intervals]
        colors = cols[:, 4 * intervals:]
        return cls(centroids, colors, jac)
