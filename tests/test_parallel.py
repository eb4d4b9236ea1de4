"""Parallel sort-last rendering (pv_hdrvol.parallel): distribution along space-filling
curves, tile culling, compositing as a pure function, the serial block-wise render
against the single pass, and the same image under ``mpiexec -n 2`` and ``-n 3``."""
import os
import subprocess
import sys

import numpy as np
import pytest

import pv_hdrvol as hv
from conftest import REPO_ROOT, in_ci
from pv_hdrvol.culling.cull import visible_blocks
from pv_hdrvol.culling.pof import PlenopticOpacity
from pv_hdrvol.parallel.composite import composite, tile_grid
from pv_hdrvol.parallel.distribute import assign, curve_order, hilbert_keys, morton_keys
from pv_hdrvol.parallel.render import render_parallel
from pv_hdrvol.raycast.grid import as_volume

pytestmark = pytest.mark.core


@pytest.mark.parametrize("shape", [(4, 4, 4), (3, 5, 7), (1, 1, 9), (8, 2, 3)])
def test_hilbert_curve_visits_every_block_once_through_face_neighbours(shape):
    order = curve_order(shape, "hilbert")
    assert sorted(order.tolist()) == list(range(int(np.prod(shape))))
    if all(n == shape[0] and n & (n - 1) == 0 for n in shape):  # the full 2^m cube: a continuous curve
        idx = np.stack(np.unravel_index(order, shape), axis=1)
        assert np.abs(np.diff(idx, axis=0)).sum(axis=1).max() == 1
    keys = hilbert_keys(shape).reshape(-1)
    assert len(set(keys.tolist())) == keys.size and len(set(morton_keys(shape).reshape(-1).tolist())) == keys.size


@pytest.mark.parametrize("curve", ["hilbert", "z", "contiguous", "random"])
@pytest.mark.parametrize("ranks", [1, 2, 3, 7, 64])
def test_every_block_is_assigned_once_and_counts_differ_by_at_most_one(curve, ranks):
    """T-POF-13."""
    owner = assign((5, 6, 7), ranks, curve)
    counts = np.bincount(owner.reshape(-1), minlength=ranks)
    assert counts.sum() == 210 and owner.min() >= 0 and owner.max() < ranks
    assert counts.max() - counts.min() <= 1


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6, 7, 16])
def test_tiles_cover_the_image_once(n):
    tiles = tile_grid(n, 50, 41)
    assert len(tiles) == n
    cover = np.zeros((41, 50), dtype=int)
    for col, row, w, h in tiles:
        cover[row:row + h, col:col + w] += 1
    assert np.all(cover == 1)


def test_composite_is_front_to_back_over_in_the_given_order():
    rng = np.random.default_rng(2)
    pieces = []
    for order in (3, 0, 2, 1):
        a = rng.random((5, 6, 1)) * 0.7
        pieces.append((order, (order, order, 6, 5), np.concatenate([rng.random((5, 6, 3)) * a, a], axis=-1)))
    tile = (0, 0, 10, 9)
    out = composite(tile, pieces, np.float64)
    expected = np.zeros((9, 10, 4))
    for order, (col, row, w, h), rgba in sorted(pieces, key=lambda p: p[0]):
        dst = expected[row:row + h, col:col + w]
        dst += (1 - dst[..., 3:4]) * rgba
    np.testing.assert_array_equal(out, expected)
    # a tile sees only its part, with the same bits
    part = composite((2, 1, 5, 6), pieces, np.float64)
    np.testing.assert_array_equal(part, out[1:7, 2:7])


def _opaque_scene():
    rng = np.random.default_rng(11)
    values = 0.6 + 0.4 * rng.random((40, 37, 45))
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1], [1, 1, 1]], [0.0, 0.9, 0.99])
    return as_volume(values), tf


@pytest.mark.parametrize("ranks", [1, 2, 4, 7, 16, 64])
def test_tile_culling_union_is_the_whole_image_culling(ranks):
    """T-POF-10: a block a tile culls only ever composites into pixels already at the
    threshold, so the union of the tiles' visible sets is the image's."""
    volume, tf = _opaque_scene()
    pof = PlenopticOpacity.compute(volume, [tf], block_size=8)
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    whole = visible_blocks(pof, volume, camera, (64, 48)).visible
    union = np.zeros_like(whole)
    for tile in tile_grid(ranks, 64, 48):
        union |= visible_blocks(pof, volume, camera, (64, 48), window=tile).visible
    np.testing.assert_array_equal(union, whole)
    assert 0 < whole.sum() < whole.size


@pytest.mark.parametrize("precision, limit", [("float64", 1e-12), ("float32", 1e-5)])
def test_serial_block_wise_render_equals_the_single_pass(precision, limit):
    rng = np.random.default_rng(0)
    volume = as_volume(rng.random((40, 37, 45)))
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1], [1, 1, 1]], [0.0, 0.05, 0.2])
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    image = render_parallel(volume, tf, camera, (64, 48), comm=None, precision=precision, termination=0.0)
    full = hv.render(volume, tf, camera, (64, 48), precision=precision, termination=0.0, progress_bar=False)
    assert image.rgba.dtype == full.rgba.dtype
    assert np.abs(image.rgba.astype(np.float64) - full.rgba).max() <= limit * np.abs(full.rgba).max()
    stats = image.metadata["parallel"]
    assert stats["ranks"] == 1 and stats["blocks"] == 27 and stats["per_rank"][0]["rendered"] == 27  # 16^3 blocks


def test_render_parallel_refuses_what_it_cannot_composite():
    volume, tf = _opaque_scene()
    ortho = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    with pytest.raises(ValueError, match="render_parallel needs an orthographic Camera"):
        render_parallel(volume, tf, hv.Camera.fit(volume.bounds, "iso"), (8, 8), comm=None)
    with pytest.raises(ValueError, match="blending='composite' only; got 'maximum'"):
        render_parallel(volume, tf, ortho, (8, 8), comm=None, blending="maximum")
    with pytest.raises(ValueError, match=r"block_size \(6\) must be a multiple of the render's block_size option"):
        render_parallel(volume, tf, ortho, (8, 8), comm=None, block_size=6)
    with pytest.raises(TypeError, match="comm must be an mpi4py communicator, 'world' or None; got int"):
        render_parallel(volume, tf, ortho, (8, 8), comm=3)


def _mpiexec():
    """The mpiexec beside this Python: the mpich wheel's for pip's mpi4py, Debian's Open
    MPI one (/usr/bin) for Debian's python3-mpi4py; never a mismatched pair from PATH."""
    try:
        import mpi4py  # noqa: F401 (only whether it is there)
    except ImportError:
        if in_ci():
            pytest.fail("mpi4py is missing (pip install -e '.[test]' installs mpi4py and mpich)", pytrace=False)
        pytest.skip("mpi4py is not installed")
    path = os.path.join(os.path.dirname(sys.executable), "mpiexec")
    if not os.access(path, os.X_OK):
        if in_ci():
            pytest.fail(f"no mpiexec beside {sys.executable} (the mpich wheel installs one)", pytrace=False)
        pytest.skip(f"no mpiexec beside {sys.executable}")
    return path


@pytest.mark.parametrize("ranks", [2, 3])
def test_mpi_ranks_give_the_serial_image_bit_for_bit(ranks):
    # Open MPI (Debian's Python uses /usr/bin/mpiexec) refuses root, and more ranks than
    # cores, without these; MPICH ignores them
    env = dict(os.environ, PYTHONPATH=str(REPO_ROOT), NUMBA_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    done = subprocess.run([_mpiexec(), "-n", str(ranks), sys.executable, str(REPO_ROOT / "tests" / "mpi" /
                                                                             "render_check.py")],
                          env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stdout[-4000:]
    lines = [line for line in done.stdout.splitlines() if line.startswith("OK ")]
    assert len(lines) == 5 and all(f"ranks={ranks} " in line for line in lines), done.stdout[-4000:]


def test_command_line_precomputes_and_renders(tmp_path, capsys):
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.parallel.__main__ import main

    volume, tf = _opaque_scene()
    grid = pv.ImageData(dimensions=volume.dims)
    grid.point_data["v"] = volume.values.reshape(-1)
    grid.save(tmp_path / "vol.vti")
    (tmp_path / "tf.json").write_text(__import__("json").dumps(tf.to_dict()))
    assert main(["pof", str(tmp_path / "vol.vti"), "--tf", str(tmp_path / "tf.json"), "--block-size", "8",
                 "-o", str(tmp_path / "vol.pof.npz")]) == 0
    assert main(["render", str(tmp_path / "vol.vti"), "--pof", str(tmp_path / "vol.pof.npz"), "--k", "2",
                 "--size", "40", "30", "--serial", "-o", str(tmp_path / "frame.exr")]) == 0
    out = capsys.readouterr().out
    assert "(5, 5, 6) blocks of 8^3, 150 non-empty, 1 bases" in out and "1 ranks" in out
    pof = PlenopticOpacity.load(tmp_path / "vol.pof.npz")
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    expected = render_parallel(volume, hv.TransferFunction.family([tf], [2.0]), camera, (40, 30), pof=pof, comm=None)
    saved = hv.load(tmp_path / "frame.exr")
    np.testing.assert_array_equal(saved.rgba, expected.rgba)


def test_simulation_accounts_for_every_block_and_pixel():
    from pv_hdrvol.parallel.simulate import BlockCosts, simulate

    shape = (2, 3, 4)
    rects = {b: ((b % 4) * 10, (b // 4) * 5, 10, 5) for b in range(24)}  # a 40 x 30 image tiled by blocks
    costs = BlockCosts(shape, (40, 30), np.ones(24, bool), np.arange(24) * 1e-3 + 1e-3, np.ones(24, int), rects,
                       1e-5, np.ones(24, bool), 1e-8, 16)
    rows = simulate(costs, [1, 2, 3, 4, 24], "hilbert", network=(1e-6, 1e9))
    one = rows[0]
    assert one["speedup"] == 1.0 and one["messages"] == 0 and one["blocks_max"] == 24
    # one rank: every block's time, every block tested, every pixel composited once
    assert one["render"] == pytest.approx(costs.seconds.sum())
    assert one["cull"] == pytest.approx(24 * 1e-5)
    assert one["composite"] == pytest.approx(24 * 50 * 1e-8)
    for row in rows[1:]:
        assert row["blocks_min"] * row["ranks"] <= 24 <= row["blocks_max"] * row["ranks"]
        assert row["blocks_max"] - row["blocks_min"] <= 1 and row["speedup"] > 1
        assert row["efficiency"] == pytest.approx(row["speedup"] / row["ranks"])


def test_a_failing_rank_ends_the_job_instead_of_hanging_it():
    """Rank 1 raises before the first collective; rank 0 would wait in it forever. The
    script's MPI.COMM_WORLD.Abort ends the whole job with a non-zero status."""
    env = dict(os.environ, PYTHONPATH=str(REPO_ROOT), NUMBA_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1", PV_HDRVOL_FAIL_RANK="1")
    done = subprocess.run([_mpiexec(), "-n", "2", sys.executable, str(REPO_ROOT / "tests" / "mpi" / "render_check.py")],
                          env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=300)
    assert done.returncode != 0
    assert "rank 1 fails on purpose" in done.stdout
