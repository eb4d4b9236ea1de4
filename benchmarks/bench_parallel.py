"""Parallel rendering: real ``mpiexec -n 1/2/4`` runs on this machine, and the simulated
scaling to 1,024 ranks from one-core block costs (pv_hdrvol.parallel.simulate).

Run: ``python benchmarks/bench_parallel.py [--dataset engine] [--size 256] [--ranks 1,2,4]``

Prints, for the real runs, the wall time and the per-rank split (cull, render,
composite); for the model, per curve (Hilbert, Z, contiguous, random) and network
(Myrinet-era, modern), the time, speedup, efficiency, blocks per rank and imbalance at
P = 1 ... 1024, beside the paper's 89 % (16 ranks) and 81 % (32 ranks) efficiency.
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import platform
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

import pv_hdrvol as hv
from pv_hdrvol.culling.pof import PlenopticOpacity
from pv_hdrvol.parallel.simulate import measure, simulate
from pv_hdrvol.raycast.grid import as_volume

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = pathlib.Path(os.environ.get("PV_HDRVOL_DATA", ROOT.parent / "shared" / "data"))
FILES = {"engine": "engine_256x256x128_uint8.vti", "bonsai": "bonsai_256x256x256_uint8.vti"}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="engine", choices=sorted(FILES))
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--ranks", default="1,2,4")
    parser.add_argument("--block-size", type=int, default=16)
    parser.add_argument("--model-only", action="store_true", help="skip the mpiexec runs")
    parser.add_argument("--plot", help="write the efficiency curves to this PNG (docs/images/parallel_efficiency.png)")
    args = parser.parse_args()
    import pyvista as pv

    path = DATA / "structured" / FILES[args.dataset]
    volume = as_volume(pv.read(path))
    tf = hv.TransferFunction([0, 60, 100, 255], [(0, 0, 0), (1, 0.9, 0.8), (1, 0.9, 0.8), (1, 1, 1)],
                             [0, 0, 0.2, 0.6], table_size=256)
    size = (args.size, args.size)
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    print(f"# bench_parallel: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load "
          f"{os.getloadavg()[0]:.2f}; {args.dataset}, {args.size}^2, blocks {args.block_size}^3")
    work = pathlib.Path(tempfile.mkdtemp())
    t = time.perf_counter()
    pof = PlenopticOpacity.compute(volume, [tf], block_size=args.block_size)
    pof.save(work / "v.pof.npz")
    print(f"POF: {time.perf_counter() - t:.1f} s")

    if not args.model_only:
        real_runs(args, path, work)
    model(args, volume, tf, camera, size, pof, work)


def real_runs(args, path, work):
    """mpiexec -n P for each P of --ranks: the same image on every rank count, times per rank."""
    mpiexec = os.path.join(os.path.dirname(sys.executable), "mpiexec")
    env = dict(os.environ, NUMBA_NUM_THREADS="1", PYTHONPATH=str(ROOT))
    for p in [int(x) for x in args.ranks.split(",")]:
        command = [mpiexec, "-n", str(p), sys.executable, "-m", "pv_hdrvol.parallel", "render", str(path), "--pof",
                   str(work / "v.pof.npz"), "--size", str(args.size), str(args.size), "-o", str(work / f"p{p}.exr")]
        done = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        wall = re.search(r"([\d.]+) s\n", done.stdout)
        print(f"mpiexec -n {p}: {wall.group(1) if wall else '?'} s (after compilation)")
        print("\n".join("  " + line.strip() for line in done.stdout.splitlines() if line.strip().startswith("rank")))
    images = [hv.load(work / f"p{p}.exr").rgba for p in [int(x) for x in args.ranks.split(",")]]
    print("images equal across rank counts:", all(np.array_equal(images[0], im) for im in images[1:]))



def model(args, volume, tf, camera, size, pof, work):
    """The scaling model from one-core block costs, and optionally its plot."""
    t = time.perf_counter()
    costs = measure(volume, hv.TransferFunction.family([tf]), camera, size, pof=pof, block_size=args.block_size,
                    repeat=2)
    print(f"block costs: {int(costs.visible.sum())} visible blocks, {costs.seconds.sum():.2f} s of block renders, "
          f"{costs.test_seconds * 1e6:.1f} us per culling test, {costs.pixel_seconds * 1e9:.1f} ns per composited "
          f"pixel (measured in {time.perf_counter() - t:.0f} s)")
    ranks = [1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024]
    results = {}
    for network in ("myrinet", "modern"):
        for curve in ("hilbert", "z", "contiguous", "random"):
            rows = simulate(costs, ranks, curve, network)
            results[f"{network}/{curve}"] = rows
            print(f"{network:8s} {curve:10s} " + " ".join(
                f"P={r['ranks']}:{r['efficiency']:.0%}/{r['imbalance']:.2f}" for r in rows))
    print("(efficiency / imbalance = largest rank's render time over the mean; paper: 89 % at 16, 81 % at 32)")
    (work / "simulation.json").write_text(json.dumps(results))
    print(f"tables: {work / 'simulation.json'}")
    if args.plot:
        plot(results, args, int(costs.visible.sum()))


def plot(results, args, n_visible):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2))
    for curve, colour in (("hilbert", "C0"), ("z", "C1"), ("contiguous", "C2"), ("random", "C3")):
        rows = results[f"modern/{curve}"]
        ax.plot([r["ranks"] for r in rows], [r["efficiency"] for r in rows], "o-", color=colour, ms=3,
                label=f"{curve}, modern network")
    rows = results["myrinet/hilbert"]
    ax.plot([r["ranks"] for r in rows], [r["efficiency"] for r in rows], "--", color="C0",
            label="hilbert, Myrinet-era network")
    ax.plot([16, 32], [0.89, 0.81], "k*", ms=10, label="paper (110,592 blocks)")
    ax.set_xscale("log", base=2)
    ax.set_ylim(0, 1.05)
    ax.set_xlabel("ranks")
    ax.set_ylabel("parallel efficiency (model)")
    ax.set_title(f"{args.dataset}, {n_visible} visible {args.block_size}³ blocks, {args.size}² (one-core block costs)",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.plot, dpi=90)
    print("wrote", args.plot)


if __name__ == "__main__":
    main()
