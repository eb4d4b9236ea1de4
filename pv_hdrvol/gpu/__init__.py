"""Rendering on an NVIDIA GPU: ``RenderOptions(device="cuda")``.

The grid ray caster's CPU kernels, compiled for CUDA by numba-cuda
(``pip install 'pv_hdrvol[gpu]'``; :mod:`pv_hdrvol.gpu._retarget`), one thread per
pixel, with the volume, tables and skip structure kept on the GPU between renders
(:class:`~pv_hdrvol.gpu.render.CudaRunner`). Importing this package imports nothing
of CUDA: ``numba.cuda`` is first imported, checked and compiled for when a render asks
for ``device="cuda"``; a machine without it then gets a
:class:`DeviceUnavailableError` naming what is missing. See docs/gpu.md.
"""
from __future__ import annotations

from ..raycast.frame import DEVICE_RUNNERS
from .device import DeviceUnavailableError, cuda_module


def _runner():
    from .render import CudaRunner

    return CudaRunner()


DEVICE_RUNNERS["cuda"] = _runner

__all__ = ["DeviceUnavailableError", "cuda_module"]
