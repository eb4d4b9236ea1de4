"""The table size each transfer function gets by default, and what it costs and saves.

A ``TransferFunction`` made without ``table_size`` takes the smallest of 256, 512, ...,
65,536 entries whose linear interpolation stays within ``TABLE_TOLERANCE`` (1e-4) of the
function everywhere (``required_table_size``); before, every function had 65,536. For
every dataset of ../shared/data with its default transfer function, and for the three
hand-made functions of bench_frontier, this prints:

- the chosen size and the table's own error there (``table_error``) and at 65,536;
- the render error it causes: RGB RMSE and max |RGBA| of a float64 render against the
  same render with a 2^20-entry table (everything else equal: step 0.5, iso camera);
- the time of a float32 render with the chosen table and with 65,536 entries, median of
  ``--frames`` (interleaved), and their ratio; the machine's load before and after.

    python3 benchmarks/bench_table_size.py                 # 256^2, 5 frames, a few minutes
    python3 benchmarks/bench_table_size.py --size 128 --frames 1 --only hydrogen m4

The data directory is ``../shared/data`` relative to the repository root, or
``$PV_HDRVOL_DATA``.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_grid import data_dir, load  # noqa: E402

FILES = ["structured/engine_256x256x128_uint8.vti", "structured/bonsai_256x256x256_uint8.vti",
         "structured/tooth_103x94x161_uint8.nrrd", "structured/ct_head_120x120x130_uint8.vtk",
         "structured/headsq_64x64x93_int16le.nhdr", "hdr/hydrogen_64x64x64_float32.vti",
         "hdr/m4_total_density_25x22x31_float32.vti", "unstructured/spx_12936tets.vtk",
         "unstructured/bluntfin_187395tets.vtu", "unstructured/post_513375tets.vtu",
         "unstructured/fea_bracket_56786tets.vtu"]


def with_size(hv, tf, n):
    return hv.TransferFunction(tf.values, tf.colors, tf.opacities, scale=tf.scale, linthresh=tf.linthresh,
                               color_space=tf.color_space, table_size=n)


def cases(hv, only):
    import pyvista as pv

    from bench_frontier import scenes
    from pv_hdrvol.raycast.grid import as_volume, default_transfer_function

    for path in FILES:
        name = Path(path).stem
        if only and not any(o in name for o in only):
            continue
        ds = pv.read(data_dir() / path)
        data = as_volume(ds) if isinstance(ds, pv.ImageData) else hv.tetmesh_from_dataset(ds)
        yield f"{name} (default)", data, default_transfer_function(data)
    wanted = [s for s in ("engine", "bonsai", "hydrogen") if not only or s in only]
    for name, (_, volume, tf) in scenes(hv, wanted).items():
        yield f"{name}, bench_frontier", volume, tf


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--only", nargs="*", default=[], help="substrings of the dataset names to run")
    args = ap.parse_args(argv)

    import pv_hdrvol as hv

    size = (args.size, args.size)
    print(f"load before: {load()}")
    print("| data, transfer function | scale | points | entries | table error | at 65,536 | render RMSE | "
          "max abs | time (s) | at 65,536 (s) | ratio |")
    print("|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    for label, data, tf in cases(hv, args.only):
        camera = hv.Camera.fit(data.bounds, "iso")
        n = tf.table_size

        def render(t, precision):
            return hv.render(data, t, camera, size, precision=precision, progress_bar=False)

        ref = np.asarray(render(with_size(hv, tf, 2**20), "float64").rgba, dtype=np.float64)
        got = np.asarray(render(tf, "float64").rgba, dtype=np.float64)
        rgb = np.clip(got[..., :3], 0, 1) - np.clip(ref[..., :3], 0, 1)
        rmse = float(np.sqrt(np.mean(rgb**2)))
        worst = float(np.abs(got - ref).max())
        old = with_size(hv, tf, 65536)
        render(tf, "float32"), render(old, "float32")  # warm-up
        times = {"auto": [], "old": []}
        for _ in range(args.frames):
            for key, t in (("auto", tf), ("old", old)):
                t0 = time.perf_counter()
                render(t, "float32")
                times[key].append(time.perf_counter() - t0)
        ta, to = statistics.median(times["auto"]), statistics.median(times["old"])
        print(f"| {label} | {tf.scale} | {tf.values.size} | {n:,} | {tf.table_error(n):.1e} | "
              f"{tf.table_error(65536):.1e} | {rmse:.1e} | {worst:.1e} | {ta:.3f} | {to:.3f} | {ta / to:.2f} |",
              flush=True)
    print(f"load after: {load()}")


if __name__ == "__main__":
    main()
