"""Thin adapters from other tools to the pv_hdrvol pipeline; no numerics here.

- :mod:`~pv_hdrvol.integrations.pyvista_accessor`: ``dataset.hdrvol.render(...)``,
  found by PyVista through the ``pyvista.accessors`` entry point.
- :mod:`~pv_hdrvol.integrations.vtk_algorithm`: ``HDRVolumeRenderer``, a VTK
  algorithm (vtkImageData in, 2-D float RGBA vtkImageData out).
- :mod:`~pv_hdrvol.integrations.vtk_image`: VTK algorithms on those 2-D HDR images:
  ``HDRToneMapper``, ``HDRImageReader``, ``HDRImageWriter`` (.exr, .hdr, .npy) and
  ``HDRUpsampler`` (joint bilateral upsampling guided by the rendered dataset).
- :mod:`~pv_hdrvol.integrations.vtk_multiscale`: ``MultiscaleReader``, one level of a
  multiresolution store (``*.ome.zarr``) as vtkImageData naming its store, which
  ``HDRVolumeRenderer`` then renders out of core.
- :mod:`~pv_hdrvol.integrations.cli`: the ``pv-hdrvol`` command.

Submodules are imported on demand: importing this package loads neither PyVista nor VTK.
"""
from __future__ import annotations


class VolumeCache:
    """The :class:`~pv_hdrvol.GridVolume` (image data, rectilinear grid) or
    :class:`~pv_hdrvol.TetMesh` (unstructured grid, curvilinear structured grid) of a
    dataset, kept while the dataset is unchanged.

    A GridVolume carries what the first render builds (bricks, block ranges), a TetMesh
    its adjacency and boundary, so a second render of the same data (another transfer
    function, camera or size) skips that work. The key is the array choice, the
    geometry, and each array and the points and cells as VTK objects with their
    modification times: not the dataset object, which a pipeline may hand over as a new
    shallow copy at each execution (ParaView does). With ``dataset_mtime`` (the
    default) the dataset's own modification time too: after changing values in place
    through numpy, call ``dataset.Modified()``, as VTK pipelines require.
    """

    def __init__(self, dataset_mtime=True):
        self._key = None
        self._volume = None
        self._dataset_mtime = dataset_mtime

    def get(self, dataset, scalars, preference):
        key = (scalars, preference, _content_key(dataset), dataset.GetMTime() if self._dataset_mtime else None)
        if key != self._key:
            if dataset.GetClassName() == "vtkUnstructuredGrid":
                from ..data.tets import tetmesh_from_dataset

                self._volume = tetmesh_from_dataset(dataset, scalars=scalars, preference=preference)
            elif dataset.GetClassName() == "vtkStructuredGrid":
                from ..data.tets import tetmesh_from_structured

                self._volume = tetmesh_from_structured(dataset, scalars=scalars, preference=preference)
            else:
                from ..data.grid import volume_from_dataset

                self._volume = volume_from_dataset(dataset, scalars=scalars, preference=preference)
            self._key = key
        return self._volume


def _content_key(dataset):
    """What identifies a dataset's content: its class and geometry, and every array,
    its points and its cells as VTK objects with their modification times."""

    def obj(o):
        return None if o is None else (o.GetAddressAsString("vtkObject"), o.GetMTime())

    parts = [dataset.GetClassName()]
    for attributes in (dataset.GetPointData(), dataset.GetCellData()):
        for i in range(attributes.GetNumberOfArrays()):
            array = attributes.GetAbstractArray(i)
            parts.append((array.GetName(), obj(array)))
    if dataset.GetClassName() == "vtkUnstructuredGrid":
        points = dataset.GetPoints()
        parts += [obj(None if points is None else points.GetData()), obj(dataset.GetCells()),
                  obj(_cell_types(dataset))]
    elif dataset.GetClassName() == "vtkStructuredGrid":  # curvilinear: the points (blanking is a ghost array)
        points = dataset.GetPoints()
        parts += [tuple(dataset.GetExtent()), obj(None if points is None else points.GetData())]
    elif dataset.GetClassName() == "vtkRectilinearGrid":  # the three coordinate arrays are the geometry
        parts += [tuple(dataset.GetExtent()), obj(dataset.GetXCoordinates()), obj(dataset.GetYCoordinates()),
                  obj(dataset.GetZCoordinates())]
    else:
        parts += [tuple(dataset.GetExtent()), tuple(dataset.GetSpacing()), tuple(dataset.GetOrigin())]
        if hasattr(dataset, "GetDirectionMatrix"):
            m = dataset.GetDirectionMatrix()
            parts.append(tuple(m.GetElement(i, j) for i in range(3) for j in range(3)))
    return tuple(parts)


def _cell_types(grid):
    """The per-cell type array of an unstructured grid, without a deprecation warning in
    any VTK: ``GetCellTypes()`` from 9.6 (which deprecates ``GetCellTypesArray``),
    ``GetCellTypesArray()`` before (9.2 deprecates the old ``GetCellTypes``)."""
    from vtkmodules.vtkCommonCore import vtkVersion

    if (vtkVersion.GetVTKMajorVersion(), vtkVersion.GetVTKMinorVersion()) >= (9, 6):
        return grid.GetCellTypes()
    return grid.GetCellTypesArray()


__all__ = ["VolumeCache"]
