"""Guards a newcomer met (issue 18): few kernel dtypes, empty renders that say why,
memory estimates, interruptible renders, PyVista's keywords."""
import re

import numpy as np
import pytest

import pv_hdrvol as hv

pytestmark = pytest.mark.core

TF = hv.TransferFunction.ramp(-200.0, 200.0, cmap="gray", opacity=(0.0, 0.3))


def _integers(dtype, shape=(9, 10, 11)):
    info = np.iinfo(dtype)
    rng = np.random.default_rng(18)
    return rng.integers(max(info.min, -200), min(info.max, 200), size=shape, endpoint=True).astype(dtype)


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.uint16, np.int32, np.uint32, np.int64])
def test_integer_volumes_reach_the_kernels_as_float32(dtype):
    vals = _integers(dtype)
    vol = hv.volume_from_array(vals)
    assert vol.values.dtype == np.float32 and vol.integer
    np.testing.assert_array_equal(vol.values, vals.astype(np.float64))
    assert vals.dtype == dtype  # the caller's array is untouched


def test_only_three_dtypes_reach_the_kernels():
    assert hv.volume_from_array(np.zeros((2, 2, 2), np.uint8)).values.dtype == np.uint8
    assert hv.volume_from_array(np.zeros((2, 2, 2), np.float16)).values.dtype == np.float32
    assert hv.volume_from_array(np.zeros((2, 2, 2), np.float64)).values.dtype == np.float64
    # integers beyond 2**24 do not all fit in float32: float64
    big = np.full((2, 2, 2), 2**24, np.int64)
    assert hv.volume_from_array(big).values.dtype == np.float32
    big[0, 0, 0] = 2**24 + 1
    assert hv.volume_from_array(big).values.dtype == np.float64
    assert hv.volume_from_array(-big).values.dtype == np.float64
    assert hv.volume_from_array(np.full((2, 2, 2), 2**40, np.uint64)).values.dtype == np.float64


@pytest.mark.parametrize("dtype", [np.int8, np.int16])
@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_int8_and_int16_render_bit_identically_to_their_float32_copies(dtype, precision):
    vals = _integers(dtype)
    a = hv.render(vals, TF, None, (24, 24), precision=precision)
    b = hv.render(vals.astype(np.float32), TF, None, (24, 24), precision=precision)
    np.testing.assert_array_equal(a.rgba, b.rgba)
    np.testing.assert_array_equal(a.depth, b.depth)


def test_integer_data_keeps_a_linear_default_transfer_function():
    # as before the conversion: integer data (CT numbers) spanning > 3 decades is not
    # put on a log axis, only floating-point data is
    from pv_hdrvol.raycast.grid import default_transfer_function

    vals = np.geomspace(1, 5000, 5000).round().astype(np.int16).reshape(10, 20, 25)
    assert default_transfer_function(hv.volume_from_array(vals)).scale == "linear"
    assert default_transfer_function(hv.volume_from_array(vals.astype(np.float32))).scale == "log"


# -- empty renders say why ------------------------------------------------------------
from pv_hdrvol.raycast.grid import EmptyRenderWarning  # noqa: E402

GRAY_TF = hv.TransferFunction.ramp(0.0, 2.0, cmap="gray", opacity=(0.5, 0.5))


def _no_warning(*args, **kwargs):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", EmptyRenderWarning)
        return hv.render(*args, **kwargs)


@pytest.mark.parametrize("shape", [(5, 5, 1), (1, 4, 4), (1, 1, 1)])
def test_a_flat_numpy_volume_renders_empty_with_a_warning(shape):
    with pytest.warns(EmptyRenderWarning, match=r"^the volume is flat \(one point thick along an axis\): rays "
                                                r"cross no thickness, so the image is empty; a 2-D image cannot "
                                                r"be volume rendered$"):
        img = hv.render(np.ones(shape), GRAY_TF, None, (8, 8))
    assert not img.rgba.any()


@pytest.mark.parametrize("fill", [np.nan, np.inf, -np.inf])
def test_a_volume_without_finite_values_warns(fill):
    vals = np.full((4, 5, 6), fill)
    with pytest.warns(EmptyRenderWarning, match=r"^the volume has no finite value \(all NaN or \+-inf\), so the "
                                                r"image is empty$"):
        img = hv.render(vals, None, None, (8, 8))
    assert not img.rgba.any()
    assert np.isnan(vals).all() or np.isinf(vals).all()  # the caller's data is untouched


def test_constant_data_with_the_default_transfer_function_warns():
    with pytest.warns(EmptyRenderWarning) as record:
        img = hv.render(np.full((4, 5, 6), 3.0), None, None, (8, 8))
    assert not img.rgba.any()
    assert str(record[0].message) == (
        "the transfer function's opacity is 0 over the whole data range [3, 3] (transfer function range [3, 4], "
        "scale='linear'), so the image is empty; the data is constant (3) and the default transfer function's "
        "opacity is 0 there: pass a tf with opacity at that value")
    # with a transfer function that is opaque there, the same data renders and says nothing
    assert _no_warning(np.full((4, 5, 6), 3.0), hv.TransferFunction.ramp(0, 4, opacity=(1, 1)), None,
                       (8, 8)).rgba[..., 3].max() > 0


def test_a_log_axis_over_data_without_positive_values_warns():
    tf = hv.TransferFunction.ramp(1e-3, 1e3, scale="log", cmap="gray")
    vals = -np.linspace(0, 5, 4 * 5 * 6).reshape(4, 5, 6)
    with pytest.warns(EmptyRenderWarning) as record:
        img = hv.render(vals, tf, None, (8, 8))
    assert not img.rgba.any()
    assert str(record[0].message) == (
        "the transfer function's opacity is 0 over the whole data range [-5, -0] (transfer function range "
        "[0.001, 1000], scale='log'), so the image is empty; a log axis maps values <= 0 below its range and "
        "the data has no positive value")


def test_a_valid_render_does_not_warn_and_a_projection_keeps_its_values():
    vals = np.linspace(0, 1, 4 * 5 * 6).reshape(4, 5, 6)
    assert _no_warning(vals, None, None, (8, 8)).rgba[..., 3].max() > 0
    # a zero-opacity transfer function still gives a projection its value image
    zero = hv.TransferFunction.ramp(0, 1, cmap="gray", opacity=(0, 0))
    assert np.nanmax(_no_warning(vals, zero, None, (8, 8), blending="maximum").value) > 0


@pytest.mark.parametrize("dims,preference,got", [
    ((8, 8, 1), "point", "dimensions (8, 8, 1)"),
    ((1, 1, 1), "point", "dimensions (1, 1, 1)"),
    ((6, 6, 2), "cell", "(5, 5, 1) cells of cell data 'c'"),
])
def test_a_2d_image_dataset_is_refused_like_a_2d_array(dims, preference, got):
    pv = pytest.importorskip("pyvista")
    grid = pv.ImageData(dimensions=dims)
    if preference == "cell":
        grid["c"] = np.ones(grid.n_cells)
    else:
        grid["p"] = np.ones(grid.n_points)
    what = "cells" if preference == "cell" else "points"
    with pytest.raises(ValueError, match=rf"^image data must be 3-D, with at least 2 {what} along every axis; "
                                         rf"got {re.escape(got)}: a 2-D image or a single voxel has no "
                                         rf"thickness to render$"):
        hv.render(grid, GRAY_TF, None, (8, 8))
    with pytest.raises(ValueError, match=r"^volume values must be a 3-D array; got 2-D"):
        hv.render(np.ones((8, 8)), GRAY_TF, None, (8, 8))


def test_a_mesh_with_constant_values_warns():
    pv = pytest.importorskip("pyvista")
    mesh = pv.ImageData(dimensions=(3, 3, 3)).triangulate()
    mesh["s"] = np.full(mesh.n_points, 2.0)
    with pytest.warns(EmptyRenderWarning, match=r"^the transfer function's opacity is 0 over the whole data "
                                                r"range \[2, 2\] .*the data is constant \(2\)"):
        img = hv.render(mesh, None, None, (8, 8))
    assert not img.rgba.any()
    mesh["s"] = np.full(mesh.n_points, np.nan)
    with pytest.warns(EmptyRenderWarning, match=r"^the mesh has no finite value"):
        hv.render(mesh, None, None, (8, 8))


def test_the_cli_prints_the_warning_on_stderr(tmp_path):
    pv = pytest.importorskip("pyvista")
    import os
    import subprocess
    import sys

    grid = pv.ImageData(dimensions=(6, 6, 6))
    grid["v"] = np.full(grid.n_points, 2.0)
    grid.save(tmp_path / "const.vti")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = {**os.environ, "PYTHONPATH": root, "PYTHONWARNINGS": ""}
    result = subprocess.run([sys.executable, "-m", "pv_hdrvol.integrations.cli", "render", str(tmp_path / "const.vti"),
                             "-o", str(tmp_path / "c.npy"), "--size", "8", "--no-progress"],
                            capture_output=True, text=True, timeout=600, env=env)
    assert result.returncode == 0, result.stderr
    assert "EmptyRenderWarning: the transfer function's opacity is 0 over the whole data range [2, 2]" \
        in result.stderr


# -- memory ---------------------------------------------------------------------------
from pv_hdrvol.raycast import memory  # noqa: E402
from pv_hdrvol.raycast.grid import render_bytes  # noqa: E402

# a (16, 16, 16) float32 volume rendered at 100x100 in float32:
IMAGE_BYTES = 100 * 100 * (4 * 4 + 8 + 8)  # rgba float32, depth float64, samples int64
BLOCK_BYTES = 4**3 * 16  # 4 blocks of 4 cells along each axis, min and max in float64
BRICK_BYTES = 3**3 * 9**3 * 4  # 16 // 8 + 1 bricks along each axis of 9**3 float32 points


def test_a_render_larger_than_the_free_memory_is_refused_before_it_starts(monkeypatch):
    vol = hv.volume_from_array(np.zeros((16, 16, 16), np.float32))
    needed = IMAGE_BYTES + BLOCK_BYTES + BRICK_BYTES
    assert needed == 399756
    monkeypatch.setattr(memory, "available_memory", lambda: needed - 1)
    with pytest.raises(memory.RenderMemoryError, match=re.escape(
            "this render needs about 390.4 KiB (399756 bytes: image 312.5 KiB, block ranges 1.0 KiB, bricks "
            "76.9 KiB) but only 390.4 KiB of memory is available; try a smaller size (now 100x100) or a "
            "subvolume (e.g. values[::2, ::2, ::2])")) as err:
        hv.render(vol, GRAY_TF, None, (100, 100))
    assert (err.value.needed, err.value.available) == (needed, needed - 1)
    assert isinstance(err.value, MemoryError)
    assert vol.cache == {}  # refused before building anything
    monkeypatch.setattr(memory, "available_memory", lambda: needed)
    hv.render(vol, GRAY_TF, None, (100, 100))
    # what the first render built stays on the volume: the next one needs the image only
    monkeypatch.setattr(memory, "available_memory", lambda: IMAGE_BYTES)
    hv.render(vol, GRAY_TF, None, (100, 100))
    monkeypatch.setattr(memory, "available_memory", lambda: IMAGE_BYTES - 1)
    with pytest.raises(memory.RenderMemoryError, match=r"^this render needs about 312.5 KiB \(320000 bytes: "
                                                      r"image 312.5 KiB\)"):
        hv.render(vol, GRAY_TF, None, (100, 100))


def test_the_estimate_names_every_copy_a_float64_render_makes():
    vol = hv.volume_from_array(np.zeros((16, 16, 16)))
    opts = hv.RenderOptions()
    assert render_bytes(vol, GRAY_TF, opts, 100, 100) == {
        "image": IMAGE_BYTES, "float32 copy of the volume": 16**3 * 4, "block ranges": BLOCK_BYTES,
        "bricks": BRICK_BYTES}
    assert render_bytes(vol, GRAY_TF, opts.replace(precision="float64"), 100, 100) == {
        "image": 100 * 100 * (4 * 8 + 8 + 8), "block ranges": BLOCK_BYTES, "bricks": BRICK_BYTES * 2}
    # the image the newcomer asked for: 16,384 squared pixels need 8 GiB before any volume
    assert render_bytes(vol, GRAY_TF, opts, 16384, 16384)["image"] == 8 * 2**30


def test_the_advice_names_float64_data_and_precision(monkeypatch):
    monkeypatch.setattr(memory, "available_memory", lambda: 0)
    with pytest.raises(memory.RenderMemoryError, match=re.escape(
            "try a smaller size (now 8x6), a subvolume (e.g. values[::2, ::2, ::2]), float32 data instead of "
            "float64 or precision='float32'")):
        hv.render(np.zeros((4, 4, 4)), GRAY_TF, None, (8, 6), precision="float64")


def test_without_a_memory_figure_there_is_no_check(monkeypatch):
    """A render whose estimate no machine has (its image counted as 2**60 bytes) is
    refused under any memory figure, and renders, unchanged, without one."""
    from pv_hdrvol.raycast import grid

    estimate = grid.render_bytes
    monkeypatch.setattr(grid, "render_bytes", lambda *a, **k: {**estimate(*a, **k), "image": 2**60})
    monkeypatch.setattr(memory, "available_memory", lambda: 2**50)
    with pytest.raises(memory.RenderMemoryError, match=r"^this render needs about 1048576.0 TiB"):
        hv.render(np.ones((4, 4, 4)), GRAY_TF, None, (8, 8), precision="float64")
    monkeypatch.setattr(memory, "available_memory", lambda: None)
    image = hv.render(np.ones((4, 4, 4)), GRAY_TF, None, (8, 8), precision="float64")
    monkeypatch.undo()
    np.testing.assert_array_equal(image.rgba, hv.render(np.ones((4, 4, 4)), GRAY_TF, None, (8, 8),
                                                        precision="float64").rgba)
    assert image.rgba[..., 3].max() > 0


def test_available_memory_reads_memavailable(tmp_path, monkeypatch):
    path = tmp_path / "meminfo"
    path.write_text("MemTotal:       16318408 kB\nMemFree:          512000 kB\nMemAvailable:    8000000 kB\n")
    monkeypatch.setattr(memory.sys, "platform", "linux")
    assert memory.available_memory(str(path)) == 8000000 * 1024


def test_a_mesh_render_larger_than_the_free_memory_is_refused(monkeypatch):
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.raycast import tets

    grid = pv.ImageData(dimensions=(3, 3, 3)).triangulate()
    grid["s"] = np.linspace(0, 1, grid.n_points)
    mesh = hv.tetmesh_from_dataset(grid)
    parts = tets.render_bytes(mesh, "float32", 8, 8)
    assert parts["image"] == 64 * (16 + 25) and parts["cell records"] == mesh.n_cells * 64 + 64
    needed = sum(parts.values())
    monkeypatch.setattr(memory, "available_memory", lambda: needed - 1)
    with pytest.raises(memory.RenderMemoryError, match=r"try a smaller size \(now 8x8\) or a part of the mesh"):
        hv.render(mesh, None, None, (8, 8))
    monkeypatch.setattr(memory, "available_memory", lambda: needed)
    assert hv.render(mesh, None, None, (8, 8)).shape == (8, 8)


def test_the_2048_cubed_volume_of_the_issue_needs_its_11_5_gib_of_bricks():
    # a uint8 2048**3 volume (a zero-stride view: no memory) rendered at 512x512
    values = np.broadcast_to(np.zeros(1, np.uint8), (2048, 2048, 2048))
    vol = hv.GridVolume(values, np.zeros(3), np.ones(3), (0.0, 0.0), False)
    parts = render_bytes(vol, GRAY_TF, hv.RenderOptions(), 512, 512)
    assert parts == {"image": 512 * 512 * 32, "block ranges": 512**3 * 16, "bricks": 257**3 * 9**3}
    assert memory.format_bytes(parts["bricks"]) == "11.5 GiB"


# -- chunks, interrupts, the automatic bar ---------------------------------------------
import sys  # noqa: E402
import types  # noqa: E402

from pv_hdrvol.raycast import frame as F  # noqa: E402


class FakeCast:
    """A render of ``height`` rows taking ``seconds_per_row`` each on a fake clock."""

    def __init__(self, monkeypatch, seconds_per_row, interrupt_at=None):
        self.now, self.calls, self.per_row, self.interrupt_at = 0.0, [], seconds_per_row, interrupt_at
        monkeypatch.setattr(F, "_clock", lambda: self.now)

    def __call__(self, tile_rows):
        if self.interrupt_at is not None and len(self.calls) == self.interrupt_at:
            raise KeyboardInterrupt  # what Ctrl-C raises once a chunk returns
        self.calls.append(tile_rows.tolist())
        self.now += self.per_row * tile_rows.size * F.TILE
        return tile_rows.size * F.TILE


class FakeBar:
    made = []

    def __init__(self, *args, **kwargs):
        self.updates, self.closed = [], False
        FakeBar.made.append(self)

    def update(self, n):
        self.updates.append(n)

    def close(self):
        self.closed = True


@pytest.fixture
def fake_bar(monkeypatch):
    FakeBar.made = []
    monkeypatch.setattr(F, "tqdm_bar", lambda enabled, total, quiet_without_tqdm=False:
                        FakeBar() if enabled else None)
    return FakeBar.made


def _covered(calls):
    rows = sorted(r for call in calls for r in call)
    return rows


@pytest.mark.parametrize("progress_bar", [None, False])
def test_a_quick_render_runs_in_a_few_calls_and_shows_no_bar(monkeypatch, fake_bar, progress_bar):
    cast = FakeCast(monkeypatch, 1e-4)  # 512 rows: 0.05 s
    monkeypatch.setattr(F, "auto_bar_wanted", lambda: True)
    F.run_in_chunks(cast, 512, progress_bar=progress_bar)
    # the middle row, chunks doubling until 15 >= 64 / 8 rows are timed, then the rest
    assert [len(c) for c in cast.calls] == [1, 2, 4, 8, 49] and cast.calls[:2] == [[32], [0, 33]]
    assert _covered(cast.calls) == list(range(64))
    assert fake_bar == []


@pytest.mark.parametrize("progress_bar", [None, False])
def test_a_slow_render_runs_in_quarter_second_chunks_whatever_the_bar(monkeypatch, fake_bar, progress_bar):
    cast = FakeCast(monkeypatch, 0.01)  # 80 ms a tile row, 5.12 s in all: 63 rows left
    F.run_in_chunks(cast, 512, progress_bar=progress_bar)
    # the middle row, then chunks of at most int(0.25 / 0.08) = 3 rows (0.24 s), spread out
    assert [len(c) for c in cast.calls] == [1, 2] + [3] * 20 + [1]
    assert cast.calls[:3] == [[32], [0, 33], [8, 16, 49]] and _covered(cast.calls) == list(range(64))
    assert fake_bar == []  # stderr is no terminal under pytest


def test_chunks_follow_the_rate_measured_so_far(monkeypatch):
    # the middle row looks cheap (1 ms), the others cost 0.1 s: after one chunk of all
    # the rest would be 6.3 s, the chunks shrink to what 0.25 s allows at the rate seen
    cast = FakeCast(monkeypatch, 0.0)
    costs = {32: 0.001}

    def timed(tile_rows):
        cast.now += sum(costs.get(r, 0.1) for r in tile_rows.tolist())
        cast.calls.append(tile_rows.tolist())
        return tile_rows.size * F.TILE

    monkeypatch.setattr(F, "AUTO_BAR_SECONDS", 0.0)
    F.run_in_chunks(timed, 512, progress_bar=False)
    sizes = [len(c) for c in cast.calls]
    # 0.001 s a row would allow 250 rows: the chunks double instead (2 rows, 0.2 s); then
    # the rate is 0.1 s a row, and int(0.25 / 0.1) = 2 rows a chunk
    assert sizes == [1] + [2] * 31 + [1] and _covered(cast.calls) == list(range(64))


def test_spread_order_is_bit_reversed():
    assert F._spread_order(np.arange(8)).tolist() == [0, 4, 2, 6, 1, 5, 3, 7]
    order = F._spread_order(np.arange(100) * 2)
    assert sorted(order.tolist()) == list(range(0, 200, 2))


def test_the_automatic_bar_shows_for_slow_renders_on_a_terminal_only(monkeypatch, fake_bar):
    monkeypatch.setattr(F, "auto_bar_wanted", lambda: True)
    cast = FakeCast(monkeypatch, 0.01)
    F.run_in_chunks(cast, 512)
    (bar,) = fake_bar
    assert bar.updates == [8, 16] + [24] * 20 + [8] and bar.closed
    F.run_in_chunks(FakeCast(monkeypatch, 0.01), 512, progress_bar=False)
    assert len(fake_bar) == 1


def test_auto_bar_wanted_on_a_terminal_or_in_a_jupyter_kernel(monkeypatch):
    class Stream:
        def __init__(self, tty):
            self.tty = tty

        def isatty(self):
            return self.tty

    monkeypatch.delitem(sys.modules, "IPython", raising=False)
    monkeypatch.setattr(sys, "stderr", Stream(False))
    assert F.auto_bar_wanted() is False
    monkeypatch.setattr(sys, "stderr", Stream(True))
    assert F.auto_bar_wanted() is True
    monkeypatch.setattr(sys, "stderr", None)
    assert F.auto_bar_wanted() is False
    # IPython in a terminal (no kernel) and in a Jupyter kernel, stderr not a terminal
    monkeypatch.setattr(sys, "stderr", Stream(False))
    fake = types.ModuleType("IPython")
    fake.get_ipython = lambda: types.SimpleNamespace()
    monkeypatch.setitem(sys.modules, "IPython", fake)
    assert F.auto_bar_wanted() is False
    fake.get_ipython = lambda: types.SimpleNamespace(kernel=object())
    assert F.auto_bar_wanted() is True
    fake.get_ipython = lambda: None
    assert F.auto_bar_wanted() is False


def test_an_interrupt_between_chunks_propagates_and_closes_the_bar(monkeypatch, fake_bar):
    cast = FakeCast(monkeypatch, 0.01, interrupt_at=5)
    with pytest.raises(KeyboardInterrupt):
        F.run_in_chunks(cast, 512, progress_bar=True)
    assert len(cast.calls) == 5 and fake_bar[0].closed


def test_an_interrupted_render_leaves_nothing_half_done():
    vals = np.linspace(0, 1, 10 * 11 * 12).reshape(10, 11, 12)
    vol = hv.volume_from_array(vals)
    seen = []

    def hook(fraction):
        seen.append(fraction)
        if len(seen) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        hv.render(vol, GRAY_TF, None, (40, 256), progress=hook)
    # 32 rows of tiles: the middle one, then 2 (chunks double while 8 * rows < 32)
    assert seen == [8 / 256, 24 / 256]
    # the interrupted render's volume renders as a fresh one: no half-built state
    again = hv.render(vol, GRAY_TF, None, (40, 256))
    fresh = hv.render(hv.volume_from_array(vals), GRAY_TF, None, (40, 256), progress_bar=False)
    np.testing.assert_array_equal(again.rgba, fresh.rgba)
    np.testing.assert_array_equal(again.depth, fresh.depth)


@pytest.mark.parametrize("seconds_per_tick,sizes", [(0.0, [1, 2, 6]), (1.0, [1] * 9)])
def test_chunking_changes_no_pixel(monkeypatch, seconds_per_tick, sizes):
    # a clock that stands still (the rest in one call once 8 * rows >= 9) or moves by
    # 1 s a reading (every row of tiles alone)
    import itertools

    vals = np.linspace(0, 1, 10 * 11 * 12).reshape(10, 11, 12)
    ref = hv.render(vals, GRAY_TF, None, (40, 72), progress_bar=False, precision="float64")
    ticks = itertools.count(0.0, seconds_per_tick)
    monkeypatch.setattr(F, "_clock", lambda: next(ticks))
    calls = []
    run = F.run_in_chunks

    def spy(cast, *args):
        return run(lambda rows: calls.append(rows.tolist()) or cast(rows), *args)

    monkeypatch.setattr(F, "run_in_chunks", spy)
    img = hv.render(vals, GRAY_TF, None, (40, 72), progress_bar=False, precision="float64")
    assert [len(c) for c in calls] == sizes
    np.testing.assert_array_equal(img.rgba, ref.rgba)
    np.testing.assert_array_equal(img.depth, ref.depth)


# -- PyVista's add_volume keywords: one meaning, in the core ---------------------------
from pv_hdrvol.raycast.grid import default_transfer_function  # noqa: E402


def _grid(pv):
    grid = pv.ImageData(dimensions=(8, 9, 10))
    grid["v"] = np.linspace(0.5, 6.0, grid.n_points)  # one sign: a signed field's default is tested below
    return grid


@pytest.mark.parametrize("name", ["linear", "linear_r", "geom", "geom_r", "sigmoid", "sigmoid_r", "sigmoid_5",
                                  "sigmoid_10_r", "foreground"])
def test_pyvista_opacity_names_give_pyvistas_curve(name):
    pv = pytest.importorskip("pyvista")
    tf = default_transfer_function(hv.volume_from_dataset(_grid(pv)), opacity=name, clim=(0.0, 4.0), cmap="gray")
    np.testing.assert_array_equal(tf.opacities, pv.opacity_transfer_function(name, 256) / 255.0)
    np.testing.assert_array_equal(tf.values, np.linspace(0.0, 4.0, 256))
    np.testing.assert_array_equal(tf.colors, np.repeat(np.linspace(0.0, 1.0, 256)[:, None], 3, axis=1))
    assert tf.scale == "linear"


def test_each_keyword_replaces_one_choice_of_the_default():
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.data.transfer import colormap_rgb

    vol = hv.volume_from_dataset(_grid(pv))
    auto = default_transfer_function(vol)
    cmap = default_transfer_function(vol, cmap="viridis")  # colours only; the colormap whole
    assert (cmap.vmin, cmap.vmax, cmap.scale) == (auto.vmin, auto.vmax, auto.scale)
    np.testing.assert_array_equal(cmap.opacities, auto.opacities)
    np.testing.assert_array_equal(cmap.colors, colormap_rgb("viridis", np.linspace(0, 1, auto.values.size)))
    assert (default_transfer_function(vol, clim=3).vmin, default_transfer_function(vol, clim=3).vmax) == (-3.0, 3.0)
    high = default_transfer_function(vol, clim=(None, 5.0))  # one end: the other stays the default's
    assert (high.vmin, high.vmax) == (auto.vmin, 5.0)
    np.testing.assert_array_equal(default_transfer_function(vol, opacity=0.25).opacities, np.full(64, 0.25))
    spread = default_transfer_function(vol, opacity=[0.0, 1.0, 0.5])
    expected = np.interp(np.linspace(0, 1, 64), [0.0, 0.5, 1.0], [0.0, 1.0, 0.5])
    np.testing.assert_array_equal(spread.opacities, expected)
    assert default_transfer_function(vol, scale="symlog").scale == "symlog"


def test_the_keywords_replace_single_choices_of_a_signed_default_too():
    """A signed field's default (symmetric range, diverging colours, opacity by
    magnitude, 129 points) keeps its other choices when one keyword replaces one."""
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.data.transfer import colormap_rgb

    grid = _grid(pv)
    grid["v"] = np.linspace(-4.0, 6.0, grid.n_points)
    vol = hv.volume_from_dataset(grid)
    auto = default_transfer_function(vol)
    assert auto.values.size == 129 and auto.vmin == -auto.vmax and auto.opacity_at(0.0) == 0.0
    cmap = default_transfer_function(vol, cmap="viridis")
    np.testing.assert_array_equal(cmap.opacities, auto.opacities)
    np.testing.assert_array_equal(cmap.colors, colormap_rgb("viridis", np.linspace(0, 1, 129)))
    np.testing.assert_array_equal(default_transfer_function(vol, opacity=0.25).opacities, np.full(129, 0.25))
    assert (default_transfer_function(vol, clim=3).vmin, default_transfer_function(vol, clim=3).vmax) == (-3.0, 3.0)
    high = default_transfer_function(vol, clim=(None, 5.0))
    assert (high.vmin, high.vmax) == (auto.vmin, 5.0)


def test_the_keywords_work_on_meshes_too():
    pv = pytest.importorskip("pyvista")
    mesh = pv.ImageData(dimensions=(3, 3, 3)).triangulate()
    mesh["s"] = np.linspace(1.0, 5.0, mesh.n_points)
    tf = default_transfer_function(hv.tetmesh_from_dataset(mesh), opacity="sigmoid", clim=(1.0, 5.0))
    assert (tf.vmin, tf.vmax) == (1.0, 5.0)
    np.testing.assert_array_equal(mesh.hdrvol.render(opacity="sigmoid", clim=(1.0, 5.0), size=8).rgba,
                                  hv.render(mesh, tf, size=8).rgba)


@pytest.mark.parametrize("kwargs,exc,msg", [
    (dict(tf=TF, cmap="gray"), TypeError, r"^pass either tf= or cmap=, not both: a TransferFunction sets colour, "
                                          r"opacity, range and axis already$"),
    (dict(tf=TF, clim=(0, 1), opacity="linear"), TypeError, r"^pass either tf= or clim=, opacity=, not"),
    (dict(opacity="sigmod"), ValueError, r"^opacity='sigmod' is not a PyVista opacity transfer function: "
                                         r"Opacity transfer function \(sigmod\) unknown"),
    (dict(opacity=1.5), ValueError, r"^opacity values must lie in \[0, 1\]; got 1.5$"),
    (dict(opacity=[0.5]), ValueError, r"^opacity must be one number or a 1-D sequence of at least 2; got shape "
                                      r"\(1,\)$"),
    (dict(opacity=True), TypeError, r"^opacity must be a PyVista opacity name, a number or a sequence of "
                                    r"numbers; got True$"),
    (dict(clim=(4, 1)), ValueError, r"^clim must be finite with high > low; got \(4, 1\)$"),
    (dict(clim=(None, -5.0)), ValueError, r"^clim \(-?[0-9.]+, -5.0\) \(the ends not given are the default's\) "
                                          r"must have high > low; give both ends$"),
    (dict(clim="0 4"), TypeError, r"^clim must be \(low, high\) or a number c meaning \(-c, c\); got '0 4'$"),
    (dict(cmap="nope"), ValueError, r"^cmap 'nope' is not a matplotlib colormap name$"),
    (dict(scale="ln"), ValueError, r"^scale must be one of \['linear', 'log', 'symlog'\]; got 'ln'$"),
])
def test_pyvista_keywords_reject_bad_input(kwargs, exc, msg):
    pv = pytest.importorskip("pyvista")
    with pytest.raises(exc, match=msg):
        _grid(pv).hdrvol.render(size=8, **kwargs)
    with pytest.raises(exc, match=msg):
        hv.render(_grid(pv), size=8, **kwargs)


def test_chunking_changes_no_pixel_of_a_mesh(monkeypatch):
    pv = pytest.importorskip("pyvista")
    import itertools

    mesh = pv.ImageData(dimensions=(5, 5, 5)).triangulate()
    mesh["s"] = np.linspace(0.0, 1.0, mesh.n_points)
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray", opacity=(0.1, 0.6))
    monkeypatch.setattr(F, "_clock", lambda: 0.0)
    ref = hv.render(mesh, tf, None, (40, 72), progress_bar=False, precision="float64")
    ticks = itertools.count(0.0, 1.0)  # every row of tiles alone
    monkeypatch.setattr(F, "_clock", lambda: next(ticks))
    img = hv.render(mesh, tf, None, (40, 72), progress_bar=False, precision="float64")
    assert img.rgba[..., 3].max() > 0.5
    np.testing.assert_array_equal(img.rgba, ref.rgba)
    np.testing.assert_array_equal(img.depth, ref.depth)


def test_the_cli_reports_a_render_too_large_as_a_user_error(tmp_path, monkeypatch, capsys):
    pv = pytest.importorskip("pyvista")
    from pv_hdrvol.integrations.cli import main

    grid = pv.ImageData(dimensions=(6, 6, 6))
    grid["v"] = np.linspace(0.0, 1.0, grid.n_points)
    grid.save(tmp_path / "v.vti")
    monkeypatch.setattr(memory, "available_memory", lambda: 1000)
    with pytest.raises(SystemExit) as exit_info:
        main(["render", str(tmp_path / "v.vti"), "-o", str(tmp_path / "v.npy"), "--size", "64", "--no-progress"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert ("pv-hdrvol render: error: this render needs about 131.8 KiB (134980 bytes: image 128.0 KiB, "
            "float32 copy of the volume 864 bytes, block ranges 128 bytes, bricks 2.8 KiB) but only 1000 bytes "
            "of memory is available; try a smaller size (now 64x64), a subvolume (e.g. values[::2, ::2, ::2]) or "
            "float32 data instead of float64\n") in err
    assert "Traceback" not in err


@pytest.mark.parametrize("kwargs", [{}, {"skip_empty": False}, {"block_mask": "all"}, {"gradient_opacity": (0, 1)}])
def test_the_empty_warning_does_not_depend_on_skipping(kwargs):
    vol = hv.volume_from_array(np.full((6, 7, 8), 3.0))
    if kwargs.get("block_mask") == "all":
        kwargs = {"block_mask": np.ones(hv.BlockGrid.of(vol, 4).shape, bool)}
    with pytest.warns(EmptyRenderWarning, match=r"the data is constant \(3\)"):
        assert not hv.render(vol, None, None, (8, 8), **kwargs).rgba.any()
