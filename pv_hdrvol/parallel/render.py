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
from ..culling.pof import PlenopticOpacity, nonempty_blocks
from ..data.transfer import TF_KEYWORDS, TransferFunctionFamily
from ..image.hdr import HDRImage
from ..rays.camera import Camera, as_size
from ..rays.clip import has_clip
from ..raycast.grid import BlockGrid, GridPlan, block_grid_shape, as_volume, default_transfer_function
from ..settings import settings_metadata
from .comm import WORLD, as_communicator, use_rank_threads
from .composite import composite, tile_grid
from .distribute import assign

def block_rect(lo, hi, camera, size):
    """``(col, row, w, h)`` of the pixels whose centre rays can cross the box ``[lo, hi]``
    (world), clipped to the image; ``None`` when it is off screen. A perspective camera
    whose eye plane the box reaches (the eye inside or beside it) gets the whole image."""
    return block_rects(np.asarray(lo, dtype=np.float64)[None], np.asarray(hi, dtype=np.float64)[None], camera,
                       size)[0]


def block_rects(lo, hi, camera, size):
    """:func:`block_rect` of each box ``[lo[i], hi[i]]`` (``(n, 3)`` world corners), in
    one pass over all their corners."""
    w, h = size
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    pick = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=bool)  # (8, 3)
    corners = np.where(pick[None], hi[:, None], lo[:, None])  # (n, 8, 3)
    whole = np.zeros(len(lo), dtype=bool)
    behind = np.zeros(len(lo), dtype=bool)
    if not camera.parallel_projection:
        depth = (corners - np.asarray(camera.position)) @ camera.basis()[2]
        near = 1e-9 * np.maximum(camera.distance, np.abs(corners).max(axis=(1, 2)))
        behind = depth.max(axis=1) <= 0  # wholly behind the eye
        whole = (depth.min(axis=1) <= near) & ~behind  # the projection of points behind the eye is meaningless
    cr = camera.project(corners.reshape(-1, 3), size).reshape(len(lo), 8, 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        c0 = np.maximum(0, np.floor(cr[..., 0].min(axis=1) - 0.5))
        c1 = np.minimum(w - 1, np.ceil(cr[..., 0].max(axis=1) - 0.5))
        r0 = np.maximum(0, np.floor(cr[..., 1].min(axis=1) - 0.5))
        r1 = np.minimum(h - 1, np.ceil(cr[..., 1].max(axis=1) - 0.5))
    out = []
    for i in range(len(lo)):
        if whole[i]:
            out.append((0, 0, w, h))
        elif behind[i] or not (c1[i] >= c0[i] and r1[i] >= r0[i]):
            out.append(None)
        else:
            out.append((int(c0[i]), int(r0[i]), int(c1[i] - c0[i]) + 1, int(r1[i] - r0[i]) + 1))
    return out


def eye_visibility_order(shape, eye, origin, extent):
    """Block indices (flat, z-y-x order of ``shape``) front to back as seen from the
    point ``eye`` (x, y, z; a perspective camera's position), for blocks of ``extent``
    world units per axis starting at ``origin`` (the last block of an axis may be
    shorter).

    Along a ray leaving ``eye`` each coordinate moves away from the eye's, so the number
    of blocks between a block and the eye's block (``|k_i - e_i|``, the eye's index
    ``e_i`` taken from the block boundaries, clipped to ``-1 .. n_i``) never decreases
    along the ray on any axis, and grows on the axis it steps along: every positive
    weighting of those counts orders a block before those behind it on any ray. The
    weights are the blocks' extents (an L1 distance in world units); ties go to the
    plain sum, and remaining ties are blocks no ray crosses both of.
    """
    eye, origin, extent = (np.asarray(v, dtype=np.float64) for v in (eye, origin, extent))
    bz, by, bx = shape
    kz, ky, kx = np.meshgrid(np.arange(bz), np.arange(by), np.arange(bx), indexing="ij")
    key = np.zeros(shape, dtype=np.int64)
    depth = np.zeros(shape)
    for axis, (idx, n) in enumerate(((kx, bx), (ky, by), (kz, bz))):
        e = int(np.clip(np.floor((eye[axis] - origin[axis]) / extent[axis]), -1, n))
        counted = np.abs(idx - e)
        key += counted
        depth += extent[axis] * counted
    return np.lexsort((key.reshape(-1), depth.reshape(-1)))


def block_partials(plan, volume, camera, size, block_size, blocks):
    """``(block, rect, image)`` for each flat block index of ``blocks`` on screen: the
    block rendered alone (``plan.execute`` with a one-block mask) over its screen
    rectangle ``rect = (col, row, w, h)``; ``image.metadata["samples"]`` counts its samples."""
    opts = plan.options
    shape = block_grid_shape(volume.dims, block_size)
    render_shape = BlockGrid.of(plan.source, opts.block_size).shape
    blocks = np.asarray(blocks, dtype=np.int64).reshape(-1)
    lo, hi = block_boxes(volume, block_size, blocks)
    for b, rect in zip(blocks, block_rects(lo, hi, camera, size)):
        if rect is None:
            continue
        mask = single_block_mask(b, shape, block_size, opts.block_size, render_shape)
        yield int(b), rect, plan.execute(camera, size, block_mask=mask, window=rect, progress_bar=False)


def render_parallel(volume, tf, camera, size=(512, 512), *, pof=None, bound=None, comm=WORLD, curve="hilbert",
                    block_size=None, threshold=DEFAULT_THRESHOLD, root=0, threads=None, **options):
    """Render ``volume`` with the blocks spread over the ranks of ``comm``.

    Parameters
    ----------
    volume, tf, camera, size, **options
        As :func:`pv_hdrvol.render`: ``tf`` ``None`` for the default transfer function
        (a family of ``pof``'s bases when ``pof`` is given); ``camera`` a
        :class:`Camera`, perspective or orthographic (orthographic with ``pof``).
    pof : PlenopticOpacity, optional
        Cull hidden blocks (per tile, then shared). Without it every non-empty block is
        rendered. POF culling assumes parallel rays: an orthographic camera only.
    bound : OcclusionBound, optional
        Cull with the view-independent occlusion bound instead (any camera, any
        transfer function; its own ``threshold``): each rank marches its tile's rays,
        and a block is culled when some tile's rays sample it and none before the
        bound reaches the threshold (one ``allgather`` of two byte vectors).
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
    threads : int, optional
        numba threads of this process for the render (restored on return). Default:
        the node's cores shared by the processes of ``comm`` on it,
        ``max(1, cores // node_processes)`` (:func:`~pv_hdrvol.parallel.comm.rank_threads`),
        or numba's count as it is when ``NUMBA_NUM_THREADS`` is set. Pixels do not
        depend on it. With numba's OpenMP layer and more than one thread, set
        ``OMP_WAIT_POLICY=PASSIVE`` before numba starts its threads (the command line
        does): threads that spin after each of the many small block renders take the
        cores the Python work needs (4× the time on the engine at 512², 2 cores).

    Returns
    -------
    HDRImage or None
        On ``root`` (every rank for ``root=None``): RGBA composited front to back,
        ``depth`` all ``inf`` (not composited yet), and ``metadata["parallel"]`` with
        per-rank counts, threads and times (cull, render, composite), and
        ``metadata["settings"]`` (:meth:`HDRImage.settings`: ``settings.render(volume)``
        gives this image to rounding; with ``pof`` the culling is not stored, as for
        :func:`pv_hdrvol.render` with ``cull=``). ``None`` elsewhere.

    Notes
    -----
    Blocks are composited in visibility order: for an orthographic camera by their
    depth along the view (:func:`~pv_hdrvol.culling.cull.visibility_order`), for a
    perspective one by their distance from the eye in blocks
    (:func:`eye_visibility_order`); either orders every block before those behind it
    on every ray, so the image is the single pass's to rounding (early termination is
    per block: ``termination`` of the light may pass where the single pass stops).
    """
    comm = as_communicator(comm)
    threads, reason, previous = use_rank_threads(comm, threads)
    try:
        return _render(volume, tf, camera, size, pof, bound, comm, curve, block_size, threshold, root, reason,
                       options)
    finally:
        import numba

        numba.set_num_threads(previous)


def _render(volume, tf, camera, size, pof, bound, comm, curve, block_size, threshold, root, threads_reason, options):
    import numba

    rank, n_ranks = comm.rank, comm.size
    t_start = time.perf_counter()
    volume = as_volume(volume)
    if not isinstance(camera, Camera):
        raise TypeError(f"render_parallel needs a Camera; got {type(camera).__name__}")
    if pof is not None and not camera.parallel_projection:
        raise ValueError("render_parallel with pof= needs an orthographic Camera (parallel_projection=True): POF "
                         "culling assumes parallel rays; without pof= any camera renders")
    size = as_size(size)
    default = tf is None
    if default and n_ranks > 1 and not any(options.get(k) is not None for k in TF_KEYWORDS):
        tf = _default_on_root(comm, volume)
    plan = GridPlan(volume, tf, **options)
    plan.default_tf = default
    opts = plan.options
    if opts.blending != "composite":
        raise ValueError(f"render_parallel composites blocks front to back: blending='composite' only; got "
                         f"{opts.blending!r}")
    _check_culling(volume, opts, pof, bound)
    bs = as_int("block_size", block_size if block_size is not None else (pof.block_size if pof else 16), low=2)
    if pof is not None and bs != pof.block_size:
        raise ValueError(f"block_size {bs} differs from the POF's ({pof.block_size})")
    if bs % opts.block_size:
        raise ValueError(f"block_size ({bs}) must be a multiple of the render's block_size option ({opts.block_size})")
    shape = block_grid_shape(volume.dims, bs)
    tiles = tile_grid(n_ranks, *size)
    tile = tiles[rank]
    owner = assign(shape, n_ranks, curve)

    # -- visibility: this rank's tile, then the union over ranks
    t = time.perf_counter()
    visible = _visible_blocks(plan, volume, camera, size, pof, bound, comm, shape, bs, tile, threshold)
    t_cull = time.perf_counter() - t

    # -- render this rank's visible blocks, each over its own rectangle
    t = time.perf_counter()
    if camera.parallel_projection:
        order = visibility_order(shape, camera.basis()[2], volume.spacing)
    else:
        order = eye_visibility_order(shape, camera.position, volume.origin, bs * np.asarray(volume.spacing))
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
             "threads": numba.get_num_threads(), "threads_reason": threads_reason, "cull_seconds": t_cull,
             "render_seconds": t_render, "composite_seconds": t_composite}
    gathered = comm.gather((mine_rgba, stats), root=0 if root is None else root)
    image = None
    if gathered is not None and (root is None or rank == root):
        rgba = np.zeros((size[1], size[0], 4), dtype=dtype)
        for (col, row, w, h), (part, _) in zip(tiles, gathered):
            rgba[row:row + h, col:col + w] = part
        per_rank = [s for _, s in gathered]
        meta = _parallel_metadata(plan, volume, camera, size, pof, bound, curve, bs, shape, visible, threshold,
                                  per_rank, t_start)
        image = HDRImage(rgba, np.full((size[1], size[0]), np.inf), metadata=meta)
    if root is None:
        image = comm.bcast(image, root=0)
    return image


def _check_culling(volume, opts, pof, bound):
    """Refuse culling that cannot apply: ``pof=`` and ``bound=`` together, either of the
    wrong type or with clip planes or a crop box (which may cut the occluders away), a
    POF of another volume."""
    if bound is not None:
        from ..culling.bound import OcclusionBound

        if pof is not None:
            raise ValueError("render_parallel takes pof= or bound=, not both")
        if not isinstance(bound, OcclusionBound):
            raise TypeError(f"bound must be an OcclusionBound; got {type(bound).__name__}")
        if has_clip(opts):
            raise ValueError("bound= culls blocks hidden behind the whole volume, which clip_planes= and crop_box= "
                             "may cut away (the hidden blocks would show): render a clipped volume without bound=")
    if pof is not None:
        if not isinstance(pof, PlenopticOpacity):
            raise TypeError(f"pof must be a PlenopticOpacity; got {type(pof).__name__}")
        pof.check_volume(volume)
        if has_clip(opts):
            raise ValueError("pof= culls blocks hidden behind the whole volume, which clip_planes= and crop_box= may "
                             "cut away (the hidden blocks would show): render a clipped volume without pof=")


def _visible_blocks(plan, volume, camera, size, pof, bound, comm, shape, bs, tile, threshold):
    """The blocks (flat, ``shape`` of ``bs`` points a side) any rank's tile may show:
    this rank's tile's non-empty blocks (or those its POF leaves visible), less those the
    occlusion bound hides, united over the ranks."""
    opts = plan.options
    if pof is not None:
        from ..culling.cull import Culling

        k = Culling(pof, threshold=threshold).weights_for(plan.tf, opts, float(np.min(volume.spacing)))
        mine = visible_blocks(pof, volume, camera, size, k, threshold=threshold, window=tile).visible
    else:
        bases = plan.tf.bases if isinstance(plan.tf, TransferFunctionFamily) else [plan.tf]
        family = TransferFunctionFamily(bases, None if not isinstance(plan.tf, TransferFunctionFamily) else plan.tf.k)
        sigma = family.basis_tables(1.0, 1.0) * family.k[:, None]
        mine = nonempty_blocks(np.asarray(volume.values, dtype=np.float64), shape, bs, sigma, family).any(axis=-1)
    if bound is not None:  # union over tiles of what rays sample, and of what they need
        needed, met, _ = bound.blocks(volume, plan.tf, camera, size, opts, bs, window=tile)
        votes = comm.allgather(np.stack([mine.reshape(-1), needed.reshape(-1), met.reshape(-1)]))
        mine_any, needed_any, met_any = np.logical_or.reduce(votes)
        visible = mine_any & ~(met_any & ~needed_any)
    else:
        visible = np.logical_or.reduce(comm.allgather(mine.reshape(-1)))
    return visible


def _parallel_metadata(plan, volume, camera, size, pof, bound, curve, bs, shape, visible, threshold, per_rank,
                       t_start):
    """The parallel render's metadata on the root: a single pass's keys and the ranks'."""
    opts = plan.options
    # the keys of a single pass's metadata (GridPlan.execute), so that tools reading
    # one read the other
    meta = {"renderer": "pv_hdrvol parallel grid ray caster", "scalars": volume.name,
            "precision": opts.precision, "step_voxels": opts.step, "step_world": plan.step_world,
            "global_alpha": opts.global_alpha, "opacity_unit_distance": plan.unit,
            "termination": opts.termination, "depth_threshold": opts.depth_threshold,
            "transfer_function": repr(plan.tf), "camera": repr(camera),
            "settings": settings_metadata(plan.tf, camera, size, opts, cull=pof if bound is None else bound),
            "samples": int(sum(s["samples"] for s in per_rank)),
            "parallel": {"ranks": len(per_rank), "curve": curve, "block_size": bs, "blocks": int(np.prod(shape)),
                         "visible": int(visible.sum()), "culled_by_pof": pof is not None,
                         "culled_by_bound": bound is not None,
                         "threshold": threshold, "per_rank": per_rank,
                         "seconds": time.perf_counter() - t_start}}
    return meta


def _default_on_root(comm, volume):
    """The default transfer function, chosen on rank 0 (it reads every value: 0.5 s of
    a 2.7 s engine render) and sent to the others; a failure there raises everywhere."""
    chosen = None
    if comm.rank == 0:
        try:
            chosen = default_transfer_function(volume)
        except Exception as e:  # sent on, so that no rank waits for a function that will not come
            chosen = e
    chosen = comm.bcast(chosen, root=0)
    if isinstance(chosen, Exception):
        raise chosen
    return chosen


def _overlaps(a, b):
    return a[0] < b[0] + b[2] and b[0] < a[0] + a[2] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]
