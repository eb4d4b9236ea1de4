"""Where a first render's time goes with an empty numba cache: compile time per kernel.

Runs one render of ``--data`` in this process with ``NUMBA_CACHE_DIR`` set to a fresh
empty folder (set before numba is imported), records numba's ``numba:compile`` events,
and prints the render's wall time and, per compiled function and signature, its
*inclusive* compile time (a function's time includes what it compiled inside it: a
kernel's callees appear again below it). The signatures show which specialisations a
render compiles, used or not (e.g. one compositing loop per precision).

    python3 benchmarks/bench_compile.py --data engine          # an image volume, float32
    python3 benchmarks/bench_compile.py --data bluntfin --top 20
    PYTHONPATH=. /usr/bin/python3 benchmarks/bench_compile.py --data engine  # Debian's numba 0.56
                                                                # (VTK from python3-paraview)

The data directory is ``../shared/data`` relative to the repository root, or
``$PV_HDRVOL_DATA``.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

DATA = {"engine": "structured/engine_256x256x128_uint8.vti", "bluntfin": "unstructured/bluntfin_187395tets.vtu"}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", choices=sorted(DATA), default="engine")
    ap.add_argument("--precision", default="float32")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--top", type=int, default=14, help="rows of the per-function table")
    args = ap.parse_args(argv)

    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="pv_hdrvol_cold_")
    import numba
    from numba.core import event
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLUnstructuredGridReader

    import pv_hdrvol as hv

    root = Path(os.environ.get("PV_HDRVOL_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
    # plain VTK readers, so that Debian's Python (ParaView's VTK, no PyVista) runs this too
    reader = (vtkXMLImageDataReader if DATA[args.data].endswith(".vti") else vtkXMLUnstructuredGridReader)()
    reader.SetFileName(str(root / DATA[args.data]))
    reader.Update()
    dataset = reader.GetOutput()
    t0 = time.perf_counter()
    with event.install_recorder("numba:compile") as recorder:
        hv.render(dataset, None, "iso", (args.size, args.size), precision=args.precision, progress_bar=False)
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
    print(f"numba {numba.__version__}: first {args.data} render ({args.precision}, {args.size}^2, empty cache) "
          f"{wall:.1f} s; {len(rows)} functions compiled")
    print("| inclusive compile (s) | function | first arguments |\n|--:|---|---|")
    for seconds, name, signature in sorted(rows, reverse=True)[:args.top]:
        print(f"| {seconds:.2f} | {name} | {signature[:70]} |")


if __name__ == "__main__":
    main()
