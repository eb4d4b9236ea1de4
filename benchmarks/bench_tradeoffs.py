"""Speed against accuracy for every knob of the grid renderer.

Each knob (step, precision, table size, early-termination threshold, image size, block
size) is varied alone from the defaults; each render is compared with a reference
rendered in float64 at step 0.05 voxels, a 2**20-entry table, no early termination,
at full size. Reports the median time of ``--repeat`` renders and three errors:

* ``rel_rms``: RMS of the luminance error over covered pixels, relative to the RMS
  reference luminance;
* ``max_alpha``: largest absolute error of accumulated opacity;
* ``log_err``: median |log10(Y / Y_ref)| over pixels non-zero in both, the error that
  matters for HDR pictures where faint pixels are 10 decades below bright ones;
* ``lost``: the share of the reference's non-zero pixels that came out black;
* the knob's own error: the same knob setting with every *other* setting at reference
  quality, so that the default step's error does not hide, say, the table's.

Run: ``python benchmarks/bench_tradeoffs.py [--size 256] [--out docs/tradeoffs.md]``.
Datasets: the embedded hydrogen 3d orbital (HDR, log transfer function) and, when
../shared/data is there, the engine CT (linear transfer function).
"""
from __future__ import annotations

import argparse
import os
import pathlib
import platform
import statistics
import sys
import time

import numpy as np

import pv_hdrvol as hv
from pv_hdrvol import datasets

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = pathlib.Path(os.environ.get("PV_HDRVOL_DATA", ROOT.parent / "shared" / "data"))


def scenes(size):
    vals, spacing, origin = datasets.hydrogen_orbital_array(size=96)
    vol = hv.volume_from_array(vals, spacing, origin, name="probability_density")
    tf = datasets.demo_transfer_function()
    yield "hydrogen 3d (HDR, log TF)", vol, tf, hv.Camera.fit(vol, "iso", zoom=1.4)
    engine = DATA / "structured" / "engine_256x256x128_uint8.vti"
    if engine.exists():
        import pyvista as pv

        vol = hv.volume_from_dataset(pv.read(engine))
        tf = hv.TransferFunction.ramp(60, 255, cmap="bone", opacity=(0.0, 0.2))
        yield "engine CT (linear TF)", vol, tf, hv.Camera.fit(vol, "iso", zoom=1.6)


def timed(repeat, fn):
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def errors(img, ref):
    """``(rel_rms, max_alpha, median_log_error, lost)``, see the module docstring."""
    y, y0 = img.luminance, ref.luminance
    cov = (y0 > 0) & np.isfinite(y0)
    if not cov.any():
        return float("nan"), float("nan"), float("nan"), float("nan")
    rel_rms = float(np.sqrt(np.mean((y[cov] - y0[cov]) ** 2)) / np.sqrt(np.mean(y0[cov] ** 2)))
    max_alpha = float(np.abs(img.rgba[..., 3].astype(np.float64) - ref.rgba[..., 3]).max())
    both = cov & (y > 0)
    log_err = float(np.median(np.abs(np.log10(y[both] / y0[both])))) if both.any() else float("nan")
    lost = float(np.mean(y[cov] <= 0))
    return rel_rms, max_alpha, log_err, lost


def upsample_bilinear(img, size):
    """Bilinear resize of an HDRImage's RGBA to ``size`` (pixel-centre aligned)."""
    h, w = img.shape
    rows = (np.arange(size) + 0.5) * h / size - 0.5
    cols = (np.arange(size) + 0.5) * w / size - 0.5
    r0 = np.clip(np.floor(rows).astype(int), 0, h - 1)
    c0 = np.clip(np.floor(cols).astype(int), 0, w - 1)
    r1, c1 = np.minimum(r0 + 1, h - 1), np.minimum(c0 + 1, w - 1)
    fr = np.clip(rows - r0, 0, 1)[:, None, None]
    fc = np.clip(cols - c0, 0, 1)[None, :, None]
    a = img.rgba.astype(np.float64)
    top = a[r0][:, c0] * (1 - fc) + a[r0][:, c1] * fc
    bot = a[r1][:, c0] * (1 - fc) + a[r1][:, c1] * fc
    return hv.HDRImage(top * (1 - fr) + bot * fr)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=None, help="write the markdown tables here")
    args = ap.parse_args(argv)
    size = args.size
    defaults = hv.RenderOptions()
    base = dict(step=defaults.step, precision=defaults.precision, termination=defaults.termination,
                block_size=defaults.block_size)
    lines = [f"Measured {time.strftime('%Y-%m-%d')} on {platform.node() or 'this machine'}, "
             f"{os.cpu_count()} cores, load average at start {os.getloadavg()[0]:.2f}; "
             f"`python benchmarks/bench_tradeoffs.py --size {size}`. Defaults: {base}, table 65,536.", ""]
    for name, vol, tf, cam in scenes(size):
        print(f"## {name}", file=sys.stderr)
        hv.render(vol, tf, cam, (32, 32), **base)  # compile
        ref_tf = hv.TransferFunction(tf.values, tf.colors, tf.opacities, scale=tf.scale, linthresh=tf.linthresh,
                                     color_space=tf.color_space, table_size=2**20)
        _, ref = timed(1, lambda: hv.render(vol, ref_tf, cam, (size, size), step=0.05, precision="float64",
                                            termination=0.0))
        lines += [f"### {name}, {size}x{size}", "",
                  "| knob | value | ms | rel. RMS luminance error | max alpha error | median abs log10 error "
                  "| lost pixels | knob's own rel. RMS error |",
                  "|---|---|---|---|---|---|---|---|"]
        ref_opts = dict(step=0.05, precision="float64", termination=0.0, block_size=8)

        def row(knob, value, t, img, alone=None):
            """``alone``: the knob's setting with every other one at reference quality."""
            e = errors(img, ref)
            own = "" if alone is None else f"{errors(alone, ref)[0]:.2e}"
            lines.append(f"| {knob} | {value} | {t * 1e3:.0f} | {e[0]:.2e} | {e[1]:.2e} | {e[2]:.2e} | {e[3]:.1%} "
                         f"| {own} |")
            print(lines[-1], file=sys.stderr)

        def alone(tf_, **knob):
            return hv.render(vol, tf_, cam, (size, size), **{**ref_opts, **knob})

        for step in (0.1, 0.25, 0.5, 1.0, 2.0):
            row("step (voxels)", step, *timed(args.repeat, lambda: hv.render(vol, tf, cam, (size, size),
                                                                           **{**base, "step": step})),
                alone(ref_tf, step=step))
        for prec in ("float64", "float32", "float16", "uint8"):
            row("precision", prec, *timed(args.repeat, lambda: hv.render(vol, tf, cam, (size, size),
                                                                       **{**base, "precision": prec})),
                alone(ref_tf, precision=prec))
        for n in (256, 4096, 65536, 2**20):
            tfn = hv.TransferFunction(tf.values, tf.colors, tf.opacities, scale=tf.scale, linthresh=tf.linthresh,
                                      color_space=tf.color_space, table_size=n)
            row("table size", n, *timed(args.repeat, lambda: hv.render(vol, tfn, cam, (size, size), **base)),
                alone(tfn))
        for term in (0.0, 1e-6, 1e-4, 1e-2):
            row("termination", term, *timed(args.repeat, lambda: hv.render(vol, tf, cam, (size, size),
                                                                         **{**base, "termination": term})),
                alone(ref_tf, termination=term))
        for small in (size // 4, size // 2, size):
            t, low = timed(args.repeat, lambda: hv.render(vol, tf, cam, (small, small), **base))
            row("image size, bilinear up", f"{small} -> {size}", t, upsample_bilinear(low, size),
                upsample_bilinear(hv.render(vol, ref_tf, cam, (small, small), **ref_opts), size))
        for b in (4, 8, 16, 32):
            row("block size (no accuracy change)", b, *timed(args.repeat, lambda: hv.render(
                vol, tf, cam, (size, size), **{**base, "block_size": b})))
        lines.append("")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        pathlib.Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
