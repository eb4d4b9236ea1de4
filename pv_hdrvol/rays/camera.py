"""Pinhole and parallel cameras that generate one ray per pixel."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import NamedTuple, Optional

import numpy as np

from .._validate import as_choice, as_int, as_real, as_size, as_vector


def ray_box_spans(rays, lo, hi, closed=(True, True, True)):
    """``(near, far)``: per ray, the world distances where it enters and leaves the box
    ``[lo, hi]`` (``near = inf`` where it misses it or only touches it). A ray parallel
    to an axis lies in the box for ``lo <= o < hi`` on that axis, ``<= hi`` where
    ``closed``: boxes that share a face then never both hold a ray in it."""
    o = np.asarray(rays.origins, dtype=np.float64)
    d = np.asarray(rays.directions, dtype=np.float64)
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    moving = d != 0
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = (lo - o) / d
        tb = (hi - o) / d
    inside = (o >= lo) & ((o < hi) | (np.asarray(closed) & (o <= hi)))
    enter = np.where(moving, np.minimum(ta, tb), np.where(inside, -np.inf, np.inf))
    leave = np.where(moving, np.maximum(ta, tb), np.where(inside, np.inf, -np.inf))
    near = np.maximum(enter.max(axis=1), 0.0)
    far = leave.min(axis=1)
    return np.where(far > near, near, np.inf), far


def check_window(window, width, height):
    """``(col, row, w, h)`` as ints after checking it is a rectangle inside a ``width x
    height`` image."""
    if isinstance(window, (str, bytes)) or not hasattr(window, "__len__") or len(window) != 4:
        raise TypeError(f"window must be (col, row, width, height); got {window!r}")
    col, row = (as_int(f"window[{k}]", window[k], low=0) for k in (0, 1))
    w, h = (as_int(f"window[{k}]", window[k], low=1) for k in (2, 3))
    if col + w > width or row + h > height:
        raise ValueError(f"window {tuple(window)} reaches outside the {width}x{height} image")
    return col, row, w, h


class Rays(NamedTuple):
    """One ray per pixel, row 0 at the top.

    Attributes
    ----------
    origins : ndarray, shape (height * width, 3), float64
    directions : ndarray, shape (height * width, 3), float64, unit length
    width, height : int
    lod : ndarray, shape (height * width,), float64, or None
        Level of detail per ray, for rays sparser than the camera's (lenses): the
        renderer samples a mip-map of the volume at that fractional level (0: the
        volume itself, 1: half resolution, ...). ``None`` (the camera's own rays):
        level 0 everywhere, and no mip-map is built.
    """

    origins: np.ndarray
    directions: np.ndarray
    width: int
    height: int
    lod: Optional[np.ndarray] = None


# Direction from the focal point to the camera, and view-up, for Camera.fit views
# (PyVista's conventions: view_xy looks down -z with +y up; "iso" from (1, 1, 1)).
_VIEWS = {
    "iso": ((1.0, 1.0, 1.0), (0.0, 0.0, 1.0)),
    "xy": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    "yx": ((0.0, 0.0, -1.0), (1.0, 0.0, 0.0)),
    "xz": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    "zx": ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0)),
    "yz": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "zy": ((-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
}


@dataclass(frozen=True)
class Camera:
    """A camera in VTK's terms.

    Parameters
    ----------
    position, focal_point, view_up : sequence of 3 floats
        World coordinates; ``view_up`` need not be orthogonal to the view direction
        (it is orthogonalised) but must not be parallel to it.
    view_angle : float
        Vertical field of view in degrees, in (0, 180) (VTK's ``ViewAngle``).
    parallel_projection : bool
        Parallel (orthographic) instead of perspective projection.
    parallel_scale : float
        Half the height of the view in world units, for parallel projection
        (VTK's ``ParallelScale``).

    Examples
    --------
    >>> cam = Camera((0, 0, 10), (0, 0, 0), (0, 1, 0), parallel_projection=True, parallel_scale=2)
    >>> rays = cam.rays((4, 4))
    >>> rays.directions[0].tolist()
    [0.0, 0.0, -1.0]
    """

    position: tuple = (0.0, 0.0, 1.0)
    focal_point: tuple = (0.0, 0.0, 0.0)
    view_up: tuple = (0.0, 1.0, 0.0)
    view_angle: float = 30.0
    parallel_projection: bool = False
    parallel_scale: float = 1.0

    def __post_init__(self):
        pos = as_vector("position", self.position)
        fp = as_vector("focal_point", self.focal_point)
        up = as_vector("view_up", self.view_up)
        d = fp - pos
        if np.linalg.norm(d) == 0:
            raise ValueError("position and focal_point must differ")
        if np.linalg.norm(np.cross(d / np.linalg.norm(d), up)) < 1e-9 * max(np.linalg.norm(up), 1e-300):
            raise ValueError(f"view_up {tuple(up.tolist())} must not be parallel to the view direction {tuple(d.tolist())}")
        object.__setattr__(self, "position", tuple(pos.tolist()))
        object.__setattr__(self, "focal_point", tuple(fp.tolist()))
        object.__setattr__(self, "view_up", tuple(up.tolist()))
        object.__setattr__(self, "view_angle",
                           as_real("view_angle", self.view_angle, low=0, high=180, low_open=True, high_open=True))
        if not isinstance(self.parallel_projection, (bool, np.bool_)):
            raise TypeError(f"parallel_projection must be a bool; got {self.parallel_projection!r}")
        object.__setattr__(self, "parallel_projection", bool(self.parallel_projection))
        object.__setattr__(self, "parallel_scale",
                           as_real("parallel_scale", self.parallel_scale, low=0, low_open=True))

    # -- frame -------------------------------------------------------------------
    def basis(self):
        """``(right, up, forward)`` unit vectors of the camera frame."""
        fwd = np.subtract(self.focal_point, self.position)
        fwd /= np.linalg.norm(fwd)
        right = np.cross(fwd, self.view_up)
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        return right, up, fwd

    @property
    def distance(self):
        """Distance from position to focal point."""
        return float(np.linalg.norm(np.subtract(self.focal_point, self.position)))

    def rays(self, size, window=None):
        """One ray through the centre of each pixel.

        Parameters
        ----------
        size : int or (width, height)
        window : (col, row, width, height), optional
            Only the rays of this rectangle of the image (the same values as cutting
            them out of the whole image's, without making those).

        Returns
        -------
        Rays
            Row 0 is the top of the image. Perspective rays start at ``position``;
            parallel rays start on the plane through ``position`` normal to the view.
        """
        w, h = as_size(size)
        col, row, ww, wh = (0, 0, w, h) if window is None else check_window(window, w, h)
        right, up, fwd = self.basis()
        half_h = self.parallel_scale if self.parallel_projection else math.tan(math.radians(self.view_angle) / 2)
        half_w = half_h * w / h
        x = ((np.arange(col, col + ww) + 0.5) * (2.0 / w) - 1.0) * half_w
        y = (1.0 - (np.arange(row, row + wh) + 0.5) * (2.0 / h)) * half_h
        w, h = ww, wh
        pos = np.asarray(self.position)
        grid = x[None, :, None] * right + y[:, None, None] * up  # (h, w, 3)
        if self.parallel_projection:
            origins = (pos + grid).reshape(-1, 3)
            directions = np.broadcast_to(fwd, origins.shape).copy()
        else:
            # the basis is orthonormal: |fwd + x right + y up|^2 = 1 + x^2 + y^2
            inv_len = 1.0 / np.sqrt(1.0 + x[None, :] ** 2 + y[:, None] ** 2)
            directions = ((grid + fwd) * inv_len[:, :, None]).reshape(-1, 3)
            origins = np.broadcast_to(pos, directions.shape).copy()
        return Rays(np.ascontiguousarray(origins), np.ascontiguousarray(directions), w, h)

    def kernel_array(self, size):
        """The camera as ``rays._kernels.camera_ray`` reads it (float64, 15 values):
        position, right, up, forward, half width and half height of the view (at unit
        distance, or of the parallel view), 1.0 for a parallel projection."""
        w, h = as_size(size)
        right, up, fwd = self.basis()
        half_h = self.parallel_scale if self.parallel_projection else math.tan(math.radians(self.view_angle) / 2)
        half_w = half_h * w / h
        return np.concatenate([np.asarray(self.position, dtype=np.float64), right, up, fwd,
                               [half_w, half_h, 1.0 if self.parallel_projection else 0.0]]).astype(np.float64)

    def project(self, points, size):
        """Pixel coordinates ``(col, row)`` (continuous, row 0 at the top) of world points."""
        w, h = as_size(size)
        p = np.atleast_2d(np.asarray(points, dtype=np.float64)) - np.asarray(self.position)
        right, up, fwd = self.basis()
        x, y, z = p @ right, p @ up, p @ fwd
        if self.parallel_projection:
            half_h = self.parallel_scale
            u, v = x / half_h, y / half_h
        else:
            half_h = math.tan(math.radians(self.view_angle) / 2)
            u, v = x / (z * half_h), y / (z * half_h)
        half_w_ratio = w / h
        col = (u / half_w_ratio + 1.0) * w / 2.0
        row = (1.0 - v) * h / 2.0
        return np.stack([col, row], axis=-1)

    # -- constructors ------------------------------------------------------------
    @classmethod
    def fit(cls, bounds, view="iso", *, view_angle=30.0, parallel_projection=False, zoom=1.0):
        """Frame ``bounds`` as PyVista's ``reset_camera`` does.

        Parameters
        ----------
        bounds : dataset or (xmin, xmax, ymin, ymax, zmin, zmax)
            Anything with ``.bounds`` (a PyVista dataset, a :class:`GridVolume`) or six numbers.
        view : {"iso", "xy", "yx", "xz", "zx", "yz", "zy"}
            Direction, as PyVista's ``view_isometric``/``view_xy``/...
        zoom : float
            > 1 moves closer (VTK's ``Zoom``).

        Notes
        -----
        The distance is ``r / sin(view_angle / 2)`` with ``r`` half the bounding box
        diagonal (VTK's ``ResetCamera``), so the bounding sphere fits the view; the
        parallel scale is ``r``.
        """
        as_choice("view", view, tuple(_VIEWS))
        zoom = as_real("zoom", zoom, low=0, low_open=True)
        b = getattr(bounds, "bounds", bounds)
        b = as_vector("bounds", b, 6)
        if np.any(b[1::2] < b[0::2]):
            raise ValueError(f"bounds must be (xmin, xmax, ymin, ymax, zmin, zmax) with min <= max; got {tuple(b.tolist())}")
        center = 0.5 * (b[0::2] + b[1::2])
        radius = 0.5 * float(np.linalg.norm(b[1::2] - b[0::2]))
        if radius == 0:
            radius = 0.5
        direction, up = _VIEWS[view]
        direction = np.asarray(direction) / np.linalg.norm(direction)
        dist = radius / math.sin(math.radians(view_angle) / 2)
        return cls(tuple(center + direction * dist / zoom), tuple(center), up, view_angle=view_angle,
                   parallel_projection=parallel_projection, parallel_scale=radius / zoom)

    @classmethod
    def from_pyvista(cls, source):
        """The camera of a ``pyvista.Plotter``, ``pyvista.Camera`` or ``vtkCamera``.

        Renders then match what that window shows (same vertical view angle and
        aspect taken from the size you render at).
        """
        cam = source
        if hasattr(cam, "camera") and not hasattr(cam, "GetViewAngle"):
            cam = cam.camera
        if hasattr(cam, "GetActiveCamera"):
            cam = cam.GetActiveCamera()
        needed = ("GetPosition", "GetFocalPoint", "GetViewUp", "GetViewAngle")
        if not all(hasattr(cam, n) for n in needed):
            raise TypeError(f"expected a pyvista.Plotter, pyvista.Camera or vtkCamera; got {type(source).__name__}")
        if hasattr(cam, "GetUseHorizontalViewAngle") and cam.GetUseHorizontalViewAngle():
            raise ValueError("cameras with UseHorizontalViewAngle are not supported; switch it off")
        return cls(cam.GetPosition(), cam.GetFocalPoint(), cam.GetViewUp(), view_angle=cam.GetViewAngle(),
                   parallel_projection=bool(cam.GetParallelProjection()), parallel_scale=cam.GetParallelScale())

    # -- plain values (JSON) ---------------------------------------------------------
    def to_dict(self):
        """The camera as plain Python values (lists, floats, a bool), ready for JSON;
        :meth:`from_dict` gives back an equal camera (JSON keeps float64 exactly).

        Examples
        --------
        >>> cam = Camera((0.1, 0, 10), (0, 0, 0), (0, 1, 0), view_angle=1 / 3)
        >>> cam.to_dict()["position"], Camera.from_dict(cam.to_dict()) == cam
        ([0.1, 0.0, 10.0], True)
        """
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return {name: list(v) if isinstance(v, tuple) else v for name, v in values.items()}

    @classmethod
    def from_dict(cls, data):
        """A camera from :meth:`to_dict`'s form; absent keys take the constructor's
        defaults, unknown keys raise ``ValueError``."""
        if not hasattr(data, "keys"):
            raise TypeError(f"Camera.from_dict needs a dict; got {type(data).__name__}")
        names = [f.name for f in fields(cls)]
        unknown = sorted(set(data) - set(names))
        if unknown:
            raise ValueError(f"Camera.from_dict: unknown keys {unknown}; allowed: {names}")
        return cls(**data)

    def to_vtk(self):
        """A ``vtkCamera`` with the same parameters."""
        from vtkmodules.vtkRenderingCore import vtkCamera

        c = vtkCamera()
        c.SetPosition(self.position)
        c.SetFocalPoint(self.focal_point)
        c.SetViewUp(self.view_up)
        c.SetViewAngle(self.view_angle)
        c.SetParallelProjection(self.parallel_projection)
        c.SetParallelScale(self.parallel_scale)
        return c


def as_camera(camera, bounds):
    """A :class:`Camera` (or :class:`Rays`) from what users pass, the same in every front end.

    Parameters
    ----------
    camera : None, str, Camera, Rays, pyvista.Plotter, pyvista.Camera or vtkCamera
        ``None`` means ``"iso"``; a string is a view name for :meth:`Camera.fit`
        (``"iso"``, ``"xy"``, ``"xz"``, ...).
    bounds : sequence of 6 floats or anything with ``.bounds``
        What a view name frames.

    Examples
    --------
    >>> as_camera("xy", (0, 1, 0, 1, 0, 1)) == Camera.fit((0, 1, 0, 1, 0, 1), "xy")
    True
    """
    if camera is None:
        camera = "iso"
    if isinstance(camera, str):
        return Camera.fit(bounds, camera)
    if isinstance(camera, (Camera, Rays)):
        return camera
    try:
        return Camera.from_pyvista(camera)
    except TypeError:
        raise TypeError(
            "camera must be None, a view name such as 'iso' or 'xy', a pv_hdrvol Camera or Rays, a "
            f"pyvista.Plotter, a pyvista.Camera or a vtkCamera; got {type(camera).__name__}") from None


def data_bounds(data, scalars=None, preference="point"):
    """``(xmin, xmax, ymin, ymax, zmin, zmax)`` that a view name frames: the dataset's
    geometric bounds, as PyVista's ``reset_camera`` and ParaView frame a dataset.

    A grid's bounds are its points' (the corners of its cells), also when the array
    rendered is cell data, whose values sit half a cell inside, at the cell centres. A
    composite dataset's are the union of the bounds of the blocks rendered: those with
    volume (not surfaces) that have the array ``scalars``.

    Parameters
    ----------
    data : dataset, GridVolume, TetMesh, MultiscaleVolume, ndarray or 6 numbers
        A VTK dataset or composite dataset, PyVista's included (``GetBounds``);
        anything with ``.bounds`` (:class:`~pv_hdrvol.GridVolume`,
        :class:`~pv_hdrvol.TetMesh`, :class:`~pv_hdrvol.MultiscaleVolume`: their
        points; a GridVolume made of cell data: the dataset's bounds it keeps,
        ``dataset_bounds``); a 3-D array ``(z, y, x)``, whose points lie at unit spacing from the
        origin (as :func:`~pv_hdrvol.volume_from_array` places them); or the six
        numbers.
    scalars, preference
        A composite dataset's array, as :func:`pv_hdrvol.render` takes them: which
        blocks are rendered (:func:`~pv_hdrvol.data.blocks.choose_block_scalars`).

    Returns
    -------
    tuple of 6 float

    Raises
    ------
    ValueError
        The dataset has no points (VTK's bounds are then "unset", min > max).

    Examples
    --------
    >>> import numpy as np
    >>> data_bounds(np.zeros((4, 3, 2)))
    (0.0, 1.0, 0.0, 2.0, 0.0, 3.0)
    """
    what = type(data).__name__
    if callable(getattr(data, "IsA", None)) and data.IsA("vtkCompositeDataSet"):
        bounds = _blocks_bounds(data, scalars, preference)
    elif callable(getattr(data, "GetBounds", None)):
        bounds = data.GetBounds()
    elif getattr(data, "dataset_bounds", None) is not None:  # a GridVolume of a dataset's cell data
        bounds = data.dataset_bounds
    elif hasattr(data, "bounds"):
        bounds = data.bounds
    elif isinstance(data, np.ndarray) and data.ndim == 3:
        nz, ny, nx = data.shape
        bounds, what = (0.0, nx - 1.0, 0.0, ny - 1.0, 0.0, nz - 1.0), "array"
    else:
        bounds, what = data, "bounds"
    b = as_vector("bounds", bounds, 6)
    if np.any(b[1::2] < b[0::2]):
        raise ValueError(f"the {what} has no points to frame: its bounds are {tuple(b.tolist())} (min > max)")
    return tuple(float(x) for x in b)


def _blocks_bounds(data, scalars, preference):
    """The union of the bounds of the blocks of a composite dataset that are rendered
    (as :func:`~pv_hdrvol.data.blocks.prepare_blocks` keeps them, without its warnings);
    VTK's bounds of all blocks where none is."""
    from ..data.blocks import SURFACE_CLASSES, choose_block_scalars, flatten

    volumetric = [leaf for leaf in flatten(data)[0] if leaf.class_name not in SURFACE_CLASSES]
    kept = choose_block_scalars(volumetric, scalars, preference)[2] if volumetric else []
    if not kept:
        bounds = [0.0] * 6  # VTK's Python wrapping fills a list for a composite dataset
        data.GetBounds(bounds)
        return bounds
    boxes = np.array([leaf.dataset.GetBounds() for leaf in kept], dtype=np.float64)
    return np.column_stack([boxes[:, 0::2].min(axis=0), boxes[:, 1::2].max(axis=0)]).reshape(-1)


def fit_camera(data, camera=None, *, scalars=None, preference="point", zoom=1.0, parallel_projection=False):
    """The camera a front end renders ``data`` with: a view name frames the data's
    geometric bounds (:func:`data_bounds`); any other camera is used as given.

    Every front end (``hv.render``, the PyVista accessor, ``plotter.hdrvol.add_volume``,
    the viewers, the VTK algorithm and the command lines) frames its default view
    through this function, so one dataset is framed alike everywhere.

    Parameters
    ----------
    data : dataset, GridVolume, TetMesh, MultiscaleVolume, ndarray or 6 numbers
        As :func:`data_bounds`. A volume made of a dataset's cell data keeps the
        dataset's bounds; for a composite dataset pass the dataset (a volume gathered
        from blocks of cell data spans their cell centres).
    camera : None, str, Camera, Rays, pyvista.Plotter, pyvista.Camera or vtkCamera
        ``None`` is ``"iso"``; a view name (``"iso"``, ``"xy"``, ``"xz"``, ...) is
        :meth:`Camera.fit` of the bounds; the rest as :func:`as_camera`.
    scalars, preference
        A composite dataset's array (:func:`data_bounds`).
    zoom : float
        A view name's zoom (> 1 moves closer).
    parallel_projection : bool
        Whether a view name makes an orthographic camera.

    Returns
    -------
    Camera or Rays

    Examples
    --------
    >>> import numpy as np
    >>> fit_camera(np.zeros((4, 3, 2)), "xy") == Camera.fit((0, 1, 0, 2, 0, 3), "xy")
    True
    """
    if camera is None:
        camera = "iso"
    if isinstance(camera, str):
        as_choice("view", camera, tuple(_VIEWS))  # named before the data is read
        return Camera.fit(data_bounds(data, scalars, preference), camera, zoom=zoom,
                          parallel_projection=parallel_projection)
    return as_camera(camera, None)
