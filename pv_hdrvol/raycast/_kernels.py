"""numba kernels for image volumes: arrays in, arrays out.

Nothing here validates or allocates; ``raycast/grid.py`` does that. What a render
compiles is chosen by the types of two arguments, so that it compiles only what it
uses: the precision's marker (a float64, float32 or int64 zero: ``_march``) and the
lighting (``0`` or a tuple of arrays: ``lit``). The rest of the modes are small integer
constants inside the ``GridParams`` tuple (kept in numba's on-disk cache, unlike jitted
callables passed as arguments).

The volume is stored in bricks of ``(8 + 1)**3`` points (one shared plane per
side), so a sample's eight neighbours sit in one small contiguous block of memory
whatever the view direction; a plain (z, y, x) array strides whole planes apart,
which on power-of-two volumes maps every plane to the same cache set.

Per ray: clip to the box, march a lattice of segments of length ``step`` (the last
one shortened to end exactly at the exit), sample each at its midpoint, classify
through one interleaved table (r, g, b, opacity per step; flat, 4 values per entry),
and composite front to back; the plain loop samples a few values ahead before it
classifies and composites them (``_march_plain``).

Indices known to be non-negative are cast to uint64 (``_u``) so numba emits no
negative-index wraparound, which cost a compare and a conditional move per load.
The per-sample loops are ``fused_kernel``s (multiply-adds as FMAs); see ``_jit.py``
for why every kernel states its fastmath flags.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from .._jit import (
    FUSED_JIT_OPTIONS as _FUSED_JIT, IR_INLINE_HELPERS, JIT_OPTIONS as _JIT, compiled_only, fused_kernel,
    fused_parallel_kernel, inline_kernel, kernel, stub_overload, uindex as _u,
)
from ..rays._kernels import CAMERA_FIELDS, camera_ray
from ._composite_kernels import (
    LOG, SYMLOG, U8, _accumulate, _lookup, _opacity, _result, _start, _take, exit_t, lattice_at, lattice_end,
    sample_t, sigma_at, table_position, table_row, ways_of,
)
from ._shading_kernels import (
    SH_AMBIENT, SH_DIFFUSE, SH_FADE, SH_INV_SPACING, SH_POWER, SH_SAMPLED, SH_SPACING, SH_SPECULAR,
)

# bricks of 2**BRICK_SHIFT cells a side (memory layout; independent of skip blocks)
BRICK_SHIFT = 3
# values a ray samples before it classifies them (``_march_plain``'s two phases)
SCRATCH = 8


class GridParams(NamedTuple):
    """Everything scalar a grid render needs, converted once by ``raycast/grid.py``.

    At most 15 fields: numba 0.56 on Python 3.11 rebuilds a NamedTuple used inside
    ``prange`` with a keyword call, which it cannot compile past 15 arguments.
    """

    step: float  # world units
    precision: int
    scale: int
    axis_lo: float  # transfer-function axis value of table entry 0
    axis_inv_range: float  # 1 / (axis_hi - axis_lo)
    linthresh: float
    alpha_stop: float  # stop once accumulated opacity reaches this (1 - termination)
    depth_alpha: float  # accumulated opacity that records depth
    block_shift: int  # log2(edge of an empty-space block, in cells)


# -- geometry --------------------------------------------------------------------------
@inline_kernel
def _slab(o, d, lo, hi, t0, t1):
    """Narrow ``[t0, t1]`` to where ``o + t d`` lies in ``[lo, hi]`` on one axis."""
    if d != 0.0:
        inv = 1.0 / d
        ta = (lo - o) * inv
        tb = (hi - o) * inv
        if ta > tb:
            ta, tb = tb, ta
        return max(t0, ta), min(t1, tb)
    if o < lo or o > hi:
        return 1.0, 0.0
    return t0, t1


@inline_kernel
def _ray_box(ox, oy, oz, dx, dy, dz, lo, hi, t_near, t_far):
    """Entry and exit distances of the ray ``o + t d`` (``t_near <= t <= t_far``) through the box.

    Returns ``(t0, t1)`` with ``t1 <= t0`` when it misses. ``[t_near, t_far]`` is
    ``[0, inf]`` but where clipping planes or a crop box cut the ray
    (``rays/clip.py``) or opaque geometry stops it (``GridPlan.execute(far=...)``).
    """
    t0, t1 = _slab(ox, dx, lo[0], hi[0], t_near, t_far)
    t0, t1 = _slab(oy, dy, lo[1], hi[1], t0, t1)
    return _slab(oz, dz, lo[2], hi[2], t0, t1)


@kernel
def segment_count(t0, t1, step):
    """Segments of length ``step`` from ``t0`` to ``t1`` (the last one shorter): at least 1."""
    n_seg = int(math.ceil((t1 - t0) / step))
    return n_seg if n_seg >= 1 else 1


@inline_kernel
def _owned_slab(o, d, lo, hi, closed, t0, t1):
    """``_slab`` for an owned box, half open: a ray parallel to the axis lies in it for
    ``lo <= o < hi`` (``<= hi`` where ``closed``: the whole box's far face), so that a
    ray in the plane two pieces share belongs to one of them."""
    if d != 0.0:
        return _slab(o, d, lo, hi, t0, t1)
    if o < lo or o > hi or (o == hi and not closed):
        return 1.0, 0.0
    return t0, t1


@kernel
def piece_segments(ox, oy, oz, dx, dy, dz, hi, piece, t0, t1, step, t_far):
    """``(k0, k1, last)``: the lattice segments of one ray that a piece of the volume
    owns -- the full segments ``k0 <= k < k1`` and, if ``last``, the shortened last
    one: those whose midpoints lie in the owned box ``[piece[0:3], piece[3:6])``.

    ``[t0, t1]`` is the ray's span in the whole volume's box ``[0, hi]`` (the lattice
    starts at ``t0`` in every piece). The owned boxes of the pieces tile the whole box
    and share their faces exactly, so the entry of one piece is computed with the same
    arithmetic as the exit of the one before it and each sample has exactly one owner.
    A whole volume owns everything: ``(0, n_full, True)``.
    """
    n_full = max(int(math.ceil((t1 - t0) / step)), 1) - 1
    a, b = _owned_slab(ox, dx, piece[0], piece[3], piece[3] >= hi[0], 0.0, t_far)
    a, b = _owned_slab(oy, dy, piece[1], piece[4], piece[4] >= hi[1], a, b)
    a, b = _owned_slab(oz, dz, piece[2], piece[5], piece[5] >= hi[2], a, b)
    if not b > a:
        return 0, 0, False
    k0 = min(max(int(math.ceil((a - t0) / step - 0.5)), 0), n_full)
    k1 = min(max(int(math.ceil((b - t0) / step - 0.5)), k0), n_full)
    tm = 0.5 * ((t0 + n_full * step) + t1)  # the last segment's midpoint, as the loops compute it
    return k0, k1, a <= tm and (tm < b or b >= t1)


# -- the ray -----------------------------------------------------------------------------
@inline_kernel
def _axis_exit(o, inv_d, b, radius, size):
    """Ray parameter at which ``o + t d`` leaves blocks ``b - radius + 1 .. b + radius - 1``
    along one axis (``inv_d = 1 / d``, 0 for a ray parallel to the axis)."""
    if inv_d > 0.0:
        return ((b + radius) * size - o) * inv_d
    if inv_d < 0.0:
        return ((b - radius + 1) * size - o) * inv_d
    return math.inf


@inline_kernel
def _block(leap, g, x, y, z):
    """Leap radius and block indices of voxel position ``(x, y, z)`` (as the loops' ``stencil`` callers)."""
    nx, ny, nz, x_max, y_max, z_max, shift, by, bx, qy, qx = g
    xi = min(int(min(max(x, 0.0), x_max)), nx - 2)
    yi = min(int(min(max(y, 0.0), y_max)), ny - 2)
    zi = min(int(min(max(z, 0.0), z_max)), nz - 2)
    ib = xi >> shift
    jb = yi >> shift
    kb = zi >> shift
    return leap[_u((kb * by + jb) * bx + ib)], ib, jb, kb


@inline_kernel
def trilinear(bricks, base, nx, ny, nz, qy, qx, x, y, z):
    """Trilinear value at point coordinates ``(x, y, z)`` of a bricked grid at offset ``base``."""
    x = min(max(x, 0.0), nx - 1.0)
    y = min(max(y, 0.0), ny - 1.0)
    z = min(max(z, 0.0), nz - 1.0)
    xi = int(x)  # x = n - 1: fraction 0 in the bricks' repeated edge (exact grid values)
    yi = int(y)
    zi = int(z)
    fx = x - xi
    fy = y - yi
    fz = z - zi
    m = (1 << BRICK_SHIFT) - 1
    pitch = (1 << BRICK_SHIFT) + 1
    brick = ((zi >> BRICK_SHIFT) * qy + (yi >> BRICK_SHIFT)) * qx + (xi >> BRICK_SHIFT)
    q = _u(base + brick * (pitch * pitch * pitch) + ((zi & m) * pitch + (yi & m)) * pitch + (xi & m))
    p1 = _u(pitch)
    p2 = _u(pitch * pitch)
    one = _u(1)
    v000 = np.float64(bricks[q])
    v100 = np.float64(bricks[q + one])
    v010 = np.float64(bricks[q + p1])
    v110 = np.float64(bricks[q + p1 + one])
    v001 = np.float64(bricks[q + p2])
    v101 = np.float64(bricks[q + p2 + one])
    v011 = np.float64(bricks[q + p2 + p1])
    v111 = np.float64(bricks[q + p2 + p1 + one])
    c00 = v000 + fx * (v100 - v000)
    c10 = v010 + fx * (v110 - v010)
    c01 = v001 + fx * (v101 - v001)
    c11 = v011 + fx * (v111 - v011)
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@kernel
def mip_sampler(pgeo, lod, n_levels):
    """The sampler tuple of a ray at level of detail ``lod`` (see ``stencil``): the two
    levels' geometry and scale, read once per ray, not per sample. (No array in it: the
    mip-map itself travels as ``bricks``.)

    The mip-map is one flat array of bricked levels: level ``L`` at offset ``pgeo[L, 0]``,
    ``pgeo[L, 1:4]`` its points along x, y, z and ``pgeo[L, 4:6]`` its brick grid (y, x);
    level ``L`` point ``i`` lies at voxel coordinate ``i * 2**L``.
    """
    level = min(int(lod), n_levels - 1)
    upper = min(level + 1, n_levels - 1)
    f = lod - level if upper > level else 0.0
    g0 = (pgeo[level, 0], pgeo[level, 1], pgeo[level, 2], pgeo[level, 3], pgeo[level, 4], pgeo[level, 5])
    g1 = (pgeo[upper, 0], pgeo[upper, 1], pgeo[upper, 2], pgeo[upper, 3], pgeo[upper, 4], pgeo[upper, 5])
    return g0, 1.0 / (1 << level), g1, 1.0 / (1 << upper), f


@kernel
def mip_value(pyr, sampler, x, y, z):
    """Value between the two levels of the mip-map ``pyr`` that ``sampler`` (``mip_sampler``)
    names, at voxel ``(x, y, z)``."""
    g0, s0, g1, s1, f = sampler
    v0 = trilinear(pyr, g0[0], g0[1], g0[2], g0[3], g0[4], g0[5], x * s0, y * s0, z * s0)
    if f == 0.0:
        return v0
    return v0 + f * (trilinear(pyr, g1[0], g1[1], g1[2], g1[3], g1[4], g1[5], x * s1, y * s1, z * s1) - v0)


@kernel
def _leap_to(k, t0, step, ox, oy, oz, rx, ry, rz, ib, jb, kb, radius, size):
    """The next segment after leaving the empty cube of blocks around ``(ib, jb, kb)``:
    the first lattice segment whose midpoint lies past it (at least ``k + 1``)."""
    te = min(_axis_exit(ox, rx, ib, radius, size), _axis_exit(oy, ry, jb, radius, size),
             _axis_exit(oz, rz, kb, radius, size))
    kn = int(math.ceil((te - t0) / step - 0.5))
    return kn if kn > k else k + 1


# -- rectilinear grids: the warp from nominal voxel coordinates to index coordinates ----------
# ``warp`` is ``0`` (a uniform grid: the helpers below compile to nothing, and the loops are
# the uniform ones) or the tuple ``(cu, inv_w, first, bucket_base, bucket_scale)`` of
# ``raycast.grid.warp_arrays``: per axis (x, then y, then z, concatenated; axis ``a``
# starts at ``base = 0, nx, nx + ny``) the nominal coordinate ``cu[i]`` of point ``i``
# (``(c_i - c_0) / h``, ``h`` the nominal spacing; ``cu[0] = 0``, ``cu[n - 1] = n - 1``) and
# ``inv_w[i] = 1 / (cu[i + 1] - cu[i])``; and a table of uniform buckets over ``[0, n - 1]``:
# ``first[bucket_base[a] + int(u * bucket_scale[a])]`` is a cell at or before the one holding
# ``u`` (a bucket holds at most a cell boundary or two), so the cell is found in O(1).
# Rays stay in nominal coordinates with ``t`` in world units (the map from world to nominal
# coordinates is affine), so steps are world lengths; only the sample positions move.
@compiled_only
def warp_at(warp, base, axis, n, u):
    """The index coordinate (cell ``i`` plus the fraction within it) of nominal voxel
    coordinate ``u`` along ``axis`` (``n`` points, its entries from ``base``): ``u``
    itself on a uniform grid, else clamped to ``[0, n - 1]`` and mapped through the
    axis's cells (compiled only). Trilinear interpolation at the index coordinates is
    the trilinear interpolant of the world cell."""
    raise NotImplementedError("compiled only")


@stub_overload(warp_at, jit_options=_FUSED_JIT, inline="always")
def _warp_at_impl(warp, base, axis, n, u):
    if isinstance(warp, numba.types.Integer):
        return lambda warp, base, axis, n, u: u

    def warped(warp, base, axis, n, u):
        return _warp_lookup(warp[0], warp[1], warp[2], warp[3][axis], warp[4][axis], base, n, u)
    return warped


@compiled_only
def nominal_end(warp, base, n):
    """The nominal coordinate of an axis's last point (``n`` points, entries from
    ``base``): ``n - 1`` on a uniform grid and on a whole rectilinear one, where a piece of
    a rectilinear grid, in the whole grid's nominal frame, ends elsewhere (compiled only)."""
    raise NotImplementedError("compiled only")


@stub_overload(nominal_end, jit_options=_FUSED_JIT, inline="always")
def _nominal_end_impl(warp, base, n):
    if isinstance(warp, numba.types.Integer):
        return lambda warp, base, n: n - 1.0
    return lambda warp, base, n: warp[0][base + n - 1]


@fused_kernel
def _warp_lookup(cu, inv_w, first, bucket_base, bucket_scale, base, n, u):
    """``warp_at`` on a rectilinear axis, a call (inlined at numba IR level, its walk over
    the bucket's cells warned of variables out of scope). The axis's nominal range is
    ``cu[base] = 0`` to ``cu[base + n - 1]`` (``n - 1`` but in a piece of a grid)."""
    u = min(max(u, 0.0), cu[_u(base + n - 1)])
    c = np.int64(first[_u(bucket_base + int(u * bucket_scale))])
    # a bucket holds at most one boundary (``raycast.grid.warp_arrays``): a select, not a
    # branch, which mispredicted at every boundary a ray crossed (1.8x the uniform time
    # with it, engine-sized, one thread). c = n - 1 at u = n - 1 gives n - 1 (inv_w 0 there).
    c += np.int64(u >= cu[_u(base + c + 1)])
    while c < n - 2 and u >= cu[_u(base + c + 1)]:  # more only where the bucket table was capped
        c += 1
    return min(c + (u - cu[_u(base + c)]) * inv_w[_u(base + c)], n - 1.0)


@kernel
def _warped_exit(cu, base, n, o, inv_d, b, radius, size):
    """``_axis_exit`` on a rectilinear axis: the block edges are points ``(b + radius) size``
    and ``(b - radius + 1) size`` (clamped to the grid: the box), at nominal ``cu``."""
    if inv_d > 0.0:
        return (cu[base + min((b + radius) * size, n - 1)] - o) * inv_d
    if inv_d < 0.0:
        return (cu[base + max((b - radius + 1) * size, 0)] - o) * inv_d
    return math.inf


@compiled_only
def leap_past(warp, g, k, t0, step, ox, oy, oz, rx, ry, rz, ib, jb, kb, radius, size):
    """``_leap_to`` on the grid ``warp`` describes (compiled only)."""
    raise NotImplementedError("compiled only")


@stub_overload(leap_past, jit_options=_JIT)
def _leap_past_impl(warp, g, k, t0, step, ox, oy, oz, rx, ry, rz, ib, jb, kb, radius, size):
    if isinstance(warp, numba.types.Integer):
        def uniform(warp, g, k, t0, step, ox, oy, oz, rx, ry, rz, ib, jb, kb, radius, size):
            return _leap_to(k, t0, step, ox, oy, oz, rx, ry, rz, ib, jb, kb, radius, size)
        return uniform

    def warped(warp, g, k, t0, step, ox, oy, oz, rx, ry, rz, ib, jb, kb, radius, size):
        # block edges lie on points, whose nominal coordinates cu holds: the ray leaves the
        # empty cube where it crosses them, so no sample of a block to sample is skipped
        cu = warp[0]
        nx = g[0]
        ny = g[1]
        te = min(_warped_exit(cu, 0, nx, ox, rx, ib, radius, size),
                 _warped_exit(cu, nx, ny, oy, ry, jb, radius, size),
                 _warped_exit(cu, nx + ny, g[2], oz, rz, kb, radius, size))
        kn = int(math.ceil((te - t0) / step - 0.5))
        return kn if kn > k else k + 1
    return warped


# -- shading: specialised at compile time by the type of ``light`` -----------------------------
# ``light`` is ``0`` (unshaded: the loops compile and run none of this) or the tuple
# ``(shading, lights, gvec)`` of ``shading.shading_arrays`` and the bricked gradient vectors
# (``grid._gradient_vector_bricks``; a placeholder for ``shade_gradient="sampled"``).

#: How ``lit`` joins the compositing loops: inlined at numba IR level on numba >= 0.57, so
#: that its gradient overlaps the loop's other work (LLVM does not inline it as a call:
#: engine 256^2, one thread, 94 ns per lit sample as a call, 80 ns inlined; the plain
#: loop unshaded 21 ns); a plain call on numba 0.56, which compiles IR inlining into a
#: loop this size very slowly (``_jit.helper_kernel``). It inlines no other helper and
#: assigns no variable in two branches: numba's IR inlining warns of variables out of
#: scope otherwise. Its lighting, ``_light_colour``, stays a call. Both compositing loops
#: light through ``lit``, so they light alike, bit for bit.
_LIGHT_INLINE = "always" if IR_INLINE_HELPERS else "never"
_LN10 = math.log(10.0)


@kernel
def _eye(shading, dx, dy, dz):
    """The unit world direction towards the eye of a ray of voxel direction ``(dx, dy, dz)``."""
    ex = -dx * shading[SH_SPACING]
    ey = -dy * shading[SH_SPACING + 1]
    ez = -dz * shading[SH_SPACING + 2]
    el = math.sqrt(ex * ex + ey * ey + ez * ez)
    return ex / el, ey / el, ez / el


@fused_kernel
def _trilinear_at(bricks, g, x, y, z):
    """``trilinear`` in the bricks of geometry ``g`` (``_march``), as a call: inlined six
    times into ``_edge_gradient`` it cost numba 0.56 22 s to compile."""
    return trilinear(bricks, 0, g[0], g[1], g[2], g[9], g[10], x, y, z)


@fused_kernel
def _edge_gradient(bricks, g, x, y, z):
    """The gradient of ``lit`` where its stencil leaves the grid (a point within a voxel
    of a face): the difference of the trilinear field over the part of ``[x - 1, x + 1]``
    (per axis) inside the grid, one-sided at the faces."""
    lo = max(x - 1.0, 0.0)
    hi = min(x + 1.0, g[3])
    gx = 0.0
    if hi > lo:
        gx = (_trilinear_at(bricks, g, hi, y, z) - _trilinear_at(bricks, g, lo, y, z)) / (hi - lo)
    lo = max(y - 1.0, 0.0)
    hi = min(y + 1.0, g[4])
    gy = 0.0
    if hi > lo:
        gy = (_trilinear_at(bricks, g, x, hi, z) - _trilinear_at(bricks, g, x, lo, z)) / (hi - lo)
    lo = max(z - 1.0, 0.0)
    hi = min(z + 1.0, g[5])
    gz = 0.0
    if hi > lo:
        gz = (_trilinear_at(bricks, g, x, y, hi) - _trilinear_at(bricks, g, x, y, lo)) / (hi - lo)
    return gx, gy, gz


@compiled_only
def eye_of(light, dx, dy, dz):
    """Per ray: the unit direction towards the eye (``_eye``); unused when ``light`` is 0
    (compiled only)."""
    raise NotImplementedError("compiled only")


@compiled_only
def lit(light, eye, bricks, offs, g, x, y, z, v, r, gg, b, scale, inv_range, linthresh):
    """The colour of a sample under ``light``: ``(r, gg, b)`` unchanged when it is 0, else
    lit by Blinn-Phong (``_shade``) (compiled only)."""
    raise NotImplementedError("compiled only")


@stub_overload(eye_of, jit_options=_FUSED_JIT, inline=_LIGHT_INLINE)
def _eye_of_impl(light, dx, dy, dz):
    if isinstance(light, numba.types.Integer):
        return lambda light, dx, dy, dz: (0.0, 0.0, 0.0)
    return lambda light, dx, dy, dz: _eye(light[0], dx, dy, dz)


@fused_kernel
def _tri_at(a, q, fx, fy, fz):
    """Trilinear value of the bricked array ``a`` in the cell whose first point is at
    ``q``, at fractions ``(fx, fy, fz)``."""
    p1 = (1 << BRICK_SHIFT) + 1
    p2 = p1 * p1
    s = np.uint64(q)
    v000 = np.float64(a[s])
    v100 = np.float64(a[s + np.uint64(1)])
    v010 = np.float64(a[s + np.uint64(p1)])
    v110 = np.float64(a[s + np.uint64(p1 + 1)])
    v001 = np.float64(a[s + np.uint64(p2)])
    v101 = np.float64(a[s + np.uint64(p2 + 1)])
    v011 = np.float64(a[s + np.uint64(p2 + p1)])
    v111 = np.float64(a[s + np.uint64(p2 + p1 + 1)])
    c00 = v000 + fx * (v100 - v000)
    c10 = v010 + fx * (v110 - v010)
    c01 = v001 + fx * (v101 - v001)
    c11 = v011 + fx * (v111 - v011)
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@fused_kernel
def _light_colour(shading, lights, eye, gx, gy, gz, v, r, gg, b, scale, inv_range, linthresh):
    """The lit colour ``(r, g, b)`` (float64, not clamped: HDR) of a sample of value ``v``
    and colour ``(r, gg, b)`` with gradient ``(gx, gy, gz)`` (world units), seen from the
    unit world direction ``eye`` (towards the eye; ``_eye``).

    ``_shading_kernels.light_factors`` with the fade weight of ``fade_weight`` over the
    transfer function's axis (``scale``, ``1 / range``, ``linthresh``), written out:
    the normal is scaled by one reciprocal, a headlight's half vector is the eye
    direction itself, and an integral specular power (up to 64) is taken by repeated
    squaring (``pow`` cost some 20 ns a sample)."""
    # the fade weight (fade_weight): the gradient on the transfer function's axis
    mag = math.sqrt(gx * gx + gy * gy + gz * gz)
    if scale == LOG:
        slope = 1.0 / (v * _LN10) if v > 0.0 else 0.0
    elif scale == SYMLOG:
        slope = 1.0 / ((linthresh + abs(v)) * _LN10)
    else:
        slope = 1.0
    w = mag * slope * inv_range * shading[SH_FADE]
    if not w > 0.0:  # also NaN: unlit, exactly
        return np.float64(r), np.float64(gg), np.float64(b)
    w = min(w, 1.0)
    # the lit colour m c + k (light_factors), the normal turned towards the eye
    ex, ey, ez = eye
    inv = 1.0 / mag
    if gx * ex + gy * ey + gz * ez < 0.0:
        inv = -inv
    nx_ = gx * inv
    ny_ = gy * inv
    nz_ = gz * inv
    dr = 0.0
    dg = 0.0
    db = 0.0
    sr = 0.0
    sg = 0.0
    sb = 0.0
    power = shading[SH_POWER]
    ks = shading[SH_SPECULAR]
    ipow = int(power) if power <= 64.0 else 0
    for k in range(lights.shape[0]):
        if lights[k, 6] != 0.0:
            # a headlight: l = e, and the half vector of l and e is e
            ndl = nx_ * ex + ny_ * ey + nz_ * ez
            ndh = ndl
        else:
            lx = lights[k, 0]
            ly = lights[k, 1]
            lz = lights[k, 2]
            ndl = nx_ * lx + ny_ * ly + nz_ * lz
            hx = lx + ex
            hy = ly + ey
            hz = lz + ez
            hl = math.sqrt(hx * hx + hy * hy + hz * hz)
            ndh = (nx_ * hx + ny_ * hy + nz_ * hz) / hl if hl > 0.0 else 0.0
        if ndl <= 0.0:
            continue
        dr += lights[k, 3] * ndl
        dg += lights[k, 4] * ndl
        db += lights[k, 5] * ndl
        if ks == 0.0 or not ndh > 0.0:
            continue
        if ipow == power:
            # ndh ** ipow by squaring (pow() costs some 20 ns a sample)
            s = 1.0
            base = ndh
            e = ipow
            while e > 0:
                if e & 1:
                    s *= base
                base *= base
                e >>= 1
        else:
            s = ndh ** power
        sr += lights[k, 3] * s
        sg += lights[k, 4] * s
        sb += lights[k, 5] * s
    ka = shading[SH_AMBIENT]
    kd = shading[SH_DIFFUSE]
    return (np.float64(r) * (1.0 + w * (ka + kd * dr - 1.0)) + w * ks * sr,
            np.float64(gg) * (1.0 + w * (ka + kd * dg - 1.0)) + w * ks * sg,
            np.float64(b) * (1.0 + w * (ka + kd * db - 1.0)) + w * ks * sb)




def _shade(light, eye, bricks, offs, g, x, y, z, v, r, gg, b, scale, inv_range, linthresh):
    """``lit``'s implementation: the lit colour of the sample of value ``v`` at voxel
    position ``(x, y, z)`` (clamped to the grid), lit from its gradient by
    ``_light_colour``.

    The gradient (data units per voxel) is the central difference of the trilinear field
    over two voxels, ``(v(x + 1) - v(x - 1)) / 2`` per axis: for a trilinear field the
    trilinear interpolation of the grid points' central differences, which is how it is
    computed inside the grid, from the 32 points of the cell's ``4 x 2 x 2`` stencils
    (the cell's own 8, in cache from sampling it, and 8 more along each axis) addressed
    through ``offs`` (``brick_offsets``): per axis the differences ``P(i + 1) - P(i - 1)``
    and ``P(i + 2) - P(i)`` at the cell's four other corners, interpolated. Within a voxel
    of a face ``_edge_gradient`` takes over. ``shade_gradient="interpolated"``
    interpolates the grid points' gradient vectors ``gvec`` (three bricked components,
    one after the other; the same sums to rounding).

    Each branch returns (no variable is assigned in two branches): numba's IR inlining
    warns of variables out of scope otherwise.
    """
    shading = light[0]
    lights = light[1]
    gvec = light[2]
    nx, ny, nz, x_max, y_max, z_max, shift, by, bx, qy, qx = g
    x = min(max(x, 0.0), x_max)
    y = min(max(y, 0.0), y_max)
    z = min(max(z, 0.0), z_max)
    xi = int(x)
    yi = int(y)
    zi = int(z)
    fx = x - xi
    fy = y - yi
    fz = z - zi
    if shading[SH_SAMPLED] == 0.0:
        # the grid points' gradient vectors, trilinear (xi = n - 1: fraction 0 in the repeated edge)
        n3 = gvec.shape[0] // 3
        q = offs[np.uint64(xi)] + offs[np.uint64(nx + yi)] + offs[np.uint64(nx + ny + zi)]
        return _light_colour(shading, lights, eye, _tri_at(gvec, q, fx, fy, fz), _tri_at(gvec, q + n3, fx, fy, fz),
                             _tri_at(gvec, q + 2 * n3, fx, fy, fz), v, r, gg, b, scale, inv_range, linthresh)
    if xi < 1 or yi < 1 or zi < 1 or xi > nx - 3 or yi > ny - 3 or zi > nz - 3:
        ux, uy, uz = _edge_gradient(bricks, g, x, y, z)
        return _light_colour(shading, lights, eye, ux * shading[SH_INV_SPACING], uy * shading[SH_INV_SPACING + 1],
                             uz * shading[SH_INV_SPACING + 2], v, r, gg, b, scale, inv_range, linthresh)
    x0 = offs[np.uint64(xi - 1)]
    x1 = offs[np.uint64(xi)]
    x2 = offs[np.uint64(xi + 1)]
    x3 = offs[np.uint64(xi + 2)]
    y0 = offs[np.uint64(nx + yi - 1)]
    y1 = offs[np.uint64(nx + yi)]
    y2 = offs[np.uint64(nx + yi + 1)]
    y3 = offs[np.uint64(nx + yi + 2)]
    z0 = offs[np.uint64(nx + ny + zi - 1)]
    z1 = offs[np.uint64(nx + ny + zi)]
    z2 = offs[np.uint64(nx + ny + zi + 1)]
    z3 = offs[np.uint64(nx + ny + zi + 2)]
    # the cell's corners, c<x><y><z> with 1 = lower, 2 = upper
    c111 = np.float64(bricks[np.uint64(x1 + y1 + z1)])
    c211 = np.float64(bricks[np.uint64(x2 + y1 + z1)])
    c121 = np.float64(bricks[np.uint64(x1 + y2 + z1)])
    c221 = np.float64(bricks[np.uint64(x2 + y2 + z1)])
    c112 = np.float64(bricks[np.uint64(x1 + y1 + z2)])
    c212 = np.float64(bricks[np.uint64(x2 + y1 + z2)])
    c122 = np.float64(bricks[np.uint64(x1 + y2 + z2)])
    c222 = np.float64(bricks[np.uint64(x2 + y2 + z2)])
    # along x: P(x2) - P(x0) and P(x3) - P(x1), interpolated in x, at the four (y, z) corners
    lo = c211 - np.float64(bricks[np.uint64(x0 + y1 + z1)])
    d11 = lo + fx * (np.float64(bricks[np.uint64(x3 + y1 + z1)]) - c111 - lo)
    lo = c221 - np.float64(bricks[np.uint64(x0 + y2 + z1)])
    d21 = lo + fx * (np.float64(bricks[np.uint64(x3 + y2 + z1)]) - c121 - lo)
    lo = c212 - np.float64(bricks[np.uint64(x0 + y1 + z2)])
    d12 = lo + fx * (np.float64(bricks[np.uint64(x3 + y1 + z2)]) - c112 - lo)
    lo = c222 - np.float64(bricks[np.uint64(x0 + y2 + z2)])
    d22 = lo + fx * (np.float64(bricks[np.uint64(x3 + y2 + z2)]) - c122 - lo)
    e1 = d11 + fy * (d21 - d11)
    e2 = d12 + fy * (d22 - d12)
    gx = 0.5 * (e1 + fz * (e2 - e1)) * shading[SH_INV_SPACING]
    # along y, at the four (x, z) corners
    lo = c121 - np.float64(bricks[np.uint64(x1 + y0 + z1)])
    d11 = lo + fy * (np.float64(bricks[np.uint64(x1 + y3 + z1)]) - c111 - lo)
    lo = c221 - np.float64(bricks[np.uint64(x2 + y0 + z1)])
    d21 = lo + fy * (np.float64(bricks[np.uint64(x2 + y3 + z1)]) - c211 - lo)
    lo = c122 - np.float64(bricks[np.uint64(x1 + y0 + z2)])
    d12 = lo + fy * (np.float64(bricks[np.uint64(x1 + y3 + z2)]) - c112 - lo)
    lo = c222 - np.float64(bricks[np.uint64(x2 + y0 + z2)])
    d22 = lo + fy * (np.float64(bricks[np.uint64(x2 + y3 + z2)]) - c212 - lo)
    e1 = d11 + fx * (d21 - d11)
    e2 = d12 + fx * (d22 - d12)
    gy = 0.5 * (e1 + fz * (e2 - e1)) * shading[SH_INV_SPACING + 1]
    # along z, at the four (x, y) corners
    lo = c112 - np.float64(bricks[np.uint64(x1 + y1 + z0)])
    d11 = lo + fz * (np.float64(bricks[np.uint64(x1 + y1 + z3)]) - c111 - lo)
    lo = c212 - np.float64(bricks[np.uint64(x2 + y1 + z0)])
    d21 = lo + fz * (np.float64(bricks[np.uint64(x2 + y1 + z3)]) - c211 - lo)
    lo = c122 - np.float64(bricks[np.uint64(x1 + y2 + z0)])
    d12 = lo + fz * (np.float64(bricks[np.uint64(x1 + y2 + z3)]) - c121 - lo)
    lo = c222 - np.float64(bricks[np.uint64(x2 + y2 + z0)])
    d22 = lo + fz * (np.float64(bricks[np.uint64(x2 + y2 + z3)]) - c221 - lo)
    e1 = d11 + fx * (d21 - d11)
    e2 = d12 + fx * (d22 - d12)
    gz = 0.5 * (e1 + fy * (e2 - e1)) * shading[SH_INV_SPACING + 2]
    return _light_colour(shading, lights, eye, gx, gy, gz, v, r, gg, b, scale, inv_range, linthresh)


@stub_overload(lit, jit_options=_FUSED_JIT, inline=_LIGHT_INLINE)
def _lit_impl(light, eye, bricks, offs, g, x, y, z, v, r, gg, b, scale, inv_range, linthresh):
    if isinstance(light, numba.types.Integer):
        return lambda light, eye, bricks, offs, g, x, y, z, v, r, gg, b, scale, inv_range, linthresh: (r, gg, b)
    return _shade


# -- the stencil of the plain loop: bricks in memory, or the pages of an out-of-core volume ------
#: Points a side of a page (a chunk of an out-of-core store): ``2**PAGE_SHIFT``.
PAGE_SHIFT = 6
#: Points a side of a page's slot in the pool: the chunk, one point before, two after.
SLOT_EDGE = (1 << PAGE_SHIFT) + 3


def is_mip_sampler(offs):
    """Whether the numba type ``offs`` is a ``mip_sampler`` tuple (its first item the
    lower level's geometry, itself a tuple) rather than a storage's offsets."""
    return isinstance(offs, numba.types.BaseTuple) and isinstance(offs[0], numba.types.BaseTuple)


@compiled_only
def stencil(bricks, offs, oy_off, oz_off, ib, jb, kb, by, bx, x, y, z, xi, yi, zi):
    """The trilinear value at voxel position ``(x, y, z)`` (clamped to the volume;
    ``xi = int(x)`` ...; ``(ib, jb, kb)`` its empty-space block, ``bx, by`` blocks per
    row and slab) for ``_march_plain`` (compiled only).

    ``offs`` picks the storage at compile time. A ``mip_sampler`` tuple: a ray with a
    level of detail, ``bricks`` the mip-map, interpolated between two levels
    (``mip_value``). An array: the volume in memory,
    ``bricks`` bricked by ``make_bricks``, point ``(i, j, k)`` at ``offs[i] +
    offs[oy_off + j] + offs[oz_off + k]`` (``brick_offsets``). A tuple ``(level, base,
    dims, place, span)``: an out-of-core volume whose resident chunks sit in the pool
    ``bricks``, each in a slot of ``SLOT_EDGE**3`` values (z, y, x) holding its level's
    points ``2**PAGE_SHIFT c - 1`` to ``2**PAGE_SHIFT (c + 1) + 1`` on each axis (the
    chunk and an apron from its neighbours: ``outofcore/cache.py``), so that every sample
    of a block reads one slot. Per empty-space block (which must be ``2**PAGE_SHIFT``
    cells): ``level[b]`` (uint8), the level ``L`` it samples, and ``base[b]``, where
    level-``L`` point ``(i, j, k)`` of its slot sits: ``base + (k SLOT_EDGE + j) SLOT_EDGE
    + i``. Per level: ``dims[L]``, its points (x, y, z), and ``place[L] = ((2**L - 1) / 2,
    2**-L)``: its point ``j`` lies at voxel coordinate ``2**L j + (2**L - 1) / 2``.

    At level 0 the position, the eight values and the arithmetic are those of the bricks
    in memory, so an out-of-core render at level 0 is the in-core one bit for bit.
    """
    raise NotImplementedError("compiled only")


@stub_overload(stencil, jit_options=_FUSED_JIT, inline="always")
def _stencil_impl(bricks, offs, oy_off, oz_off, ib, jb, kb, by, bx, x, y, z, xi, yi, zi):
    # Inlined into the loops (a call per sample, passing arrays, cost 5-20 %), so the
    # full-resolution stencils are written out and call no other jitted helper: numba
    # 0.56 deep-copies the dispatchers an inlined function refers to (compiling the loop
    # took minutes), and its IR inlining of nested inlines trips its own scope checks.
    if is_mip_sampler(offs):
        def mipmapped(bricks, offs, oy_off, oz_off, ib, jb, kb, by, bx, x, y, z, xi, yi, zi):
            return mip_value(bricks, offs, x, y, z)  # a call, as it always was
        return mipmapped
    if isinstance(offs, numba.types.Array):
        def in_memory(bricks, offs, oy_off, oz_off, ib, jb, kb, by, bx, x, y, z, xi, yi, zi):
            fx = x - xi
            fy = y - yi
            fz = z - zi
            # x = n - 1: fraction 0 in the bricks' repeated edge (exact grid values)
            q = np.uint64(offs[np.uint64(xi)] + offs[oy_off + np.uint64(yi)] + offs[oz_off + np.uint64(zi)])
            one = np.uint64(1)
            p1 = np.uint64((1 << BRICK_SHIFT) + 1)
            p2 = p1 * p1
            v000 = np.float64(bricks[q])
            v100 = np.float64(bricks[q + one])
            v010 = np.float64(bricks[q + p1])
            v110 = np.float64(bricks[q + p1 + one])
            v001 = np.float64(bricks[q + p2])
            v101 = np.float64(bricks[q + p2 + one])
            v011 = np.float64(bricks[q + p2 + p1])
            v111 = np.float64(bricks[q + p2 + p1 + one])
            c00 = v000 + fx * (v100 - v000)
            c10 = v010 + fx * (v110 - v010)
            c01 = v001 + fx * (v101 - v001)
            c11 = v011 + fx * (v111 - v011)
            c0 = c00 + fy * (c10 - c00)
            c1 = c01 + fy * (c11 - c01)
            return c0 + fz * (c1 - c0)
        return in_memory

    def paged(bricks, offs, oy_off, oz_off, ib, jb, kb, by, bx, x, y, z, xi, yi, zi):
        level_of = offs[0]
        base_of = offs[1]
        dims = offs[2]
        place = offs[3]
        b = np.uint64((kb * by + jb) * bx + ib)
        level = np.int64(level_of[b])
        base = base_of[b]
        h = place[level, 0]
        s = place[level, 1]
        n_x = dims[level, 0]
        n_y = dims[level, 1]
        n_z = dims[level, 2]
        u = min(max((x - h) * s, 0.0), n_x - 1.0)
        v = min(max((y - h) * s, 0.0), n_y - 1.0)
        w = min(max((z - h) * s, 0.0), n_z - 1.0)
        u0 = int(u)
        v0 = int(v)
        w0 = int(w)
        fx = u - u0
        fy = v - v0
        fz = w - w0
        e = SLOT_EDGE
        du = min(u0 + 1, n_x - 1) - u0  # the far edge: fraction 0, the edge value again
        dv = (min(v0 + 1, n_y - 1) - v0) * e
        dw = (min(w0 + 1, n_z - 1) - w0) * (e * e)
        q = base + (w0 * e + v0) * e + u0
        v000 = np.float64(bricks[np.uint64(q)])
        v100 = np.float64(bricks[np.uint64(q + du)])
        v010 = np.float64(bricks[np.uint64(q + dv)])
        v110 = np.float64(bricks[np.uint64(q + dv + du)])
        v001 = np.float64(bricks[np.uint64(q + dw)])
        v101 = np.float64(bricks[np.uint64(q + dw + du)])
        v011 = np.float64(bricks[np.uint64(q + dw + dv)])
        v111 = np.float64(bricks[np.uint64(q + dw + dv + du)])
        c00 = v000 + fx * (v100 - v000)
        c10 = v010 + fx * (v110 - v010)
        c01 = v001 + fx * (v101 - v001)
        c11 = v011 + fx * (v111 - v011)
        c0 = c00 + fy * (c10 - c00)
        c1 = c01 + fy * (c11 - c01)
        return c0 + fz * (c1 - c0)
    return paged


@compiled_only
def span_of(offs, ib, jb, kb, by, bx):
    """Segments a sample in block ``(ib, jb, kb)`` stands for (compiled only): 1 for a
    volume in memory (``offs`` an array) and for a mip-map (a ``mip_sampler``); an
    out-of-core volume's ``offs`` tuple carries a fifth array, per block the ``uint8``
    count ``2**(L - F)`` (``_march_plain``)."""
    raise NotImplementedError("compiled only")


@stub_overload(span_of, jit_options=_FUSED_JIT, inline="always")
def _span_of_impl(offs, ib, jb, kb, by, bx):
    if isinstance(offs, numba.types.Array) or is_mip_sampler(offs):
        return lambda offs, ib, jb, kb, by, bx: 1

    def paged(offs, ib, jb, kb, by, bx):
        return np.int64(offs[4][np.uint64((kb * by + jb) * bx + ib)])
    return paged


@fused_kernel
def probe(bricks, offs, leap, g, x, y, z):
    """One sample off the loop's batches: ``(radius, ib, jb, kb, v)`` at voxel position
    ``(x, y, z)`` (clamped to the grid), the block radius from ``leap`` (0: sample) with
    the block indices, and the value through ``stencil`` (NaN where ``radius != 0``).
    The plain loop's last segment and the labelled loop's samples (``_kernels_ext``)."""
    nx, ny, nz, x_max, y_max, z_max, shift, by, bx, qy, qx = g
    x = min(max(x, 0.0), x_max)
    y = min(max(y, 0.0), y_max)
    z = min(max(z, 0.0), z_max)
    xi = int(x)
    yi = int(y)
    zi = int(z)
    ib = min(xi, nx - 2) >> shift
    jb = min(yi, ny - 2) >> shift
    kb = min(zi, nz - 2) >> shift
    radius = leap[_u((kb * by + jb) * bx + ib)]
    if radius != 0:
        return radius, ib, jb, kb, math.nan
    return 0, ib, jb, kb, stencil(bricks, offs, _u(nx), _u(nx + ny), ib, jb, kb, by, bx, x, y, z, xi, yi, zi)


@inline_kernel
def midpoint_lattice(ox, oy, oz, dx, dy, dz, t0, step):
    """``(bx, by, bz, sx, sy, sz)``: the midpoint of full segment ``k`` lies at
    ``(bx, by, bz) + k (sx, sy, sz)``. Inlined into both compositing loops
    (``_march_plain``, ``_kernels_ext._composite_ext``), so they place samples alike."""
    tb = t0 + 0.5 * step
    return ox + tb * dx, oy + tb * dy, oz + tb * dz, step * dx, step * dy, step * dz


@fused_kernel
def _march_plain(marker, proj, comp, light, warp, bricks, offs, table, sigma, leap, g, ox, oy, oz, dx, dy, dz, t0, t1,
                 p, step, scratch, k0, k1, last):
    """The sampling and compositing loop of ``_march``, compiled once per ``marker`` (a
    precision or a projection: ``_composite_kernels``) and storage (the type of
    ``offs``: ``stencil``). ``proj`` and ``comp`` are the marker or ``None``
    (``ways_of``): each sample goes the way of the one that is not ``None``, and numba
    prunes the other way before typing it.

    Sample ``k`` lies at ``t0 + (k + 1/2) step``, the last segment shortened to the
    exit. The loop is arranged for a short chain of dependent operations per sample,
    which bounds how many samples the CPU overlaps:

    - sample ``k`` lies at ``b + k s`` (``b``, ``s`` per ray; fused multiply-adds),
      a function of ``k`` alone, so empty-space leaps change no sample;
    - its brick offset is the sum of three per-axis entries of ``offs``
      (``brick_offsets``), three loads instead of a chain of multiplies;
    - the loop is compiled with fused multiply-adds (``fused_kernel``);
    - it runs in two phases: it samples the next few values (2, then 4, then up to
      ``SCRATCH``) into ``scratch``, then classifies and composites them. The table
      lookups and the compositing chain of one batch then overlap the brick loads of
      the next instead of waiting behind them (engine, 256², one thread: 0.86x the
      time of one sample at a time with a transparent transfer function, 1.00-1.04x
      with an opaque one, which stops within a batch and drops its rest). The samples,
      their order and the arithmetic are those of one sample at a time, so the bits
      are too.

    The labelled loop (``_kernels_ext._composite_ext``) repeats this arithmetic, so a
    composite label gives the same bits.

    ``light`` (``lit``): 0 compiles the loop unlit; the lighting tuple lights each
    sample that adds opacity, in phase 2, at its position recomputed from its ``k``
    (the same arithmetic as phase 1's): the same lighting as the labelled loop's, so a
    shaded composite label gives the same bits too.

    ``offs`` holds the x, then y, then z offsets (``nx + ny + nz`` entries);
    ``scratch`` is float64 with ``3 * SCRATCH`` entries (values, then their ``k``, then
    the segments each stands for), one per lane of ``render_tiles`` (a lane runs on one
    thread at a time).

    ``span_of(offs, ...)`` is the number of segments a sample of a block stands for: 1
    for a volume in memory (compiled away), ``2**(L - F)`` in an out-of-core block of
    level ``L`` when the frame steps at level ``F``'s: the block is sampled once per
    ``2**(L - F)`` segments, at their centre (if that lies in a block to sample), with
    the opacity of their length from the extinction column; the segments' count and
    the lattice are unchanged, so a frame at one level samples as before. Segments
    ``k0 <= k < k1`` and, if ``last``, the last one are sampled (``piece_segments``).

    ``warp`` (``warp_at``): 0 samples a uniform grid; a rectilinear grid's warp moves each
    sample from its nominal position to its index coordinates (and the leaps and lit
    positions with it); the samples' ``t`` and the arithmetic after are the same.
    """
    nx, ny, nz, x_max, y_max, z_max, shift, by, bx, qy, qx = g
    y_base = nx
    z_base = nx + ny
    # the nominal positions' ranges (x_max... are the index coordinates')
    u_max = nominal_end(warp, 0, nx)
    v_max = nominal_end(warp, y_base, ny)
    w_max = nominal_end(warp, z_base, nz)
    size = 1 << p.block_shift
    n_table = table.shape[0] // 4
    u8 = p.precision == U8
    rx = 1.0 / dx if dx != 0.0 else 0.0  # reciprocals for block exits (0: never exits)
    ry = 1.0 / dy if dy != 0.0 else 0.0
    rz = 1.0 / dz if dz != 0.0 else 0.0
    n_seg = int(math.ceil((t1 - t0) / step))
    if n_seg < 1:
        n_seg = 1
    bx0, by0, bz0, sx, sy, sz = midpoint_lattice(ox, oy, oz, dx, dy, dz, t0, step)
    eye = eye_of(light, dx, dy, dz)
    oy_off = _u(nx)
    oz_off = _u(nx + ny)
    state = _start(marker)
    depth = math.inf
    samples = 0
    stopped = False
    k = k0
    kf = float(k0)  # k as a float, counted (no conversion per sample)
    n_full = n_seg - 1
    k1 = lattice_end(marker, k1, last)  # an extreme's lattice points: one more than the full segments
    cap = SCRATCH
    chunk = 2
    while k < k1:
        # phase 1: the next `chunk` values that are not NaN, with their segment indices
        # (k after the sample), leaping empty blocks
        j = 0
        while j < chunk and k < k1:
            x = warp_at(warp, 0, 0, nx, min(max(lattice_at(marker, bx0, sx, ox, dx, t0, kf, step), 0.0), u_max))
            y = warp_at(warp, y_base, 1, ny, min(max(lattice_at(marker, by0, sy, oy, dy, t0, kf, step), 0.0), v_max))
            z = warp_at(warp, z_base, 2, nz, min(max(lattice_at(marker, bz0, sz, oz, dz, t0, kf, step), 0.0), w_max))
            xi = int(x)
            yi = int(y)
            zi = int(z)
            ib = min(xi, nx - 2) >> shift
            jb = min(yi, ny - 2) >> shift
            kb = min(zi, nz - 2) >> shift
            radius = leap[_u((kb * by + jb) * bx + ib)]
            if radius != 0:
                k = leap_past(warp, g, k, t0, step, ox, oy, oz, rx, ry, rz, ib, jb, kb, radius, size)
                kf = float(k)
                continue
            # segments this sample stands for: 1, or a coarse out-of-core block's 2**(L - F)
            m = span_of(offs, ib, jb, kb, by, bx)
            kc = kf
            if m > 1:  # one sample at the centre of m segments (of this piece), in a block to sample
                m = min(m, k1 - k)
                kc = kf + 0.5 * (m - 1)
                xc = warp_at(warp, 0, 0, nx, min(max(bx0 + kc * sx, 0.0), u_max))
                yc = warp_at(warp, y_base, 1, ny, min(max(by0 + kc * sy, 0.0), v_max))
                zc = warp_at(warp, z_base, 2, nz, min(max(bz0 + kc * sz, 0.0), w_max))
                ic = min(int(xc), nx - 2) >> shift
                jc = min(int(yc), ny - 2) >> shift
                kcb = min(int(zc), nz - 2) >> shift
                if leap[_u((kcb * by + jc) * bx + ic)] == 0:
                    x, y, z = xc, yc, zc
                    xi, yi, zi = int(xc), int(yc), int(zc)
                    ib, jb, kb = ic, jc, kcb
                else:
                    kc = kf
            # trilinear in the bricks (the labelled loop's stencil too: _kernels_ext._sample),
            # in the pages of an out-of-core volume, or between two levels of a mip-map
            v = stencil(bricks, offs, oy_off, oz_off, ib, jb, kb, by, bx, x, y, z, xi, yi, zi)
            k += m
            kf += m
            if v != v:  # NaN in the stencil: empty
                continue
            scratch[_u(j)] = v
            scratch[_u(cap + j)] = kc + 1.0
            scratch[_u(2 * cap + j)] = m
            j += 1
        # phase 2: classify and composite them in order; at termination the rest of the
        # chunk is dropped, so every count and bit is that of one sample at a time
        for jj in range(j):
            samples += 1
            v = scratch[_u(jj)]
            # one of proj and comp is None: numba prunes the branch of the None one before typing
            if proj is not None:
                # at the sample's lattice point (an extreme) or segment midpoint, and its length
                kk = scratch[_u(cap + jj)] - 1.0
                state, stopped = _take(marker, state, v, sample_t(marker, t0, kk, step),
                                       scratch[_u(2 * cap + jj)] * step, table, sigma, n_table, p)
                if stopped:
                    break
            if comp is not None:
                r, gg, b, a_i, i, f = table_row(table, 0, n_table, table_position(v, p), u8)
                span = scratch[_u(2 * cap + jj)]
                if span > 1.0 and a_i > 0.0:  # m segments of a coarse block: from the extinction
                    a_i = -math.expm1(-sigma_at(sigma, i, f) * span * step)
                if a_i > 0.0:  # as skipped samples: skipping then changes no bit
                    kk = scratch[_u(cap + jj)] - 1.0  # the sample's k, as phase 1 placed it
                    r, gg, b = lit(light, eye, bricks, offs, g, warp_at(warp, 0, 0, nx, bx0 + kk * sx),
                                   warp_at(warp, y_base, 1, ny, by0 + kk * sy),
                                   warp_at(warp, z_base, 2, nz, bz0 + kk * sz), v, r, gg, b, p.scale,
                                   p.axis_inv_range, p.linthresh)
                    state = _accumulate(marker, p.precision, state, a_i, r, gg, b)
                    alpha = _opacity(marker, state)
                    if depth == math.inf and alpha >= p.depth_alpha:
                        depth = t0 + (scratch[_u(cap + jj)] - 0.5) * step
                    if alpha >= p.alpha_stop:
                        stopped = True
                        break
        if stopped:
            break
        chunk = min(2 * chunk, cap)
    if last and not stopped:
        # the last segment ends exactly at the exit and is shorter than a step: its
        # opacity comes from the extinction column (the per-step one may have rounded to 1)
        ta = t0 + n_full * step
        tm = exit_t(marker, ta, t1)
        # clamped as the full segments' positions, through the same stencil
        xm = min(max(warp_at(warp, 0, 0, nx, ox + tm * dx), 0.0), x_max)
        ym = min(max(warp_at(warp, y_base, 1, ny, oy + tm * dy), 0.0), y_max)
        zm = min(max(warp_at(warp, z_base, 2, nz, oz + tm * dz), 0.0), z_max)
        radius, ib, jb, kb, v = probe(bricks, offs, leap, g, xm, ym, zm)
        if radius == 0 and v == v:
            samples += 1
            if proj is not None:
                state, stopped = _take(marker, state, v, tm, t1 - ta, table, sigma, n_table, p)
            if comp is not None:
                r, gg, b, a_i, i, f = _lookup(table, v, n_table, p)
                if a_i > 0.0:
                    sg = sigma_at(sigma, i, f)
                    r, gg, b = lit(light, eye, bricks, offs, g, xm, ym, zm, v, r, gg, b, p.scale, p.axis_inv_range,
                                   p.linthresh)
                    state = _accumulate(marker, p.precision, state, -math.expm1(-sg * (t1 - ta)), r, gg, b)
                    if depth == math.inf and _opacity(marker, state) >= p.depth_alpha:
                        depth = tm
    return _result(marker, state, depth, samples, table, sigma, n_table, p)


@kernel
def _march(marker, light, warp, bricks, offs, table, sigma, leap, grids, dims, ox, oy, oz, dx, dy, dz, lo, hi, piece,
           p, step, scratch, t_near, t_far):
    """Composite or project one ray. Returns ``(r, g, b, alpha, depth, samples, value)``
    (``value``: a projection's, else NaN).

    One loop serves every storage, ``_march_plain``, which batches samples in the
    float64 array ``scratch`` of ``3 * SCRATCH`` entries, one per lane. The type of
    ``offs`` names the storage (``stencil``): the brick offsets per axis of the volume
    ``bricks`` in memory, an out-of-core volume's pages, or a ``mip_sampler`` tuple: a
    ray with a level of detail samples the mip-map, passed as ``bricks``.

    ``grids`` holds the shapes (z, y, x) of the empty-space block grid, then of the
    brick grid. ``leap`` (flat over the block grid) is 0 for a block to sample, else the
    Chebyshev distance ``r`` (in blocks) to the nearest such block: the ray may leave
    the whole cube of blocks within ``r - 1`` at once (empty-space leaping).

    ``table`` is flat, 4 values per entry: ``(r, g, b, a)`` with ``a`` the opacity of one full ``step``
    (opacity-corrected on the host), so full segments need no exponential; ``sigma``
    (extinction per world unit, same rows) serves the shorter last segment.

    Needs at least 2 points on every axis (a flat volume has no thickness and is not
    rendered: ``raycast/grid.py`` returns an empty image before calling).

    The ray ``o + t d`` is in voxel coordinates (point ``(i, j, k)`` at ``(i, j, k)``)
    with ``t`` in world units: ``d`` is the world direction divided by the spacing.

    ``[lo, hi]`` is the whole volume's box, where the lattice starts and ends; ``piece``
    (9 values) the box this render owns, ``piece[0:3]`` to ``piece[3:6]``, and the
    offset ``piece[6:9]`` of the first point of ``bricks`` in the whole volume: a piece
    of a volume distributed over processes samples only the segments whose midpoints
    it owns (``piece_segments``), in its own points, so that the pieces' partial images
    composited in depth order are the whole render. A whole volume: ``piece`` is
    ``lo, hi, 0``.

    Front to back, each sample adds ``w = (1 - A) a_i`` to the accumulated opacity
    ``A`` and ``w c_i`` to the colour. ``1 - a_i`` is never formed: in float32,
    1 - 1e-7 rounds to 1 - 1.19e-7, and multiplying transmittance by it loses 19% over
    4,096 samples; ``A`` itself is small there and sums exactly. float32 works in
    float32 arithmetic with compensated (Kahan) sums. ``float16``/``uint8`` apply the
    conventional ``over`` operator in that buffer precision, for comparison.

    ``marker`` (a float64, float32 or int64 zero, ``frame.MARKERS``) picks the
    precision at compile time: only that precision's compositing is compiled; float16
    and uint8 share the emulated one (``_marker_precision``). ``light`` is 0 (unshaded)
    or the lighting tuple ``(shading, lights, gvec)`` (``lit``), also chosen at compile
    time: an unshaded render compiles and runs no lighting. ``warp`` (``warp_at``) is 0
    for a uniform grid, else a rectilinear grid's warp, also by type. (A ray with a
    level of detail is neither lit nor warped: ``raycast/grid.py`` sends a lit one to
    the extended loop and refuses a lens on a rectilinear grid.)
    """
    t0, t1 = _ray_box(ox, oy, oz, dx, dy, dz, lo, hi, t_near, t_far)
    if not t1 > t0:
        return 0.0, 0.0, 0.0, 0.0, math.inf, 0, math.nan
    k0, k1, last = piece_segments(ox, oy, oz, dx, dy, dz, hi, piece, t0, t1, step, t_far)
    if k1 <= k0 and not last:
        return 0.0, 0.0, 0.0, 0.0, math.inf, 0, math.nan
    ox -= piece[6]  # into the piece's own points (t is unchanged)
    oy -= piece[7]
    oz -= piece[8]
    nx = dims[0]
    ny = dims[1]
    nz = dims[2]
    g = (nx, ny, nz, nx - 1.0, ny - 1.0, nz - 1.0, p.block_shift, grids[1], grids[2], grids[4], grids[5])
    proj, comp = ways_of(marker)
    return _march_plain(marker, proj, comp, light, warp, bricks, offs, table, sigma, leap, g, ox, oy, oz, dx, dy, dz,
                        t0, t1, p, step, scratch, k0, k1, last)


@fused_parallel_kernel
def render_tiles(marker, bricks, offs, table, sigma, leap, grids, dims, cam, origins, directions, span, width, height,
                 tile, tile_rows, lanes, lo, hi, piece, p, light, warp, out_rgba, out_depth, out_samples, out_value):
    """Fill the pixels of the tiles in the rows of tiles ``tile_rows``, composited or
    projected as ``marker`` says (``_composite_kernels``); a projection's values go to
    ``out_value`` (one per pixel; a composite passes a placeholder of another length).

    Rays come from ``cam`` (``Camera.kernel_array``, then the volume's origin and the
    reciprocal of its spacing: ``camera_ray`` in voxel coordinates) or, when ``cam`` is
    empty, from ``origins`` and ``directions`` (one row per pixel, voxel coordinates).
    ``span`` (one ``[near, far]`` row per pixel, world distances along the ray; or
    empty: ``[0, inf]``) limits each ray: clipping planes and a crop box
    (``rays/clip.py``), and opaque geometry in front of or inside the volume. ``light``: 0, or
    the lighting of a shaded render; ``warp``: 0, or a rectilinear grid's (``_march``).

    Tiles of ``tile x tile`` rays walk nearly the same bricks, so they stay in cache
    (a row of rays sweeps a whole slab of the volume). Lane ``l`` renders tiles
    ``l, l + lanes, ...``, one lane per thread (``frame.tile_lanes``): each thread's work
    is spread evenly over the image (balanced without dynamic scheduling, which numba
    0.56 lacks), and the tile it renders next lies a few tiles on along the row, where
    most of the last one's bricks are still in cache.
    """
    for lane in numba.prange(lanes):
        scratch = np.empty(3 * SCRATCH)
        for i in range(lane_pixels(lane, lanes, tile_rows, tile, width)):
            pix = lane_pixel(i, lane, lanes, tile_rows, tile, width, height)
            if pix >= 0:
                ox, oy, oz, dx, dy, dz, t_near, t_far = pixel_ray_span(cam, origins, directions, span, pix, width,
                                                                       height)
                r, g, b, a, dep, ns, v = _march(marker, light, warp, bricks, offs, table, sigma, leap, grids, dims,
                                                ox, oy, oz, dx, dy, dz, lo, hi, piece, p, p.step, scratch, t_near,
                                                t_far)
                store_pixel(out_rgba, out_depth, out_samples, pix, r, g, b, a, dep, ns)
                if out_value.shape[0] == out_rgba.shape[0]:
                    out_value[pix] = v


# -- the pixel loop's pieces, shared by every tile kernel (CPU) and pixel kernel (GPU) -----
@kernel
def lane_pixels(lane, lanes, tile_rows, tile, width):
    """How many pixel slots lane ``lane`` of ``lanes`` walks: ``tile * tile`` for each of
    its tiles ``lane, lane + lanes, ...`` of the rows of tiles ``tile_rows``
    (:func:`lane_pixel` maps a slot to its pixel)."""
    n_tiles = tile_rows.shape[0] * ((width + tile - 1) // tile)
    return (n_tiles - lane + lanes - 1) // lanes * (tile * tile)


@kernel
def lane_pixel(i, lane, lanes, tile_rows, tile, width, height):
    """The pixel (``row * width + col``) of slot ``i`` of lane ``lane``: pixel
    ``i % tile**2`` (row by row) of the lane's tile ``i // tile**2``, or -1 past the
    image's right or bottom edge."""
    tiles_x = (width + tile - 1) // tile
    t = lane + (i // (tile * tile)) * lanes
    k = i % (tile * tile)
    row = tile_rows[t // tiles_x] * tile + k // tile
    col = (t % tiles_x) * tile + k % tile
    if row >= height or col >= width:
        return -1
    return row * width + col


@kernel
def pixel_ray_span(cam, origins, directions, span, pix, width, height):
    """The ray of pixel ``pix`` (``row * width + col``) in voxel coordinates and its
    ``[near, far]``: from the camera array ``cam`` (``voxel_ray``) or, when it is empty,
    from ``origins``/``directions`` (one row per pixel); ``span`` empty means
    ``[0, inf]``."""
    if cam.shape[0] > 0:
        ox, oy, oz, dx, dy, dz = voxel_ray(cam, pix % width, pix // width, width, height)
    else:
        ox = origins[pix, 0]
        oy = origins[pix, 1]
        oz = origins[pix, 2]
        dx = directions[pix, 0]
        dy = directions[pix, 1]
        dz = directions[pix, 2]
    if span.shape[0] > 0:
        return ox, oy, oz, dx, dy, dz, span[pix, 0], span[pix, 1]
    return ox, oy, oz, dx, dy, dz, 0.0, math.inf


@kernel
def store_pixel(out_rgba, out_depth, out_counts, pix, r, g, b, a, depth, count):
    """Write pixel ``pix``'s colour, opacity, depth and work count to the outputs."""
    out_rgba[pix, 0] = r
    out_rgba[pix, 1] = g
    out_rgba[pix, 2] = b
    out_rgba[pix, 3] = a
    out_depth[pix] = depth
    out_counts[pix] = count


@kernel
def voxel_ray(cam, col, row, width, height):
    """``camera_ray`` in voxel coordinates, as ``raycast/grid.py`` converts ``Camera.rays``:
    ``(o - origin) / spacing`` and ``d / spacing`` (``cam`` ends with the volume's
    origin and ``1 / spacing``)."""
    ox, oy, oz, dx, dy, dz = camera_ray(cam, col, row, width, height)
    c = CAMERA_FIELDS
    return ((ox - cam[c]) * cam[c + 3], (oy - cam[c + 1]) * cam[c + 4], (oz - cam[c + 2]) * cam[c + 5],
            dx * cam[c + 3], dy * cam[c + 4], dz * cam[c + 5])


@kernel
def brick_offsets(n, qy, qx, out):
    """Offsets into the bricks (``make_bricks``) of the points along each axis: a point
    ``(i, j, k)`` sits at ``out[i] + out[nx + j] + out[nx + ny + k]`` (``n`` = points
    along x, y, z; ``qy, qx`` bricks along y and x)."""
    size = 1 << BRICK_SHIFT
    pitch = size + 1
    m = size - 1
    per_brick = pitch * pitch * pitch
    strides = (1, qx, qx * qy)
    pos = 0
    for axis in range(3):
        local = pitch ** axis
        for i in range(n[axis]):
            out[pos + i] = (i >> BRICK_SHIFT) * strides[axis] * per_brick + (i & m) * local
        pos += n[axis]


@kernel
def make_bricks(values, shift, bz, by, bx, out):
    """Copy ``values`` (z, y, x) into a (bz, by, bx) grid of bricks of ``(size + 1)**3`` points.

    Brick ``(kb, jb, ib)`` holds points ``[b * size, b * size + size]`` on each axis (the
    last plane duplicates the next brick's first: trilinear interpolation never leaves
    a brick). Points past the volume's edge repeat the edge; there are ``n // size + 1``
    bricks along an axis of ``n`` points, so the last point starts a cell of its own. ``out`` is flat, bricks in
    (kb, jb, ib) order, points z, y, x inside.
    """
    nz, ny, nx = values.shape
    size = 1 << shift
    pitch = size + 1
    q = 0
    for kb in range(bz):
        for jb in range(by):
            for ib in range(bx):
                for lk in range(pitch):
                    k = min(kb * size + lk, nz - 1)
                    for lj in range(pitch):
                        j = min(jb * size + lj, ny - 1)
                        for li in range(pitch):
                            i = min(ib * size + li, nx - 1)
                            out[q] = values[k, j, i]
                            q += 1


@kernel
def level_block_ranges(values, level, shift, out_min, out_max):
    """Min and max (NaN ignored) of the mip level ``level`` points that samples in each
    level-0 block can read.

    Level-0 block ``b`` (``2**shift`` cells) spans voxel coordinates ``[b s, (b + 1) s]``;
    a level-``L`` sample there reads the level points from ``floor(b s / 2**L)`` to
    ``ceil((b + 1) s / 2**L)``. ``out_min``/``out_max`` have the level-0 block grid's shape.
    """
    nz, ny, nx = values.shape
    bz, by, bx = out_min.shape
    size = 1 << shift
    step = 1 << level
    for kb in range(bz):
        k0 = (kb * size) // step
        k1 = min(-(-((kb + 1) * size) // step), nz - 1)
        for jb in range(by):
            j0 = (jb * size) // step
            j1 = min(-(-((jb + 1) * size) // step), ny - 1)
            for ib in range(bx):
                i0 = (ib * size) // step
                i1 = min(-(-((ib + 1) * size) // step), nx - 1)
                lo = math.inf
                hi = -math.inf
                for k in range(min(k0, nz - 1), k1 + 1):
                    for j in range(min(j0, ny - 1), j1 + 1):
                        for i in range(min(i0, nx - 1), i1 + 1):
                            v = np.float64(values[k, j, i])
                            if v < lo:
                                lo = v
                            if v > hi:
                                hi = v
                out_min[kb, jb, ib] = lo
                out_max[kb, jb, ib] = hi


@kernel
def block_ranges(values, shift, out_min, out_max):
    """Min and max (NaN ignored) of the points each block's cells touch.

    Block ``b`` covers cells ``[b * size, (b + 1) * size)``, hence points
    ``[b * size, (b + 1) * size]``: neighbouring blocks share a plane of points. A
    block of NaN only gets ``min = +inf, max = -inf``.
    """
    nz, ny, nx = values.shape
    bz, by, bx = out_min.shape
    size = 1 << shift
    for kb in range(bz):
        for jb in range(by):
            for ib in range(bx):
                lo = math.inf
                hi = -math.inf
                for k in range(kb * size, min((kb + 1) * size + 1, nz)):
                    for j in range(jb * size, min((jb + 1) * size + 1, ny)):
                        for i in range(ib * size, min((ib + 1) * size + 1, nx)):
                            v = np.float64(values[k, j, i])
                            if v < lo:
                                lo = v
                            if v > hi:
                                hi = v
                out_min[kb, jb, ib] = lo
                out_max[kb, jb, ib] = hi
