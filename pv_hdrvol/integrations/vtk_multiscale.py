"""``MultiscaleReader``: one level of a multiresolution store (``*.ome.zarr``) as a VTK
image, carrying the store's path so that ``HDRVolumeRenderer`` renders the whole store
out of core.

Pure VTK + pv_hdrvol (no ParaView import): the ParaView plugin's reader wraps it with
decorators only. A store (:func:`pv_hdrvol.write_multiscale`, ``pv-hdrvol convert``)
holds the volume at every level of detail; opening one reads one level only, by default
the finest that has at most ``max_points`` points (64 Mi: 256 MiB of float32), so that
opening never loads the whole volume.

The output's field data names the store (:data:`STORE_ARRAY`, its absolute path),
the level (:data:`LEVEL_ARRAY`) and the point array that holds its values
(:data:`SCALARS_ARRAY`, and that array object's address, :data:`ADDRESS_ARRAY`). :func:`store_of` reads them back; ``HDRVolumeRenderer``
renders the store through :func:`pv_hdrvol.open_multiscale` (finer levels where the
camera needs them) when its input carries them and is still the reader's level
(same array, same geometry).
"""
from __future__ import annotations

import os

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonCore import vtkIntArray, vtkStringArray
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkImageData
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

from .._validate import as_int
from .vtk_base import ReportingAlgorithm

_SDDP = vtkStreamingDemandDrivenPipeline

#: Field-data string array: the store's absolute path.
STORE_ARRAY = "pv_hdrvol_store"
#: Field-data int array: the level the image holds (0: the finest).
LEVEL_ARRAY = "pv_hdrvol_level"
#: Field-data string array: the name of the point array holding the store's values.
SCALARS_ARRAY = "pv_hdrvol_scalars"
#: Field-data string array: the address of that point array (``GetAddressAsString``):
#: a filter that makes new values makes a new array, so its output is not the level.
ADDRESS_ARRAY = "pv_hdrvol_array"
#: The default most points of the level a reader loads (64 Mi).
DEFAULT_MAX_POINTS = 64 * 2 ** 20


def store_path(path):
    """The store's directory for ``path``: the directory itself, or the folder of its
    ``zarr.json`` (what a file dialog lets one pick inside it)."""
    path = os.fspath(path)
    if os.path.basename(path) == "zarr.json":
        path = os.path.dirname(path)
    return os.path.abspath(path)


def default_level(store, max_points=DEFAULT_MAX_POINTS):
    """The finest level of ``store`` with at most ``max_points`` points (the coarsest if
    none has so few)."""
    for level, lv in enumerate(store.levels):
        if int(np.prod(lv.shape, dtype=np.int64)) <= max_points:
            return level
    return store.n_levels - 1


def store_of(dataset):
    """``(path, level, array name)`` of a :class:`MultiscaleReader` output (or a shallow
    copy of one, as pipelines pass it on), else ``None``: also for data whose values
    were made anew on the way (the field data passes through filters; the reader's
    array does not)."""
    if dataset is None or not hasattr(dataset, "GetFieldData") or not hasattr(dataset, "GetPointData"):
        return None
    fd = dataset.GetFieldData()
    arrays = [fd.GetAbstractArray(n) for n in (STORE_ARRAY, LEVEL_ARRAY, SCALARS_ARRAY, ADDRESS_ARRAY)]
    if any(a is None or a.GetNumberOfValues() != 1 for a in arrays):
        return None
    store, level, name, address = arrays
    values = dataset.GetPointData().GetArray(str(name.GetValue(0)))
    if values is None or values.GetAddressAsString("vtkDataArray") != address.GetValue(0):
        return None
    return str(store.GetValue(0)), int(level.GetValue(0)), str(name.GetValue(0))


def level_image(store, level):
    """Level ``level`` of ``store`` as a ``vtkImageData`` with its world spacing and origin
    (:meth:`MultiscaleStore.level_geometry`), its values as the point array named after
    the store (``"values"`` if it has no name), and the field data of :func:`store_of`."""
    values = store.read_level(level)  # (z, y, x): VTK's point order (x fastest) when raveled
    spacing, origin = store.level_geometry(level)
    image = vtkImageData()
    nz, ny, nx = values.shape
    image.SetDimensions(nx, ny, nz)
    image.SetSpacing(*(float(v) for v in spacing))
    image.SetOrigin(*(float(v) for v in origin))
    name = store.name or "values"
    array = numpy_to_vtk(np.ascontiguousarray(values).reshape(-1), deep=False)
    array.SetName(name)
    image.GetPointData().SetScalars(array)
    fd = image.GetFieldData()
    for key, text in ((STORE_ARRAY, os.path.abspath(store.path)), (SCALARS_ARRAY, name),
                      (ADDRESS_ARRAY, array.GetAddressAsString("vtkDataArray"))):
        strings = vtkStringArray()
        strings.SetName(key)
        strings.InsertNextValue(text)
        fd.AddArray(strings)
    lv = vtkIntArray()
    lv.SetName(LEVEL_ARRAY)
    lv.InsertNextValue(int(level))
    fd.AddArray(lv)
    return image


class MultiscaleReader(ReportingAlgorithm):
    """Read one level of a multiresolution store (``*.ome.zarr``) as ``vtkImageData``.

    ``SetFileName``: the store's directory (or its ``zarr.json``). ``SetLevel``: the
    level to load (0: the finest; ``None``, the default: the finest with at most
    ``SetMaxPoints`` points, 64 Mi by default). The output has the level's world
    spacing and origin, its values as a point array named after the store, and field
    data naming the store, the level and that array (:func:`store_of`), which
    ``HDRVolumeRenderer`` uses to render the store out of core. The level is read in
    ``RequestData`` and kept while the store, its ``zarr.json`` and the level are
    unchanged.

    Examples
    --------
    >>> import tempfile, numpy as np, pv_hdrvol as hv
    >>> path = tempfile.mkdtemp() + "/ramp.ome.zarr"
    >>> _ = hv.write_multiscale(np.ones((80, 70, 90), np.float32), path, progress_bar=False)
    >>> reader = MultiscaleReader()
    >>> reader.SetFileName(path)
    >>> reader.SetMaxPoints(100_000)
    >>> reader.Update()
    True
    >>> reader.GetOutput().GetDimensions(), reader.GetLevel(), reader.GetLevelRead()
    ((45, 35, 40), None, 1)
    """

    def __init__(self):
        super().__init__(nInputPorts=0, nOutputPorts=1, outputType="vtkImageData")
        self._file_name = None
        self._level = None
        self._max_points = DEFAULT_MAX_POINTS
        self._store = None  # (key, MultiscaleStore)
        self._image = None  # (key, level, vtkImageData)

    # -- properties -----------------------------------------------------------------
    def SetFileName(self, path):
        """The store (``str`` or ``os.PathLike``; its ``zarr.json`` names it too; ``None``: none)."""
        path = None if path is None else store_path(path)
        if path != self._file_name:
            self._file_name = path
            self.Modified()

    def GetFileName(self):
        return self._file_name

    def SetLevel(self, level):
        """The level to read, 0 (the finest) to ``GetNumberOfLevels() - 1``; ``None`` or a
        negative number: the finest with at most ``GetMaxPoints()`` points."""
        level = None if level is None or level < 0 else as_int("level", level, low=0)
        if level != self._level:
            self._level = level
            self.Modified()

    def GetLevel(self):
        """The level set (``None``: chosen by the point limit)."""
        return self._level

    def SetMaxPoints(self, n):
        """The most points the default level may have (default 64 Mi)."""
        n = as_int("max_points", n, low=1)
        if n != self._max_points:
            self._max_points = n
            self.Modified()

    def GetMaxPoints(self):
        return self._max_points

    def CanReadFile(self, path):
        """1 if ``path`` is a pv_hdrvol multiresolution store (or its ``zarr.json``), else 0."""
        try:
            from ..outofcore.store import MultiscaleStore

            MultiscaleStore(store_path(path))
        except Exception:  # noqa: BLE001 - any failure means "not one of ours"
            return 0
        return 1

    def GetStore(self):
        """The opened :class:`~pv_hdrvol.MultiscaleStore` (opened again when its
        ``zarr.json`` changes)."""
        from ..outofcore.store import MultiscaleStore

        path = self._file_name
        if path is None:
            raise ValueError("MultiscaleReader has no store to read: call SetFileName(path)")
        try:
            st = os.stat(os.path.join(path, "zarr.json"))
            key = (path, st.st_mtime_ns, st.st_size)
        except OSError:
            key = (path, None, None)
        if self._store is None or self._store[0] != key:
            self._store, self._image = None, None
            self._store = (key, MultiscaleStore(path))  # raises its own error for a bad path
        return self._store[1]

    def GetNumberOfLevels(self):
        return self.GetStore().n_levels

    def GetLevelRead(self):
        """The level the output holds (the one set, or the default)."""
        store = self.GetStore()
        if self._level is None:
            return default_level(store, self._max_points)
        if self._level >= store.n_levels:
            raise ValueError(f"level must be 0 to {store.n_levels - 1} for {store.path}; got {self._level}")
        return self._level

    def GetOutput(self, port=0):
        return self.GetOutputDataObject(port)

    # -- pipeline ---------------------------------------------------------------------
    def RequestInformation(self, request, inInfo, outInfo):
        self._last_error = None
        return self._reporting(self._information, outInfo)

    def _information(self, outInfo):
        store = self.GetStore()
        level = self.GetLevelRead()
        nz, ny, nx = store.levels[level].shape
        spacing, origin = store.level_geometry(level)
        info = outInfo.GetInformationObject(0)
        info.Set(_SDDP.WHOLE_EXTENT(), 0, nx - 1, 0, ny - 1, 0, nz - 1)
        info.Set(vtkDataObject.SPACING(), *(float(v) for v in spacing))
        info.Set(vtkDataObject.ORIGIN(), *(float(v) for v in origin))
        return 1

    def _execute(self, inInfo, outInfo):
        store = self.GetStore()
        level = self.GetLevelRead()
        if self._image is None or self._image[0] != (self._store[0], level):
            self._image = None  # drop the previous level before reading the next
            self._image = ((self._store[0], level), level_image(store, level))
        vtkImageData.GetData(outInfo).ShallowCopy(self._image[1])
        return 1


__all__ = ["ADDRESS_ARRAY", "DEFAULT_MAX_POINTS", "LEVEL_ARRAY", "MultiscaleReader", "SCALARS_ARRAY", "STORE_ARRAY",
           "default_level", "level_image", "store_of", "store_path"]
