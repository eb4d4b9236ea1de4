"""A store rendered on several processes (pv_hdrvol.outofcore.parallel): each reads only
the chunks of its own box of blocks, and the composite is the serial render to rounding;
``python -m pv_hdrvol.parallel render STORE`` under mpiexec."""
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("zarr")

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.outofcore.parallel import render_multiscale_pieces, store_pieces  # noqa: E402
from pv_hdrvol.parallel.pieces import check_tiling  # noqa: E402
from test_ooc_render import _field  # noqa: E402
from conftest import REPO_ROOT  # noqa: E402
from mpirun import mpi_env as _mpi_env, mpiexec as _mpiexec  # noqa: E402
from thread_comm import run_spmd  # noqa: E402

SIZE = (48, 40)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("oocp") / "field.ome.zarr"
    hv.write_multiscale(_field((150, 131, 200)), path, spacing=(1.0, 1.25, 0.75), progress_bar=False)
    return path


def test_pieces_are_boxes_of_whole_blocks_that_tile_the_volume(store):
    with hv.open_multiscale(store) as volume:
        for n in (1, 2, 3, 5):
            pieces = store_pieces(volume, n)
            check_tiling(pieces)
            for p in pieces:
                for lo, hi, d in zip(p.owned_lo, p.owned_hi, volume.dims):
                    assert lo % 64 == 0 and (hi % 64 == 0 or hi == d - 1)
    with pytest.raises(TypeError, match="MultiscaleVolume"):
        store_pieces(np.zeros((4, 4, 4)), 2)


@pytest.mark.parametrize("n", [2, 3])
@pytest.mark.parametrize("screen_error", [1e-9, 1.0])
def test_the_composite_is_the_serial_render_and_each_rank_reads_its_own_chunks(store, n, screen_error):
    with hv.open_multiscale(store) as volume:
        tf = volume.default_transfer_function()
        camera = hv.Camera.fit(volume.bounds, "iso")
        serial = volume.render(tf, camera, SIZE, screen_error=screen_error)

    def one(comm):
        with hv.open_multiscale(store) as mine:
            image = render_multiscale_pieces(mine, tf, camera, SIZE, comm=comm, screen_error=screen_error)
            return image, sorted(mine.cache()._slot_of), store_pieces(mine, comm.size)[comm.rank]

    results, errors = run_spmd(n, one)
    assert errors == [None] * n
    image = results[0][0]
    assert all(r[0] is None for r in results[1:])
    assert np.abs(image.rgba - serial.rgba).max() < 1e-6
    assert image.metadata["levels"] == serial.metadata["levels"]
    assert serial.rgba[..., 3].max() > 0.2
    # each rank read only chunks its blocks' samples touch: those of its own box of
    # points at each level, and at most one chunk beyond it on each axis
    for _, keys, piece in results:
        for level, cz, cy, cx in keys:
            lo = np.array(piece.owned_lo[::-1]) // 2 ** level // 64
            hi = np.array(piece.owned_hi[::-1]) // 2 ** level // 64
            if level == len(serial.metadata["levels"]) - 1:
                continue  # the coarsest level: every process holds it
            assert ((np.array([cz, cy, cx]) >= lo - 1) & (np.array([cz, cy, cx]) <= hi + 1)).all()


def test_mpiexec_renders_a_store_as_the_serial_command(store, tmp_path):
    mpiexec = _mpiexec()
    env = _mpi_env()
    env.pop("NUMBA_NUM_THREADS", None)
    serial = tmp_path / "serial.exr"
    ranks = tmp_path / "ranks.exr"
    base = [sys.executable, "-m", "pv_hdrvol.parallel", "render", str(store), "--size", "40", "32"]
    done = subprocess.run(base + ["--serial", "-o", str(serial)], capture_output=True, text=True, timeout=600,
                          env=env, cwd=REPO_ROOT)
    assert done.returncode == 0, done.stderr
    done = subprocess.run([mpiexec, "-n", "2"] + base + ["-o", str(ranks)], capture_output=True, text=True,
                          timeout=600, env=env, cwd=REPO_ROOT)
    assert done.returncode == 0, done.stderr
    assert "2 ranks" in done.stdout and "rank 1:" in done.stdout
    a, b = hv.load(serial), hv.load(ranks)
    assert np.abs(a.rgba - b.rgba).max() < 1e-6
    assert a.metadata["levels"] == b.metadata["levels"]
    bad = subprocess.run(base + ["--serial", "--pof", "x.npz", "-o", str(ranks)], capture_output=True, text=True,
                         timeout=600, env=env, cwd=REPO_ROOT)
    assert bad.returncode == 2 and "leave them out" in bad.stderr.splitlines()[-1]
