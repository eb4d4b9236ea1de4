"""Where a first render's time goes with an empty numba cache: compile time per kernel.

Runs one render of ``--data`` in ``--mode`` in this process with ``NUMBA_CACHE_DIR`` set
to a fresh empty folder (set before numba is imported), records numba's
``numba:compile`` events, and prints the render's wall time and, per compiled function
and signature, its *inclusive* compile time (a function's time includes what it
compiled inside it: a kernel's callees appear again below it). The signatures show
which specialisations a render compiles, used or not (e.g. one compositing loop per
precision).

Modes (``--mode``): ``plain`` (emission-absorption), ``shade`` (Blinn-Phong, one
headlight), ``maximum`` (maximum intensity projection), ``lens`` (a sampling-rate lens:
its rays carry a level of detail, so the render samples a mip-map), ``labels`` (two
labels, one composite and one maximum: two-level rendering). A tetrahedral mesh
(``--data bluntfin``) takes ``plain`` and ``shade``. Several modes (or ``all``) run
one after the other, each in a fresh process with its own empty cache, and end with a
table of their wall times.

    python3 benchmarks/bench_compile.py --data engine          # an image volume, float32
    python3 benchmarks/bench_compile.py --data engine --mode shade --top 20
    python3 benchmarks/bench_compile.py --data bluntfin
    python3 benchmarks/bench_compile.py --mode all            # every grid mode, then the mesh
    PYTHONPATH=. /usr/bin/python3 benchmarks/bench_compile.py --mode all  # Debian's numba 0.56
                                                                # (VTK from python3-paraview)

The data directory is ``../shared/data`` relative to the repository root, or
``$PV_HDRVOL_DATA``.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DATA = {"engine": "structured/engine_256x256x128_uint8.vti", "hydrogen": "hdr/hydrogen_64x64x64_float32.vti",
        "bluntfin": "unstructured/bluntfin_187395tets.vtu"}
GRID_MODES = ("plain", "shade", "maximum", "lens", "labels")
MESH_MODES = ("plain", "shade")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", choices=sorted(DATA), default="engine")
    ap.add_argument("--mode", nargs="+", default=["plain"], choices=GRID_MODES + ("all",))
    ap.add_argument("--precision", default="float32")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--top", type=int, default=14, help="rows of the per-function table")
    args = ap.parse_args(argv)
    if args.mode == ["all"] or len(args.mode) > 1:
        return several(args)
    mode = args.mode[0]
    mesh = DATA[args.data].endswith(".vtu")
    if mesh and mode not in MESH_MODES:
        ap.error(f"a tetrahedral mesh renders in modes {MESH_MODES}; got {mode!r}")

    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="pv_hdrvol_cold_")
    import numba
    import numpy as np
    from numba.core import event
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLUnstructuredGridReader

    import pv_hdrvol as hv

    root = Path(os.environ.get("PV_HDRVOL_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
    # plain VTK readers, so that Debian's Python (ParaView's VTK, no PyVista) runs this too
    reader = (vtkXMLUnstructuredGridReader if mesh else vtkXMLImageDataReader)()
    reader.SetFileName(str(root / DATA[args.data]))
    reader.Update()
    dataset = reader.GetOutput()
    kw = {}
    if mode == "shade":
        kw["shade"] = True
    elif mode == "maximum":
        kw["blending"] = "maximum"
    elif mode == "lens":
        kw["lens"] = hv.SamplingRateLens((args.size / 2, args.size / 2), args.size / 3)
    elif mode == "labels":
        nx, ny, nz = dataset.GetDimensions()
        labels = np.zeros((nz, ny, nx), np.int32)
        labels[:, :, nx // 2:] = 1
        kw.update(labels=labels, label_styles={1: "maximum"})
    t0 = time.perf_counter()
    with event.install_recorder("numba:compile") as recorder:
        hv.render(dataset, None, "iso", (args.size, args.size), precision=args.precision, progress_bar=False, **kw)
    wall = time.perf_counter() - t0

    started, rows = {}, []
    for stamp, e in recorder.buffer:
        key = (id(e.data["dispatcher"]), str(e.data["args"]))
        if e.is_start:
            started[key] = stamp
            continue
        fn = e.data["dispatcher"].py_func
        rows.append((stamp - started.pop(key), f"{fn.__module__.rsplit('.', 1)[-1]}.{fn.__name__}",
                     str(e.data["args"])))
    print(f"numba {numba.__version__}: first {args.data} {mode} render ({args.precision}, {args.size}^2, empty "
          f"cache) {wall:.1f} s; {len(rows)} functions compiled")
    print("| inclusive compile (s) | function | first arguments |\n|--:|---|---|")
    for seconds, name, signature in sorted(rows, reverse=True)[:args.top]:
        print(f"| {seconds:.2f} | {name} | {signature[:70]} |")
    print(f"WALL {args.data} {mode} {wall:.2f} {len(rows)}", flush=True)


def several(args):
    """Each mode in a fresh process (an empty cache of its own), then a table of walls."""
    if args.mode == ["all"]:
        runs = [(args.data if not DATA[args.data].endswith(".vtu") else "engine", m) for m in GRID_MODES]
        runs.append(("bluntfin", "plain"))
    else:
        runs = [(args.data, m) for m in args.mode]
    with open("/proc/loadavg") as f:
        load_before = f.read().split()[0]
    table = []
    for data, mode in runs:
        cmd = [sys.executable, __file__, "--data", data, "--mode", mode, "--precision", args.precision, "--size",
               str(args.size), "--top", str(args.top)]
        out = subprocess.run(cmd, capture_output=True, text=True)
        sys.stdout.write(out.stdout + out.stderr[-2000:])
        walls = [line.split() for line in out.stdout.splitlines() if line.startswith("WALL ")]
        table.append((data, mode, walls[0][3] if walls else "failed", walls[0][4] if walls else "-"))
    with open("/proc/loadavg") as f:
        load_after = f.read().split()[0]
    import numba

    print(f"\nnumba {numba.__version__}, {args.precision}, {args.size}^2, empty cache; load {load_before} -> "
          f"{load_after}")
    print("| data | mode | first render (s) | functions compiled |\n|---|---|--:|--:|")
    for row in table:
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
