"""References to measure POF culling against (../shared/notes/methods.md, A.5):

- :func:`ert_oracle` (R1): the blocks in which the unculled ray caster evaluates a
  sample while the ray's accumulated opacity is still below the threshold: exactly the
  blocks that can change the image when the render terminates rays at the threshold.
- :func:`exact_sequential` (R2): the paper's exact algorithm: blocks front to back,
  each rendered alone into its own opacity image and composited; a block is culled
  when every pixel it may touch already has the threshold.

Both render with the library's own ray caster (same sample positions), so they are
slow (R2 renders every non-empty block once): benchmarks and tests only.
"""
from __future__ import annotations

import numpy as np

from ..rays.camera import Camera
from ..raycast.grid import block_grid_shape
from .cull import DEFAULT_THRESHOLD, block_boxes, single_block_mask, visibility_order


def ert_oracle(volume, tf, camera, size, *, block_size=16, threshold=DEFAULT_THRESHOLD, nonempty=None, **options):
    """(bz, by, bx) bool: R1 for the ray caster with ``options`` (its ``step``).

    From a render's depth image at ``depth_threshold = threshold``: every sample
    position ``t0 + (k + 1/2) step`` up to that depth (all of the ray where it never
    reaches the threshold) marks the block containing it; ``nonempty`` (same shape)
    keeps only blocks that can hold opacity.
    """
    from ..raycast.grid import as_volume, render_volume

    volume = as_volume(volume)
    image = render_volume(volume, tf, camera, size, depth_threshold=threshold, termination=0.0, progress_bar=False,
                   **options)
    step_world = image.metadata["step_world"]
    rays = camera.rays(size)
    inv = 1.0 / volume.spacing
    o = (rays.origins - volume.origin) * inv
    d = rays.directions * inv
    hi = np.array(volume.dims, dtype=np.float64) - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ta, tb = (0.0 - o) / d, (hi - o) / d
    t0 = np.nan_to_num(np.minimum(ta, tb), nan=-np.inf).max(axis=1).clip(min=0.0)
    t1 = np.nan_to_num(np.maximum(ta, tb), nan=np.inf).min(axis=1)
    depth = image.depth.reshape(-1)
    end = np.minimum(t1, depth)
    shape = block_grid_shape(volume.dims, block_size)
    marked = np.zeros(shape, dtype=bool)
    for r in np.nonzero(t1 > t0)[0]:
        n = int(np.ceil((t1[r] - t0[r]) / step_world))
        t = t0[r] + (np.arange(n) + 0.5) * step_world
        t[-1] = 0.5 * (t0[r] + (n - 1) * step_world + t1[r])  # the last, shorter segment's midpoint
        t = t[t <= end[r]]
        p = o[r] + t[:, None] * d[r]
        b = np.minimum(np.floor(p / block_size).astype(np.int64), np.array(shape[::-1]) - 1).clip(min=0)
        marked[b[:, 2], b[:, 1], b[:, 0]] = True
    return marked if nonempty is None else marked & nonempty


def exact_sequential(volume, tf, camera, size, *, block_size=16, threshold=DEFAULT_THRESHOLD, nonempty=None,
                     render_block_size=4, **options):
    """(bz, by, bx) bool: R2, the paper's exact sequential culling, and the number of
    block renders it took. ``nonempty`` (default: every block) limits the candidates."""
    from ..raycast.grid import BlockGrid, as_volume, render_volume

    if not isinstance(camera, Camera) or not camera.parallel_projection:
        raise ValueError("exact_sequential needs an orthographic Camera")
    volume = as_volume(volume)
    shape = block_grid_shape(volume.dims, block_size)
    nonempty = np.ones(shape, dtype=bool) if nonempty is None else nonempty
    width, height = (size, size) if np.isscalar(size) else size
    cam = camera.kernel_array((width, height))
    rays = camera.rays((width, height))
    lo, hi = block_boxes(volume, block_size)
    pitch = 2.0 * cam[13] / height
    halo = pitch * np.sqrt(0.5)
    render_shape = BlockGrid.of(volume, render_block_size).shape
    opacity = np.zeros(height * width)
    visible = np.zeros(int(np.prod(shape)), dtype=bool)
    renders = 0

    for b in visibility_order(shape, cam[9:12], volume.spacing):
        if not nonempty.reshape(-1)[b]:
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = (lo[b] - halo - rays.origins) / rays.directions
            tb = (hi[b] + halo - rays.origins) / rays.directions
        near = np.nan_to_num(np.minimum(ta, tb), nan=-np.inf).max(axis=1)
        far = np.nan_to_num(np.maximum(ta, tb), nan=np.inf).min(axis=1)
        touched = far > near
        if touched.any() and np.all(opacity[touched] >= threshold):
            continue
        visible[b] = True
        mask = single_block_mask(b, shape, block_size, render_block_size, render_shape)
        alpha = render_volume(volume, tf, camera, (width, height), block_mask=mask, termination=0.0, progress_bar=False,
                       **options).rgba[..., 3].reshape(-1).astype(np.float64)
        renders += 1
        opacity = 1.0 - (1.0 - opacity) * (1.0 - alpha)
    return visible.reshape(shape), renders
