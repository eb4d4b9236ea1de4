"""Multiresolution stores: the cost of writing one, and of reading its chunks back.

1. **Build.** ``write_multiscale`` of a procedural float32 volume (a smooth field plus
   thin sheets and tubes, made box by box: never held whole), ``--n`` points a side
   (default 512): seconds, shards per second, and the peak resident memory of the
   process that wrote it (a fresh forked child; its resident memory before writing is
   shown too) against the volume's size.
2. **Chunk edge.** The same volume written with inner chunks of 64 and of 128 points:
   bytes on disk, and the time to read ``--bricks`` random level-0 chunks one by one
   through ``MultiscaleStore.read_chunk`` (zarr-python), per chunk and per megabyte.
   The files were just written, so they are in the page cache: this is decoding and
   library cost, not the disk's.
3. **Reader.** The same chunks read with tensorstore (``zarr3`` driver), one at a time
   and all requested at once, when ``import tensorstore`` works (``pip install
   tensorstore``; not a dependency), as ratios against zarr-python.

    python3 benchmarks/bench_ooc_store.py            # 512^3: about a minute on 2 cores
    python3 benchmarks/bench_ooc_store.py --n 256    # a quick look

Measured (2-core machine shared with another engineer's numba compiles; zarr 3.1.6,
tensorstore 0.1.86, numpy 2; --n 384, --bricks 64):

    volume 384^3 float32 (216 MiB), procedural; load average (1, 5, 15 min) 1.49 1.47 1.17 before, 1.78 1.53 1.19 after

    |                                              |       chunk 64 |      chunk 128 |
    |----------------------------------------------|----------------|----------------|
    | build: seconds                               |            4.1 |            4.8 |
    | build: levels, shard files                   |          4, 37 |          3, 36 |
    | build: shards/s                              |            9.0 |            7.5 |
    | build: MB/s of level 0                       |             55 |             47 |
    | build: peak RSS MiB (RSS before)             |       145 (59) |       199 (59) |
    | build: (peak - before) / volume              |           0.40 |           0.65 |
    | bytes on disk (all levels), MiB              |          150.3 |          146.4 |
    | compression ratio (all levels)               |           1.64 |           1.68 |
    | random level-0 chunks read                   |     64 (67 MB) |    27 (226 MB) |
    | zarr-python: ms per chunk                    |           2.83 |           9.21 |
    | zarr-python: MB/s                            |            371 |            910 |
    | tensorstore one at a time: ms per chunk      |           1.16 |           7.48 |
    | tensorstore all at once: ms per chunk        |           0.97 |           5.68 |
    | zarr-python / tensorstore one at a time      |           2.43 |           1.23 |
    | zarr-python / tensorstore all at once        |           2.91 |           1.62 |

    chunk 128 / chunk 64, time per voxel read (zarr-python): 0.41

At --n 256 (64 MiB) the writer's peak RSS was 133 MiB (chunk 64; 59 before): the
74 MiB it adds is about the 86 MiB it adds at 384^3 (216 MiB): bounded by shards, not
the volume. Readings: tensorstore reads a 64^3 chunk 2.4x faster than zarr-python one
at a time (2.9x all requested at once); most of zarr-python's 2.8 ms per 1 MiB chunk is
per-call overhead (128^3 chunks: 0.41x the time per voxel, and tensorstore's lead
shrinks to 1.2x). Chunks of 128 cost more writer memory (one 8 MiB chunk per shard)
and 8x the bytes per brick a renderer needs; 64 stays the default.
"""
from __future__ import annotations

import argparse
import multiprocessing
import os
import resource
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pv_hdrvol.outofcore.store import MultiscaleStore, write_multiscale  # noqa: E402


def procedural(n):
    """``f(box)`` of an n^3 float32 volume: a smooth field over 3 decades, thin sheets
    (one point thick, every 37 points along x) and tubes along z (every 29 points in x
    and y), built from the box's own coordinates only."""
    def f(box):
        z, y, x = (np.arange(a, b, dtype=np.float32) / n for a, b in box)
        r2 = (x - 0.5)[None, None, :] ** 2 + (y - 0.5)[None, :, None] ** 2 + (z - 0.5)[:, None, None] ** 2
        v = np.exp(-8.0 * r2).astype(np.float32) * 1e3 + np.sin(12.0 * x)[None, None, :] + 1.5
        ix, iy = (np.arange(a, b) for a, b in box[2:0:-1])
        v[:, :, ix % 37 == 0] += 100.0
        tubes = ((iy % 29) == 0)[:, None] & ((ix % 29) == 0)[None, :]
        v[:, tubes] += 300.0
        return v
    return f


def _rss_mib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def _build_child(n, chunk, path, queue):
    before = _rss_mib()
    t = time.perf_counter()
    store = write_multiscale(procedural(n), path, shape=(n, n, n), dtype="float32", chunk=chunk, progress_bar=False)
    seconds = time.perf_counter() - t
    shards = sum(len(files) for root, _, files in os.walk(path)
                 if (os.sep + "c" + os.sep in root + os.sep) and "pv_hdrvol" not in root)
    queue.put(dict(seconds=seconds, shards=shards, levels=store.n_levels,
                   rss_before=before, rss_peak=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024))


def build(n, chunk, path):
    """Write the store in a forked child: its peak RSS is the writer's alone."""
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    proc = ctx.Process(target=_build_child, args=(n, chunk, path, queue))
    proc.start()
    result = queue.get()
    proc.join()
    return result


def disk_bytes(path):
    return sum(os.path.getsize(os.path.join(root, f)) for root, _, files in os.walk(path) for f in files)


def bricks(store, count, seed=0):
    """``count`` distinct random level-0 chunk indices (inner ones when there are enough)."""
    rng = np.random.default_rng(seed)
    grid = store.levels[0].chunks
    every = list(np.ndindex(*grid))
    picks = rng.choice(len(every), size=min(count, len(every)), replace=False)
    return [every[i] for i in picks]


def time_zarr(store, indices, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        for index in indices:
            store.read_chunk(0, index)
        times.append(time.perf_counter() - t)
    return min(times)


def time_tensorstore(store, indices, repeats):
    import tensorstore as ts

    arr = ts.open({"driver": "zarr3", "kvstore": {"driver": "file", "path": os.path.join(store.path, "0")}},
                  read=True, context=ts.Context({"cache_pool": {"total_bytes_limit": 0}})).result()
    c = store.chunk

    def box(index):
        return tuple(slice(i * c, min((i + 1) * c, n)) for i, n in zip(index, store.levels[0].shape))

    for index in indices[:4]:  # the same numbers as zarr-python
        assert np.asarray(arr[box(index)].read().result()).tobytes() == store.read_chunk(0, index).tobytes()
    one, together = [], []
    for _ in range(repeats):
        t = time.perf_counter()
        for index in indices:
            arr[box(index)].read().result()
        one.append(time.perf_counter() - t)
        t = time.perf_counter()
        futures = [arr[box(index)].read() for index in indices]
        for f in futures:
            f.result()
        together.append(time.perf_counter() - t)
    return min(one), min(together)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=512, help="points a side of the volume (default 512)")
    parser.add_argument("--bricks", type=int, default=64, help="random level-0 chunks read (default 64)")
    parser.add_argument("--repeats", type=int, default=3, help="reads of the set; the fastest counts (default 3)")
    parser.add_argument("--folder", default=None, help="where the stores are written (default: a temporary one)")
    args = parser.parse_args(argv)
    n = args.n
    folder = args.folder or tempfile.mkdtemp(prefix="bench_ooc_")
    try:
        import tensorstore  # noqa: F401
        have_ts = True
    except ImportError:
        have_ts = False
    load_before = os.getloadavg()
    volume_mib = n ** 3 * 4 / 2 ** 20
    rows, builds, paths = {}, {}, {}
    for chunk in (64, 128):  # both before any reading: each writer forks from the same parent
        paths[chunk] = os.path.join(folder, f"v{n}_c{chunk}.ome.zarr")
        shutil.rmtree(paths[chunk], ignore_errors=True)
        builds[chunk] = build(n, chunk, paths[chunk])
    for chunk in (64, 128):
        path, b = paths[chunk], builds[chunk]
        store = MultiscaleStore(path)
        indices = bricks(store, args.bricks)
        voxels_mb = sum(store.read_chunk(0, i).nbytes for i in indices) / 1e6
        zr = time_zarr(store, indices, args.repeats)
        raw = sum(int(np.prod(lv.shape)) * lv.dtype.itemsize for lv in store.levels)
        row = dict(build=b, disk=disk_bytes(path), raw=raw, n_chunks=len(indices), mb=voxels_mb, zarr=zr)
        if have_ts:
            row["ts_one"], row["ts_all"] = time_tensorstore(store, indices, args.repeats)
        rows[chunk] = row
        shutil.rmtree(path, ignore_errors=True)
    load_after = os.getloadavg()

    r64, r128 = rows[64], rows[128]
    lines = [f"volume {n}^3 float32 ({volume_mib:.0f} MiB), procedural; load average (1, 5, 15 min) "
             f"{' '.join(f'{v:.2f}' for v in load_before)} before, {' '.join(f'{v:.2f}' for v in load_after)} after",
             "",
             f"| {'':44} | {'chunk 64':>14} | {'chunk 128':>14} |",
             f"|{'-' * 46}|{'-' * 16}|{'-' * 16}|"]

    def row(label, f):
        lines.append(f"| {label:44} | {f(r64):>14} | {f(r128):>14} |")

    row("build: seconds", lambda r: f"{r['build']['seconds']:.1f}")
    row("build: levels, shard files", lambda r: f"{r['build']['levels']}, {r['build']['shards']}")
    row("build: shards/s", lambda r: f"{r['build']['shards'] / r['build']['seconds']:.1f}")
    row("build: MB/s of level 0", lambda r: f"{n ** 3 * 4 / 1e6 / r['build']['seconds']:.0f}")
    row("build: peak RSS MiB (RSS before)", lambda r: f"{r['build']['rss_peak']:.0f} ({r['build']['rss_before']:.0f})")
    row("build: (peak - before) / volume",
        lambda r: f"{(r['build']['rss_peak'] - r['build']['rss_before']) / volume_mib:.2f}")
    row("bytes on disk (all levels), MiB", lambda r: f"{r['disk'] / 2 ** 20:.1f}")
    row("compression ratio (all levels)", lambda r: f"{r['raw'] / r['disk']:.2f}")
    row("random level-0 chunks read", lambda r: f"{r['n_chunks']} ({r['mb']:.0f} MB)")
    row("zarr-python: ms per chunk", lambda r: f"{1e3 * r['zarr'] / r['n_chunks']:.2f}")
    row("zarr-python: MB/s", lambda r: f"{r['mb'] / r['zarr']:.0f}")
    if have_ts:
        row("tensorstore one at a time: ms per chunk", lambda r: f"{1e3 * r['ts_one'] / r['n_chunks']:.2f}")
        row("tensorstore all at once: ms per chunk", lambda r: f"{1e3 * r['ts_all'] / r['n_chunks']:.2f}")
        row("zarr-python / tensorstore one at a time", lambda r: f"{r['zarr'] / r['ts_one']:.2f}")
        row("zarr-python / tensorstore all at once", lambda r: f"{r['zarr'] / r['ts_all']:.2f}")
    else:
        lines.append("(tensorstore not installed: pip install tensorstore for its columns)")
    lines.append("")
    lines.append(f"chunk 128 / chunk 64, time per voxel read (zarr-python): "
                 f"{(r128['zarr'] / r128['mb']) / (r64['zarr'] / r64['mb']):.2f}")
    print("\n".join(lines))
    if not args.folder:
        shutil.rmtree(folder, ignore_errors=True)
    return rows


if __name__ == "__main__":
    main()
