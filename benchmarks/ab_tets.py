"""Same-process A/B of the tetrahedral pipeline at two git revisions.

On a shared 2-core machine the same frame drifts by 20-50 % between processes a few
minutes apart, which hides a 10 % change. This script extracts the package at two
revisions into a temporary directory (``git archive``), imports both in one process
and renders the same scenes with each in turn, frame by frame, so drift hits both
alike. Per mesh it reports the medians of ``render(upsample=f)``'s stages (I: the
low-resolution render, R: the reference, U: the upsampling), the total, and with
``--full`` the full-resolution render and the speedup.

    python3 benchmarks/ab_tets.py --old d6121b0 --new HEAD --meshes "FEA bracket" --full

The first run of a revision compiles its kernels (a few minutes; numba caches them in
the extracted copy, which is removed afterwards). Renders are checked to be equal
between the revisions (``--no-check`` to skip, for changes meant to alter pixels).
"""
from __future__ import annotations

import argparse
import importlib
import io
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_tets import MESHES, OPAQUE, data_dir, load  # noqa: E402


def extract(rev, into, name):
    """The package at ``rev`` as module ``name`` under ``into``."""
    archive = subprocess.run(["git", "-C", str(REPO), "archive", "--format=tar", rev, "pv_hdrvol"],
                             check=True, capture_output=True).stdout
    target = Path(into) / rev.replace("/", "_")
    target.mkdir()
    with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
        tar.extractall(target, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
    (target / "pv_hdrvol").rename(Path(into) / name)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True, help="git revision A")
    ap.add_argument("--new", default="HEAD", help="git revision B (default HEAD)")
    ap.add_argument("--meshes", nargs="+", help="labels (default all four)")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--factor", type=int, default=8)
    ap.add_argument("--frames", type=int, default=9)
    ap.add_argument("--full", action="store_true", help="also time the full-resolution render")
    ap.add_argument("--no-check", action="store_true")
    args = ap.parse_args(argv)
    import pyvista as pv

    with tempfile.TemporaryDirectory() as tmp:
        extract(args.old, tmp, "pvh_a")
        extract(args.new, tmp, "pvh_b")
        sys.path.insert(0, tmp)
        versions = {"old": importlib.import_module("pvh_a"), "new": importlib.import_module("pvh_b")}
        print(f"old {args.old}, new {args.new}; {os.cpu_count()} CPUs, load {load()}", flush=True)
        size = (args.size, args.size)
        for file, scalars, label in MESHES:
            if args.meshes and label not in args.meshes:
                continue
            grid = pv.read(data_dir() / file)
            grid.set_active_scalars(scalars, preference="point" if scalars in grid.point_data else "cell")
            scenes = {}
            for key, hv in versions.items():
                mesh = hv.tetmesh_from_dataset(grid, scalars)
                lo, hi = mesh.value_range
                tf = hv.TransferFunction.ramp(lo, hi, cmap="viridis", opacity=OPAQUE["opacity"])
                camera = hv.Camera.fit(mesh.bounds, "iso")
                opts = {"opacity_unit_distance": mesh.default_unit_distance() * OPAQUE["unit_factor"],
                        "progress_bar": False}
                first = hv.render(mesh, tf, camera, size, upsample=args.factor, **opts)  # compiles, warms
                scenes[key] = (hv, mesh, tf, camera, opts, first)
            if not args.no_check:
                a, b = scenes["old"][5].rgba, scenes["new"][5].rgba
                if not np.array_equal(a, b):
                    print(f"{label}: the revisions' upsampled images differ (max {np.abs(a - b).max():.3g})")
            times = {key: {"I": [], "R": [], "U": [], "total": [], "full": []} for key in scenes}
            for _ in range(args.frames):
                for key, (hv, mesh, tf, camera, opts, _) in scenes.items():
                    t = time.perf_counter()
                    img = hv.render(mesh, tf, camera, size, upsample=args.factor, **opts)
                    times[key]["total"].append(time.perf_counter() - t)
                    times[key]["I"].append(img.metadata["low_render_seconds"])
                    times[key]["R"].append(img.metadata["reference_seconds"])
                    times[key]["U"].append(img.metadata["upsample_seconds"])
                    if args.full:
                        t = time.perf_counter()
                        hv.render(mesh, tf, camera, size, **opts)
                        times[key]["full"].append(time.perf_counter() - t)
            med = {key: {k: statistics.median(v) * 1e3 for k, v in t.items() if v} for key, t in times.items()}
            for key, m in med.items():
                line = f"{label} {key}: " + " ".join(f"{k} {m[k]:.1f}" for k in ("I", "R", "U", "total")) + " ms"
                if args.full:
                    line += f", full {m['full']:.0f} ms, speedup {m['full'] / m['total']:.1f}x"
                print(line, flush=True)
            print(f"{label}: new/old total {med['new']['total'] / med['old']['total']:.3f}, load {load()}",
                  flush=True)


if __name__ == "__main__":
    main()
