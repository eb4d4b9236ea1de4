"""Image volumes (``pyvista.ImageData``, ``vtkImageData`` or numpy arrays) as flat arrays."""
from __future__ import annotations

import hashlib
import weakref
from dataclasses import dataclass, field, replace

import numpy as np

from .._validate import as_choice, as_vector

# Dtypes the kernels read natively (no copy); anything else is converted once, so that
# numba compiles each kernel for these three only (every other integer type would cost
# another 30-60 s of compilation on first use). The kernels read every value as float64,
# so an exact conversion changes no pixel.
_NATIVE = (np.uint8, np.float32, np.float64)
# float32 holds every integer of magnitude <= 2**24 exactly
_FLOAT32_EXACT = 2**24


class ScalarsError(ValueError):
    """The requested scalars are missing or not usable for volume rendering."""


@dataclass(frozen=True)
class GridVolume:
    """A scalar field on a uniform grid, ready for the kernels.

    Attributes
    ----------
    values : ndarray, shape (nz, ny, nx)
        Point values, C-contiguous, x fastest (VTK order). Never the caller's array
        when it had to be cleaned (NaN/inf) or converted.
    origin, spacing : ndarray, shape (3,)
        World position of ``values[0, 0, 0]`` and the distance between points (x, y, z).
    value_range : (float, float)
        Finite minimum and maximum (NaN ignored).
    has_nan : bool
        Whether NaN points exist: samples touching them are empty.
    any_finite : bool
        Whether any point was finite (False for all-NaN or all-inf data, whose
        ``value_range`` is then a placeholder ``(0.0, 0.0)``).
    integer : bool
        Whether the caller's values were integers (``values`` may be a float copy).
    axes : tuple of 3 ndarray (float64) or None
        A rectilinear grid's point coordinates along x, y and z (``None``: uniform).
        ``origin`` is then the first coordinates and ``spacing`` the *nominal* spacing
        ``(last - first) / (n - 1)``, so that ``bounds`` and cameras read it as they
        read a uniform grid's; the kernels sample the true cells (``raycast/grid.py``).
    dataset_bounds : tuple of 6 float or None
        The bounds of the dataset the volume was made of, where they are not
        :attr:`bounds`: a volume of cell data holds the values at the cell centres,
        half a cell inside the dataset's bounds (its cells' corners). What a view name
        frames (:func:`~pv_hdrvol.rays.camera.fit_camera`), as PyVista and ParaView
        frame the dataset. ``None``: :attr:`bounds`.
    """

    values: np.ndarray
    origin: np.ndarray
    spacing: np.ndarray
    value_range: tuple
    has_nan: bool
    name: str = ""
    any_finite: bool = True
    integer: bool = False
    axes: tuple = None
    dataset_bounds: tuple = None
    #: Derived arrays (bricks, block ranges) built on first render and reused.
    cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def dims(self):
        """Points along (x, y, z)."""
        nz, ny, nx = self.values.shape
        return nx, ny, nz

    @property
    def bounds(self):
        """``(xmin, xmax, ymin, ymax, zmin, zmax)`` of the sampled domain."""
        hi = self.origin + (np.array(self.dims) - 1) * self.spacing
        return (self.origin[0], hi[0], self.origin[1], hi[1], self.origin[2], hi[2])

    @property
    def min_cell_width(self):
        """The smallest distance between neighbouring points on any axis (world units):
        the smallest spacing of a uniform grid, the narrowest cell of a rectilinear one."""
        if self.axes is None:
            return float(self.spacing.min())
        return float(min(np.diff(a).min() for a in self.axes))


def volume_from_array(values, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), *, order="zyx", name=""):
    """Make a :class:`GridVolume` from a 3-D numpy array.

    Parameters
    ----------
    values : ndarray, 3-D, any real numeric dtype
        ``order="zyx"`` (default): ``values[k, j, i]`` is at x index i; ``"xyz"``: the
        transpose, as ``pyvista.ImageData`` ``dimensions`` order.
    spacing, origin : sequence of 3 floats
        Spacing must be > 0 on every axis.

    Notes
    -----
    NaN points are kept and treated as empty space by the kernels (a sample whose
    interpolation stencil touches a NaN contributes nothing). ``+inf``/``-inf`` are
    clamped to the largest/smallest finite value, on a copy.

    Only uint8, float32 and float64 values are kept as they are; other dtypes are
    copied once to float32 where that holds every value exactly (float16, integers
    of up to 16 bits, wider integers within +-2**24), else to float64. The kernels
    read each value as float64, so the picture is the same as for the original dtype,
    and the kernels are compiled for three dtypes only.
    """
    as_choice("order", order, ("zyx", "xyz"))
    arr = np.asarray(values)
    if arr.ndim != 3:
        raise ValueError(f"volume values must be a 3-D array; got {arr.ndim}-D with shape {arr.shape}")
    if arr.dtype == np.bool_ or not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        raise TypeError(f"volume values must have a real numeric dtype; got {arr.dtype}")
    if arr.size == 0:
        raise ValueError(f"volume values must not be empty; got shape {arr.shape}")
    if order == "xyz":
        arr = arr.transpose(2, 1, 0)
    spacing = as_vector("spacing", spacing)
    if np.any(spacing <= 0):
        raise ValueError(f"spacing must be > 0 on every axis; got {tuple(spacing.tolist())}")
    origin = as_vector("origin", origin)
    integer = bool(np.issubdtype(arr.dtype, np.integer))
    if arr.dtype.type not in _NATIVE:
        arr = arr.astype(_kernel_dtype(arr))
    has_nan = False
    any_finite = True
    if np.issubdtype(arr.dtype, np.floating):
        finite = np.isfinite(arr)
        if not finite.all():
            has_nan = bool(np.isnan(arr).any())
            fin = arr[finite]
            lo, hi = (float(fin.min()), float(fin.max())) if fin.size else (0.0, 0.0)
            any_finite = bool(fin.size)
            arr = np.array(arr, copy=True)  # never touch the caller's data
            arr[np.isposinf(arr)] = hi
            arr[np.isneginf(arr)] = lo
            vr = (lo, hi)
        else:
            vr = (float(arr.min()), float(arr.max()))
    else:
        vr = (float(arr.min()), float(arr.max()))
    arr = np.ascontiguousarray(arr)
    return GridVolume(arr, origin, spacing, vr, has_nan, name, any_finite, integer)


#: Axes whose points deviate from even spacing by at most this much, relative to the
#: coordinates' magnitude ``max(|first|, |last|)``, are uniform (``volume_from_rectilinear``):
#: 1e-12 is some 4,500 float64 ulps, far above the rounding of ``first + i * h`` or of
#: ``np.linspace``, and moves a sample by at most ~1e-12 of a cell. (Float32 coordinates
#: get 4 of their own ulps, ~5e-7: a uniform axis stored in float32 stays uniform.)
UNIFORM_AXIS_TOLERANCE = 1e-12


def volume_from_rectilinear(values, x, y, z, *, name=""):
    """Make a :class:`GridVolume` from point values on a rectilinear grid.

    Parameters
    ----------
    values : ndarray, shape (nz, ny, nx), any real numeric dtype
        Point values, x fastest (as :func:`volume_from_array` with ``order="zyx"``).
    x, y, z : 1-D arrays of nx, ny, nz finite, strictly increasing coordinates
        At least 2 each. Copied as float64; the caller's arrays are not modified.

    Returns
    -------
    GridVolume
        ``axes`` holds the coordinates; ``origin`` the first of each, ``spacing`` the
        nominal ``(last - first) / (n - 1)``. Axes that are all evenly spaced (to
        :data:`UNIFORM_AXIS_TOLERANCE`) give a plain uniform volume (``axes=None``),
        rendered as the same ``ImageData`` would be.

    Raises
    ------
    ValueError
        An axis that is not 1-D, has fewer than 2 points, a non-finite coordinate, a
        coordinate not above the one before it (named with its index and value), or a
        length other than ``values``' along that axis.

    Examples
    --------
    >>> import numpy as np
    >>> v = volume_from_rectilinear(np.zeros((2, 2, 3)), [0.0, 1.0, 3.0], [0, 1], [0, 2])
    >>> v.spacing.tolist(), v.axes[0].tolist()
    ([1.5, 1.0, 2.0], [0.0, 1.0, 3.0])
    """
    arr = np.asarray(values)
    if arr.ndim != 3:
        raise ValueError(f"volume values must be a 3-D array; got {arr.ndim}-D with shape {arr.shape}")
    axes = tuple(_check_axis(label, c, n, arr.shape) for label, c, n in zip("xyz", (x, y, z), arr.shape[::-1]))
    origin = np.array([a[0] for a in axes])
    spacing = np.array([(a[-1] - a[0]) / (a.size - 1) for a in axes])
    volume = volume_from_array(arr, spacing, origin, name=name)
    if all(_is_uniform(a, raw) for a, raw in zip(axes, (x, y, z))):
        return volume
    for a in axes:
        a.flags.writeable = False
    return GridVolume(volume.values, volume.origin, volume.spacing, volume.value_range, volume.has_nan,
                      volume.name, volume.any_finite, volume.integer, axes)


def _check_axis(label, coords, n, shape):
    """The coordinates ``coords`` of axis ``label`` as a fresh float64 array, checked."""
    raw = np.asarray(coords)
    if raw.ndim != 1:
        raise ValueError(f"{label} must be a 1-D array of coordinates; got shape {raw.shape}")
    if raw.dtype == np.bool_ or not (np.issubdtype(raw.dtype, np.integer) or np.issubdtype(raw.dtype, np.floating)):
        raise TypeError(f"{label} coordinates must be real numbers; got dtype {raw.dtype}")
    if raw.size < 2:
        raise ValueError(f"{label} needs at least 2 coordinates (a grid without thickness has nothing to render); "
                         f"got {raw.size}")
    if raw.size != n:
        raise ValueError(f"{label} has {raw.size} coordinates but the values have {n} points along {label} "
                         f"(values' shape (z, y, x) = {shape})")
    a = np.array(raw, dtype=np.float64)  # a copy: never the caller's array
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{label} coordinates must be finite; {label}[{i}] = {float(a[i])!r}")
    bad = np.flatnonzero(np.diff(a) <= 0.0)
    if bad.size:
        i = int(bad[0]) + 1
        raise ValueError(f"{label} coordinates must be strictly increasing; {label}[{i}] = {float(a[i])!r} <= "
                         f"{label}[{i - 1}] = {float(a[i - 1])!r}")
    return a


def _is_uniform(a, raw):
    """Whether the points ``a`` are evenly spaced to :data:`UNIFORM_AXIS_TOLERANCE` (or
    to 4 ulps of the caller's float type ``raw``, where that is coarser)."""
    n = a.size
    h = (a[-1] - a[0]) / (n - 1)
    even = a[0] + np.arange(n) * h
    eps = np.finfo(np.asarray(raw).dtype).eps if np.issubdtype(np.asarray(raw).dtype, np.floating) else 0.0
    tol = max(UNIFORM_AXIS_TOLERANCE, 4.0 * eps) * max(abs(a[0]), abs(a[-1]))
    return bool(np.abs(a - even).max() <= tol)


def as_volume(data, scalars=None, preference="point"):
    """A :class:`GridVolume` from a GridVolume, a 3-D numpy array, an image dataset or a
    rectilinear grid (``pyvista.RectilinearGrid``, ``vtkRectilinearGrid``)."""
    if isinstance(data, GridVolume):
        return data
    if isinstance(data, np.ndarray):
        if scalars is not None:
            raise ValueError("scalars names an array of a dataset; a numpy volume has none")
        return volume_from_array(data)
    return cached_volume_from_dataset(data, scalars=scalars, preference=preference)


def _kernel_dtype(arr):
    """The dtype a non-native array is converted to: float32 where it holds every value
    exactly (floats of <= 4 bytes, integers of <= 2 bytes, wider integers whose values
    lie within +-2**24), else float64."""
    if np.issubdtype(arr.dtype, np.floating):
        return np.float32 if arr.dtype.itemsize <= 4 else np.float64
    if arr.dtype.itemsize <= 2:
        return np.float32
    lo, hi = int(arr.min()), int(arr.max())
    return np.float32 if -_FLOAT32_EXACT <= lo and hi <= _FLOAT32_EXACT else np.float64


def content_digest(*arrays):
    """SHA-1 of the arrays' dtypes, shapes and bytes: a cache key that sees in-place edits
    (not for security; about 2 GB/s)."""
    h = hashlib.sha1(usedforsecurity=False)
    for array in arrays:
        a = np.ascontiguousarray(array)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(memoryview(a).cast("B"))
    return h.digest()


class DatasetCache(dict):
    """What was prepared from VTK datasets, one entry ``id -> (weak ref, key, value)`` per
    dataset: an entry goes when its dataset does, and at most ``size`` are kept (each
    may hold a copy of a large array)."""

    def __init__(self, size):
        super().__init__()
        self.size = size

    def lookup(self, dataset, key):
        """The value stored for ``dataset`` under ``key``, else None."""
        entry = self.get(id(dataset))
        return entry[2] if entry is not None and entry[0]() is dataset and entry[1] == key else None

    def store(self, dataset, key, value):
        """Keep ``value`` for ``dataset`` under ``key`` (replacing its older one); returns it."""
        self.pop(id(dataset), None)
        self[id(dataset)] = (weakref.ref(dataset, self._forget), key, value)
        if len(self) > self.size:
            self.pop(next(iter(self)))
        return value

    def _forget(self, ref):
        for k, entry in list(self.items()):
            if entry[0] is ref:
                del self[k]


def cached_volume_from_dataset(dataset, scalars=None, preference="point"):
    """:func:`volume_from_dataset`, cached per dataset with what the renderer derives from
    it (bricks, block grids, skip structures), so repeated renders of one
    ``pyvista.ImageData`` (or ``RectilinearGrid``) skip that work.

    The cache holds the dataset weakly and at most four volumes (:class:`DatasetCache`).
    It is used only while the dataset's modification time, the array (its memory, shape
    and dtype), spacing and origin (a rectilinear grid's coordinates) are unchanged *and*
    the array's :func:`content_digest` is the same: an in-place numpy edit that did not
    call ``Modified()`` is still seen. The hash reads the array once, a fraction of what
    rebuilding costs.
    """
    if _is_rectilinear(dataset):
        arr, axes, name = _rectilinear_array(dataset, scalars, preference)
        key = (int(dataset.GetMTime()), scalars, preference, name, arr.__array_interface__["data"][0],
               content_digest(arr, *axes))
        volume = _VOLUME_CACHE.lookup(dataset, key)
        if volume is None:
            volume = _VOLUME_CACHE.store(dataset, key,
                                         _framed(volume_from_rectilinear(arr, *axes, name=name), dataset))
        return volume
    arr, spacing, origin, name = image_array(dataset, scalars, preference)
    key = (int(dataset.GetMTime()), scalars, preference, name, arr.__array_interface__["data"][0],
           tuple(spacing.tolist()), tuple(origin.tolist()), content_digest(arr))
    volume = _VOLUME_CACHE.lookup(dataset, key)
    if volume is None:
        volume = _VOLUME_CACHE.store(dataset, key, _framed(volume_from_array(arr, spacing, origin, name=name), dataset))
    return volume


def _framed(volume, dataset):
    """``volume`` of ``dataset``'s cell data with the dataset's bounds, which a view frames
    (:attr:`GridVolume.dataset_bounds`); a volume of its point data as it is."""
    if volume.dims == tuple(int(d) for d in dataset.GetDimensions()):
        return volume
    return replace(volume, dataset_bounds=tuple(float(b) for b in dataset.GetBounds()))


_VOLUME_CACHE = DatasetCache(4)


def volume_from_dataset(dataset, scalars=None, preference="point"):
    """Make a :class:`GridVolume` from a ``pyvista.ImageData``, ``vtkImageData``,
    ``pyvista.RectilinearGrid`` or ``vtkRectilinearGrid`` (:func:`volume_from_rectilinear`).

    Parameters
    ----------
    scalars : str, optional
        Array name; default: the active scalars, else the only array.
    preference : {"point", "cell"}
        Which association to prefer when the name exists in both. Cell data is
        rendered as a point field at the cell centres (the domain shrinks by half a
        cell on every side; on a rectilinear grid the centres are the midpoints of
        its coordinates); the volume keeps the dataset's bounds, which a view name
        frames (:attr:`GridVolume.dataset_bounds`).
    """
    if _is_rectilinear(dataset):
        arr, axes, scalars = _rectilinear_array(dataset, scalars, preference)
        return _framed(volume_from_rectilinear(arr, *axes, name=scalars), dataset)
    arr, spacing, origin, scalars = image_array(dataset, scalars, preference)
    # np.asarray of a VTK array is a view: volume_from_array copies before any change.
    return _framed(volume_from_array(arr, spacing, origin, name=scalars), dataset)


def labels_from_dataset(dataset, name, preference="point"):
    """The array ``name`` of an image dataset as a (z, y, x) numpy copy, dtype kept.

    For label (segmentation) arrays, which must stay integers: see
    ``render_volume(labels=...)``.
    """
    return np.array(image_array(dataset, name, preference)[0])


def image_array(dataset, scalars, preference):
    """``(array (z, y, x) view, spacing, origin, name)`` of one array of an image dataset."""
    as_choice("preference", preference, ("point", "cell"))
    cls_name = dataset.GetClassName() if hasattr(dataset, "GetClassName") else type(dataset).__name__
    if cls_name not in ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid"):
        raise TypeError(f"expected image data (pyvista.ImageData / vtkImageData) or a rectilinear grid "
                        f"(pyvista.RectilinearGrid / vtkRectilinearGrid); got {cls_name}")
    ds = dataset
    dims = tuple(int(d) for d in ds.GetDimensions())
    if min(dims) < 1:
        raise ValueError(f"the image has no points (dimensions {dims})")
    # plain VTK calls: works without PyVista (ParaView's Python) and on pyvista.ImageData
    pdata, cdata = _arrays(ds.GetPointData()), _arrays(ds.GetCellData())
    scalars, use_cell = choose_scalars(ds, scalars, preference, "dataset")
    arr = (cdata if use_cell else pdata)[scalars]()
    if arr.ndim != 1:
        raise ScalarsError(f"scalars {scalars!r} must have one component; got shape {arr.shape}")
    spacing = np.array(ds.GetSpacing(), dtype=np.float64)
    # the first point is origin + extent start * spacing: a piece of a larger image, or a
    # file whose extent does not start at 0 (vtkRTAnalyticSource's -10..10)
    origin = np.array(ds.GetOrigin(), dtype=np.float64) + np.array(ds.GetExtent()[::2], dtype=np.float64) * spacing
    if hasattr(ds, "GetDirectionMatrix"):
        m = ds.GetDirectionMatrix()
        dm = np.array([[m.GetElement(i, j) for j in range(3)] for i in range(3)])
        if not np.allclose(dm, np.eye(3)):
            raise ValueError("oriented images (a direction matrix other than identity) are not supported yet")
    if use_cell:
        cdims = tuple(max(d - 1, 1) for d in dims)
        shape = cdims[::-1]
        origin = origin + 0.5 * spacing * (np.array(dims) > 1)
    else:
        shape = dims[::-1]
    # as volume_from_array refuses 2-D arrays: such an image has no thickness, so every
    # render of it would be empty
    _check_thickness(shape, dims, use_cell, scalars, "image data", "a 2-D image or a single voxel")
    return arr.reshape(shape), spacing, origin, scalars


def _check_thickness(shape, dims, use_cell, scalars, kind, flat):
    """Refuse a dataset with fewer than 2 points (cells, for cell data) along an axis of
    its array's ``shape`` (z, y, x): ``kind`` names the dataset, ``flat`` what it is."""
    if min(shape) < 2:
        got = f"{shape[::-1]} cells of cell data {scalars!r}" if use_cell else f"dimensions {dims}"
        raise ValueError(f"{kind} must be 3-D, with at least 2 {'cells' if use_cell else 'points'} along "
                         f"every axis; got {got}: {flat} has no thickness to render")


def _is_rectilinear(dataset):
    return hasattr(dataset, "GetClassName") and dataset.GetClassName() == "vtkRectilinearGrid"


def _rectilinear_array(dataset, scalars, preference):
    """``(array (z, y, x) view, (x, y, z) coordinates, name)`` of one array of a
    ``vtkRectilinearGrid``; cell data sits at the midpoints of the coordinates."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    as_choice("preference", preference, ("point", "cell"))
    ds = dataset
    dims = tuple(int(d) for d in ds.GetDimensions())
    if min(dims) < 1:
        raise ValueError(f"the rectilinear grid has no points (dimensions {dims})")
    scalars, use_cell = choose_scalars(ds, scalars, preference, "dataset")
    arr = (_arrays(ds.GetCellData()) if use_cell else _arrays(ds.GetPointData()))[scalars]()
    if arr.ndim != 1:
        raise ScalarsError(f"scalars {scalars!r} must have one component; got shape {arr.shape}")
    coords = [np.asarray(vtk_to_numpy(c), dtype=np.float64).reshape(-1)
              for c in (ds.GetXCoordinates(), ds.GetYCoordinates(), ds.GetZCoordinates())]
    if use_cell:
        coords = [0.5 * (c[:-1] + c[1:]) if c.size > 1 else c for c in coords]
        shape = tuple(max(d - 1, 1) for d in dims)[::-1]
    else:
        shape = dims[::-1]
    _check_thickness(shape, dims, use_cell, scalars, "a rectilinear grid", "a 2-D grid")
    return arr.reshape(shape), tuple(coords), scalars


def choose_scalars(ds, scalars, preference, what="dataset"):
    """``(name, use_cell)``: the array to render of a VTK dataset: ``scalars``, else the
    active scalars, else its only array; cell data when the name is only a cell array
    or ``preference == "cell"``."""
    pnames, cnames = list(_arrays(ds.GetPointData())), list(_arrays(ds.GetCellData()))
    if scalars is None:
        active = ds.GetPointData().GetScalars() or ds.GetCellData().GetScalars()
        if active is not None and active.GetName():
            scalars = active.GetName()
        elif len(pnames) + len(cnames) == 1:
            scalars = (pnames + cnames)[0]
        else:
            raise ScalarsError(f"scalars must be given: the {what} has no active scalars and "
                               f"{'no arrays' if not pnames + cnames else 'several arrays'} "
                               f"(point: {pnames}, cell: {cnames})")
    if not isinstance(scalars, str):
        raise TypeError(f"scalars must be an array name (str); got {scalars!r}")
    in_point, in_cell = scalars in pnames, scalars in cnames
    if not (in_point or in_cell):
        raise ScalarsError(f"scalars {scalars!r} not found; point arrays: {pnames}, cell arrays: {cnames}")
    return scalars, in_cell and (preference == "cell" or not in_point)


def _arrays(field_data):
    """``{name: loader}`` of the data arrays of a vtkPointData/vtkCellData (lazy views)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    out = {}
    for i in range(field_data.GetNumberOfArrays()):
        arr = field_data.GetArray(i)
        if arr is not None and arr.GetName():
            out[arr.GetName()] = (lambda a=arr: vtk_to_numpy(a))
    return out
