"""Parallel sort-last rendering (pv_hdrvol.parallel): distribution along space-filling
curves, tile culling, compositing as a pure function, the serial block-wise render
against the single pass (orthographic and perspective), threads per rank, the same image
under ``mpiexec -n 2`` and ``-n 3``, and the command line against ``pv-hdrvol render``."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import pv_hdrvol as hv
from conftest import REPO_ROOT
from mpirun import mpi_env as _mpi_env, mpiexec as _mpiexec
from pv_hdrvol.culling.cull import visible_blocks
from pv_hdrvol.culling.pof import PlenopticOpacity
from pv_hdrvol.parallel.comm import rank_threads, threads_for
from pv_hdrvol.parallel.composite import composite, tile_grid
from pv_hdrvol.parallel.distribute import assign, curve_order, hilbert_keys, morton_keys
from pv_hdrvol.parallel.render import block_rect, eye_visibility_order, render_parallel
from pv_hdrvol.rays.camera import ray_box_spans
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
    pof = PlenopticOpacity.compute(volume, [tf], block_size=8, threads=1)
    with pytest.raises(ValueError, match="render_parallel with pof= needs an orthographic Camera"):
        render_parallel(volume, tf, hv.Camera.fit(volume.bounds, "iso"), (8, 8), pof=pof, comm=None)
    with pytest.raises(TypeError, match="render_parallel needs a Camera; got str"):
        render_parallel(volume, tf, "iso", (8, 8), comm=None)
    with pytest.raises(ValueError, match="blending='composite' only; got 'maximum'"):
        render_parallel(volume, tf, ortho, (8, 8), comm=None, blending="maximum")
    with pytest.raises(ValueError, match=r"block_size \(6\) must be a multiple of the render's block_size option"):
        render_parallel(volume, tf, ortho, (8, 8), comm=None, block_size=6)
    with pytest.raises(TypeError, match="comm must be an mpi4py communicator, 'world' or None; got int"):
        render_parallel(volume, tf, ortho, (8, 8), comm=3)
    with pytest.raises(ValueError, match="threads must be a positive int or None; got 0"):
        render_parallel(volume, tf, ortho, (8, 8), comm=None, threads=0)


def _blocks_along(eye, direction, origin, extent, shape, length):
    """Flat indices of the blocks a ray from ``eye`` visits, in order (dense samples)."""
    t = np.linspace(1e-6, length, 4000)
    points = eye + t[:, None] * direction
    k = np.floor((points - origin) / extent).astype(int)  # x, y, z
    inside = np.all((k >= 0) & (k < np.array(shape[::-1])), axis=1)
    flat = np.ravel_multi_index((k[inside, 2], k[inside, 1], k[inside, 0]), shape)
    return flat[np.r_[True, np.diff(flat) != 0]] if flat.size else flat


@pytest.mark.parametrize("seed", range(6))
def test_eye_visibility_order_puts_every_block_before_those_behind_it_on_any_ray(seed):
    """A perspective camera's blocks: from eyes inside, beside and far from the grid,
    every ray meets the blocks in increasing order."""
    rng = np.random.default_rng(seed)
    shape = tuple(int(n) for n in rng.integers(2, 7, 3))  # (bz, by, bx)
    extent = rng.uniform(0.5, 2.0, 3)
    origin = rng.uniform(-3, 3, 3)
    size = np.array(shape[::-1]) * extent
    eye = origin + size * rng.uniform(-1.5, 2.5, 3)  # inside the grid for some seeds, outside for others
    if seed == 0:
        eye = origin + size * 0.37  # inside
    order = eye_visibility_order(shape, eye, origin, extent)
    assert sorted(order.tolist()) == list(range(int(np.prod(shape))))
    position = np.empty_like(order)
    position[order] = np.arange(order.size)
    length = float(np.linalg.norm(eye - origin) + 2 * np.linalg.norm(size))
    for direction in rng.normal(size=(300, 3)):
        visited = _blocks_along(eye, direction / np.linalg.norm(direction), origin, extent, shape, length)
        assert np.all(np.diff(position[visited]) > 0), (eye, direction, visited)


def test_block_rect_covers_the_pixels_whose_rays_cross_the_box():
    """Perspective too, and the eye inside the box (whole image) or the box behind it."""
    lo, hi = np.array([2.0, 1.0, 0.5]), np.array([5.0, 3.0, 2.5])
    size = (37, 29)
    for camera in (hv.Camera((12, 9, 7), (3, 2, 1.5), (0, 0, 1)),
                   hv.Camera((3, 2, 1.5), (9, 9, 9), (0, 0, 1), view_angle=120),
                   hv.Camera((12, 9, 7), (3, 2, 1.5), (0, 0, 1), parallel_projection=True, parallel_scale=3)):
        rect = block_rect(lo, hi, camera, size)
        near, _ = ray_box_spans(camera.rays(size), lo, hi)
        hit = np.isfinite(near).reshape(size[1], size[0])
        rows, cols = np.nonzero(hit)
        assert rect is not None and hit.any()
        col, row, w, h = rect
        assert col <= cols.min() and cols.max() < col + w and row <= rows.min() and rows.max() < row + h
    assert block_rect(lo, hi, hv.Camera((3, 2, 1.5), (9, 9, 9), (0, 0, 1)), size) == (0, 0) + size  # eye inside
    assert block_rect(lo, hi, hv.Camera((12, 9, 7), (20, 20, 20), (0, 0, 1)), size) is None  # behind the eye


@pytest.mark.parametrize("view", ["iso", "zoomed", "inside"])
@pytest.mark.parametrize("precision, limit", [("float64", 1e-12), ("float32", 1e-5)])
def test_perspective_block_wise_render_equals_the_single_pass(view, precision, limit):
    """Blocks composited in their order from the eye: a zoomed view (blocks off
    screen) and an eye inside the volume (blocks on every side) too."""
    rng = np.random.default_rng(0)
    volume = as_volume(rng.random((40, 37, 45)))
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1], [1, 1, 1]], [0.0, 0.05, 0.2])
    camera = {"iso": hv.Camera.fit(volume.bounds, "iso"), "zoomed": hv.Camera.fit(volume.bounds, "xz", zoom=2.5),
              "inside": hv.Camera((20, 18, 22), (0, 0, 0), (0, 0, 1), view_angle=100)}[view]
    image = render_parallel(volume, tf, camera, (64, 48), comm=None, precision=precision, termination=0.0,
                            block_size=8)
    full = hv.render(volume, tf, camera, (64, 48), precision=precision, termination=0.0, progress_bar=False)
    assert full.rgba[..., 3].max() > 0.5
    assert np.abs(image.rgba.astype(np.float64) - full.rgba).max() <= limit * np.abs(full.rgba).max()


def test_threads_per_rank_share_the_node_unless_numba_num_threads_is_set():
    assert threads_for(16, 16, 4, 16) == (4, "16 cores, 4 processes on this node")
    assert threads_for(2, 2, 2, 2)[0] == 1 and threads_for(2, 2, 3, 2)[0] == 1  # oversubscribed: still 1
    assert threads_for(16, 16, 1, 8)[0] == 8  # never more than numba's pool
    assert threads_for(4, 16, 4, 16) == (4, "bound to 4 of the node's 16 cores")  # the launcher's share
    import numba

    assert rank_threads(None, environ={"NUMBA_NUM_THREADS": "3"}) == (numba.get_num_threads(), "NUMBA_NUM_THREADS=3")
    threads, reason = rank_threads(None, environ={})
    assert threads == min(len(os.sched_getaffinity(0)), numba.config.NUMBA_NUM_THREADS)
    assert "1 process on this node" in reason or "bound to" in reason


def test_node_size_counts_the_processes_of_this_host_through_sends_and_receives():
    """VTK's processes (a PointToPointComm) have no shared-memory split: host names."""
    from thread_comm import run_spmd

    from pv_hdrvol.parallel.comm import node_size

    results, errors = run_spmd(3, node_size)
    assert errors == [None] * 3 and results == [3, 3, 3]
    assert node_size(None) == 1


@pytest.mark.expected_skip(reason="a one-core machine: numba's pool has one thread, there is no second count")
def test_pixels_do_not_depend_on_the_thread_count():
    """Kernels are per pixel: one thread and two give the same bits (and the count is
    restored after the render)."""
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba's pool has one thread")
    before = numba.get_num_threads()
    rng = np.random.default_rng(1)
    volume = as_volume(rng.random((30, 27, 35)))
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1], [1, 1, 1]], [0.0, 0.05, 0.2])
    camera = hv.Camera.fit(volume.bounds, "iso")
    images = [render_parallel(volume, tf, camera, (61, 47), comm=None, threads=n, block_size=8) for n in (1, 2)]
    assert numba.get_num_threads() == before
    assert [im.metadata["parallel"]["per_rank"][0]["threads"] for im in images] == [1, 2]
    np.testing.assert_array_equal(images[0].rgba, images[1].rgba)



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
    assert len(lines) == 7 and all(f"ranks={ranks} " in line for line in lines), done.stdout[-4000:]


def test_command_line_precomputes_and_renders(tmp_path, capsys):
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.parallel.__main__ import main

    volume, tf = _opaque_scene()
    grid = pv.ImageData(dimensions=volume.dims)
    grid.point_data["v"] = volume.values.reshape(-1)
    grid.save(tmp_path / "vol.vti")
    (tmp_path / "tf.json").write_text(json.dumps(tf.to_dict()))
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


def _smooth_vti(tmp_path, pv):
    """A small image volume (a blob and noise) as a .vti, for the command lines."""
    z, y, x = np.mgrid[0:27, 0:24, 0:30]
    values = np.exp(-((x - 14) ** 2 + (y - 11) ** 2 + (z - 13) ** 2) / 60.0) \
        + 0.05 * np.random.default_rng(3).random(x.shape)
    grid = pv.ImageData(dimensions=(30, 24, 27), spacing=(1.0, 1.2, 0.9), origin=(1.0, -2.0, 0.5))
    grid.point_data["density"] = values.reshape(-1)
    path = tmp_path / "blob.vti"
    grid.save(path)
    return path, grid


#: How far the parallel command line's image may differ from ``pv-hdrvol render``'s, in
#: units of its brightest value: on more than one rank the pieces are composited one
#: after another (measured 8.1e-8 in float32, 2.6e-15 in float64 on 2 and 3 ranks) and
#: early ray termination is per piece (1e-6 of the light); on one rank it is the same
#: image; with --pof the blocks are composited one after another in float32.
CLI_TOLERANCE = 2e-6


def test_command_line_renders_what_pv_hdrvol_render_renders(tmp_path, capsys):
    """Issue 31: the same camera (perspective), size and transfer function by default,
    and the EXR keeps the settings, which render the image again."""
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.integrations.cli import main as cli_main
    from pv_hdrvol.parallel.__main__ import main

    path, grid = _smooth_vti(tmp_path, pv)
    assert cli_main(["render", str(path), "-o", str(tmp_path / "serial.exr"), "--size", "40", "30",
                     "--no-progress"]) == 0
    assert main(["render", str(path), "--serial", "--size", "40", "30", "-o", str(tmp_path / "parallel.exr")]) == 0
    out = capsys.readouterr().out
    assert "40x30, perspective 30 degrees from iso, 1 ranks" in out and "rank 0: " in out
    reference, image = hv.load(tmp_path / "serial.exr"), hv.load(tmp_path / "parallel.exr")
    scale = float(np.abs(reference.rgba).max())
    assert scale > 0.05
    assert np.abs(image.rgba.astype(np.float64) - reference.rgba).max() <= CLI_TOLERANCE * scale
    settings = image.settings()  # raised "holds no render settings" before
    expected = reference.settings()
    assert settings.camera == expected.camera and not settings.camera.parallel_projection
    assert settings.size == (40, 30) and settings.options == expected.options
    assert settings.tf.to_dict() == expected.tf.to_dict()
    again = settings.render(grid, progress_bar=False)
    assert np.abs(again.rgba.astype(np.float64) - image.rgba).max() <= CLI_TOLERANCE * scale
    np.testing.assert_array_equal(again.rgba, reference.rgba)


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_command_line_without_pof_renders_each_ranks_box_as_one_piece(tmp_path, capsys, precision):
    """Without --pof the command renders each rank's box of the volume as one piece
    (render_in_pieces: split_volume, GridPlan.execute(piece=...), gather_pieces), not
    block by block; on one rank that is pv-hdrvol render's image bit for bit, within
    the stated tolerance by far."""
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.integrations.cli import main as cli_main
    from pv_hdrvol.parallel.__main__ import main

    path, _ = _smooth_vti(tmp_path, pv)
    size = ["--size", "40", "30", "--precision", precision]
    assert cli_main(["render", str(path), *size, "-o", str(tmp_path / "serial.npy"), "--no-progress"]) == 0
    for name in ("parallel.npy", "parallel.exr"):
        assert main(["render", str(path), "--serial", *size, "-o", str(tmp_path / name)]) == 0
    out = capsys.readouterr().out
    assert "40x30, perspective 30 degrees from iso, 1 ranks, 1 piece (one box of the volume per rank)" in out
    assert "rank 0: " in out and "piece (0, 0, 0)..(29, 23, 26) points, render " in out and "blocks" not in out
    reference = np.load(tmp_path / "serial.npy")[..., :4]
    image = np.load(tmp_path / "parallel.npy")[..., :4]
    assert image.dtype == reference.dtype == np.dtype(precision)
    assert np.abs(image.astype(np.float64) - reference).max() <= CLI_TOLERANCE * float(np.abs(reference).max())
    np.testing.assert_array_equal(image, reference)
    info = hv.load(tmp_path / "parallel.exr").metadata["parallel"]
    assert info["ranks"] == 1 and info["pieces"] == 1
    (rank,) = info["per_rank"]
    assert rank["piece"] == [[0, 0, 0], [29, 23, 26]] and rank["threads"] >= 1 and rank["samples"] > 0


def test_both_command_lines_say_which_camera_they_use(capsys):
    from pv_hdrvol.integrations.cli import main as cli_main
    from pv_hdrvol.parallel.__main__ import main

    texts = []
    for run in (lambda: cli_main(["render", "--help"]), lambda: main(["render", "--help"])):
        with pytest.raises(SystemExit) as done:
            run()
        assert done.value.code == 0
        texts.append(" ".join(capsys.readouterr().out.split()))
    for text in texts:
        assert "perspective, 30-degree vertical view angle" in text, text
        assert "orthographic" in text and "--pof" in text


def _error_line(capsys, run):
    with pytest.raises(SystemExit) as done:
        run()
    err = capsys.readouterr().err
    assert done.value.code == 2 and "Traceback" not in err, err
    return err.strip().splitlines()[-1]


def test_command_line_errors_are_one_line_naming_the_file_and_the_fix(tmp_path, capsys):
    """Issue 31, part 6: a .vtr, a damaged .pof and an output folder that does not exist
    gave tracebacks."""
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.parallel.__main__ import main

    path, _ = _smooth_vti(tmp_path, pv)
    rect = pv.RectilinearGrid(np.arange(5.0), np.arange(4.0), np.arange(3.0))
    rect.point_data["v"] = np.arange(rect.n_points, dtype=float)
    rect.save(tmp_path / "grid.vtr")
    (tmp_path / "bad.pof.npz").write_bytes(b"not a zip file")
    prefix = "python -m pv_hdrvol.parallel render: error: "

    line = _error_line(capsys, lambda: main(["render", str(tmp_path / "grid.vtr"), "--serial"]))
    assert line.startswith(prefix) and "grid.vtr' holds a RectilinearGrid" in line and "Resample To Image" in line
    line = _error_line(capsys, lambda: main(["render", str(path), "--serial", "--pof", str(tmp_path / "bad.pof.npz")]))
    assert line.startswith(prefix + "--pof: ") and "bad.pof.npz" in line and "python -m pv_hdrvol.parallel pof" in line
    missing = tmp_path / "nodir" / "frame.exr"
    line = _error_line(capsys, lambda: main(["render", str(path), "--serial", "-o", str(missing)]))
    assert line == prefix + f"-o/--output: cannot write {str(missing)!r}: no such folder: {str(missing.parent)!r}"
    line = _error_line(capsys, lambda: main(["render", str(path), "--serial", "--size", "0"]))
    assert line == prefix + "--size takes N or W H, positive; got 0"
    (tmp_path / "tf.json").write_text("{")
    line = _error_line(capsys, lambda: main(["pof", str(path), "--tf", str(tmp_path / "tf.json"), "-o",
                                             str(tmp_path / "nodir" / "v.pof.npz")]))
    assert line.startswith("python -m pv_hdrvol.parallel pof: error: -o/--output: cannot write")
    line = _error_line(capsys, lambda: main(["pof", str(path), "--tf", str(tmp_path / "tf.json"), "-o",
                                             str(tmp_path / "v.pof.npz")]))
    assert "--tf" in line and "tf.json' is not a transfer function" in line




def test_mpi_command_line_shares_the_cores_and_gives_the_serial_image(tmp_path, capsys):
    """Issue 31: each rank ran as many numba threads as the machine has cores. Now the
    ranks on a node share its cores (NUMBA_NUM_THREADS unset); the image is the serial
    one to the command's tolerance (each rank renders one piece), and a user error under
    MPI is one line and exit status 2."""
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.parallel.__main__ import main

    mpiexec = _mpiexec()
    path, _ = _smooth_vti(tmp_path, pv)
    env = _mpi_env()
    env.pop("NUMBA_NUM_THREADS", None)
    command = [mpiexec, "-n", "2", sys.executable, "-m", "pv_hdrvol.parallel", "render", str(path), "--size", "40",
               "30", "-o", str(tmp_path / "mpi.exr")]
    done = subprocess.run(command, env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-4000:]
    import re

    import numba

    ranks = re.findall(r"rank (\d): (\d+) threads? \((\d+) cores, (\d) processes on this node\)", done.stdout)
    assert len(ranks) == 2, done.stdout
    for _, threads, cores, local in ranks:
        assert local == "2" and int(threads) == min(max(1, int(cores) // 2), numba.config.NUMBA_NUM_THREADS)
    assert "2 ranks, 2 pieces (one box of the volume per rank)" in done.stdout, done.stdout
    assert main(["render", str(path), "--serial", "--size", "40", "30", "-o", str(tmp_path / "serial.exr")]) == 0
    # each rank renders one piece: the serial image to rounding (the pieces composited in float64)
    serial = hv.load(tmp_path / "serial.exr").rgba
    assert np.abs(hv.load(tmp_path / "mpi.exr").rgba.astype(np.float64) - serial).max() <= \
        CLI_TOLERANCE * float(np.abs(serial).max())
    done = subprocess.run(command[:-1] + [str(tmp_path / "nodir" / "mpi.exr")], env=env, cwd=REPO_ROOT,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=600)
    assert done.returncode != 0 and "Traceback" not in done.stderr, done.stderr
    errors = [line for line in done.stderr.splitlines() if "error:" in line]
    assert errors == [f"python -m pv_hdrvol.parallel render: error: -o/--output: cannot write "
                      f"{str(tmp_path / 'nodir' / 'mpi.exr')!r}: no such folder: {str(tmp_path / 'nodir')!r}"], \
        done.stderr


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


def _smooth_vtm(tmp_path, pv):
    """A smooth float field cut into 8 extent pieces (2 x 2 x 2, sharing faces) saved as
    a .vtm with one .vti per piece; and the whole lattice volume they gather into."""
    from pv_hdrvol.data.blocks import prepare_blocks

    z, y, x = np.mgrid[0:13, 0:11, 0:15]
    values = np.exp(-((x - 7) ** 2 + (y - 5) ** 2 + (z - 6) ** 2) / 20.0) + 0.02 * np.sin(x + 2 * y)
    grid = pv.ImageData(dimensions=(15, 11, 13), spacing=(1.0, 1.2, 0.9), origin=(1.0, -2.0, 0.5))
    grid.point_data["density"] = values.reshape(-1)
    pieces = [grid.extract_subset((x0, x1, y0, y1, z0, z1)) for z0, z1 in ((0, 6), (6, 12))
              for y0, y1 in ((0, 5), (5, 10)) for x0, x1 in ((0, 8), (8, 14))]
    path = tmp_path / "blob.vtm"
    pv.MultiBlock(pieces).save(path)
    return path, prepare_blocks(pv.read(path)).volume


#: How far ``python -m pv_hdrvol.parallel render FILE.vtm --precision float64`` may
#: differ from the serial ``pv_hdrvol.render(pyvista.read(FILE.vtm))``, relative to its
#: brightest value: the blocks are composited one after another instead of sample by
#: sample (measured 5.5e-16 in float64; an .exr holds float32: 3.6e-8).
VTM_TOLERANCE = 1e-6


def _vtm_reference(path, volume, pv, size=(24, 20)):
    camera = hv.Camera.fit(volume.bounds, "iso")
    return hv.render(pv.read(path), None, camera, size, precision="float64", progress_bar=False)


def test_command_line_renders_a_multiblock_file_as_the_serial_render(tmp_path, capsys):
    """Issue 33 part 5: a .vtm of image blocks on one lattice renders as pieces of one
    volume and equals the serial render (which gathers them), default transfer function
    and all; the image says which blocks and files each rank read."""
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.parallel.__main__ import main

    path, volume = _smooth_vtm(tmp_path, pv)
    reference = _vtm_reference(path, volume, pv)
    assert reference.metadata["blocks"]["kind"] == "grid"
    scale = float(np.abs(reference.rgba).max())
    assert scale > 0.05
    assert main(["render", str(path), "--serial", "--size", "24", "20", "--precision", "float64", "-o",
                 str(tmp_path / "vtm.npy")]) == 0
    out = capsys.readouterr().out
    assert "24x20, perspective 30 degrees from iso, 1 ranks, 8 blocks of" in out
    assert "rank 0: " in out and "8 blocks read and rendered" in out
    image = np.load(tmp_path / "vtm.npy")
    assert image.dtype == np.float64
    assert np.abs(image[..., :4] - reference.rgba).max() <= VTM_TOLERANCE * scale
    assert main(["render", str(path), "--serial", "--size", "24", "20", "--precision", "float64", "-o",
                 str(tmp_path / "vtm.exr")]) == 0
    saved = hv.load(tmp_path / "vtm.exr")
    (rank,) = saved.metadata["parallel"]["per_rank"]
    assert [os.path.basename(f) for f in rank["files"]] == [f"blob_{i}.vti" for i in range(8)]
    assert saved.settings().tf.to_dict() == reference.settings().tf.to_dict()


@pytest.mark.parametrize("ranks, counts", [(2, [4, 4]), (3, [3, 2, 3])])
def test_mpi_ranks_read_only_their_own_blocks_of_a_multiblock_file(tmp_path, ranks, counts):
    """Issue 33 part 5: each rank reads its own contiguous run of the .vtm's leaf files
    (8 equal blocks: 4 + 4, 3 + 2 + 3) and the composite is the serial render."""
    pv = pytest.importorskip("pyvista")
    mpiexec = _mpiexec()
    path, volume = _smooth_vtm(tmp_path, pv)
    out = tmp_path / "mpi.exr"
    done = subprocess.run([mpiexec, "-n", str(ranks), sys.executable, "-m", "pv_hdrvol.parallel", "render", str(path),
                           "--size", "24", "20", "--precision", "float64", "-o", str(out)],
                          env=_mpi_env(NUMBA_NUM_THREADS="1"), cwd=REPO_ROOT, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-4000:]
    assert f"{ranks} ranks, 8 blocks of" in done.stdout, done.stdout
    image = hv.load(out)
    per_rank = image.metadata["parallel"]["per_rank"]
    assert [len(s["blocks"]) for s in per_rank] == counts
    first = np.concatenate([[0], np.cumsum(counts)])
    for r, s in enumerate(per_rank):
        assert s["rank"] == r
        assert [os.path.basename(f) for f in s["files"]] == [f"blob_{i}.vti" for i in range(first[r], first[r + 1])]
    reference = _vtm_reference(path, volume, pv)
    scale = float(np.abs(reference.rgba).max())
    # an .exr holds float32: the float64 composite rounded once
    assert np.abs(image.rgba.astype(np.float64) - reference.rgba).max() <= VTM_TOLERANCE * scale


def test_command_line_refuses_multiblock_files_it_would_render_otherwise_than_serial(tmp_path, capsys):
    """Blocks with a hole between them, a leaf that is not image data, and --pof: one
    line each, naming what is not supported in parallel and what to do."""
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.parallel.__main__ import main

    path, _ = _smooth_vtm(tmp_path, pv)
    blocks = pv.read(path)
    hole = tmp_path / "hole.vtm"
    pv.MultiBlock([blocks[i] for i in range(7)]).save(hole)
    rect = pv.RectilinearGrid(np.arange(5.0), np.arange(4.0), np.arange(3.0))
    rect.point_data["density"] = np.arange(rect.n_points, dtype=float)
    mixed = tmp_path / "mixed.vtm"
    pv.MultiBlock([blocks[0], rect]).save(mixed)
    prefix = "python -m pv_hdrvol.parallel render: error: "
    output = str(tmp_path / "x.npy")

    line = _error_line(capsys, lambda: main(["render", str(hole), "--serial", "-o", output]))
    assert line == prefix + (f"the image blocks leave holes in their union box ((15, 11, 13) points): they hold 1500 "
                             f"of its 1680 cells; python -m pv_hdrvol.parallel renders blocks that tile one box; "
                             f"render it serially with: pv-hdrvol render {hole}")
    line = _error_line(capsys, lambda: main(["render", str(mixed), "--serial", "-o", output]))
    assert line == prefix + (f"block 'Block-01' (mixed_1.vtr) is a rectilinear grid: python -m pv_hdrvol.parallel "
                             f"renders .vtm files of image blocks (.vti) only; render it serially with: pv-hdrvol "
                             f"render {mixed}")
    line = _error_line(capsys, lambda: main(["render", str(path), "--serial", "--pof", "x.pof.npz", "-o", output]))
    assert line == prefix + (f"--pof culls the blocks of one image volume; {str(path)!r} is a multiblock file: leave "
                             f"out --pof")
