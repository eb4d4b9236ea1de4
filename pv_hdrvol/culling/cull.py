"""Front-to-back visibility culling of volume blocks with plenoptic opacity functions
(Gao et al. 2003, section 3.3): an opacity buffer at the image's pixels, each block's
conservative opacity composited front to back, a block culled when every pixel it may
touch is already at the threshold."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_real
from ..rays.camera import Camera
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


def visibility_order(shape, d):
    """Block indices (flat, z-y-x order of ``shape``) front to back for an orthographic
    view along ``d`` (x, y, z): blocks sorted by the sum of their indices counted from
    the side the rays enter. If block A lies in front of block B on some ray, each of
    A's indices is <= B's (counted that way) and one is smaller, so A comes first: any
    order by that sum is a valid visibility order (the paper's flipped Z curve is another)."""
    bz, by, bx = shape
    kz, ky, kx = np.meshgrid(np.arange(bz), np.arange(by), np.arange(bx), indexing="ij")
    key = np.zeros(shape, dtype=np.int64)
    for idx, n, comp in ((kx, bx, d[0]), (ky, by, d[1]), (kz, bz, d[2])):
        key += idx if comp >= 0 else (n - 1 - idx)
    return np.argsort(key.reshape(-1), kind="stable")


def visible_blocks(pof, volume, camera, size, k=None, *, threshold=DEFAULT_THRESHOLD, encoding="table",
                   lookup="min4"):
    """The blocks of ``volume`` a render with ``camera`` and ``size`` must sample.

    ``pof``: :class:`~pv_hdrvol.culling.pof.PlenopticOpacity` of ``volume``; ``k``: the
    family's weights (default all 1). Orthographic cameras only: the paper's order and
    POFs assume parallel rays.
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
    alpha = pof.block_opacity(d, k, encoding=encoding, lookup=lookup)
    weights = np.ones(pof.n_bases) if k is None else np.asarray(k, dtype=np.float64)
    nonempty = (pof.nonempty & (weights > 0)).any(axis=-1)
    shape = pof.grid_shape
    b = pof.block_size
    idx = np.stack(np.meshgrid(*(np.arange(n) for n in shape), indexing="ij"), axis=-1).reshape(-1, 3)[:, ::-1]
    lo_pt = idx * b
    hi_pt = np.minimum(lo_pt + b, np.array(volume.dims) - 1)
    origin, spacing = np.asarray(volume.origin, dtype=np.float64), np.asarray(volume.spacing, dtype=np.float64)
    lo = np.ascontiguousarray(origin + lo_pt * spacing)
    hi = np.ascontiguousarray(origin + hi_pt * spacing)
    order = visibility_order(shape, d)
    order = np.ascontiguousarray(order[nonempty.reshape(-1)[order]])
    opacity = np.zeros((height, width))
    visible = np.zeros(int(np.prod(shape)), dtype=np.uint8)
    pitch = 2.0 * cam[13] / height
    halo = pitch * np.sqrt(0.5)  # a pixel's square lies within this of its centre
    chord_min = pof.chord_min * float(np.min(spacing))
    K.cull_blocks(order, lo, hi, np.ascontiguousarray(alpha.reshape(-1)), cam, width, height, threshold, chord_min,
                  halo, opacity, visible)
    return CullResult(visible.reshape(shape).astype(bool), nonempty, opacity)


def render_mask(result, pof, render_block_size, render_shape):
    """The POF blocks' visibility on the ray caster's (finer) block grid."""
    if pof.block_size % render_block_size:
        raise ValueError(f"the POF block size ({pof.block_size}) must be a multiple of the render's block_size "
                         f"({render_block_size})")
    r = pof.block_size // render_block_size
    mask = result.visible.repeat(r, 0).repeat(r, 1).repeat(r, 2)
    return np.ascontiguousarray(mask[:render_shape[0], :render_shape[1], :render_shape[2]])
