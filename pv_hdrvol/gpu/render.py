"""The CUDA side of a :class:`~pv_hdrvol.raycast.grid.GridPlan`: device arrays kept
between executions, one launch a frame (per chunk of rows of tiles when progress is
watched)."""
from __future__ import annotations

import contextlib
import threading
import time

import numpy as np

from . import _kernels as G
from .device import cuda_module


class CudaRunner:
    """Device arrays of one plan, uploaded once and kept while the host array they copy
    is the same object (the volume's bricks, the tables, the skip structure: a camera
    orbit uploads none of them again). Per frame only the camera (21 floats), the
    per-pixel spans of clipped renders and the rows of tiles travel."""

    def __init__(self):
        self.cuda = cuda_module()
        self._lock = threading.RLock()
        self._arrays = {}  # name -> (host array, device array)
        self._out = None
        self.uploaded_bytes = 0  # by this frame (frame())
        self.kernel_seconds = 0.0  # launches to their end, this frame (the first compiles)

    @contextlib.contextmanager
    def frame(self):
        """Hold the runner for one frame (its device outputs and counters are shared by
        the plan's frames: a viewer's worker and a script may render one plan at once)."""
        with self._lock:
            self.uploaded_bytes = 0
            self.kernel_seconds = 0.0
            yield self

    def device_array(self, name, host):
        """``host`` on the device, uploaded only if it is not the array uploaded last
        under ``name``."""
        held = self._arrays.get(name)
        if held is not None and held[0] is host:
            return held[1]
        data = np.ascontiguousarray(host)
        if data.dtype == np.uint8 and _simulated():
            # the simulator runs the kernels as Python, where numpy adds a Python int and
            # a uint8 in uint8 (NEP 50) and a leap radius then wraps; compiled code adds
            # them in int64, as the CPU's does
            data = data.astype(np.int64)
        dev = self.cuda.to_device(data)
        self.uploaded_bytes += host.nbytes
        self._arrays[name] = (host, dev)
        return dev

    def small(self, host):
        """A per-frame array (camera, rows of tiles), uploaded every time."""
        self.uploaded_bytes += host.nbytes
        return self.cuda.to_device(np.ascontiguousarray(host))

    def outputs(self, n, dtype, value):
        """Device output arrays for ``n`` pixels, reused while the size and dtype last."""
        key = (n, np.dtype(dtype), value)
        if self._out is None or self._out[0] != key:
            c = self.cuda
            self._out = (key, (c.device_array((n, 4), dtype), c.device_array(n, np.float64),
                               c.device_array(n, np.int64), c.device_array(n if value else 1, np.float64)))
        return self._out[1]

    def launch(self, kernel, width, rows, *args):
        """``kernel`` over ``width`` columns and the pixel rows of ``rows`` tile rows."""
        from ..raycast.frame import TILE

        # the simulator runs a block's threads as Python threads that contend for the GIL
        # with its polling (a 16 x 16 render: 18-56 s in 8 x 8 blocks, 0.6 s one by one);
        # the kernels share nothing between threads, so the block shape changes no pixel
        bx, by = (1, 1) if _simulated() else G.BLOCK
        grid = ((width + bx - 1) // bx, (rows * TILE + by - 1) // by)
        t = time.perf_counter()
        kernel[grid, (bx, by)](*args)
        self.cuda.synchronize()
        self.kernel_seconds += time.perf_counter() - t

    def describe(self):
        """``metadata["device"]`` of a frame: the GPU and the bytes this frame uploaded."""
        if _simulated():
            gpu = "numba-cuda simulator"
        else:
            name = self.cuda.get_current_device().name
            gpu = name.decode() if isinstance(name, bytes) else str(name)
        return {"name": "cuda", "gpu": gpu, "uploaded_bytes": int(self.uploaded_bytes),
                "kernel_seconds": self.kernel_seconds}

    def tet_outputs(self, n, dtype):
        """Device outputs of a tetrahedral frame (the kernel writes every pixel), reused
        while the size and dtype last."""
        key = ("tets", n, np.dtype(dtype))
        if self._out is None or self._out[0] != key:
            c = self.cuda
            self._out = (key, (c.device_array((n, 4), dtype), c.device_array(n, np.float64),
                               c.device_array(n, np.int64), c.device_array(n, np.int64),
                               c.device_array(n, np.bool_)))
        return self._out[1]

    def tet_frame(self, *args):
        return tet_frame(self, *args)

    def composite_frame(self, *args):
        return composite_frame(self, *args)

    def projection_frame(self, *args):
        return projection_frame(self, *args)


def _simulated():
    import os

    return os.environ.get("NUMBA_ENABLE_CUDASIM") == "1"


def composite_frame(runner, prec, light, bricks, table, sigma, leap, grids, dims, cam, origins, directions, span,
                    width, height, lo, hi, piece, params, out_rgba, out_depth, out_samples):
    """``(cast, finish)`` of a composite render on the GPU: ``cast(tile_rows)`` renders
    those rows of tiles (``raycast.frame.run_in_chunks``), ``finish()`` copies the image
    into the host arrays ``out_*``. Arguments as ``raycast._kernels.render_tiles``."""
    return _grid_frame(runner, G.composite_kernel(prec, light != 0), G.marker(prec), light, bricks, table, sigma, leap,
                       grids, dims, cam, origins, directions, span, width, height, lo, hi, piece, params, None,
                       out_rgba, out_depth, out_samples)


def projection_frame(runner, bricks, table, leap, grids, dims, a, cam, origins, directions, span, width, height,
                     lo, hi, params, out_value, out_rgba, out_depth, out_samples):
    """As :func:`composite_frame`, for a projection: the same loop with the projection's
    marker (``a``: the frame's ``_Extended`` arguments; no level of detail). ``cam``: the
    camera's kernel array, or empty with the rays in ``origins``/``directions``."""
    piece = np.concatenate([lo, hi, np.zeros(3)])
    return _grid_frame(runner, G.projection_kernel(a.projection), a.projection, 0, bricks, table, a.sigmas, leap,
                       grids, dims, cam, origins, directions, span, width, height, lo, hi, piece, params, out_value,
                       out_rgba, out_depth, out_samples)


def _grid_frame(runner, kernel, marker, light, bricks, table, sigma, leap, grids, dims, cam, origins, directions, span,
                width, height, lo, hi, piece, params, out_value, out_rgba, out_depth, out_samples):
    from ..raycast.frame import pixel_rows

    d = runner.device_array
    if light != 0:
        shading, lights, gvec = (d("shading", light[0]), d("lights", light[1]), d("gvec", light[2]))
    else:
        shading = lights = gvec = d("no light", _NO_LIGHT)
    static = (d("bricks", bricks.values), d("offsets", bricks.offsets), d("table", table).reshape(-1),
              d("sigma", sigma), d("leap", leap), d("grids", grids), d("dims", dims))
    cam, origins, directions, span = (runner.small(x) for x in (cam, origins, directions, span))
    rgba, depth, samples, value = runner.outputs(width * height, out_rgba.dtype, out_value is not None)

    def cast(tile_rows):
        rows = runner.small(np.ascontiguousarray(tile_rows, dtype=np.int64))
        runner.launch(kernel, width, tile_rows.shape[0], marker, *static, cam, origins, directions, span, width,
                      height, rows, runner.small(lo), runner.small(hi), runner.small(piece), params, shading, lights,
                      gvec, value, rgba, depth, samples)
        return pixel_rows(tile_rows, height)

    def finish():
        if out_value is not None:
            value.copy_to_host(out_value)
        rgba.copy_to_host(out_rgba)
        depth.copy_to_host(out_depth)
        samples.copy_to_host(out_samples)

    return cast, finish


def tet_frame(runner, prec, mesh, cells_i, cells_f, active, table, grads, shading, lights, hits, cam, own, span,
              width, height, params, out_rgba, out_depth, out_cells, out_pieces, out_guard):
    """As :func:`composite_frame`, for ``raycast._tet_kernels.render_tiles``: the mesh,
    its cell records and tables stay on the device; the boundary crossings ``hits``
    (``raycast.tets.boundary_crossings``, found on the CPU for each view) travel with
    every frame."""
    from ..raycast.frame import pixel_rows

    kernel = G.tet_kernel(prec)
    d = runner.device_array
    static = (d("points", mesh.points), d("cells_i", cells_i), d("cells_f", cells_f), d("active", active),
              d("boundary", mesh.boundary), d("boundary_cell", mesh.boundary_cell),
              d("boundary_face", mesh.boundary_face), d("table", table), d("grads", grads), runner.small(shading),
              runner.small(lights))
    per_view = tuple(runner.small(a) for a in (hits.offsets, hits.t, hits.face, hits.entering, cam, own, span))
    n = width * height
    outs = runner.tet_outputs(n, out_rgba.dtype)
    marker = G.marker(prec)

    def cast(tile_rows):
        rows = runner.small(np.ascontiguousarray(tile_rows, dtype=np.int64))
        runner.launch(kernel, width, tile_rows.shape[0], marker, *static, *per_view, width, height, rows, params,
                      *outs)
        return pixel_rows(tile_rows, height)

    def finish():
        for dev, host in zip(outs, (out_rgba, out_depth, out_cells, out_pieces, out_guard)):
            dev.copy_to_host(host)

    return cast, finish


_NO_LIGHT = np.zeros(1)
