"""Lens overhead and the lens's anti-aliasing trade, on engine and bonsai at 512^2.

1. **Overhead.** For each lens type (circular and square magnifier, feature lens,
   sampling-rate lens, 180-degree fisheye) the same scene is rendered with and without
   the lens, frames interleaved (one plain frame, one lens frame per round) so that load
   from other processes hits both alike. The lens frame includes making its rays (the
   user's cost). The Magic Volume Lens paper calls its lenses "only slightly" slower
   than plain ray casting; the target here is at most 25 % overhead. A lens also changes
   *what* each pixel sees (a magnified pixel may cross more material), so the number of
   samples is reported beside the time.

2. **Anti-aliasing (lens sampling).** Where a lens compresses the surround, its rays are
   sparser than the camera's and alias. ``antialias=True`` gives those rays a level of
   detail and samples a mip-map (the paper's Eq. 4). Against a reference -- the same lens
   at 4x the resolution (every parameter scaled), box-filtered down, so each pixel
   averages 16 rays over its footprint -- the RMSE of the luminance over the lens's
   compressed band (pixels with ``lod > 0``) is reported with antialiasing off and on,
   with the time of each.

Usage::

    python3 benchmarks/bench_lenses.py                  # both datasets, ~3 minutes
    python3 benchmarks/bench_lenses.py --data engine --repeat 5 --out results.json
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

DATASETS = {
    "engine": ("structured/engine_256x256x128_uint8.vti", 160),
    "bonsai": ("structured/bonsai_256x256x256_uint8.vti", 100),
}
SIZE = 512
STEP = 0.5


def data_dir():
    return Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data"))


def load():
    return tuple(round(x, 2) for x in os.getloadavg())


def transfer_function():
    import pv_hdrvol as hv

    return hv.TransferFunction([0, 40, 100, 160, 255],
                               [[0, 0, 0], [0.3, 0.5, 0.9], [0.9, 0.8, 0.5], [1.0, 0.5, 0.2], [1, 1, 1]],
                               [0.0, 0.0, 0.01, 0.15, 0.6])


def lenses(volume, feature_threshold, size):
    import pv_hdrvol as hv

    c = (0.47 * size, 0.55 * size)
    r = 0.2 * size
    return {
        "magnifier circle x3": hv.Magnifier(c, radius=r, transition=r / 3, factor=3.0),
        "magnifier square x3": hv.Magnifier(c, radius=r, transition=r / 3, factor=3.0, shape="square"),
        f"feature lens (> {feature_threshold}) x2": hv.FeatureLens.from_range(
            volume, feature_threshold, 255, transition=size / 25, factor=2.0),
        "sampling-rate lens cubic": hv.SamplingRateLens(c, radius=1.2 * r, factor=6.0),
        "fisheye 180°": hv.Fisheye(180.0),
    }


def scaled(lens, k):
    """The same lens at ``k`` times the image size (pixel parameters scaled)."""
    import pv_hdrvol as hv

    if isinstance(lens, hv.Magnifier):
        return dataclasses.replace(lens, center=tuple(k * np.asarray(lens.center) + 0.0), radius=lens.radius * k,
                                   transition=lens.transition * k)
    if isinstance(lens, hv.SamplingRateLens):
        return dataclasses.replace(lens, center=tuple(k * np.asarray(lens.center)), radius=lens.radius * k)
    raise TypeError(type(lens).__name__)


def luminance(rgba):
    return rgba[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])


def overhead(name, volume, feature_threshold, repeat):
    import pv_hdrvol as hv

    tf = transfer_function()
    cam = hv.Camera.fit(volume, "iso", zoom=1.3)
    rows = []
    for label, lens in lenses(volume, feature_threshold, SIZE).items():
        def plain():
            return hv.render(volume, tf, cam, SIZE, step=STEP, progress_bar=False)

        def with_lens():
            return hv.render(volume, tf, cam, SIZE, step=STEP, lens=lens, progress_bar=False)

        no_aa = dataclasses.replace(lens, antialias=False)

        def without_aa():
            return hv.render(volume, tf, cam, SIZE, step=STEP, lens=no_aa, progress_bar=False)

        a, b, c = plain(), with_lens(), without_aa()  # warm-up (JIT, caches, mip-map)
        t_plain, t_lens, t_noaa, t_rays = [], [], [], []
        load0 = load()
        for _ in range(repeat):
            for fn, ts in ((plain, t_plain), (with_lens, t_lens), (without_aa, t_noaa)):
                t = time.perf_counter()
                fn()
                ts.append(time.perf_counter() - t)
            t = time.perf_counter()
            rays = lens.rays(cam, SIZE)
            t_rays.append(time.perf_counter() - t)
        lod = rays.lod
        rows.append({
            "dataset": name, "lens": label, "plain_ms": 1e3 * statistics.median(t_plain),
            "lens_ms": 1e3 * statistics.median(t_lens), "rays_ms": 1e3 * statistics.median(t_rays),
            "no_aa_ms": 1e3 * statistics.median(t_noaa), "no_aa_samples": c.metadata["samples"],
            "plain_samples": a.metadata["samples"], "lens_samples": b.metadata["samples"],
            "mip_rays": 0 if lod is None else int(np.count_nonzero(lod)), "load": (load0, load()),
        })
        r = rows[-1]
        print(f"{name:7s} {label:32s} plain {r['plain_ms']:7.1f} ms  lens {r['lens_ms']:7.1f} ms  "
              f"overhead {100 * (r['lens_ms'] / r['plain_ms'] - 1):+6.1f} %  (no AA {r['no_aa_ms']:.1f} ms, rays "
              f"{r['rays_ms']:.1f} ms, samples x{r['lens_samples'] / r['plain_samples']:.2f}, mip rays "
              f"{r['mip_rays']})", flush=True)
    return rows


def antialias_trade(name, volume, feature_threshold, repeat, k=4):
    import pv_hdrvol as hv

    tf = transfer_function()
    cam = hv.Camera.fit(volume, "iso", zoom=1.3)
    rows = []
    chosen = {n: l for n, l in lenses(volume, feature_threshold, SIZE).items()
              if isinstance(l, (hv.Magnifier, hv.SamplingRateLens))}
    for label, lens in chosen.items():
        big = hv.render(volume, tf, cam, SIZE * k, step=STEP, lens=scaled(lens, k), precision="float64",
                        progress_bar=False)
        ref = luminance(big.rgba).reshape(SIZE, k, SIZE, k).mean(axis=(1, 3))
        band = lens.rays(cam, SIZE).lod
        band = np.zeros(SIZE * SIZE, bool) if band is None else (band > 0)
        band = band.reshape(SIZE, SIZE)
        row = {"dataset": name, "lens": label, "band_pixels": int(band.sum())}
        for aa in (False, True):
            this = dataclasses.replace(lens, antialias=aa)
            ts = []
            for _ in range(repeat):
                t = time.perf_counter()
                img = hv.render(volume, tf, cam, SIZE, step=STEP, lens=this, progress_bar=False)
                ts.append(time.perf_counter() - t)
            err = luminance(img.rgba)[band] - ref[band]
            row["antialias" if aa else "plain"] = {
                "ms": 1e3 * statistics.median(ts), "rmse": float(np.sqrt(np.mean(err ** 2))),
                "rel_rmse": float(np.sqrt(np.mean(err ** 2)) / max(ref[band].mean(), 1e-30)),
            }
        rows.append(row)
        print(f"{name:7s} {label:32s} band {row['band_pixels']:6d} px  RMSE off {row['plain']['rel_rmse']:.4f} "
              f"({row['plain']['ms']:.0f} ms)  on {row['antialias']['rel_rmse']:.4f} ({row['antialias']['ms']:.0f} ms)",
              flush=True)
    return rows


def table_size_trade(repeat):
    """The sampling-rate lens's table: error of the source radius rho(r) in pixels against a
    2**20-entry table, and the time of ``rays()`` at 512^2, per table size."""
    import pv_hdrvol as hv

    cam = hv.Camera((0.0, 0.0, 10.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    c, radius = (256.0, 256.0), 200.0
    r = np.linspace(0.0, radius, 2001)
    ref = hv.SamplingRateLens(c, radius, factor=6.0, table_size=2 ** 20).source_radius(r)
    rows = []
    for n in (16, 64, 256, 1024, 4096, 16384):
        lens = hv.SamplingRateLens(c, radius, factor=6.0, table_size=n)
        err = float(np.max(np.abs(lens.source_radius(r) - ref)))
        ts = []
        for _ in range(repeat):
            t = time.perf_counter()
            lens.rays(cam, SIZE)
            ts.append(time.perf_counter() - t)
        rows.append({"table_size": n, "max_rho_error_px": err, "rays_ms": 1e3 * statistics.median(ts)})
        print(f"sampling-rate table {n:6d}: max |rho - rho_ref| {err:.2e} px, rays() {rows[-1]['rays_ms']:.1f} ms",
              flush=True)
    return rows


def markdown(results):
    lines = [f"Machine: {results['machine']}, {results['cpus']} CPUs, numba threads {results['threads']}; "
             f"load {results['load_start']} -> {results['load_end']}. {SIZE}², step {STEP} voxel, float32, "
             f"median of {results['repeat']} interleaved frames.", "",
             "Overhead = lens frame / plain frame - 1. A lens shows other content than the plain view (a "
             "magnified pixel may cross more material), so the samples ratio and the overhead per sample "
             "(time ratio / samples ratio - 1) are given too.", "",
             "| dataset | lens | plain ms | lens ms | overhead | per sample | lens without AA | of which rays ms "
             "| samples lens/plain | mip rays |",
             "|---|---|--:|--:|--:|--:|--:|--:|--:|--:|"]
    for r in results["overhead"]:
        ratio = r["lens_ms"] / r["plain_ms"]
        sratio = r["lens_samples"] / r["plain_samples"]
        noaa = r["no_aa_ms"] / r["plain_ms"]
        lines.append(f"| {r['dataset']} | {r['lens']} | {r['plain_ms']:.0f} | {r['lens_ms']:.0f} | "
                     f"{100 * (ratio - 1):+.0f} % | {100 * (ratio / sratio - 1):+.0f} % | "
                     f"{r['no_aa_ms']:.0f} ms ({100 * (noaa - 1):+.0f} %) | {r['rays_ms']:.1f} | "
                     f"{sratio:.2f} | {r['mip_rays']} |")
    lines += ["", "Anti-aliasing in the compressed band (relative RMSE of luminance against the lens rendered at "
              "4x and box-filtered):", "",
              "| dataset | lens | band pixels | RMSE, no AA | RMSE, mip-mapped | ms, no AA | ms, mip-mapped |",
              "|---|---|--:|--:|--:|--:|--:|"]
    for r in results["antialias"]:
        lines.append(f"| {r['dataset']} | {r['lens']} | {r['band_pixels']} | {r['plain']['rel_rmse']:.4f} | "
                     f"{r['antialias']['rel_rmse']:.4f} | {r['plain']['ms']:.0f} | {r['antialias']['ms']:.0f} |")
    if results.get("table"):
        lines += ["", "Sampling-rate lens table (cubic rate, factor 6, radius 200 px): largest error of the source "
                  "radius against a 2^20-entry table, and the time of `rays()` at 512²:", "",
                  "| table size | max error (px) | rays() ms |", "|--:|--:|--:|"]
        for r in results["table"]:
            lines.append(f"| {r['table_size']} | {r['max_rho_error_px']:.1e} | {r['rays_ms']:.1f} |")
    return "\n".join(lines)


def main(argv=None):
    import numba

    import pv_hdrvol as hv

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", nargs="+", default=list(DATASETS), choices=list(DATASETS))
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--skip-antialias", action="store_true")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    results = {"machine": platform.platform(), "cpus": os.cpu_count(), "threads": numba.get_num_threads(),
               "repeat": args.repeat, "load_start": load(), "overhead": [], "antialias": []}
    for name in args.data:
        path, threshold = DATASETS[name]
        import pyvista as pv

        volume = hv.volume_from_dataset(pv.read(data_dir() / path))
        results["overhead"] += overhead(name, volume, threshold, args.repeat)
        if not args.skip_antialias:
            results["antialias"] += antialias_trade(name, volume, threshold, max(1, args.repeat // 2))
    results["table"] = table_size_trade(args.repeat)
    results["load_end"] = load()
    print()
    print(markdown(results))
    if args.out:
        args.out.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
