"""``python -m pv_hdrvol.parallel render`` as users run it: serial against 2 and 3 ranks
of ``mpiexec``, each with the numba threads it picks by default, and as before issue 31
(every rank as many threads as the machine has cores, OpenMP threads spinning between
parallel regions) for comparison.

Run: ``python benchmarks/bench_parallel_cli.py [--dataset engine] [--size 512] [--rounds 3]``

Every configuration runs as a fresh process (``mpiexec`` for the ranked ones), round
by round in turn, after one warm-up run of each that fills the numba cache. Per
configuration: the median wall time of the whole command (start-up, reading, render,
writing) and of the render as the command reports it (``render_parallel``'s seconds),
each as a ratio to ``--serial``'s; the threads each rank ran; the load average before
and after. The images are compared with the serial one (bit for bit) and with
``pv-hdrvol render``'s (largest difference over the brightest value).
"""
from __future__ import annotations

import argparse
import os
import pathlib
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import pv_hdrvol as hv

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = pathlib.Path(os.environ.get("PV_HDRVOL_DATA", ROOT.parent / "shared" / "data"))
FILES = {"engine": "structured/engine_256x256x128_uint8.vti", "bonsai": "structured/bonsai_256x256x256_uint8.vti",
         "head": "structured/ct_head_120x120x130_uint8.vtk", "hydrogen": "hdr/hydrogen_64x64x64_float32.vti"}


def load():
    return f"{os.getloadavg()[0]:.2f}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default="engine", choices=sorted(FILES))
    parser.add_argument("--size", type=int, default=512, help="image size (default 512, the command's default)")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--ranks", default="2,3", help="rank counts of mpiexec (default 2,3)")
    parser.add_argument("--no-old", action="store_true",
                        help="skip the runs as before this change (every rank all the cores' threads, OpenMP's "
                             "default wait policy)")
    args = parser.parse_args()

    path = DATA / FILES[args.dataset]
    work = pathlib.Path(tempfile.mkdtemp(prefix="bench_parallel_cli_"))
    mpiexec = os.path.join(os.path.dirname(sys.executable), "mpiexec")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    base = {k: v for k, v in os.environ.items() if k not in ("NUMBA_NUM_THREADS", "OMP_WAIT_POLICY")}
    base["PYTHONPATH"] = str(ROOT)
    render = [sys.executable, "-m", "pv_hdrvol.parallel", "render", str(path), "--size", str(args.size)]
    # as before this change: numba's default threads in every rank (all the cores) and
    # OpenMP's default wait policy (main() without the command's OMP_WAIT_POLICY=PASSIVE)
    before = [sys.executable, "-c", "import sys; from pv_hdrvol.parallel.__main__ import main; sys.exit(main())",
              "render", str(path), "--size", str(args.size)]
    old_env = dict(base, NUMBA_NUM_THREADS=str(cores))
    configs = [("serial", "--serial", render + ["--serial"], base),
               ("serial, 1 thread", "--serial, NUMBA_NUM_THREADS=1", render + ["--serial"],
                dict(base, NUMBA_NUM_THREADS="1"))]
    if not args.no_old:
        configs.append(("serial, before", "before: --serial", before + ["--serial"], old_env))
    for n in [int(x) for x in args.ranks.split(",")]:
        over = " (oversubscribed)" if n > cores else ""
        configs.append((f"{n} ranks", f"mpiexec -n {n}{over}", [mpiexec, "-n", str(n)] + render, base))
        if not args.no_old:
            configs.append((f"{n} ranks, before", f"before: mpiexec -n {n}", [mpiexec, "-n", str(n)] + before,
                            old_env))
    print(f"# bench_parallel_cli: {cores} cores, {args.dataset} ({path.name}), {args.size}^2, {args.rounds} rounds; "
          f"load {load()}", flush=True)

    def run(i, name, command, env, tag):
        out = work / f"{i}_{tag}.exr"
        t = time.perf_counter()
        done = subprocess.run(command + ["-o", str(out)], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              text=True)
        wall = time.perf_counter() - t
        if done.returncode:
            raise SystemExit(f"{name} failed:\n{done.stdout[-3000:]}")
        render_s = float(re.search(r"blocks visible, ([\d.]+) s", done.stdout).group(1))
        threads = re.findall(r"rank \d+: (\d+) threads?", done.stdout)
        return wall, render_s, threads, out

    reference = work / "reference.exr"
    t = time.perf_counter()
    subprocess.run(["pv-hdrvol", "render", str(path), "--size", str(args.size), "-o", str(reference), "--no-progress"],
                   env=base, check=True, stdout=subprocess.DEVNULL)
    single = time.perf_counter() - t
    for i, (name, _, command, env) in enumerate(configs):  # warm-up: numba's cache, the files in memory
        run(i, name, command, env, "warm")
    times = {name: [] for name, *_ in configs}
    threads = {}
    loads = []
    for r in range(args.rounds):
        before = load()
        for i, (name, _, command, env) in enumerate(configs):
            wall, render_s, used, out = run(i, name, command, env, str(r))
            times[name].append((wall, render_s))
            threads[name] = used
        loads.append((before, load()))
        print(f"round {r + 1}: load {before} -> {loads[-1][1]}", flush=True)
    t = time.perf_counter()
    subprocess.run(["pv-hdrvol", "render", str(path), "--size", str(args.size), "-o", str(reference), "--no-progress"],
                   env=base, check=True, stdout=subprocess.DEVNULL)
    single = min(single, time.perf_counter() - t)

    serial_wall = statistics.median(w for w, _ in times["serial"])
    serial_render = statistics.median(s for _, s in times["serial"])
    serial_image = hv.load(work / "0_0.exr").rgba
    ref = hv.load(reference).rgba
    print()
    print(f"| command | threads per rank | wall (s) | / serial | render (s) | / serial | image = serial |")
    print(f"|---|---|--:|--:|--:|--:|---|")
    for i, (name, label, _, _) in enumerate(configs):
        wall = statistics.median(w for w, _ in times[name])
        render_s = statistics.median(s for _, s in times[name])
        same = all(np.array_equal(hv.load(work / f"{i}_{r}.exr").rgba, serial_image) for r in range(args.rounds))
        print(f"| {label} | {', '.join(threads[name])} | {wall:.2f} | {wall / serial_wall:.2f} | {render_s:.2f} | "
              f"{render_s / serial_render:.2f} | {'bit for bit' if same else 'DIFFERS'} |")
    print(f"| pv-hdrvol render (single pass, for reference) | {cores} | {single:.2f} | {single / serial_wall:.2f} | "
          f"| | |")
    err = float(np.abs(serial_image.astype(np.float64) - ref).max() / np.abs(ref).max())
    print(f"\nlargest difference from pv-hdrvol render's image: {err:.2g} of its brightest value; "
          f"loads per round (before -> after): {', '.join(f'{a} -> {b}' for a, b in loads)}")


if __name__ == "__main__":
    main()
