"""Run under ``mpiexec -n P python tests/mpi/render_check.py``: the parallel render on P
ranks equals the serial block-wise render bit for bit, and the single-pass render to
rounding; each rank's box rendered as one piece (``render_in_pieces``, the command
line's path without ``--pof``) equals the single-pass render to rounding; printed by
rank 0 as ``OK ...`` lines (tests/parallel/test_parallel.py reads them).
Any failure raises, and the whole job aborts (MPI.COMM_WORLD.Abort), never hangs."""
import os
import sys
import time
import traceback

import numpy as np
from mpi4py import MPI

import pv_hdrvol as hv
from pv_hdrvol.culling.pof import PlenopticOpacity
from pv_hdrvol.parallel.pieces import render_in_pieces
from pv_hdrvol.parallel.render import render_parallel
from pv_hdrvol.raycast.grid import as_volume


def scene():
    rng = np.random.default_rng(11)
    values = 0.6 + 0.4 * rng.random((40, 37, 45))  # opaque: blocks behind the front ones are culled
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1], [1, 1, 1]], [0.0, 0.9, 0.99])
    return as_volume(values), tf


def main():
    comm = MPI.COMM_WORLD
    if os.environ.get("PV_HDRVOL_FAIL_RANK") == str(comm.rank):  # tests/parallel/test_parallel.py: a failing rank
        raise RuntimeError(f"rank {comm.rank} fails on purpose")
    volume, tf = scene()
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    pof = PlenopticOpacity.compute(volume, [tf], block_size=8, threads=1) if comm.rank == 0 else None
    pof = comm.bcast(pof, root=0)
    for precision in ("float64", "float32"):
        for cull in (None, pof):
            options = dict(precision=precision, termination=0.0)
            image = render_parallel(volume, tf, camera, (50, 41), pof=cull, comm=comm, block_size=8, **options)
            if comm.rank != 0:
                assert image is None
                continue
            serial = render_parallel(volume, tf, camera, (50, 41), pof=cull, comm=None, block_size=8, **options)
            assert image.rgba.dtype == serial.rgba.dtype
            assert np.array_equal(image.rgba, serial.rgba), "parallel != serial block-wise"
            full = hv.render(volume, tf, camera, (50, 41), progress_bar=False, **options)
            scale = np.abs(full.rgba).max()
            err = float(np.abs(image.rgba.astype(np.float64) - full.rgba).max() / scale)
            limit = 1e-12 if precision == "float64" else 1e-5
            per_rank = image.metadata["parallel"]["per_rank"]
            assert len(per_rank) == comm.size and sum(r["owned"] for r in per_rank) == 6 * 5 * 5
            if cull is not None:
                assert image.metadata["parallel"]["visible"] < 150, "nothing culled"
            else:
                assert err <= limit, f"{precision}: parallel vs single pass {err:.3g} > {limit}"
            print(f"OK ranks={comm.size} precision={precision} cull={cull is not None} "
                  f"visible={image.metadata['parallel']['visible']} rel_err_vs_single_pass={err:.3g}", flush=True)


def one_block_scene(comm):
    """Every rank but one holds no visible block: they send nothing and still composite
    and gather their tiles."""
    values = np.zeros((40, 37, 45))
    values[18:22, 18:22, 18:22] = 1.0  # inside one 8^3 block only
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 1, 1]] * 3, [0.0, 0.0, 0.5])
    volume = as_volume(values)
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    image = render_parallel(volume, tf, camera, (50, 41), comm=comm, block_size=8, precision="float64")
    if comm.rank == 0:
        serial = render_parallel(volume, tf, camera, (50, 41), comm=None, block_size=8, precision="float64")
        assert np.array_equal(image.rgba, serial.rgba) and image.rgba[..., 3].max() > 0.1
        rendered = [r["rendered"] for r in image.metadata["parallel"]["per_rank"]]
        assert sorted(rendered) == [0] * (comm.size - 1) + [1], rendered
        print(f"OK ranks={comm.size} one visible block, rendered per rank {rendered}", flush=True)


def pieces_scene(comm):
    """Each rank renders its own box of the volume as one piece; rank 0 composites."""
    volume = as_volume(np.random.default_rng(0).random((40, 37, 45)))
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1], [1, 1, 1]], [0.0, 0.05, 0.2])
    camera = hv.Camera.fit(volume.bounds, "iso")
    for precision, limit in (("float64", 1e-12), ("float32", 1e-6)):
        image = render_in_pieces(volume, tf, camera, (50, 41), comm=comm, precision=precision)
        if comm.rank != 0:
            assert image is None
            continue
        full = hv.render(volume, tf, camera, (50, 41), precision=precision, progress_bar=False)
        assert image.rgba.dtype == full.rgba.dtype
        err = float(np.abs(image.rgba.astype(np.float64) - full.rgba).max() / np.abs(full.rgba).max())
        assert err <= limit, f"{precision}: pieces vs single pass {err:.3g} > {limit}"
        info = image.metadata["parallel"]
        assert info["pieces"] == comm.size and [r["rank"] for r in info["per_rank"]] == list(range(comm.size))
        print(f"OK ranks={comm.size} pieces precision={precision} rel_err_vs_single_pass={err:.3g}", flush=True)


if __name__ == "__main__":
    try:
        main()
        one_block_scene(MPI.COMM_WORLD)
        pieces_scene(MPI.COMM_WORLD)
    except BaseException:
        traceback.print_exc()
        sys.stdout.flush()
        sys.stderr.flush()
        # Abort ends every process at once: give mpiexec a moment to forward what this
        # one printed (without it the message was lost in about 1 run in 10 here)
        time.sleep(0.5)
        MPI.COMM_WORLD.Abort(1)
