r"""Image-space lighting of proxy images: normals, shading, ambient occlusion, enhancement.

Everything here works on images alone, without the volume (paper §5 and §6.5):

- :func:`normals_from_depth` turns a depth proxy into eye-space normals;
- :func:`shade` lights them with the ray caster's Blinn-Phong model;
- :func:`ambient_occlusion` (the paper's anisotropic kernel, Eq. 5, with the raw sum
  in :func:`occlusion_sum`) and :func:`unsharp_occlusion` (the baseline it is
  compared with, Luft et al. 2006) darken creases;
- :func:`enhance` darkens the edges of the accumulated attenuation (Eq. 11);
- :func:`composite_layers` composites lit semi-transparent layers front to back.

Conventions. Images are ``(rows, cols)``, row 0 at the top. Eye space is right-handed:
``x`` to the right (increasing column), ``y`` up (decreasing row), ``z`` towards the
viewer; the view is orthographic along ``-z``. A depth image holds, per pixel, the
distance of the surface from the camera plane along the view direction in world units
(growing away from the viewer), and a non-finite value (``inf``, ``NaN``) where the
pixel's ray misses the layer. ``pitch`` is the world size of a (square) pixel. Colour
images are linear; RGBA is premultiplied. No function modifies its arguments.

References
----------
.. [1] "Visualization by Proxy", §5 (relighting, proxy-based ambient occlusion, Eq. 5)
   and §6.5 (depth-aware enhancement, Eq. 11); ``shared/papers/visualization_by_proxy.txt``.
.. [2] T. Luft, C. Colditz, O. Deussen, "Image enhancement by unsharp masking the depth
   buffer", ACM Trans. Graph. 25(3), 2006.
"""
from __future__ import annotations

import numbers

import numpy as np

from .._validate import as_real
from ..image.filters import gaussian_blur
from ..params import Light, as_lights
from . import _lighting_kernels as _k

__all__ = ["normals_from_depth", "shade", "occlusion_sum", "ambient_occlusion", "unsharp_occlusion",
           "enhance", "composite_layers"]

#: Largest neighbourhood radius (pixels) of the occlusion functions: the ambient
#: occlusion costs ``pi radius**2`` operations per pixel.
MAX_RADIUS = 256

#: How far from orthonormal (max abs entry of ``B B^T - I``) a ``basis`` may be.
_BASIS_TOLERANCE = 1e-6


# -- validation ------------------------------------------------------------------------
def _as_depth(value, name="depth"):
    """``value`` as a new C-contiguous float64 2-D array with NaN at every non-finite pixel."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a real float or integer array; got dtype {arr.dtype}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array (rows, cols); got shape {arr.shape}")
    z = np.array(arr, dtype=np.float64, order="C")  # always a copy: the caller's array stays
    z[~np.isfinite(z)] = np.nan
    return z


def _as_radius(radius):
    if isinstance(radius, bool) or not isinstance(radius, numbers.Integral):
        raise TypeError(f"radius must be an integer number of pixels; got {radius!r} ({type(radius).__name__})")
    if radius < 1:
        raise ValueError(f"radius must be >= 1 pixel; got {radius!r}")
    if radius > MAX_RADIUS:
        raise ValueError(f"radius must be <= {MAX_RADIUS} pixels; got {radius!r}")
    return int(radius)


def _as_pitch(pitch):
    return as_real("pitch", pitch, low=0.0, low_open=True)


def _as_discontinuity(discontinuity):
    return as_real("discontinuity", discontinuity, low=0.0, low_open=True)


def _as_float_array(name, value):
    arr = np.asarray(value)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a real float or integer array; got dtype {arr.dtype}")
    return arr.astype(np.float64, copy=False)


# -- depth derivatives -----------------------------------------------------------------
def _axis_derivative(z, axis, threshold):
    """Derivative of ``z`` (NaN at misses) along ``axis`` in depth units per pixel
    (towards increasing index): central differences, else the one-sided difference of
    smaller magnitude among the valid sides, else 0; NaN where ``z`` is NaN."""
    zz = np.moveaxis(z, axis, 0)
    n = zz.shape[0]
    fwd = np.full(zz.shape, np.nan)  # z[i + 1] - z[i]
    bwd = np.full(zz.shape, np.nan)  # z[i] - z[i - 1]
    if n > 1:
        fwd[:-1] = zz[1:] - zz[:-1]
        bwd[1:] = fwd[:-1]
    central = np.zeros(zz.shape)
    if n > 2:
        central[1:-1] = 0.5 * (zz[2:] - zz[:-2])
    fwd_ok = np.isfinite(fwd)
    bwd_ok = np.isfinite(bwd)
    afwd = np.where(fwd_ok, np.abs(fwd), np.inf)
    abwd = np.where(bwd_ok, np.abs(bwd), np.inf)
    smooth = fwd_ok & bwd_ok & (afwd <= threshold) & (abwd <= threshold)
    # a tie (a spike, or a flat step) keeps the symmetric central difference
    d = np.where(afwd < abwd, fwd, np.where(abwd < afwd, bwd, central))
    d = np.where(smooth, central, d)
    d = np.where(fwd_ok | bwd_ok, d, 0.0)
    d[np.isnan(zz)] = np.nan
    return np.moveaxis(d, 0, axis)


def _depth_gradient(z, pitch, discontinuity):
    """``(dZ/drow, dZ/dcol)`` in world units per pixel (see :func:`normals_from_depth`)."""
    threshold = discontinuity * pitch
    return _axis_derivative(z, 0, threshold), _axis_derivative(z, 1, threshold)


def normals_from_depth(depth, pitch, *, discontinuity=4.0):
    r"""Eye-space unit normals of a depth image.

    Parameters
    ----------
    depth : array_like, shape (rows, cols), float
        Distance of the surface from the camera plane along the view direction, world
        units, growing away from the viewer; non-finite (``inf``, ``NaN``) where the
        ray misses. Row 0 at the top. Not modified.
    pitch : float
        World size of a pixel, ``> 0``.
    discontinuity : float, optional
        A depth jump larger than ``discontinuity * pitch`` between neighbouring pixels
        is an edge between two surfaces, not a slope (default 4, a slope of 76°).

    Returns
    -------
    ndarray, shape (rows, cols, 3), float64
        Unit normals ``(x right, y up, z towards the viewer)``, ``n_z > 0``; NaN where
        ``depth`` is not finite.

    Raises
    ------
    ValueError
        If ``depth`` is not 2-D, or ``pitch`` or ``discontinuity`` is not finite and
        ``> 0``.
    TypeError
        If ``depth`` is not a real array, or ``pitch`` not a number.

    Notes
    -----
    The surface point of pixel ``(x, y)`` is ``(x, y, -Z)``; its tangents
    ``(1, 0, -Z_x)`` and ``(0, 1, -Z_y)`` give the outward normal ([1]_ §5)

    .. math:: n \propto \Bigl(\frac{\partial Z}{\partial x},
              \frac{\partial Z}{\partial y}, 1\Bigr),
              \quad \frac{\partial Z}{\partial x} = \frac{Z_{r,c+1} - Z_{r,c-1}}{2\,\mathrm{pitch}},
              \quad \frac{\partial Z}{\partial y} = \frac{Z_{r-1,c} - Z_{r+1,c}}{2\,\mathrm{pitch}}

    (``y`` is up, so it grows towards row 0). With ``x``, ``y`` and ``Z`` in the same
    world units the normal is exact for a plane in an orthographic view. Where a
    neighbour is missing or one of the two one-sided differences jumps by more than
    ``discontinuity * pitch``, the one-sided difference of smaller magnitude among the
    existing neighbours is used (it lies on the pixel's own surface); a pixel with
    neither neighbour on an axis gets the derivative 0 on that axis.

    References
    ----------
    .. [1] "Visualization by Proxy", §5.

    Examples
    --------
    A plane rising by half a pixel per pixel to the right faces right:

    >>> import numpy as np
    >>> z = np.tile(0.5 * np.arange(5.0), (4, 1))
    >>> n = normals_from_depth(z, 1.0)
    >>> np.allclose(n, np.array([0.5, 0.0, 1.0]) / np.sqrt(1.25))
    True
    """
    z = _as_depth(depth)
    pitch = _as_pitch(pitch)
    discontinuity = _as_discontinuity(discontinuity)
    g_row, g_col = _depth_gradient(z, pitch, discontinuity)
    n = np.empty(z.shape + (3,))
    n[..., 0] = g_col / pitch
    n[..., 1] = -g_row / pitch
    n[..., 2] = 1.0
    n /= np.sqrt(np.einsum("...i,...i->...", n, n))[..., None]
    n[np.isnan(z)] = np.nan
    return n


# -- Blinn-Phong -----------------------------------------------------------------------
def _as_basis(basis):
    try:
        b = np.array(basis, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"basis must be (right, up, forward), three 3-vectors; got {basis!r}") from None
    if b.shape != (3, 3):
        raise ValueError(f"basis must be (right, up, forward), three 3-vectors; got shape {b.shape}")
    if not np.all(np.isfinite(b)):
        raise ValueError(f"basis must be finite; got {basis!r}")
    if np.max(np.abs(b @ b.T - np.eye(3))) > _BASIS_TOLERANCE:
        raise ValueError(f"basis must be orthonormal unit vectors (right, up, forward), as Camera.basis() "
                         f"returns; got {basis!r}")
    return b


def _eye_lights(lights, basis):
    """``(n, 3)`` unit directions towards the lights in eye space and ``(n, 3)`` intensities."""
    lights = (Light(),) if lights is None else as_lights(lights)
    b = None if basis is None else _as_basis(basis)
    dirs = np.empty((len(lights), 3))
    rgb = np.empty((len(lights), 3))
    for k, light in enumerate(lights):
        if light.is_headlight:
            dirs[k] = (0.0, 0.0, 1.0)
        else:
            if b is None:
                raise ValueError(f"lights[{k}] has the world direction {light.direction!r}: pass basis=(right, up, "
                                 "forward) (Camera.basis()) to turn it into eye space, or use a headlight")
            d = np.array(light.unit_direction)
            right, up, forward = b
            dirs[k] = (d @ right, d @ up, -(d @ forward))
        rgb[k] = light.intensity
    return dirs, rgb


def shade(normals, color, lights=None, *, ambient=0.1, diffuse=0.7, specular=0.2, specular_power=10.0,
          basis=None):
    r"""Blinn-Phong lighting of eye-space normals, as the ray caster shades samples.

    Parameters
    ----------
    normals : array_like, shape (rows, cols, 3), float
        Eye-space normals (any non-zero length), e.g. from :func:`normals_from_depth`;
        NaN (or the zero vector) where there is no surface. Not modified.
    color : array_like, shape (3,) or (rows, cols, 3), float
        Linear RGB surface colour (HDR values above 1 are kept). Not modified.
    lights : None, Light, direction, or a sequence of them, optional
        As :class:`~pv_hdrvol.params.RenderOptions` ``lights``; ``None`` (default): one
        white headlight. A headlight shines along the view (``l = e = (0, 0, 1)``);
        other directions are in *world* coordinates, from the scene towards the light,
        and need ``basis``.
    ambient, diffuse, specular : float, optional
        Blinn-Phong weights, each ``>= 0`` (defaults 0.1, 0.7, 0.2: the ray caster's).
    specular_power : float, optional
        Exponent ``p``, ``>= 1`` (default 10).
    basis : (right, up, forward), optional
        The camera frame as :meth:`Camera.basis() <pv_hdrvol.rays.camera.Camera.basis>`
        returns it (unit world vectors); needed only for lights that are not headlights.

    Returns
    -------
    ndarray, shape (rows, cols, 3), float64
        The lit colour; 0 where there is no surface.

    Raises
    ------
    ValueError
        On a wrong shape, a weight out of range, a world light without ``basis`` or a
        ``basis`` that is not orthonormal.
    TypeError
        If an array is not real, or a weight not a number.

    Notes
    -----
    The model of the ray caster (``raycast/_shading_kernels.light_factors``), at full
    strength: with ``n`` the unit normal turned towards the eye (two-sided lighting),
    ``e = (0, 0, 1)`` the direction towards the eye of the orthographic view, and per
    light ``l`` (unit, towards the light), ``I`` (RGB) and
    ``h = (l + e) / |l + e|``:

    .. math:: c_{lit} = c \Bigl(k_a + k_d \sum_l I_l \max(n\cdot l, 0)\Bigr)
              + k_s \sum_{l:\, n\cdot l > 0} I_l \max(n\cdot h, 0)^p

    A world direction ``d`` becomes ``(d·right, d·up, -d·forward)`` in eye space.
    The paper lights depth proxies with diffuse and specular terms ([1]_ §5).

    References
    ----------
    .. [1] "Visualization by Proxy", §5.

    Examples
    --------
    A surface facing the headlight gets ``c (k_a + k_d) + k_s``:

    >>> import numpy as np
    >>> n = np.zeros((1, 1, 3)); n[..., 2] = 1.0
    >>> shade(n, (0.5, 0.5, 0.5))[0, 0].tolist()
    [0.6, 0.6, 0.6]
    """
    n = _as_float_array("normals", normals)
    if n.ndim != 3 or n.shape[2] != 3:
        raise ValueError(f"normals must have shape (rows, cols, 3); got shape {n.shape}")
    c = _as_float_array("color", color)
    if c.shape != (3,) and c.shape != n.shape:
        raise ValueError(f"color must have shape (3,) or {n.shape} (the normals' shape); got shape {c.shape}")
    ka = as_real("ambient", ambient, low=0.0)
    kd = as_real("diffuse", diffuse, low=0.0)
    ks = as_real("specular", specular, low=0.0)
    p = as_real("specular_power", specular_power, low=1.0)
    dirs, rgb = _eye_lights(lights, basis)

    length = np.sqrt(np.einsum("...i,...i->...", n, n))
    surface = length > 0.0  # False at NaN too
    unit = np.where(surface[..., None], n, 0.0) / np.where(surface, length, 1.0)[..., None]
    unit = np.where(unit[..., 2:3] < 0.0, -unit, unit)  # towards the eye, e = (0, 0, 1)
    diff = np.zeros(n.shape)
    spec = np.zeros(n.shape)
    for (lx, ly, lz), intensity in zip(dirs, rgb):
        ndl = unit[..., 0] * lx + unit[..., 1] * ly + unit[..., 2] * lz
        lit = ndl > 0.0
        diff += np.where(lit, ndl, 0.0)[..., None] * intensity
        hx, hy, hz = lx, ly, lz + 1.0
        hl = np.sqrt(hx * hx + hy * hy + hz * hz)
        if ks == 0.0 or not hl > 0.0:
            continue
        ndh = (unit[..., 0] * hx + unit[..., 1] * hy + unit[..., 2] * hz) / hl
        s = np.where(lit & (ndh > 0.0), np.maximum(ndh, 0.0) ** p, 0.0)
        spec += s[..., None] * intensity
    out = c * (ka + kd * diff) + ks * spec
    out[~surface] = 0.0
    return out


# -- ambient occlusion -----------------------------------------------------------------
def _disc_offsets(radius):
    """Row and column offsets (int64) of the pixels within ``radius`` of a pixel, itself excluded."""
    r = np.arange(-radius, radius + 1, dtype=np.int64)
    dr, dc = np.meshgrid(r, r, indexing="ij")
    inside = (dr * dr + dc * dc <= radius * radius) & ((dr != 0) | (dc != 0))
    return np.ascontiguousarray(dr[inside]), np.ascontiguousarray(dc[inside])


def occlusion_sum(depth, pitch, *, radius=8, discontinuity=4.0):
    r"""The proxy ambient occlusion sum of paper Eq. (5) and the size of each neighbourhood.

    Parameters
    ----------
    depth : array_like, shape (rows, cols), float
        Depth proxy (world units, non-finite at misses); see :func:`normals_from_depth`.
        Not modified.
    pitch : float
        World size of a pixel, ``> 0``.
    radius : int, optional
        Neighbourhood: the pixels ``q != p`` with ``|q - p| <= radius`` pixels
        (default 8, 1 to :data:`MAX_RADIUS`).
    discontinuity : float, optional
        As in :func:`normals_from_depth`, for the depth gradient.

    Returns
    -------
    ao : ndarray, shape (rows, cols), float64
        :math:`AO(p)` in world units; NaN where ``depth`` is not finite.
    count : ndarray, shape (rows, cols), float64
        :math:`|Neigh(p)|`, the number of neighbours inside the image with a finite
        depth (0 at misses).

    Raises
    ------
    ValueError, TypeError
        As :func:`normals_from_depth`; and for ``radius`` not an integer in
        ``[1, MAX_RADIUS]``.

    Notes
    -----
    .. math:: AO(p) = \sum_{q \in Neigh(p)} \max\Bigl(0,\; Z(p) + \nabla Z(p)^\top (q - p)
              - Z(q)\Bigr)

    ([1]_ Eq. 5) with ``q - p`` in pixels and :math:`\nabla Z` in world units per pixel
    (the differences of :func:`normals_from_depth`). :math:`Z(p) + \nabla Z^\top (q - p)`
    is the depth of ``p``'s tangent plane at ``q``: a neighbour nearer than the tangent
    plane occludes ``p``. A plane and a convex surface facing the viewer therefore
    give 0, a crease or a bowl a positive sum. Misses are no neighbours.

    References
    ----------
    .. [1] "Visualization by Proxy", §5, Eq. (5).

    Examples
    --------
    >>> import numpy as np
    >>> ao, count = occlusion_sum(np.zeros((9, 9)), 1.0, radius=1)
    >>> float(ao.max()), float(count[4, 4]), float(count[0, 0])
    (0.0, 4.0, 2.0)
    """
    z = _as_depth(depth)
    pitch = _as_pitch(pitch)
    radius = _as_radius(radius)
    discontinuity = _as_discontinuity(discontinuity)
    g_row, g_col = _depth_gradient(z, pitch, discontinuity)
    off_r, off_c = _disc_offsets(radius)
    ao = np.empty(z.shape)
    count = np.empty(z.shape)
    _k.occlusion_sum(z, np.ascontiguousarray(g_row), np.ascontiguousarray(g_col), off_r, off_c, ao, count)
    return ao, count


def _factor(darkness, strength):
    """``1 - clip(strength * darkness, 0, 1)``, 1 where ``darkness`` is NaN (a miss)."""
    f = 1.0 - np.clip(strength * darkness, 0.0, 1.0)
    f[np.isnan(darkness)] = 1.0
    return f


def ambient_occlusion(depth, pitch, *, radius=8, strength=1.0, discontinuity=4.0):
    r"""Proxy-based ambient occlusion (the paper's anisotropic kernel) as a shading factor.

    Parameters
    ----------
    depth : array_like, shape (rows, cols), float
        Depth proxy (world units, non-finite at misses). Not modified.
    pitch : float
        World size of a pixel, ``> 0``.
    radius : int, optional
        Neighbourhood radius in pixels (default 8).
    strength : float, optional
        :math:`\kappa`, ``>= 0`` (default 1).
    discontinuity : float, optional
        As in :func:`normals_from_depth`.

    Returns
    -------
    ndarray, shape (rows, cols), float64
        Factor in ``[0, 1]`` to multiply the lit colour by: 1 unoccluded, and 1 at
        misses (there is nothing to darken).

    Notes
    -----
    With :math:`AO(p)` and :math:`|Neigh(p)|` from :func:`occlusion_sum` (Eq. 5 of
    [1]_),

    .. math:: f(p) = 1 - \operatorname{clip}\Bigl(\kappa\,
              \frac{AO(p)}{|Neigh(p)|\; R\; \mathrm{pitch}}, 0, 1\Bigr)

    so the mean occluder height above the tangent plane is measured in units of the
    neighbourhood's world radius. A pixel without neighbours gets 1. The paper gives
    no normalisation; this is the choice of ``notes/methods.md`` §B.1.5.

    References
    ----------
    .. [1] "Visualization by Proxy", §5, Eq. (5) and Fig. 9.

    Examples
    --------
    A tilted plane is not occluded:

    >>> import numpy as np
    >>> rows, cols = np.mgrid[0:32, 0:32]
    >>> float(ambient_occlusion(0.25 * rows + 0.5 * cols, 1.0).min())
    1.0
    """
    strength = as_real("strength", strength, low=0.0)
    ao, count = occlusion_sum(depth, pitch, radius=radius, discontinuity=discontinuity)
    pitch = float(pitch)
    with np.errstate(invalid="ignore", divide="ignore"):
        norm = np.where(count > 0, ao / (np.maximum(count, 1.0) * radius * pitch), 0.0)
    norm[np.isnan(ao)] = np.nan
    return _factor(norm, strength)


def unsharp_occlusion(depth, pitch, *, radius=8, strength=1.0):
    r"""Ambient occlusion by unsharp masking of the depth buffer (Luft et al. 2006): the baseline.

    Parameters
    ----------
    depth, pitch
        As :func:`ambient_occlusion`: the depth proxy (not modified) and a pixel's world size.
    radius : int, optional
        The Gaussian's standard deviation is ``radius / 2`` pixels (default 8); also
        the normalising length, as in :func:`ambient_occlusion`.
    strength : float, optional
        ``>= 0`` (default 1).

    Returns
    -------
    ndarray, shape (rows, cols), float64
        Factor in ``[0, 1]``; 1 at misses.

    Notes
    -----
    .. math:: \Delta D = G_\sigma * Z - Z, \qquad
              f = 1 - \operatorname{clip}\Bigl(\kappa\,
              \frac{\max(-\Delta D, 0)}{R\;\mathrm{pitch}}, 0, 1\Bigr),
              \quad \sigma = R / 2

    with :math:`G_\sigma * Z` the normalised convolution over the pixels that hit
    (:func:`~pv_hdrvol.image.filters.gaussian_blur` leaves NaN out). Only a nearer
    neighbourhood (:math:`\Delta D < 0`) darkens. The isotropic kernel cannot tell a
    crease from a surface turning away: a convex object darkens along its silhouette,
    where its neighbourhood is all nearer ([1]_ Fig. 9c); :func:`ambient_occlusion`
    does not.

    References
    ----------
    .. [1] "Visualization by Proxy", §5, Fig. 9.
    .. [2] T. Luft, C. Colditz, O. Deussen, "Image enhancement by unsharp masking the
       depth buffer", ACM Trans. Graph. 25(3), 2006.

    Examples
    --------
    >>> import numpy as np
    >>> float(unsharp_occlusion(np.full((16, 16), 3.0), 1.0).min())
    1.0
    """
    z = _as_depth(depth)
    pitch = _as_pitch(pitch)
    radius = _as_radius(radius)
    strength = as_real("strength", strength, low=0.0)
    delta = gaussian_blur(z, 0.5 * radius) - z  # NaN at misses
    return _factor(np.maximum(-delta, 0.0) / (radius * pitch), strength)


# -- enhancement -----------------------------------------------------------------------
def enhance(color, atten, *, strength=1.0, contrast=0.5):
    r"""Depth-aware enhancement: darken where the accumulated attenuation changes (Eq. 11).

    Parameters
    ----------
    color : array_like, shape (rows, cols, 3) or (rows, cols, 4), float
        Linear RGB, or premultiplied RGBA. Not modified.
    atten : array_like, shape (L, rows, cols), float
        Accumulated attenuation :math:`a_i` of each of the ``L`` intensity intervals;
        finite. Not modified.
    strength : float, optional
        :math:`\lambda`, ``>= 0`` (default 1).
    contrast : float, optional
        :math:`\gamma`, ``> 0`` (default 0.5: ``r`` is then the Frobenius norm of the
        attenuation gradient).

    Returns
    -------
    ndarray, same shape as ``color``, float64
        :math:`(1 - r)\,c`. For RGBA only the colour channels are scaled and alpha is
        kept: the enhancement darkens, as lighting does, without making a pixel more
        transparent (premultiplied RGB times ``1 - r`` stays ``<= alpha``).

    Notes
    -----
    .. math:: c_{enhanced} = (1 - r)\,c, \qquad
              r = \operatorname{clip}\Bigl(\lambda \Bigl(\sum_{i=1}^{L}
              \Bigl\|\Bigl(\frac{\partial a_i}{\partial x},
              \frac{\partial a_i}{\partial y}\Bigr)\Bigr\|^2\Bigr)^{\gamma}, 0, 1\Bigr)

    ([1]_ Eq. 11, summed over the ``L`` intervals), the derivatives by central
    differences in pixel units (one-sided on the image border, ``numpy.gradient``).
    Attenuation encodes depth, so the edges this darkens are volumetric edges. ``r`` is
    clamped, as it can exceed 1. The sign of ``y`` does not matter: only squared
    derivatives enter.

    References
    ----------
    .. [1] "Visualization by Proxy", §6.5, Eq. (11).

    Examples
    --------
    Constant attenuation leaves the colour unchanged:

    >>> import numpy as np
    >>> c = np.full((4, 4, 3), 0.5)
    >>> bool(np.array_equal(enhance(c, np.full((2, 4, 4), 0.3)), c))
    True
    """
    c = _as_float_array("color", color)
    if c.ndim != 3 or c.shape[2] not in (3, 4):
        raise ValueError(f"color must have shape (rows, cols, 3) or (rows, cols, 4); got shape {c.shape}")
    a = _as_float_array("atten", atten)
    if a.ndim != 3 or a.shape[1:] != c.shape[:2]:
        raise ValueError(f"atten must have shape (L, rows, cols) = (L, {c.shape[0]}, {c.shape[1]}) to match "
                         f"color; got shape {a.shape}")
    if a.shape[0] < 1:
        raise ValueError("atten must hold at least one interval (L >= 1); got L = 0")
    if not np.all(np.isfinite(a)):
        raise ValueError("atten must be finite; got NaN or inf")
    lam = as_real("strength", strength, low=0.0)
    gamma = as_real("contrast", contrast, low=0.0, low_open=True)
    rows, cols = c.shape[:2]
    energy = np.zeros((rows, cols))
    for ai in a:
        if rows > 1:
            energy += np.gradient(ai, axis=0) ** 2
        if cols > 1:
            energy += np.gradient(ai, axis=1) ** 2
    r = np.clip(lam * energy ** gamma, 0.0, 1.0)
    out = np.array(c, dtype=np.float64)
    out[..., :3] *= (1.0 - r)[..., None]
    return out


# -- semi-transparent layers -----------------------------------------------------------
def composite_layers(colors, opacities, depths):
    r"""Composite lit semi-transparent layers front to back, per pixel in depth order.

    Parameters
    ----------
    colors : array_like, shape (k, rows, cols, 3), float
        Colour of each layer (already lit, e.g. by :func:`shade`), not premultiplied.
        Not read where the layer misses. Not modified.
    opacities : array_like, shape (k,) or (k, rows, cols), float
        Opacity of each layer (per layer or per pixel), in ``[0, 1]``.
    depths : array_like, shape (k, rows, cols), float
        Depth of each layer; non-finite where the layer misses the pixel. The layers
        may come in any order. Not modified.

    Returns
    -------
    ndarray, shape (rows, cols, 4), float64
        Premultiplied RGBA.

    Notes
    -----
    Per pixel the layers that hit are sorted by increasing depth (a stable sort:
    layers at equal depth keep their given order) and combined with the over operator

    .. math:: C \leftarrow C + (1 - A)\,\alpha_j c_j, \qquad A \leftarrow A + (1 - A)\,\alpha_j

    from :math:`C = 0, A = 0`: the semi-transparent layer compositing of depth proxies
    ([1]_ §3.1, Fig. 1).

    References
    ----------
    .. [1] "Visualization by Proxy", §3.1 and §5.

    Examples
    --------
    >>> import numpy as np
    >>> colors = np.array([1.0, 0.0, 0.0]) * np.ones((2, 1, 1, 3))
    >>> colors[1] = (0.0, 0.0, 1.0)
    >>> depths = np.array([2.0, 1.0]).reshape(2, 1, 1)  # the blue layer is in front
    >>> composite_layers(colors, [0.5, 0.5], depths)[0, 0].tolist()
    [0.25, 0.0, 0.5, 0.75]
    """
    d = _as_float_array("depths", depths)
    if d.ndim != 3:
        raise ValueError(f"depths must have shape (k, rows, cols); got shape {d.shape}")
    k, rows, cols = d.shape
    c = _as_float_array("colors", colors)
    if c.shape != (k, rows, cols, 3):
        raise ValueError(f"colors must have shape (k, rows, cols, 3) = {(k, rows, cols, 3)} to match depths; "
                         f"got shape {c.shape}")
    a = _as_float_array("opacities", opacities)
    if a.shape == (k,):
        a = np.broadcast_to(a[:, None, None], d.shape)
    elif a.shape != d.shape:
        raise ValueError(f"opacities must have shape (k,) = {(k,)} or (k, rows, cols) = {d.shape}; "
                         f"got shape {a.shape}")
    if not np.all((a >= 0.0) & (a <= 1.0)):
        raise ValueError("opacities must be in [0, 1]; got values outside it (or NaN)")

    key = np.where(np.isfinite(d), d, np.inf)
    order = np.argsort(key, axis=0, kind="stable")
    key = np.take_along_axis(key, order, axis=0)
    alpha = np.take_along_axis(a, order, axis=0)
    rgb = np.take_along_axis(c, order[..., None], axis=0)
    out = np.zeros((rows, cols, 4))
    acc = np.zeros((rows, cols))
    for j in range(k):
        hit = np.isfinite(key[j])
        w = np.where(hit, (1.0 - acc) * alpha[j], 0.0)
        out[..., :3] += w[..., None] * np.where(hit[..., None], rgb[j], 0.0)
        acc += w
    out[..., 3] = acc
    return out
