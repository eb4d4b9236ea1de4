"""CUDA kernels of the grid ray caster: one thread per pixel, the CPU loops' source.

Nothing here imports ``numba.cuda`` at import time: :func:`composite_kernel` and
:func:`projection_kernel` build a variant (precision, shading) when a render first
asks for it, through :class:`~pv_hdrvol.gpu._retarget.Retarget`, and numba-cuda
compiles it at its first launch. The kernel bodies below are the per-pixel bodies of
``raycast._kernels.render_tiles`` (composite or projection, by the marker's type); the
marching, sampling, classification, lighting and compositing they call are the CPU
kernels' own functions.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import STUBS, compiled_only, kernel
from ..raycast import _kernels as K
from ..raycast._kernels import _march as march, pixel_ray_span, store_pixel  # noqa: F401 (retargeted by name)
from ..raycast._tet_kernels import _march as tet_march, pixel_ray  # noqa: F401

#: Threads of a CUDA block, (x, y): 8 x 8 pixels, a tile of the CPU kernels.
BLOCK = (8, 8)
_SCRATCH = 3 * K.SCRATCH


@kernel
def launch_row(col, y, tile_rows, tile, width, height):
    """The image row of a thread at ``(col, y)`` of a launch over the rows of tiles
    ``tile_rows`` (``y``: the ``y``-th pixel row of them), or -1 past the image's edge.
    (A CPU kernel, retargeted with the rest.)"""
    row = tile_rows[y // tile] * tile + y % tile
    if col >= width or y >= tile_rows.shape[0] * tile or row >= height:
        return -1
    return row


def _grid_pixels(marker, bricks, offs, table, sigma, leap, grids, dims, cam, origins, directions, span, width, height,
                 tile_rows, lo, hi, piece, p, shading, lights, gvec, out_value, out_rgba, out_depth, out_samples):
    """One pixel of ``render_tiles`` per thread: pixel column ``x``, and the ``y``-th row
    of the rows of tiles ``tile_rows`` (``raycast.frame.run_in_chunks``). Composited or
    projected as ``marker`` says (``raycast._composite_kernels``); a projection's values
    go to ``out_value`` (one per pixel; a composite passes a placeholder of another length)."""
    col, y = cuda.grid(2)  # noqa: F821 (injected)
    row = launch_row(col, y, tile_rows, TILE, width, height)  # noqa: F821
    if row < 0:
        return
    pix = row * width + col
    ox, oy, oz, dx, dy, dz, t_near, t_far = pixel_ray_span(cam, origins, directions, span, pix, width, height)
    scratch = cuda.local.array(SCRATCH_LEN, numba.float64)  # noqa: F821
    r, g, b, a, dep, ns, v = march(marker, _make_light(shading, lights, gvec), 0, bricks, offs, table, sigma,  # noqa
                                   leap, grids, dims, ox, oy, oz, dx, dy, dz, lo, hi, piece, p, p.step, scratch,
                                   t_near, t_far)
    store_pixel(out_rgba, out_depth, out_samples, pix, r, g, b, a, dep, ns)
    if out_value.shape[0] == out_rgba.shape[0]:
        out_value[pix] = v


def _tet_pixels(marker, points, cells_i, cells_f, active, btri, bcell, bface, table, grads, shading, lights,
                hit_offsets, hit_t, hit_face, hit_enter, cam, own, span, width, height, tile_rows, p, out_rgba,
                out_depth, out_cells, out_pieces, out_guard):
    """One pixel of ``raycast._tet_kernels.render_tiles`` per thread, as
    :func:`_grid_pixels` places it (the boundary crossings ``hit_*`` come from the
    CPU's rasteriser)."""
    col, y = cuda.grid(2)  # noqa: F821
    row = launch_row(col, y, tile_rows, TILE, width, height)  # noqa: F821
    if row < 0:
        return
    pix = row * width + col
    # a skipped pixel is written too, as the CPU's zeroed outputs leave it
    r = 0.0
    g = 0.0
    b = 0.0
    a = 0.0
    dep = math.inf
    nc = 0
    npc = 0
    guard = False
    lo = hit_offsets[pix]
    hi = hit_offsets[pix + 1]
    own0 = -math.inf
    own1 = math.inf
    t_near = 0.0
    t_far = math.inf
    go = hi > lo
    if own.shape[0] > 0:
        go = go and own[pix, 1] > own[pix, 0]
        own0 = own[pix, 0] / p.length_scale
        own1 = own[pix, 1] / p.length_scale
    if span.shape[0] > 0:
        go = go and span[pix, 1] > span[pix, 0]
        t_near = span[pix, 0] / p.length_scale
        t_far = span[pix, 1] / p.length_scale
    if go:
        ox, oy, oz, dx, dy, dz = pixel_ray(cam, col, row, width, height)
        r, g, b, a, dep, nc, npc, guard = tet_march(marker, points, cells_i, cells_f, active, btri, bcell, bface,
                                                    table, grads, shading, lights, hit_t, hit_face, hit_enter, lo, hi,
                                                    ox, oy, oz, dx, dy, dz, p, own0, own1, t_near, t_far)
    store_pixel(out_rgba, out_depth, out_cells, pix, r, g, b, a, dep, nc)
    out_pieces[pix] = npc
    out_guard[pix] = guard


def _no_light(shading, lights, gvec):
    return 0


def _light_tuple(shading, lights, gvec):
    return shading, lights, gvec


@compiled_only
def _make_light(shading, lights, gvec):
    """The ``light`` of ``_kernels.lit`` from its three arrays (compiled only: resolved
    per variant to 0 or the tuple; a kernel takes arrays, not a tuple of them)."""
    raise NotImplementedError("compiled only")


def _impl(generator, types_by_name):
    """The Python implementation an ``@overload`` generator returns for the argument
    types named in ``types_by_name`` (its other arguments ``None``: it does not look)."""
    names = generator.__code__.co_varnames[:generator.__code__.co_argcount]
    return generator(*(types_by_name.get(name) for name in names))


def _resolve(marker, shaded):
    """Stub -> implementation for the grid loop of one variant (uniform grid, bricks in
    memory; ``marker`` the numba type of a compositing precision's or a projection's
    marker): every stub of the CPU kernels (``_jit.STUBS``), from its generator given the
    variant's types by argument name."""
    i64 = numba.types.int64
    light = numba.types.Tuple((numba.types.float64[:],) * 3) if shaded else i64
    by_name = {"marker": marker, "light": light, "warp": i64, "offs": numba.types.float64[:]}
    resolved = {stub: _impl(stub.implementation, by_name) for stub in STUBS}
    resolved[_make_light] = _light_tuple if shaded else _no_light
    return resolved


_built = {}


def _build(source, resolve):
    from numba import cuda

    from ..raycast.frame import TILE
    from ._retarget import Retarget

    retarget = Retarget(lambda f: cuda.jit(device=True)(f), resolve,
                        inject={"cuda": cuda, "TILE": TILE, "SCRATCH_LEN": _SCRATCH})
    return cuda.jit(retarget.source(source))


def composite_kernel(precision, shaded):
    """The compositing kernel of ``precision`` (``"float32"``/``"float64"``), lit or not."""
    key = ("composite", precision, bool(shaded))
    if key not in _built:
        _built[key] = _build(_grid_pixels, _resolve(numba.typeof(marker(precision)), shaded))
    return _built[key]


def projection_kernel(projection):
    """The kernel of a projection's marker (``raycast._composite_kernels.projection_marker``):
    one per kind (an extreme or an integral; the mode is a value of the marker)."""
    kind = numba.typeof(projection)
    key = ("projection", type(projection).__name__)
    if key not in _built:
        _built[key] = _build(_grid_pixels, _resolve(kind, False))
    return _built[key]


def tet_kernel(precision):
    """The tetrahedral kernel of ``precision`` (shading is a run-time flag there)."""
    key = ("tets", precision)
    if key not in _built:
        _built[key] = _build(_tet_pixels, _resolve(numba.typeof(marker(precision)), False))
    return _built[key]


def marker(precision):
    """The compositing marker of ``precision`` (``raycast.frame.MARKERS``)."""
    return np.float64(0.0) if precision == "float64" else np.float32(0.0)
