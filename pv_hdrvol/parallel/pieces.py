"""Render an image volume where its pieces live: each process renders the piece it
holds, and the partial images are composited sort-last in depth order.

This is data-parallel rendering as ParaView distributes data (``pvbatch --mpi``: a
reader gives each rank one extent of the image): no process holds the whole volume.

1. **Pieces.** The whole volume's points are cut into boxes that share their faces
   (:func:`split_boxes`, VTK's piece extents without ghosts). A process holds its box
   plus the ghost points its render reads: none for trilinear samples, one layer for
   shading and gradient opacity (:class:`~pv_hdrvol.raycast.grid.VolumePiece`).
2. **Rendering.** Every piece samples the whole volume's ray lattice (the one a serial
   render uses: it starts where the ray enters the whole box) and composites, from
   transparent, the samples whose midpoints lie in its owned box
   (``GridPlan.execute(piece=...)``). Every sample has exactly one owner.
3. **Compositing.** The owned boxes are disjoint and convex, so along each ray they are
   met one after another: the partial images are composited front to back in the
   order of each pixel's entry into the boxes (:func:`composite_pieces`), a pure
   function of the images and the boxes.

The result equals the serial render to rounding (composited per piece instead of per
sample; early termination is per piece, so it stops at ``1 - termination`` of each
piece); the tests ask 1e-5. One piece is the serial render bit for bit.

:func:`render_pieces` takes the piece a process holds; :func:`render_in_pieces` cuts a
volume every process holds whole (``python -m pv_hdrvol.parallel render VOLUME``), one
box per process. The depth image is the first crossing of the depth
threshold within the piece where the composite crosses it: exact where that piece alone
crosses it, otherwise the piece's own crossing or, failing that, where the ray enters it.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .._validate import as_int, as_size
from ..data.grid import volume_from_array, volume_from_rectilinear
from ..params import RenderOptions
from ..rays.camera import Rays, ray_box_spans
from ..raycast.compositing import composite_in_order
from ..raycast.grid import GridPlan, VolumePiece, as_volume
from .comm import WORLD, as_communicator


def split_boxes(dims, n):
    """``n`` boxes of points ``(lo, hi)`` (x, y, z, inclusive) that tile the points
    ``0 .. dims - 1`` of a volume, sharing faces: the longest axis (in cells) is halved
    again and again, ``n`` split as evenly as it goes (as VTK's extent translator in
    block mode). Needs at least ``n`` cells along the split axes."""
    dims = tuple(as_int("dims", d, low=2) for d in dims)
    n = as_int("n", n, low=1)
    cells = int(np.prod([d - 1 for d in dims]))
    if n > cells:
        raise ValueError(f"cannot cut {n} pieces of at least one cell from a volume of {cells} cells")

    def cut(lo, hi, k):
        if k == 1:
            return [(tuple(lo), tuple(hi))]
        axis = max(range(3), key=lambda a: (hi[a] - lo[a], a))  # ties: the later axis, as VTK
        k1 = k // 2
        mid = lo[axis] + (hi[axis] - lo[axis]) * k1 // k
        if mid == lo[axis]:
            mid += 1
        left_hi, right_lo = list(hi), list(lo)
        left_hi[axis] = right_lo[axis] = mid
        return cut(lo, left_hi, k1) + cut(right_lo, hi, k - k1)

    boxes = cut([0, 0, 0], [d - 1 for d in dims], n)
    if any(h <= l for lo, hi in boxes for l, h in zip(lo, hi)):
        raise ValueError(f"cannot cut {n} pieces of at least one cell per axis from a volume of {dims} points")
    return boxes


def split_bounds(bounds, n, samples=None, weights=None):
    """``n`` world boxes ``(lo, hi)`` that tile ``bounds = (xmin, xmax, ..., zmax)``,
    sharing faces: the longest side is cut again and again (a k-d split), each cut at the
    quantile of ``samples`` (points, ``(m, 3)``: cell centres, so that the boxes hold
    about equal work; each standing for ``weights`` cells, default 1) that splits the
    pieces ``k // 2 : k - k // 2``, or in proportion without samples. The same arguments
    give the same boxes on every process."""
    b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
    n = as_int("n", n, low=1)
    if not np.isfinite(b).all() or (b[:, 1] < b[:, 0]).any():
        raise ValueError(f"bounds must be finite (xmin, xmax, ymin, ymax, zmin, zmax); got {tuple(b.reshape(-1))}")
    pts = np.empty((0, 3)) if samples is None else np.asarray(samples, dtype=np.float64).reshape(-1, 3)
    w = np.ones(len(pts)) if weights is None else np.broadcast_to(np.asarray(weights, dtype=np.float64), len(pts))

    def cut(lo, hi, k, inside, w):
        if k == 1:
            return [(lo, hi)]
        axis = max(range(3), key=lambda a: (hi[a] - lo[a], a))
        k1 = k // 2
        mid = lo[axis] + (hi[axis] - lo[axis]) * k1 / k
        if len(inside) >= k:  # the weighted quantile k1 / k, between two distinct sample values
            order = np.argsort(inside[:, axis], kind="stable")
            values = inside[order, axis]
            cumulative = np.cumsum(w[order])
            i = min(int(np.searchsorted(cumulative, cumulative[-1] * k1 / k)), len(values) - 1)
            j = int(np.searchsorted(values, values[i], side="right"))
            mid = float(0.5 * (values[i] + values[j])) if j < len(values) else float(values[i])
        mid = min(max(mid, lo[axis]), hi[axis])
        left_hi, right_lo = hi.copy(), lo.copy()
        left_hi[axis] = right_lo[axis] = mid
        below = inside[:, axis] < mid
        return cut(lo, left_hi, k1, inside[below], w[below]) + cut(right_lo, hi, k - k1, inside[~below], w[~below])

    return cut(b[:, 0].copy(), b[:, 1].copy(), n, pts, w)


def split_volume(volume, n, ghosts=1):
    """``n`` pieces of an image volume as a distributed run holds them: a list of
    ``(GridVolume, VolumePiece)``, each the points of one :func:`split_boxes` box plus
    ``ghosts`` layers around it (where the volume goes on). For tests and for
    simulations that hand their own piece to :func:`render_pieces`. A rectilinear volume
    (``axes``) gives rectilinear pieces: each with its own coordinates (kept even where
    they are evenly spaced within the piece) and :meth:`VolumePiece.from_rectilinear`
    (its plan takes :meth:`VolumePiece.options_for`)."""
    volume = as_volume(volume)
    return [volume_piece(volume, n, index, ghosts) for index in range(n)]


def volume_piece(volume, n, index, ghosts=1):
    """Piece ``index`` of :func:`split_volume`'s ``n``, made alone: a process that holds
    the whole volume copies only its own box."""
    volume = as_volume(volume)
    ghosts = as_int("ghosts", ghosts, low=0)
    dims = np.array(volume.dims)
    lo, hi = split_boxes(volume.dims, n)[index]
    a = np.maximum(np.array(lo) - ghosts, 0)
    b = np.minimum(np.array(hi) + ghosts, dims - 1)
    values = volume.values[a[2]:b[2] + 1, a[1]:b[1] + 1, a[0]:b[0] + 1]
    if volume.axes is None:
        part = volume_from_array(values, volume.spacing, volume.origin + a * volume.spacing, name=volume.name)
        return part, VolumePiece(tuple(volume.origin.tolist()), tuple(volume.dims), tuple(a.tolist()), tuple(lo),
                                 tuple(hi))
    # a rectilinear grid: before, its pieces were made uniform at the nominal spacing
    local = tuple(c[i:j + 1] for c, i, j in zip(volume.axes, a, b))
    part = volume_from_rectilinear(values, *local, name=volume.name)
    if part.axes is None:  # even within the piece, uneven in the whole
        part = dataclasses.replace(part, axes=local, cache={})
    return part, VolumePiece.from_rectilinear(volume.axes, a, lo, hi)


def check_tiling(pieces):
    """Raise ``ValueError`` unless the owned boxes of ``pieces`` (VolumePieces of one
    volume) tile its whole box: same whole volume, no overlap, nothing missing."""
    if not pieces:
        raise ValueError("no pieces")
    first = pieces[0]
    for p in pieces[1:]:
        if tuple(p.whole_dims) != tuple(first.whole_dims) or \
                not np.array_equal(np.asarray(p.whole_origin, float), np.asarray(first.whole_origin, float)):
            raise ValueError(f"the pieces are of different volumes: {first.whole_dims} points at "
                             f"{tuple(first.whole_origin)} and {p.whole_dims} at {tuple(p.whole_origin)}")
    lo = np.array([p.owned_lo for p in pieces], dtype=np.int64)
    hi = np.array([p.owned_hi for p in pieces], dtype=np.int64)
    whole = np.prod(np.array(first.whole_dims, dtype=np.int64) - 1)
    if np.prod(hi - lo, axis=1).sum() != whole or (lo < 0).any() or (hi > np.array(first.whole_dims) - 1).any():
        raise ValueError(f"the owned boxes of the {len(pieces)} pieces do not tile the whole volume of "
                         f"{first.whole_dims} points: {[(tuple(a), tuple(b)) for a, b in zip(lo.tolist(), hi.tolist())]}")
    for i in range(len(pieces)):
        inner = (np.minimum(hi[i], hi[i + 1:]) > np.maximum(lo[i], lo[i + 1:])).all(axis=1)
        if inner.any():
            j = i + 1 + int(np.argmax(inner))
            raise ValueError(f"the owned boxes of pieces {i} and {j} overlap: {tuple(lo[i].tolist())}.."
                             f"{tuple(hi[i].tolist())} and {tuple(lo[j].tolist())}..{tuple(hi[j].tolist())}")


def box_entries(rays, boxes):
    """(n_boxes, n_rays) distance along each ray where it enters each world box
    ``(lo, hi)``; ``inf`` where it misses (or only touches) it (``ray_box_spans``)."""
    return np.stack([ray_box_spans(rays, lo, hi)[0] for lo, hi in boxes])


def composite_pieces(images, boxes, rays, dtype=None):
    """The whole render from the pieces' partial images.

    ``images``: HDRImages of one size (each piece's ``GridPlan.execute(piece=...)``);
    ``boxes``: each piece's owned box in world coordinates (``VolumePiece.world_box``);
    ``rays``: the render's :class:`~pv_hdrvol.Rays` (``camera.rays(size)``). Per pixel,
    front to back in the order the ray enters the boxes: ``C += (1 - A) c``,
    ``A += (1 - A) a`` in float64, then ``dtype`` (default: the images'). Returns an
    HDRImage with the first image's metadata.
    """
    if len(images) != len(boxes) or not images:
        raise ValueError(f"composite_pieces needs one box per image; got {len(images)} images and {len(boxes)} boxes")
    h, w = images[0].rgba.shape[:2]
    if any(im.rgba.shape[:2] != (h, w) for im in images) or rays.width * rays.height != w * h:
        raise ValueError("the partial images and the rays must all have one size")
    image = composite_in_order(images, box_entries(rays, boxes), dtype)
    image.metadata.pop("piece", None)
    image.metadata["pieces"] = len(images)
    return image


def render_pieces(volume, piece, tf, camera, size=(512, 512), *, comm=WORLD, root=0, **options):
    """Render a volume spread over the processes of ``comm``: each renders its own
    piece, ``root`` composites (SPMD: every process calls it with its own piece).

    Parameters
    ----------
    volume : GridVolume or 3-D array
        This process's piece (its owned box and ghosts, as ``piece`` says).
    piece : VolumePiece
        Where ``volume`` lies in the whole volume and the box it owns; the owned boxes
        of all processes must tile the whole volume (checked on every process).
    tf : TransferFunction
        Required: the default transfer function reads every value of the whole volume.
    camera : Camera, Rays or view name
        A view name frames the whole volume.
    size, **options
        As :func:`pv_hdrvol.render` (composite blending; no labels or culling).
    comm : mpi4py communicator, ``"world"`` (default) or None (serial: one piece)
    root : int or None
        The process that gets the image; ``None``: every process does.

    Returns
    -------
    HDRImage or None
        The whole render on ``root`` (to rounding the serial render of the whole
        volume, see the module's notes); ``None`` elsewhere.
    """
    comm = as_communicator(comm)
    image, volume, rays, error = _render_own_piece(volume, piece, tf, camera, size, None, options)
    return gather_pieces(image, piece, None if error else volume.spacing, rays, comm=comm, root=root, error=error)


def _render_own_piece(volume, piece, tf, camera, size, options, option_kwargs):
    """``(image, volume, rays, error)``: this process's part of :func:`render_pieces`
    (``options``: RenderOptions or None, changed by ``option_kwargs``), or the exception
    it met (``error``) for the gather to tell the others."""
    from ..data.transfer import TransferFunction
    from ..rays.camera import as_camera

    image = rays = error = None
    try:
        if not isinstance(tf, TransferFunction):
            raise TypeError(f"render_pieces needs tf, a TransferFunction (the default transfer function reads every "
                            f"value of the whole volume, which no process holds); got {type(tf).__name__}")
        if not isinstance(piece, VolumePiece):
            raise TypeError(f"piece must be a VolumePiece; got {type(piece).__name__}")
        volume = as_volume(volume)
        camera = as_camera(camera, piece.bounds(volume.spacing))
        rays = camera if isinstance(camera, Rays) else camera.rays(as_size(size))
        plan_options = RenderOptions.from_kwargs(options, **option_kwargs)
        if piece.whole_axes is not None and volume.axes is not None:
            # a rectilinear piece steps by the whole grid's narrowest cell, not its own
            plan_options = piece.options_for(plan_options, volume)
        image = GridPlan(volume, tf, plan_options).execute(camera, size, piece=piece, progress_bar=False)
    except Exception as e:  # every process learns of it in gather_pieces; none waits forever
        error = e
    return image, volume, rays, error


def render_in_pieces(volume, tf=None, camera=None, size=(512, 512), *, comm=WORLD, root=0, threads=None, **options):
    """Render an image volume that every process holds whole, each process one box of it
    as one piece, composited on ``root`` (SPMD: every process calls it alike).

    The path of ``python -m pv_hdrvol.parallel render VOLUME`` without ``--pof``: process
    ``r`` renders ``volume_piece(volume, comm.size, r)`` (its owned box and one ghost
    layer) with :func:`render_pieces`' steps, and :func:`gather_pieces` composites the
    pieces on ``root``. One piece per process, one render each: on one process it
    costs what a serial render costs (:func:`~pv_hdrvol.parallel.render.render_parallel`
    renders block by block instead, which its culling needs).

    Parameters
    ----------
    volume : GridVolume or 3-D array
        The whole volume, the same on every process.
    tf : TransferFunction, optional
        Default: the whole volume's default transfer function shaped by ``cmap``,
        ``clim``, ``opacity`` and ``scale`` in ``options``
        (:func:`~pv_hdrvol.raycast.grid.resolve_render_options`), chosen on rank 0 (it
        reads every value) and sent to the others.
    camera : Camera, Rays or view name
        A view name (default ``"iso"``) frames the whole volume
        (:func:`~pv_hdrvol.rays.camera.fit_camera`).
    size, **options
        As :func:`pv_hdrvol.render`: :class:`~pv_hdrvol.RenderOptions` fields and
        PyVista's words (composite blending; no labels or culling).
    comm : mpi4py communicator, ``"world"`` (default) or None (serial: one piece)
    root : int or None
        The process that gets the image; ``None``: every process does.
    threads : int, optional
        numba threads of this process, as :func:`~pv_hdrvol.parallel.render.render_parallel`'s
        (default: the node's cores shared by its processes; restored on return).

    Returns
    -------
    HDRImage or None
        On ``root``: the pieces composited per pixel in depth order
        (:func:`composite_pieces`): on one process the serial render, on more the
        serial render to rounding (see the module's notes), with its render settings,
        and ``metadata["parallel"]``: ``ranks``, ``pieces``, ``seconds`` and
        ``per_rank`` (``rank``, ``piece``: the owned box in points ``[lo, hi]``,
        ``threads``, ``threads_reason``, ``samples``, ``render_seconds``,
        ``composite_seconds``: gathering and compositing, on ``root``). ``None``
        elsewhere.
    """
    import time

    import numba

    from ..raycast.grid import resolve_render_options
    from ..rays.camera import fit_camera
    from .comm import use_rank_threads

    t_start = time.perf_counter()
    comm = as_communicator(comm)
    chosen = None
    if comm.rank == 0:  # one choice for all: the default transfer function reads every value
        try:
            volume = as_volume(volume)
            chosen = resolve_render_options(volume, tf, **options)
        except (ValueError, TypeError) as e:  # sent on, so that no process waits for what will not come
            chosen = e
    chosen = comm.bcast(chosen, root=0)
    if isinstance(chosen, Exception):
        raise chosen
    tf, opts = chosen
    volume = as_volume(volume)
    camera = fit_camera(volume, camera)
    threads, reason, previous = use_rank_threads(comm, threads)
    try:
        part, piece = volume_piece(volume, comm.size, comm.rank)
        t = time.perf_counter()
        image, part, rays, error = _render_own_piece(part, piece, tf, camera, size, opts, {})
        t_render = time.perf_counter() - t
        t = time.perf_counter()
        out = gather_pieces(image, piece, None if error else part.spacing, rays, comm=comm, root=root, error=error)
        t_composite = time.perf_counter() - t
        stats = {"rank": comm.rank, "piece": [list(piece.owned_lo), list(piece.owned_hi)],
                 "threads": numba.get_num_threads(), "threads_reason": reason,
                 "samples": int(image.metadata["samples"]), "render_seconds": t_render,
                 "composite_seconds": t_composite}
    finally:
        numba.set_num_threads(previous)
    per_rank = comm.gather(stats, root=0 if root is None else root)
    if root is None:
        per_rank = comm.bcast(per_rank, root=0)
    if out is not None:
        out.metadata["parallel"] = {"ranks": comm.size, "pieces": comm.size, "per_rank": per_rank,
                                    "seconds": time.perf_counter() - t_start}
    return out


def gather_pieces(image, piece, spacing, rays, *, comm=WORLD, root=0, error=None):
    """Composite every process's partial image on ``root`` (SPMD; the second half of
    :func:`render_pieces`, for callers that render their piece themselves).

    ``image``: this process's ``GridPlan.execute(piece=piece)``; ``spacing``: the
    volume's; ``rays``: the render's. ``error``: the exception this process met instead
    of rendering. Every process first learns whether any failed, and then all raise
    (the failing ones their own error, the others a ``RuntimeError`` naming it), so that
    none waits forever for an image that will not come; so do all when the owned boxes
    do not tile the volume. Returns the composited HDRImage on ``root`` (every process
    for ``root=None``), else ``None``.
    """
    box = None if error is not None else piece.world_box(spacing)
    return gather_boxes(image, box, rays, comm=comm, root=root, error=error, check=check_tiling, piece=piece)


def allgather_or_raise(comm, value, error=None):
    """Every process's ``value`` (``comm.allgather``), unless a process met an
    exception (``error``) instead: then every process raises, the failing ones their
    own error, the others a ``RuntimeError`` naming the first that failed, so that none
    goes on to a collective step and waits forever for the others."""
    report = None if error is None else f"{type(error).__name__}: {error}"
    status = comm.allgather((report, value))
    failed = [(rank, text) for rank, (text, _) in enumerate(status) if text is not None]
    if failed:
        if error is not None:
            raise error
        raise RuntimeError(f"process {failed[0][0]} could not render its piece: {failed[0][1]}")
    return [v for _, v in status]


def gather_boxes(image, box, rays, *, comm=WORLD, root=0, error=None, check=None, piece=None):
    """:func:`gather_pieces` for any pieces that own disjoint world boxes (``box =
    (lo, hi)``; a tetrahedral mesh's :class:`~pv_hdrvol.raycast.tets.MeshPiece`);
    ``check``, when given, is called on every process with the list of all ``piece``
    values and raises if they do not fit together."""
    comm = as_communicator(comm)
    pieces = allgather_or_raise(comm, piece, error)
    if check is not None:
        check(pieces)
    gathered = comm.gather((image, box), root=0 if root is None else root)
    out = None
    if gathered is not None and (root is None or comm.rank == root):
        out = composite_pieces([g[0] for g in gathered], [g[1] for g in gathered], rays)
    if root is None:
        out = comm.bcast(out, root=0)
    return out


__all__ = ["allgather_or_raise", "box_entries", "check_tiling", "composite_pieces", "gather_boxes", "gather_pieces",
           "render_in_pieces", "render_pieces", "split_boxes", "split_bounds", "split_volume", "volume_piece"]
