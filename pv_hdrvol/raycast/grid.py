"""Render image volumes: validate, build tables and the block grid, call the kernel."""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..data.grid import GridVolume, volume_from_array, volume_from_dataset
from ..data.transfer import SCALE_CODES, SCALES, TransferFunction, scale_forward
from ..image.hdr import HDRImage
from ..params import PRECISION_CODES, RenderOptions
from ..rays.camera import Camera, Rays
from . import _kernels as K

# Rays are cast in square tiles of this many pixels a side (cache locality).
_TILE = 8
# progress_bar=None shows a bar for renders expected to take longer than this (seconds).
_AUTO_BAR_SECONDS = 1.0


def as_volume(data, scalars=None, preference="point"):
    """A :class:`GridVolume` from a GridVolume, a 3-D numpy array or an image dataset."""
    if isinstance(data, GridVolume):
        return data
    if isinstance(data, np.ndarray):
        if scalars is not None:
            raise ValueError("scalars names an array of a dataset; a numpy volume has none")
        return volume_from_array(data)
    return volume_from_dataset(data, scalars=scalars, preference=preference)


def default_transfer_function(volume):
    """A magma ramp over the data range, on a log axis when positive data spans > 3 decades."""
    lo, hi = volume.value_range
    v = volume.values
    if hi > 0 and np.issubdtype(v.dtype, np.floating):
        pos = v[v > 0]
        pmin = float(pos.min()) if pos.size else hi
        if lo >= 0 and pmin > 0 and hi / pmin > 1e3:
            return TransferFunction.ramp(pmin, hi, scale="log", cmap="magma")
    if hi <= lo:
        hi = lo + 1.0
    return TransferFunction.ramp(lo, hi, cmap="magma")


def _grid_shape(dims, size):
    """Blocks of ``size`` cells along (z, y, x) covering a volume of ``dims`` (x, y, z) points."""
    return tuple(max(1, -(-max(n - 1, 1) // size)) for n in dims[::-1])


class Bricks:
    """The volume copied into bricks of ``(8 + 1)**3`` points, cached on the volume.

    A sample's eight neighbours then sit in one small contiguous block whatever the
    view direction (see ``_kernels.make_bricks``).
    """

    def __init__(self, volume):
        size = 1 << K.BRICK_SHIFT
        self.shape = _grid_shape(volume.dims, size)
        self.values = np.empty(int(np.prod(self.shape)) * (size + 1) ** 3, dtype=volume.values.dtype)
        K.make_bricks(volume.values, K.BRICK_SHIFT, *self.shape, self.values)

    @classmethod
    def of(cls, volume):
        if "bricks" not in volume.cache:
            volume.cache["bricks"] = cls(volume)
        return volume.cache["bricks"]


class BlockGrid:
    """Min/max of the volume per block: empty-space leaping and culling.

    Built once per :class:`GridVolume` and block size, then cached on the volume.

    Attributes
    ----------
    minimum, maximum : ndarray, shape (bz, by, bx), float64
        Range of the points each block's cells touch (NaN ignored; ``+inf/-inf`` for
        an all-NaN block).
    block_size : int
        Cells per block edge.
    """

    def __init__(self, volume, block_size=4):
        self.block_size = block_size
        self.shift = int(round(math.log2(block_size)))
        shape = _grid_shape(volume.dims, block_size)
        self.minimum = np.empty(shape)
        self.maximum = np.empty(shape)
        K.block_ranges(volume.values, self.shift, self.minimum, self.maximum)

    @classmethod
    def of(cls, volume, block_size=4):
        """The cached block grid of ``volume`` (built on first use)."""
        key = ("blocks", block_size)
        if key not in volume.cache:
            volume.cache[key] = cls(volume, block_size)
        return volume.cache[key]

    @property
    def shape(self):
        """Blocks along (z, y, x)."""
        return self.minimum.shape

    def visible(self, opacity, params):
        """Blocks that can reach a non-zero opacity entry (uint8 mask, z, y, x).

        Mirrors the kernel's lookup (``_kernels._table_index``) on each block's value
        range: the axis transform is monotone, so the entries a block can touch lie
        between those of its minimum and maximum. Non-linear axes get a margin of 1e-9
        of the axis, because the kernel's ``log10`` may differ from numpy's by an ulp.
        """
        n = opacity.size
        nonzero = np.concatenate([[0], np.cumsum(opacity > 0)])
        all_nan = ~np.isfinite(self.minimum)
        lo = np.where(all_nan, 0.0, self.minimum)
        hi = np.where(all_nan, 0.0, self.maximum)
        margin = 0.0 if params.scale == SCALE_CODES["linear"] else 1e-9
        ulo = np.clip(_axis_position(lo, params) - margin, 0.0, 1.0)
        uhi = np.clip(_axis_position(hi, params) + margin, 0.0, 1.0)
        if params.precision == PRECISION_CODES["uint8"]:
            i0 = np.floor(ulo * (n - 1) + 0.5).astype(np.int64)
            i1 = np.floor(uhi * (n - 1) + 0.5).astype(np.int64)
        else:
            i0 = np.floor(ulo * (n - 1)).astype(np.int64)
            i1 = np.ceil(uhi * (n - 1)).astype(np.int64)
        vis = (nonzero[i1 + 1] - nonzero[i0]) > 0
        return (vis & ~all_nan).astype(np.uint8)


def leap_radius(active, cap=255):
    """Empty-space leaping distances over the block grid.

    Parameters
    ----------
    active : ndarray of bool or uint8, shape (bz, by, bx)
        Blocks to sample.

    Returns
    -------
    ndarray, uint8, same shape
        0 for an active block; else the Chebyshev distance ``r`` (in blocks, at most
        ``cap``) to the nearest active block, so every block within ``r - 1`` of it is
        empty. Blocks outside the grid count as empty (a ray leaves the volume there).

    Examples
    --------
    >>> a = np.zeros((1, 1, 6), bool); a[0, 0, 0] = True
    >>> leap_radius(a).tolist()
    [[[0, 1, 2, 3, 4, 5]]]
    """
    reached = np.asarray(active).astype(bool)
    radius = np.where(reached, 0, cap).astype(np.uint8)
    r = 1
    while r < cap and not reached.all() and reached.any():
        grown = reached.copy()
        for axis in range(3):  # a Chebyshev dilation is three 1-D dilations
            step = grown.copy()
            lo = [slice(None)] * 3
            hi = [slice(None)] * 3
            lo[axis], hi[axis] = slice(1, None), slice(None, -1)
            step[tuple(lo)] |= grown[tuple(hi)]
            step[tuple(hi)] |= grown[tuple(lo)]
            grown = step
        radius[grown & ~reached] = r
        reached = grown
        r += 1
    return np.ascontiguousarray(radius)


def _axis_position(values, params):
    """``_kernels.table_position`` in numpy, unclipped (float64)."""
    axis = scale_forward(values, SCALES[params.scale], params.linthresh)
    return (axis - params.axis_lo) * params.axis_inv_range


def render_volume(volume, tf=None, camera=None, size=(512, 512), options=None, *, block_mask=None,
                  progress=None, progress_bar=None, **option_kwargs):
    r"""Ray cast an image volume into an :class:`~pv_hdrvol.HDRImage`.

    Parameters
    ----------
    volume : GridVolume, ndarray (z, y, x), pyvista.ImageData or vtkImageData
        The field. Datasets use their active scalars (see :func:`render` for
        ``scalars=``).
    tf : TransferFunction, optional
        Default: :func:`default_transfer_function`.
    camera : Camera, optional
        Default: ``Camera.fit(volume, "iso")``.
    size : int or (width, height)
        Output size in pixels.
    options : RenderOptions, optional
        Sampling and compositing options; keywords (``step=``, ``precision=``, ...)
        override single fields.
    block_mask : ndarray of bool, shape ``BlockGrid(volume, block_size).shape``, optional
        Render only these blocks (visibility culling, parallel rendering). Blocks
        outside the mask are treated as empty.
    progress : callable, optional
        Called with the fraction of rows done (0..1) after each chunk; if it returns
        ``False`` the render stops and raises ``RuntimeError("render aborted")``.
    progress_bar : bool or None
        ``None`` (default): a tqdm progress bar for renders that will take over 1 s,
        judged from the time of the first chunk (every n-th row of tiles); quicker
        renders print nothing and run unchunked. ``True``: always; ``False``: never.

    Returns
    -------
    HDRImage
        Linear, premultiplied RGBA (row 0 at the top) in float64 for
        ``precision="float64"``, else float32; depth; statistics.

    Notes
    -----
    Emission-absorption along each ray, sampled at segment midpoints
    ``t_k = t_0 + (k + 1/2) * step`` (the last segment ends at the exit point) and
    composited front to back with premultiplied colour:

    .. math:: w_k = (1 - A_{k-1})\, a_k, \qquad A_k = A_{k-1} + w_k, \qquad
              C_k = C_{k-1} + w_k\, c_k, \qquad a_k = 1 - e^{-\sigma(v_k) \Delta_k}

    Skipped blocks hold only zero opacity, so skipping changes no pixel.

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> tf = hv.TransferFunction([0.0, 1.0], [[1, 1, 1], [1, 1, 1]], [0.1, 0.1])
    >>> cam = hv.Camera((1, 1, 10), (1, 1, 0), (0, 1, 0), parallel_projection=True, parallel_scale=0.5)
    >>> img = hv.render(np.full((5, 3, 3), 0.5), tf, cam, (2, 2), precision="float64")
    >>> round(float(img.rgba[0, 0, 3]), 12)  # 4 voxels of opacity 0.1: 1 - 0.9**4
    0.3439
    """
    volume = as_volume(volume)
    opts = RenderOptions.from_kwargs(options, **option_kwargs)
    if tf is None:
        tf = default_transfer_function(volume)
    if not isinstance(tf, TransferFunction):
        raise TypeError(f"tf must be a TransferFunction; got {type(tf).__name__}")
    if camera is None:
        camera = Camera.fit(volume.bounds, "iso")
    if isinstance(camera, Rays):
        rays = camera
    elif isinstance(camera, Camera):
        rays = camera.rays(size)
    else:
        raise TypeError(f"camera must be a Camera or Rays; got {type(camera).__name__}")
    width, height = rays.width, rays.height

    prec = opts.precision
    table_dtype = np.float64 if prec == "float64" else np.float32
    unit = opts.opacity_unit_distance if opts.opacity_unit_distance is not None else float(volume.spacing.min())
    table_size = 256 if prec == "uint8" else tf.table_size
    step_world = opts.step * float(volume.spacing.min())
    rgb, sigma = tf.table(np.float64, opts.global_alpha, unit, table_size)
    # opacity correction on the host: the opacity of one full step, 1 - exp(-sigma step)
    alpha_step = -np.expm1(-sigma * step_world)
    if prec == "uint8":
        rgb = np.round(np.clip(rgb, 0, 1) * 255) / 255
        alpha_step = np.round(alpha_step * 255) / 255
    table = np.ascontiguousarray(np.column_stack([rgb, alpha_step]), dtype=table_dtype)
    sigma = np.ascontiguousarray(sigma, dtype=table_dtype)

    values = volume.values
    if prec != "float64" and values.dtype == np.float64:
        volume = _derived(volume, "float32", lambda: values.astype(np.float32))
    if prec == "uint8":
        # an 8-bit pipeline quantises the data to 256 levels of the table's axis
        volume = _derived(volume, ("u8", tf.scale, tf.linthresh, tf.axis_range), lambda: _quantize_u8(values, tf))
    blocks = BlockGrid.of(volume, opts.block_size)

    a0, a1 = tf.axis_range
    # rays in voxel coordinates with t still in world units (see _kernels._march)
    inv_spacing = 1.0 / volume.spacing
    origins = np.ascontiguousarray((rays.origins - volume.origin) * inv_spacing)
    directions = np.ascontiguousarray(rays.directions * inv_spacing)
    lo = np.zeros(3)
    hi = np.array(volume.dims, dtype=np.float64) - 1.0
    params = K.GridParams(
        float(step_world), PRECISION_CODES[prec], SCALE_CODES[tf.scale],
        float(a0), float(1.0 / (a1 - a0)), float(tf.linthresh),
        1.0 - opts.termination if opts.termination > 0 else math.inf,
        float(opts.depth_threshold), int(blocks.shift),
    )
    if prec == "uint8":
        params = params._replace(scale=SCALE_CODES["linear"], axis_lo=0.0, axis_inv_range=1.0 / 255.0)
    dims = np.array(volume.dims, dtype=np.int64)
    active = blocks.visible(table[:, 3], params) if opts.skip_empty else np.ones(blocks.shape, np.uint8)
    if block_mask is not None:
        mask = np.asarray(block_mask)
        if mask.shape != blocks.shape:
            raise ValueError(f"block_mask must have shape {blocks.shape} (blocks along z, y, x); got {mask.shape}")
        if mask.dtype != np.bool_:
            raise TypeError(f"block_mask must be a bool array; got dtype {mask.dtype}")
        active = active & mask.astype(np.uint8)
    leap = leap_radius(active).reshape(-1)  # flat, (z, y, x) order
    bricks = Bricks.of(volume)
    grids = np.array(blocks.shape + bricks.shape, dtype=np.int64)

    out_dtype = np.float64 if prec == "float64" else np.float32
    rgba = np.zeros((height * width, 4), dtype=out_dtype)
    depth = np.full(height * width, np.inf, dtype=np.float64)
    samples = np.zeros(height * width, dtype=np.int64)

    # a volume with one point along an axis has no thickness: nothing to integrate
    flat = min(volume.dims) < 2
    tile_count_y = -(-height // _TILE)
    all_tile_rows = np.arange(tile_count_y, dtype=np.int64)
    lanes = _lanes()

    def cast(tile_rows):
        if not flat:
            K.render_tiles(bricks.values, table.reshape(-1), sigma, leap, grids, dims, origins, directions, width, height,
                           _TILE, np.ascontiguousarray(tile_rows), lanes, lo, hi, params, rgba, depth, samples)
        return int(np.minimum((tile_rows + 1) * _TILE, height).sum() - (tile_rows * _TILE).sum())

    _check_progress_bar(progress_bar)
    t_start = time.perf_counter()
    bar = None
    done = 0
    # Chunks are every n-th row of tiles, each a uniform sample of the image. Each chunk
    # ends in a thread barrier, so a render is split only when someone watches it.
    n = max(1, min(tile_count_y // 4, 64))
    if progress is None and progress_bar is None:
        # automatic bar: time the first chunk; go on in chunks with a bar only when the
        # whole render would take over a second, else finish in one call
        done = cast(all_tile_rows[::n])
        if (time.perf_counter() - t_start) * n > _AUTO_BAR_SECONDS and n > 1:
            bar = _progress_bar(True, height, quiet_without_tqdm=True)
            chunks = [all_tile_rows[c::n] for c in range(1, n)]
        else:
            chunks = [all_tile_rows[all_tile_rows % n != 0]]
    elif progress is None and not progress_bar:
        chunks = [all_tile_rows]
    else:
        bar = _progress_bar(progress_bar, height)
        chunks = [all_tile_rows[c::n] for c in range(n)]
    try:
        if bar is not None and done:
            bar.update(done)
        for tile_rows in chunks:
            rows = cast(tile_rows) if tile_rows.size else 0
            done += rows
            if bar is not None:
                bar.update(rows)
            if progress is not None and progress(done / height) is False:
                raise RuntimeError("render aborted")
    finally:
        if bar is not None:
            bar.close()
    elapsed = time.perf_counter() - t_start

    meta = {
        "renderer": "pv_hdrvol grid ray caster",
        "scalars": volume.name,
        "precision": prec,
        "step_voxels": opts.step,
        "step_world": step_world,
        "global_alpha": opts.global_alpha,
        "opacity_unit_distance": unit,
        "termination": opts.termination,
        "depth_threshold": opts.depth_threshold,
        "transfer_function": repr(tf),
        "camera": repr(camera) if isinstance(camera, Camera) else "rays",
        "render_seconds": elapsed,
        "samples": int(samples.sum()),
    }
    return HDRImage(rgba.reshape(height, width, 4), depth.reshape(height, width), metadata=meta)


def _derived(volume, key, make):
    """A cached variant of ``volume`` with other values (same geometry)."""
    key = ("derived", key)
    if key not in volume.cache:
        volume.cache[key] = dataclasses.replace(volume, values=np.ascontiguousarray(make()), cache={})
    return volume.cache[key]


def _quantize_u8(values, tf):
    u = (scale_forward(values, tf.scale, tf.linthresh) - tf.axis_range[0]) / (tf.axis_range[1] - tf.axis_range[0])
    with np.errstate(invalid="ignore"):
        q = np.round(np.clip(u, 0, 1) * 255)
    out = np.where(np.isnan(values), np.nan, q).astype(np.float32)
    return out


def _lanes():
    import numba

    return 8 * numba.get_num_threads()


def _check_progress_bar(value):
    if value not in (True, False, None):
        raise TypeError(f"progress_bar must be True, False or None (after 1 s); got {value!r}")


def _progress_bar(enabled, total, quiet_without_tqdm=False):
    """A tqdm bar over ``total`` rows when ``enabled`` (None without tqdm if ``quiet_without_tqdm``)."""
    if not enabled:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if quiet_without_tqdm:
            return None  # the automatic bar is a convenience: no tqdm, no bar
        raise ImportError("progress_bar=True needs tqdm (pip install tqdm)") from None
    return tqdm(total=total, desc="Rendering", unit="rows")
