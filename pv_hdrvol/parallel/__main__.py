"""``python -m pv_hdrvol.parallel``: POF precomputation and MPI rendering from the shell.

    python -m pv_hdrvol.parallel pof head.vti --tf skin.json --tf bone.json -o head.pof.npz
    mpiexec -n 4 python -m pv_hdrvol.parallel render head.vti --pof head.pof.npz --k 0.25,0.9 -o frame.exr
    mpiexec -n 4 python -m pv_hdrvol.parallel render blocks.vtm --tf tf.json -o frame.exr
    mpiexec -n 4 python -m pv_hdrvol.parallel render big.ome.zarr --screen-error 1 -o frame.exr

Transfer functions are JSON files of ``TransferFunction.to_dict()``. ``render`` without
``--pof`` renders with ``--tf`` (or the default transfer function, as ``pv-hdrvol
render``'s, chosen on rank 0) and ``pv-hdrvol render``'s camera (perspective), each rank
its own box of the volume as one piece (:func:`~pv_hdrvol.parallel.pieces.render_in_pieces`:
``volume_piece(volume, ranks, rank)``, ``GridPlan.execute(piece=...)``, ``gather_pieces``,
the path of ParaView's ranks), composited on rank 0 in depth order. On one rank that is
``pv-hdrvol render``'s image bit for bit, in about its time; on more, its image to
rounding (the pieces composited in float64: measured 8.1e-8 of the brightest value in
float32 and 2.6e-15 in float64 on 2 and 3 ranks; early ray termination per piece).
With ``--pof`` the camera is orthographic, as ``pv-hdrvol render --pof``'s, and each
rank renders its visible blocks one by one (:func:`~pv_hdrvol.parallel.render.render_parallel`:
culling needs blocks; the image does not depend on the rank count). Rank 0 writes the
image, with its render settings (``pv_hdrvol.load(OUT).settings()``), and prints the
per-rank threads and times.

A multiblock file (``.vtm``) of image blocks (``.vti`` leaves) on one lattice that tile
their union box is rendered with each rank reading only its own leaf files (contiguous
runs in file order, balanced by points) and rendering each block as a piece of the union
volume; rank 0 composites them (:mod:`pv_hdrvol.parallel.multiblock`). The image is
``pv_hdrvol.render(pyvista.read(FILE.vtm))``'s to rounding (1e-6 relative asked, 5e-16
measured in float64). Without ``--tf`` rank 0 gathers every block's values once to
choose the default transfer function, as the serial render does. Other ``.vtm``
contents (leaves that are not ``.vti``, other lattices, holes, overlaps, cell data,
``--pof``) are refused: render them serially with ``pv-hdrvol render FILE.vtm``.

A multiresolution store (``.ome.zarr``, :func:`pv_hdrvol.write_multiscale`) is rendered
out of core with each rank reading only the chunks of its own box of blocks (and the
plane of points across its faces) at the levels of detail ``--screen-error`` asks for
(:mod:`pv_hdrvol.outofcore.parallel`; the command-line front end reaches that later
stage); ``--cache-bytes`` bounds each rank's chunks in memory.

User errors (files that are missing or unreadable, volumes that are not image data,
POF files that do not fit, outputs that cannot be written) end with one
``argparse``-style line on stderr and exit status 2, without a traceback.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys

import numpy as np

from ..integrations.cli import add_transfer_function_options, transfer_function_words
from ..rays.camera import fit_camera

#: Views of ``--view`` (``Camera.fit``), as ``pv-hdrvol render``'s.
VIEWS = ("iso", "xy", "yx", "xz", "zx", "yz", "zy")
#: Image formats ``render -o`` writes (``.npy`` keeps no render settings).
OUTPUTS = (".exr", ".hdr", ".npy")

RENDER_DESCRIPTION = (
    "Render an image volume spread over the ranks of mpiexec (or alone with --serial) to a float image: each rank "
    "renders its own box of the volume as one piece, and rank 0 composites the pieces in depth order; with --pof "
    "each rank renders its visible blocks one by one instead (culling needs blocks). Camera: as pv-hdrvol render's "
    "-- perspective, 30-degree vertical view angle, framing the volume's bounding sphere from --view (default iso) "
    "-- except with --pof, where it is orthographic (POF culling assumes parallel rays; pv-hdrvol render --pof is "
    "orthographic too). Size 512x512 and the transfer function chosen from the data (without --tf or --pof), as "
    "pv-hdrvol render's. On one rank the image is pv-hdrvol render's bit for bit; on more, its image to rounding "
    "(the pieces composited in float64; measured 8.1e-8 of the brightest value in float32 and 2.6e-15 in float64 on "
    "2 and 3 ranks; early ray termination per piece); with --pof, to 2e-6 (blocks composited one after another). "
    "Each rank runs "
    "max(1, cores // ranks on its node) numba threads unless NUMBA_NUM_THREADS is set. Rank 0 writes OUT with the "
    "render settings (pv_hdrvol.load(OUT).settings(); .npy keeps none) and prints each rank's threads and times. "
    "A multiblock file (.vtm) of .vti blocks on one lattice that tile their union box: each rank reads only its own "
    "block files (contiguous runs, balanced by points; --curve does not apply) and renders each block as a piece of "
    "the whole; the image equals pv-hdrvol render FILE.vtm's (serial pv_hdrvol.render) to 1e-6 of the brightest "
    "value. Without --tf rank 0 gathers all blocks' values once to choose the default transfer function. Other .vtm "
    "files (non-.vti leaves, several lattices, holes, overlaps, cell data) and --pof with a .vtm are refused: render "
    "them with pv-hdrvol render FILE.vtm. A multiresolution store (.ome.zarr folder, pv-hdrvol convert): each rank "
    "reads only the chunks of its own box of blocks at the levels --screen-error asks for, within --cache-bytes; "
    "the transfer function without --tf is chosen from the coarsest level (as pv_hdrvol.open_multiscale's).")


class UserError(Exception):
    """A problem with the command line or the files it names (exit status 2)."""


def build_parser():
    """The ``argparse`` parser of ``python -m pv_hdrvol.parallel`` (``pof``, ``render``)."""
    parser = argparse.ArgumentParser(prog="python -m pv_hdrvol.parallel", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("pof", help="precompute plenoptic opacity functions of a volume",
                       description="Precompute the plenoptic opacity functions of an image volume for a family of "
                                   "transfer functions (one process; --threads threads).")
    p.add_argument("volume", help="image volume (.vti, or anything pyvista.read gives as ImageData)")
    p.add_argument("--tf", action="append", required=True, help="a basis transfer function (JSON); repeat")
    p.add_argument("--scalars", help="array to use (default: active scalars)")
    p.add_argument("--block-size", type=int, default=16)
    p.add_argument("--threads", type=int, help="threads (default: the machine's cores)")
    p.add_argument("-o", "--output", required=True, help="the .npz file to write")
    p.set_defaults(subparser=p)
    r = sub.add_parser("render", help="render on the ranks of mpiexec (or alone)", description=RENDER_DESCRIPTION)
    r.add_argument("volume", help="image volume (.vti, or anything pyvista.read gives as ImageData), or a .vtm of .vti "
                                  "blocks on one lattice (each rank reads its own)")
    r.add_argument("--pof", help="a .pof.npz file: cull with it (orthographic camera); the transfer function is its "
                                 "bases' family")
    r.add_argument("--k", help="the family's weights, comma-separated (default all 1)")
    r.add_argument("--tf", help="a transfer function (JSON), without --pof (default: chosen from the data, as "
                                "pv-hdrvol render's)")
    r.add_argument("--scalars", help="array to render (default: active scalars)")
    r.add_argument("--size", type=int, nargs="+", default=[512], metavar="N",
                   help="image size: N (square) or W H (default 512)")
    r.add_argument("--view", default="iso", choices=VIEWS, metavar="VIEW",
                   help=f"the direction the camera looks from, one of {', '.join(VIEWS)} (default iso); perspective, "
                        f"30-degree view angle, framing the bounding sphere (orthographic with --pof)")
    r.add_argument("--curve", default="hilbert", choices=("hilbert", "z", "contiguous", "random"),
                   help="with --pof, how blocks are dealt to ranks (default hilbert); without it each rank renders "
                        "one box of the volume")
    r.add_argument("--precision", default="float32", choices=("float32", "float64"),
                   help="compositing precision (default float32)")
    r.add_argument("--screen-error", type=float, default=1.0, metavar="PIXELS",
                   help="a store's level of detail: the largest projected voxel, in pixels (default 1)")
    r.add_argument("--cache-bytes", type=float, default=2 * 2 ** 30, metavar="BYTES",
                   help="a store's chunks in memory per rank, at most (default 2 GiB)")
    r.add_argument("--serial", action="store_true", help="no MPI (comm=None)")
    r.add_argument("-o", "--output", default="frame.exr", metavar="OUT",
                   help=f"image to write, one of {', '.join(OUTPUTS)} (default frame.exr)")
    add_transfer_function_options(r)  # pv-hdrvol render's --cmap, --clim, --opacity, --scale, without --tf
    r.set_defaults(subparser=r)
    return parser


def _words(args):
    """``cmap=``, ``clim=``, ``opacity=``, ``scale=`` of the command line (``None`` where
    not given); refused beside ``--tf`` and ``--pof``, which set the transfer function."""
    try:
        words = transfer_function_words(args)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    given = [f"--{name}" for name, value in words.items() if value is not None]
    for option, value in (("--tf", args.tf), ("--pof", args.pof)):
        if value and given:
            raise UserError(f"{option} sets the transfer function: leave out {', '.join(given)}")
    return words


def main(argv=None):
    """Run ``python -m pv_hdrvol.parallel`` with ``argv``. Returns 0; user errors raise
    ``SystemExit(2)`` after one line on stderr (on rank 0 only, under MPI)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "pof":
        try:
            return _pof(args)
        except UserError as exc:
            args.subparser.error(str(exc))
    try:
        comm = _comm(args)
    except UserError as exc:
        args.subparser.error(str(exc))
    if pathlib.Path(args.volume).suffix.lower() == ".vtm":
        return _render_multiblock(args, comm)
    if (pathlib.Path(args.volume) / "zarr.json").is_file():
        return _render_store(args, comm)
    job = error = None
    try:
        job = _prepare(args)
    except UserError as exc:
        error = str(exc)
    # every rank prepares alike; one exchange so that none goes on to render alone
    failed = [(rank, text) for rank, text in enumerate(comm.allgather(error)) if text is not None]
    if failed:
        _fail(args, comm, failed[0][1] if failed[0][0] == 0 else f"rank {failed[0][0]}: {failed[0][1]}")
    from ..raycast.memory import RenderMemoryError
    from .pieces import render_in_pieces
    from .render import render_parallel

    volume, tf, pof, camera, size, output, words = job
    try:
        # the plan gives the words their meaning (resolve_render_options), as in hv.render
        if pof is None:  # each rank renders its box of the volume as one piece, as ParaView's ranks do
            image = render_in_pieces(volume, tf, camera, size, comm=comm, precision=args.precision, **words)
        else:  # culling needs blocks: each rank renders its visible ones, one by one
            image = render_parallel(volume, tf, camera, size, pof=pof, comm=comm, curve=args.curve,
                                    precision=args.precision, **words)
    except (ValueError, TypeError, RenderMemoryError) as exc:  # raised alike on every rank, before any exchange
        _fail(args, comm, str(exc))
    except RuntimeError as exc:  # the pieces: the others learn that one rank failed, and which
        if pof is not None:
            raise
        _fail(args, comm, str(exc))
    if image is not None:
        image.metadata["source_file"] = str(args.volume)
        try:
            image.save(output)
        except OSError as exc:
            _fail(args, comm, f"cannot write {str(output)!r}: {exc}")
        info = image.metadata["parallel"]
        kind = "orthographic" if camera.parallel_projection else f"perspective {camera.view_angle:g} degrees"
        if pof is None:
            what = f"{info['pieces']} piece{'s' if info['pieces'] != 1 else ''} (one box of the volume per rank)"
        else:
            what = f"{info['visible']} of {info['blocks']} blocks visible"
        print(f"{output}: {size[0]}x{size[1]}, {kind} from {args.view}, {info['ranks']} ranks, {what}, "
              f"{info['seconds']:.2f} s")
        for s in info["per_rank"]:
            threads = f"{s['threads']} thread{'s' if s['threads'] != 1 else ''} ({s['threads_reason']})"
            if pof is None:
                (lo, hi) = s["piece"]
                work = f"piece {tuple(lo)}..{tuple(hi)} points"
            else:
                work = f"{s['rendered']} blocks, cull {s['cull_seconds']:.3f} s"
            print(f"  rank {s['rank']}: {threads}, {work}, render {s['render_seconds']:.3f} s, composite "
                  f"{s['composite_seconds']:.3f} s")
    return 0


def _agree(args, comm, error):
    """Every rank learns whether any met a user error (``error``: its text or None);
    then all end with the first one's line, so that none goes on alone."""
    failed = [(rank, text) for rank, text in enumerate(comm.allgather(error)) if text is not None]
    if failed:
        _fail(args, comm, failed[0][1] if failed[0][0] == 0 else f"rank {failed[0][0]}: {failed[0][1]}")


def _multiblock_options(args):
    """``(size, output, tf)`` of a ``.vtm`` render, each checked."""
    name = args.volume
    if args.pof:
        raise UserError(f"--pof culls the blocks of one image volume; {name!r} is a multiblock file: leave out --pof")
    if args.k is not None:
        raise UserError("--k weighs the bases of --pof; give --pof FILE.npz")
    size, output, words = _size_output_words(args)
    tf = _read_tf("--tf", args.tf) if args.tf else None
    _existing_file("", name)
    return size, output, tf, words


def _render_multiblock(args, comm):
    """``render FILE.vtm``: each rank reads its own leaves, renders each as a piece of the
    blocks' union volume, and rank 0 composites them (:mod:`pv_hdrvol.parallel.multiblock`)."""
    import time

    from ..data.blocks import gather_images
    from ..raycast.grid import resolve_render_options
    from ..raycast.memory import RenderMemoryError
    from .comm import use_rank_threads
    from .multiblock import (SERIAL_HINT, MultiblockError, assign_leaves, lattice_pieces, leaf_points,
                             render_leaf_pieces, vtm_leaves)

    started = time.perf_counter()
    vtm = args.volume
    hint = SERIAL_HINT.format(file=vtm)
    # 1. options; rank 0 reads the index and deals the leaves
    plan = error = size = output = tf = words = None
    try:
        size, output, tf, words = _multiblock_options(args)
        if comm.rank == 0:
            leaves = vtm_leaves(vtm)
            if not leaves:
                raise UserError(f"{vtm!r} lists no block files: nothing to render")
            plan = (leaves, assign_leaves([leaf_points(leaf.file) for leaf in leaves], comm.size).tolist())
    except (UserError, MultiblockError) as exc:
        error = str(exc)
    _agree(args, comm, error)
    leaves, owners = comm.bcast(plan, root=0)
    mine = [leaf for leaf, rank in zip(leaves, owners) if rank == comm.rank]

    # 2. each rank reads its own leaves, and only those
    name, blocks, infos, error = _read_own_leaves(args, mine, vtm, hint)
    _agree(args, comm, error)

    # 3. every rank: the blocks as pieces of one volume, or the reason not
    everyone = comm.allgather((name, infos))
    names = sorted({n for n, i in everyone if i})
    error = None
    try:
        if not names:
            raise UserError(f"{vtm!r} holds no non-empty block: nothing to render")
        if len(names) > 1:
            raise UserError(f"the blocks' scalars differ ({', '.join(map(repr, names))}): give --scalars NAME")
        every = [info for _, i in everyone for info in i]
        pieces = lattice_pieces(every, vtm)
    except (UserError, MultiblockError) as exc:
        error = str(exc)
    _agree(args, comm, error)  # the same on every rank: all fail alike
    name = names[0]
    start = sum(len(i) for _, i in everyone[:comm.rank])
    my_pieces = pieces[start:start + len(infos)]
    volumes = [b.volume(name) for b in blocks]

    # 4. the transfer function: the default one reads every value (rank 0 gathers them)
    if tf is None:
        gathered = comm.gather(blocks, root=0)
        chosen = None
        if comm.rank == 0:
            try:
                volume, _ = gather_images([b for batch in gathered for b in batch], name)
                chosen = resolve_render_options(volume, None, **words)[0]
            except (ValueError, TypeError) as exc:
                chosen = str(exc)
        chosen = comm.bcast(chosen, root=0)
        _agree(args, comm, chosen if isinstance(chosen, str) else None)
        tf = chosen
    spacing = np.asarray(every[0].spacing, dtype=np.float64)
    camera = fit_camera(pieces[0].bounds(spacing), args.view)  # the union volume's bounds

    # 5. render this rank's blocks, composite on rank 0
    threads, reason, previous = use_rank_threads(comm)
    try:
        image, stats = render_leaf_pieces(volumes, my_pieces, tf, camera, size, comm=comm, precision=args.precision)
    except (ValueError, TypeError, RenderMemoryError, RuntimeError) as exc:
        _fail(args, comm, str(exc))
    finally:
        import numba

        numba.set_num_threads(previous)
    stats.update(rank=comm.rank, threads=threads, threads_reason=reason, blocks=[i.path for i in infos],
                 files=[i.file for i in infos], points=int(sum(int(np.prod(i.dims)) for i in infos)))
    per_rank = comm.gather(stats, root=0)
    if image is None:
        return 0
    _write_multiblock_image(args, comm, image, output, camera, size, every, per_rank, started)
    return 0


def _read_own_leaves(args, mine, vtm, hint):
    """``(name, blocks, infos, error)``: the scalars' name, the image blocks and their
    descriptions of the leaves ``mine`` (this rank's), read here and only here; ``error``
    the text of a user error instead (every rank then agrees to stop)."""
    from ..data.blocks import Leaf, choose_block_scalars, image_blocks
    from .multiblock import BlockInfo, MultiblockError, read_leaf

    name = None
    blocks, infos = [], []
    try:
        read = [(leaf, read_leaf(leaf, vtm)) for leaf in mine]
        kept = [(leaf, data) for leaf, data in read if data.GetNumberOfPoints() and data.GetNumberOfCells()]
        if kept:
            name, use_cell, chosen, missing = choose_block_scalars([Leaf(leaf.path, data) for leaf, data in kept],
                                                                   args.scalars)
            if missing:
                raise MultiblockError(f"blocks {missing} lack scalars {name!r}: python -m pv_hdrvol.parallel renders "
                                      f"blocks that all have them; {hint}")
            if use_cell:
                raise MultiblockError(f"scalars {name!r} are cell data: python -m pv_hdrvol.parallel renders the "
                                      f"point data of .vtm blocks (blocks of cell data do not share points); {hint}")
            blocks = image_blocks(chosen, name, False)
            files = {leaf.path: leaf.file for leaf, _ in kept}
            infos = [BlockInfo(b.path, str(files[b.path]), tuple(b.origin.tolist()), tuple(b.spacing.tolist()),
                               tuple(int(n) for n in b.values.shape[::-1])) for b in blocks]
    except (UserError, MultiblockError, ValueError, TypeError) as exc:
        return name, blocks, infos, str(exc)
    return name, blocks, infos, None


def _write_multiblock_image(args, comm, image, output, camera, size, every, per_rank, started):
    """Rank 0: the multiblock render's metadata, the file and the lines it prints."""
    import time

    vtm = args.volume
    image.metadata["source_file"] = str(vtm)
    image.metadata["blocks"] = {"kind": "grid", "rendered": [i.path for i in every]}
    image.metadata["parallel"] = {"ranks": comm.size, "blocks": len(every), "per_rank": per_rank,
                                  "seconds": time.perf_counter() - started}
    try:
        image.save(output)
    except OSError as exc:
        _fail(args, comm, f"cannot write {str(output)!r}: {exc}")
    print(f"{output}: {size[0]}x{size[1]}, perspective {camera.view_angle:g} degrees from {args.view}, {comm.size} "
          f"ranks, {len(every)} blocks of {vtm}, {image.metadata['parallel']['seconds']:.2f} s")
    for s in per_rank:
        print(f"  rank {s['rank']}: {s['threads']} thread{'s' if s['threads'] != 1 else ''} ({s['threads_reason']}), "
              f"{len(s['blocks'])} block{'s' if len(s['blocks']) != 1 else ''} read and rendered, render "
              f"{s['render_seconds']:.3f} s, composite {s['composite_seconds']:.3f} s")


def _render_store(args, comm):
    """``render STORE.ome.zarr``: each rank reads and renders its own box of blocks out of
    core; rank 0 composites (:mod:`pv_hdrvol.outofcore.parallel`)."""
    import time

    import pv_hdrvol as hv

    from .._validate import as_size
    from ..outofcore.parallel import render_multiscale_pieces
    from ..raycast.grid import resolve_render_options

    started = time.perf_counter()
    volume = tf = size = output = error = None
    try:
        if args.pof or args.k is not None:
            raise UserError("--pof and --k cull the blocks of an in-memory volume; a store reads only what it needs "
                            "already: leave them out")
        if args.scalars:
            raise UserError("a store holds one array: leave out --scalars")
        try:
            size = as_size(tuple(args.size) if len(args.size) == 2 else args.size[0] if len(args.size) == 1 else None)
        except (TypeError, ValueError):
            raise UserError(f"--size takes N or W H, positive; got {' '.join(map(str, args.size))}") from None
        if not args.screen_error > 0:
            raise UserError(f"--screen-error must be > 0 pixels; got {args.screen_error}")
        output = _output(args.output, OUTPUTS)
        words = _words(args)
        try:
            volume = hv.open_multiscale(args.volume, cache_bytes=args.cache_bytes)
            # the coarsest level's default function (the store's), shaped by the words
            tf = resolve_render_options(volume, _read_tf("--tf", args.tf) if args.tf else None, **words)[0]
        except (ValueError, TypeError, OSError, ImportError) as exc:
            raise UserError(f"{args.volume!r}: {exc}") from None
    except UserError as exc:
        error = str(exc)
    _agree(args, comm, error)
    camera = fit_camera(volume, args.view)
    try:
        image = render_multiscale_pieces(volume, tf, camera, size, comm=comm, screen_error=args.screen_error,
                                         precision=args.precision)
    except (ValueError, TypeError, OSError, RuntimeError) as exc:
        _fail(args, comm, str(exc))
    finally:
        volume.close()
    if image is None:
        return 0
    image.metadata["source_file"] = str(args.volume)
    seconds = time.perf_counter() - started
    try:
        image.save(output)
    except OSError as exc:
        _fail(args, comm, f"cannot write {str(output)!r}: {exc}")
    read = image.metadata["bytes_read_per_rank"]
    print(f"{output}: {size[0]}x{size[1]}, perspective {camera.view_angle:g} degrees from {args.view}, {comm.size} "
          f"ranks, levels {image.metadata['levels']}, {seconds:.2f} s")
    for rank, b in enumerate(read):
        print(f"  rank {rank}: {b / 2 ** 20:.1f} MiB read")
    return 0


def _fail(args, comm, message):
    """End with ``message`` as argparse does (exit status 2), printed by rank 0 only."""
    if comm.rank == 0:
        args.subparser.error(message)
    sys.exit(2)


def _comm(args):
    from .comm import as_communicator

    if args.serial:
        return as_communicator(None)
    try:
        return as_communicator("world")
    except ImportError as exc:
        raise UserError(f"{exc}; or add --serial") from None


def _prepare(args):
    """``(volume, tf, pof, camera, size, output, words)`` from the command line, each checked."""
    import pv_hdrvol as hv

    size, output, words = _size_output_words(args)
    volume = _read_volume(args.volume, args.scalars)
    pof = tf = None
    if args.pof:
        if args.tf:
            raise UserError("--pof renders the family of its bases: leave out --tf")
        pof = _read_pof(args.pof, volume)
        k = None if args.k is None else [_number("--k", x) for x in args.k.split(",")]
        try:
            tf = hv.TransferFunction.family(pof.bases, k)
        except (ValueError, TypeError) as exc:
            raise UserError(f"--k {args.k}: {exc}") from None
    elif args.k is not None:
        raise UserError("--k weighs the bases of --pof; give --pof FILE.npz")
    elif args.tf:
        tf = _read_tf("--tf", args.tf)
    # pv-hdrvol render's camera (the dataset's bounds, fit_camera); orthographic with culling, as its --pof
    camera = fit_camera(volume, args.view, parallel_projection=pof is not None)
    return volume, tf, pof, camera, size, output, words


def _pof(args):
    from ..culling.pof import PlenopticOpacity

    output = _output(args.output, (".npz",))
    volume = _read_volume(args.volume, args.scalars)
    tfs = [_read_tf("--tf", t) for t in args.tf]
    try:
        pof = PlenopticOpacity.compute(volume, tfs, block_size=args.block_size, threads=args.threads,
                                       progress_bar=sys.stderr.isatty())
    except (ValueError, TypeError) as exc:
        raise UserError(str(exc)) from None
    try:
        pof.save(output)
    except OSError as exc:
        raise UserError(f"cannot write {str(output)!r}: {exc}") from None
    print(f"{output}: {pof.grid_shape} blocks of {pof.block_size}^3, {int(pof.nonempty.any(-1).sum())} "
          f"non-empty, {len(pof.bases)} bases")
    return 0


def _size_output_words(args):
    """``--size``, ``-o`` and the transfer function's words of ``render``, each checked."""
    from .._validate import as_size

    try:
        size = as_size(tuple(args.size) if len(args.size) == 2 else args.size[0] if len(args.size) == 1 else None)
    except (TypeError, ValueError):
        raise UserError(f"--size takes N or W H, positive; got {' '.join(map(str, args.size))}") from None
    return size, _output(args.output, OUTPUTS), _words(args)


def _output(name, suffixes):
    """``-o`` as a path, after checking its suffix and that its folder takes it."""
    from ..image.io import check_writable

    path = pathlib.Path(name)
    if path.suffix.lower() not in suffixes:
        raise UserError(f"-o/--output {name!r} must end in {' or '.join(suffixes)}")
    try:
        check_writable(path)
    except OSError as exc:  # "cannot write 'a/b.exr': no such folder: 'a'"
        raise UserError(f"-o/--output: {exc.strerror}: {exc.filename!r}") from None
    return path


def _existing_file(option, name):
    path = pathlib.Path(name)
    if not path.exists():
        raise UserError(f"{option}file not found: {name!r}")
    if not path.is_file():
        raise UserError(f"{option}not a file: {name!r}")
    return path


def _read_volume(name, scalars):
    """The image volume of ``scalars`` in file ``name``, read with PyVista (or VTK's
    ``.vti`` reader in a Python without PyVista: ParaView's)."""
    from ..data.grid import volume_from_dataset
    from ..raycast.grid import as_volume

    path = _existing_file("", name)
    fix = ("resample it to image data first (pyvista: pv.ImageData(...).sample(dataset); ParaView: Resample To "
           "Image) and save that as .vti")
    try:
        import pyvista as pv
    except ImportError:  # ParaView's Python has VTK but no PyVista
        pv = None
    if pv is None:
        if path.suffix.lower() != ".vti":
            raise UserError(f"cannot read {str(path)!r}: without PyVista only .vti files are read here; "
                            f"pip install pyvista, or save it as .vti")
        from vtkmodules.vtkIOXML import vtkXMLImageDataReader

        reader = vtkXMLImageDataReader()
        reader.SetFileName(str(path))
        reader.Update()
        dataset = reader.GetOutput()
        if dataset is None or dataset.GetNumberOfPoints() == 0:
            raise UserError(f"cannot read {str(path)!r}: VTK's reader found no image data in it")
    else:
        try:
            dataset = pv.read(path)
        except Exception as exc:  # readers raise anything from OSError to ValueError
            raise UserError(f"cannot read {str(path)!r}: {exc}") from None
        if not isinstance(dataset, pv.ImageData):
            raise UserError(f"{str(path)!r} holds a {type(dataset).__name__}; python -m pv_hdrvol.parallel renders "
                            f"image data (ImageData): {fix}")
    try:
        return as_volume(volume_from_dataset(dataset, scalars=scalars))
    except (ValueError, TypeError) as exc:
        raise UserError(f"{str(path)!r}: {exc}") from None


def _read_tf(option, name):
    from ..data.transfer import TransferFunction

    path = _existing_file(f"{option}: ", name)
    try:
        with open(path) as f:
            return TransferFunction.from_dict(json.load(f))
    except (OSError, ValueError, TypeError, KeyError) as exc:  # json's errors are ValueErrors
        raise UserError(f"{option} {str(path)!r} is not a transfer function (JSON of TransferFunction.to_dict()): "
                        f"{exc}") from None


def _read_pof(name, volume):
    from ..culling.pof import PlenopticOpacity

    path = _existing_file("--pof: ", name)
    make = f"make it with: python -m pv_hdrvol.parallel pof VOLUME --tf TF.json -o {name}"
    try:
        pof = PlenopticOpacity.load(path)
    except Exception as exc:  # ValueError naming the file; older numpy, zipfile and json errors did not
        text = str(exc) or type(exc).__name__
        if str(path) not in text:
            text = f"{str(path)!r} is not a readable POF file ({text}); {make}"
        raise UserError(f"--pof: {text}") from None
    try:
        pof.check_volume(volume)
    except ValueError as exc:
        raise UserError(f"--pof {str(path)!r} is not of this volume: {exc}; {make}") from None
    return pof


def _number(option, text):
    try:
        return float(text)
    except ValueError:
        raise UserError(f"{option}: {text!r} is not a number") from None


def _quiet_openmp_threads():
    """``OMP_WAIT_POLICY=PASSIVE`` unless set: with numba's OpenMP layer, threads that end
    a parallel region spin for a while before they sleep, and between the many small
    block renders that spin takes the cores the Python work needs (engine, 512^2,
    ``--serial`` with 2 threads on 2 busy cores: 16.5 s, passive 3.3 s). Read when
    numba starts its threads, so set before; in a program, not in :func:`main` (tests
    call it)."""
    import os

    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


if __name__ == "__main__":
    _quiet_openmp_threads()
    sys.exit(main())
