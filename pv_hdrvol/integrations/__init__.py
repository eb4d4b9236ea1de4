"""Thin adapters from other tools to the pv_hdrvol pipeline; no numerics here.

- :mod:`~pv_hdrvol.integrations.pyvista_accessor`: ``dataset.hdrvol.render(...)``,
  found by PyVista through the ``pyvista.accessors`` entry point.
- :mod:`~pv_hdrvol.integrations.vtk_algorithm`: ``HDRVolumeRenderer``, a VTK
  algorithm (vtkImageData in, 2-D float RGBA vtkImageData out).
- :mod:`~pv_hdrvol.integrations.vtk_image`: VTK algorithms on those 2-D HDR images:
  ``HDRToneMapper``, ``HDRImageReader``, ``HDRImageWriter`` (.exr, .hdr, .npy) and
  ``HDRUpsampler`` (joint bilateral upsampling guided by the rendered dataset).
- :mod:`~pv_hdrvol.integrations.cli`: the ``pv-hdrvol`` command.

Submodules are imported on demand: importing this package loads neither PyVista nor VTK.
"""
from __future__ import annotations


class VolumeCache:
    """The :class:`~pv_hdrvol.GridVolume` of a dataset, kept while the dataset is unchanged.

    A GridVolume carries what the first render builds (bricks, block ranges), so a
    second render of the same data (another transfer function, camera or size) skips
    that work. The key is the array choice and the dataset's VTK modification time,
    which covers its arrays: after changing values in place through numpy, call
    ``dataset.Modified()``, as VTK pipelines require too.
    """

    def __init__(self):
        self._key = None
        self._volume = None

    def get(self, dataset, scalars, preference):
        from ..data.grid import volume_from_dataset

        key = (scalars, preference, dataset.GetMTime())
        if key != self._key:
            self._volume, self._key = volume_from_dataset(dataset, scalars=scalars, preference=preference), key
        return self._volume


__all__ = ["VolumeCache"]
