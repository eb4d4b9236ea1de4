"""Render image volumes: validate, build tables and the block grid, call the kernel."""
from __future__ import annotations

import contextlib
import dataclasses
import math
import threading
import time
from typing import NamedTuple

import numpy as np

from ..data.grid import GridVolume, as_volume, content_digest  # as_volume: re-exported
from ..data.transfer import (SCALE_CODES, SCALES, TF_KEYWORDS, TransferFunction, auto_transfer_function,
                             scale_forward, table_entry_span)
from ..params import BLENDING_CODES, PRECISION_CODES, RenderOptions
from ..rays.camera import Camera, as_camera, fit_camera
from ..rays.clip import has_clip, ray_spans, with_clip
from ..settings import settings_metadata
from . import _kernels as K
from . import _kernels_ext as KX
from ._composite_kernels import projection_marker
from .memory import check_memory
from .frame import (MARKERS, NO_VALUE, TILE, FrameBuffers, FramePlan, check_lod, check_progress_bar, frame_metadata,
                    frame_rays, pixel_rows, tile_lanes, voxel_rays, windowed)
from .shading import shading_arrays, shading_metadata

# empty-space structures kept per volume (one per transfer function and block mask)
_SKIP_CACHE = 4


def default_transfer_function(volume, *, cmap=None, clim=None, opacity=None, scale=None):
    """The default transfer function of an image volume or a tetrahedral mesh:
    :func:`~pv_hdrvol.data.transfer.auto_transfer_function` of its values, for a ray
    as long as the bounding box's diagonal in unit distances (the smallest spacing; a
    mesh's typical cell size). Integer data (CT) keeps a linear axis and gets its
    classes separated (``integer=True``).

    ``cmap``, ``clim``, ``opacity`` (PyVista's ``add_volume`` keywords, with its
    meanings) and ``scale`` (the axis) each replace one choice; what is not given
    stays the default's (:data:`TF_KEYWORDS`)."""
    b = np.asarray(volume.bounds, dtype=np.float64)
    diagonal = float(np.linalg.norm(b[1::2] - b[0::2]))
    keywords = dict(cmap=cmap, clim=clim, opacity=opacity, scale=scale)
    if isinstance(volume, GridVolume):
        unit = volume.min_cell_width
        if volume.integer and scale is None:
            keywords["scale"] = "linear"
        # a rectilinear grid's points weighted by the volume each stands for (as a mesh's):
        # a finely resolved region does not dominate the histogram
        weights = None if volume.axes is None else point_volumes(volume.axes)
        return auto_transfer_function(volume.values, diagonal / unit, spacing=volume.spacing / unit,
                                      weights=weights, integer=volume.integer, **keywords)
    # a mesh's values weighted by the volume they stand for: what fills space, not where
    # the mesh is fine, is its background
    volumes = np.abs(volume.cell_volumes())
    values = np.asarray(volume.values)
    weights = np.broadcast_to((volumes / values.shape[1])[:, None], values.shape) if values.ndim == 2 else volumes
    return auto_transfer_function(values, diagonal / volume.default_unit_distance(), weights=weights, **keywords)


def point_volumes(axes):
    """The volume (z, y, x) each point of a rectilinear grid with coordinates ``axes``
    (x, y, z) stands for: the product of its dual cell's widths, half of each
    neighbouring cell's along every axis."""
    dual = []
    for c in axes:
        w = np.diff(c)
        d = np.zeros(c.size)
        d[:-1] += 0.5 * w
        d[1:] += 0.5 * w
        dual.append(d)
    return dual[2][:, None, None] * dual[1][None, :, None] * dual[0][None, None, :]


#: At most this many buckets per nominal voxel in a rectilinear axis's lookup table
#: (:func:`warp_arrays`): enough for one cell boundary per bucket while the narrowest
#: cell is at least 1/64 of the mean; beyond, a lookup walks a few boundaries more.
_MAX_BUCKETS_PER_VOXEL = 64


def nominal_coordinates(c):
    """An axis's points in nominal voxel units, ``(c - c[0]) / h`` for the mean spacing
    ``h``, ending exactly at ``0`` and ``n - 1``: the frame rays of a rectilinear grid
    march in (``_kernels._march``)."""
    h = (c[-1] - c[0]) / (c.size - 1)
    cu = (c - c[0]) / h
    cu[0], cu[-1] = 0.0, c.size - 1.0
    return cu


def warp_arrays(volume, frame=None):
    """The kernels' ``warp`` (``_kernels.warp_at``): ``0`` for a uniform volume, else the
    tuple ``(cu, inv_w, first, bucket_base, bucket_scale)`` of its axes, built once and
    cached on the volume. ``frame`` (3 arrays): a piece of a whole rectilinear grid, its
    points' nominal coordinates in the whole grid's frame less its first point's
    (``VolumePiece.nominal``): they start at 0 and end where the piece ends there.

    Per axis of ``n`` points: ``cu`` the nominal voxel coordinates of the points
    (``(c - c[0]) / h``, ``h`` the nominal spacing; ends exactly ``0`` and ``n - 1``),
    ``inv_w`` the reciprocal widths of the cells in those units (0 after the last point),
    and ``M + 1`` buckets over ``[0, n - 1]``, ``M = ceil((n - 1) / narrowest cell)``
    (capped at :data:`_MAX_BUCKETS_PER_VOXEL` per voxel), each holding the cell where
    the bucket's lookups start: the number of interior points whose own bucket
    ``floor(cu * scale)`` -- computed as the kernel computes it -- lies before it. Every
    such point lies below every ``u`` of the bucket, so the kernel's forward walk from
    there never passes the right cell. Axes concatenated x, y, z.
    """
    if volume.axes is None:
        return 0
    key = "warp" if frame is None else ("warp",) + tuple(c.tobytes() for c in frame)
    cached = volume.cache.get(key)
    if cached is not None:
        return cached
    cus, invs, firsts, bases, scales = [], [], [], [], []
    base = 0
    for a, (label, c) in enumerate(zip("xyz", volume.axes)):
        n = c.size
        if frame is None:
            cu = nominal_coordinates(c)
        else:
            cu = np.array(frame[a], dtype=np.float64)
        w = np.diff(cu)
        if not (w > 0).all():
            i = int(np.flatnonzero(w <= 0)[0])
            raise ValueError(f"the {label} axis has a cell too narrow for float64 against its extent: "
                             f"{label}[{i}] = {float(c[i])!r}, {label}[{i + 1}] = {float(c[i + 1])!r}")
        inv = np.zeros(n)
        inv[:-1] = 1.0 / w
        end = float(cu[-1])
        m = int(min(math.ceil(end / float(w.min())), _MAX_BUCKETS_PER_VOXEL * (n - 1)))
        scale = m / end
        keys = np.floor(cu[1:n - 1] * scale)
        first = np.minimum(np.searchsorted(keys, np.arange(m + 1, dtype=np.float64), side="left"), n - 2)
        cus.append(cu)
        invs.append(inv)
        firsts.append(first.astype(np.int32))
        bases.append(base)
        scales.append(scale)
        base += m + 1
    warp = (np.concatenate(cus), np.concatenate(invs), np.concatenate(firsts), np.array(bases, dtype=np.int64),
            np.array(scales, dtype=np.float64))
    volume.cache[key] = warp
    return warp


def check_rectilinear(volume, **features):
    """Raise ``ValueError`` for each feature given a truthy value that a rectilinear
    ``volume`` cannot render yet (nothing for a uniform one)."""
    if volume.axes is None:
        return
    for name, value in features.items():
        if value is not None and value is not False:
            raise ValueError(f"{name} is not supported for rectilinear grids yet; resample the grid to an ImageData "
                             f"(e.g. pyvista's sample()) to use it")


def resolve_transfer_function(data, tf=None, *, cmap=None, clim=None, opacity=None, scale=None):
    """``tf`` itself, or the default transfer function of ``data`` (a
    :class:`GridVolume` or :class:`~pv_hdrvol.TetMesh`: :func:`default_transfer_function`;
    anything else with a ``default_transfer_function(cmap=, clim=, opacity=, scale=)``
    method, such as a :class:`~pv_hdrvol.MultiscaleVolume`: that method) shaped by the
    keywords. Giving ``tf`` and a keyword is a ``TypeError``: a transfer function sets
    colour, opacity, range and axis already."""
    given = [name for name, value in zip(TF_KEYWORDS, (cmap, clim, opacity, scale)) if value is not None]
    if tf is not None and given:
        raise TypeError(f"pass either tf= or {', '.join(n + '=' for n in given)}, not both: a TransferFunction "
                        "sets colour, opacity, range and axis already")
    if tf is None:
        own = getattr(data, "default_transfer_function", None)  # a later stage's data (out of core) brings its own
        make = own if callable(own) else lambda **keywords: default_transfer_function(data, **keywords)
        return make(cmap=cmap, clim=clim, opacity=opacity, scale=scale)
    if not isinstance(tf, TransferFunction):
        raise TypeError(f"tf must be a TransferFunction; got {type(tf).__name__}")
    return tf


def resolve_render_options(data, tf=None, options=None, *, cmap=None, clim=None, opacity=None, scale=None,
                           **option_kwargs):
    """The transfer function and :class:`~pv_hdrvol.RenderOptions` of a render, from the
    keywords every front end takes: the one place they get their meaning.

    ``hv.render``, ``dataset.hdrvol.render``, ``plotter.hdrvol.add_volume``, ``hv.view``
    and the notebook editor, the progressive renderer, the VTK algorithm (and the
    ParaView filter over it) and both command lines reach their transfer function and
    options through this function (the render plans call it), so a keyword means the
    same in each of them.

    Parameters
    ----------
    data : GridVolume, TetMesh, or an object with a ``default_transfer_function`` method
        What the default transfer function is chosen from: the volume or mesh made of a
        dataset (:func:`~pv_hdrvol.data.kinds.as_renderable`), a
        :class:`~pv_hdrvol.MultiscaleVolume` (its coarsest level), ... Read only when
        ``tf`` is ``None``.
    tf : TransferFunction, optional
        Used as given. Default: the data's default transfer function
        (:func:`resolve_transfer_function`).
    options : RenderOptions, optional
        The options ``option_kwargs`` change (default ``RenderOptions()``).
    cmap, clim, opacity, scale : optional
        PyVista's ``add_volume`` words, with its meanings, each replacing one choice of
        the default transfer function (:func:`default_transfer_function`): a matplotlib
        colormap name; the range ``(low, high)`` the colours and opacity span (a number
        ``c`` is ``(-c, c)``, an end ``None`` stays the default's); a PyVista opacity
        curve name (``"linear"``, ``"sigmoid"``, ``"geom_r"``, ...), one opacity or
        opacities spread over the range; and the axis (``"linear"``, ``"log"``,
        ``"symlog"``). Not together with ``tf``.
    **option_kwargs
        :class:`~pv_hdrvol.RenderOptions` fields (``step=``, ``precision=``,
        ``global_alpha=``, ``shade=``, ...), replacing those of ``options``.

    Returns
    -------
    tf : TransferFunction
    options : RenderOptions
        Validated once; the plans take both as they are.

    Raises
    ------
    TypeError
        An unknown keyword (the message names it and the allowed ones), ``tf`` with a
        word of the default transfer function, a ``tf`` that is not a
        :class:`~pv_hdrvol.TransferFunction`, ``options`` that are not
        :class:`~pv_hdrvol.RenderOptions`.
    ValueError
        A value out of its range (the message names the value and the range).

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> volume = hv.volume_from_array(np.linspace(0.0, 1.0, 64).reshape(4, 4, 4))
    >>> tf, options = resolve_render_options(volume, clim=(0.2, 0.8), cmap="bone", step=0.25)
    >>> (tf.vmin, tf.vmax, options.step)
    (0.2, 0.8, 0.25)
    """
    fields = {f.name for f in dataclasses.fields(RenderOptions)}
    unknown = sorted(set(option_kwargs) - fields)
    if unknown:
        raise TypeError(f"unknown render option(s) {unknown}; allowed: {sorted(fields)} and the transfer "
                        f"function's {', '.join(TF_KEYWORDS)}")
    opts = RenderOptions.from_kwargs(options, **option_kwargs)
    return resolve_transfer_function(data, tf, cmap=cmap, clim=clim, opacity=opacity, scale=scale), opts


class EmptyRenderWarning(RuntimeWarning):
    """A render will give an empty (all transparent) image, for the reason named."""


def empty_render_reason(value_range, any_finite, tf, *, flat=False, visible=True, default_tf=False, what="volume"):
    """Why a render is bound to be empty, or None.

    ``visible``: whether any block (cell) can meet a non-zero opacity of ``tf``;
    ``default_tf``: whether ``tf`` was :func:`default_transfer_function`.
    """
    if flat:
        return (f"the {what} is flat (one point thick along an axis): rays cross no thickness, so the image is "
                "empty; a 2-D image cannot be volume rendered")
    if not any_finite:
        return f"the {what} has no finite value (all NaN or +-inf), so the image is empty"
    if visible:
        return None
    lo, hi = value_range
    why = (f"the transfer function's opacity is 0 over the whole data range [{lo:.6g}, {hi:.6g}] (transfer "
           f"function range [{tf.vmin:.6g}, {tf.vmax:.6g}], scale={tf.scale!r}), so the image is empty")
    if tf.scale == "log" and hi <= 0:
        why += "; a log axis maps values <= 0 below its range and the data has no positive value"
    elif default_tf and lo == hi:
        why += (f"; the data is constant ({lo:.6g}) and the default transfer function's opacity is 0 there: "
                "pass a tf with opacity at that value")
    return why


_collecting = threading.local()  # .sink: the list of collected_warnings() active on this thread


@contextlib.contextmanager
def collected_warnings():
    """Collect the renderer's warnings (:class:`EmptyRenderWarning`) raised on this
    thread inside the block into the list it yields, instead of warning.

    :mod:`warnings` is process-wide: its filters, ``catch_warnings`` and the printing
    serve every thread at once, so a warning raised on a worker thread lands in
    whatever the main thread runs then (a later notebook cell, another test's
    ``pytest.warns``). A worker renders inside this block and hands the warnings to its
    owner (:attr:`pv_hdrvol.viewer.progressive.Frame.warnings`), who shows them where
    the image is. Other threads, the caller's included, warn as before.
    """
    previous = getattr(_collecting, "sink", None)
    sink = []
    _collecting.sink = sink
    try:
        yield sink
    finally:
        _collecting.sink = previous


def warn_empty(reason):
    """Warn (:class:`EmptyRenderWarning`) that a render is empty, when ``reason`` is
    given (or collect it: :func:`collected_warnings`)."""
    if reason is not None:
        sink = getattr(_collecting, "sink", None)
        if sink is not None:
            sink.append(EmptyRenderWarning(reason))
            return
        import warnings

        warnings.warn(reason, EmptyRenderWarning, stacklevel=4)


def block_grid_shape(dims, size):
    """Blocks of ``size`` cells along (z, y, x) covering a volume of ``dims`` (x, y, z) points."""
    return tuple(max(1, -(-max(n - 1, 1) // size)) for n in dims[::-1])


def _brick_shape(dims):
    """Bricks along (z, y, x) for ``dims`` (x, y, z) points: ``n // 8 + 1`` per axis, so
    that the last point starts a (repeated-edge) cell of its own (``_kernels.make_bricks``)."""
    return tuple(n // (1 << K.BRICK_SHIFT) + 1 for n in dims[::-1])


class Bricks:
    """The volume copied into bricks of ``(8 + 1)**3`` points, cached on the volume.

    A sample's eight neighbours then sit in one small contiguous block whatever the
    view direction (see ``_kernels.make_bricks``).
    """

    def __init__(self, volume):
        size = 1 << K.BRICK_SHIFT
        self.shape = _brick_shape(volume.dims)
        self.values = np.empty(int(np.prod(self.shape)) * (size + 1) ** 3, dtype=volume.values.dtype)
        K.make_bricks(volume.values, K.BRICK_SHIFT, *self.shape, self.values)
        # where point (i, j, k) starts: offsets[i] + offsets[nx + j] + offsets[nx + ny + k]
        self.offsets = np.empty(sum(volume.dims), dtype=np.int64)
        K.brick_offsets(np.array(volume.dims, dtype=np.int64), self.shape[1], self.shape[2], self.offsets)

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
        shape = block_grid_shape(volume.dims, block_size)
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

        Mirrors the kernel's lookup (``_kernels.table_row``) on each block's value
        range: the axis transform is monotone, so the entries a block can touch lie
        between those of its minimum and maximum. Non-linear axes get a margin of 1e-9
        of the axis, because the kernel's ``log10`` may differ from numpy's by an ulp.
        """
        return ranges_visible(self.minimum, self.maximum, opacity, params)


def ranges_visible(minimum, maximum, opacity, params):
    """:meth:`BlockGrid.visible` for any arrays of block ranges."""
    n = opacity.size
    nonzero = np.concatenate([[0], np.cumsum(opacity > 0)])
    all_nan = ~np.isfinite(minimum)
    lo = np.where(all_nan, 0.0, minimum)
    hi = np.where(all_nan, 0.0, maximum)
    i0, i1 = table_entry_span(lo, hi, SCALES[params.scale], params.linthresh, params.axis_lo, params.axis_inv_range, n,
                              nearest=params.precision == PRECISION_CODES["uint8"])
    vis = (nonzero[i1 + 1] - nonzero[i0]) > 0
    return (vis & ~all_nan).astype(np.uint8)


def _active_blocks(minimum, maximum, opts, styles, table, params):
    """Blocks a render must sample, from block value ranges (uint8, z, y, x)."""
    if opts.blending != "composite" or (styles is not None and styles.needs_all_blocks):
        # a projection (or a maximum label) must see every value, opaque or not
        return np.isfinite(minimum).astype(np.uint8)
    if not opts.skip_empty:
        return np.ones(minimum.shape, np.uint8)
    if styles is not None:
        active = np.zeros(minimum.shape, np.uint8)
        for t in styles.opacity_columns():
            active |= ranges_visible(minimum, maximum, t, params)
        return active
    return ranges_visible(minimum, maximum, table[:, 3], params)


def _base_active(volume, blocks, opts, styles, table, params):
    """``_active_blocks`` without a mask, cached on the volume like the skip structures:
    the renders of one scene under many masks (each block of a parallel render, each
    culling) classify the block grid once (12 ms for the engine's 131,072 blocks)."""
    def build():
        return _active_blocks(blocks.minimum, blocks.maximum, opts, styles, table, params)

    if styles is not None:
        return build()
    key = (blocks.block_size, opts.blending, opts.skip_empty, params.scale, params.axis_lo, params.axis_inv_range,
           params.linthresh, params.precision, table.shape[0], content_digest(table[:, 3] > 0))
    return cached(volume.cache, "active_blocks", key, build, _SKIP_CACHE)


def _skip_structure(volume, blocks, opts, styles, table, params, mask):
    """``(active, leap)``: the blocks to sample (uint8, z, y, x) and their leap radii
    (``leap_radius``, flat), cached on the volume for the last few transfer functions.

    A render that changes only the camera (the common case: orbiting, an animation)
    then skips both. The key holds everything ``_active_blocks`` reads, with which
    entries of the opacity column are non-zero (all it reads of them: renders at other
    steps share the structure) and the mask as ``content_digest``s (a table may have
    2**24 entries: the cache keeps no copy); labelled renders are not cached.
    """
    def build():
        active = _base_active(volume, blocks, opts, styles, table, params)
        if mask is not None:
            active = active & mask
            box = _mask_box(mask)
            if box is not None:  # one block of a parallel or culled render: no dilation needed
                return active, _box_leap_radius(active, box).reshape(-1)
        return active, leap_radius(active).reshape(-1)  # flat, (z, y, x) order

    if styles is not None:
        return build()
    key = (blocks.block_size, opts.blending, opts.skip_empty, params.scale, params.axis_lo, params.axis_inv_range,
           params.linthresh, params.precision, table.shape[0], content_digest(table[:, 3] > 0),
           None if mask is None else content_digest(mask))
    return cached(volume.cache, "skip_structures", key, build, _SKIP_CACHE)


def cached(cache, name, key, build, size):
    """``build()``, kept in ``cache[name]`` (a list of ``(key, value)``, the last ``size``)."""
    entries = cache.setdefault(name, [])
    for k, value in entries:
        if k == key:
            return value
    value = build()
    entries.append((key, value))
    if len(entries) > size:
        entries.pop(0)
    return value


def _mask_box(mask):
    """``(lo, hi)`` (z, y, x, inclusive) when the true blocks of ``mask`` fill a box, else ``None``."""
    where = [np.flatnonzero(np.asarray(mask).any(axis=tuple(a for a in range(3) if a != axis))) for axis in range(3)]
    if any(w.size == 0 for w in where):
        return None
    lo = np.array([w[0] for w in where])
    hi = np.array([w[-1] for w in where])
    count = int(np.prod(hi - lo + 1))
    if count != int(np.count_nonzero(mask)):
        return None
    return lo, hi


def _box_leap_radius(active, box, cap=255):
    """Leap radii when every active block lies in ``box``: outside it, the Chebyshev
    distance to the box (no active block is nearer); inside, 1 for an inactive block
    (itself only). Never larger than :func:`leap_radius`'s, so just as safe; the same
    samples are taken either way (leaps only cross empty blocks)."""
    lo, hi = box
    shape = active.shape
    # per axis, the distance to the box (capped: uint8), broadcast to the grid
    d = [np.minimum(np.maximum(np.maximum(lo[a] - np.arange(n), np.arange(n) - hi[a]), 0), cap).astype(np.uint8)
         for a, n in enumerate(shape)]
    radius = np.maximum(np.maximum(d[0][:, None, None], d[1][None, :, None]), d[2][None, None, :])
    inside = (slice(lo[0], hi[0] + 1), slice(lo[1], hi[1] + 1), slice(lo[2], hi[2] + 1))
    radius[inside] = np.where(np.asarray(active[inside]).astype(bool), 0, 1)
    return np.ascontiguousarray(radius)


def dilate(mask):
    """``mask`` (bool, 3-D) grown by one in Chebyshev distance: each cell and its 26
    neighbours (three 1-D dilations)."""
    grown = np.asarray(mask, dtype=bool)
    for axis in range(3):
        step = grown.copy()
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[axis], hi[axis] = slice(1, None), slice(None, -1)
        step[tuple(lo)] |= grown[tuple(hi)]
        step[tuple(hi)] |= grown[tuple(lo)]
        grown = step
    return grown


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
        grown = dilate(reached)
        radius[grown & ~reached] = r
        reached = grown
        r += 1
    return np.ascontiguousarray(radius)


def render_volume(volume, tf=None, camera=None, size=(512, 512), options=None, *, block_mask=None, cull=None,
                  lens=None, labels=None, label_styles=None, progress=None, progress_bar=None, cmap=None, clim=None,
                  opacity=None, scale=None, **option_kwargs):
    r"""Ray cast an image volume into an :class:`~pv_hdrvol.HDRImage`.

    Parameters
    ----------
    volume : GridVolume, ndarray (z, y, x), pyvista.ImageData or vtkImageData
        The field. Datasets use their active scalars (see :func:`render` for
        ``scalars=``).
    tf : TransferFunction, optional
        Default: :func:`default_transfer_function`, chosen from the data.
    cmap, clim, opacity, scale : optional
        Instead of ``tf``: each replaces one choice of the default transfer function,
        with PyVista's meanings (``add_volume``): a matplotlib colormap (used whole);
        the range ``(low, high)`` the colormap and opacity span (a number ``c`` is
        ``(-c, c)``; an end ``None`` stays the default's); the opacity, a name of
        ``pyvista.opacity_transfer_function`` (``"linear"``, ``"sigmoid"``,
        ``"geom_r"``, ...), one number, or values spread evenly over the range,
        reached over one ``opacity_unit_distance``; and the axis, ``"linear"``,
        ``"log"`` or ``"symlog"`` (default: log where the data span decades, where
        PyVista is linear). What is not given stays the default's.
    camera : Camera, Rays, view name, pyvista.Plotter, pyvista.Camera or vtkCamera, optional
        Default ``"iso"``; a view name is ``Camera.fit(volume, name)``
        (:func:`~pv_hdrvol.rays.camera.as_camera`). ``Rays`` give one ray per pixel and
        fix the size; where they carry a level of detail (``Rays.lod``), those rays
        sample a mip-map of the volume, built once per volume.
    size : int or (width, height)
        Output size in pixels (ignored for ``Rays``).
    lens : Lens, optional
        A ray generator of :mod:`pv_hdrvol.rays.lenses` (magnifier, feature,
        sampling-rate, fisheye lens; or anything with ``rays(camera, size) -> Rays``)
        applied to ``camera``. Lenses change which rays are cast, never how they are
        composited.
    options : RenderOptions, optional
        Sampling and compositing options; keywords (``step=``, ``precision=``, ...)
        override single fields.
    block_mask : ndarray of bool, shape ``BlockGrid(volume, block_size).shape``, optional
        Render only these blocks (visibility culling, parallel rendering). Blocks
        outside the mask are treated as empty.
    cull : PlenopticOpacity, Culling or OcclusionBound, optional
        Visibility culling (:mod:`pv_hdrvol.culling`): blocks hidden behind accumulated
        opacity >= the threshold (0.95) on every pixel they cover are not sampled.
        POFs: orthographic cameras, ``blending="composite"``, a ``tf`` of the POFs'
        bases; :class:`~pv_hdrvol.OcclusionBound`: any camera and ``tf``, float32 or
        float64. The image's ``metadata["culling"]`` holds the counts and the culling's time.
    labels : ndarray of int, shape (z, y, x) as the volume, optional
        A segmentation: two-level rendering (Hauser et al. 2001). Each sample takes the
        label of its nearest grid point; ``label_styles`` gives a label its own
        transfer function and blending. Consecutive samples of one label form a
        segment, blended in the label's mode; segments composite front to back.
    label_styles : dict, optional
        ``{label: style}`` where a style is a :class:`TransferFunction`, a blending
        name (``"composite"``, ``"maximum"`` or ``"minimum"``) or a ``(tf, blending)``
        pair. Labels without a style use ``tf`` and ``"composite"``.
    progress : callable, optional
        Called with the fraction of rows done (0..1) after each chunk; if it returns
        ``False`` the render stops and raises ``RuntimeError("render aborted")``.
    progress_bar : bool or None
        ``None`` (default): a tqdm progress bar for renders that will take over 1 s,
        judged from the time of the first chunk (the middle row of tiles), when stderr
        is a terminal or in a Jupyter notebook (never into a log file or a pipe);
        quicker renders print nothing. ``True``: always; ``False``: never. Whatever
        it is, a render that will take over 1 s runs in chunks of about 0.25 s, so
        Ctrl-C stops it soon after; chunks change no pixel.

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
    plan = GridPlan(volume, tf, options, labels=labels, label_styles=label_styles, cmap=cmap, clim=clim,
                    opacity=opacity, scale=scale, **option_kwargs)
    return plan.execute(camera, size, lens=lens, block_mask=block_mask, cull=cull, progress=progress,
                        progress_bar=progress_bar)


class _Prepared(NamedTuple):
    """What a :class:`GridPlan` builds on its first execution (cached on the volume)."""

    volume: GridVolume  # the values the kernels read (a float32 or 8-bit copy where needed)
    blocks: BlockGrid
    params: K.GridParams
    styles: object  # _LabelStyles or None
    bricks: Bricks
    dims: np.ndarray
    grids: np.ndarray
    flat: bool


class GridPlan(FramePlan):
    """A grid render validated and prepared once, executed many times.

    Construction takes what does not change between renders of one scene: the volume,
    the transfer function, the :class:`~pv_hdrvol.RenderOptions` and any labels. It
    validates them and builds the kernel's tables; the first :meth:`execute` builds the
    arrays the kernels read (float32 or 8-bit copies, block ranges, bricks, label slots;
    after the memory check, and cached on the volume). :meth:`execute` then renders for
    any camera, rays or lens, image size and block mask: culling, parallel tiles,
    progressive refinement and proxy training call it instead of re-validating.
    :func:`render_volume` is ``GridPlan(...).execute(...)``; the pixels are the same.

    Parameters
    ----------
    volume, tf, options, labels, label_styles, cmap, clim, opacity, scale, **option_kwargs
        As :func:`render_volume`.

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> plan = GridPlan(np.random.default_rng(0).random((8, 8, 8)), precision="float64")
    >>> small, large = plan.execute("iso", (8, 8)), plan.execute("iso", (32, 32))
    >>> small.shape, large.shape
    ((8, 8), (32, 32))
    """

    def __new__(cls, volume=None, *args, **kwargs):
        # a volume larger than memory (pv_hdrvol.outofcore, a later stage: known by its
        # method) brings its own plan, which executes as this one does
        make = getattr(volume, "multiscale_plan", None)
        if callable(make):
            return make(*args, **kwargs)
        return super().__new__(cls)

    def __init__(self, volume, tf=None, options=None, *, labels=None, label_styles=None, cmap=None, clim=None,
                 opacity=None, scale=None, **option_kwargs):
        volume = as_volume(volume)
        self.default_tf = tf is None
        tf, opts = resolve_render_options(volume, tf, options, cmap=cmap, clim=clim, opacity=opacity, scale=scale,
                                          **option_kwargs)
        if opts.precision == "uint8" and labels is not None:
            raise ValueError("labels need a floating-point precision; precision='uint8' quantises the data to one "
                             "transfer function")
        prec = opts.precision
        table_dtype = np.float64 if prec == "float64" else np.float32
        check_rectilinear(volume, **{"labels=": labels, "gradient_opacity=": opts.gradient_opacity,
                                     f"blending={opts.blending!r}": opts.blending != "composite" or None})
        # a voxel: the smallest spacing, or a rectilinear grid's narrowest cell
        unit = opts.opacity_unit_distance if opts.opacity_unit_distance is not None else volume.min_cell_width
        table_size = 256 if prec == "uint8" else tf.table_size
        step_world = opts.step * volume.min_cell_width
        rgb, sigma = tf.table(np.float64, opts.global_alpha, unit, table_size)
        # opacity correction on the host: the opacity of one full step, 1 - exp(-sigma step)
        alpha_step = -np.expm1(-sigma * step_world)
        if prec == "uint8":
            rgb = np.round(np.clip(rgb, 0, 1) * 255) / 255
            alpha_step = np.round(alpha_step * 255) / 255
        #: the volume as given; the kernels read ``_prepare().volume``
        self.source = volume
        self.tf, self.options = tf, opts
        self.table = np.ascontiguousarray(np.column_stack([rgb, alpha_step]), dtype=table_dtype)
        self.sigma = np.ascontiguousarray(sigma, dtype=table_dtype)
        self.unit, self.step_world = unit, step_world
        self.labels, self.label_styles = labels, label_styles
        self._prepared = None
        if opts.device != "cpu":
            _check_device(opts, volume, labels)

    def _prepare(self):
        """The arrays the kernels read, built on the first execution."""
        if self._prepared is not None:
            return self._prepared
        volume, tf, opts = self.source, self.tf, self.options
        prec = opts.precision
        values = volume.values
        if prec != "float64" and values.dtype == np.float64:
            volume = _derived(volume, "float32", lambda: values.astype(np.float32))
        if prec == "uint8":
            # an 8-bit pipeline quantises the data to 256 levels of the table's axis
            volume = _derived(volume, ("u8", tf.scale, tf.linthresh, tf.axis_range), lambda: _quantize_u8(values, tf))
        blocks = BlockGrid.of(volume, opts.block_size)
        a0, a1 = tf.axis_range
        params = K.GridParams(
            float(self.step_world), PRECISION_CODES[prec], SCALE_CODES[tf.scale],
            float(a0), float(1.0 / (a1 - a0)), float(tf.linthresh),
            1.0 - opts.termination if opts.termination > 0 else math.inf,
            float(opts.depth_threshold), int(blocks.shift),
        )
        if prec == "uint8":
            params = params._replace(scale=SCALE_CODES["linear"], axis_lo=0.0, axis_inv_range=1.0 / 255.0)
        styles = _LabelStyles(volume, self.labels, self.label_styles, tf, self.table, self.sigma, params, opts,
                              self.step_world, self.unit) if self.labels is not None else None
        bricks = Bricks.of(volume)
        self._prepared = _Prepared(volume, blocks, params, styles, bricks, np.array(volume.dims, dtype=np.int64),
                                   np.array(blocks.shape + bricks.shape, dtype=np.int64),
                                   # a volume with one point along an axis has no thickness: nothing to integrate
                                   min(volume.dims) < 2)
        return self._prepared

    with_clip = with_clip

    def execute(self, camera=None, size=(512, 512), *, lens=None, block_mask=None, cull=None, window=None,
                progress=None, progress_bar=None, chunk_seconds=None, far=None, piece=None):
        """Render the plan: ``camera``, ``size``, ``lens``, ``block_mask``, ``progress`` and
        ``progress_bar`` as :func:`render_volume`. Returns an :class:`~pv_hdrvol.HDRImage`.

        ``chunk_seconds``: how long a chunk of rows of tiles may take between
        ``progress`` reports (default 0.25 s; see :func:`run_in_chunks`): an interactive
        render that must stop soon when ``progress`` returns ``False`` asks for less.

        ``far``: array (rows, cols) of the image of ``size``, the world distance along
        each pixel's ray at which it stops (``inf``: no limit) -- opaque geometry drawn
        in the same scene, in front of or inside the volume, as VTK's volume mappers
        stop at its depth buffer.

        ``window=(col, row, width, height)``: render only that rectangle of the image of
        ``size`` (a tile: sort-first parallel rendering, a region refined first); the
        result is that window, pixel for pixel the same as the full render's (a camera
        makes only the window's rays; given rays are cut).

        ``piece``: a :class:`VolumePiece` -- the plan's volume is one piece of a whole
        volume spread over processes, and this render is that piece's part of the whole
        render: samples on the whole volume's lattice whose midpoints lie in the owned
        box, composited from transparent. The pieces' images composited in depth order
        (:func:`pv_hdrvol.parallel.pieces.composite_pieces`) are the whole render to
        rounding; the default camera frames the whole volume. Composite blending, no
        labels, no culling, no level-of-detail lens.
        """
        tf, opts, table, sigma = self.tf, self.options, self.table, self.sigma
        if opts.tolerance is not None:
            if piece is not None:
                raise ValueError("tolerance= chooses the knobs per render; a piece of a distributed volume needs the "
                                 "whole render's: choose them once (metadata['tolerance'] of a render of the whole) "
                                 "and give step=, termination= and precision=")
            from .tolerance import execute_grid

            return execute_grid(self, camera, size, lens=lens, block_mask=block_mask, cull=cull, window=window,
                                progress=progress, progress_bar=progress_bar, chunk_seconds=chunk_seconds, far=far)
        check_rectilinear(self.source, **{"cull=": cull, "lens=": lens,
                                          "tolerance=": opts.tolerance})
        if piece is not None:
            if self.labels is not None or cull is not None or block_mask is not None:
                raise ValueError("a piece of a distributed volume renders without labels, cull= and block_mask=")
            ghosts = 1 if (opts.shade or opts.gradient_opacity is not None) else 0
            piece_box, whole_hi, whole_origin, nominal = _check_piece(piece, self.source, opts, ghosts)
        camera = fit_camera(self.source, camera) if piece is None else as_camera(camera,
                                                                                  piece.bounds(self.source.spacing))
        rays, width, height = frame_rays(camera, size, lens)  # rays None: the kernel makes the camera's
        image_size = (width, height)  # a window's render culls for the whole image's rays (its own among them)
        rays, far, width, height = windowed(camera, rays, far, window, width, height)
        lod = check_lod(rays) if rays is not None else None
        # clipping planes, a crop box and far: one [near, far] per pixel (rays/clip.py)
        span = ray_spans(rays if rays is not None else camera, (width, height), opts, far)
        check_rectilinear(self.source, **{"Rays with a level of detail (Rays.lod)": lod is not None or None})
        if piece is not None and lod is not None:
            raise ValueError("a piece of a distributed volume renders without a level-of-detail (sampling-rate) lens")
        prec = opts.precision
        parts = render_bytes(self.source, tf, opts, width, height, rays, lod, self.labels)
        if self._prepared is not None:
            parts.pop("label slots", None)  # built by the first execution
        check_memory(parts, _memory_advice(self.source, prec, width, height))
        volume, blocks, params, styles, bricks, dims, grids, flat = self._prepare()

        # rays in voxel coordinates with t still in world units (see _kernels._march); a
        # piece's rays are in the whole volume's points, as the whole render's
        # (a rectilinear piece: the whole grid's nominal spacing)
        inv_spacing = 1.0 / (volume.spacing if piece is None or nominal is None else nominal[0])
        ray_origin = volume.origin if piece is None else whole_origin
        cam, origins, directions = voxel_rays(camera, rays, width, height, ray_origin, inv_spacing)
        lo = np.zeros(3)
        hi = np.array(volume.dims, dtype=np.float64) - 1.0 if piece is None else whole_hi
        piece_box = np.concatenate([lo, hi, np.zeros(3)]) if piece is None else piece_box
        mask, culling = self._frame_mask(block_mask, cull, volume, blocks, styles, camera, lens, image_size)
        active, leap = _skip_structure(volume, blocks, opts, styles, table, params, mask)
        if piece is None:  # a piece may well be empty where the whole is not
            warn_empty(self._empty_reason(volume, blocks, params, styles, flat))

        # shading alone lights the plain loop (render_tiles); the rest takes the extended kernels
        extended = opts.blending != "composite" or opts.gradient_opacity is not None or styles is not None \
            or lod is not None
        on_device = opts.device != "cpu"
        if on_device and lod is not None:
            raise ValueError(f"device={opts.device!r} renders lenses without a level of detail (Rays.lod: a lens "
                             "made with antialias=True, the default, or a sampling-rate lens): make the lens with "
                             "antialias=False, or render on device='cpu'")
        kernel = _grid_kernel(flat, extended, opts, styles, lod)
        if kernel in ("levels", "extended") and rays is None and not on_device:
            # these kernels take rays as arrays (the device kernels make a camera's own)
            rays = camera.rays((width, height))
            _, origins, directions = voxel_rays(camera, rays, width, height, ray_origin, inv_spacing)
        out = FrameBuffers(width, height, prec, value=opts.blending != "composite")
        kernel_args = None
        if extended and not flat:
            kernel_args = _extended_arguments(volume, opts, params, table, sigma, self.unit, blocks, active, leap, lod,
                                              styles, tf, prec, mask)
        # the precision's marker and the lighting (0: none): each kernel compiles that
        # precision's loop, lit or not, only
        light = _light(volume, opts, prec, piece) if not flat else 0
        frame = _GridFrame(prec, MARKERS[prec], light, bricks, table, sigma, leap, grids, dims, cam, origins,
                           directions, span, width, height, tile_lanes(), lo, hi, piece_box, params,
                           warp_arrays(volume, None if piece is None or nominal is None else nominal[1]), kernel_args,
                           kernel, out)

        check_progress_bar(progress_bar)
        t_start = time.perf_counter()
        device_meta = self.run_frame(lambda rows: _cast_grid(frame, rows), height, progress, progress_bar,
                                     chunk_seconds, opts.device, None if flat else frame.on_device)
        elapsed = time.perf_counter() - t_start
        settings = settings_metadata(tf, camera, (width, height), opts, lens=lens, labels=self.labels,
                                     label_styles=self.label_styles, block_mask=block_mask, window=window, cull=cull)
        meta = frame_metadata("pv_hdrvol grid ray caster", volume.name, tf, camera, opts, self.unit, settings, elapsed,
                              step_voxels=opts.step, step_world=self.step_world)
        meta["samples"] = int(out.counts.sum())
        meta.update(self._mode_metadata(lens, piece, culling, styles, lod))
        if on_device:
            meta["device"] = device_meta if device_meta is not None else {"name": opts.device}
        return out.image(meta)

    def _frame_mask(self, block_mask, cull, volume, blocks, styles, camera, lens, image_size):
        """``(mask, culling)``: the blocks a frame may sample (uint8 per block, or None for
        all) from ``block_mask`` and ``cull``, and the culling's metadata (or None)."""
        mask = None
        if block_mask is not None:
            mask = np.asarray(block_mask)
            if mask.shape != blocks.shape:
                raise ValueError(f"block_mask must have shape {blocks.shape} (blocks along z, y, x); got {mask.shape}")
            if mask.dtype != np.bool_:
                raise TypeError(f"block_mask must be a bool array; got dtype {mask.dtype}")
            mask = mask.astype(np.uint8)
        culling = None
        if cull is not None:
            if has_clip(self.options):
                raise ValueError("cull= hides blocks behind the whole volume, which clip_planes= and crop_box= may cut "
                                 "away (the hidden blocks would show): render a clipped volume without cull=")
            if not callable(getattr(cull, "mask_for", None)):
                raise TypeError(f"cull must be a PlenopticOpacity, Culling or OcclusionBound; got {type(cull).__name__}")
            if not isinstance(camera, Camera) or lens is not None or styles is not None:
                raise ValueError("cull= needs a Camera (no Rays, no lens) and no label styles")
            culled, culling = cull.mask_for(volume, self.tf, camera, image_size, self.options, blocks.shape)
            mask = culled.astype(np.uint8) if mask is None else mask & culled
        return mask, culling

    def _empty_reason(self, volume, blocks, params, styles, flat):
        """Why an image is bound to be empty, or None (:func:`empty_render_reason`). Label
        styles have tables of their own, and a projection keeps its value image
        (HDRImage.value) whatever the opacity; without a mask the skip structure already
        holds the visible blocks."""
        opts, table = self.options, self.table
        if styles is not None or opts.blending != "composite":
            visible = True
        elif opts.skip_empty:  # the unmasked classification: whether the function shows anything at all
            visible = bool(_base_active(volume, blocks, opts, styles, table, params).any())
        else:
            visible = bool(ranges_visible(blocks.minimum, blocks.maximum, table[:, 3], params).any())
        reason = empty_render_reason(volume.value_range, volume.any_finite, self.tf, flat=flat, visible=visible,
                                     default_tf=self.default_tf)
        if reason is not None and not visible and opts.precision == "uint8":
            reason += "; precision='uint8' rounds the opacity of each step to a multiple of 1/255"
        return reason

    def _mode_metadata(self, lens, piece, culling, styles, lod):
        """The metadata of what this frame turned on (lens, piece, culling, blending,
        gradient opacity, shading, label styles, level of detail)."""
        opts, meta = self.options, {}
        if lens is not None:
            meta["lens"] = repr(lens)
        if piece is not None:
            meta["piece"] = {"offset": list(piece.offset), "owned_lo": list(piece.owned_lo),
                             "owned_hi": list(piece.owned_hi), "whole_dims": list(piece.whole_dims)}
        if culling is not None:
            meta["culling"] = culling
        if opts.blending != "composite":
            meta["blending"] = opts.blending
        if opts.gradient_opacity is not None:
            meta["gradient_opacity"] = list(opts.gradient_opacity)
        if opts.shade:
            meta["shading"] = shading_metadata(opts)
        if styles is not None:
            meta["label_styles"] = styles.describe()
        if lod is not None:
            meta["max_lod"] = float(lod.max())
        return meta


class _GridFrame(NamedTuple):
    """A grid frame's kernel inputs and outputs (:func:`_cast_grid` runs them)."""

    precision: str
    marker: object
    light: object
    bricks: Bricks
    table: np.ndarray
    sigma: np.ndarray
    leap: np.ndarray
    grids: np.ndarray
    dims: np.ndarray
    cam: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    span: np.ndarray
    width: int
    height: int
    lanes: int
    lo: np.ndarray
    hi: np.ndarray
    piece_box: np.ndarray
    params: object
    warp: object
    ext: object  # _Extended or None
    kernel: str  # "none" (a flat volume), "plain", "projection", "levels" or "extended"
    out: FrameBuffers

    def on_device(self, runner):
        """The device runner's ``(cast, finish)`` of this frame."""
        f, out = self, self.out
        if out.value is None:
            return runner.composite_frame(f.precision, f.light, f.bricks, f.table, f.sigma, f.leap, f.grids, f.dims,
                                          f.cam, f.origins, f.directions, f.span, f.width, f.height, f.lo, f.hi,
                                          f.piece_box, f.params, out.rgba, out.depth, out.counts)
        return runner.projection_frame(f.bricks, f.table, f.leap, f.grids, f.dims, f.ext, f.cam, f.origins,
                                       f.directions, f.span, f.width, f.height, f.lo, f.hi, f.params, out.value,
                                       out.rgba, out.depth, out.counts)


def _grid_kernel(flat, extended, opts, styles, lod):
    """Which grid kernel a frame runs (see :class:`_GridFrame`): rays with a level of
    detail and nothing else extended take the plain loop on the mip-map (``"levels"``),
    as a projection's rays with one do; a projection without them ``render_tiles``."""
    if flat:
        return "none"
    if not extended:
        return "plain"
    if opts.blending != "composite":  # (a projection is neither lit nor labelled)
        return "projection" if lod is None else "levels"
    if lod is not None and opts.gradient_opacity is None and styles is None and not opts.shade:
        return "levels"
    return "extended"


def _cast_grid(f, tile_rows):
    """Render the rows of tiles ``tile_rows`` of the grid frame ``f``; returns the pixel rows done."""
    rows = np.ascontiguousarray(tile_rows)
    out, a = f.out, f.ext
    # the one grid loop composites or projects as its marker says (a projection is not lit)
    marker, light, value = (f.marker, f.light, NO_VALUE) if a is None or a.projection is None else \
        (a.projection, 0, out.value)
    if f.kernel in ("plain", "projection"):
        K.render_tiles(marker, f.bricks.values, f.bricks.offsets, f.table.reshape(-1), f.sigma, f.leap, f.grids,
                       f.dims, f.cam, f.origins, f.directions, f.span, f.width, f.height, TILE, rows, f.lanes, f.lo,
                       f.hi, f.piece_box, f.params, light, f.warp, out.rgba, out.depth, out.counts, value)
    elif f.kernel == "levels":
        # the same loop, on the mip-map where a ray has a level of detail
        KX.render_levels(marker, f.bricks.values, f.bricks.offsets, f.leap, a.leap_lod, f.grids, f.dims, a.pyr,
                         a.pgeo, a.e.n_levels, a.lods, a.tables, a.sigmas, a.level_tables, a.level_steps, f.origins,
                         f.directions, f.span, f.width, f.height, TILE, rows, f.lanes, f.lo, f.hi, f.piece_box,
                         f.params, out.rgba, out.depth, out.counts, value)
    elif f.kernel == "extended":
        KX.render_ext(f.marker, f.light, f.bricks.values, f.bricks.offsets, f.leap, a.leap_lod, f.grids, f.dims, a.pyr,
                      a.pgeo, a.lods, a.gbricks, a.slots, a.modes, a.tables, a.sigmas, a.axes, f.origins, f.directions,
                      f.span, f.width, f.height, TILE, rows, f.lanes, f.lo, f.hi, f.piece_box, f.params, a.e, out.rgba,
                      out.depth, out.counts)
    return pixel_rows(tile_rows, f.height)


def _check_device(opts, volume, labels):
    """Refuse, by name, what a device render does not take (``RenderOptions.device``)."""
    what = {"labels=": labels is not None, "gradient_opacity=": opts.gradient_opacity is not None,
            "a rectilinear grid (axes)": volume.axes is not None}
    refused = [name for name, given in what.items() if given]
    if refused:
        raise ValueError(f"device={opts.device!r} renders uniform grids without labels and gradient opacity; got "
                         f"{', '.join(refused)}: render it with device='cpu'")


class VolumePiece(NamedTuple):
    """Where a volume's points lie in a whole volume spread over processes, and the box
    of it this process renders (``GridPlan.execute(piece=...)``).

    All in points of the whole volume, x, y, z: ``whole_dims`` its points per axis,
    ``offset`` the index of the piece's first point, ``owned_lo``/``owned_hi`` the owned
    box (integers). The owned boxes of the pieces tile the whole box ``[0, dims - 1]``,
    sharing faces (VTK's piece extents without ghosts); a piece holds its owned box plus
    the ghost points its render needs: none for trilinear samples, one layer for
    shading and gradient opacity (central differences). ``whole_origin`` is the world
    position of the whole volume's first point, as the whole volume's ``origin``.

    :func:`pv_hdrvol.parallel.pieces.split_volume` makes pieces of an array;
    :meth:`from_extents` reads them from VTK extents.

    ``whole_axes``: a piece of a rectilinear grid, the whole grid's coordinates (3 arrays,
    x, y, z; ``whole_origin`` their first values): the piece samples the whole grid's
    lattice in its nominal frame (:meth:`from_rectilinear`; its plan's step and opacity
    unit from :meth:`options_for`). ``None``: a piece of an image volume.
    """

    whole_origin: tuple
    whole_dims: tuple
    offset: tuple
    owned_lo: tuple
    owned_hi: tuple
    whole_axes: tuple = None

    @classmethod
    def from_rectilinear(cls, whole_axes, offset, owned_lo, owned_hi):
        """A piece of the rectilinear grid whose coordinates are ``whole_axes``: its first
        point's index ``offset`` and owned box, in points of the whole."""
        axes = tuple(np.asarray(a, dtype=np.float64).reshape(-1) for a in whole_axes)
        return cls(tuple(float(a[0]) for a in axes), tuple(a.size for a in axes), tuple(int(v) for v in offset),
                   tuple(int(v) for v in owned_lo), tuple(int(v) for v in owned_hi), axes)

    def options_for(self, options, volume):
        """``options`` for the plan of this piece's ``volume`` (a rectilinear piece): the
        step and opacity unit of the whole grid (its narrowest cell), not the piece's, so
        that the pieces sample the whole render's lattice. An image piece: unchanged."""
        if self.whole_axes is None:
            return options
        whole = float(min(np.diff(a).min() for a in self.whole_axes))
        mine = float(min(np.diff(a).min() for a in volume.axes))
        unit = options.opacity_unit_distance if options.opacity_unit_distance is not None else whole
        return options.replace(step=options.step * whole / mine, opacity_unit_distance=unit)

    def nominal(self, dims):
        """A rectilinear piece (of ``dims`` points) in the whole grid's nominal frame
        (``_kernels._march``'s, as ``warp_arrays`` makes it for the whole grid): the
        nominal spacing per axis, the owned box and first point, and the piece's points
        less its first point's, per axis."""
        h = np.array([(a[-1] - a[0]) / (a.size - 1) for a in self.whole_axes])
        cu = [nominal_coordinates(a) for a in self.whole_axes]
        at = lambda index: np.array([c[i] for c, i in zip(cu, index)])  # noqa: E731
        frame = tuple(c[o:o + n] - c[o] for c, o, n in zip(cu, self.offset, dims))
        return h, at(self.owned_lo), at(self.owned_hi), at(self.offset), frame

    @classmethod
    def from_extents(cls, origin, spacing, whole_extent, extent, owned_extent):
        """From a ``vtkImageData``'s ``GetOrigin()``/``GetSpacing()``, the pipeline's
        whole extent, the piece's data extent (with ghosts) and its owned extent
        (without): each ``(x0, x1, y0, y1, z0, z1)``."""
        we, de, oe = (np.asarray(e, dtype=np.int64).reshape(3, 2) for e in (whole_extent, extent, owned_extent))
        # the whole volume's first point as a whole image's GridVolume places it (data/grid.py)
        first = np.asarray(origin, dtype=np.float64) + we[:, 0].astype(np.float64) * np.asarray(spacing, np.float64)
        return cls(tuple(first.tolist()), tuple((we[:, 1] - we[:, 0] + 1).tolist()), tuple((de[:, 0] - we[:, 0]).tolist()),
                   tuple((oe[:, 0] - we[:, 0]).tolist()), tuple((oe[:, 1] - we[:, 0]).tolist()))

    def bounds(self, spacing):
        """The whole volume's ``(xmin, xmax, ymin, ymax, zmin, zmax)``."""
        if self.whole_axes is not None:
            return tuple(float(v) for a in self.whole_axes for v in (a[0], a[-1]))
        lo = np.asarray(self.whole_origin, dtype=np.float64)
        hi = lo + (np.asarray(self.whole_dims) - 1) * np.asarray(spacing, dtype=np.float64)
        return (lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])

    def world_box(self, spacing):
        """``(lo, hi)``: the owned box in world coordinates."""
        if self.whole_axes is not None:
            return (np.array([a[i] for a, i in zip(self.whole_axes, self.owned_lo)]),
                    np.array([a[i] for a, i in zip(self.whole_axes, self.owned_hi)]))
        o = np.asarray(self.whole_origin, dtype=np.float64)
        sp = np.asarray(spacing, dtype=np.float64)
        return o + np.asarray(self.owned_lo) * sp, o + np.asarray(self.owned_hi) * sp


def _check_piece(piece, volume, opts, ghosts):
    """``piece`` validated against the piece's ``volume``; ``ghosts``: the layer of
    points beyond the owned box the options read (1 for central differences)."""
    if not isinstance(piece, VolumePiece):
        raise TypeError(f"piece must be a VolumePiece; got {type(piece).__name__}")
    try:
        whole = np.array(piece.whole_dims, dtype=np.int64).reshape(3)
        offset = np.array(piece.offset, dtype=np.int64).reshape(3)
        lo = np.array(piece.owned_lo, dtype=np.int64).reshape(3)
        hi = np.array(piece.owned_hi, dtype=np.int64).reshape(3)
        origin = np.array(piece.whole_origin, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ValueError(f"piece must hold three numbers per field; got {piece!r}") from None
    dims = np.array(volume.dims, dtype=np.int64)
    if (whole < 2).any() or (lo < 0).any() or (hi > whole - 1).any() or (hi <= lo).any():
        raise ValueError(f"piece's owned box {tuple(lo.tolist())}..{tuple(hi.tolist())} must be a box of at least one "
                         f"cell per axis inside the whole volume's points 0..{tuple((whole - 1).tolist())}")
    need_lo = np.where(lo > 0, lo - ghosts, lo)
    need_hi = np.where(hi < whole - 1, hi + ghosts, hi)
    if (offset > need_lo).any() or (offset + dims - 1 < need_hi).any():
        raise ValueError(f"the piece's points {tuple(offset.tolist())}..{tuple((offset + dims - 1).tolist())} must "
                         f"cover its owned box {tuple(lo.tolist())}..{tuple(hi.tolist())} with {ghosts} ghost "
                         f"layer(s) inside the volume ({'shading and gradient opacity read' if ghosts else 'samples read'} "
                         f"them)")
    if opts.blending != "composite":
        raise ValueError(f"a piece of a distributed volume composites in depth order: blending='composite' only; got "
                         f"{opts.blending!r}")
    if (piece.whole_axes is None) != (volume.axes is None):
        raise ValueError("a piece of a rectilinear grid needs a VolumePiece with the whole grid's axes "
                         "(VolumePiece.from_rectilinear), and a piece of an image volume one without")
    if volume.axes is not None:
        # the rays, the owned box and the piece's first point in the whole grid's nominal frame
        for label, a, c, o in zip("xyz", piece.whole_axes, volume.axes, offset):
            if a.size != whole[("xyz".index(label))] or not np.array_equal(a[o:o + c.size], c):
                raise ValueError(f"the piece's {label} coordinates are not the whole grid's from index {o}")
        h, nominal_lo, nominal_hi, nominal_offset, frame = piece.nominal(volume.dims)
        return (np.concatenate([nominal_lo, nominal_hi, nominal_offset]), (whole - 1).astype(np.float64), origin,
                (h, frame))
    expected = origin + offset * volume.spacing
    if not np.allclose(volume.origin, expected, rtol=0.0, atol=1e-6 * float(volume.spacing.min())):
        raise ValueError(f"the piece's origin {tuple(volume.origin.tolist())} is not the whole volume's origin plus "
                         f"offset x spacing {tuple(expected.tolist())}")
    return np.concatenate([lo, hi, offset]).astype(np.float64), (whole - 1).astype(np.float64), origin, None


def render_bytes(volume, tf, opts, width, height, rays=None, lod=None, labels=None):
    """``{what: bytes}``: what :func:`render_volume` will allocate for these arguments
    (``rays``: the Rays it is given; ``lod``: their level of detail), not counting
    what ``volume.cache`` already holds. Checked against the free memory before a
    render starts (:func:`~pv_hdrvol.raycast.memory.check_memory`)."""
    prec = opts.precision
    n_pix = width * height
    n = volume.values.size
    out_item = 8 if prec == "float64" else 4
    extended = opts.blending != "composite" or opts.gradient_opacity is not None or labels is not None \
        or lod is not None
    parts = {"image": n_pix * (4 * out_item + 8 + 8 + (8 if opts.blending != "composite" else 0))}
    if rays is not None or extended:
        # origins and directions in voxel units (and the camera's rays they come from)
        parts["rays"] = n_pix * 48 * (2 if rays is None else 1)
    cache, item = volume.cache, volume.values.itemsize
    if prec != "float64" and volume.values.dtype == np.float64:
        derived = cache.get(("derived", "float32"))
        if derived is None:
            parts["float32 copy of the volume"] = 4 * n
        cache, item = ({} if derived is None else derived.cache), 4
    if prec == "uint8":
        derived = cache.get(("derived", ("u8", tf.scale, tf.linthresh, tf.axis_range)))
        if derived is None:
            parts["8-bit levels of the volume"] = 4 * n + 24 * n  # the float32 levels, float64 temporaries
        cache, item = ({} if derived is None else derived.cache), 4
    if ("blocks", opts.block_size) not in cache:
        parts["block ranges"] = 16 * int(np.prod(block_grid_shape(volume.dims, opts.block_size)))
    brick_points = int(np.prod(_brick_shape(volume.dims))) * ((1 << K.BRICK_SHIFT) + 1) ** 3
    if "bricks" not in cache:
        parts["bricks"] = brick_points * item
    kernel_item = 8 if prec == "float64" else 4
    kernel_dtype = np.dtype(np.float64 if prec == "float64" else np.float32).str
    if opts.gradient_opacity is not None and ("gradient", kernel_dtype) not in cache:
        parts["gradient bricks"] = (n + brick_points) * kernel_item
    if opts.shade and (opts.shade_gradient == "interpolated" or volume.axes is not None) \
            and ("gradient_vectors", kernel_dtype) not in cache:
        # three components per point as float64, then bricked in the kernel precision
        parts["gradient vector bricks"] = 3 * (8 * n + brick_points * kernel_item)
    if lod is not None and ("mip", kernel_dtype) not in cache:
        # levels of 1, 1/8, 1/64, ... of the volume, bricked, then joined into one array
        parts["mip-map"] = int((n + 2 * brick_points) * kernel_item * 8 / 7)
    if labels is not None:
        parts["label slots"] = 8 * n + n + brick_points
    return parts


def _memory_advice(volume, prec, width, height):
    advice = [f"a smaller size (now {width}x{height})", "a subvolume (e.g. values[::2, ::2, ::2])"]
    if volume.values.dtype == np.float64:
        advice.append("float32 data instead of float64")
    if prec == "float64":
        advice.append("precision='float32'")
    return "try " + ", ".join(advice[:-1]) + " or " + advice[-1]


class _Extended(NamedTuple):
    """Arrays of ``_kernels_ext`` (placeholders of one element where unused)."""

    pyr: np.ndarray
    pgeo: np.ndarray
    lods: np.ndarray
    leap_lod: np.ndarray
    gbricks: np.ndarray
    slots: np.ndarray
    modes: np.ndarray
    tables: np.ndarray
    sigmas: np.ndarray
    axes: np.ndarray
    level_tables: np.ndarray
    level_steps: np.ndarray
    e: KX.ExtParams
    projection: object  # a projection's marker (_composite_kernels), or None


def _extended_arguments(volume, opts, params, table, sigma, unit, blocks, active, leap, lod, styles, tf, prec, mask):
    dtype = np.float64 if prec == "float64" else np.float32
    one = np.zeros(1, dtype)
    if lod is not None:
        levels = int(math.ceil(lod.max())) + 1
        pyr, pgeo, grids = _mip_pyramid(volume, dtype, levels)
        leap_lod = _mip_leaps(grids, blocks, opts, styles, table, params, mask)
        lods = lod
        # A ray at level L samples a volume filtered to 2**L voxels: along the ray too,
        # a step of 2**L times the render's step resolves it (the opacity table follows).
        # A projection keeps the render's step: a maximum's lattice points are its grid's.
        project = opts.blending != "composite"
        steps = [params.step * (1.0 if project else 2.0 ** level) for level in range(pgeo.shape[0])]
        level_tables = np.stack([np.column_stack([table[:, :3], -np.expm1(-sigma.astype(np.float64) * st)])
                                 .astype(table.dtype).reshape(-1) for st in steps])
        level_steps = np.array(steps)
    else:
        pyr, pgeo, lods, leap_lod = one, np.zeros((1, 6), np.int64), np.zeros(1), leap.reshape(1, -1)
        level_tables, level_steps = table.reshape(1, -1), np.array([params.step])
    gbricks = _gradient_bricks(volume, dtype) if opts.gradient_opacity is not None else one
    g_lo, g_hi = opts.gradient_opacity if opts.gradient_opacity is not None else (0.0, 1.0)
    if styles is not None:
        slots, modes, tables, sigmas, axes = styles.slots, styles.modes, styles.tables, styles.sigmas, styles.axes
        lattice, midpoint = styles.lattice, styles.midpoint
    else:
        slots = np.zeros(1, np.uint8)
        modes = np.array([BLENDING_CODES["composite"]], np.int64)
        tables, sigmas = table.reshape(-1), sigma
        axes = np.array([[params.scale, params.axis_lo, params.axis_inv_range, params.linthresh]], np.float64)
        lattice, midpoint = 0, 1
    # a maximum (minimum) projection may stop at the largest (smallest) value the
    # sampled data holds: the block ranges of the values actually rendered (a float32
    # or 8-bit copy has other extremes than the caller's array)
    finite = np.isfinite(blocks.minimum)
    stop = math.inf
    if finite.any() and block_is_whole(active, blocks):
        if opts.blending == "maximum":
            stop = float(blocks.maximum[finite].max())
        elif opts.blending == "minimum":
            stop = -float(blocks.minimum[finite].min())
    e = KX.ExtParams(float(unit), int(opts.gradient_opacity is not None), float(g_lo), float(1.0 / (g_hi - g_lo)),
                     int(pgeo.shape[0]) if lod is not None else 0, int(styles is not None), int(lattice),
                     int(midpoint))
    projection = None
    if opts.blending != "composite":
        projection = projection_marker(BLENDING_CODES[opts.blending], float(unit), stop)
    return _Extended(pyr, pgeo, lods, leap_lod, gbricks, slots, modes, tables, sigmas, axes, level_tables, level_steps,
                     e, projection)


def _light(volume, opts, prec, piece=None):
    """The kernels' ``light`` (``_kernels.lit``): 0 for an unshaded render, else the
    tuple ``(shading, lights, gradient vectors)`` (the vectors bricked in the kernel
    precision for ``shade_gradient="interpolated"``, else a placeholder). ``piece``: a
    rectilinear piece's :class:`VolumePiece`, whose shading fades over the whole grid's
    spacing and narrowest cell."""
    if not opts.shade:
        return 0
    dtype = np.float64 if prec == "float64" else np.float32
    if volume.axes is not None:
        # a rectilinear grid lights from its points' gradients (central differences over
        # the true neighbours, exact for linear fields), interpolated at the sample's index
        # coordinates: the sampled gradient's stencil assumes even spacing
        spacing, unit = volume.spacing, volume.min_cell_width
        if piece is not None and piece.whole_axes is not None:
            spacing = piece.nominal(volume.dims)[0]
            unit = float(min(np.diff(a).min() for a in piece.whole_axes))
        shading, lights = shading_arrays(opts, spacing, unit=unit, sampled=False)
        return shading, lights, _gradient_vector_bricks(volume, dtype)
    interpolated = opts.shade_gradient == "interpolated"
    gvec = _gradient_vector_bricks(volume, dtype) if interpolated else np.zeros(1, dtype)
    shading, lights = shading_arrays(opts, volume.spacing)
    return shading, lights, gvec


def _mip_leaps(grids, blocks, opts, styles, table, params, mask):
    """Leap radii, one row per mip level ``L``, for rays that sample levels ``L`` and ``L + 1``.

    A level-``L`` sample in level-0 block ``b`` reads only the level-``L`` points over
    that block's span (``_kernels.level_block_ranges``), and a value between two levels
    lies within both levels' ranges. So a level-0 block is sampled when the union of
    those ranges can be visible (the same test as level 0): skipping changes no pixel.
    """
    ranges = []
    for ell, g in enumerate(grids):
        if ell == 0:
            ranges.append((blocks.minimum, blocks.maximum))
            continue
        lo = np.empty(blocks.shape)
        hi = np.empty(blocks.shape)
        K.level_block_ranges(g, ell, blocks.shift, lo, hi)
        ranges.append((lo, hi))
    rows = []
    for ell in range(len(grids)):
        lo, hi = ranges[ell]
        if ell + 1 < len(grids):
            lo = np.fmin(lo, ranges[ell + 1][0])
            hi = np.fmax(hi, ranges[ell + 1][1])
        active = _active_blocks(lo, hi, opts, styles, table, params)
        if mask is not None:
            active = active & mask
        rows.append(leap_radius(active).reshape(-1))
    return np.ascontiguousarray(np.stack(rows))


def block_is_whole(active, blocks):
    """Whether every block with a finite value is sampled (no mask excludes any)."""
    return bool(np.all(active.astype(bool) | ~np.isfinite(blocks.minimum)))


def _mip_pyramid(volume, dtype, levels):
    """Bricked mip-map levels ``0 .. levels - 1`` (fewer if the volume gets too small).

    Cached on the volume; returns ``(flat values, geometry (levels, 6) int64, the levels
    as (z, y, x) arrays)``, the first two as ``_kernels.mip_sampler`` reads them.
    """
    key = ("mip", np.dtype(dtype).str)
    cached = volume.cache.get(key)
    if cached is None or cached[1].shape[0] < levels:
        grids = [np.ascontiguousarray(volume.values, dtype=dtype)]
        while len(grids) < levels:
            nz, ny, nx = grids[-1].shape
            if min(nx, ny, nz) < 3:
                break
            out = np.empty((nz // 2 + 1, ny // 2 + 1, nx // 2 + 1), dtype)
            KX.downsample(grids[-1], out)
            grids.append(out)
        size = 1 << K.BRICK_SHIFT
        parts, geo, offset = [], [], 0
        for g in grids:
            dims = g.shape[::-1]
            shape = _brick_shape(dims)
            b = np.empty(int(np.prod(shape)) * (size + 1) ** 3, dtype)
            K.make_bricks(g, K.BRICK_SHIFT, *shape, b)
            geo.append((offset, dims[0], dims[1], dims[2], shape[1], shape[2]))
            parts.append(b)
            offset += b.size
        cached = (np.concatenate(parts), np.array(geo, dtype=np.int64), grids)
        volume.cache[key] = cached
    return cached[0], cached[1][:levels], cached[2][:levels]


def _gradient_bricks(volume, dtype):
    """``|grad v|`` per grid point (world units), bricked like the data; cached."""
    key = ("gradient", np.dtype(dtype).str)
    if key not in volume.cache:
        mag = np.empty(volume.values.shape, dtype)
        KX.gradient_magnitude(volume.values, np.ascontiguousarray(1.0 / volume.spacing, dtype=np.float64), mag)
        size = 1 << K.BRICK_SHIFT
        shape = _brick_shape(volume.dims)
        b = np.empty(int(np.prod(shape)) * (size + 1) ** 3, dtype)
        K.make_bricks(mag, K.BRICK_SHIFT, *shape, b)
        volume.cache[key] = b
    return volume.cache[key]


def _gradient_vector_bricks(volume, dtype):
    """``grad v`` per grid point (world units), each component bricked like the data, one
    after the other in one flat array (``_kernels.lit``); cached on the volume."""
    key = ("gradient_vectors", np.dtype(dtype).str)
    if key not in volume.cache:
        if volume.axes is not None:
            grad = rectilinear_gradient(volume.values, volume.axes)
        else:
            grad = np.empty((3,) + volume.values.shape, np.float64)
            KX.gradient_vectors(volume.values, np.ascontiguousarray(1.0 / volume.spacing, dtype=np.float64), grad)
        size = 1 << K.BRICK_SHIFT
        shape = _brick_shape(volume.dims)
        n = int(np.prod(shape)) * (size + 1) ** 3
        b = np.empty(3 * n, dtype)
        for axis in range(3):
            K.make_bricks(grad[axis].astype(dtype), K.BRICK_SHIFT, *shape, b[axis * n:(axis + 1) * n])
        volume.cache[key] = b
    return volume.cache[key]


def rectilinear_gradient(values, axes):
    """``grad v`` (3, z, y, x), world units, at the points of a rectilinear grid: per axis
    ``(v[i + 1] - v[i - 1]) / (c[i + 1] - c[i - 1])``, one-sided at the ends (as
    ``_kernels_ext._grid_gradient`` on a uniform grid; exact for a linear field)."""
    v = np.asarray(values, dtype=np.float64)
    grad = np.empty((3,) + v.shape)
    for axis, c in enumerate(axes):
        n = c.size
        i0 = np.maximum(np.arange(n) - 1, 0)
        i1 = np.minimum(np.arange(n) + 1, n - 1)
        inv = 1.0 / (c[i1] - c[i0])
        along = 2 - axis  # values are (z, y, x)
        shape = [1, 1, 1]
        shape[along] = n
        grad[axis] = (np.take(v, i1, axis=along) - np.take(v, i0, axis=along)) * inv.reshape(shape)
    return grad


_LABEL_BLENDINGS = ("composite", "maximum", "minimum")


class _LabelStyles:
    """Per-label transfer functions and blendings as ``_kernels_ext`` reads them.

    Slot 0 is the default style (``tf``, composite); each styled label gets a slot.
    The label volume becomes a bricked uint8 array of slots.
    """

    def __init__(self, volume, labels, label_styles, tf, table, sigma, params, opts, step_world, unit):
        lab = np.asarray(labels)
        shape = volume.values.shape
        if lab.shape != shape:
            raise ValueError(f"labels must have the volume's shape {shape} (z, y, x); got {lab.shape}")
        if not (np.issubdtype(lab.dtype, np.integer) or lab.dtype == np.bool_):
            raise TypeError(f"labels must be an integer or bool array; got dtype {lab.dtype}")
        label_styles = {} if label_styles is None else label_styles
        if not isinstance(label_styles, dict):
            raise TypeError(f"label_styles must be a dict {{label: style}}; got {type(label_styles).__name__}")
        if len(label_styles) > 254:
            raise ValueError(f"at most 254 styled labels; got {len(label_styles)}")
        present = set(np.unique(lab).tolist())
        tfs, blendings, names = [tf], ["composite"], ["default"]
        slot_of = {}
        for key, style in label_styles.items():
            if isinstance(key, (bool, np.bool_)) or not isinstance(key, (int, np.integer)):
                raise TypeError(f"label_styles keys must be integer labels; got {key!r}")
            if int(key) not in present:
                raise ValueError(f"label {key!r} of label_styles does not occur in labels (labels present: "
                                 f"{sorted(present)[:20]})")
            stf, blend = _parse_style(key, style, tf)
            slot_of[int(key)] = len(tfs)
            tfs.append(stf)
            blendings.append(blend)
            names.append(int(key))
        n = max(t.table_size for t in tfs) if params.precision != PRECISION_CODES["uint8"] else 256
        dtype = table.dtype
        tables, sigmas, axes = [], [], []
        for t in tfs:
            if t is tf and len(table) == n:
                rows, sig = table, sigma
            else:
                rgb, s = t.table(np.float64, opts.global_alpha, unit, n)
                rows = np.column_stack([rgb, -np.expm1(-s * step_world)]).astype(dtype)
                sig = s.astype(dtype)
            a0, a1 = t.axis_range
            tables.append(np.ascontiguousarray(rows).reshape(-1))
            sigmas.append(sig)
            axes.append((SCALE_CODES[t.scale], a0, 1.0 / (a1 - a0), t.linthresh))
        self.tables = np.ascontiguousarray(np.concatenate(tables), dtype=dtype)
        self.sigmas = np.ascontiguousarray(np.concatenate(sigmas), dtype=dtype)
        self.axes = np.array(axes, dtype=np.float64)
        self.modes = np.array([BLENDING_CODES[b] for b in blendings], np.int64)
        self._opacity = [self.tables.reshape(len(tfs), n, 4)[i, :, 3] for i in range(len(tfs))]
        self._blendings = blendings
        self._names = names
        # the slot of each grid point, bricked as the data
        lut_keys = np.array(sorted(slot_of), dtype=np.int64)
        lut_vals = np.array([slot_of[k] for k in sorted(slot_of)], dtype=np.uint8)
        flat = lab.astype(np.int64).reshape(-1)
        slot_volume = np.zeros(flat.size, np.uint8)
        if lut_keys.size:
            pos = np.clip(np.searchsorted(lut_keys, flat), 0, lut_keys.size - 1)
            hit = lut_keys[pos] == flat
            slot_volume[hit] = lut_vals[pos[hit]]
        size = 1 << K.BRICK_SHIFT
        bshape = _brick_shape(volume.dims)
        self.slots = np.empty(int(np.prod(bshape)) * (size + 1) ** 3, np.uint8)
        K.make_bricks(slot_volume.reshape(shape), K.BRICK_SHIFT, *bshape, self.slots)
        used = set(blendings)
        self.lattice = int(bool(used & {"maximum", "minimum"}))
        self.midpoint = int("composite" in used)
        self.needs_all_blocks = bool(self.lattice)

    def opacity_columns(self):
        """Per-step opacity of every composite style (for empty-space skipping)."""
        return [a for a, b in zip(self._opacity, self._blendings) if b == "composite"]

    def describe(self):
        return {str(n): b for n, b in zip(self._names, self._blendings)}


def _parse_style(label, style, default_tf):
    """``(TransferFunction, blending)`` of one ``label_styles`` entry."""
    stf, blend = default_tf, "composite"
    if isinstance(style, TransferFunction):
        stf = style
    elif isinstance(style, str):
        blend = style
    elif isinstance(style, tuple) and len(style) == 2 and isinstance(style[0], TransferFunction):
        stf, blend = style
    else:
        raise TypeError(f"the style of label {label!r} must be a TransferFunction, a blending name or a "
                        f"(TransferFunction, blending) pair; got {style!r}")
    if blend not in _LABEL_BLENDINGS:
        raise ValueError(f"the blending of label {label!r} must be one of {list(_LABEL_BLENDINGS)}; got {blend!r}")
    return stf, blend


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


