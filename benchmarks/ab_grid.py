"""Same-process A/B of the grid ray caster at two git revisions.

The grid counterpart of ``ab_tets.py``: on a shared 2-core machine the same frame
drifts by 20-50 % between processes minutes apart, which hides a 10 % change. This
script extracts the package at both revisions (``git archive``), imports both in one
process and renders bench_grid.py's scenes (engine or bonsai, its transparent and
opaque transfer functions, the iso camera, step 0.5 voxel) with one revision, then
the other, frame by frame, so drift hits both alike. It reports each revision's
fastest and median frame, their ratio new/old, the samples per second, and whether
the two revisions' images (RGBA and depth) are bit for bit the same.

    python3 benchmarks/ab_grid.py --old 60bd657 --new HEAD
    python3 benchmarks/ab_grid.py --old 60bd657 --data bonsai --size 512 --threads 2 --frames 9

The first frame of each revision compiles its kernels (about a minute; numba caches
them in the extracted copy, which is removed afterwards).
"""
from __future__ import annotations

import argparse
import importlib
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from ab_tets import extract  # noqa: E402
from bench_grid import DATASETS, STEP, data_dir, load, read_vti, transfer_functions  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True, help="git revision A")
    ap.add_argument("--new", default="HEAD", help="git revision B (default HEAD)")
    ap.add_argument("--data", choices=sorted(DATASETS), default="engine")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--frames", type=int, default=7)
    ap.add_argument("--threads", type=int, default=1, help="numba threads (default 1: the kernel alone)")
    ap.add_argument("--precisions", nargs="+", default=["float32", "float64"])
    ap.add_argument("--tfs", nargs="+", default=["transparent", "opaque"])
    args = ap.parse_args(argv)
    import numba

    numba.set_num_threads(args.threads)
    dataset = read_vti(data_dir() / DATASETS[args.data])
    size = (args.size, args.size)
    with tempfile.TemporaryDirectory() as tmp:
        extract(args.old, tmp, "pvh_a")
        extract(args.new, tmp, "pvh_b")
        sys.path.insert(0, tmp)
        scenes = {}
        for key, name in (("old", "pvh_a"), ("new", "pvh_b")):
            hv = importlib.import_module(name)
            volume = hv.volume_from_dataset(dataset)
            scenes[key] = (hv, volume, transfer_functions(hv), hv.Camera.fit(volume.bounds, "iso"))
        print(f"old {args.old}, new {args.new}; {args.data} {args.size}^2, {args.threads} thread(s), "
              f"{os.cpu_count()} CPUs, load {load()}", flush=True)
        for tf_name in args.tfs:
            for precision in args.precisions:
                def frame(key):
                    hv, volume, tfs, camera = scenes[key]
                    return hv.render(volume, tfs[tf_name], camera, size, precision=precision, step=STEP,
                                     progress_bar=False)

                first = {key: frame(key) for key in scenes}  # compiles, warms the caches
                a, b = first["old"], first["new"]
                same = np.array_equal(a.rgba, b.rgba) and np.array_equal(a.depth, b.depth)
                times = {key: [] for key in scenes}
                for _ in range(args.frames):
                    for key in scenes:
                        t = time.perf_counter()
                        frame(key)
                        times[key].append(time.perf_counter() - t)
                best = {key: min(t) * 1e3 for key, t in times.items()}
                med = {key: statistics.median(t) * 1e3 for key, t in times.items()}
                msps = a.metadata["samples"] / best["old"] / 1e3
                print(f"{tf_name:11s} {precision:7s} old {best['old']:7.1f} / {med['old']:7.1f} ms  "
                      f"new {best['new']:7.1f} / {med['new']:7.1f} ms  new/old {best['new'] / best['old']:.3f} "
                      f"(median {med['new'] / med['old']:.3f})  old {msps:.1f} Msamples/s  "
                      f"images {'bit for bit the same' if same else 'DIFFER'}  load {load()}", flush=True)


if __name__ == "__main__":
    main()
