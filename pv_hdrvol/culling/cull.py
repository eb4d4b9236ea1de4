"""Front-to-back visibility culling of volume blocks with plenoptic opacity functions
(Gao et al. 2003, section 3.3): an opacity buffer at the image's pixels, each block's
conservative opacity composited front to back, a block culled when every pixel it may
touch is already at the threshold."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_real
from ..rays.camera import Camera
from ..raycast.grid import block_grid_shape
from . import _kernels as K

#: The paper's threshold: a pixel at accumulated opacity 0.95 counts as opaque.
DEFAULT_THRESHOLD = 0.95


@dataclass(frozen=True)
class CullResult:
    """Which blocks a view needs.

    ``visible`` (bz, by, bx) bool over the POF blocks; ``nonempty`` the blocks the family
    does not map to zero; ``opacity`` the final opacity buffer (rows, cols).
    """

    visible: np.ndarray
    nonempty: np.ndarray
    opacity: np.ndarray

    @property
    def statistics(self):
        n = int(self.nonempty.sum())
        v = int(self.visible.sum())
        return {"blocks": int(self.visible.size), "nonempty": n, "visible": v, "culled": n - v,
                "culled_fraction": (n - v) / n if n else 0.0}


def block_boxes(volume, block_size, blocks=None):
    """``(lo, hi)`` (B, 3) world boxes of blocks of ``block_size`` cells (x, y, z), for the
    flat z-y-x block indices ``blocks`` (default all): block ``(k, j, i)`` spans points
    ``i * block_size`` to ``min((i + 1) * block_size, nx - 1)`` along x, and so on."""
    shape = block_grid_shape(volume.dims, block_size)
    flat = np.arange(int(np.prod(shape))) if blocks is None else np.asarray(blocks, dtype=np.int64).reshape(-1)
    lo_pt = np.stack(np.unravel_index(flat, shape), axis=-1)[:, ::-1] * block_size
    hi_pt = np.minimum(lo_pt + block_size, np.array(volume.dims) - 1)
    origin, spacing = np.asarray(volume.origin, dtype=np.float64), np.asarray(volume.spacing, dtype=np.float64)
    return np.ascontiguousarray(origin + lo_pt * spacing), np.ascontiguousarray(origin + hi_pt * spacing)


def visibility_order(shape, d, spacing=(1.0, 1.0, 1.0)):
    """Block indices (flat, z-y-x order of ``shape``) front to back for an orthographic
    view along ``d`` (x, y, z), nearest first.

    If block A lies in front of block B on some ray, each of A's indices is <= B's,
    counted from the side the rays enter, and one with ``d_i != 0`` is smaller; so any
    positive weighting of those indices orders A first. The weights here are
    ``|d_i| spacing_i`` (the depth of the block's centre along ``d``, up to a constant),
    so that a block's neighbours across the view are composited before the blocks
    behind them, and the culling test of a block (whose footprint reaches into its
    neighbours' pixels) sees them. Components below 1e-9 get weight 0 (no ray crosses
    blocks along them, and float rounding could otherwise invert a pair); ties go to
    the plain sum of the counted indices, itself a valid order (the paper's flipped Z
    curve is another).
    """
    bz, by, bx = shape
    kz, ky, kx = np.meshgrid(np.arange(bz), np.arange(by), np.arange(bx), indexing="ij")
    key = np.zeros(shape, dtype=np.int64)
    depth = np.zeros(shape)
    for idx, n, comp, step in ((kx, bx, d[0], spacing[0]), (ky, by, d[1], spacing[1]), (kz, bz, d[2], spacing[2])):
        counted = idx if comp >= 0 else (n - 1 - idx)
        key += counted
        if abs(comp) >= 1e-9:
            depth += abs(comp) * float(step) * counted
    return np.lexsort((key.reshape(-1), depth.reshape(-1)))


def visible_blocks(pof, volume, camera, size, k=None, *, threshold=DEFAULT_THRESHOLD, encoding="table",
                   lookup="min4", method="conservative", window=None):
    """The blocks of ``volume`` a render with ``camera`` and ``size`` must sample.

    ``pof``: :class:`~pv_hdrvol.culling.pof.PlenopticOpacity` of ``volume``; ``k``: the
    family's weights (default all 1). Orthographic cameras only: the paper's order and
    POFs assume parallel rays. ``window=(col, row, width, height)``: the blocks that
    tile of the image needs (its own opacity buffer; the union over tiles of an
    image is the whole image's set). ``encoding``, ``lookup`` and ``method``: see
    :meth:`PlenopticOpacity.block_opacity`.
    """
    from ..raycast.grid import as_volume

    volume = as_volume(volume)
    pof.check_volume(volume)
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a Camera; got {type(camera).__name__}")
    if not camera.parallel_projection:
        raise ValueError("POF culling needs an orthographic camera (parallel_projection=True); got a perspective one")
    threshold = as_real("threshold", threshold, low=0, high=1, low_open=True, high_open=True)
    width, height = (size, size) if np.isscalar(size) else (int(size[0]), int(size[1]))
    cam = camera.kernel_array((width, height))
    d = cam[9:12]
    alpha = pof.block_opacity(d, k, encoding=encoding, lookup=lookup, method=method)
    weights = np.ones(pof.n_bases) if k is None else np.asarray(k, dtype=np.float64)
    nonempty = (pof.nonempty & (weights > 0)).any(axis=-1)
    shape = pof.grid_shape
    lo, hi = block_boxes(volume, pof.block_size)
    order = visibility_order(shape, d, volume.spacing)
    order = np.ascontiguousarray(order[nonempty.reshape(-1)[order]])
    opacity = np.zeros((height, width))
    visible = np.zeros(int(np.prod(shape)), dtype=np.uint8)
    pitch = 2.0 * cam[13] / height
    halo = pitch * np.sqrt(0.5)  # a pixel's square lies within this of its centre
    chord_min = pof.chord_min * float(np.min(volume.spacing))
    if window is None:
        limits = np.array([0, 0, width - 1, height - 1], dtype=np.int64)
    else:
        col, row, w, h = (int(x) for x in window)
        if w < 1 or h < 1 or col < 0 or row < 0 or col + w > width or row + h > height:
            raise ValueError(f"window must be (col, row, width, height) inside the {width}x{height} image; got {window}")
        limits = np.array([col, row, col + w - 1, row + h - 1], dtype=np.int64)
    K.cull_blocks(order, lo, hi, np.ascontiguousarray(alpha.reshape(-1)), cam, width, height, limits, threshold,
                  chord_min, halo, opacity, visible)
    return CullResult(visible.reshape(shape).astype(bool), nonempty, opacity)


def render_mask(result, pof, render_block_size, render_shape):
    """The POF blocks' visibility on the ray caster's (finer) block grid."""
    return expand_mask(result.visible, pof.block_size, render_block_size, render_shape)


def single_block_mask(block, shape, block_size, render_block_size, render_shape):
    """The ray caster's ``block_mask`` that keeps only the block of flat z-y-x index
    ``block`` of a grid of ``shape`` blocks of ``block_size`` cells."""
    one = np.zeros(shape, dtype=bool)
    one.reshape(-1)[int(block)] = True
    return expand_mask(one, block_size, render_block_size, render_shape)


def expand_mask(blocks, block_size, render_block_size, render_shape):
    """(bz, by, bx) bool over blocks of ``block_size`` cells as the ray caster's
    ``block_mask`` (blocks of ``render_block_size``, shape ``render_shape``)."""
    if block_size % render_block_size:
        raise ValueError(f"the POF block size ({block_size}) must be a multiple of the render's block_size "
                         f"({render_block_size})")
    r = block_size // render_block_size
    mask = blocks.repeat(r, 0).repeat(r, 1).repeat(r, 2)
    return np.ascontiguousarray(mask[:render_shape[0], :render_shape[1], :render_shape[2]])


@dataclass(frozen=True)
class Culling:
    """POF culling as a render takes it: ``render(..., cull=Culling(pof, threshold=0.9))``
    (``cull=pof`` is ``Culling(pof)``).

    Parameters
    ----------
    pof : PlenopticOpacity
        Of the volume rendered, for the bases of the render's transfer function.
    threshold : float
        Opacity at which a pixel counts as opaque (the paper's 0.95). A culled block
        lies behind at least this opacity on every pixel it covers, so it changes a
        pixel by at most ``(1 - threshold)`` times what it would emit there; with the
        render's ``termination = 1 - threshold`` it changes none.
    encoding : {"table", "poly"}
    lookup : {"min4", "nearest", "bilinear"}
        See :meth:`PlenopticOpacity.view_minimum`.
    method : {"conservative", "sets"}
        See :meth:`PlenopticOpacity.block_opacity` (``"sets"`` is not a bound).
    """

    pof: object
    threshold: float = DEFAULT_THRESHOLD
    encoding: str = "table"
    lookup: str = "min4"
    method: str = "conservative"

    def __post_init__(self):
        # what a PlenopticOpacity offers (pof.py imports this module: no isinstance)
        if not all(callable(getattr(self.pof, name, None)) for name in ("block_opacity", "check_volume")):
            raise TypeError(f"cull needs a PlenopticOpacity; got {type(self.pof).__name__}")
        object.__setattr__(self, "threshold",
                           as_real("threshold", self.threshold, low=0, high=1, low_open=True, high_open=True))
        from .._validate import as_choice

        as_choice("encoding", self.encoding, ("table", "poly"))
        as_choice("lookup", self.lookup, ("min4", "nearest", "bilinear"))
        as_choice("method", self.method, ("conservative", "sets"))
        if self.method == "sets" and (self.pof.sets is None or self.encoding != "table"):
            raise ValueError("method='sets' needs the table encoding and POFs computed with sets=True")

    def weights_for(self, tf, options, unit):
        """The family weights ``k`` for which the POFs bound the render's extinction.

        ``tf`` must be a family of the POFs' bases (or one of them). The render's
        ``global_alpha`` and ``opacity_unit_distance`` change each basis's extinction
        from the POFs' ``sigma_i`` to ``sigma_i'``; the weights returned are ``k_i``
        times the smallest ratio ``sigma_i' / sigma_i`` over the table, so the bound
        holds for any of them (exactly ``unit / opacity_unit_distance`` at
        ``global_alpha = 1``)."""
        from ..data.transfer import TransferFunctionFamily

        bases = self.pof.bases
        keys = [b.to_dict() for b in bases]
        if isinstance(tf, TransferFunctionFamily) and [b.to_dict() for b in tf.bases] == keys:
            k = np.array(tf.k, dtype=np.float64)
        elif not isinstance(tf, TransferFunctionFamily) and tf.to_dict() in keys:
            k = np.array([1.0 if key == tf.to_dict() else 0.0 for key in keys])
        else:
            raise ValueError("cull= needs the render's tf to be TransferFunction.family(pof.bases, k) (or one of "
                             f"the {len(bases)} bases the POFs were computed for); got {tf!r}")
        family = TransferFunctionFamily(bases)
        computed = family.basis_tables(1.0, unit)
        distance = unit if options.opacity_unit_distance is None else options.opacity_unit_distance
        rendered = family.basis_tables(options.global_alpha, distance)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(computed > 0, rendered / computed, np.inf).min(axis=1)
        return k * np.where(np.isfinite(ratio), ratio, 0.0)

    def mask_for(self, volume, tf, camera, size, options, render_shape):
        """``(mask, statistics)``: the render's block mask (shape ``render_shape``) and
        the culling's counts and time."""
        import time

        start = time.perf_counter()
        if options.blending != "composite" or options.gradient_opacity is not None:
            raise ValueError("cull= applies to blending='composite' without gradient_opacity (the POFs bound the "
                             "transfer function's extinction only)")
        k = self.weights_for(tf, options, float(np.min(volume.spacing)))
        result = visible_blocks(self.pof, volume, camera, size, k, threshold=self.threshold, encoding=self.encoding,
                                lookup=self.lookup, method=self.method)
        mask = render_mask(result, self.pof, options.block_size, render_shape)
        stats = dict(result.statistics, threshold=self.threshold, encoding=self.encoding, lookup=self.lookup,
                     method=self.method,
                     block_size=self.pof.block_size, seconds=time.perf_counter() - start)
        return mask, stats

