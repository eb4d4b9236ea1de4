"""Compile every CUDA kernel variant of pv_hdrvol.gpu to PTX for a GPU of compute
capability 9.0 (an H100/H200), with no GPU and no driver: numba-cuda types and
lowers the whole kernel and NVVM compiles it, so what only the real CUDA target
rejects (an overload it cannot type, a construct with no CUDA lowering) fails here.

Run as a script (tests/gpu/test_gpu.py runs it in a subprocess, without the simulator):
prints one line per variant, ``<variant> <PTX bytes> <seconds>``.
"""
import sys
import time

import numpy as np
import numba
from numba.cuda import dispatcher as cuda_dispatcher

import pv_hdrvol as hv
from pv_hdrvol.gpu import device, render


class _CC90:
    compute_capability = (9, 0)


# device functions take the compute capability from the current device: there is none
cuda_dispatcher.get_current_device = lambda: _CC90()


class _HostArray(np.ndarray):
    def copy_to_host(self, out):
        out[...] = self


class _HostCuda:
    """Enough of numba.cuda for a runner whose arrays stay on the host."""

    @staticmethod
    def to_device(a):
        return np.array(a).view(_HostArray)

    @staticmethod
    def device_array(shape, dtype):
        return np.empty(shape, dtype).view(_HostArray)

    @staticmethod
    def synchronize():
        pass


launches = []
device.cuda_module = lambda: _HostCuda()
render.cuda_module = device.cuda_module
render.CudaRunner.launch = lambda self, kernel, width, rows, *args: launches.append((kernel, args))
render.CudaRunner.describe = lambda self: {"name": "cuda"}


def main():
    from numba import cuda

    z, y, x = np.mgrid[0:12, 0:12, 0:12]
    vol = np.exp(-((x - 5.5) ** 2 + (y - 5.0) ** 2 + (z - 6.0) ** 2) / 10.0)
    variants = {
        "composite float32": dict(precision="float32"),
        "composite float64": dict(precision="float64"),
        "composite float32 shaded": dict(precision="float32", shade=True),
        "composite float64 shaded": dict(precision="float64", shade=True),
        "projection float32": dict(precision="float32", blending="maximum"),
        "projection float64": dict(precision="float64", blending="additive"),
    }
    variants.update({"tets float32": dict(precision="float32"), "tets float64": dict(precision="float64")})
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    tet = hv.tetmesh_from_arrays(points, np.array([[0, 1, 2, 3]]), np.arange(4.0))
    wanted = sys.argv[1:] or list(variants)
    for name in wanted:
        launches.clear()
        hv.render(tet if name.startswith("tets") else vol, None, "iso", (8, 8), device="cuda", **variants[name])
        kernel, args = launches[0]
        sig = tuple(numba.typeof(np.asarray(a) if isinstance(a, np.ndarray) else a) for a in args)
        t = time.perf_counter()
        ptx, _ = cuda.compile_ptx(kernel.py_func, sig, cc=(9, 0))
        print(f"{name}: {len(ptx)} {time.perf_counter() - t:.1f}", flush=True)


if __name__ == "__main__":
    main()
