"""Whether this process can render on a CUDA GPU, and why not."""
from __future__ import annotations

import os

_GPU_EXTRA = "pip install 'pv_hdrvol[gpu]' (numba-cuda with the CUDA 13 toolkit libraries)"


class DeviceUnavailableError(RuntimeError):
    """``device="cuda"`` asked for on a machine that cannot run it; the message says what
    is missing (numba-cuda, an NVIDIA driver, a GPU)."""


def cuda_module():
    """``numba.cuda``, checked usable: a GPU with a driver, or the simulator
    (``NUMBA_ENABLE_CUDASIM=1``). Raises :class:`DeviceUnavailableError` naming what is
    missing; imports nothing of CUDA before it is asked for."""
    try:
        import numba_cuda  # noqa: F401 (the maintained target; numba's own built-in one is deprecated)
        from numba import cuda
    except ImportError as exc:
        raise DeviceUnavailableError(f"device='cuda' needs numba-cuda, which is not installed ({exc}): "
                                     f"{_GPU_EXTRA}") from None
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        return cuda
    if not cuda.is_available():
        try:
            cuda.current_context()
            reason = "no usable GPU"
        except Exception as exc:  # numba-cuda's CudaSupportError and the driver's errors
            reason = " ".join(str(exc).split())
        raise DeviceUnavailableError(f"device='cuda' found no CUDA GPU: {reason}. Render with device='cpu' "
                                     "(the default), or on a machine with an NVIDIA GPU and its driver")
    return cuda
