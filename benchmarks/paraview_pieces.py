"""HDR Volume Render where the data lives: ``mpiexec -n N pvbatch --mpi --symmetric``
with N = 1 (one rank renders everything: the baseline), 2 and 3, for the engine CT
(an image, split by the reader) and the Blunt Fin (tetrahedra, read on rank 0 and moved
to each rank's box by the filter), with the array's colour map, at 512 x 512.

    python3 benchmarks/paraview_pieces.py [DATA_ROOT]

runs this file under each N (Debian's ``/usr/bin/mpiexec``; ``pv-hdrvol paraview``'s
environment, ``$PV_HDRVOL_PARAVIEW_SITE`` added and ``$NUMBA_CACHE_DIR`` kept; each rank
``NUMBA_NUM_THREADS = max(1, cores // N)``). Inside pvbatch
(``--inside``) it times 5 re-executions after a camera change (median; the first
execution loads the kernels) and prints, per rank, the data it rendered; rank 0 the
largest difference from the 1-rank image (saved by the first run). Prints a table with
the machine's load average.
"""
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
CASES = [("structured/engine_256x256x128_uint8.vti", "ImageFile"),
         ("unstructured/bluntfin_187395tets.vtu", "Density")]
SIZE = (512, 512)


def inside(data_root, folder):
    import numpy as np
    from paraview import servermanager, simple

    import pv_hdrvol as hv

    controller = servermanager.vtkProcessModule.GetProcessModule().GetGlobalController()
    rank, size = controller.GetLocalProcessId(), controller.GetNumberOfProcesses()
    simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))
    results = []
    for name, array in CASES:
        reader = simple.OpenDataFile(os.path.join(data_root, name))
        render = simple.HDRVolumeRender(Input=reader, ImageSize=list(SIZE), Camera="iso")
        render.Scalars = ["POINTS", array]
        render.UpdatePipeline()  # the first: kernels loaded, the mesh moved
        times = []
        for k in range(5):
            render.TransferFunction = render.TransferFunction  # unchanged; the camera below changes
            render.Camera = "iso" if k % 2 else "xy"
            t = time.perf_counter()
            render.UpdatePipeline()
            times.append(time.perf_counter() - t)
        render.Camera = "iso"
        render.UpdatePipeline()
        algorithm = render.GetClientSideObject()
        piece = algorithm.GetLastPiece() or reader.GetClientSideObject().GetOutputDataObject(0)
        record = {"rank": rank, "ranks": size, "data": name, "seconds": statistics.median(times),
                  "cells": piece.GetNumberOfCells(), "kB": piece.GetActualMemorySize()}
        if rank == 0:
            image = hv.HDRImage.from_pyvista(algorithm.GetOutputDataObject(0)).rgba
            reference = os.path.join(folder, os.path.basename(name) + ".npy")
            if size == 1:
                np.save(reference, image)
            record["difference"] = float(np.abs(image - np.load(reference)).max())
        results.append(record)
        simple.Delete(render)
        simple.Delete(reader)
    print("RESULT " + json.dumps(results), flush=True)


def main(data_root):
    cores = os.cpu_count() or 1
    folder = tempfile.mkdtemp(prefix="pv_hdrvol_pieces_")
    # ParaView's Python with this source tree (as `pv-hdrvol paraview` prints it);
    # $PV_HDRVOL_PARAVIEW_SITE: extra packages, $NUMBA_CACHE_DIR: ParaView numba's cache
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PV_PLUGIN_PATH")}
    path = [os.path.join(ROOT, "paraview_plugin", "shim"), ROOT]
    path += [os.environ["PV_HDRVOL_PARAVIEW_SITE"]] if os.environ.get("PV_HDRVOL_PARAVIEW_SITE") else []
    env.update(PYTHONPATH=os.pathsep.join(path), PYTHONNOUSERSITE="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    load = os.getloadavg()[0]
    rows = {}
    for n in (1, 2, 3):
        env["NUMBA_NUM_THREADS"] = str(max(1, cores // n))
        done = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", "/usr/bin/mpiexec", "-n", str(n),
                               "pvbatch", "--mpi", "--symmetric", __file__, "--inside", data_root, folder],
                              env=env, capture_output=True, text=True, timeout=1800)
        for line in done.stdout.splitlines():
            if line.startswith("RESULT "):
                for record in json.loads(line[7:]):
                    rows.setdefault((record["data"], n), []).append(record)
        if not any(key[1] == n for key in rows):
            sys.exit(f"mpiexec -n {n} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    print(f"{SIZE[0]}x{SIZE[1]}, {cores} cores, load average {load:.1f} before and {os.getloadavg()[0]:.1f} after")
    print("| data | ranks | render (s, rank 0) | vs 1 rank | per rank: cells (kB) | max difference from 1 rank |")
    print("|---|--:|--:|--:|---|--:|")
    for name, _ in CASES:
        base = next(r["seconds"] for r in rows[(name, 1)] if r["rank"] == 0)
        for n in (1, 2, 3):
            records = sorted(rows[(name, n)], key=lambda r: r["rank"])
            zero = records[0]
            held = ", ".join(f"{r['cells']} ({r['kB']})" for r in records)
            print(f"| {os.path.basename(name)} | {n} | {zero['seconds']:.3f} | {zero['seconds'] / base:.2f} | {held} "
                  f"| {zero['difference']:.1e} |")


if __name__ == "__main__":
    if "--inside" in sys.argv:
        i = sys.argv.index("--inside")
        inside(sys.argv[i + 1], sys.argv[i + 2])
    else:
        main(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(ROOT), "shared", "data"))
