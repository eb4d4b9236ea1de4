"""Lenses of the Magic Volume Lens as ray generators: ``lens.rays(camera, size) -> Rays``.

A lens changes only where rays start and where they point; the compositing kernels
never know which lens made the rays. Four lenses of Wang et al. (2005) are here:
:class:`Magnifier` (§3.1, circle, square or any shape), :class:`FeatureLens` (§3.2, the
shape is a volume feature's projection), :class:`SamplingRateLens` (§3.3) and
:class:`Fisheye` (§3.4).

The homothety model of the planar lenses
----------------------------------------
Pixel positions are continuous ``(col, row)``, row 0 at the top, pixel ``(i, j)``'s centre
at ``(i + 0.5, j + 0.5)`` (as :meth:`Camera.project`). A planar lens defines a scale
``s(p) > 0`` per pixel and a centre ``c``; ``s = 1`` is the camera's own ray, copied bit
for bit. ``E`` is the camera position, ``P0`` the point where the camera ray through
``c`` meets the *focal plane* (through ``camera.focal_point``, normal to the view).

- Perspective camera: the ray of pixel ``p`` starts at the camera position ``E`` and
  passes through the focal-plane point ``P0 + s(p) (X(p) - P0)`` (``X(p)``: where the
  camera ray of ``p`` meets the focal plane), i.e. it is the camera ray through the
  pixel position ``q(p) = c + s(p) (p - c)``. The content around ``P0`` appears
  magnified ``1/s`` times on the focal plane -- and, the rays all leaving ``E``, at
  every depth: what a camera moved to the virtual focal point ``V = P0 + (E - P0) / M``
  on the lens's centre ray would show on the focal plane, without its clipping of
  everything between ``E`` and ``V`` or its perspective blow-up of what lies near
  ``V``.
- Parallel camera: direction unchanged, origin ``O_c + s(p) (O_p - O_c)`` (``O_p``, ``O_c``:
  the camera-plane origins of ``p`` and ``c``), a lateral zoom about the centre ray,
  the same at every depth (the virtual focal point is at infinity).

``q(p)`` is the *source map*: the camera pixel whose focal-plane point the ray of ``p``
passes through. Its Jacobian gives the level of detail for anti-aliasing (the paper's
Eq. 4): ``lod(p) = max(0, log2 sigma_max(dq/dp))``, > 0 only where rays are sparser than
the camera's (the compressed transition band of a magnifier, the minified region of a
minifier).

Choices where the paper leaves room
-----------------------------------
- Magnification is a homothety of the rays' focal-plane points about ``P0``: exactly
  ``M`` there; a parallel view stays parallel (a lateral zoom) and a perspective one
  keeps its centre of projection (an angular zoom), so nothing in front of the lens is
  cut away. ``focal_distance`` (the paper's virtual focal point ``V``, placed on the
  centre ray so that a camera at ``V`` sees the focal plane as the lens shows it) and
  ``factor`` are the two ways to set it: ``M = D / (D - focal_distance)``. (We first
  cast the rays *from* ``V`` -- a camera dolly: on the engine CT at ``M = 3`` that put
  ``V`` at the volume's edge, clipped the front and blew up the nearest structure.)
- The transition band interpolates the *scale* ``s`` linearly in the distance from the
  magnification region (continuous, so no gap and no seam); for a minifier that could
  fold the band the factor is rejected.
- Arbitrary shapes (masks, polygons, projected features): the band lies *outside* the
  shape, ``transition`` pixels wide by the exact Euclidean distance between pixel
  centres; the homothety is about the shape's centroid. No fold check is made for
  them (a strongly non-convex shape with a wide band can fold).
- The sampling-rate lens takes ``f`` piecewise linear between its table samples, so the
  cumulative trapezoid is its exact integral and the inverse is solved exactly per
  table interval (a quadratic), which makes ``s(0) = F(1)/f(0)`` the true limit.
- The feature lens fills the exact projection of each voxel cube (the convex hull of
  its 8 projected corners), from the voxels on the feature's surface only (their
  projections cover the solid's); a voxel that straddles the eye plane of a
  perspective camera fills the whole image.
- The fisheye covers the whole image (equidistant, normalised to the image's corner).

References
----------
L. Wang, Y. Zhao, K. Mueller, A. Kaufman, "The Magic Volume Lens: An Interactive
Focus+Context Technique for Volume Rendering", Proc. IEEE Visualization 2005,
pp. 367-374.
"""
from __future__ import annotations

import abc
import math
from dataclasses import dataclass, field, fields
from typing import NamedTuple, Optional

import numpy as np

from .._validate import as_choice, as_int, as_real, as_size, as_vector
from ._kernels import (
    _apply_homothety, _fill_lod, _fill_projected_cubes, _fisheye_grid, _fisheye_points, _project_cubes,
    _invert_rates, _magnifier_scale, _mask_scale, _numeric_sigma, _sampling_scale, _squared_edt,
)
from .camera import Camera, Rays

__all__ = ["Lens", "Magnifier", "FeatureLens", "SamplingRateLens", "Fisheye", "distance_transform"]

_SHAPE_NAMES = ("circle", "square")
# Named sampling rates f(x) = 1 + (factor - 1) * (1 - x)**n.
_RATE_POWERS = {"linear": 1, "quadratic": 2, "cubic": 3}
# Surface voxels projected per Camera.project call (bounds the corner arrays to ~12 MB).
_VOXEL_CHUNK = 1 << 16


# -- base classes ---------------------------------------------------------------------------
class Lens(abc.ABC):
    """A ray generator that replaces the camera's rays: ``lens.rays(camera, size) -> Rays``.

    Subclasses implement :meth:`rays`; the renderer only sees the :class:`Rays`.
    """

    @abc.abstractmethod
    def rays(self, camera, size):
        """One ray per pixel for ``camera`` at ``size`` (int or (width, height)).

        Returns
        -------
        Rays
            Ray of pixel (row, col) at index ``row * width + col``.
        """


def _short(value):
    """The repr of one field: arrays are summarised, not printed."""
    if isinstance(value, np.ndarray):
        if value.dtype == np.bool_:
            return f"<bool array {value.shape}, {int(np.count_nonzero(value))} True>"
        return f"<polygon of {len(value)} vertices>"
    if callable(value):
        return getattr(value, "__qualname__", None) or repr(value)
    return repr(value)


def _key(value):
    """A hashable, comparable stand-in for one field (arrays by content)."""
    if isinstance(value, np.ndarray):
        return (value.dtype.str, value.shape, value.tobytes())
    return value


class _Fields:
    """repr, == and hash of the lens dataclasses, with array fields by content."""

    def __repr__(self):
        parts = (f"{f.name}={_short(getattr(self, f.name))}" for f in fields(self) if f.repr)
        return f"{type(self).__name__}({', '.join(parts)})"

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        return all(_key(getattr(self, f.name)) == _key(getattr(other, f.name)) for f in fields(self) if f.compare)

    def __hash__(self):
        return hash(tuple(_key(getattr(self, f.name)) for f in fields(self) if f.compare))

    def _set(self, **values):
        for name, value in values.items():
            object.__setattr__(self, name, value)


class _Window(NamedTuple):
    """A planar lens's scale on the part of the image it can change (s = 1 elsewhere)."""

    rows: slice
    cols: slice
    s: np.ndarray         # (rows, cols) float64
    sigma: np.ndarray     # sigma_max(dq/dp) there, or empty (0, 0) when not asked for
    center: np.ndarray    # (col, row), pixels
    magnification: float  # M = 1 / s in the magnification region


def _as_camera(camera):
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a pv_hdrvol.Camera; got {type(camera).__name__}")
    return camera


def _plane_offsets(camera, w, h, col, row):
    """Camera-frame offsets (x, y) of continuous pixel positions, as Camera.rays makes them.

    Perspective: tangents (the ray is fwd + x right + y up); parallel: world units.
    """
    half_h = camera.parallel_scale if camera.parallel_projection else math.tan(math.radians(camera.view_angle) / 2)
    half_w = half_h * w / h
    return (col * (2.0 / w) - 1.0) * half_w, (1.0 - row * (2.0 / h)) * half_h


def _centre_point(camera, w, h, center):
    """P0 (perspective: the centre ray on the focal plane) or O_c (parallel: on the camera plane)."""
    right, up, fwd = camera.basis()
    x, y = _plane_offsets(camera, w, h, float(center[0]), float(center[1]))
    pos = np.asarray(camera.position, dtype=np.float64)
    if camera.parallel_projection:
        return pos + x * right + y * up
    return pos + camera.distance * (fwd + x * right + y * up)


def _factor_from_focal_distance(camera, w, h, center, focal_distance):
    """M = D / (D - focal_distance), D = |E - P0|, for a perspective camera."""
    if camera.parallel_projection:
        raise ValueError("focal_distance needs a perspective camera: a parallel camera's lens rays stay "
                         "parallel (its virtual focal point is at infinity); give factor instead")
    d = float(np.linalg.norm(_centre_point(camera, w, h, center) - np.asarray(camera.position)))
    if not focal_distance < d:
        raise ValueError(f"focal_distance must be < D = {d:.6g}, the distance from the camera position to the "
                         f"focal plane along the lens's centre ray; got focal_distance={focal_distance!r}")
    return d / (d - focal_distance)


# -- kernels: arrays in, arrays filled ---------------------------------------------------------


def _radial_window(center, radius, w, h, what):
    """Rows and columns of the pixels a radial lens can change (its bounding box plus a
    margin), after checking that the lens meets the image."""
    cx, cy = float(center[0]), float(center[1])
    if cx + radius <= 0 or cx - radius >= w or cy + radius <= 0 or cy - radius >= h:
        raise ValueError(f"{what} at center ({cx:g}, {cy:g}) with radius {radius:g} lies entirely outside "
                         f"the {w}x{h} image (pixels [0, {w}] x [0, {h}])")
    c0, c1 = max(0, math.floor(cx - radius) - 1), min(w, math.ceil(cx + radius) + 1)
    r0, r1 = max(0, math.floor(cy - radius) - 1), min(h, math.ceil(cy + radius) + 1)
    return slice(r0, r1), slice(c0, c1)


def _empty_window(rows, cols, jacobian):
    shape = (rows.stop - rows.start, cols.stop - cols.start)
    return np.empty(shape), (np.empty(shape) if jacobian else np.empty((0, 0)))


class _PlanarLens(Lens):
    """Planar lenses: a scale s(p) about a centre c, applied as a homothety of the ray starts."""

    @abc.abstractmethod
    def _window(self, camera, w, h, jacobian):
        """The scale (and, if ``jacobian``, sigma_max of dq/dp) where the lens can act: a _Window."""

    def scale(self, camera, size):
        """The scale map ``s`` and the lens centre.

        Returns
        -------
        s : ndarray, shape (height, width), float64
            1 where the rays are the camera's, ``1/M`` in a magnification region.
        center : (float, float)
            ``(col, row)`` in pixels.
        """
        camera = _as_camera(camera)
        w, h = as_size(size)
        win = self._window(camera, w, h, False)
        s = np.ones((h, w))
        s[win.rows, win.cols] = win.s
        return s, (float(win.center[0]), float(win.center[1]))

    def source_map(self, camera, size):
        """``q(p) = c + s(p) (p - c)`` for every pixel centre ``p``: shape (height, width, 2), (col, row).

        The ray of pixel ``p`` passes through the focal-plane point of the camera's ray
        through ``q(p)``; ``q = p`` exactly where ``s = 1``.
        """
        w, h = as_size(size)
        s, (cx, cy) = self.scale(camera, size)
        x = np.broadcast_to((np.arange(w) + 0.5)[None, :], (h, w))
        y = np.broadcast_to((np.arange(h) + 0.5)[:, None], (h, w))
        same = s == 1.0
        q = np.empty((h, w, 2))
        q[..., 0] = np.where(same, x, cx + s * (x - cx))
        q[..., 1] = np.where(same, y, cy + s * (y - cy))
        return q

    def magnification(self, camera, size):
        """The magnification ``M`` of the lens's magnification region (at its centre)."""
        w, h = as_size(size)
        return float(self._window(_as_camera(camera), w, h, False).magnification)

    def focal_point(self, camera, size):
        """The virtual focal point ``V = P0 + (E - P0) / M`` (world, shape (3,)), on the
        lens's centre ray: a camera moved there would show the focal plane as the
        magnification region does. Perspective cameras only."""
        camera = _as_camera(camera)
        if camera.parallel_projection:
            raise ValueError("a parallel camera has no focal point for a lens: its lens rays stay parallel "
                             "(the virtual focal point is at infinity)")
        w, h = as_size(size)
        win = self._window(camera, w, h, False)
        p0 = _centre_point(camera, w, h, win.center)
        return p0 + (np.asarray(camera.position) - p0) / win.magnification

    def rays(self, camera, size):
        """The camera's rays re-aimed by the homothety ``s(p)`` (see the module docstring).

        Parameters
        ----------
        camera : Camera
        size : int or (width, height)

        Returns
        -------
        Rays
            Pixels with ``s == 1`` carry the camera's rays bit for bit. ``lod`` is None
            when ``antialias`` is off or no ray is sparser than the camera's.
        """
        camera = _as_camera(camera)
        w, h = as_size(size)
        win = self._window(camera, w, h, self.antialias)
        base = camera.rays((w, h))
        fwd = camera.basis()[2]
        if camera.parallel_projection:
            anchor = _centre_point(camera, w, h, win.center)  # O_c
        else:
            x, y = _plane_offsets(camera, w, h, float(win.center[0]), float(win.center[1]))
            right, up, _ = camera.basis()
            anchor = fwd + x * right + y * up  # u_c: the centre ray's point at unit depth
        moved = _apply_homothety(base.origins, base.directions, w, win.rows.start, win.cols.start, win.s,
                                 np.ascontiguousarray(anchor, dtype=np.float64), np.ascontiguousarray(fwd),
                                 camera.parallel_projection)
        lod = None
        if moved and self.antialias:
            lod = np.zeros(w * h)
            if not _fill_lod(win.sigma, win.rows.start, win.cols.start, w, lod):
                lod = None
        return Rays(base.origins, base.directions, w, h, lod)


# -- shapes: polygon rasterisation and the exact Euclidean distance transform -----------------
def _rasterize_polygon(vertices, w, h):
    """Pixels whose centre is inside the polygon (even-odd rule), shape (h, w) bool."""
    x0, y0 = vertices[:, 0], vertices[:, 1]
    x1, y1 = np.roll(x0, -1), np.roll(y0, -1)
    yc = np.arange(h) + 0.5
    # half-open rule: an edge crosses the scanline when exactly one end is at or below it
    edge, row = np.nonzero((y0[:, None] <= yc[None, :]) != (y1[:, None] <= yc[None, :]))
    xc = x0[edge] + (yc[row] - y0[edge]) * (x1[edge] - x0[edge]) / (y1[edge] - y0[edge])
    # every pixel whose centre lies right of a crossing toggles: first one is floor(xc - 0.5) + 1
    first = np.clip(np.floor(xc - 0.5) + 1.0, 0, w).astype(np.intp)
    toggles = np.zeros((h, w + 1), dtype=np.int32)
    np.add.at(toggles, (row, first), 1)
    return (np.cumsum(toggles[:, :w], axis=1) & 1).astype(bool)


def distance_transform(mask):
    """Exact Euclidean distance from each pixel centre to the nearest True pixel centre.

    Parameters
    ----------
    mask : ndarray, shape (height, width), bool

    Returns
    -------
    ndarray, shape (height, width), float64
        In pixels; 0 on the mask, ``inf`` everywhere if the mask is empty. Equals
        ``scipy.ndimage.distance_transform_edt(~mask)``.

    Notes
    -----
    Felzenszwalb & Huttenlocher's lower envelope of parabolas, along columns then
    rows, O(pixels); squared distances are integers, so the result is exact.

    References
    ----------
    P. F. Felzenszwalb, D. P. Huttenlocher, "Distance Transforms of Sampled Functions",
    Theory of Computing 8 (2012), 415-428.

    Examples
    --------
    >>> m = np.zeros((3, 4), bool); m[0, 0] = True
    >>> round(float(distance_transform(m)[2, 3]) ** 2, 12)
    13.0
    """
    m = np.asarray(mask)
    if m.dtype != np.bool_ or m.ndim != 2:
        raise TypeError(f"mask must be a 2-D bool array; got {m.dtype} with shape {m.shape}")
    return np.sqrt(_squared_edt(np.ascontiguousarray(m)))


def _mask_window(mask, transition, magnification, center, jacobian):
    """Scale over the mask's bounding box grown by the band (and a margin): 1/M on the
    mask, the linear band in the exact distance to it, 1 beyond."""
    h, w = mask.shape
    rows_any = np.flatnonzero(mask.any(axis=1))
    cols_any = np.flatnonzero(mask.any(axis=0))
    grow = int(math.ceil(transition)) + 2
    rows = slice(max(0, rows_any[0] - grow), min(h, rows_any[-1] + 1 + grow))
    cols = slice(max(0, cols_any[0] - grow), min(w, cols_any[-1] + 1 + grow))
    # the nearest mask pixel of any pixel in the window is inside it: exact distances
    sq_dist = _squared_edt(np.ascontiguousarray(mask[rows, cols]))
    s, sigma = _empty_window(rows, cols, jacobian)
    _mask_scale(sq_dist, transition, 1.0 / magnification, s)
    if jacobian:
        _numeric_sigma(s, rows.start, cols.start, center[0], center[1], sigma)
    return _Window(rows, cols, s, sigma, center, magnification)


def _centroid(mask):
    j, i = np.nonzero(mask)
    return np.array([i.mean() + 0.5, j.mean() + 0.5])


def _as_bool(name, value):
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool; got {value!r}")
    return bool(value)


def _factor_or_focal(factor, focal_distance, default):
    """Validate the mutually exclusive factor / focal_distance pair."""
    if factor is not None and focal_distance is not None:
        raise ValueError(f"give factor or focal_distance, not both (factor is derived from focal_distance); "
                         f"got factor={factor!r}, focal_distance={focal_distance!r}")
    if focal_distance is not None:
        return None, as_real("focal_distance", focal_distance, low=0)
    return as_real("factor", default if factor is None else factor, low=0, low_open=True), None


# -- magnifier ----------------------------------------------------------------------------------
@dataclass(frozen=True, init=False, repr=False, eq=False)
class Magnifier(_Fields, _PlanarLens):
    """A magnifying (or minifying) lens of constant magnification with a transition band.

    Parameters
    ----------
    center : (col, row), pixels
        Lens centre; for a mask or polygon shape, default the shape's centroid.
    radius : float, pixels
        Outer radius of a circle (or half-side of a square) lens: magnification region
        plus transition band. Must be None for a mask or polygon shape.
    transition : float, pixels
        Width of the transition band. Circle/square: ``0 <= transition < radius``,
        default ``radius / 3``; the magnification region has radius ``radius - transition``.
        Mask/polygon: ``> 0``, default 16, the band lies outside the shape.
    factor : float
        Magnification ``M > 0`` (default 2; ``M < 1`` minifies). Excludes ``focal_distance``;
        stored resolved, so ``dataclasses.replace(lens, factor=None, focal_distance=...)``
        switches from one to the other.
    shape : "circle", "square", bool ndarray (height, width), or ndarray (k, 2)
        Euclidean or L-infinity distance to ``center``; a mask (True: magnification
        region) of the render size; or a polygon of ``k >= 3`` (col, row) vertices,
        rasterised at the render size (pixel centres inside, even-odd rule).
    focal_distance : float, world units
        Perspective cameras: distance from the camera position to the virtual focal point
        ``V`` along the centre ray, ``0 <= focal_distance < D``; then ``M = D / (D - focal_distance)``.
    antialias : bool
        Give rays a level of detail where the lens makes them sparser than the camera's.

    Notes
    -----
    With ``d`` the distance of a pixel centre from the magnification region (circle:
    ``r - (radius - transition)``, ``r = |p - c|``; square: the same with the L-infinity
    norm; mask: the exact Euclidean distance to the nearest mask pixel) and
    ``T = transition`` (Eqs. 1-3 of the paper, as a scale of the ray starts)::

        s(p) = 1/M                       d <= 0          (magnification region)
        s(p) = 1/M + (1 - 1/M) d / T     0 < d < T       (transition band)
        s(p) = 1                         d >= T          (the camera's own rays)

    Perspective rays start at ``A(p) = P0 + s(p) (E - P0)`` in the camera's direction;
    parallel rays at ``O_c + s(p) (O_p - O_c)``. The focal plane shows the content around
    ``P0`` magnified ``M`` times: a dolly toward ``P0``, so what lies between the camera and
    ``A(p)`` is not sampled inside the lens (a magnifier held at ``V``). With
    ``focal_distance``, ``M = D / (D - focal_distance)``, ``D = |E - P0|``.

    The source radius ``rho(r) = s(r) r`` must increase: ``drho/dr = s + r s' > 0``. For
    ``M >= 1`` it always does; a minifier (circle, square) needs
    ``M > radius / (radius + transition)``. Level of detail: ``lod = max(0, log2(max(s,
    s + r s')))`` (circle), the Jacobian's largest singular value in general.

    References
    ----------
    L. Wang, Y. Zhao, K. Mueller, A. Kaufman, "The Magic Volume Lens", IEEE Visualization
    2005, §3.1.

    Examples
    --------
    >>> cam = Camera((0, 0, 10), (0, 0, 0), (0, 1, 0))
    >>> plain = cam.rays((64, 48))
    >>> rays = Magnifier((32.5, 24.5), radius=12, factor=1.0).rays(cam, (64, 48))
    >>> np.array_equal(rays.origins, plain.origins), rays.lod is None
    (True, True)
    >>> lens = Magnifier((32, 24), radius=12, focal_distance=5.0)  # centred on the view axis
    >>> lens.magnification(cam, (64, 48))
    2.0
    >>> lens.focal_point(cam, (64, 48)).round(12).tolist()
    [0.0, 0.0, 5.0]
    """

    center: Optional[tuple] = None
    radius: Optional[float] = None
    transition: Optional[float] = None
    factor: Optional[float] = None
    shape: object = "circle"
    focal_distance: Optional[float] = None
    antialias: bool = True

    def __init__(self, center=None, radius=None, transition=None, factor=None, *, shape="circle",
                 focal_distance=None, antialias=True):
        factor, focal_distance = _factor_or_focal(factor, focal_distance, 2.0)
        if isinstance(shape, str):
            if shape not in _SHAPE_NAMES:
                raise ValueError(f"shape must be one of {list(_SHAPE_NAMES)}, a bool mask (height, width) or a "
                                 f"(k, 2) polygon; got {shape!r}")
            if center is None:
                raise ValueError(f"center is required for shape {shape!r}")
            if radius is None:
                raise ValueError(f"radius is required for shape {shape!r}")
            radius = as_real("radius", radius, low=0, low_open=True)
            transition = radius / 3.0 if transition is None else as_real("transition", transition, low=0)
            if not transition < radius:
                raise ValueError(f"transition must be < radius; got transition={transition!r}, radius={radius!r}")
            if factor is not None and factor < 1.0 and not factor > radius / (radius + transition):
                raise ValueError(
                    f"factor {factor!r} folds the transition band: with radius {radius!r} and transition "
                    f"{transition!r} a minifier needs factor > radius / (radius + transition) = "
                    f"{radius / (radius + transition):.6g}, so that drho/dr = s + r s' > 0 across the band")
        else:
            shape = self._as_region(shape)
            if radius is not None:
                raise ValueError(f"radius must be None for a mask or polygon shape (the band is `transition` "
                                 f"pixels outside the shape); got radius={radius!r}")
            transition = as_real("transition", 16.0 if transition is None else transition, low=0, low_open=True)
        if center is not None:
            center = tuple(as_vector("center", center, 2).tolist())
        self._set(center=center, radius=radius, transition=transition, factor=factor, shape=shape,
                  focal_distance=focal_distance, antialias=_as_bool("antialias", antialias))

    @staticmethod
    def _as_region(shape):
        arr = np.asarray(shape)
        if arr.dtype == np.bool_:
            if arr.ndim != 2:
                raise ValueError(f"a mask shape must be 2-D (height, width); got shape {arr.shape}")
            if not arr.any():
                raise ValueError(f"the mask is empty: no True pixel in a {arr.shape} mask")
            region = arr.copy()  # the caller's array is never kept, so never changed
        else:
            if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)) \
                    or arr.ndim != 2 or arr.shape[1] != 2:
                raise ValueError(f"shape must be 'circle', 'square', a bool mask (height, width) or a (k, 2) "
                                 f"polygon of (col, row) vertices; got an array of {arr.dtype} {arr.shape}")
            if arr.shape[0] < 3:
                raise ValueError(f"a polygon must have at least 3 vertices; got {arr.shape[0]}")
            region = arr.astype(np.float64)
            if not np.all(np.isfinite(region)):
                raise ValueError("polygon vertices must be finite")
        region.setflags(write=False)
        return region

    def _window(self, camera, w, h, jacobian):
        if isinstance(self.shape, str):
            center = np.array(self.center)
            m = self.factor if self.focal_distance is None else \
                _factor_from_focal_distance(camera, w, h, center, self.focal_distance)
            rows, cols = _radial_window(center, self.radius, w, h, "the lens")
            s, sigma = _empty_window(rows, cols, jacobian)
            _magnifier_scale(rows.start, cols.start, center[0], center[1], self.shape == "square", self.radius,
                             self.transition, 1.0 / m, s, sigma)
            return _Window(rows, cols, s, sigma, center, m)
        if self.shape.dtype == np.bool_:
            if self.shape.shape != (h, w):
                raise ValueError(f"mask shape {self.shape.shape} does not match the image: size ({w}, {h}) "
                                 f"needs a mask of shape (height, width) = {(h, w)}")
            mask = self.shape
        else:
            mask = _rasterize_polygon(self.shape, w, h)
            if not mask.any():
                raise ValueError(f"the polygon covers no pixel centre of the {w}x{h} image")
        center = _centroid(mask) if self.center is None else np.array(self.center)
        m = self.factor if self.focal_distance is None else \
            _factor_from_focal_distance(camera, w, h, center, self.focal_distance)
        return _mask_window(mask, self.transition, m, center, jacobian)


# -- feature lens -------------------------------------------------------------------------------
def _is_volume(obj):
    return all(hasattr(obj, a) for a in ("values", "origin", "spacing"))


@dataclass(frozen=True, init=False, repr=False, eq=False)
class FeatureLens(_Fields, _PlanarLens):
    """A magnifier whose shape is the projection of a volume feature (§3.2 of the paper).

    Parameters
    ----------
    feature : ndarray, shape (nz, ny, nx), bool
        The feature's voxels; voxel ``(k, j, i)`` is the cube of side ``spacing`` centred
        at ``origin + (i, j, k) * spacing``. Copied; see :meth:`from_labels` and
        :meth:`from_range` to make it from a volume.
    origin, spacing : sequence of 3 floats, world units
        Grid geometry (x, y, z), as :class:`pv_hdrvol.GridVolume`; spacing > 0.
    transition : float, pixels
        Width of the band outside the projected shape (> 0, default 16).
    factor, focal_distance, antialias
        As :class:`Magnifier` (default ``factor`` 2).

    Notes
    -----
    For each view the shape is the set of pixels whose centre lies in the projection of
    a feature voxel's cube (exact: the convex hull of its 8 projected corners). Only
    surface voxels (a 6-neighbour missing) are projected: any line through the solid
    crosses a surface voxel, so the union of their projections is the solid's. Voxels
    wholly behind a perspective camera's eye plane are ignored, and a voxel that
    straddles it fills the whole image (its projection is unbounded). Then the lens is
    a :class:`Magnifier` with that mask, centred at its centroid.

    References
    ----------
    L. Wang, Y. Zhao, K. Mueller, A. Kaufman, "The Magic Volume Lens", IEEE Visualization
    2005, §3.2.

    Examples
    --------
    A one-voxel feature (a unit cube at the origin) seen along -z by a parallel camera
    4 units high covers the centre 4x4 pixels of a 16x16 image:

    >>> cam = Camera((0, 0, 10), (0, 0, 0), (0, 1, 0), parallel_projection=True, parallel_scale=2)
    >>> lens = FeatureLens(np.ones((1, 1, 1), bool), origin=(0, 0, 0), spacing=(1, 1, 1))
    >>> s, center = lens.scale(cam, 16)
    >>> np.argwhere(s == 0.5)[[0, -1]].tolist(), center
    ([[6, 6], [9, 9]], (8.0, 8.0))
    """

    feature: np.ndarray = None
    origin: tuple = (0.0, 0.0, 0.0)
    spacing: tuple = (1.0, 1.0, 1.0)
    transition: float = 16.0
    factor: Optional[float] = None
    focal_distance: Optional[float] = None
    antialias: bool = True
    _surface: np.ndarray = field(default=None, init=False, repr=False, compare=False)

    def __init__(self, feature, *, origin=(0.0, 0.0, 0.0), spacing=(1.0, 1.0, 1.0), transition=16.0, factor=None,
                 focal_distance=None, antialias=True):
        factor, focal_distance = _factor_or_focal(factor, focal_distance, 2.0)
        arr = np.asarray(feature)
        if arr.dtype != np.bool_ or arr.ndim != 3:
            raise TypeError(f"feature must be a 3-D bool array (z, y, x); got {arr.dtype} with shape {arr.shape} "
                            f"(FeatureLens.from_labels / from_range make one from a volume)")
        if not arr.any():
            raise ValueError(f"the feature is empty: no True voxel in a {arr.shape} array")
        arr = arr.copy()
        arr.setflags(write=False)
        spacing = as_vector("spacing", spacing)
        if np.any(spacing <= 0):
            raise ValueError(f"spacing must be > 0 on every axis; got {tuple(spacing.tolist())}")
        origin = as_vector("origin", origin)
        pad = np.pad(arr, 1)
        inner = arr.copy()
        c, lo, hi = slice(1, -1), slice(None, -2), slice(2, None)
        for nb in (pad[lo, c, c], pad[hi, c, c], pad[c, lo, c], pad[c, hi, c], pad[c, c, lo], pad[c, c, hi]):
            inner &= nb  # a voxel with all six face neighbours is hidden inside the solid
        surface = np.argwhere(arr & ~inner)[:, ::-1].astype(np.float64)  # (i, j, k)
        self._set(feature=arr, origin=tuple(origin.tolist()), spacing=tuple(spacing.tolist()),
                  transition=as_real("transition", transition, low=0, low_open=True), factor=factor,
                  focal_distance=focal_distance, antialias=_as_bool("antialias", antialias), _surface=surface)

    @classmethod
    def from_labels(cls, labels, label, *, origin=None, spacing=None, **options):
        """The voxels of ``labels`` equal to ``label`` (a value or a sequence of values).

        ``labels`` is a :class:`pv_hdrvol.GridVolume` (geometry from it) or a 3-D integer
        array (z, y, x) with ``origin``/``spacing`` (default 0 and 1). ``options`` go to
        the constructor.
        """
        values, origin, spacing = cls._grid("labels", labels, origin, spacing)
        wanted = np.atleast_1d(np.asarray(label))
        mask = np.isin(values, wanted)
        if not mask.any():
            raise ValueError(f"no voxel has label {label!r} (labels range {values.min()!r} .. {values.max()!r})")
        return cls(mask, origin=origin, spacing=spacing, **options)

    @classmethod
    def from_range(cls, volume, lo, hi, *, origin=None, spacing=None, **options):
        """The voxels with ``lo <= value <= hi`` (NaN never), of a GridVolume or 3-D array."""
        values, origin, spacing = cls._grid("volume", volume, origin, spacing)
        lo = as_real("lo", lo)
        hi = as_real("hi", hi)
        if lo > hi:
            raise ValueError(f"lo must be <= hi; got lo={lo!r}, hi={hi!r}")
        mask = (values >= lo) & (values <= hi)
        if not mask.any():
            raise ValueError(f"no voxel lies in [{lo!r}, {hi!r}]")
        return cls(mask, origin=origin, spacing=spacing, **options)

    @staticmethod
    def _grid(name, data, origin, spacing):
        if _is_volume(data):
            if origin is not None or spacing is not None:
                raise ValueError(f"origin and spacing come from the {name} volume; do not give them too")
            return np.asarray(data.values), data.origin, data.spacing
        values = np.asarray(data)
        if values.ndim != 3:
            raise ValueError(f"{name} must be a GridVolume or a 3-D array (z, y, x); got shape {values.shape}")
        return (values, (0.0, 0.0, 0.0) if origin is None else origin,
                (1.0, 1.0, 1.0) if spacing is None else spacing)

    def projected_mask(self, camera, size):
        """Pixels whose centre lies in the feature's projection: shape (height, width), bool."""
        camera = _as_camera(camera)
        w, h = as_size(size)
        mask = np.zeros((h, w), dtype=bool)
        right, up, fwd = camera.basis()
        pos = np.asarray(camera.position, dtype=np.float64)
        spacing, origin = np.asarray(self.spacing, np.float64), np.asarray(self.origin, np.float64)
        half_h = camera.parallel_scale if camera.parallel_projection else math.tan(math.radians(camera.view_angle) / 2)
        for start in range(0, len(self._surface), _VOXEL_CHUNK):
            cells = np.ascontiguousarray(self._surface[start:start + _VOXEL_CHUNK])
            pts = np.empty((len(cells), 8, 2))
            flags = np.empty(len(cells), dtype=np.int8)
            _project_cubes(cells, origin, spacing, pos, right, up, fwd, camera.parallel_projection, half_h,
                           float(w), float(h), pts, flags)
            _fill_projected_cubes(pts, flags, mask)
        return mask

    def _window(self, camera, w, h, jacobian):
        mask = self.projected_mask(camera, (w, h))
        if not mask.any():
            raise ValueError(f"the feature projects outside the {w}x{h} image (no pixel centre is covered)")
        center = _centroid(mask)
        m = self.factor if self.focal_distance is None else \
            _factor_from_focal_distance(camera, w, h, center, self.focal_distance)
        return _mask_window(mask, self.transition, m, center, jacobian)


# -- sampling-rate lens -------------------------------------------------------------------------
class _RateTable(NamedTuple):
    f: np.ndarray      # (n + 1,) samples of f on x = k / n
    cum: np.ndarray    # (n + 1,) cumulative trapezoid: F(x_k)
    start: np.ndarray  # (n + 1,) the last k with cum[k] <= (m / n) F(1), so inverting needs no long search
    identity: bool     # f is constant by construction: s = 1 exactly


def _rate_table(rate, factor, n):
    x = np.linspace(0.0, 1.0, n + 1)
    if isinstance(rate, str):
        f = 1.0 + (factor - 1.0) * (1.0 - x) ** _RATE_POWERS[rate]
        identity = factor == 1.0
    else:
        f = np.asarray(rate(x), dtype=np.float64)
        try:
            f = np.broadcast_to(f, x.shape).copy()
        except ValueError:
            raise ValueError(f"rate(x) must return one value per x (shape {x.shape}); got shape {f.shape}") from None
        bad = ~np.isfinite(f)
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(f"rate(x) must return finite values on [0, 1]; got f({x[k]:g}) = {float(f[k])!r}")
        if np.any(f <= 0):
            k = int(np.argmax(f <= 0))
            raise ValueError(f"rate(x) must return values > 0 on [0, 1]; got f({x[k]:g}) = {float(f[k])!r}")
        identity = False
    cum = np.empty(n + 1)
    cum[0] = 0.0
    np.cumsum((f[1:] + f[:-1]) * (0.5 / n), out=cum[1:])
    start = np.clip(np.searchsorted(cum, x * cum[-1], side="right") - 1, 0, n - 1).astype(np.int64)
    for a in (f, cum, start):
        a.setflags(write=False)
    return _RateTable(f, cum, start, identity)


@dataclass(frozen=True, init=False, repr=False, eq=False)
class SamplingRateLens(_Fields, _PlanarLens):
    """A circular lens whose ray density follows a sampling-rate function (§3.3 of the paper).

    Parameters
    ----------
    center : (col, row), pixels
    radius : float, pixels
        The lens radius; the magnified centre and the compressed rim fill it exactly.
    rate : {"cubic", "quadratic", "linear"} or callable
        ``f(x)``, x the normalised *source* radius in [0, 1]: relative ray density.
        Named: ``f(x) = 1 + (factor - 1) (1 - x)**n`` with n = 3, 2, 1. A callable takes an
        array of x and returns finite values > 0 (one per x, or a scalar).
    factor : float
        Density ratio ``f(0) / f(1)`` of the named rates (default 4); not for callables.
    table_size : int
        Number of table intervals, in [16, 2**20].
    focal_distance : float, world units
        Perspective cameras, named rates: sets the centre magnification
        ``M = D / (D - focal_distance)`` (``factor`` is then derived); ``M < n + 1``.
    antialias : bool

    Notes
    -----
    With ``F(x) = integral_0^x f`` (Eqs. 5-7 as implemented), a source radius ``rho``
    appears at ``r(rho) = radius F(rho / radius) / F(1)``, so ``dr/drho = f / F(1)``: the
    centre is magnified ``f(0) / F(1)`` times and ``r(radius) = radius``. F is tabulated on
    ``table_size + 1`` samples by the cumulative trapezoid, which is the exact integral of
    the piecewise-linear interpolant of f; ``rho(r)`` solves that interpolant's quadratic
    in each table interval exactly, so ``rho`` is continuous and strictly increasing and
    ``s = rho(r) / r`` has the limit ``F(1) / f(0)`` at ``r = 0``. ``s = 1`` from
    ``r = radius`` on. The rays follow the module's homothety model; the level of detail
    is ``max(0, log2(max(s, drho/dr)))``, ``drho/dr = F(1) / f``.

    A named rate gives the centre magnification ``M = k / (1 + (k - 1) / (n + 1))`` for
    ``factor = k``, hence ``k = M (1 - 1/(n+1)) / (1 - M / (n+1))`` from a focal distance.

    References
    ----------
    L. Wang, Y. Zhao, K. Mueller, A. Kaufman, "The Magic Volume Lens", IEEE Visualization
    2005, §3.3.

    Examples
    --------
    >>> lens = SamplingRateLens((32, 32), 20, rate="linear", factor=3.0)
    >>> float(lens.source_radius(20.0)), lens.magnification(Camera(), 64)
    (20.0, 1.5)
    """

    center: tuple = (0.0, 0.0)
    radius: float = 1.0
    rate: object = "cubic"
    factor: Optional[float] = None
    table_size: int = 4096
    focal_distance: Optional[float] = None
    antialias: bool = True
    _table: _RateTable = field(default=None, init=False, repr=False, compare=False)

    def __init__(self, center, radius, *, rate="cubic", factor=None, table_size=4096, focal_distance=None,
                 antialias=True):
        center = tuple(as_vector("center", center, 2).tolist())
        radius = as_real("radius", radius, low=0, low_open=True)
        table_size = as_int("table_size", table_size, low=16, high=2**20)
        if isinstance(rate, str):
            as_choice("rate", rate, tuple(_RATE_POWERS))
            factor, focal_distance = _factor_or_focal(factor, focal_distance, 4.0)
        elif callable(rate):
            if factor is not None:
                raise ValueError(f"factor applies to the named rates only; a callable rate sets the density "
                                 f"itself; got factor={factor!r}")
            if focal_distance is not None:
                raise ValueError("focal_distance needs a named rate (it derives the factor); a callable rate fixes "
                                 "the centre magnification f(0) / F(1) itself")
        else:
            raise TypeError(f"rate must be one of {list(_RATE_POWERS)} or a callable f(x); got {rate!r}")
        table = None if focal_distance is not None else _rate_table(rate, factor, table_size)
        self._set(center=center, radius=radius, rate=rate, factor=factor, table_size=table_size,
                  focal_distance=focal_distance, antialias=_as_bool("antialias", antialias), _table=table)

    def _table_for(self, camera, w, h):
        if self.focal_distance is None:
            return self._table
        m = _factor_from_focal_distance(camera, w, h, self.center, self.focal_distance)
        # the tabulated integral of g = (1 - x)**n (about 1 / (n + 1)), so that f(0) / F(1) is M exactly
        g = _rate_table(self.rate, 2.0, self.table_size).cum[-1] - 1.0
        if not m * g < 1.0:
            raise ValueError(f"focal_distance={self.focal_distance!r} asks for a centre magnification "
                             f"{m:.6g}; the {self.rate} rate reaches only magnifications < {1 / g:.6g}")
        return _rate_table(self.rate, m * (1.0 - g) / (1.0 - m * g), self.table_size)

    def source_radius(self, r, camera=None, size=None):
        """Source radius ``rho(r)`` (pixels) of output radii ``r`` (pixels); ``r >= radius`` is kept.

        ``camera`` and ``size`` are needed only with ``focal_distance``.
        """
        r = np.asarray(r, dtype=np.float64)
        if self.focal_distance is None:
            table = self._table
        else:
            w, h = as_size(size)
            table = self._table_for(_as_camera(camera), w, h)
        if table.identity:
            return r.copy()
        u = np.ascontiguousarray(np.clip(r, 0.0, self.radius).reshape(-1)) / self.radius
        x = np.empty_like(u)
        _invert_rates(u, table.f, table.cum, table.start, x)
        return np.where(r < self.radius, x.reshape(r.shape) * self.radius, r)

    def _window(self, camera, w, h, jacobian):
        center = np.array(self.center)
        table = self._table_for(camera, w, h)
        rows, cols = _radial_window(center, self.radius, w, h, "the lens")
        s, sigma = _empty_window(rows, cols, jacobian)
        if table.identity:
            s[:] = 1.0
            sigma[:] = 1.0
        else:
            _sampling_scale(rows.start, cols.start, center[0], center[1], self.radius, table.f, table.cum,
                            table.start, s, sigma)
        return _Window(rows, cols, s, sigma, center, float(table.f[0] / table.cum[-1]))


# -- fisheye ----------------------------------------------------------------------------------


@dataclass(frozen=True, init=False, repr=False, eq=False)
class Fisheye(_Fields, Lens):
    """An equidistant (angular) fisheye over the whole image (§3.4 of the paper).

    Parameters
    ----------
    fov_degrees : float
        Full field of view across the image diagonal, in (0, 360]; 360 makes the image
        corners look straight backwards.
    antialias : bool
        Give the rays a level of detail when they are sparser than the camera's.

    Notes
    -----
    A position ``p`` at distance ``r`` (pixels) from the image centre looks at angle
    ``theta = (r / r_corner) fov / 2`` from the view direction, ``r_corner`` the image's
    half-diagonal, at azimuth the angle of ``p - centre`` in the image plane (right =
    camera right, up = camera up; rows grow downward). So the corner *point* (0, 0) is
    at exactly ``fov / 2`` and a corner *pixel centre* slightly less. All rays start at
    ``camera.position``, for parallel cameras too, so a camera inside the volume (the
    paper's virtual colonoscopy) sees all around it.

    Neighbouring rays are ``fov / (2 r_corner)`` radians apart radially and
    ``sin(theta) / r`` (smaller) tangentially, so the level of detail is uniform:
    ``lod = max(0, log2((fov / (2 r_corner)) / (view_angle / height)))`` against the
    camera's mean angular pixel size (``view_angle`` in radians; also for parallel cameras).

    References
    ----------
    L. Wang, Y. Zhao, K. Mueller, A. Kaufman, "The Magic Volume Lens", IEEE Visualization
    2005, §3.4.

    Examples
    --------
    >>> cam = Camera((0, 0, 10), (0, 0, 0), (0, 1, 0))
    >>> Fisheye(180).direction_at(cam, (65, 49), (32.5, 24.5)).tolist()
    [0.0, 0.0, -1.0]
    >>> (Fisheye(360).direction_at(cam, (64, 48), (0, 0)).round(12) + 0.0).tolist()
    [0.0, 0.0, 1.0]
    """

    fov_degrees: float = 180.0
    antialias: bool = True

    def __init__(self, fov_degrees=180.0, *, antialias=True):
        self._set(fov_degrees=as_real("fov_degrees", fov_degrees, low=0, high=360, low_open=True),
                  antialias=_as_bool("antialias", antialias))

    def _pixel_angle(self, w, h):
        """Angle between neighbouring rays along a radius: radians per pixel."""
        return math.radians(self.fov_degrees) / 2.0 / math.hypot(0.5 * w, 0.5 * h)

    def direction_at(self, camera, size, position):
        """Unit direction of the ray through continuous pixel position(s) ``(col, row)``.

        ``position`` of shape (2,) gives (3,); (n, 2) gives (n, 3).
        """
        camera = _as_camera(camera)
        w, h = as_size(size)
        p = np.asarray(position, dtype=np.float64)
        if p.shape[-1:] != (2,) or p.ndim > 2:
            raise ValueError(f"position must be (col, row) or an (n, 2) array; got shape {p.shape}")
        pts = np.ascontiguousarray(p.reshape(-1, 2))
        out = np.empty((len(pts), 3))
        _fisheye_points(pts, w, h, self._pixel_angle(w, h), np.array(camera.basis()), out)
        return out.reshape(p.shape[:-1] + (3,))

    def rays(self, camera, size):
        """One ray per pixel centre; see the Notes. Returns :class:`Rays`."""
        camera = _as_camera(camera)
        w, h = as_size(size)
        directions = np.empty((w * h, 3))
        _fisheye_grid(w, h, self._pixel_angle(w, h), np.array(camera.basis()), directions)
        origins = np.empty_like(directions)
        origins[:] = camera.position
        lod = None
        if self.antialias:
            ratio = self._pixel_angle(w, h) / (math.radians(camera.view_angle) / h)
            if ratio > 1.0:
                lod = np.full(w * h, math.log2(ratio))
        return Rays(origins, directions, w, h, lod)
