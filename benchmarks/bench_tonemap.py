"""Tone-mapping operators: time per frame against OpenCV's, and detail kept, in one run.

    python3 benchmarks/bench_tonemap.py                   # 1024^2 and 2048^2
    python3 benchmarks/bench_tonemap.py --sizes 512 --repeat 3
    python3 benchmarks/bench_tonemap.py --out tonemap.json

Input: the hydrogen orbital density of ../shared/data (6 decades) rendered once at the
largest size with a log-scale transfer function in float64; smaller sizes are that
render block-averaged (so every size shows the same picture). Each operator runs once
to warm up (numba JIT), then ``--repeat`` times; the median is reported, with the load
average beside it (the machine is shared). OpenCV runs in the same process on the same
float32 image: ``Tonemap`` (gamma), ``TonemapDrago``, ``TonemapReinhard`` (its own
global variant with chromatic adaptation, not the same formula as ours),
``TonemapMantiuk`` and, where the build has it, ``xphoto.TonemapDurand`` (opencv-contrib
with OPENCV_ENABLE_NONFREE; the PyPI wheels leave it out as patented).

Detail kept: :func:`pv_hdrvol.image.detail.detail_preserved` of each of our operators
against the float64 render, and of the 8-bit pipeline (``precision="uint8"``, shown as
it is) as the baseline.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]

OURS = [
    ("linear", {}), ("gamma", {}), ("reinhard", {}), ("drago", {}),
    ("reinhard", {"local": True}), ("durand", {}), ("fattal", {}),
]
TARGET_MS_1024 = {"linear": 20, "gamma": 20, "reinhard": 20, "drago": 20, "durand": 200, "fattal": 1000}


def data_dir():
    return Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data"))


def render_input(size, precision="float64"):
    import pv_hdrvol as hv
    import pyvista as pv

    grid = pv.read(data_dir() / "hdr" / "hydrogen_64x64x64_float32.vti")
    tf = hv.TransferFunction.ramp(1e-6, 1.0, scale="log", cmap="magma", opacity=(0.0, 0.5))
    return hv.render(grid, tf, size=(size, size), precision=precision, global_alpha=0.2, progress_bar=False)


def block_average(rgb, factor):
    if factor == 1:
        return rgb
    h, w = rgb.shape[0] // factor, rgb.shape[1] // factor
    return rgb[:h * factor, :w * factor].reshape(h, factor, w, factor, -1).mean(axis=(1, 3))


def timed(fn, repeat):
    fn()  # warm-up (JIT, caches)
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return ts


def opencv_ops():
    try:
        import cv2
    except ImportError:
        return {}
    ops = {
        "cv Tonemap(gamma 2.2)": lambda: cv2.createTonemap(2.2),
        "cv Drago": lambda: cv2.createTonemapDrago(1.0, 1.0, 0.85),
        "cv Reinhard": lambda: cv2.createTonemapReinhard(1.0, 0.0, 0.0, 0.0),
        "cv Mantiuk": lambda: cv2.createTonemapMantiuk(2.2, 0.85, 1.2),
    }
    try:  # patented: only in OpenCV builds with OPENCV_ENABLE_NONFREE (not the PyPI wheels)
        cv2.xphoto.createTonemapDurand(2.2, 4.0, 1.0, 2.0, 2.0)
        ops["cv xphoto Durand"] = lambda: cv2.xphoto.createTonemapDurand(2.2, 4.0, 1.0, 2.0, 2.0)
    except (AttributeError, cv2.error):
        print("note: this OpenCV has no xphoto.TonemapDurand (non-free); Durand has no peer here")
    return ops


def main(argv=None):
    import pv_hdrvol as hv
    from pv_hdrvol.image.detail import detail_preserved

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)

    biggest = max(args.sizes)
    t = time.perf_counter()
    ref = render_input(biggest)
    base8 = render_input(biggest, "uint8")
    render_s = time.perf_counter() - t
    results = {"machine": platform.platform(), "cpus": os.cpu_count(), "render_seconds": render_s, "cases": []}
    import numba

    results["numba_threads"] = numba.get_num_threads()
    for size in sorted(args.sizes):
        rgb = np.ascontiguousarray(block_average(ref.rgba.astype(np.float64), biggest // size)).astype(np.float32)
        img = hv.HDRImage(rgb)
        rgb8 = block_average(base8.rgba.astype(np.float64), biggest // size)
        row = {"size": size, "ours": {}, "opencv": {}, "detail": {}}
        load0 = os.getloadavg()[0]
        for name, params in OURS:
            label = name + (" local" if params.get("local") else "")
            ts = timed(lambda: hv.tonemap(img, name, **params), args.repeat)
            row["ours"][label] = ts
            row["detail"][label] = detail_preserved(img, hv.tonemap(img, name, **params))
        bgr = np.ascontiguousarray(rgb[..., 2::-1])
        for label, make in opencv_ops().items():
            op = make()
            row["opencv"][label] = timed(lambda: op.process(bgr), args.repeat)
        # the 8-bit pipeline, shown as it is (its buffer already is the display range)
        row["detail"]["8-bit pipeline (uint8)"] = detail_preserved(
            img, hv.tonemap(rgb8.astype(np.float32), "linear", exposure_stops=0.0))
        row["load"] = (load0, os.getloadavg()[0])
        results["cases"].append(row)
    print(markdown(results))
    if args.out:
        args.out.write_text(json.dumps(results, indent=1))


def markdown(results):
    lines = [f"Machine: {results['machine']}, {results['cpus']} CPUs, numba threads {results['numba_threads']}.",
             "Median ms per frame (float32 RGB in, 8-bit-ready display values out).", ""]
    sizes = [c["size"] for c in results["cases"]]
    lines.append("| operator | " + " | ".join(f"{s}² ms" for s in sizes) + " | target at 1024² | detail kept (1024²) |")
    lines.append("|---|" + "--:|" * len(sizes) + "--:|--:|")
    first = results["cases"][0]
    ref_case = next((c for c in results["cases"] if c["size"] == 1024), first)
    for label in first["ours"]:
        ms = [f"{np.median(c['ours'][label]) * 1e3:.1f}" for c in results["cases"]]
        target = TARGET_MS_1024.get(label.split()[0] if "local" not in label else "", "")
        lines.append(f"| ours {label} | " + " | ".join(ms) + f" | {target} | {ref_case['detail'][label]:.3f} |")
    for label in first["opencv"]:
        ms = [f"{np.median(c['opencv'][label]) * 1e3:.1f}" for c in results["cases"]]
        lines.append(f"| {label} | " + " | ".join(ms) + " | | |")
    lines.append(f"| 8-bit pipeline (uint8 render) | " + " | ".join("" for _ in sizes)
                 + f" | | {ref_case['detail']['8-bit pipeline (uint8)']:.3f} |")
    loads = ", ".join(f"{c['size']}²: {c['load'][0]:.2f} -> {c['load'][1]:.2f}" for c in results["cases"])
    lines += ["", f"Load average (1 min) before -> after each size: {loads}."]
    return "\n".join(lines)


if __name__ == "__main__":
    main()
