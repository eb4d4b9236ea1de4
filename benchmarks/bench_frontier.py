"""The speed-accuracy frontier: time to a given accuracy, ours against VTK's mappers.

Three scenes at ``--size`` (default 512^2), iso camera:

- engine CT with bench_grid's *transparent* transfer function (no ray terminates early),
- bonsai CT with bench_grid's *opaque* one,
- hydrogen (../shared/data, 64^3 float32, 6 decades) with a log-axis transfer function
  whose opacity is proportional to the density (the HDR case).

Each is rendered with our knobs (step, precision, table size, early termination) and
with VTK's ``vtkFixedPointVolumeRayCastMapper`` and ``vtkGPUVolumeRayCastMapper``
(Mesa llvmpipe here) over their sample distances, all with the same camera, control
points and opacity unit distance (bench_grid.VTKScene). The error of each picture is
the RMS over all pixels and the three channels of its RGB against a converged
reference: ours in float64 at step 0.05 voxel, a 2^20-entry table and no early
termination, whose own convergence is checked against the same at step 0.1 (that
difference is printed and must be below the smallest target). Our RGB is the
premultiplied colour over black, clipped to [0, 1] as a window shows it; VTK's is its
8-bit window read back.

Time is the median of ``--frames`` renders after a warm-up, renderers interleaved per
frame round. Prints per scene a table of every setting (time, error) and, per target
RMSE (1e-2, 3e-3, 1e-3, 1e-4), the fastest setting of each renderer that meets it;
``--figure`` draws time against error per renderer. The machine's load is printed.

    python3 benchmarks/bench_frontier.py --figure docs/images/frontier.png
    python3 benchmarks/bench_frontier.py --size 128 --frames 1 --scenes engine   # a quick look
    python3 benchmarks/bench_frontier.py --scenes hydrogen --steps 8 4 2 --tables 256 1024 4096 --peers
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_grid import DATASETS, VTKScene, data_dir, load, read_vti, transfer_functions  # noqa: E402

TARGETS = (1e-2, 3e-3, 1e-3, 1e-4)
STEPS = (2.0, 1.0, 0.5, 0.25, 0.125)
VTK_STEPS = (2.0, 1.0, 0.5, 0.25, 0.125)
REFERENCE_STEP = 0.05


def hydrogen_tf(hv):
    """The hydrogen scene's function: a log axis over 6 decades, opacity in proportion to
    the density (magma colours)."""
    values = np.logspace(-6.0, 0.0, 13)
    opacity = 0.5 * values
    opacity[0] = 0.0
    colors = hv.TransferFunction.ramp(1e-6, 1.0, scale="log", cmap="magma").color_at(values)
    return hv.TransferFunction(values, colors, opacity, scale="log")


def scenes(hv, which):
    """``{name: (vtkImageData, GridVolume, tf)}``."""
    tfs = transfer_functions(hv)
    out = {}
    if "engine" in which:
        image = read_vti(data_dir() / DATASETS["engine"])
        out["engine (transparent)"] = (image, hv.volume_from_dataset(image), tfs["transparent"])
    if "bonsai" in which:
        image = read_vti(data_dir() / DATASETS["bonsai"])
        out["bonsai (opaque)"] = (image, hv.volume_from_dataset(image), tfs["opaque"])
    if "hydrogen" in which:
        image = read_vti(data_dir() / "hdr" / "hydrogen_64x64x64_float32.vti")
        out["hydrogen (log TF)"] = (image, hv.volume_from_dataset(image), hydrogen_tf(hv))
    return out


def our_rgb(img):
    return np.clip(np.asarray(img.rgba[..., :3], dtype=np.float64), 0.0, 1.0)


def rmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", default=["engine", "bonsai", "hydrogen"],
                    choices=["engine", "bonsai", "hydrogen"])
    ap.add_argument("--peers", nargs="*", default=["fixed", "gpu"], choices=["fixed", "gpu"])
    ap.add_argument("--steps", type=float, nargs="+", default=list(STEPS), help="our steps, in voxels")
    ap.add_argument("--tables", type=int, nargs="*", default=[4096, 65536],
                    help="table sizes tried besides the transfer function's own default (float32)")
    ap.add_argument("--figure", default=None, help="PNG of time against error")
    ap.add_argument("--out", default=None, help="JSON of every measurement")
    args = ap.parse_args(argv)

    import pv_hdrvol as hv

    size = (args.size, args.size)
    results = {}
    print(f"load before: {load()}")
    for name, (image, volume, tf) in scenes(hv, args.scenes).items():
        camera = hv.Camera.fit(volume.bounds, "iso")
        unit = float(volume.spacing.min())
        fine_tf = hv.TransferFunction(tf.values, tf.colors, tf.opacities, scale=tf.scale, linthresh=tf.linthresh,
                                      table_size=2**20)
        ref = our_rgb(hv.render(volume, fine_tf, camera, size, precision="float64", step=REFERENCE_STEP,
                                termination=0.0, progress_bar=False))
        check = our_rgb(hv.render(volume, fine_tf, camera, size, precision="float64", step=2 * REFERENCE_STEP,
                                  termination=0.0, progress_bar=False))
        converged = rmse(ref, check)
        print(f"\n## {name}, {args.size}^2: reference step {REFERENCE_STEP} vs {2 * REFERENCE_STEP}: "
              f"RMSE {converged:.2e}; the default table has {tf.table_size:,} entries")

        runs = {}
        for precision in ("float32", "float64"):
            for step in args.steps:
                runs[("ours", f"{precision}, step {step}")] = dict(precision=precision, step=step)
        for table_size in args.tables:
            for step in args.steps:
                t4 = hv.TransferFunction(tf.values, tf.colors, tf.opacities, scale=tf.scale, linthresh=tf.linthresh,
                                         table_size=table_size)
                runs[("ours", f"float32, step {step}, table {table_size}")] = dict(step=step, tf=t4)
        for step in (1.0, 0.5):
            runs[("ours", f"float32, step {step}, termination 1e-3")] = dict(step=step, termination=1e-3)

        def ours(kw):
            kw = dict(kw)
            t = kw.pop("tf", tf)
            return lambda: hv.render(volume, t, camera, size, progress_bar=False, **kw)

        frames = {key: ours(kw) for key, kw in runs.items()}
        scenes_vtk = []
        for kind in args.peers:
            for step in VTK_STEPS:
                scene = VTKScene(kind, image, tf, camera, size, step, unit)
                scenes_vtk.append(scene)
                frames[(f"VTK {kind}", f"sample distance {step}")] = scene

        pictures, times = {}, {key: [] for key in frames}
        for key, frame in frames.items():  # warm-up, and the picture
            if hasattr(frame, "render"):
                frame.render()
                pictures[key] = frame.luminance()[1].astype(np.float64) / 255.0
            else:
                pictures[key] = our_rgb(frame())
        for _ in range(args.frames):
            for key, frame in frames.items():
                if hasattr(frame, "render"):
                    times[key].append(frame.render())
                else:
                    t = time.perf_counter()
                    frame()
                    times[key].append(time.perf_counter() - t)
        for scene in scenes_vtk:
            scene.close()

        rows = []
        for key in frames:
            rows.append({"renderer": key[0], "setting": key[1], "seconds": statistics.median(times[key]),
                         "rmse": rmse(pictures[key], ref)})
        results[name] = {"reference_convergence": converged, "rows": rows, "load": load()}
        print("| renderer | setting | time (s) | RGB RMSE |\n|---|---|--:|--:|")
        for r in rows:
            print(f"| {r['renderer']} | {r['setting']} | {r['seconds']:.3f} | {r['rmse']:.2e} |")
        print("\n| target RMSE | " + " | ".join(sorted({r["renderer"] for r in rows})) + " |")
        print("|---|" + "---|" * len({r["renderer"] for r in rows}))
        for target in TARGETS:
            cells = []
            for renderer in sorted({r["renderer"] for r in rows}):
                ok = [r for r in rows if r["renderer"] == renderer and r["rmse"] <= target]
                if ok:
                    best = min(ok, key=lambda r: r["seconds"])
                    cells.append(f"{best['seconds']:.3f} s ({best['setting']})")
                else:
                    floor = min(r["rmse"] for r in rows if r["renderer"] == renderer)
                    cells.append(f"not met (floor {floor:.1e})")
            print(f"| {target:g} | " + " | ".join(cells) + " |")
        print(f"load after: {load()}")

    if args.out:
        Path(args.out).write_text(json.dumps(results, indent=1))
    if args.figure:
        draw(results, args.figure)


def draw(results, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(5 * len(results), 4.2), squeeze=False)
    for ax, (name, res) in zip(axes[0], results.items()):
        for renderer in sorted({r["renderer"] for r in res["rows"]}):
            pts = sorted((r["rmse"], r["seconds"]) for r in res["rows"] if r["renderer"] == renderer)
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o", label=renderer, alpha=0.8)
        for target in TARGETS:
            ax.axvline(target, color="0.8", lw=0.8, zorder=0)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("RGB RMSE against the converged reference")
        ax.set_ylabel("seconds per frame")
        ax.set_title(name)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    print("wrote", path)


if __name__ == "__main__":
    main()
