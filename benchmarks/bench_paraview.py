"""Time to the first image of HDR Volume Render in a fresh pvbatch, with an empty and
with a filled numba cache, and the filter's render time inside ParaView against
``hv.render`` in the same process.

    python3 benchmarks/bench_paraview.py                         # Debian's numba (0.56)
    python3 benchmarks/bench_paraview.py --numba-site DIR        # a newer numba there:
        /usr/bin/python3 -m pip install --no-deps --target DIR numba llvmlite

Each case runs ``xvfb-run -a pvbatch benchmarks/paraview_first_image.py`` twice with one
fresh NUMBA_CACHE_DIR (cold, then warm) and prints a Markdown table: the process's wall
time, the script's time to the first image (plugin load, read, compile or cache load,
render), and the median of ``--repeats`` re-executions after a property change against
``hv.render`` of the same data, camera and transfer function (same interpreter, same
process, alternating). Notes the machine's load. ParaView's environment is built as
``pv-hdrvol paraview`` prints it; the data come from ../shared/data or $PV_HDRVOL_DATA.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(case, size, repeats, data, cache, site, transfer_function):
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PV_PLUGIN_PATH")}
    path = [str(ROOT / "paraview_plugin" / "shim"), str(ROOT)] + ([site] if site else [])
    env.update(PYTHONPATH=os.pathsep.join(path), PYTHONNOUSERSITE="1", NUMBA_CACHE_DIR=cache)
    command = [shutil.which("xvfb-run"), "-a", "-s", "-screen 0 1280x1024x24", shutil.which("pvbatch"),
               str(ROOT / "benchmarks" / "paraview_first_image.py"), case, str(size), str(repeats), str(data),
               transfer_function]
    t = time.perf_counter()
    done = subprocess.run(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.perf_counter() - t
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f"pvbatch failed ({done.returncode}):\n{done.stdout[-3000:]}")
    return dict(json.loads(lines[-1]), wall=wall)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", nargs="+", default=["engine", "bluntfin"], choices=["engine", "bluntfin"])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--numba-site", default=None, help="a folder with another numba for ParaView's Python")
    ap.add_argument("--transfer-function", default="pv_hdrvol default",
                    choices=["pv_hdrvol default", "Color Map Editor"],
                    help="HDR Volume Render's Transfer Function (Color Map Editor: the array's ParaView colour map)")
    args = ap.parse_args(argv)
    data = Path(os.environ.get("PV_HDRVOL_DATA", ROOT.parent / "shared" / "data"))
    print(f"load average before: {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    print(f"transfer function: {args.transfer_function}")
    print("| data | numba | cache | pvbatch wall (s) | first image in script (s) | of which filter made and "
          "rendered (s) | render in ParaView (s) | hv.render (s) | ratio |\n|---|---|---|--:|--:|--:|--:|--:|--:|")
    for case in args.data:
        cache = tempfile.mkdtemp(prefix="pv_hdrvol_bench_numba_")
        for state in ("cold", "warm"):
            r = run(case, args.size, args.repeats, data, cache, args.numba_site, args.transfer_function)
            print(f"| {case} {args.size}² | {r['numba']} | {state} | {r['wall']:.1f} | {r['t_first_image']:.1f} "
                  f"| {r['t_first_image'] - r['t_read']:.1f} "
                  f"| {r['render_paraview']:.3f} | {r['render_hv']:.3f} "
                  f"| {r['render_paraview'] / r['render_hv']:.3f} |", flush=True)
        shutil.rmtree(cache, ignore_errors=True)
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
