"""Multiresolution OME-Zarr stores (pv_hdrvol.outofcore.store): sources, levels, ranges,
metadata, damage, interruption and the ``pv-hdrvol convert`` command.

Not ``core``: Debian's Python has no zarr.
"""
import json
import os
import re
import signal
import subprocess
import sys
import textwrap
import time
import tracemalloc

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")

from pv_hdrvol.integrations.cli import main  # noqa: E402
from pv_hdrvol.outofcore.store import (FORMAT, MultiscaleStore, downsample_mean,  # noqa: E402
                                       downsample_mode, level_shapes, write_multiscale)


def _levels(store):
    return [store.read_level(L) for L in range(store.n_levels)]


def _chunk(a, index, c):
    return a[tuple(slice(i * c, (i + 1) * c) for i in index)]


@pytest.fixture(scope="module")
def odd_store(tmp_path_factory):
    """An odd-sized float32 volume with NaN (one all-NaN chunk), chunks of 16: 4 levels."""
    rng = np.random.default_rng(7)
    values = (rng.standard_normal((37, 50, 71)) * 10).astype(np.float32)
    values[3, 4, 5] = np.nan
    values[16:32, 16:32, 32:48] = np.nan  # chunk (1, 1, 2) of level 0 holds no number
    path = tmp_path_factory.mktemp("odd") / "odd.ome.zarr"
    store = write_multiscale(values, path, chunk=16, spacing=(0.5, 2.0, 3.0), origin=(1.0, -2.0, 5.0), name="odd")
    return values, store


# -- levels ---------------------------------------------------------------------------
def test_level_shapes_halve_with_ceiling_down_to_one_chunk(odd_store):
    values, store = odd_store
    assert level_shapes((37, 50, 71), 16) == [(37, 50, 71), (19, 25, 36), (10, 13, 18), (5, 7, 9)]
    assert [lv.shape for lv in store.levels] == level_shapes((37, 50, 71), 16)
    assert [lv.chunks for lv in store.levels] == [(3, 4, 5), (2, 2, 3), (1, 1, 2), (1, 1, 1)]
    assert level_shapes((64, 64, 64)) == [(64, 64, 64)] and level_shapes((65, 1, 1)) == [(65, 1, 1), (33, 1, 1)]
    assert store.n_levels == 4 and store.chunk == 16


def test_each_level_is_the_mean_of_the_one_below_exactly(odd_store):
    values, store = odd_store
    levels = _levels(store)
    assert levels[0].dtype == np.float32
    np.testing.assert_array_equal(levels[0], values)  # NaN at the same places
    for L in range(1, store.n_levels):
        assert levels[L].dtype == np.float32
        np.testing.assert_array_equal(levels[L], downsample_mean(levels[L - 1]).astype(np.float32))


def test_downsample_mean_replicates_the_last_plane_and_ignores_nan():
    a = np.array([[[1.0, 2.0, 7.0]]])  # (1, 1, 3): every axis odd
    np.testing.assert_array_equal(downsample_mean(a), [[[1.5, 7.0]]])
    b = np.arange(8.0).reshape(2, 2, 2)
    b[0, 0, 0] = np.nan
    assert downsample_mean(b)[0, 0, 0] == pytest.approx(sum(range(1, 8)) / 7, abs=0)
    assert np.isnan(downsample_mean(np.full((2, 2, 2), np.nan))[0, 0, 0])


def test_mode_downsampling_of_labels_by_hand(tmp_path):
    group = np.array([3, 3, 5, 5, 5, 1, 1, 1])  # 5 and 1 tie at three: the smaller, 1
    a = np.zeros((2, 2, 4), np.uint8)
    a[..., :2] = group.reshape(2, 2, 2)
    a[..., 2:] = np.array([9, 9, 9, 9, 9, 2, 2, 0]).reshape(2, 2, 2)  # 9 wins
    np.testing.assert_array_equal(downsample_mode(a), [[[1, 9]]])
    np.testing.assert_array_equal(downsample_mode(np.array([[[4, 2, 7]]])), [[[2, 7]]])  # (4, 2): tie -> 2
    labels = np.random.default_rng(3).integers(0, 4, (40, 33, 20)).astype(np.int16)
    store = write_multiscale(labels, tmp_path / "labels.ome.zarr", downsample="mode", chunk=8)
    levels = _levels(store)
    for L in range(1, store.n_levels):
        assert levels[L].dtype == np.int16
        np.testing.assert_array_equal(levels[L], downsample_mode(levels[L - 1]))
    assert store.downsample == "mode"


def test_mode_refuses_floats(tmp_path):
    with pytest.raises(ValueError, match="downsample='mode' is for label volumes"):
        write_multiscale(np.zeros((4, 4, 4), np.float32), tmp_path / "x.ome.zarr", downsample="mode")


# -- ranges -----------------------------------------------------------------------------
def test_chunk_ranges_are_numpy_min_max_of_each_chunk(odd_store):
    values, store = odd_store
    c = store.chunk
    for L, level in enumerate(_levels(store)):
        r = store.levels[L].ranges
        assert r.shape == store.levels[L].chunks + (5,) and r.dtype == np.float64
        for index in np.ndindex(*store.levels[L].chunks):
            part = _chunk(level, index, c)
            finite = part[~np.isnan(part)]
            if finite.size:
                assert (r[index][0], r[index][1]) == (float(finite.min()), float(finite.max()))
            else:
                assert (r[index][0], r[index][1]) == (np.inf, -np.inf)
    assert tuple(store.levels[0].ranges[1, 1, 2, :2]) == (np.inf, -np.inf)  # the all-NaN chunk
    assert store.value_range == (float(np.nanmin(values)), float(np.nanmax(values)))


def test_sub_ranges_cover_the_level0_points_below(odd_store):
    values, store = odd_store
    c = store.chunk
    for L in range(store.n_levels):
        r = store.levels[L].ranges
        for index in np.ndindex(*store.levels[L].chunks):
            below = values[tuple(slice(i * c * 2 ** L, (i + 1) * c * 2 ** L) for i in index)]
            finite = below[~np.isnan(below)]
            want = (float(finite.min()), float(finite.max())) if finite.size else (np.inf, -np.inf)
            assert (r[index][3], r[index][4]) == want, (L, index)


def test_error_field_is_the_largest_difference_to_the_parent(odd_store):
    values, store = odd_store
    c = store.chunk
    levels = _levels(store)
    for L in range(store.n_levels - 1):
        fine, coarse = levels[L].astype(np.float64), levels[L + 1].astype(np.float64)
        nz, ny, nx = fine.shape
        parent = coarse[np.arange(nz)[:, None, None] // 2, np.arange(ny)[None, :, None] // 2,
                        np.arange(nx)[None, None, :] // 2]
        diff = np.abs(fine - parent)
        for index in np.ndindex(*store.levels[L].chunks):
            d = _chunk(diff, index, c)
            d = d[~np.isnan(d)]
            want = float(d.max()) if d.size else 0.0
            assert store.levels[L].ranges[index][2] == want, (L, index)
    assert np.all(store.levels[-1].ranges[..., 2] == 0.0)
    assert store.levels[0].ranges[0, 0, 0, 2] > 0  # random data differs from its means


# -- chunks -------------------------------------------------------------------------------
def test_all_chunks_reassemble_each_level_bit_for_bit(odd_store):
    values, store = odd_store
    c = store.chunk
    for L, level in enumerate(_levels(store)):
        out = np.empty(store.levels[L].shape, store.levels[L].dtype)
        for index in np.ndindex(*store.levels[L].chunks):
            block = store.read_chunk(L, index)
            out[tuple(slice(i * c, i * c + n) for i, n in zip(index, block.shape))] = block
        assert out.tobytes() == level.tobytes()
    assert store.chunks_read == [int(np.prod(lv.chunks)) for lv in store.levels]
    assert store.bytes_read[0] == values.nbytes


# -- metadata -------------------------------------------------------------------------------
def test_ome_metadata_scale_and_translation(odd_store):
    values, store = odd_store
    attrs = json.loads((store.path and open(os.path.join(store.path, "zarr.json")).read()))["attributes"]
    ome = attrs["ome"]
    assert ome["version"] == "0.5"
    (ms,) = ome["multiscales"]
    assert [a["name"] for a in ms["axes"]] == ["z", "y", "x"] and ms["name"] == "odd"
    sx, sy, sz = 0.5, 2.0, 3.0
    ox, oy, oz = 1.0, -2.0, 5.0
    for L, d in enumerate(ms["datasets"]):
        assert d["path"] == str(L)
        scale, translation = d["coordinateTransformations"]
        f = 2 ** L
        assert scale == {"type": "scale", "scale": [sz * f, sy * f, sx * f]}
        h = (f - 1) / 2
        assert translation == {"type": "translation", "translation": [oz + h * sz, oy + h * sy, ox + h * sx]}
        spacing, origin = store.level_geometry(L)
        assert list(spacing[::-1]) == scale["scale"] and list(origin[::-1]) == translation["translation"]
    assert attrs["pv_hdrvol"]["format"] == FORMAT and attrs["pv_hdrvol"]["complete"] is True
    assert store.bounds == (1.0, 1.0 + 70 * 0.5, -2.0, -2.0 + 49 * 2.0, 5.0, 5.0 + 36 * 3.0)


def test_ome_zarr_reader_finds_every_level(odd_store):
    from ome_zarr.io import parse_url
    from ome_zarr.reader import Multiscales, Reader

    values, store = odd_store
    nodes = list(Reader(parse_url(store.path))())
    images = [n for n in nodes if any(isinstance(s, Multiscales) for s in n.specs)]
    assert len(images) == 1
    assert [tuple(d.shape) for d in images[0].data] == [lv.shape for lv in store.levels]
    np.testing.assert_array_equal(np.asarray(images[0].data[2]), store.read_level(2))


# -- sources -------------------------------------------------------------------------------
def test_sources_give_the_same_store(tmp_path):
    import pyvista as pv

    from pv_hdrvol.data.grid import volume_from_array

    values = (np.arange(20 * 30 * 40).reshape(20, 30, 40) % 251).astype(np.float32)
    values[1, 2, 3] = np.nan
    ref_store = write_multiscale(values, tmp_path / "np.ome.zarr", chunk=8)
    ref = _levels(ref_store)
    values.tofile(tmp_path / "v.raw")
    values.astype(">f4").tofile(tmp_path / "big.raw")
    mm = np.memmap(tmp_path / "v.raw", dtype=np.float32, mode="r", shape=values.shape)
    za = zarr.create_array(store=str(tmp_path / "src.zarr"), shape=values.shape, dtype="f4", chunks=(7, 9, 11))
    za[...] = values
    grid = pv.ImageData(dimensions=(40, 30, 20), spacing=(0.5, 1.0, 2.0), origin=(1.0, 2.0, 3.0))
    grid["v"] = values.ravel()
    grid.save(tmp_path / "g.vti")
    sources = {
        "raw": (str(tmp_path / "v.raw"), dict(shape=(20, 30, 40), dtype="float32")),
        "raw big-endian": (tmp_path / "big.raw", dict(shape=(20, 30, 40), dtype=">f4")),
        "memmap": (mm, {}),
        "zarr": (za, {}),
        "function": (lambda box: values[tuple(slice(a, b) for a, b in box)].astype(np.float64),
                     dict(shape=values.shape, dtype="float32")),
        "GridVolume": (volume_from_array(values, (0.5, 1.0, 2.0), (1.0, 2.0, 3.0)), {}),
        "ImageData": (grid, {}),
        "vti": (tmp_path / "g.vti", {}),
    }
    for i, (label, (source, kw)) in enumerate(sources.items()):
        store = write_multiscale(source, tmp_path / f"s{i}.ome.zarr", chunk=8, **kw)
        assert store.dtype == np.float32, label
        for a, b in zip(_levels(store), ref):
            assert a.tobytes() == b.tobytes(), label
        for a, b in zip(store.levels, ref_store.levels):  # ranges of the stored (cast) values
            assert a.ranges.tobytes() == b.ranges.tobytes(), label
        if label in ("GridVolume", "ImageData", "vti"):
            assert tuple(store.spacing) == (0.5, 1.0, 2.0) and tuple(store.origin) == (1.0, 2.0, 3.0), label
        else:
            assert tuple(store.spacing) == (1.0, 1.0, 1.0) and tuple(store.origin) == (0.0, 0.0, 0.0), label
    assert write_multiscale(tmp_path / "g.vti", tmp_path / "named.ome.zarr").name == "v"


def test_file_keeps_its_integer_dtype(tmp_path):
    import pyvista as pv

    values = np.random.default_rng(1).integers(0, 3000, (10, 12, 70)).astype(np.int16)
    grid = pv.ImageData(dimensions=(70, 12, 10))
    grid["labels"] = values.ravel()
    grid.save(tmp_path / "l.vti")
    store = write_multiscale(tmp_path / "l.vti", tmp_path / "l.ome.zarr")
    assert store.dtype == np.int16 and store.levels[1].dtype == np.float32  # the mean of integers
    np.testing.assert_array_equal(store.read_level(0), values)
    np.testing.assert_array_equal(store.read_level(1), downsample_mean(values).astype(np.float32))


def test_float64_stays_float64(tmp_path):
    values = np.random.default_rng(2).random((9, 10, 70))  # float64 whose float32 rounding differs
    store = write_multiscale(values, tmp_path / "f.ome.zarr")
    assert [lv.dtype for lv in store.levels] == [np.float64, np.float64]
    assert store.read_level(0).tobytes() == values.tobytes()
    np.testing.assert_array_equal(store.read_level(1), downsample_mean(values))


def test_the_callers_data_is_not_changed(tmp_path):
    values = np.random.default_rng(4).random((20, 20, 70)).astype(np.float32)
    values[0, 0, :3] = [np.nan, np.inf, -np.inf]
    before = values.copy()
    values.flags.writeable = False  # a write would raise
    store = write_multiscale(values, tmp_path / "c.ome.zarr", chunk=8)
    assert values.tobytes() == before.tobytes()
    np.testing.assert_array_equal(store.read_level(0), before)  # inf kept as inf, NaN as NaN


def test_raw_size_mismatch_names_both(tmp_path):
    np.zeros((4, 5, 6), np.float32).tofile(tmp_path / "x.raw")
    with pytest.raises(ValueError, match=r"has 480 bytes; shape \(4, 5, 7\) of float32 needs 560"):
        write_multiscale(tmp_path / "x.raw", tmp_path / "x.ome.zarr", shape=(4, 5, 7), dtype="float32")
    with pytest.raises(ValueError, match="a .raw file holds no shape or dtype"):
        write_multiscale(tmp_path / "x.raw", tmp_path / "x.ome.zarr")
    assert not (tmp_path / "x.ome.zarr").exists()  # refused before anything is written


@pytest.mark.parametrize("source, kw, error, message", [
    (np.zeros((3, 4)), {}, ValueError, r"ndarray source must be 3-D \(z, y, x\); got shape \(3, 4\)"),
    (np.zeros((3, 0, 4)), {}, ValueError, r"must not be empty; got shape \(3, 0, 4\)"),
    (np.zeros((3, 3, 3), complex), {}, TypeError, "must hold real numbers .*; got dtype complex128"),
    (np.zeros((3, 3, 3), bool), {}, TypeError, "got dtype bool"),
    (np.zeros((3, 3, 3)), dict(spacing=(1, 0, 1)), ValueError, r"spacing must be finite and > 0 .*\(1.0, 0.0, 1.0\)"),
    (np.zeros((3, 3, 3)), dict(spacing=(1, 2)), ValueError, "spacing must be 3 numbers"),
    (np.zeros((3, 3, 3)), dict(origin=(0, np.nan, 0)), ValueError, "origin must be finite"),
    (np.zeros((3, 3, 3)), dict(shape=(3, 3, 4)), ValueError, r"shape=\(3, 3, 4\) does not match"),
    (np.zeros((3, 3, 3)), dict(chunk=48), ValueError, "chunk must be a power of two"),
    (np.zeros((3, 3, 3)), dict(downsample="max"), ValueError, "downsample must be one of"),
    (np.zeros((3, 3, 3)), dict(scalars="v"), ValueError, "scalars names an array of a dataset or file"),
    ([[[1.0]]], {}, TypeError, "source must be an array .*; got list"),
    (lambda box: 0, {}, ValueError, "give shape=.* and dtype="),
    (lambda box: 0, dict(shape=(2, 2), dtype="f4"), ValueError, r"shape must be 3 sizes \(nz, ny, nx\)"),
    (lambda box: 0, dict(shape=(2, 2, 2), dtype="c8"), TypeError, "dtype must hold real numbers"),
    (lambda box: np.zeros((1, 1, 1)), dict(shape=(2, 2, 2), dtype="f4"), ValueError,
     r"returned shape \(1, 1, 1\) for the box \(\(0, 2\), \(0, 2\), \(0, 2\)\); expected \(2, 2, 2\)"),
    (lambda box: np.zeros((2, 2, 2), complex), dict(shape=(2, 2, 2), dtype="f4"), TypeError,
     "returned dtype complex128 .*; expected float32"),
    (lambda box: np.zeros((2, 2, 2)), dict(shape=(2, 2, 2), dtype="i2"), TypeError, "returned dtype float64"),
])
def test_bad_sources_are_refused_by_name(source, kw, error, message, tmp_path):
    with pytest.raises(error, match=message):
        write_multiscale(source, tmp_path / "bad.ome.zarr", **kw)


def test_missing_file_and_rectilinear_grid(tmp_path):
    import pyvista as pv

    with pytest.raises(FileNotFoundError, match="nope.vti"):
        write_multiscale(tmp_path / "nope.vti", tmp_path / "x.ome.zarr")
    grid = pv.RectilinearGrid(np.array([0.0, 1, 3]), np.array([0.0, 1]), np.array([0.0, 2]))
    grid["v"] = np.arange(grid.n_points, dtype=np.float32)
    with pytest.raises(ValueError, match="uniform grids"):
        write_multiscale(grid, tmp_path / "x.ome.zarr")


# -- overwrite, damage ---------------------------------------------------------------------
def test_overwrite(tmp_path):
    path = tmp_path / "o.ome.zarr"
    write_multiscale(np.zeros((4, 4, 4), np.float32), path)
    with pytest.raises(FileExistsError, match="exists; pass overwrite=True"):
        write_multiscale(np.ones((4, 4, 4), np.float32), path)
    assert MultiscaleStore(path).value_range == (0.0, 0.0)
    assert write_multiscale(np.ones((4, 4, 4), np.float32), path, overwrite=True).value_range == (1.0, 1.0)
    (tmp_path / "folder").mkdir()
    (tmp_path / "folder" / "keep.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="is not a zarr store"):
        write_multiscale(np.ones((4, 4, 4), np.float32), tmp_path / "folder", overwrite=True)
    assert (tmp_path / "folder" / "keep.txt").read_text() == "mine"
    # a bad option is refused before the old store is removed
    with pytest.raises(TypeError, match="progress_bar must be True, False or None"):
        write_multiscale(np.ones((4, 4, 4), np.float32), path, overwrite=True, progress_bar="yes")
    assert MultiscaleStore(path).value_range == (1.0, 1.0)
    with pytest.raises(ValueError, match="threads must be >= 1; got 0"):
        write_multiscale(np.full((4, 4, 4), 2.0, np.float32), path, overwrite=True, threads=0)
    assert MultiscaleStore(path).value_range == (1.0, 1.0)


def test_missing_shard_is_an_error_naming_chunk_and_file(tmp_path):
    values = np.random.default_rng(5).random((200, 20, 20)).astype(np.float32)
    store = write_multiscale(values, tmp_path / "m.ome.zarr")  # float32: shards of 128^3, two along z
    path = store.chunk_path(0, (2, 0, 0))
    assert path == os.path.join(store.path, "0", "c", "1", "0", "0")
    os.remove(path)
    for index in ((2, 0, 0), (3, 0, 0)):
        with pytest.raises(OSError, match=re.escape(f"chunk {index} of level 0 ({path}) is missing")):
            store.read_chunk(0, index)
    assert store.read_chunk(0, (1, 0, 0)).tobytes() == values[64:128].tobytes()
    # outside the store: the caller's mistake, not damage
    for index in ((4, 0, 0), (-1, 0, 0), (0, 0)):
        with pytest.raises(IndexError, match=r"is outside level 0's chunks \(4, 1, 1\)"):
            store.read_chunk(0, index)
    with pytest.raises(IndexError, match="level must be 0 to 2; got 3"):
        store.read_chunk(3, (0, 0, 0))


def test_corrupted_shard_is_an_error_naming_the_chunk(tmp_path):
    values = np.random.default_rng(6).random((128, 128, 128)).astype(np.float32)
    store = write_multiscale(values, tmp_path / "c.ome.zarr")  # level 0: one shard of 8 chunks
    path = store.chunk_path(0, (0, 0, 0))
    data = bytearray(open(path, "rb").read())
    for offset in (len(data) // 8, len(data) // 3, len(data) // 2):  # inside some chunk's bytes
        damaged = bytearray(data)
        damaged[offset:offset + 16] = bytes(16)
        with open(path, "wb") as f:
            f.write(damaged)
        store = MultiscaleStore(tmp_path / "c.ome.zarr")
        failed = []
        for index in np.ndindex(2, 2, 2):
            try:
                block = store.read_chunk(0, index)
            except OSError as e:
                assert f"chunk {index} of level 0" in str(e) and "cannot be read" in str(e)
                failed.append(index)
            else:
                assert block.tobytes() == _chunk(values, index, 64).tobytes()  # never wrong numbers
        assert len(failed) == 1, offset
    with open(path, "wb") as f:
        f.write(data)
    assert MultiscaleStore(tmp_path / "c.ome.zarr").read_chunk(0, (1, 1, 1)).tobytes() == \
        _chunk(values, (1, 1, 1), 64).tobytes()


# -- interruption -------------------------------------------------------------------------
def test_interrupted_writing_leaves_a_refused_store(tmp_path):
    calls = []

    def source(box):
        calls.append(box)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return np.zeros(tuple(b - a for a, b in box), np.float32)

    path = tmp_path / "i.ome.zarr"
    with pytest.raises(KeyboardInterrupt):
        write_multiscale(source, path, shape=(400, 16, 16), dtype="float32", chunk=8, progress_bar=False, threads=1)
    # level 0 has four shards of 128 along z: two were written (one thread: in order)
    assert len(calls) == 3 and sorted(os.listdir(path / "0" / "c")) == ["0", "1"]
    with pytest.raises(ValueError, match="is incomplete: it is being written or its writing was interrupted"):
        MultiscaleStore(path)
    # written again, it is complete
    store = write_multiscale(lambda box: np.zeros(tuple(b - a for a, b in box)), path, shape=(400, 16, 16),
                             dtype="float32", chunk=8, overwrite=True)
    assert store.n_levels == 7 and store.value_range == (0.0, 0.0)


def test_sigint_mid_write_leaves_a_store_no_reader_accepts(tmp_path):
    from ome_zarr.io import parse_url
    from ome_zarr.reader import Multiscales, Reader

    path = tmp_path / "sig.ome.zarr"
    flag = tmp_path / "started"
    code = textwrap.dedent(f"""
        import pathlib, signal, time
        import numpy as np
        from pv_hdrvol.outofcore.store import write_multiscale

        # Ctrl-C as in a terminal: a job started in the background (nohup ... &, as CI
        # scripts may be) inherits SIGINT ignored, and Python then keeps ignoring it
        signal.signal(signal.SIGINT, signal.default_int_handler)

        def slow(box):  # forty shards of 128 x 8 x 8 along z, 0.2 s each (4 s on the default 2 threads)
            pathlib.Path({str(flag)!r}).touch()
            time.sleep(0.2)
            return np.ones(tuple(b - a for a, b in box), np.float32)

        write_multiscale(slow, {str(path)!r}, shape=(5120, 8, 8), dtype="float32", chunk=8, progress_bar=False)
        print("finished")
    """)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                                                       os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    deadline = time.monotonic() + 120
    while not flag.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert flag.exists(), proc.communicate()
    time.sleep(0.5)  # some shards written, most not
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode != 0 and "finished" not in out
    assert "KeyboardInterrupt" in err
    assert (path / "zarr.json").is_file() and 0 < len(os.listdir(path / "0" / "c")) < 40
    with pytest.raises(ValueError, match="is incomplete"):
        MultiscaleStore(path)
    nodes = list(Reader(parse_url(str(path)))())
    assert not any(isinstance(s, Multiscales) for n in nodes for s in n.specs)


# -- memory -----------------------------------------------------------------------------
@pytest.mark.parametrize("threads, bound_mib", [(1, 40), (2, 80)])
def test_peak_memory_is_a_few_shards_not_the_volume(tmp_path, threads, bound_mib):
    """A 320^3 float32 volume (125 MiB) from a function: the peak of numpy and Python
    allocations stays under five level-0 shards of 8 MiB per thread (one shard, zarr's
    encoding of it and the float64 work on a chunk; two shards per thread in flight):
    40 MiB on one thread, 80 on two, well under the volume."""
    n = 320

    def source(box):
        z, y, x = (np.arange(a, b, dtype=np.float32) for a, b in box)
        smooth = np.sin(0.05 * x)[None, None, :] + np.cos(0.03 * y)[None, :, None] + 1e-3 * z[:, None, None]
        smooth[:, :, (x.astype(np.int64) % 37) == 0] += 10.0  # thin sheets
        return smooth

    tracemalloc.start()
    try:
        store = write_multiscale(source, tmp_path / "big.ome.zarr", shape=(n, n, n), dtype="float32",
                                 progress_bar=False, threads=threads)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    volume = n ** 3 * 4
    assert peak < bound_mib * 2 ** 20 < volume * 2 / 3, peak / 2 ** 20
    assert [lv.shape for lv in store.levels] == [(320,) * 3, (160,) * 3, (80,) * 3, (40,) * 3]
    assert store.value_range[1] > 10


# -- pv-hdrvol convert ----------------------------------------------------------------------
def test_convert_raw(tmp_path, capsys):
    values = np.random.default_rng(8).random((30, 20, 130)).astype(np.float32)
    values.tofile(tmp_path / "v.raw")
    out = tmp_path / "v.ome.zarr"
    assert main(["convert", str(tmp_path / "v.raw"), str(out), "--raw-shape", "30", "20", "130",
                 "--raw-dtype", "float32", "--spacing", "1", "2", "3", "--origin", "0", "0", "-1",
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    store = MultiscaleStore(out)
    assert text.startswith(f"wrote {out}: 3 levels of float32 (mean), chunks of 64^3")
    assert "  level 1: 65x10x15 points, float32, 2 chunks" in text and " s\n" in text
    np.testing.assert_array_equal(store.read_level(0), values)
    assert tuple(store.spacing) == (1.0, 2.0, 3.0) and tuple(store.origin) == (0.0, 0.0, -1.0)


def test_convert_vti_mode(tmp_path, capsys):
    import pyvista as pv

    labels = np.random.default_rng(9).integers(0, 5, (10, 12, 70)).astype(np.uint8)
    grid = pv.ImageData(dimensions=(70, 12, 10), spacing=(2, 2, 2))
    grid["labels"] = labels.ravel()
    grid.save(tmp_path / "l.vti")
    assert main(["convert", str(tmp_path / "l.vti"), str(tmp_path / "l.ome.zarr"), "--downsample", "mode",
                 "--no-progress"]) == 0
    store = MultiscaleStore(tmp_path / "l.ome.zarr")
    assert store.levels[1].dtype == np.uint8 and tuple(store.spacing) == (2.0, 2.0, 2.0)
    np.testing.assert_array_equal(store.read_level(1), downsample_mode(labels))


@pytest.mark.parametrize("args, message", [
    (["{tmp}/v.raw", "{tmp}/o.ome.zarr"], "is a .raw file: give --raw-shape NZ NY NX and --raw-dtype"),
    (["{tmp}/v.raw", "{tmp}/o.ome.zarr", "--raw-shape", "2", "3", "5", "--raw-dtype", "float32"],
     "has 96 bytes; shape (2, 3, 5) of float32 needs 120"),
    (["{tmp}/v.raw", "{tmp}/o.ome.zarr", "--raw-shape", "2", "3", "4", "--raw-dtype", "floot"],
     "--raw-dtype: 'floot' is not a numpy dtype"),
    (["{tmp}/v.raw", "{tmp}/o.ome.zarr", "--raw-shape", "2", "3", "4", "--raw-dtype", "complex64"],
     "must hold real numbers"),
    (["{tmp}/v.raw", "{tmp}/exists", "--raw-shape", "2", "3", "4", "--raw-dtype", "float32"],
     "exists; add --overwrite to replace it"),
    (["{tmp}/v.raw", "{tmp}/exists", "--raw-shape", "2", "3", "4", "--raw-dtype", "float32", "--overwrite"],
     "is not a zarr store"),
    (["{tmp}/v.raw", "{tmp}/o.ome.zarr", "--raw-shape", "2", "3", "4", "--raw-dtype", "float32",
      "--spacing", "1", "-1", "1"], "spacing must be finite and > 0"),
    (["{tmp}/missing.raw", "{tmp}/o.ome.zarr"], "file not found"),
    (["{tmp}/v.txt", "{tmp}/o.ome.zarr"], "unknown extension '.txt'"),
    (["{tmp}/v.txt", "{tmp}/o.ome.zarr", "--raw-shape", "2", "3", "4"], "--raw-shape and --raw-dtype describe a .raw"),
])
def test_convert_user_errors_exit_2(args, message, tmp_path, capsys):
    np.zeros((2, 3, 4), np.float32).tofile(tmp_path / "v.raw")
    (tmp_path / "v.txt").write_text("x")
    (tmp_path / "exists").mkdir()
    with pytest.raises(SystemExit) as exit_info:
        main(["convert"] + [a.format(tmp=tmp_path) for a in args])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    (line,) = [line for line in err.splitlines() if "error:" in line]
    assert line.startswith("pv-hdrvol convert: error: ") and message in line
    assert not (tmp_path / "o.ome.zarr").exists()


def test_threads_write_the_same_store_as_one_thread(tmp_path):
    """Shards made on two threads: every level, the chunk ranges and the group ranges
    are those of one thread's store, bit for bit."""
    values = np.random.default_rng(3).random((300, 140, 130)).astype(np.float32)
    one = write_multiscale(values, tmp_path / "one.ome.zarr", progress_bar=False, threads=1)
    two = write_multiscale(values, tmp_path / "two.ome.zarr", progress_bar=False, threads=2)
    assert one.n_levels == two.n_levels == 4
    for level in range(one.n_levels):
        assert np.array_equal(one.read_level(level), two.read_level(level))
        assert np.array_equal(one.levels[level].ranges, two.levels[level].ranges)
    assert np.array_equal(one.group_ranges(), two.group_ranges())


def test_group_ranges_are_the_min_and_max_of_each_cube_of_8_points(tmp_path):
    values = np.random.default_rng(4).random((150, 131, 140)).astype(np.float32)
    values[:8, :8, :8] = np.nan
    values[8:16, 0, 0] = np.nan
    store = write_multiscale(values, tmp_path / "g.ome.zarr", progress_bar=False)
    groups = store.group_ranges()
    assert groups.shape == (19, 17, 18, 2)
    assert tuple(groups[0, 0, 0]) == (np.inf, -np.inf)  # all NaN
    for k, j, i in [(1, 0, 0), (1, 2, 3), (18, 16, 17), (9, 8, 7)]:
        part = values[8 * k:8 * k + 8, 8 * j:8 * j + 8, 8 * i:8 * i + 8]
        assert tuple(groups[k, j, i]) == (float(np.nanmin(part)), float(np.nanmax(part)))
