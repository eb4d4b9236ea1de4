"""Analytic example volumes: no downloads, no licences.

The hydrogen atom's bound-state probability densities :math:`|\\psi_{nlm}|^2` are a
realistic high-dynamic-range field: smooth, with nodal surfaces where the density is
exactly zero, and an exponential tail that spans tens of decades inside a modest box.
"""
from __future__ import annotations

import math

import numpy as np

from ._validate import as_int, as_real

#: Name of the point array written by :func:`hydrogen_orbital`.
ARRAY_NAME = "probability_density"


def default_extent(n):
    """Half-width (Bohr radii) of the default cube for principal quantum number ``n``.

    ``2.5 * n * (n + 3)``: the sphere of that radius holds all but less than 1e-6 of
    the probability of every orbital with ``n <= 6`` (checked by quadrature), so the
    cube around it does too.

    Examples
    --------
    >>> default_extent(3)
    45.0
    """
    n = as_int("n", n, low=1)
    return 2.5 * n * (n + 3)


def _check_quantum_numbers(n, l, m):  # noqa: E741 - l is the physicists' name
    n = as_int("n", n, low=1, high=30)
    l = as_int("l", l, low=0)  # noqa: E741
    m = as_int("m", m)
    if l >= n:
        raise ValueError(f"l must satisfy 0 <= l < n = {n}; got l={l}")
    if abs(m) > l:
        raise ValueError(f"m must satisfy -l <= m <= l = {l}; got m={m}")
    return n, l, m


def hydrogen_density(x, y, z, n=3, l=2, m=0):  # noqa: E741
    """:math:`|\\psi_{nlm}|^2` of the hydrogen atom at Cartesian points (Bohr radii).

    Parameters
    ----------
    x, y, z : array_like, broadcastable, float
        Positions in Bohr radii :math:`a_0`, nucleus at the origin.
    n, l, m : int
        Principal, azimuthal and magnetic quantum numbers, ``1 <= n <= 30``,
        ``0 <= l < n``, ``-l <= m <= l``. ``m`` selects a *real* orbital:
        ``m > 0`` goes with :math:`\\cos(m\\phi)`, ``m < 0`` with
        :math:`\\sin(|m|\\phi)` (e.g. ``(2, 1, 1)`` is :math:`p_x`, ``(2, 1, -1)`` is
        :math:`p_y`, ``(2, 1, 0)`` is :math:`p_z`).

    Returns
    -------
    ndarray, float64
        Probability density in :math:`a_0^{-3}`, >= 0.

    Notes
    -----
    With :math:`\\rho = 2r / (n a_0)` and :math:`a_0 = 1`,

    .. math::
        \\psi_{nlm} = R_{nl}(r)\\, Y_{lm}(\\theta, \\phi), \\qquad
        R_{nl}(r) = \\sqrt{\\Big(\\frac{2}{n}\\Big)^3 \\frac{(n-l-1)!}{2n\\,(n+l)!}}\\;
                     e^{-\\rho/2} \\rho^l L^{(2l+1)}_{n-l-1}(\\rho)

    where :math:`L^{(\\alpha)}_k` is the generalised Laguerre polynomial
    (:math:`L^{(\\alpha)}_0 = 1`, :math:`L^{(\\alpha)}_1 = 1 + \\alpha - x`,
    :math:`(k+1) L^{(\\alpha)}_{k+1} = (2k+1+\\alpha-x) L^{(\\alpha)}_k - (k+\\alpha)
    L^{(\\alpha)}_{k-1}`) and the real spherical harmonic is

    .. math::
        Y_{lm} = \\sqrt{2 - \\delta_{m0}}\\,\\sqrt{\\frac{2l+1}{4\\pi}
                 \\frac{(l-|m|)!}{(l+|m|)!}}\\; P_l^{|m|}(\\cos\\theta)
                 \\times \\begin{cases}\\cos(m\\phi) & m \\ge 0\\\\
                 \\sin(|m|\\phi) & m < 0\\end{cases}

    Both factors are normalised, so :math:`\\int |\\psi|^2 dV = 1`. The product is
    evaluated as a polynomial in ``x, y, z`` with no trigonometry and no division by
    ``r``:
    :math:`r^{|m|} \\sin^{|m|}\\theta\\, \\{\\cos, \\sin\\}(|m|\\phi) =
    \\{\\mathrm{Re}, \\mathrm{Im}\\}(x + iy)^{|m|}` and
    :math:`r^{l-|m|} P_l^{|m|}(\\cos\\theta) / \\sin^{|m|}\\theta` follows the Legendre
    recurrence in ``z`` and :math:`r^2`. So the density is finite at the nucleus and
    exactly ``0.0`` on nodal planes through grid points (``x = 0`` for ``m = 1``,
    ``z = 0`` for ``l - |m|`` odd). The Condon–Shortley phase is omitted; it does not
    change :math:`|\\psi|^2`.

    References
    ----------
    .. [1] D. J. Griffiths, D. F. Schroeter, *Introduction to Quantum Mechanics*,
       3rd ed., Cambridge University Press (2018), §4.2 "The Hydrogen Atom".
    .. [2] NIST Digital Library of Mathematical Functions, §18.9 (Laguerre
       recurrence) and §14.10 (Legendre recurrences), https://dlmf.nist.gov/.
    .. [3] M. A. Blanco, M. Flórez, M. Bermejo, "Evaluation of the rotation matrices
       in the basis of real spherical harmonics", *J. Mol. Struct. (Theochem)* 419,
       19–27 (1997) (real spherical harmonics).

    Examples
    --------
    The ground state at the nucleus is :math:`1/\\pi`:

    >>> d = float(hydrogen_density(0.0, 0.0, 0.0, n=1, l=0, m=0))
    >>> abs(d - 1 / math.pi) < 1e-15
    True
    """
    n, l, m = _check_quantum_numbers(n, l, m)  # noqa: E741
    x, y, z = (np.asarray(c, dtype=np.float64) for c in (x, y, z))
    x, y, z = np.broadcast_arrays(x, y, z)
    r2 = x * x + y * y + z * z
    rho = (2.0 / n) * np.sqrt(r2)
    k = abs(m)

    # generalised Laguerre L^{(2l+1)}_{n-l-1}(rho)
    alpha = 2 * l + 1
    lag_prev, lag = np.zeros_like(rho), np.ones_like(rho)
    for j in range(n - l - 1):
        lag_prev, lag = lag, ((2 * j + 1 + alpha - rho) * lag - (j + alpha) * lag_prev) / (j + 1)

    # H_l = r^(l-k) P_l^k(cos t) / sin^k t, by the Legendre recurrence in degree
    h_prev = np.zeros_like(rho)
    h = np.full_like(rho, float(_double_factorial(2 * k - 1)))
    for deg in range(k + 1, l + 1):
        h_prev, h = h, ((2 * deg - 1) * z * h - (deg + k - 1) * r2 * h_prev) / (deg - k)

    # Re/Im (x + iy)^k by repeated multiplication: exact zeros on the nodal planes
    c, s = np.ones_like(rho), np.zeros_like(rho)
    for _ in range(k):
        c, s = x * c - y * s, x * s + y * c
    azimuthal = s if m < 0 else c

    norm_r = math.sqrt((2.0 / n) ** 3 * math.factorial(n - l - 1) / (2 * n * math.factorial(n + l)))
    norm_y = math.sqrt((2 - (m == 0)) * (2 * l + 1) / (4 * math.pi) * math.factorial(l - k) / math.factorial(l + k))
    # rho^l = (2/n)^l r^l, and r^l Y_lm = norm_y * H_l * azimuthal
    psi = (norm_r * norm_y * (2.0 / n) ** l) * np.exp(-0.5 * rho) * lag * h * azimuthal
    return psi * psi


def _double_factorial(k):
    out = 1
    while k > 1:
        out *= k
        k -= 2
    return out


def hydrogen_orbital_array(n=3, l=2, m=0, size=64, extent=None, dtype=np.float64):  # noqa: E741
    """:func:`hydrogen_density` sampled on a cube, as numpy arrays (no PyVista needed).

    Parameters
    ----------
    n, l, m : int
        Quantum numbers (see :func:`hydrogen_density`).
    size : int
        Points per axis, >= 2. An odd size puts a point on the nucleus and on the
        planes ``x = 0``, ``y = 0``, ``z = 0``.
    extent : float, optional
        Half-width of the cube in Bohr radii; points run from ``-extent`` to
        ``+extent``. Default :func:`default_extent` ``(n)``.
    dtype : {numpy.float64, numpy.float32}
        Of the returned values (computed in float64).

    Returns
    -------
    values : ndarray, shape (size, size, size), ``dtype``
        ``values[k, j, i]`` is the density at ``origin + (i, j, k) * spacing``
        (z, y, x order: x fastest, as VTK stores points).
    spacing : tuple of 3 floats
        ``2 * extent / (size - 1)`` on each axis.
    origin : tuple of 3 floats
        ``(-extent, -extent, -extent)``.

    Examples
    --------
    >>> values, spacing, origin = hydrogen_orbital_array(2, 1, 0, size=5, extent=4.0)
    >>> values.shape, spacing, origin
    ((5, 5, 5), (2.0, 2.0, 2.0), (-4.0, -4.0, -4.0))
    >>> float(values[2].max())  # the 2p_z orbital vanishes on the plane z = 0
    0.0
    """
    n, l, m = _check_quantum_numbers(n, l, m)  # noqa: E741
    size = as_int("size", size, low=2, high=2048)
    extent = default_extent(n) if extent is None else as_real("extent", extent, low=0, low_open=True)
    dt = np.dtype(dtype)
    if dt not in (np.float32, np.float64):
        raise TypeError(f"dtype must be float32 or float64; got {dt}")
    h = 2.0 * extent / (size - 1)
    axis = -extent + h * np.arange(size)
    # exact zero at the centre for odd sizes (the arange product can leave 1e-15)
    if size % 2:
        axis[size // 2] = 0.0
    z, y, x = np.meshgrid(axis, axis, axis, indexing="ij", sparse=True)
    values = hydrogen_density(x, y, z, n, l, m).astype(dt, copy=False)
    return np.ascontiguousarray(values), (h, h, h), (-extent, -extent, -extent)


def hydrogen_orbital(n=3, l=2, m=0, size=64, extent=None, dtype=np.float64):  # noqa: E741
    """The hydrogen orbital density :math:`|\\psi_{nlm}|^2` as a ``pyvista.ImageData``.

    A cube of ``size**3`` points centred on the nucleus, in Bohr radii, with the point
    array ``"probability_density"`` (active scalars, :math:`a_0^{-3}`). The default
    ``3d_{z^2}`` orbital (``n=3, l=2, m=0``) has two nodal cones
    (:math:`\\cos^2\\theta = 1/3`); the cube's diagonals lie on them, so its corners
    are exactly 0. At ``size=64`` its positive values span 47 decades (peak 7.0e-4,
    median 1.1e-12, smallest 4.9e-51). See :func:`hydrogen_density` for the formula and
    :func:`hydrogen_orbital_array` for the parameters.

    Examples
    --------
    >>> grid = hydrogen_orbital(1, 0, 0, size=3, extent=1.0)
    >>> grid.dimensions, grid.active_scalars_name
    ((3, 3, 3), 'probability_density')
    >>> bool(abs(grid["probability_density"][13] - 1 / math.pi) < 1e-15)  # the nucleus
    True
    """
    import pyvista as pv

    values, spacing, origin = hydrogen_orbital_array(n, l, m, size, extent, dtype)
    grid = pv.ImageData(dimensions=values.shape[::-1], spacing=spacing, origin=origin)
    grid.point_data[ARRAY_NAME] = values.reshape(-1)
    grid.set_active_scalars(ARRAY_NAME)
    grid.field_data["quantum_numbers_nlm"] = np.array([n, l, m])
    return grid


def demo_transfer_function(vmax=1e-3, decades=10.0, cmap="magma", opacity=(0.0, 0.005, 0.02, 0.1),
                           emission_gamma=0.2, n_points=64):
    """A log-scale transfer function for :func:`hydrogen_orbital` (``n = 3``).

    Colours follow ``cmap`` along ``log10(v)`` and are scaled by
    ``(v / vmax) ** emission_gamma``, so the emission itself is high-dynamic-range
    (``decades * emission_gamma`` decades: 2 by default) and the faint tail glows
    dimly instead of fogging the bright lobes.

    Parameters
    ----------
    vmax : float
        Top of the range (:math:`a_0^{-3}`); the default suits ``n = 3`` (the
        ``3d_{z^2}`` peak density is 7.7e-4 at r = 6 on the z axis).
    decades : float
        The range is ``[vmax * 10**-decades, vmax]`` on a log10 axis; densities
        below it are transparent.
    cmap : str
        Matplotlib colormap name (``"gray"`` works without matplotlib).
    opacity : sequence of float
        Per-voxel opacities spread evenly over the decades, interpolated between.
    emission_gamma : float
        Exponent of the emission scaling, >= 0 (0: plain colormap).
    n_points : int
        Control points.

    Returns
    -------
    TransferFunction

    Examples
    --------
    >>> tf = demo_transfer_function()
    >>> tf.scale, tf.vmin, tf.vmax
    ('log', 1e-13, 0.001)
    >>> gray = demo_transfer_function(cmap="gray")  # halfway: 0.5 * 10**(-5 * 0.2)
    >>> round(float(gray.color_at(1e-8)[0]), 3)
    0.05
    """
    from .data.transfer import TransferFunction, colormap_rgb

    vmax = as_real("vmax", vmax, low=0, low_open=True)
    decades = as_real("decades", decades, low=0, low_open=True)
    gamma = as_real("emission_gamma", emission_gamma, low=0)
    n_points = as_int("n_points", n_points, low=2, high=4096)
    t = np.linspace(0.0, 1.0, n_points)
    values = vmax * 10.0 ** (decades * (t - 1.0))
    values[-1] = vmax
    colors = colormap_rgb(cmap, t) * (10.0 ** (gamma * decades * (t - 1.0)))[:, None]
    ops = np.array(opacity, dtype=np.float64).reshape(-1)
    if ops.size < 2:
        raise ValueError(f"opacity must hold at least 2 values; got {opacity!r}")
    opac = np.interp(t, np.linspace(0.0, 1.0, ops.size), ops)
    return TransferFunction(values, colors, opac, scale="log")


__all__ = ["ARRAY_NAME", "default_extent", "demo_transfer_function", "hydrogen_density", "hydrogen_orbital",
           "hydrogen_orbital_array"]
