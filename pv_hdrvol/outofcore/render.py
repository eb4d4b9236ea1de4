"""Render a multiresolution store out of core: level of detail per block by screen-space
error, chunks read on demand into a bounded cache, the nearest resident ancestor where
a chunk has not arrived (never a hole).

Per frame (:meth:`MultiscalePlan.execute`):

1. **Blocks.** The volume's level-0 cells are cut into blocks of 64 cells (a store
   chunk; the ray caster's empty-space blocks). Blocks outside the view frustum are not
   rendered (nor read).
2. **Level of detail.** Each block's level ``D`` is the coarsest whose voxels (the
   largest spacing times ``2**D``) project to at most ``screen_error`` pixels at the
   block's nearest point (perspective) or anywhere (parallel projection). Given rays
   (``Rays``, a lens) have no pixel footprint to measure: every block is at level 0.
3. **Empty blocks.** A block samples, at level ``L``, only the points of a few level-``L``
   chunks (``required``); the union of their stored value ranges, through the transfer
   function, says whether the block can show anything. Blocks that cannot are neither
   read nor sampled.
4. **Reads.** The chunks of the visible blocks at their levels are requested front to
   back (nearest block first) from the loader threads (:class:`~.cache.ChunkCache`).
   When they do not all fit in ``cache_bytes``, every block is coarsened by one more
   level until they do (``metadata["coarsened"]``).
5. **Pages.** Each block samples the finest level at or above its ``D`` whose required
   chunks are all resident (the coarsest level always is), so a frame rendered before
   its chunks arrive shows coarser data, never a hole. ``wait=True`` (the default)
   waits for every chunk first: the converged image.
6. **Rays.** The plain ray caster (``raycast/_kernels.render_tiles``) samples the
   pages (``_kernels.stencil``) on one lattice for the frame, ``step`` voxels of the
   finest level ``F`` any visible block samples; a block of level ``L`` takes one sample
   per ``2**(L - F)`` segments (``_kernels.span_of``), so a frame costs what its blocks'
   own levels ask for. With every block at level 0 the samples, values and arithmetic
   are those of the in-core render: the images are equal bit for bit.
"""
from __future__ import annotations

import math
import os
import threading
import time

import numpy as np

from .._validate import as_real, as_size
from ..data.transfer import SCALE_CODES, auto_transfer_function
from ..params import PRECISION_CODES
from ..raycast import _kernels as K
from ..raycast.grid import VolumePiece, ranges_visible, dilate, leap_radius, resolve_render_options
from ..raycast.frame import (MARKERS, NO_VALUE, TILE, FrameBuffers, FramePlan, check_progress_bar, frame_metadata, frame_rays,
                              pixel_rows, tile_lanes, voxel_rays, windowed)
from ..rays.camera import Camera, Rays, as_camera
from ..rays.clip import ray_spans, with_clip
from ..settings import settings_metadata
from . import _kernels as KO
from .cache import CHUNK, SLOT_EDGE, SLOT_VALUES, ChunkCache
from .store import MultiscaleStore

#: Cells a side of a block (one chunk of level 0).
BLOCK = CHUNK
DEFAULT_CACHE_BYTES = 2 * 2 ** 30


def _axis_required(n0, n_level, level, blocks):
    """Per block along one axis (``blocks`` of ``BLOCK`` cells over ``n0`` level-0
    points): the first and last level-``level`` chunk whose points its samples read."""
    i = np.arange(blocks, dtype=np.float64)
    h = (2.0 ** level - 1.0) / 2.0
    s = 2.0 ** -level
    x0 = BLOCK * i
    x1 = np.minimum(BLOCK * (i + 1), n0 - 1)
    u0 = np.clip((x0 - h) * s, 0.0, n_level - 1.0)
    u1 = np.clip((x1 - h) * s, 0.0, n_level - 1.0)
    p0 = np.floor(u0).astype(np.int64)
    p1 = np.minimum(np.floor(u1).astype(np.int64) + 1, n_level - 1)
    return p0 >> K.PAGE_SHIFT, p1 >> K.PAGE_SHIFT


class MultiscaleVolume:
    """A volume in a multiresolution store, rendered out of core (:func:`open_multiscale`).

    Attributes
    ----------
    store : MultiscaleStore
    cache_bytes : int
        The most bytes of chunks held in memory (per precision rendered).
    """

    def __init__(self, store, cache_bytes=DEFAULT_CACHE_BYTES, threads=2):
        self.store = store if isinstance(store, MultiscaleStore) else MultiscaleStore(store)
        self.cache_bytes = int(as_real("cache_bytes", cache_bytes, low=1.0))
        self.threads = int(threads)
        if self.threads < 1:
            raise ValueError(f"threads must be >= 1; got {threads}")
        self._caches = {}
        # one frame at a time per volume: frames evict chunks another frame would read
        self.lock = threading.RLock()
        s = self.store
        self.block_shape = tuple(max(1, -(-(n - 1) // BLOCK)) for n in s.levels[0].shape)  # z, y, x
        # per level and axis (z, y, x): the chunks each block's samples read
        self._required = [[_axis_required(s.levels[0].shape[a], lv.shape[a], L, self.block_shape[a])
                           for a in range(3)] for L, lv in enumerate(s.levels)]

    # -- what front ends read -------------------------------------------------------------
    @property
    def dims(self):
        return self.store.dims

    @property
    def spacing(self):
        return self.store.spacing

    @property
    def origin(self):
        return self.store.origin

    @property
    def bounds(self):
        return self.store.bounds

    @property
    def value_range(self):
        return self.store.value_range

    @property
    def name(self):
        return self.store.name

    @property
    def n_levels(self):
        return self.store.n_levels

    def cache(self, dtype=np.float32):
        """The chunk cache of the values the kernels read as ``dtype`` (made on first use:
        it reads the coarsest level)."""
        key = np.dtype(dtype).str
        if key not in self._caches:
            self._caches[key] = ChunkCache(self.store, self.cache_bytes, dtype, self.threads)
        return self._caches[key]

    def close(self):
        for c in self._caches.values():
            c.close()
        self._caches.clear()

    def default_transfer_function(self, *, cmap=None, clim=None, opacity=None, scale=None):
        """The default transfer function (as an in-core volume's), from the coarsest
        level's values: the only ones known without reading the volume."""
        s = self.store
        b = np.asarray(s.bounds, dtype=np.float64)
        diagonal = float(np.linalg.norm(b[1::2] - b[0::2]))
        unit = float(s.spacing.min())
        integer = np.issubdtype(s.dtype, np.integer)
        keywords = dict(cmap=cmap, clim=clim, opacity=opacity, scale=scale)
        if integer and scale is None:
            keywords["scale"] = "linear"
        return auto_transfer_function(s.read_level(s.n_levels - 1), diagonal / unit, spacing=s.spacing / unit,
                                      integer=integer, **keywords)

    def multiscale_plan(self, tf=None, options=None, *, labels=None, label_styles=None, **kwargs):
        """The :class:`MultiscalePlan` of this volume (what ``GridPlan(volume, ...)``
        returns for it, so that front ends that plan grids plan this too)."""
        if labels is not None or label_styles is not None:
            raise ValueError("labels= is not supported for out-of-core volumes (MultiscaleVolume) yet")
        return MultiscalePlan(self, tf, options, **kwargs)

    def render(self, tf=None, camera=None, size=(512, 512), *, screen_error=1.0, wait=True, lens=None,
               occlusion=None, progress_bar=None, progress=None, options=None, cmap=None, clim=None, opacity=None, scale=None, **option_kwargs):
        """Render (``MultiscalePlan(self, tf, ...).execute(camera, size, ...)``)."""
        plan = MultiscalePlan(self, tf, options, cmap=cmap, clim=clim, opacity=opacity, scale=scale, **option_kwargs)
        return plan.execute(camera, size, screen_error=screen_error, wait=wait, lens=lens, occlusion=occlusion,
                            progress_bar=progress_bar, progress=progress)

    def __repr__(self):
        return f"MultiscaleVolume({self.store.path!r}, {self.n_levels} levels, level 0 {self.dims} points)"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def open_multiscale(path, cache_bytes=DEFAULT_CACHE_BYTES, threads=2):
    """Open a multiresolution store (:func:`~pv_hdrvol.write_multiscale`, ``pv-hdrvol
    convert``) for rendering out of core.

    Parameters
    ----------
    path : str or os.PathLike
        The store (``*.ome.zarr``).
    cache_bytes : int
        The most bytes of chunks kept in memory (default 2 GiB); at least enough for the
        coarsest level and one block (a ``ValueError`` says how much).
    threads : int
        Loader threads that read chunks while the renderer works.

    Returns
    -------
    MultiscaleVolume
        ``hv.render`` takes it, as ``volume.render(...)``.
    """
    return MultiscaleVolume(MultiscaleStore(os.fspath(path)), cache_bytes, threads)


class MultiscalePlan(FramePlan):
    """An out-of-core render validated once, executed for any camera (see the module).

    Parameters
    ----------
    volume : MultiscaleVolume
    tf, options, cmap, clim, opacity, scale, **option_kwargs
        As :func:`pv_hdrvol.render`. Composite blending without shading or gradient
        opacity, in float64, float32 or float16 (the out-of-core path samples values
        only; the rest comes later).
    """

    def __init__(self, volume, tf=None, options=None, *, cmap=None, clim=None, opacity=None, scale=None,
                 **option_kwargs):
        if not isinstance(volume, MultiscaleVolume):
            raise TypeError(f"volume must be a MultiscaleVolume (pv_hdrvol.open_multiscale); got {type(volume).__name__}")
        self.default_tf = tf is None
        tf, opts = resolve_render_options(volume, tf, options, cmap=cmap, clim=clim, opacity=opacity, scale=scale,
                                          **option_kwargs)
        refused = [name for name, on in (("shade=True", opts.shade), ("gradient_opacity=", opts.gradient_opacity),
                                         (f"blending={opts.blending!r}", opts.blending != "composite"),
                                         ("tolerance=", opts.tolerance is not None),
                                         ("precision='uint8'", opts.precision == "uint8"),
                                         (f"device={opts.device!r}", opts.device != "cpu")) if on]
        if refused:
            raise ValueError(f"an out-of-core volume renders composite blending of values in float64, float32 or "
                             f"float16; {', '.join(refused)} is not supported for it yet")
        self.volume, self.tf, self.options = volume, tf, opts
        prec = opts.precision
        self.dtype = np.float64 if prec == "float64" and volume.store.dtype == np.float64 else np.float32
        table_dtype = np.float64 if prec == "float64" else np.float32
        h0 = float(volume.spacing.min())
        self.unit = opts.opacity_unit_distance if opts.opacity_unit_distance is not None else h0
        rgb, sigma = tf.table(np.float64, opts.global_alpha, self.unit, tf.table_size)
        self._rgb, self._sigma64, self._table_dtype = rgb, sigma, table_dtype
        self.sigma = np.ascontiguousarray(sigma, dtype=table_dtype)
        self._tables = {}
        a0, a1 = tf.axis_range
        self.params = K.GridParams(
            float(opts.step * h0), PRECISION_CODES[prec], SCALE_CODES[tf.scale], float(a0), float(1.0 / (a1 - a0)),
            float(tf.linthresh), 1.0 - opts.termination if opts.termination > 0 else math.inf,
            float(opts.depth_threshold), K.PAGE_SHIFT)
        # which blocks can show anything, per level (from the stored ranges alone)
        self._visible = [self._visible_at(L) for L in range(volume.n_levels)]

    def table(self, finest):
        """The (r, g, b, opacity of one step) table for a frame stepping at ``finest``'s
        voxels, and that step in world units."""
        if finest not in self._tables:
            step_world = self.options.step * float(self.volume.spacing.min()) * 2 ** finest
            alpha = -np.expm1(-self._sigma64 * step_world)
            table = np.ascontiguousarray(np.column_stack([self._rgb, alpha]), dtype=self._table_dtype)
            self._tables[finest] = (table, step_world)
        return self._tables[finest]

    def _corner_gather(self, level, values):
        """For every block (z, y, x), ``values`` (a per-chunk array of ``level``) at each of
        the up to 8 chunks its samples read: a list of 8 arrays of the block grid's shape."""
        (z0, z1), (y0, y1), (x0, x1) = self._volume_required(level)
        out = []
        for zz in (z0, z1):
            for yy in (y0, y1):
                for xx in (x0, x1):
                    out.append(values[zz[:, None, None], yy[None, :, None], xx[None, None, :]])
        return out

    def _volume_required(self, level):
        return self.volume._required[level]

    def _visible_at(self, level):
        ranges = self.volume.store.levels[level].ranges
        lo = np.minimum.reduce(self._corner_gather(level, ranges[..., 0]))
        hi = np.maximum.reduce(self._corner_gather(level, ranges[..., 1]))
        # +-inf is read as the finite extremes (cache.py), as in memory; no number: none
        none = ~(lo <= hi)
        if np.issubdtype(self.volume.store.dtype, np.floating):
            v0, v1 = self.volume.value_range
            lo, hi = np.clip(lo, v0, v1), np.clip(hi, v0, v1)
            lo[none], hi[none] = np.inf, -np.inf
        table = self.table(0)[0]
        return ranges_visible(lo, hi, table[:, 3], self.params).astype(bool)

    def _ready_at(self, cache, level):
        lv = self.volume.store.levels[level]
        ready = cache.slots[int(cache.bases[level]):int(cache.bases[level + 1])].reshape(lv.chunks) >= 0
        return np.logical_and.reduce(self._corner_gather(level, ready))

    def _keys(self, level, blocks):
        """The chunk keys ``(level, cz, cy, cx)`` that ``blocks`` (indices z, y, x arrays)
        read at ``level``, in the blocks' order, without repeats."""
        (z0, z1), (y0, y1), (x0, x1) = self._volume_required(level)
        kz, ky, kx = blocks
        _, cy, cx = self.volume.store.levels[level].chunks
        flat = np.stack([(zz[kz] * cy + yy[ky]) * cx + xx[kx] for zz in (z0, z1) for yy in (y0, y1)
                         for xx in (x0, x1)], axis=1).reshape(-1)  # block by block
        _, first = np.unique(flat, return_index=True)
        chunks = flat[np.sort(first)]
        cz_, rest = np.divmod(chunks, cy * cx)
        cy_, cx_ = np.divmod(rest, cx)
        return [(level, int(a), int(b), int(c)) for a, b, c in zip(cz_.tolist(), cy_.tolist(), cx_.tolist())]

    def _block_boxes(self):
        """Per axis (x, y, z): the world coordinates where each block starts and ends."""
        vol = self.volume
        dims = np.array(vol.dims, dtype=np.float64)
        idx = [np.arange(n, dtype=np.float64) for n in vol.block_shape[::-1]]
        lo = [vol.origin[a] + BLOCK * idx[a] * vol.spacing[a] for a in range(3)]
        hi = [vol.origin[a] + np.minimum(BLOCK * (idx[a] + 1), dims[a] - 1) * vol.spacing[a] for a in range(3)]
        return lo, hi

    def block_distance(self, camera):
        """Per block (z, y, x): the distance from the eye to the block's nearest point (0
        inside it; 0 everywhere for given rays): the order in which chunks are read."""
        if not isinstance(camera, Camera):
            return np.zeros(self.volume.block_shape)
        lo, hi = self._block_boxes()
        pos = np.asarray(camera.position, dtype=np.float64)
        d = [np.maximum(np.maximum(lo[a] - pos[a], pos[a] - hi[a]), 0.0) for a in range(3)]
        return np.sqrt(d[2][:, None, None] ** 2 + d[1][None, :, None] ** 2 + d[0][None, None, :] ** 2)

    def desired_levels(self, camera, size, screen_error=1.0):
        """Per block (z, y, x): the level screen-space error asks for, or -1 outside the
        view. ``camera``: a Camera (the distance of each block's nearest point, the
        frustum) or Rays (a lens's: :meth:`_ray_levels`)."""
        vol = self.volume
        shape = vol.block_shape
        if isinstance(camera, Rays):
            return self._ray_levels(camera, screen_error)
        w, h = as_size(size)
        lo, hi = self._block_boxes()
        pos = np.asarray(camera.position, dtype=np.float64)
        dist = self.block_distance(camera)
        right, up, fwd = camera.basis()
        if camera.parallel_projection:
            half_h = camera.parallel_scale
            pixel = np.full(shape, 2.0 * half_h / h)
        else:
            half_h = math.tan(math.radians(camera.view_angle) / 2.0)
            pixel = dist * (2.0 * half_h / h)
        half_w = half_h * w / h
        voxel = float(vol.spacing.max())
        with np.errstate(divide="ignore"):
            level = np.floor(np.log2(np.maximum(screen_error * pixel / voxel, 1e-300)))
        level = np.clip(level, 0, vol.n_levels - 1).astype(np.int64)
        # outside the frustum: every corner beyond one side plane (a pixel's margin)
        margin = 1.0 + 2.0 / min(w, h)
        outside = np.zeros(shape, dtype=bool)
        corners = []
        for cz in (lo[2], hi[2]):
            for cy in (lo[1], hi[1]):
                for cx in (lo[0], hi[0]):
                    rel = (cx[None, None, :] - pos[0], cy[None, :, None] - pos[1], cz[:, None, None] - pos[2])
                    x = rel[0] * right[0] + rel[1] * right[1] + rel[2] * right[2]
                    y = rel[0] * up[0] + rel[1] * up[1] + rel[2] * up[2]
                    z = rel[0] * fwd[0] + rel[1] * fwd[1] + rel[2] * fwd[2]
                    corners.append(np.broadcast_arrays(x, y, z))
        xs = np.stack([c[0] for c in corners])
        ys = np.stack([c[1] for c in corners])
        zs = np.stack([c[2] for c in corners])
        if camera.parallel_projection:
            outside |= (xs > half_w * margin).all(0) | (xs < -half_w * margin).all(0)
            outside |= (ys > half_h * margin).all(0) | (ys < -half_h * margin).all(0)
        else:
            outside |= (zs <= 0).all(0)
            outside |= (xs > zs * half_w * margin).all(0) | (xs < -zs * half_w * margin).all(0)
            outside |= (ys > zs * half_h * margin).all(0) | (ys < -zs * half_h * margin).all(0)
        level[outside] = -1
        return level

    with_clip = with_clip

    def _ray_levels(self, rays, screen_error):
        """:meth:`desired_levels` of given rays (a lens's, or any): per block, the finest
        level any ray crossing it asks for, from the distance to the rays of the
        neighbouring pixels over the ray's stretch in the block (``_kernels.ray_block_levels``:
        a magnifier's dense rays ask for finer blocks). Blocks no ray crosses are -1,
        except those next to one (rounding at a block's face): the coarsest level."""
        vol = self.volume
        n_levels = vol.n_levels
        out = np.full(vol.block_shape, n_levels, dtype=np.int64)
        KO.ray_block_levels(np.ascontiguousarray(rays.origins, dtype=np.float64),
                            np.ascontiguousarray(rays.directions, dtype=np.float64), rays.width, rays.height,
                            vol.origin, 1.0 / vol.spacing, np.array(vol.dims, dtype=np.int64), float(BLOCK),
                            np.array(vol.block_shape, dtype=np.int64), float(vol.spacing.max()),
                            float(screen_error), n_levels, out)
        hit = out < n_levels
        level = np.where(hit, out, np.where(dilate(hit), n_levels - 1, -1))
        return level

    def execute(self, camera=None, size=(512, 512), *, screen_error=1.0, wait=True, timeout=None, progress=None,
                progress_bar=None, chunk_seconds=None, window=None, far=None, lens=None, block_mask=None, cull=None,
                piece=None, occlusion=None, _pass=False, _culled=None):
        """Render one frame; returns an :class:`~pv_hdrvol.HDRImage`.

        ``screen_error``: the largest projected voxel, in pixels, a block may show
        (default 1). ``wait``: wait for every chunk the frame asks for (the converged
        image); ``False`` renders what is resident now (coarser ancestors where chunks
        have not arrived) and leaves the rest loading for the next frame. ``timeout``:
        seconds to wait at most (then as ``wait=False``).
        ``chunk_seconds``, ``window`` and ``far``: as :meth:`GridPlan.execute
        <pv_hdrvol.raycast.grid.GridPlan.execute>` (a window's level of detail is the
        whole image's).
        ``occlusion``: leave out blocks that the conservative occlusion bound
        (:func:`~pv_hdrvol.culling.bound.occluded_blocks`, from the store's value ranges
        per cube of 8 points) shows every ray reaches only after it has stopped: they are
        neither read nor sampled, and the image does not change. Default: for frames that
        wait (the converged ones, where reading is the cost), when the store has the
        ranges, the precision is float32 or float64 and rays terminate.
        ``metadata``: ``levels`` (blocks per level), ``converged``, ``pending``,
        ``bytes_read`` and ``chunks_read`` (per level, by this volume's cache so far),
        ``coarsened``, ``passes``, ``occluded`` (blocks left out, or None).
        """
        # frames of one volume from several threads (viewers, scenes) take turns: a frame
        # evicts chunks another would read
        with self.volume.lock:
            return self._execute(camera, size, screen_error=screen_error, wait=wait, timeout=timeout,
                                 progress=progress, progress_bar=progress_bar, chunk_seconds=chunk_seconds,
                                 window=window, far=far, lens=lens, block_mask=block_mask, cull=cull, piece=piece,
                                 occlusion=occlusion, _pass=_pass, _culled=_culled)

    def _execute(self, camera=None, size=(512, 512), *, screen_error=1.0, wait=True, timeout=None, progress=None,
                 progress_bar=None, chunk_seconds=None, window=None, far=None, lens=None, block_mask=None, cull=None,
                 piece=None, occlusion=None, _pass=False, _culled=None):
        vol, opts = self.volume, self.options
        for name, value in (("block_mask", block_mask), ("cull", cull)):
            if value is not None:
                raise ValueError(f"{name}= is not supported for out-of-core volumes (MultiscaleVolume) yet")
        owned = None if piece is None else self._check_piece(piece)
        screen_error = as_real("screen_error", screen_error, low=0.0, low_open=True)
        check_progress_bar(progress_bar)
        camera = as_camera(camera, vol.bounds)
        rays, width, height = frame_rays(camera, size, lens)
        lens_camera = None
        if lens is not None:
            lens_camera, camera = camera, rays
        cache = vol.cache(self.dtype)
        t_start = time.perf_counter()
        # (a ray's level of detail, Rays.lod, is not read: the blocks' levels come from
        # the rays' footprints, which a minifying lens's sparse rays make coarser)
        desired = self.desired_levels(camera, (width, height), screen_error)
        rays, far, width, height = windowed(camera, rays, far, window, width, height)
        n_levels = vol.n_levels
        shown, piece_finest, occluded = self._shown_blocks(
            desired, owned, _culled, wait if occlusion is None else occlusion,
            lambda: rays if rays is not None else camera.rays((width, height)))
        coarsened = 0
        order = np.argsort(self.block_distance(camera)[shown], kind="stable")  # nearest blocks first
        while True:
            want, keys = self._wanted_chunks(shown, desired, coarsened, order)
            if len(keys) + len(cache.permanent) <= cache.n_slots or coarsened >= n_levels:
                break
            if wait and piece is None and window is None and not _pass:
                # a converged frame that does not fit: render it in boxes that do, one after
                # another, and composite them (the same image to rounding; reads each once)
                return self._in_passes(camera, lens_camera, lens, (width, height), rays, screen_error, timeout,
                                       shown, want, keys, far, t_start, occluded)
            coarsened += 1
        refused = cache.request(keys, pinned=keys)
        cache.touch(keys)
        if wait:
            cache.wait(keys, timeout=timeout)
        cache.raise_errors()
        level, active = self._resident_levels(cache, shown, want)
        finest = int(level[active].min()) if active.any() else n_levels - 1
        if owned is not None or occluded is not None:  # the lattice the pieces or the bound assumed
            finest = min(finest, piece_finest)
        table, step_world = self.table(finest)
        params = self.params._replace(step=float(step_world))
        offs, leap = self._pages(cache, level, active, finest)
        bz, by, bx = vol.block_shape
        grids = np.array([bz, by, bx, 1, 1, 1], dtype=np.int64)
        dims = np.array(vol.dims, dtype=np.int64)
        cam, origins, directions = voxel_rays(camera, rays, width, height, vol.origin, 1.0 / vol.spacing)
        span = ray_spans(rays if rays is not None else camera, (width, height), opts, far)
        lo = np.zeros(3)
        hi = dims.astype(np.float64) - 1.0
        piece_box = np.concatenate([lo, hi, np.zeros(3)]) if piece is None else \
            np.array(list(piece.owned_lo) + list(piece.owned_hi) + [0, 0, 0], dtype=np.float64)
        prec = opts.precision
        out = FrameBuffers(width, height, prec)
        marker = MARKERS[prec]
        lanes = tile_lanes()
        flat = min(vol.dims) < 2

        def cast(tile_rows):
            rows = np.ascontiguousarray(tile_rows)
            if not flat:
                K.render_tiles(marker, cache.pool, offs, table.reshape(-1), self.sigma, leap, grids, dims, cam,
                               origins, directions, span, width, height, TILE, rows, lanes, lo, hi, piece_box,
                               params, 0, 0, out.rgba, out.depth, out.counts, NO_VALUE)
            return pixel_rows(tile_rows, height)

        self.run_frame(cast, height, progress, progress_bar, chunk_seconds)
        elapsed = time.perf_counter() - t_start
        shown_camera = repr(camera) if isinstance(camera, Camera) else repr(lens_camera) if lens is not None else "rays"
        settings = settings_metadata(self.tf, camera if lens is None else lens_camera, (width, height), opts,
                                     window=window, lens=lens)
        meta = frame_metadata("pv_hdrvol out-of-core grid ray caster", vol.name, self.tf, shown_camera, opts,
                              self.unit, settings, elapsed, store=vol.store.path, step_voxels=opts.step,
                              step_world=step_world)
        meta["samples"] = int(out.counts.sum())
        meta.update(self._frame_reads(cache, screen_error, level, active, desired, shown, want, coarsened, refused,
                                      occluded))
        if lens is not None:
            meta["lens"] = repr(lens)
        if piece is not None:
            meta["piece"] = {"offset": [0, 0, 0], "owned_lo": list(piece.owned_lo), "owned_hi": list(piece.owned_hi),
                             "whole_dims": list(piece.whole_dims)}
        return out.image(meta)

    def _shown_blocks(self, desired, owned, culled, occlusion, frame_rays):
        """``(shown, piece_finest, occluded)``: the blocks a frame draws (visible where the
        desired level's data can show anything under the function, not occluded, owned by
        the piece), the finest level any visible block of the whole asks for (a piece
        steps as the whole render does: from metadata and the camera alone, the same on
        every process), and the occluded blocks (``culled`` if given; the bound's when
        ``occlusion``, on ``frame_rays()``; else None)."""
        n_levels = self.volume.n_levels
        shown = desired >= 0
        for L in range(n_levels):
            at = desired == L
            shown[at] &= self._visible[L][at]
        piece_finest = int(desired[shown].min()) if shown.any() else n_levels - 1
        occluded = culled
        if occluded is None and occlusion and shown.any():
            occluded = self.occluded(frame_rays(), shown, desired, piece_finest)
        if occluded is not None:
            shown &= ~occluded
        if owned is not None:
            shown &= owned
        return shown, piece_finest, occluded

    def _wanted_chunks(self, shown, desired, coarsened, order):
        """``(want, keys)``: each shown block's level, ``coarsened`` levels coarser than it
        desires (-1: not shown), and the chunks those levels read, nearest blocks first
        (``order``), each once."""
        n_levels = self.volume.n_levels
        want = np.where(shown, np.minimum(desired + coarsened, n_levels - 1), -1)
        blocks = np.nonzero(shown)
        keys = []
        seen = set()
        for L in range(n_levels):
            sel = want[blocks] == L
            if sel.any():
                for key in self._keys(L, tuple(b[order][sel[order]] for b in blocks)):
                    if key not in seen:
                        seen.add(key)
                        keys.append(key)
        return want, keys

    def _resident_levels(self, cache, shown, want):
        """``(level, active)``: each shown block at the finest resident level at or above
        the one it wants, and the blocks that can show anything at their level."""
        vol = self.volume
        level = np.full(vol.block_shape, vol.n_levels - 1, dtype=np.int64)
        assigned = np.zeros(vol.block_shape, dtype=bool)
        for L in range(vol.n_levels):
            ok = shown & ~assigned & (want <= L) & self._ready_at(cache, L)
            level[ok] = L
            assigned |= ok
        return level, shown & self._visible_at_levels(level)

    def _pages(self, cache, level, active, finest):
        """The kernel's page tables of a frame (``offs``: each block's level and slot base,
        the levels' points and placement, its samples per segment) and the leap radii,
        after checking that every active block's chunks are resident and filling their
        aprons."""
        vol = self.volume
        for L in np.unique(level[active]):  # never sample a chunk that is not resident
            chunks = self._keys(int(L), np.nonzero(active & (level == L)))
            missing = [k for k in chunks if not cache.is_ready(k)]
            if missing:
                raise RuntimeError(f"internal error: blocks at level {L} read chunks not in memory: {missing[:4]}")
        # each active block's slot: the chunk of its level that holds it, its apron filled
        kz, ky, kx = np.nonzero(active)
        lv = level[active]
        central = np.stack([lv, kz >> lv, ky >> lv, kx >> lv], axis=1)
        cache.fill_aprons({tuple(int(v) for v in row) for row in np.unique(central, axis=0)})
        chunk_shape = np.array([lv_.chunks for lv_ in vol.store.levels], dtype=np.int64)[central[:, 0]]
        slot = cache.slots[cache.bases[central[:, 0]] + (central[:, 1] * chunk_shape[:, 1] + central[:, 2])
                           * chunk_shape[:, 2] + central[:, 3]]
        e = SLOT_EDGE
        first = CHUNK * central[:, 1:] - 1  # the slot's first point (z, y, x) in its level
        base = np.zeros(vol.block_shape, dtype=np.int64)
        base[active] = slot * SLOT_VALUES - ((first[:, 0] * e + first[:, 1]) * e + first[:, 2])
        page_level = np.ascontiguousarray(level.astype(np.uint8).reshape(-1))
        page_base = np.ascontiguousarray(base.reshape(-1))
        dims_of = np.array([lv_.shape[::-1] for lv_ in vol.store.levels], dtype=np.int64)
        place = np.array([[(2.0 ** L - 1.0) / 2.0, 2.0 ** -L] for L in range(vol.n_levels)])
        # a block of level L samples once per 2**(L - finest) segments of the frame's lattice
        segments = np.ones(vol.block_shape, dtype=np.int64)
        segments[active] = 1 << (level[active] - finest)
        offs = (page_level, page_base, dims_of, place, np.ascontiguousarray(segments.reshape(-1)))
        return offs, leap_radius(active).reshape(-1)

    def _frame_reads(self, cache, screen_error, level, active, desired, shown, want, coarsened, refused, occluded):
        """The out-of-core metadata of a frame: levels asked for and rendered, whether it
        converged, the chunks read and pending, the cache's bytes."""
        n_levels = self.volume.n_levels
        return {
            "screen_error": screen_error,
            "levels": [int(c) for c in np.bincount(level[active], minlength=n_levels)],
            "desired_levels": [int(c) for c in np.bincount(np.minimum(desired[shown] + coarsened, n_levels - 1),
                                                            minlength=n_levels)],
            "converged": bool((level[shown] == want[shown]).all()),
            "pending": cache.pending,
            "not_requested": int(refused),
            "coarsened": coarsened,
            "passes": 1,
            "occluded": None if occluded is None else int(occluded.sum()),
            "bytes_read": int(sum(cache.bytes_read)),
            "bytes_read_per_level": [int(b) for b in cache.bytes_read],
            "chunks_read_per_level": [int(c) for c in cache.chunks_read],
            "cache_bytes": cache.pool.nbytes,
            "resident_bytes": cache.resident_bytes,
        }

    def _in_passes(self, camera, lens_camera, lens, size, rays, screen_error, timeout, shown, want, keys, far,
                   t_start, occluded):
        """The converged frame in passes: boxes of whole blocks (``split_boxes`` of the
        block grid, more until each box's chunks fit the cache), each rendered as a piece
        (the whole frame's lattice and step, samples whose midpoints it owns), composited
        per pixel in the order the ray enters the boxes, as a distributed render's."""
        from ..parallel.pieces import box_entries, split_boxes
        from ..raycast.compositing import composite_in_order

        vol = self.volume
        cache = vol.cache(self.dtype)
        room = cache.n_slots - len(cache.permanent)
        bz, by, bx = vol.block_shape
        n = max(2, -(-len(keys) * 5 // (4 * max(room, 1))))
        blocks = np.nonzero(shown)
        while True:
            if n > bx * by * bz:
                raise ValueError(f"cache_bytes={cache.cache_bytes} cannot hold the chunks of one block of this "
                                 f"frame; open the store with a larger cache")
            boxes = split_boxes((bx + 1, by + 1, bz + 1), n)
            fits = True
            for lo, hi in boxes:
                inside = ((blocks[0] >= lo[2]) & (blocks[0] < hi[2]) & (blocks[1] >= lo[1]) & (blocks[1] < hi[1])
                          & (blocks[2] >= lo[0]) & (blocks[2] < hi[0]))
                count = sum(len(self._keys(L, tuple(b[inside & (want[blocks] == L)] for b in blocks)))
                            for L in range(vol.n_levels))
                if count > room:
                    fits = False
                    break
            if fits:
                break
            n *= 2
        dims = np.array(vol.dims)
        pieces = [VolumePiece(tuple(vol.origin.tolist()), tuple(int(d) for d in dims), (0, 0, 0),
                              tuple(int(v) for v in np.minimum(BLOCK * np.array(lo), dims - 1)),
                              tuple(int(v) for v in np.minimum(BLOCK * np.array(hi), dims - 1))) for lo, hi in boxes]
        frame = rays if rays is not None else camera
        far = far.reshape(size[1], size[0]) if far.size else None
        culled = np.zeros(vol.block_shape, dtype=bool) if occluded is None else occluded
        images = [self.execute(frame, size, screen_error=screen_error, wait=True, timeout=timeout, far=far,
                               piece=p, progress_bar=False, _pass=True, _culled=culled) for p in pieces]
        rays = rays if rays is not None else camera.rays(size)
        image = composite_in_order(images, box_entries(rays, [p.world_box(vol.spacing) for p in pieces]))
        meta = image.metadata
        meta.pop("piece", None)
        meta["levels"] = [int(v) for v in np.sum([im.metadata["levels"] for im in images], axis=0)]
        meta["desired_levels"] = [int(v) for v in np.bincount(want[shown], minlength=vol.n_levels)]
        meta["converged"] = all(im.metadata["converged"] for im in images)
        meta["passes"] = len(pieces)
        meta["occluded"] = None if occluded is None else int(occluded.sum())
        meta["camera"] = repr(camera) if isinstance(camera, Camera) else repr(lens_camera) if lens else "rays"
        for key in ("bytes_read", "bytes_read_per_level", "chunks_read_per_level", "pending", "resident_bytes"):
            meta[key] = images[-1].metadata[key]
        meta["render_seconds"] = time.perf_counter() - t_start
        if lens is not None:
            meta["lens"] = repr(lens)
        return image

    def occluded(self, rays, shown, desired, finest):
        """Blocks (bool, z, y, x) among ``shown`` that every ray sampling them reaches
        only behind the render's termination opacity, by the conservative occlusion bound
        (:func:`~pv_hdrvol.culling.bound.occluded_blocks`); ``None`` where it does not
        apply (no group ranges in the store, float16, no termination).

        The bound's value ranges are the store's per cube of 8 level-0 points, widened by
        the reach of the coarsest level ``L`` asked for (``1.5 * 2**L`` voxels: a coarse
        point is a mean of level-0 points that far; a coarse block's one sample for
        several segments lies within half their length), so they hold every value any
        sample of the frame interpolates; the march steps on the frame's lattice
        (``finest``'s)."""
        from ..culling.bound import occluded_blocks, table_axis
        from .store import GROUP

        opts = self.options
        store = self.volume.store
        groups = store.group_ranges()
        if groups is None or opts.precision not in ("float32", "float64") or not opts.termination > 0:
            return None
        reach = max(1, math.ceil(1.5 * 2 ** int(desired[shown].max()) / GROUP))
        lo, hi = self._widened_groups(groups, reach)
        vol = self.volume
        _, step_world = self.table(finest)
        box = (vol.origin, vol.origin + (np.array(vol.dims) - 1) * vol.spacing)
        per_block = BLOCK // GROUP
        mask = occluded_blocks(lo, hi, self._sigma64, table_axis(self.tf), origin=vol.origin,
                               group_size=GROUP * vol.spacing, rays=rays, step=step_world, box=box,
                               block_groups=per_block, threshold=1.0 - opts.termination, precision=opts.precision)
        # the bound's blocks start where this renderer's do; a trailing one (the last plane of
        # points) belongs to the block before it here: occluded only if both are
        out = mask[tuple(slice(0, n) for n in vol.block_shape)].copy()
        for axis, n in enumerate(vol.block_shape):
            if mask.shape[axis] > n:
                extra = np.take(mask, [n], axis=axis)[tuple(slice(0, m) for m in vol.block_shape)]
                last = [slice(None)] * 3
                last[axis] = slice(n - 1, n)
                out[tuple(last)] &= extra
        return out & shown

    def _widened_groups(self, groups, reach):
        """The group ranges' minimum and maximum over the ``reach`` groups around each
        (kept per reach: the ranges never change)."""
        cache = self.volume.__dict__.setdefault("_widened", {})
        if reach not in cache:
            lo, hi = groups[..., 0].copy(), groups[..., 1].copy()
            for _ in range(reach):
                for axis in range(3):
                    a = [slice(None)] * 3
                    b = [slice(None)] * 3
                    a[axis], b[axis] = slice(1, None), slice(None, -1)
                    lo2, hi2 = lo.copy(), hi.copy()
                    np.minimum(lo2[tuple(a)], lo[tuple(b)], out=lo2[tuple(a)])
                    np.minimum(lo2[tuple(b)], lo[tuple(a)], out=lo2[tuple(b)])
                    np.maximum(hi2[tuple(a)], hi[tuple(b)], out=hi2[tuple(a)])
                    np.maximum(hi2[tuple(b)], hi[tuple(a)], out=hi2[tuple(b)])
                    lo, hi = lo2, hi2
            cache.clear()  # one reach at a time: each is two float64 arrays of the groups
            cache[reach] = (lo, hi)
        return cache[reach]

    def _check_piece(self, piece):
        """The blocks (bool, z, y, x) whose cells meet ``piece``'s owned box, after checking
        that ``piece`` is a :class:`VolumePiece` of this store's level 0 (offset 0: every
        process addresses the store's chunks itself)."""
        vol = self.volume
        if not isinstance(piece, VolumePiece):
            raise TypeError(f"piece must be a VolumePiece; got {type(piece).__name__}")
        if tuple(piece.whole_dims) != tuple(vol.dims) or \
                not np.allclose(np.asarray(piece.whole_origin, float), vol.origin, rtol=0, atol=0):
            raise ValueError(f"the piece is of a volume of {tuple(piece.whole_dims)} points at "
                             f"{tuple(piece.whole_origin)}; the store's level 0 has {tuple(vol.dims)} at "
                             f"{tuple(vol.origin.tolist())}")
        if tuple(piece.offset) != (0, 0, 0):
            raise ValueError(f"a piece of a store has offset (0, 0, 0) (it reads the store's own chunks); got "
                             f"{tuple(piece.offset)}")
        lo = np.array(piece.owned_lo)[::-1]  # z, y, x
        hi = np.array(piece.owned_hi)[::-1]
        if (lo < 0).any() or (hi > np.array(vol.dims)[::-1] - 1).any() or (hi <= lo).any():
            raise ValueError(f"the owned box {tuple(piece.owned_lo)}..{tuple(piece.owned_hi)} is not a box of "
                             f"the volume's {tuple(vol.dims)} points")
        meets = [(BLOCK * np.arange(n) < h) & (BLOCK * (np.arange(n) + 1) > l)
                 for n, l, h in zip(vol.block_shape, lo, hi)]
        return meets[0][:, None, None] & meets[1][None, :, None] & meets[2][None, None, :]

    def _visible_at_levels(self, level):
        out = np.zeros(level.shape, dtype=bool)
        for L in range(self.volume.n_levels):
            at = level == L
            out[at] = self._visible[L][at]
        return out


__all__ = ["MultiscalePlan", "MultiscaleVolume", "open_multiscale"]
