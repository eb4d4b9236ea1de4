"""Gradient-domain high-dynamic-range compression (Fattal, Lischinski & Werman 2002).

The method works on the natural log of luminance, ``H``. It scales every gradient of
``H`` by a factor ``Phi`` that is below 1 for large gradients and above 1 for small
ones, then finds the image ``I`` whose gradient is closest (least squares) to the
scaled field by solving a Poisson equation with Neumann boundary conditions.

Everything here is plain numpy (the Poisson solver is a DCT built on ``numpy.fft``);
images are ``(rows, cols)`` float64, row 0 at the top, and no function modifies its
arguments.

* :func:`compress_log_luminance` -- the whole method: ``H`` in, compressed ``I`` out.
* :func:`attenuation` -- the multiscale attenuation factor ``Phi`` (section 4).
* :func:`gaussian_pyramid` -- the binomial pyramid ``Phi`` is built on.
* :func:`laplacian_neumann`, :func:`solve_poisson_neumann` -- the discrete Laplacian
  and its inverse (section 5).

References
----------
.. [1] R. Fattal, D. Lischinski, M. Werman, "Gradient domain high dynamic range
   compression", ACM Transactions on Graphics 21(3) (SIGGRAPH 2002), 249-256.
   https://doi.org/10.1145/566654.566573
.. [2] J. Makhoul, "A fast cosine transform in one and multiple dimensions", IEEE
   Transactions on Acoustics, Speech, and Signal Processing 28(1) (1980), 27-34.
   https://doi.org/10.1109/TASSP.1980.1163351
"""
from __future__ import annotations

import numpy as np

from .._validate import as_int, as_real

__all__ = [
    "attenuation", "compress_log_luminance", "gaussian_pyramid", "laplacian_neumann", "solve_poisson_neumann",
]

#: Gradient magnitudes below this fraction of ``alpha_abs`` are raised to it before
#: ``phi`` is evaluated, so that ``phi`` stays finite where the gradient vanishes; with
#: ``beta < 1`` this caps each level's ``phi`` at ``MAGNITUDE_FLOOR ** (beta - 1)``
#: (2.8 at ``beta = 0.85``).
MAGNITUDE_FLOOR = 1e-3

#: The 5-tap binomial filter of :func:`gaussian_pyramid`.
_BINOMIAL = (1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0)


# -- validation ------------------------------------------------------------------------

def _as_image(name, value, kinds="iuf"):
    """Return ``value`` as a float64 (rows, cols) array, or raise.

    A float64 ``value`` comes back as itself, not a copy: callers must not write to it.
    """
    arr = np.asarray(value)
    if arr.dtype.kind not in kinds:
        allowed = "real numbers or booleans" if "b" in kinds else "real numbers"
        raise TypeError(f"{name} must be an array of {allowed}; got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D (rows, cols) array; got shape {arr.shape}")
    if arr.shape[0] < 2 or arr.shape[1] < 2:
        raise ValueError(f"{name} must be at least 2x2; got shape {arr.shape}")
    arr = arr.astype(np.float64, copy=False)
    finite = np.isfinite(arr)
    if not finite.all():
        n_nan = int(np.isnan(arr).sum())
        n_inf = int((~finite).sum()) - n_nan
        raise ValueError(f"{name} must be finite; got {n_nan} NaN and {n_inf} infinite values "
                         "(fill NaN pixels before calling)")
    return arr


def _as_weights(weights, shape):
    w = _as_image("weights", weights, kinds="biuf")  # a boolean mask is a region of interest
    if w.shape != shape:
        raise ValueError(f"weights must have the shape of H, {shape}; got {w.shape}")
    if (w < 0).any():
        raise ValueError(f"weights must be >= 0; got a minimum of {w.min()!r}")
    if not w.sum() > 0:
        raise ValueError("weights must have a positive sum; got all zeros")
    return w


def _check_parameters(alpha, beta, min_size):
    alpha = as_real("alpha", alpha, low=0.0, low_open=True)
    beta = as_real("beta", beta, low=0.0, low_open=True)
    min_size = as_int("min_size", min_size, low=2)
    return alpha, beta, min_size


# -- discrete operators ----------------------------------------------------------------

def _forward_gradient(I):
    """Forward differences, zero in the last column (x) and last row (y)."""
    gx = np.zeros_like(I)
    gy = np.zeros_like(I)
    np.subtract(I[:, 1:], I[:, :-1], out=gx[:, :-1])
    np.subtract(I[1:, :], I[:-1, :], out=gy[:-1, :])
    return gx, gy


def _backward_divergence(gx, gy):
    """Backward differences with ``g = 0`` outside the grid: the adjoint of -gradient."""
    div = gx.copy()
    div[:, 1:] -= gx[:, :-1]
    div += gy
    div[1:, :] -= gy[:-1, :]
    return div


def laplacian_neumann(I):
    """The 5-point Laplacian with homogeneous Neumann boundary conditions.

    Parameters
    ----------
    I : array_like, shape (rows, cols)
        Finite real values; rows and cols at least 2.

    Returns
    -------
    ndarray, shape (rows, cols), float64
        ``lap(I)``; a new array.

    Notes
    -----
    With ghost cells mirrored across each edge (``I[-1, j] = I[0, j]`` and so on),

    .. math:: (\\Delta I)_{i,j} = I_{i-1,j} + I_{i+1,j} + I_{i,j-1} + I_{i,j+1} - 4 I_{i,j},

    so a boundary pixel sums only over its neighbours inside the grid. This equals the
    backward-difference divergence of the forward-difference gradient (the gradient is
    zero across the last column and row), which is how it is computed. The operator is
    diagonal in the DCT-II basis
    ``cos(pi kx (j + 1/2) / cols) cos(pi ky (i + 1/2) / rows)`` with eigenvalue
    ``2 cos(pi kx / cols) + 2 cos(pi ky / rows) - 4``; :func:`solve_poisson_neumann`
    inverts it. The sum of ``lap(I)`` is always 0 (up to rounding).

    References
    ----------
    .. [1] R. Fattal, D. Lischinski, M. Werman, "Gradient domain high dynamic range
       compression", ACM TOG 21(3) (2002), section 5.

    Examples
    --------
    A constant has zero Laplacian; a ramp has it only at its two ends.

    >>> import numpy as np
    >>> from pv_hdrvol.image.gradient_domain import laplacian_neumann
    >>> bool(laplacian_neumann(np.full((3, 4), 7.0)).any())
    False
    >>> laplacian_neumann(np.tile(np.arange(4.0), (3, 1)))[0].tolist()
    [1.0, 0.0, 0.0, -1.0]
    """
    I = _as_image("I", I)
    return _backward_divergence(*_forward_gradient(I))


# -- DCT-II / DCT-III by Makhoul's N-point FFT --------------------------------------------

def _index(axis, s):
    return (s,) if axis == 0 else (slice(None), s)


def _makhoul_twiddle(n, axis):
    w = np.exp(-0.5j * np.pi * np.arange(n // 2 + 1) / n)
    return w[:, None] if axis == 0 else w


def _dct_ii(x, axis):
    """Unnormalised DCT-II ``X_k = sum_n x_n cos(pi k (2n + 1) / (2N))`` along ``axis``.

    Makhoul: reorder ``v = (x_0, x_2, x_4, ..., x_5, x_3, x_1)``, ``V = rfft(v)``, then
    ``X_k = Re(w_k V_k)`` and ``X_{N-k} = -Im(w_k V_k)`` with ``w_k = exp(-i pi k / 2N)``.
    """
    n = x.shape[axis]
    h = n // 2
    evens = x[_index(axis, slice(0, None, 2))]
    odds_reversed = x[_index(axis, slice(1, None, 2))][_index(axis, slice(None, None, -1))]
    v = np.concatenate([evens, odds_reversed], axis=axis)
    z = np.fft.rfft(v, axis=axis)
    z *= _makhoul_twiddle(n, axis)
    out = np.empty(x.shape)
    out[_index(axis, slice(0, h + 1))] = z.real
    # For even n the middle term X_{n/2} is already set from the real part.
    out[_index(axis, slice(n - 1, h, -1))] = -z.imag[_index(axis, slice(1, n - h))]
    return out


def _dct_iii(X, axis):
    """Exact inverse of :func:`_dct_ii` along ``axis``: ``V_k = conj(w_k) (X_k - i X_{N-k})``."""
    n = X.shape[axis]
    h = n // 2
    shape = list(X.shape)
    shape[axis] = h + 1
    V = np.empty(shape, dtype=np.complex128)
    V.real = X[_index(axis, slice(0, h + 1))]
    V.imag[_index(axis, 0)] = 0.0  # X_N := 0
    V.imag[_index(axis, slice(1, None))] = X[_index(axis, slice(n - 1, n - 1 - h, -1))]
    np.negative(V.imag, out=V.imag)
    V *= np.conj(_makhoul_twiddle(n, axis))
    v = np.fft.irfft(V, n=n, axis=axis)
    out = np.empty(X.shape)
    m = (n + 1) // 2
    out[_index(axis, slice(0, None, 2))] = v[_index(axis, slice(0, m))]
    out[_index(axis, slice(1, None, 2))] = v[_index(axis, slice(m, None))][_index(axis, slice(None, None, -1))]
    return out


def _neumann_eigenvalues(n):
    """Eigenvalues ``2 cos(pi k / n) - 2 = -4 sin^2(pi k / 2n)`` of the 1-D Neumann Laplacian."""
    return -4.0 * np.sin(0.5 * np.pi * np.arange(n) / n) ** 2


def _solve_poisson(div):
    """Zero-mean solution of ``lap(I) = div - mean(div)``; ``div`` float64 (rows, cols)."""
    rows, cols = div.shape
    coef = _dct_ii(_dct_ii(div, 1), 0)
    denom = _neumann_eigenvalues(rows)[:, None] + _neumann_eigenvalues(cols)[None, :]
    denom[0, 0] = 1.0
    coef /= denom
    # The (0, 0) coefficient of div is sum(div): zeroing it projects out mean(div);
    # the (0, 0) coefficient of I is sum(I): zeroing it picks the zero-mean solution.
    coef[0, 0] = 0.0
    return _dct_iii(_dct_iii(coef, 0), 1)


def solve_poisson_neumann(div):
    """Solve ``lap(I) = div`` with homogeneous Neumann boundary conditions.

    Parameters
    ----------
    div : array_like, shape (rows, cols)
        Finite real right-hand side; rows and cols at least 2.

    Returns
    -------
    ndarray, shape (rows, cols), float64
        The zero-mean ``I`` with ``laplacian_neumann(I) = div - mean(div)``.

    Notes
    -----
    ``lap`` is the operator of :func:`laplacian_neumann`. It is diagonalised by the 2-D
    DCT-II: with ``D = DCT(div)``,

    .. math::

        \\hat I_{k_y k_x} = \\frac{D_{k_y k_x}}
            {2\\cos(\\pi k_x / W) + 2\\cos(\\pi k_y / H) - 4},
        \\qquad I = \\mathrm{DCT}^{-1}(\\hat I),

    for ``(ky, kx) != (0, 0)``. The DCT-II and its inverse (DCT-III) are computed with
    Makhoul's N-point reordering and ``numpy.fft.rfft``/``irfft`` along each axis,
    ``O(rows cols log(rows cols))``.

    The constants are the null space of ``lap``, so a solution exists only when
    ``sum(div) == 0`` and is unique up to a constant. The DC coefficient of ``div`` is
    ``sum(div)``; it is set to zero, which is the same as subtracting ``mean(div)``
    first: a ``div`` that violates the condition (by rounding, or at all) is projected
    onto the solvable ones without warning. The DC coefficient of ``I`` is set to zero
    too, which picks the zero-mean solution.

    References
    ----------
    .. [1] R. Fattal, D. Lischinski, M. Werman, "Gradient domain high dynamic range
       compression", ACM TOG 21(3) (2002), section 5.
    .. [2] J. Makhoul, "A fast cosine transform in one and multiple dimensions", IEEE
       Trans. ASSP 28(1) (1980), 27-34.

    Examples
    --------
    It inverts :func:`laplacian_neumann` up to the mean:

    >>> import numpy as np
    >>> from pv_hdrvol.image.gradient_domain import laplacian_neumann, solve_poisson_neumann
    >>> I0 = np.random.default_rng(0).random((5, 8))
    >>> I = solve_poisson_neumann(laplacian_neumann(I0))
    >>> bool(np.abs(I - (I0 - I0.mean())).max() < 1e-12)
    True
    """
    return _solve_poisson(_as_image("div", div))


# -- pyramid ---------------------------------------------------------------------------

def _blur_decimate(a, axis):
    """``[1 4 6 4 1] / 16`` along ``axis`` with half-sample mirroring, kept at even indices."""
    pad = [(0, 0), (0, 0)]
    pad[axis] = (2, 2)
    p = np.pad(a, pad, mode="symmetric")
    n_out = (a.shape[axis] + 1) // 2
    out = np.zeros(tuple(n_out if d == axis else a.shape[d] for d in range(2)))
    for t, w in enumerate(_BINOMIAL):
        out += w * p[_index(axis, slice(t, t + 2 * n_out - 1, 2))]
    return out


def _pyramid(H, min_size):
    levels = [H]
    while min((s + 1) // 2 for s in levels[-1].shape) >= min_size:
        levels.append(_blur_decimate(_blur_decimate(levels[-1], 0), 1))
    return levels


def gaussian_pyramid(H, min_size=32):
    """The binomial Gaussian pyramid of ``H``, finest level first.

    Parameters
    ----------
    H : array_like, shape (rows, cols)
        Finite real values; rows and cols at least 2.
    min_size : int, >= 2
        Stop before a level whose smaller side would be below this.

    Returns
    -------
    list of ndarray, float64
        ``levels[0]`` is a float64 copy of ``H``; ``levels[k + 1]`` has shape
        ``(ceil(rows_k / 2), ceil(cols_k / 2))``. Only ``levels[0]`` may have a side
        below ``min_size`` (when ``H`` itself does).

    Notes
    -----
    Each level is the previous one blurred with the separable 5-tap binomial filter

    .. math:: b = \\tfrac{1}{16}\\,[1, 4, 6, 4, 1]

    along rows and columns, with half-sample mirrored boundaries (``scipy.ndimage``
    ``mode="reflect"``, ``numpy.pad`` ``mode="symmetric"``: the mirror of the Neumann
    ghost cells), then sampled at every second pixel starting with the first, so
    sample ``i`` of level ``k + 1`` sits at pixel ``2 i`` of level ``k``. Only the kept
    samples are computed.

    References
    ----------
    .. [1] P. J. Burt, E. H. Adelson, "The Laplacian pyramid as a compact image code",
       IEEE Transactions on Communications 31(4) (1983), 532-540.
    .. [2] R. Fattal, D. Lischinski, M. Werman, "Gradient domain high dynamic range
       compression", ACM TOG 21(3) (2002), section 4.

    Examples
    --------
    >>> import numpy as np
    >>> from pv_hdrvol.image.gradient_domain import gaussian_pyramid
    >>> [p.shape for p in gaussian_pyramid(np.zeros((1000, 700)), min_size=32)]
    [(1000, 700), (500, 350), (250, 175), (125, 88), (63, 44)]
    """
    H = _as_image("H", H)
    min_size = as_int("min_size", min_size, low=2)
    return _pyramid(H.copy(), min_size)


# -- attenuation -----------------------------------------------------------------------

def _central_gradient_magnitude(Hk, spacing):
    """``|grad Hk|`` by central differences over ``2 * spacing``; one-sided at the edges."""
    gx = np.empty_like(Hk)
    gy = np.empty_like(Hk)
    np.subtract(Hk[:, 2:], Hk[:, :-2], out=gx[:, 1:-1])
    gx[:, 1:-1] *= 0.5 / spacing
    gx[:, 0] = (Hk[:, 1] - Hk[:, 0]) / spacing
    gx[:, -1] = (Hk[:, -1] - Hk[:, -2]) / spacing
    np.subtract(Hk[2:, :], Hk[:-2, :], out=gy[1:-1, :])
    gy[1:-1, :] *= 0.5 / spacing
    gy[0, :] = (Hk[1, :] - Hk[0, :]) / spacing
    gy[-1, :] = (Hk[-1, :] - Hk[-2, :]) / spacing
    gx *= gx
    gy *= gy
    gx += gy
    return np.sqrt(gx, out=gx)


def _upsample2(P, shape):
    """Bilinear upsampling by 2 to ``shape``: coarse sample ``i`` sits at fine pixel ``2 i``."""
    for axis in (0, 1):
        n_out = shape[axis]
        n_odd = n_out // 2
        ext = np.concatenate([P, P[_index(axis, slice(-1, None))]], axis=axis)  # clamp at the far edge
        out_shape = list(P.shape)
        out_shape[axis] = n_out
        out = np.empty(out_shape)
        out[_index(axis, slice(0, None, 2))] = P[_index(axis, slice(0, (n_out + 1) // 2))]
        odd = out[_index(axis, slice(1, None, 2))]
        np.add(ext[_index(axis, slice(0, n_odd))], ext[_index(axis, slice(1, n_odd + 1))], out=odd)
        odd *= 0.5
        P = out
    return P


def _attenuation(H, alpha, beta, min_size, weights):
    levels = _pyramid(H, min_size)
    magnitude0 = _central_gradient_magnitude(H, 1.0)
    if weights is None:
        mean_magnitude = float(np.mean(magnitude0))
    else:
        mean_magnitude = float(np.sum(weights * magnitude0) / np.sum(weights))
    alpha_abs = alpha * mean_magnitude
    if not alpha_abs > 0.0:
        if not magnitude0.any():
            return np.ones_like(H)  # H is constant: there is nothing to attenuate
        if weights is not None and mean_magnitude == 0.0:
            raise ValueError("the weighted mean gradient magnitude of H is 0 (weights select only flat "
                             "pixels), so alpha * that mean is 0; weights must cover some non-zero gradient")
        raise ValueError(f"alpha * mean gradient magnitude of H underflows to 0 (alpha={alpha!r}, "
                         f"mean={mean_magnitude!r}); use a larger alpha")
    floor = MAGNITUDE_FLOOR * alpha_abs
    Phi = None
    for k in range(len(levels) - 1, -1, -1):
        magnitude = magnitude0 if k == 0 else _central_gradient_magnitude(levels[k], 2.0 ** k)
        np.maximum(magnitude, floor, out=magnitude)
        magnitude /= alpha_abs
        with np.errstate(over="ignore"):
            phi = np.power(magnitude, beta - 1.0, out=magnitude)
        if Phi is None:
            Phi = phi
        else:
            Phi = _upsample2(Phi, phi.shape)
            with np.errstate(over="ignore", invalid="ignore"):  # inf * 0: checked below
                Phi *= phi
    if not np.isfinite(Phi).all():  # only a large beta > 1 gets here
        raise ValueError(f"Phi overflows with beta={beta!r}: gradients are raised to the power "
                         f"beta - 1 on each of {len(levels)} levels; use a beta closer to 1")
    return Phi


def attenuation(H, alpha=0.1, beta=0.85, *, min_size=32, weights=None):
    """The gradient attenuation factor ``Phi`` of Fattal et al. (their section 4).

    Parameters
    ----------
    H : array_like, shape (rows, cols)
        Log luminance: finite real values; rows and cols at least 2.
    alpha : float, > 0
        Gradient magnitude left unchanged at each level, relative to the mean gradient
        magnitude of ``H``: ``alpha_abs = alpha * mean(|grad H_0|)`` (the paper's "0.1
        times the average gradient magnitude").
    beta : float, > 0
        Exponent: ``beta < 1`` attenuates gradients above ``alpha_abs`` and magnifies
        those below (compression, the paper uses 0.8 to 0.9); ``beta = 1`` gives
        ``Phi = 1``; ``beta > 1`` is allowed and does the opposite (contrast expansion).
    min_size : int, >= 2
        The coarsest level is the last one of :func:`gaussian_pyramid` with this
        ``min_size``.
    weights : array_like, shape (rows, cols), optional
        Non-negative, finite, with a positive sum, or a boolean mask (a region of
        interest): the mean in ``alpha_abs`` becomes the ``weights``-weighted mean.

    Returns
    -------
    ndarray, shape (rows, cols), float64
        ``Phi``, positive.

    Raises
    ------
    ValueError
        For NaN or infinite values, a shape not 2-D or smaller than 2x2, ``alpha`` or
        ``beta`` not > 0, ``min_size`` below 2, bad ``weights``, ``weights`` whose
        weighted mean gradient magnitude is 0 while ``H`` is not constant, or a
        ``beta > 1`` so large that ``Phi`` overflows.
    TypeError
        For complex, object or string arrays, or parameters of the wrong type.

    Notes
    -----
    On each pyramid level ``H_k`` (:func:`gaussian_pyramid`) the gradient is taken by
    central differences scaled to level-0 pixels,

    .. math::

        \\nabla H_k = \\left(\\frac{H_k(x+1, y) - H_k(x-1, y)}{2^{k+1}},
                            \\frac{H_k(x, y+1) - H_k(x, y-1)}{2^{k+1}}\\right),

    one-sided (``(H_k(1, y) - H_k(0, y)) / 2^k``) on the first and last row and column.
    Then

    .. math::

        \\varphi_k = \\frac{\\alpha}{\\lVert\\nabla H_k\\rVert}
            \\left(\\frac{\\lVert\\nabla H_k\\rVert}{\\alpha}\\right)^{\\beta}
            = \\left(\\frac{\\lVert\\nabla H_k\\rVert}{\\alpha}\\right)^{\\beta - 1},
        \\qquad \\Phi_d = \\varphi_d,
        \\qquad \\Phi_k = L(\\Phi_{k+1})\\,\\varphi_k,

    with ``alpha`` standing for ``alpha_abs``, ``d`` the coarsest level and ``L``
    bilinear upsampling to level ``k``'s shape (coarse sample ``i`` at fine pixel
    ``2 i``, the last sample repeated past the far edge). ``Phi = Phi_0``.

    For ``beta < 1``, ``phi`` grows without bound as the gradient goes to 0, so
    magnitudes below ``MAGNITUDE_FLOOR * alpha_abs`` (``1e-3 * alpha_abs``) are raised
    to it first; each ``phi_k`` is then at most ``1000 ** (1 - beta)``. Where ``H`` is
    flat the scaled gradient ``Phi * grad H`` is 0 whatever ``Phi`` is; but detail
    finer than a coarse level's blur sits where that level is flat, so the floor sets
    its ``phi_k`` and the detail is magnified by that cap once per such level. A
    constant ``H`` (``alpha_abs = 0``) gives ``Phi = 1``.

    Away from that floor, ``Phi`` is proportional to ``alpha_abs ** ((1 - beta) (d + 1))``:
    ``alpha`` and ``weights`` scale ``Phi`` (and the output of
    :func:`compress_log_luminance`) by one constant factor and move the floor, nothing
    else.

    References
    ----------
    .. [1] R. Fattal, D. Lischinski, M. Werman, "Gradient domain high dynamic range
       compression", ACM TOG 21(3) (2002), section 4, equation 4.

    Examples
    --------
    On a ramp every gradient has the mean magnitude, so with ``alpha = 1`` nothing is
    attenuated at any level:

    >>> import numpy as np
    >>> from pv_hdrvol.image.gradient_domain import attenuation
    >>> ramp = np.tile(0.5 * np.arange(64.0), (48, 1))
    >>> bool(np.all(attenuation(ramp, alpha=1.0, beta=0.8, min_size=1000) == 1.0))
    True
    """
    H = _as_image("H", H)
    alpha, beta, min_size = _check_parameters(alpha, beta, min_size)
    if weights is not None:
        weights = _as_weights(weights, H.shape)
    return _attenuation(H, alpha, beta, min_size, weights)


# -- the method ------------------------------------------------------------------------

def compress_log_luminance(H, alpha=0.1, beta=0.85, *, min_size=32, weights=None):
    """Compress the range of log luminance ``H`` in the gradient domain (Fattal et al.).

    Parameters
    ----------
    H : array_like, shape (rows, cols)
        Natural log of luminance, row 0 at the top; finite real values (fill NaN
        pixels, for example from zero luminance, before calling); rows and cols at
        least 2. Not modified.
    alpha, beta, min_size, weights
        As in :func:`attenuation`.

    Returns
    -------
    ndarray, shape (rows, cols), float64
        The compressed log luminance ``I``, zero mean. The caller maps it to the
        display range (for example ``exp(I - I.max())`` as relative luminance).

    Raises
    ------
    ValueError
        As :func:`attenuation`; in particular for any NaN in ``H``.

    Notes
    -----
    With forward differences (zero across the last column and row),

    .. math::

        G = \\Phi\\,\\nabla H, \\qquad
        G_x(i, j) = \\Phi(i, j)\\,(H(i, j+1) - H(i, j)),

    and likewise ``G_y``. ``I`` minimises ``sum |grad I - G|^2``, whose normal
    equations are the Poisson equation

    .. math::

        \\Delta I = \\operatorname{div} G, \\qquad
        \\operatorname{div} G(i, j) = G_x(i, j) - G_x(i, j-1) + G_y(i, j) - G_y(i-1, j),

    (backward differences, ``G = 0`` outside the grid), solved with Neumann boundary
    conditions by :func:`solve_poisson_neumann`. Backward ``div`` of forward ``grad``
    is exactly :func:`laplacian_neumann`, so ``beta = 1`` (``Phi = 1``) returns
    ``H - mean(H)`` up to rounding. ``Phi`` is :func:`attenuation`.

    References
    ----------
    .. [1] R. Fattal, D. Lischinski, M. Werman, "Gradient domain high dynamic range
       compression", ACM TOG 21(3) (2002), sections 3-5.

    Examples
    --------
    With ``beta = 1`` the gradients are untouched and ``H`` comes back, less its mean:

    >>> import numpy as np
    >>> from pv_hdrvol.image.gradient_domain import compress_log_luminance
    >>> H = np.log(np.random.default_rng(1).uniform(1e-3, 1e3, (40, 50)))
    >>> I = compress_log_luminance(H, beta=1.0)
    >>> bool(np.abs(I - (H - H.mean())).max() < 1e-9)
    True
    """
    H = _as_image("H", H)
    alpha, beta, min_size = _check_parameters(alpha, beta, min_size)
    if weights is not None:
        weights = _as_weights(weights, H.shape)
    Phi = _attenuation(H, alpha, beta, min_size, weights)
    gx, gy = _forward_gradient(H)
    gx *= Phi
    gy *= Phi
    return _solve_poisson(_backward_divergence(gx, gy))
