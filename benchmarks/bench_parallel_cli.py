"""``python -m pv_hdrvol.parallel render`` as users run it: serial against 2 and 3 ranks
of ``mpiexec``, each with the numba threads it picks by default, and as before issue 31
(every rank as many threads as the machine has cores, OpenMP threads spinning between
parallel regions) for comparison.

Run: ``python benchmarks/bench_parallel_cli.py [--dataset engine] [--size 512] [--rounds 3]``

``--single-pass``: instead, ``pv-hdrvol render`` against the command on one rank
(``--serial``, no ``--pof``: one piece, one render) on the same volume, image size and
precision (float32, then float64), each command a fresh process writing ``.npy``: best
wall time of ``--rounds`` after a warm-up of each, the ratio (the goal: at most 1.1),
and the load average; then the largest difference of the command's image from
``pv-hdrvol render``'s, relative to its brightest value, on one rank and under
``mpiexec -n`` each of ``--ranks``; and the render alone in this process (a fresh
volume each time, the transfer function given): ``hv.render`` against
``render_in_pieces(comm=None)`` (the command's path) and ``render_parallel(comm=None)``
(block by block, the command's path before, and still with ``--pof``).

Every configuration runs as a fresh process (``mpiexec`` for the ranked ones), round
by round in turn, after one warm-up run of each that fills the numba cache. Per
configuration: the median wall time of the whole command (start-up, reading, render,
writing) and of the render as the command reports it (the seconds on its first line),
each as a ratio to ``--serial``'s; the threads each rank ran; the load average before
and after. The images are compared with the serial one and with ``pv-hdrvol render``'s
(largest difference over the brightest value): without ``--pof`` each rank renders one
piece, so rank counts agree to rounding, not bit for bit.
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
    parser.add_argument("--single-pass", action="store_true",
                        help="time pv-hdrvol render against the command on one rank, and measure the images' "
                             "difference on one rank and on --ranks")
    args = parser.parse_args()
    if args.single_pass:
        return against_single_pass(DATA / FILES[args.dataset], args.size, args.rounds,
                                   [int(x) for x in args.ranks.split(",")])

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
        render_s = float(re.search(r", ([\d.]+) s$", done.stdout.splitlines()[0]).group(1))
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
    print(f"| command | threads per rank | wall (s) | / serial | render (s) | / serial | image - serial |")
    print(f"|---|---|--:|--:|--:|--:|---|")
    for i, (name, label, _, _) in enumerate(configs):
        wall = statistics.median(w for w, _ in times[name])
        render_s = statistics.median(s for _, s in times[name])
        diff = max(float(np.abs(hv.load(work / f"{i}_{r}.exr").rgba.astype(np.float64) - serial_image).max())
                   for r in range(args.rounds)) / float(np.abs(serial_image).max())
        print(f"| {label} | {', '.join(threads[name])} | {wall:.2f} | {wall / serial_wall:.2f} | {render_s:.2f} | "
              f"{render_s / serial_render:.2f} | {'bit for bit' if diff == 0 else f'{diff:.2g}'} |")
    print(f"| pv-hdrvol render (single pass, for reference) | {cores} | {single:.2f} | {single / serial_wall:.2f} | "
          f"| | |")
    err = float(np.abs(serial_image.astype(np.float64) - ref).max() / np.abs(ref).max())
    print(f"\nlargest difference from pv-hdrvol render's image: {err:.2g} of its brightest value; "
          f"loads per round (before -> after): {', '.join(f'{a} -> {b}' for a, b in loads)}")


def against_single_pass(path, size, rounds, ranks):
    """``pv-hdrvol render`` against ``python -m pv_hdrvol.parallel render --serial`` (see
    the module's notes): a table of best wall times, their ratio and the differences."""
    work = pathlib.Path(tempfile.mkdtemp(prefix="bench_parallel_cli_"))
    mpiexec = os.path.join(os.path.dirname(sys.executable), "mpiexec")
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_NUM_THREADS", "OMP_WAIT_POLICY")}
    env["PYTHONPATH"] = str(ROOT)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"# bench_parallel_cli --single-pass: {cores} cores, {path.name}, {size}^2, best of {rounds} after a "
          f"warm-up; load {load()}", flush=True)

    def commands(precision, out):
        common = [str(path), "--size", str(size), "--precision", precision]
        single = ["pv-hdrvol", "render", *common, "--no-progress", "-o", str(out("single"))]
        parallel = [sys.executable, "-m", "pv_hdrvol.parallel", "render", *common, "-o"]
        return single, parallel

    def timed(command):
        t = time.perf_counter()
        done = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        wall = time.perf_counter() - t
        if done.returncode:
            raise SystemExit(f"{' '.join(command)} failed:\n{done.stdout[-3000:]}")
        return wall, done.stdout

    rows, errors = [], []
    for precision in ("float32", "float64"):
        out = lambda tag: work / f"{precision}_{tag}.npy"  # noqa: E731
        single, parallel = commands(precision, out)
        serial = parallel + [str(out("serial")), "--serial"]
        for command in (single, serial):  # warm-up: numba's cache, the file in memory
            timed(command)
        best = {"single": [], "serial": []}
        loads = [load()]
        for _ in range(rounds):
            best["single"].append(timed(single)[0])
            wall, text = timed(serial)
            best["serial"].append(wall)
            loads.append(load())
        rows.append((precision, min(best["single"]), min(best["serial"]), loads, text.splitlines()[0]))
        reference = np.load(out("single"))[..., :4].astype(np.float64)
        scale = float(np.abs(reference).max())
        runs = [("--serial (1 rank)", out("serial"))]
        for n in ranks:
            target = out(f"mpi{n}")
            timed([mpiexec, "-n", str(n)] + parallel + [str(target)])
            runs.append((f"mpiexec -n {n}", target))
        for name, target in runs:
            image = np.load(target)[..., :4]
            assert image.dtype == np.dtype(precision), (image.dtype, precision)
            errors.append((precision, name, float(np.abs(image - reference).max() / scale),
                           bool(np.array_equal(image, reference))))
    print()
    print("| precision | pv-hdrvol render (s) | parallel --serial (s) | ratio | load during the rounds |")
    print("|---|--:|--:|--:|---|")
    for precision, a, b, loads, _ in rows:
        print(f"| {precision} | {a:.2f} | {b:.2f} | {b / a:.2f} | {' -> '.join(loads)} |")
    print()
    print("| precision | command | largest difference / brightest value | bit for bit |")
    print("|---|---|--:|---|")
    for precision, name, err, same in errors:
        print(f"| {precision} | {name} | {err:.2g} | {'yes' if same else 'no'} |")
    print(f"\n{rows[-1][4]}")
    in_process(path, size, rounds)


def in_process(path, size, rounds):
    """The render alone, best of ``rounds`` after a warm-up, in this process."""
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as the command sets it (render_parallel's advice)
    import pyvista as pv

    from pv_hdrvol.data.grid import volume_from_array, volume_from_dataset
    from pv_hdrvol.parallel.pieces import render_in_pieces
    from pv_hdrvol.parallel.render import render_parallel
    from pv_hdrvol.rays.camera import fit_camera
    from pv_hdrvol.raycast.grid import resolve_transfer_function

    whole = volume_from_dataset(pv.read(path))
    tf = resolve_transfer_function(whole)
    camera = fit_camera(whole, "iso")

    def fresh():  # no arrays derived by an earlier render
        return volume_from_array(whole.values, whole.spacing, whole.origin, name=whole.name)

    runs = {"hv.render": lambda p: hv.render(fresh(), tf, camera, (size, size), precision=p, progress_bar=False),
            "render_in_pieces": lambda p: render_in_pieces(fresh(), tf, camera, (size, size), comm=None, precision=p),
            "render_parallel": lambda p: render_parallel(fresh(), tf, camera, (size, size), comm=None, precision=p)}
    print(f"\nthe render alone, in one process ({os.cpu_count()} cores), best of {rounds} after a warm-up:\n")
    print("| precision | hv.render (s) | render_in_pieces, one piece (s) | ratio | render_parallel, block by block "
          "(s) | ratio | load |")
    print("|---|--:|--:|--:|--:|--:|---|")
    for precision in ("float32", "float64"):
        best = {}
        for name, run in runs.items():
            run(precision)
        for _ in range(rounds):
            for name, run in runs.items():
                t = time.perf_counter()
                run(precision)
                best[name] = min(best.get(name, np.inf), time.perf_counter() - t)
        a, b, c = best["hv.render"], best["render_in_pieces"], best["render_parallel"]
        print(f"| {precision} | {a:.2f} | {b:.2f} | {b / a:.2f} | {c:.2f} | {c / a:.2f} | {load()} |")


if __name__ == "__main__":
    main()
