"""A view-independent conservative occlusion bound (../shared/notes/methods.md A.7).

Per group of ``s**3`` cells, the smallest extinction the transfer function gives any
value of the group's range; each pixel ray marched through the groups at the ray
caster's own sample positions sums that extinction times each segment's length: a
lower bound on the optical depth the ray caster accumulates. Once the bound before a
block reaches ``-ln(1 - threshold)``, the ray caster (terminating at that opacity) has
stopped before the block on that pixel; a block for which that holds on every pixel
whose ray samples it cannot change the image, and is culled.

Unlike plenoptic opacity functions (``pof.py``) it needs no sampled views, holds for
perspective cameras, cameras inside the volume and any transfer function, and stores
one number per group (1/8 of an 8-bit volume at ``s = 2``).

- :class:`OcclusionBound`: what ``render(..., cull=OcclusionBound())`` takes.
- :func:`occluded_blocks`: the same from per-group value ranges and any rays (the
  out-of-core renderer's entry: its ranges per chunk and group).
- :func:`group_extinction` and :func:`group_ranges`: the two halves of the
  precomputation.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .._validate import as_int, as_real
from ..data.transfer import SCALE_CODES, TransferFunction, TransferFunctionFamily, table_entry_span
from ..rays.camera import Camera, Rays
from . import _kernels as K
from .cull import DEFAULT_THRESHOLD

#: Chunk of table entries of :func:`group_extinction`'s range-minimum queries.
_CHUNK = 16
#: The rounding unit of the ray caster's opacity sums, per precision: the bound must
#: exceed ``-ln(1 - threshold)`` by ``(k + 32) eps / (1 - threshold)`` before sample
#: ``k`` (see :func:`march_slack`).
_EPS = {"float64": 2.0**-52, "float32": 2.0**-23}


def group_ranges(values, group):
    """``(minimum, maximum)`` (gz, gy, gx) float64: the range of the points each group's
    cells touch (group ``(k, j, i)`` spans points ``i * group`` to ``(i + 1) * group``
    along x, clipped to the volume, and so on: neighbours share their faces).

    NaN propagates: a group with a NaN point has NaN bounds (its cells' samples next to
    the NaN are empty, the ray caster's rule, so :func:`group_extinction` gives it no
    extinction). ``values`` (z, y, x), at least 2 points per axis.
    """
    lo = np.asarray(values)
    if lo.ndim != 3 or min(lo.shape) < 2:
        raise ValueError(f"values must be a 3-D array with at least 2 points per axis; got shape {lo.shape}")
    group = as_int("group", group, low=1)
    hi = lo
    for axis in (2, 1, 0):
        n = lo.shape[axis]
        starts = np.arange(0, n - 1, group)
        ends = np.minimum(starts + group, n - 1)  # the shared face, inclusive
        lo = np.minimum(np.minimum.reduceat(lo, starts, axis=axis), np.take(lo, ends, axis=axis))
        hi = np.maximum(np.maximum.reduceat(hi, starts, axis=axis), np.take(hi, ends, axis=axis))
    return lo.astype(np.float64), hi.astype(np.float64)


def table_axis(tf):
    """``(scale, linthresh, axis_lo, axis_hi)`` of ``tf``'s table: how the ray caster
    maps a value to an entry (``table_position``), for :func:`group_extinction`."""
    a0, a1 = tf.axis_range
    return tf.scale, float(tf.linthresh), float(a0), float(a1)


def group_extinction(minimum, maximum, sigma, axis, weights=None):
    """Per group, a lower bound on the extinction of any value in its range.

    Parameters
    ----------
    minimum, maximum : ndarray, shape (gz, gy, gx)
        Each group's value range (:func:`group_ranges`, or any superset of the values
        its samples can interpolate). A NaN or infinite bound means the group has no
        extinction bound (0): its samples may be NaN, which the ray caster skips.
    sigma : ndarray, shape (n,) or (p, n)
        Extinction per world unit at the table's ``n`` entries
        (``TransferFunction.table(...)[1]``, or a family's ``basis_tables(...)``: one
        row per basis).
    axis : tuple
        ``(scale, linthresh, axis_lo, axis_hi)`` of the table (:func:`table_axis`).
    weights : sequence of float, optional
        With ``p`` rows: the family's weights ``k_i >= 0``; the bound is
        ``sum_i k_i min_i``, each basis's minimum over the group's entries, which is at
        most the minimum of ``sum_i k_i sigma_i``: one precomputation of the per-basis
        minima serves every weight vector. Default all 1.

    Returns
    -------
    ndarray, float32, shape (gz, gy, gx)
        Rounded down from float64 (the bound stays a lower bound).

    Notes
    -----
    The entries are those ``table_entry_span`` gives the range (the ray caster
    interpolates between entries ``floor(x)`` and ``floor(x) + 1`` of its position
    ``x``), widened by one entry on each side: a float32 trilinear sample may round an
    ulp outside its corners' range.
    """
    total, finite = _span_reduce(minimum, maximum, sigma, axis, weights, largest=False)
    total[~finite] = 0.0
    out = total.astype(np.float32)
    over = out.astype(np.float64) > total
    out[over] = np.nextafter(out[over], np.float32(0))
    return out.reshape(np.shape(minimum))


def group_empty(minimum, maximum, sigma, axis, weights=None):
    """(gz, gy, gx) bool: no value of the group's range has extinction (the largest
    over its entries, widened as :func:`group_extinction`'s, is 0); a NaN or infinite
    bound is not empty. Arguments as :func:`group_extinction`. The march leaps over
    blocks whose groups are all empty, as the ray caster leaps over empty space."""
    total, finite = _span_reduce(minimum, maximum, sigma, axis, weights, largest=True)
    return ((total == 0) & finite).reshape(np.shape(minimum))


def _span_reduce(minimum, maximum, sigma, axis, weights, largest):
    """``(sum_i k_i reduce_i, finite)`` flat over the groups: each row's minimum (or
    largest value) over the entries the group's range can read, widened by one."""
    minimum = np.asarray(minimum, dtype=np.float64)
    maximum = np.asarray(maximum, dtype=np.float64)
    if minimum.shape != maximum.shape:
        raise ValueError(f"minimum and maximum must have one shape; got {minimum.shape} and {maximum.shape}")
    sigma = np.asarray(sigma, dtype=np.float64)
    if sigma.ndim == 1:
        sigma = sigma[None]
    if sigma.ndim != 2 or sigma.shape[1] < 2:
        raise ValueError(f"sigma must have shape (n,) or (p, n) with n >= 2 table entries; got {sigma.shape}")
    if np.any(np.isnan(sigma)) or np.any(sigma < 0):
        raise ValueError("sigma must be extinctions >= 0 (no NaN)")
    p, n = sigma.shape
    k = np.ones(p) if weights is None else np.asarray(weights, dtype=np.float64).reshape(-1)
    if k.shape != (p,) or not np.all(np.isfinite(k)) or np.any(k < 0):
        raise ValueError(f"weights must be {p} finite values >= 0 (one per row of sigma); got {np.ravel(weights)!r}")
    try:
        scale, linthresh, a0, a1 = axis
        SCALE_CODES[scale]  # a known scale name
    except (TypeError, ValueError, KeyError):
        raise ValueError(f"axis must be (scale, linthresh, axis_lo, axis_hi) with scale one of "
                         f"{list(SCALE_CODES)}; got {axis!r}") from None
    finite = np.isfinite(minimum) & np.isfinite(maximum)
    i0, i1 = table_entry_span(np.where(finite, minimum, 0.0), np.where(finite, maximum, 0.0), scale, float(linthresh),
                              float(a0), 1.0 / (a1 - a0) if a1 > a0 else 0.0, n)
    i0 = np.ascontiguousarray(np.maximum(i0 - 1, 0).reshape(-1))
    i1 = np.ascontiguousarray(np.minimum(i1 + 1, n - 1).reshape(-1))
    total = np.zeros(i0.size)
    part = np.empty(i0.size)
    sign = -1.0 if largest else 1.0  # the largest value is minus the minimum of the negated row
    for row, w in zip(sigma, k):
        if w == 0:
            continue
        row = np.ascontiguousarray(sign * row)
        K.span_minimum(row, _sparse_table(row), _CHUNK, i0, i1, part)
        total += w * (sign * part)
    return total, finite.reshape(-1)


def _sparse_table(row):
    """``(levels, chunks)`` minima of runs of ``2**l`` chunks of ``_CHUNK`` entries."""
    n_chunks = len(row) // _CHUNK
    if n_chunks == 0:
        return np.zeros((1, 1))
    level = row[:n_chunks * _CHUNK].reshape(n_chunks, _CHUNK).min(axis=1)
    levels = [level]
    width = 1
    while 2 * width <= n_chunks:
        level = np.minimum(level[:-width], level[width:])
        levels.append(np.concatenate([level, np.full(n_chunks - level.size, np.inf)]))
        width *= 2
    return np.ascontiguousarray(np.stack(levels))


def march_slack(threshold, precision):
    """``(target, slack)``: the bound must reach ``target + (k + 32) slack`` before
    sample ``k`` to count it occluded.

    ``target = -ln(1 - threshold)``. The ray caster sums opacities, not optical depths:
    each step's opacity is rounded to the table's precision and the sum carries
    rounding of about ``eps`` per sample (float32 compensated, float64 plain), which
    near the threshold is ``eps / (1 - threshold)`` of optical depth.
    """
    return -math.log1p(-threshold), _EPS[precision] / (1.0 - threshold)


def _march(extinction, empty, rays, lo, hi, group_width, block_width, block_shape, step, threshold, precision):
    """``(needed, met, seconds)`` (bool, ``block_shape``) of :func:`K.march_bound`.
    ``empty``: :func:`group_empty` (or None); ``rays``: ``(cam, width, height)`` or a
    :class:`Rays` in lattice coordinates."""
    import numba

    lanes = numba.get_num_threads()
    needed = np.zeros((lanes,) + tuple(block_shape), dtype=np.uint8)
    met = np.zeros_like(needed)
    target, slack = march_slack(threshold, precision)
    cap = target + 1.0  # one sample past the target is opaque on its own: no need to count it exactly
    if isinstance(rays, Rays):
        cam = np.empty(0)
        origins, directions, width, height = rays.origins, rays.directions, rays.width, rays.height
    else:
        cam, width, height = rays
        origins = directions = np.empty((0, 3))
    blocks_empty = np.zeros(block_shape, dtype=np.uint8)
    r = block_width / group_width
    if empty is not None and r >= 1 and r == int(r):  # a block is empty when all its groups are
        r = int(r)
        e = np.pad(np.asarray(empty, dtype=bool), [(0, n * r - m) for n, m in zip(block_shape, np.shape(empty))],
                   constant_values=True)
        blocks_empty = np.ascontiguousarray(
            e.reshape(block_shape[0], r, block_shape[1], r, block_shape[2], r).all(axis=(1, 3, 5)), dtype=np.uint8)
    start = time.perf_counter()
    K.march_bound(np.ascontiguousarray(extinction, dtype=np.float32), blocks_empty, cam, np.ascontiguousarray(origins),
                  np.ascontiguousarray(directions), int(width), int(height), np.ascontiguousarray(lo, dtype=np.float64),
                  np.ascontiguousarray(hi, dtype=np.float64), float(group_width), float(block_width), float(step),
                  target, slack, cap, lanes, needed, met)
    seconds = time.perf_counter() - start
    return needed.any(axis=0), met.any(axis=0), seconds


def occluded_blocks(minimum, maximum, sigma, axis, *, origin, group_size, rays, step, box=None, block_groups=1,
                    threshold=DEFAULT_THRESHOLD, weights=None, precision="float32"):
    """Blocks that every ray sampling them reaches only behind ``threshold`` opacity.

    Parameters
    ----------
    minimum, maximum : ndarray, shape (gz, gy, gx)
        Value range of each group (NaN or infinite: no extinction; see
        :func:`group_extinction`).
    sigma, axis, weights
        The extinction table: see :func:`group_extinction`.
    origin : sequence of 3 float
        World position (x, y, z) of the first group's corner.
    group_size : float or sequence of 3 float
        A group's edge in world units (x, y, z).
    rays : Rays or (Camera, size)
        The ray caster's rays (world units, ``Camera.rays(size)``); a ``(camera,
        size)`` pair makes them.
    step : float
        The ray caster's step in world units.
    box : (lo, hi), optional
        World corners of the box the rays sample (the volume's bounds: where the ray
        caster's sample lattice starts and ends); default the groups' box.
    block_groups : int
        Groups per block edge: the blocks of the mask returned.
    threshold : float
        Opacity at which the ray caster stops a ray (``1 - termination``).
    precision : {"float32", "float64"}
        The ray caster's: the rounding margin of :func:`march_slack`.

    Returns
    -------
    ndarray, bool, shape (ceil(gz / block_groups), ...)
        True for a block that some ray samples and none before its bound reaches
        ``-ln(1 - threshold)``. A block no ray samples is False (outside the view: the
        frustum's business).

    Notes
    -----
    Ray ``r`` samples the box from its entry ``t0`` at ``t0 + (k + 1/2) step`` (the
    last, shorter segment at its own midpoint), as the ray caster does; sample ``k``
    adds ``sigma_min(g) * length`` of the group ``g`` its cell lies in. The sum before
    a sample is at most the optical depth the ray caster has accumulated there
    (``sigma_min`` is at most the extinction of any value the sample can interpolate),
    so once it reaches ``-ln(1 - threshold)`` (plus the rounding margin) the ray
    caster has stopped. Summing ``sigma_min`` over exact ray-box lengths instead
    would not be a bound: a segment straddling a dense and an empty group takes the
    empty one's extinction when its midpoint lies there.
    """
    from .._validate import as_choice

    ext = group_extinction(minimum, maximum, sigma, axis, weights)
    empty = group_empty(minimum, maximum, sigma, axis, weights)
    origin = _vector("origin", origin)
    size = _vector("group_size", group_size)
    if np.any(size <= 0):
        raise ValueError(f"group_size must be > 0; got {size.tolist()}")
    step = as_real("step", step, low=0, low_open=True)
    block_groups = as_int("block_groups", block_groups, low=1)
    threshold = as_real("threshold", threshold, low=0, high=1, low_open=True, high_open=True)
    precision = as_choice("precision", precision, tuple(_EPS))
    counts = np.array(ext.shape[::-1], dtype=np.float64)  # x, y, z
    if box is None:
        lo_w, hi_w = origin, origin + counts * size
    else:
        try:
            lo_w, hi_w = (_vector("box", b) for b in box)
        except (TypeError, ValueError):
            raise ValueError(f"box must be (lo, hi), two world points (x, y, z); got {box!r}") from None
        if np.any(hi_w < lo_w):
            raise ValueError(f"box must have lo <= hi; got {box!r}")
    if isinstance(rays, tuple) and len(rays) == 2 and isinstance(rays[0], Camera):
        rays = rays[0].rays(rays[1])
    if not isinstance(rays, Rays):
        raise TypeError(f"rays must be Rays or (Camera, size); got {type(rays).__name__}")
    # lattice coordinates: a group is one unit, t stays in world units
    lattice = Rays(np.ascontiguousarray((rays.origins - origin) / size), np.ascontiguousarray(rays.directions / size),
                   rays.width, rays.height)
    bshape = tuple(-(-n // block_groups) for n in ext.shape)
    needed, met, _ = _march(ext, empty, lattice, (lo_w - origin) / size, (hi_w - origin) / size, 1.0, float(block_groups),
                            bshape, step, threshold, precision)
    return met & ~needed


def _vector(name, v):
    out = np.broadcast_to(np.asarray(v, dtype=np.float64), (3,)).copy()
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name} must be finite; got {v!r}")
    return out


@dataclass(frozen=True)
class OcclusionBound:
    """View-independent occlusion culling: ``render(..., cull=OcclusionBound())``.

    Parameters
    ----------
    group : int
        Cells per group edge (a power of two): one extinction bound per ``group**3``
        cells. Smaller groups give tighter bounds (more culling) and larger
        precomputations (``group=1``: one float32 per cell).
    threshold : float
        Opacity at which a pixel counts as opaque. Render with
        ``termination = 1 - threshold`` and the culled image equals the unculled one
        bit for bit (tested); with less termination, a culled block changes a pixel
        by at most ``1 - threshold`` of what it would emit there.
    block_size : int, optional
        Cells per edge of the blocks culled; default the render's ``block_size``
        option (its empty-space blocks). A multiple of that option, or a divisor.

    Notes
    -----
    Per group, ``sigma_min`` is the smallest extinction of the render's table over the
    entries the group's value range (the corner points of its cells) can read
    (:func:`group_extinction`); for a :class:`~pv_hdrvol.TransferFunctionFamily`, the
    sum over bases of ``k_i`` times each basis's minimum, computed once per basis
    set and reused for any weights. Each pixel ray (the render's own:
    ``Camera.kernel_array``) is marched at the ray caster's sample positions,

    .. math:: D_k = \\sum_{j < k} \\sigma_{min}(g_j)\\, \\Delta_j \\le -\\ln(1 - A_k),

    with ``A_k`` the opacity the ray caster has accumulated before sample ``k``. A
    render block is occluded for the pixel at its first sample with
    ``D_k >= -ln(1 - threshold)`` (plus a rounding margin, :func:`march_slack`), and
    culled when occluded for every pixel whose ray samples it. Blocks no ray samples
    are kept. Composite blending without ``gradient_opacity`` (which lowers
    opacities below the table's), float32 or float64 precision (the emulated 8- and
    16-bit pipelines round each step's opacity), uniform grids; the render's
    ``step``, ``global_alpha`` and ``opacity_unit_distance`` are taken into account.

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> values = np.zeros((16, 16, 16)); values[:, :, :4] = 1.0  # an opaque slab at x < 3
    >>> tf = hv.TransferFunction([0.0, 1.0], [[1, 1, 1]] * 2, [0.0, 0.9])
    >>> camera = hv.Camera((-50, 7.5, 7.5), (7.5, 7.5, 7.5), (0, 0, 1), parallel_projection=True,
    ...                    parallel_scale=12)
    >>> image = hv.render(values, tf, camera, (32, 32), cull=OcclusionBound(), termination=0.05, block_size=4)
    >>> stats = image.metadata["culling"]
    >>> stats["culled"], stats["met"]  # behind the slab: blocks x = 1, 2, 3 of 4 x 4 x 4
    (48, 64)
    """

    group: int = 2
    threshold: float = DEFAULT_THRESHOLD
    block_size: int | None = None

    def __post_init__(self):
        g = as_int("group", self.group, low=1, high=256)
        if g & (g - 1):
            raise ValueError(f"group must be a power of two; got {self.group!r}")
        object.__setattr__(self, "group", g)
        object.__setattr__(self, "threshold",
                           as_real("threshold", self.threshold, low=0, high=1, low_open=True, high_open=True))
        if self.block_size is not None:
            b = as_int("block_size", self.block_size, low=1, high=4096)
            if b & (b - 1):
                raise ValueError(f"block_size must be a power of two; got {self.block_size!r}")
            object.__setattr__(self, "block_size", b)

    def extinction(self, volume, tf, options):
        """``(sigma_min, empty)``, (gz, gy, gx) float32 and bool, of the render of
        ``volume`` with ``tf`` and ``options`` (a :class:`~pv_hdrvol.RenderOptions`):
        :func:`group_extinction` and :func:`group_empty`, cached on the volume (the
        group ranges per group size and precision, the per-basis minima per table)."""
        from ..data.grid import content_digest
        from ..raycast.grid import cached

        values = volume.values
        if options.precision != "float64" and values.dtype == np.float64:
            values_key = "float32"  # the ray caster samples a float32 copy
        else:
            values_key = "as is"

        def ranges():
            v = values.astype(np.float32) if values_key == "float32" else values
            return group_ranges(v, self.group)

        lo, hi = cached(volume.cache, "occlusion_ranges", (self.group, values_key), ranges, 2)
        unit = options.opacity_unit_distance if options.opacity_unit_distance is not None else volume.min_cell_width
        if isinstance(tf, TransferFunctionFamily):
            sigma, k = tf.basis_tables(options.global_alpha, unit), tf.k
        elif isinstance(tf, TransferFunction):
            sigma, k = tf.table(np.float64, options.global_alpha, unit)[1][None], np.ones(1)
        else:
            raise TypeError(f"tf must be a TransferFunction; got {type(tf).__name__}")
        axis = table_axis(tf)
        key = (self.group, values_key, axis, content_digest(sigma))

        def per_basis():  # one row per basis: any weights reuse them
            return (np.stack([group_extinction(lo, hi, row, axis) for row in sigma]),
                    np.stack([group_empty(lo, hi, row, axis) for row in sigma]))

        minima, empties = cached(volume.cache, "occlusion_minima", key, per_basis, 4)
        empty = empties[k > 0].all(axis=0) if np.any(k > 0) else np.ones(minima.shape[1:], dtype=bool)
        if minima.shape[0] == 1:  # a plain function (k = 1)
            return minima[0], empty
        total = np.einsum("p,p...->...", k, minima.astype(np.float64))
        out = total.astype(np.float32)
        over = out.astype(np.float64) > total
        out[over] = np.nextafter(out[over], np.float32(0))
        return out, empty

    def blocks(self, volume, tf, camera, size, options, block_size, window=None):
        """``(needed, met, statistics)``: bool (bz, by, bx) over blocks of
        ``block_size`` cells: sampled before the bound reaches the threshold on some
        pixel, and sampled at all. ``window=(col, row, width, height)``: by that
        rectangle's pixels only (a tile of a parallel render: a block is culled where
        the union over tiles of ``met`` holds and that of ``needed`` does not)."""
        from .._validate import as_size
        from ..raycast.grid import block_grid_shape

        if options.blending != "composite" or options.gradient_opacity is not None:
            raise ValueError("cull=OcclusionBound() applies to blending='composite' without gradient_opacity (it "
                             "bounds the transfer function's extinction)")
        if options.precision not in _EPS:
            raise ValueError(f"cull=OcclusionBound() needs precision 'float32' or 'float64' (the emulated pipelines "
                             f"round each step's opacity, perhaps to 0); got {options.precision!r}")
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a Camera; got {type(camera).__name__}")
        if min(volume.dims) < 2:
            raise ValueError(f"the volume must have at least 2 points per axis; got {tuple(volume.dims)}")
        width, height = as_size(size)
        start = time.perf_counter()
        ext, empty = self.extinction(volume, tf, options)
        t_ext = time.perf_counter() - start
        spacing = np.asarray(volume.spacing, dtype=np.float64)
        origin = np.asarray(volume.origin, dtype=np.float64)
        if window is None:  # the kernel makes the render's rays (camera_ray), bit for bit
            rays = (np.concatenate([camera.kernel_array((width, height)), origin, 1.0 / spacing]), width, height)
        else:  # Camera.rays is camera_ray's arithmetic; into voxels as raycast/grid.py does
            r = camera.rays((width, height), window)
            rays = Rays(np.ascontiguousarray((r.origins - origin) * (1.0 / spacing)),
                        np.ascontiguousarray(r.directions * (1.0 / spacing)), r.width, r.height)
        shape = block_grid_shape(volume.dims, block_size)
        hi = np.array(volume.dims, dtype=np.float64) - 1.0
        step = options.step * volume.min_cell_width
        needed, met, t_march = _march(ext, empty, rays, np.zeros(3), hi, float(self.group), float(block_size),
                                      shape, step, self.threshold, options.precision)
        stats = {"blocks": int(np.prod(shape)), "met": int(met.sum()), "needed": int(needed.sum()),
                 "culled": int((met & ~needed).sum()), "threshold": self.threshold, "group": self.group,
                 "block_size": block_size, "extinction_seconds": t_ext, "march_seconds": t_march}
        return needed, met, stats

    def mask_for(self, volume, tf, camera, size, options, render_shape):
        """``(mask, statistics)``: the render's block mask (shape ``render_shape``, False
        for culled blocks) and the counts and times (``met``: blocks some ray samples,
        ``culled``, ``march_seconds``, ...)."""
        from .cull import expand_mask

        start = time.perf_counter()
        block_size = options.block_size if self.block_size is None else self.block_size
        needed, met, stats = self.blocks(volume, tf, camera, size, options, block_size)
        keep = needed | ~met
        if block_size >= options.block_size:
            mask = expand_mask(keep, block_size, options.block_size, render_shape)
        else:  # finer than the render's blocks: a render block is kept when any of its parts is
            r = options.block_size // block_size
            pad = [(0, (-n) % r) for n in keep.shape]
            k = np.pad(keep, pad)
            k = k.reshape(k.shape[0] // r, r, k.shape[1] // r, r, k.shape[2] // r, r).any(axis=(1, 3, 5))
            mask = np.ascontiguousarray(k[:render_shape[0], :render_shape[1], :render_shape[2]])
        stats["seconds"] = time.perf_counter() - start
        return mask, stats


__all__ = ["OcclusionBound", "occluded_blocks", "group_extinction", "group_empty", "group_ranges", "table_axis", "march_slack"]
