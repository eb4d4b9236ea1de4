"""SPMD sort-last rendering of one image volume on MPI ranks (Gao et al. 2003, section 4).

Every rank runs :func:`render_parallel` with the same arguments:

1. **Distribution.** Blocks (the POF's, 16^3 by default) are dealt round-robin along a
   Hilbert curve (:func:`~pv_hdrvol.parallel.distribute.assign`): static, independent
   of the transfer function.
2. **Culling.** The image is split into one tile per rank; each rank culls for its tile
   with the replicated POFs (no communication), and one ``Allreduce(MAX)`` of a byte
   per block gives every rank the visible set (the union over tiles is the whole
   image's set).
3. **Rendering.** Each rank renders its own visible blocks one by one, each into a
   float partial image over the block's screen rectangle (``GridPlan.execute`` with a
   one-block mask and a window): samples are the global ray lattice's, so the blocks'
   samples together are exactly the single-pass render's; early termination is local
   to a block.
4. **Compositing.** Direct send: each partial goes to the ranks whose tiles it
   overlaps (``alltoall``); each rank composites its tile front to back in the
   visibility order (:func:`~pv_hdrvol.parallel.composite.composite`), and the tiles
   are gathered on ``root``.

The image depends only on the blocks' partial images and their order, never on the
rank count: ``comm=None`` (serial) gives the same bits as any ``mpiexec -n P``.
"""
from __future__ import annotations

import time

import numpy as np

from .._validate import as_int
from ..culling.cull import (DEFAULT_THRESHOLD, block_boxes, single_block_mask, visibility_order,
                            visible_blocks)
from ..culling.pof import PlenopticOpacity, _nonempty
from ..data.transfer import TransferFunctionFamily
from ..image.hdr import HDRImage
from ..rays.camera import Camera, as_size
from ..raycast.grid import BlockGrid, GridPlan, _grid_shape, as_volume
from .comm import WORLD, _communicator
from .composite import composite, tile_grid
from .distribute import assign

def block_rect(lo, hi, camera, size):
    """``(col, row, w, h)`` of the pixels whose centre rays can cross the box ``[lo, hi]``
    (world), clipped to the image; ``None`` when it is off screen."""
    w, h = size
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    cr = camera.project(corners, size)
    c0 = max(0, int(np.floor(cr[:, 0].min() - 0.5)))
    c1 = min(w - 1, int(np.ceil(cr[:, 0].max() - 0.5)))
    r0 = max(0, int(np.floor(cr[:, 1].min() - 0.5)))
    r1 = min(h - 1, int(np.ceil(cr[:, 1].max() - 0.5)))
    return (c0, r0, c1 - c0 + 1, r1 - r0 + 1) if c1 >= c0 and r1 >= r0 else None


def block_partials(plan, volume, camera, size, block_size, blocks):
    """``(block, rect, image)`` for each flat block index of ``blocks`` on screen: the
    block rendered alone (``plan.execute`` with a one-block mask) over its screen
    rectangle ``rect = (col, row, w, h)``; ``image.metadata["samples"]`` counts its samples."""
    opts = plan.options
    shape = _grid_shape(volume.dims, block_size)
    render_shape = BlockGrid.of(plan.source, opts.block_size).shape
    blocks = np.asarray(blocks, dtype=np.int64).reshape(-1)
    lo, hi = block_boxes(volume, block_size, blocks)
    for b, box_lo, box_hi in zip(blocks, lo, hi):
        rect = block_rect(box_lo, box_hi, camera, size)
        if rect is None:
            continue
        mask = single_block_mask(b, shape, block_size, opts.block_size, render_shape)
        yield int(b), rect, plan.execute(camera, size, block_mask=mask, window=rect, progress_bar=False)


def render_parallel(volume, tf, camera, size=(512, 512), *, pof=None, comm=WORLD, curve="hilbert", block_size=None,
                    threshold=DEFAULT_THRESHOLD, root=0, **options):
    """Render ``volume`` with the blocks spread over the ranks of ``comm``.

    Parameters
    ----------
    volume, tf, camera, size, **options
        As :func:`pv_hdrvol.render` (an orthographic :class:`Camera`; ``tf`` a family
        of ``pof``'s bases when ``pof`` is given).
    pof : PlenopticOpacity, optional
        Cull hidden blocks (per tile, then shared). Without it every non-empty block is
        rendered.
    comm : mpi4py communicator, ``"world"`` (default: ``MPI.COMM_WORLD``) or None (serial)
    curve : {"hilbert", "z", "contiguous", "random"}
        How blocks are dealt to ranks.
    block_size : int, optional
        Blocks of the distribution (cells per edge); default the POF's, else 16. A
        multiple of the render's ``block_size`` option (4).
    threshold : float
        The culling threshold (the paper's 0.95).
    root : int or None
        The rank that gets the image; ``None``: every rank does.

    Returns
    -------
    HDRImage or None
        On ``root`` (every rank for ``root=None``): RGBA composited front to back,
        ``depth`` all ``inf`` (not composited yet), and ``metadata["parallel"]`` with
        per-rank counts and times (cull, render, composite). ``None`` elsewhere.
    """
    comm = _communicator(comm)
    rank, n_ranks = comm.rank, comm.size
    t_start = time.perf_counter()
    volume = as_volume(volume)
    if not isinstance(camera, Camera) or not camera.parallel_projection:
        raise ValueError("render_parallel needs an orthographic Camera (parallel_projection=True): the visibility "
                         "order of blocks is the orthographic one")
    size = as_size(size)
    plan = GridPlan(volume, tf, **options)
    opts = plan.options
    if opts.blending != "composite":
        raise ValueError(f"render_parallel composites blocks front to back: blending='composite' only; got "
                         f"{opts.blending!r}")
    if pof is not None:
        if not isinstance(pof, PlenopticOpacity):
            raise TypeError(f"pof must be a PlenopticOpacity; got {type(pof).__name__}")
        pof.check_volume(volume)
    bs = as_int("block_size", block_size if block_size is not None else (pof.block_size if pof else 16), low=2)
    if pof is not None and bs != pof.block_size:
        raise ValueError(f"block_size {bs} differs from the POF's ({pof.block_size})")
    if bs % opts.block_size:
        raise ValueError(f"block_size ({bs}) must be a multiple of the render's block_size option ({opts.block_size})")
    shape = _grid_shape(volume.dims, bs)
    tiles = tile_grid(n_ranks, *size)
    tile = tiles[rank]
    cam = camera.kernel_array(size)
    owner = assign(shape, n_ranks, curve)

    # -- visibility: this rank's tile, then the union over ranks
    t = time.perf_counter()
    if pof is not None:
        from ..culling.cull import Culling

        k = Culling(pof, threshold=threshold).weights_for(plan.tf, opts, float(np.min(volume.spacing)))
        mine = visible_blocks(pof, volume, camera, size, k, threshold=threshold, window=tile).visible
    else:
        bases = plan.tf.bases if isinstance(plan.tf, TransferFunctionFamily) else [plan.tf]
        family = TransferFunctionFamily(bases, None if not isinstance(plan.tf, TransferFunctionFamily) else plan.tf.k)
        sigma = family.basis_tables(1.0, 1.0) * family.k[:, None]
        mine = _nonempty(np.asarray(volume.values, dtype=np.float64), shape, bs, sigma, family).any(axis=-1)
    visible = np.logical_or.reduce(comm.allgather(mine.reshape(-1)))
    t_cull = time.perf_counter() - t

    # -- render this rank's visible blocks, each over its own rectangle
    t = time.perf_counter()
    order = visibility_order(shape, cam[9:12], volume.spacing)
    position = np.empty(order.size, dtype=np.int64)
    position[order] = np.arange(order.size)
    outgoing = [[] for _ in range(n_ranks)]
    rendered = 0
    samples = 0
    mine = np.nonzero(visible & (owner.reshape(-1) == rank))[0]
    for b, rect, part in block_partials(plan, volume, camera, size, bs, mine):
        rendered += 1
        samples += part.metadata["samples"]
        if not part.rgba[..., 3].any():
            continue
        for r, other in enumerate(tiles):
            if _overlaps(rect, other):
                outgoing[r].append((int(position[b]), rect, part.rgba))
    t_render = time.perf_counter() - t

    # -- direct send, composite this tile, gather
    t = time.perf_counter()
    received = comm.alltoall(outgoing)
    pieces = [p for batch in received for p in batch]
    dtype = np.float64 if opts.precision == "float64" else np.float32
    mine_rgba = composite(tile, pieces, dtype)
    t_composite = time.perf_counter() - t
    stats = {"rank": rank, "tile": list(tile), "owned": int((owner == rank).sum()), "rendered": rendered,
             "pieces_sent": sum(len(x) for x in outgoing), "pieces_received": len(pieces), "samples": samples,
             "cull_seconds": t_cull, "render_seconds": t_render, "composite_seconds": t_composite}
    gathered = comm.gather((mine_rgba, stats), root=0 if root is None else root)
    image = None
    if gathered is not None and (root is None or rank == root):
        rgba = np.zeros((size[1], size[0], 4), dtype=dtype)
        for (col, row, w, h), (part, _) in zip(tiles, gathered):
            rgba[row:row + h, col:col + w] = part
        meta = {"renderer": "pv_hdrvol parallel grid ray caster", "precision": opts.precision,
                "transfer_function": repr(plan.tf), "camera": repr(camera),
                "parallel": {"ranks": n_ranks, "curve": curve, "block_size": bs, "blocks": int(np.prod(shape)),
                             "visible": int(visible.sum()), "culled_by_pof": pof is not None,
                             "threshold": threshold, "per_rank": [s for _, s in gathered],
                             "seconds": time.perf_counter() - t_start}}
        image = HDRImage(rgba, np.full((size[1], size[0]), np.inf), metadata=meta)
    if root is None:
        image = comm.bcast(image, root=0)
    return image


def _overlaps(a, b):
    return a[0] < b[0] + b[2] and b[0] < a[0] + a[2] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]
