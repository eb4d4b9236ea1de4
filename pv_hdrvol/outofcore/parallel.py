"""Render a store on the processes of an MPI communicator: each reads and renders the
blocks of its own box of the volume, and the partial images are composited in depth
order (:mod:`pv_hdrvol.parallel.pieces`).

The boxes are :func:`~pv_hdrvol.parallel.pieces.split_boxes` of the grid of 64-cell
blocks (a chunk of level 0 each), so a process reads the chunks of its blocks at the
levels they need, and of its neighbours only the chunks that hold the one plane of
points its samples interpolate from across its faces. Every process chooses the level
of detail of every block from the store's metadata and the camera alone, so all step
alike (at the finest level any block of the whole needs) without a message; with every
block at level 0 the composite equals the serial render to rounding (composited per
piece instead of per sample, as for in-core pieces).
"""
from __future__ import annotations

import numpy as np

from .._validate import as_size
from ..parallel.comm import WORLD, as_communicator
from ..parallel.pieces import gather_pieces, split_boxes
from ..raycast.grid import VolumePiece
from ..rays.camera import Rays, as_camera
from .render import BLOCK, MultiscaleVolume


def store_pieces(volume, n):
    """``n`` :class:`VolumePiece` s of a :class:`MultiscaleVolume`'s level 0 whose owned
    boxes are boxes of whole 64-cell blocks that tile the volume (``split_boxes`` of the
    block grid)."""
    if not isinstance(volume, MultiscaleVolume):
        raise TypeError(f"volume must be a MultiscaleVolume (pv_hdrvol.open_multiscale); got {type(volume).__name__}")
    bz, by, bx = volume.block_shape
    dims = np.array(volume.dims)
    out = []
    for lo, hi in split_boxes((bx + 1, by + 1, bz + 1), n):
        p_lo = tuple(int(v) for v in np.minimum(BLOCK * np.array(lo), dims - 1))
        p_hi = tuple(int(v) for v in np.minimum(BLOCK * np.array(hi), dims - 1))
        out.append(VolumePiece(tuple(volume.origin.tolist()), tuple(int(d) for d in dims), (0, 0, 0), p_lo, p_hi))
    return out


def render_multiscale_pieces(volume, tf, camera=None, size=(512, 512), *, comm=WORLD, root=0, screen_error=1.0,
                             **options):
    """Render a store spread over the processes of ``comm`` (SPMD: every process calls
    it with its own :class:`MultiscaleVolume` of the same store).

    Parameters
    ----------
    volume : MultiscaleVolume
        This process's handle on the store (``open_multiscale``; each has its own cache).
    tf : TransferFunction
        Required: every process must use the same one (the default one is chosen from
        the coarsest level: pass ``volume.default_transfer_function()`` to get it).
    camera, size, screen_error, **options
        As :meth:`MultiscalePlan.execute` and :func:`pv_hdrvol.render`.
    comm : mpi4py communicator, ``"world"`` (default) or None (serial: one piece)
    root : int or None
        The process that gets the image (``None``: every process).

    Returns
    -------
    HDRImage or None
        The composite on ``root``, ``None`` elsewhere. Its metadata's ``levels`` counts
        the blocks of all processes; ``bytes_read_per_rank`` lists what each read.
    """
    from ..data.transfer import TransferFunction

    comm = as_communicator(comm)
    image = rays = piece = error = None
    try:
        if not isinstance(tf, TransferFunction):
            raise TypeError(f"render_multiscale_pieces needs tf, a TransferFunction (every process must render "
                            f"with the same one); got {type(tf).__name__}")
        piece = store_pieces(volume, comm.size)[comm.rank]
        camera = as_camera(camera, volume.bounds)
        rays = camera if isinstance(camera, Rays) else camera.rays(as_size(size))
        image = volume.multiscale_plan(tf, **options).execute(camera, size, screen_error=screen_error, piece=piece,
                                                               progress_bar=False)
    except Exception as e:  # noqa: BLE001 - every process learns of it in gather_pieces
        error = e
    mine = None if image is None else (image.metadata["bytes_read"], image.metadata["levels"])
    every = comm.gather(mine, root=0 if root is None else root)
    out = gather_pieces(image, piece, None if error else volume.spacing, rays, comm=comm, root=root, error=error)
    if out is not None and every is not None:
        out.metadata["bytes_read_per_rank"] = [e[0] for e in every]
        out.metadata["levels"] = [int(v) for v in np.sum([e[1] for e in every], axis=0)]
        out.metadata["bytes_read"] = int(sum(e[0] for e in every))
    return out


__all__ = ["render_multiscale_pieces", "store_pieces"]
