"""Rectilinear grids: time against the uniform grid of the same dimensions, and accuracy.

A smooth field (a Gaussian blob plus a linear ramp) on 128^3 points, rendered by
``hv.render`` as a ``pyvista.ImageData`` (uniform) and as a ``pyvista.RectilinearGrid``
of the same dimensions and bounds whose spacing varies 2x along x and y (fine in the
middle, coarse at the sides: a CTH run's refinement around a shock), the same camera
(iso) and transfer function, at 256^2 and 512^2. Frames alternate between the two after
one warm-up each (compilation), so load hits both alike; the median time of each and
their ratio are printed with ``os.getloadavg()``.

Accuracy: a linear field ``f = a + b x + c y + d z`` on the rectilinear grid, opacity
proportional to the value (``unit`` opacity unit distance), seen along z and obliquely
by orthographic cameras: the error of the alpha channel against the closed-form
emission-absorption integral, at 2-3 step sizes.

    python3 benchmarks/bench_rectilinear.py                     # float32, 256^2 and 512^2, 5 frames
    python3 benchmarks/bench_rectilinear.py --precision float64 --sizes 256 --frames 3
    python3 benchmarks/bench_rectilinear.py --uniform-only      # the uniform renders alone (before/after)
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np


def axis(n, lo, hi, ratio):
    """``n`` coordinates from ``lo`` to ``hi`` whose spacing varies smoothly by ``ratio``
    (fine in the middle, coarse at both ends); ``ratio=1``: uniform."""
    s = np.linspace(-1.0, 1.0, n - 1)
    widths = 1.0 + (ratio - 1.0) * s * s
    c = np.concatenate([[0.0], np.cumsum(widths)])
    return lo + (hi - lo) * c / c[-1]


def blob(x, y, z):
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    f = np.exp(-((X - 0.5) ** 2 + (Y - 0.45) ** 2 + (Z - 0.55) ** 2) / 0.05) + 0.3 * X
    return np.ascontiguousarray(f.transpose(2, 1, 0))  # (z, y, x)


def grids(n, ratio):
    import pyvista as pv

    x, y, z = axis(n, 0.0, 1.0, ratio), axis(n, 0.0, 1.0, ratio), np.linspace(0.0, 1.0, n)
    rect = pv.RectilinearGrid(x, y, z)
    rect.point_data["f"] = blob(x, y, z).reshape(-1)
    u = np.linspace(0.0, 1.0, n)
    image = pv.ImageData(dimensions=(n, n, n), spacing=(1.0 / (n - 1),) * 3)
    image.point_data["f"] = blob(u, u, u).reshape(-1)
    return image, rect


def timing(args):
    import pv_hdrvol as hv

    image, rect = grids(args.n, 2.0)
    tf = hv.TransferFunction.ramp(0.2, 1.2, cmap="viridis", opacity=(0.0, 0.05))
    camera = hv.Camera.fit(image.bounds, "iso")
    kw = dict(precision=args.precision, progress_bar=False)
    rect_volume = hv.volume_from_dataset(rect)
    # the default step is in narrowest cells, which are 0.75 of the uniform grid's spacing
    # here: the same world step takes the uniform grid's step times the ratio
    same_step = args.step * float(image.spacing[0]) / rect_volume.min_cell_width
    print(f"{args.n}^3 points, {args.precision}, step {args.step} (rectilinear: {args.step} narrowest cells, and "
          f"{same_step:.3f}: the uniform grid's world step), iso camera; spacing varies 2x along x and y")
    print("| size | uniform (s) | rectilinear, same world step (s) | ratio | rectilinear, default step (s) | ratio "
          "| samples rectilinear / uniform (same step) | load |")
    print("|--:|--:|--:|--:|--:|--:|--:|---|")
    for size in args.sizes:
        runs = {"uniform": (image, args.step)}
        if not args.uniform_only:
            runs.update({"same": (rect, same_step), "default": (rect, args.step)})
        times = {name: [] for name in runs}
        samples = {}
        for name, (data, step) in runs.items():  # warm-up: compilation, bricks, skip structures
            samples[name] = hv.render(data, tf, camera, (size, size), step=step, **kw).metadata["samples"]
        for _ in range(args.frames):
            for name, (data, step) in runs.items():
                t = time.perf_counter()
                hv.render(data, tf, camera, (size, size), step=step, **kw)
                times[name].append(time.perf_counter() - t)
        med = {name: statistics.median(ts) for name, ts in times.items()}
        load = " ".join(f"{x:.2f}" for x in os.getloadavg())
        if args.uniform_only:
            print(f"| {size} | {med['uniform']:.4f} | - | - | - | - | - | {load} |")
        else:
            print(f"| {size} | {med['uniform']:.4f} | {med['same']:.4f} | {med['same'] / med['uniform']:.2f} | "
                  f"{med['default']:.4f} | {med['default'] / med['uniform']:.2f} | "
                  f"{samples['same'] / samples['uniform']:.3f} | {load} |")


def linear_case(n=24, ratio=3.0):
    """The linear field's volume, its coefficients and the closed form of its alpha."""
    import pv_hdrvol as hv

    a, b, c, d = 0.2, 0.5, 0.3, 0.4
    x, y, z = axis(n, 0.0, 2.0, ratio), axis(n, -1.0, 1.0, ratio), axis(n, 0.0, 1.5, ratio)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    f = (a + b * X + c * Y + d * Z).transpose(2, 1, 0)
    return hv.volume_from_rectilinear(np.ascontiguousarray(f), x, y, z), (a, b, c, d)


def analytic_alpha(coef, o, u, t0, t1, a_max, f_max, unit):
    """``1 - exp(-int sigma)`` of opacity ``a_max f / f_max`` per ``unit`` along ``o + t u``."""
    a, b, c, d = coef
    f0 = a + b * o[0] + c * o[1] + d * o[2]
    df = b * u[0] + c * u[1] + d * u[2]
    # sigma = -ln(1 - k f) / unit, k = a_max / f_max; int -ln(1 - k f) dt over [t0, t1]
    k = a_max / f_max

    def prim(t):
        w = 1.0 - k * (f0 + df * t)
        return (w * math.log(w) - w) / (k * df) if df != 0 else -math.log(w) * t
    tau = (prim(t1) - prim(t0)) / unit
    return 1.0 - math.exp(-tau)


def accuracy(args):
    import pv_hdrvol as hv

    vol, coef = linear_case()
    lo, hi = vol.value_range
    f_max = 2.0 * hi
    a_max = 0.5
    tf = hv.TransferFunction([0.0, f_max], [[1, 1, 1], [1, 1, 1]], [0.0, a_max])
    unit = 0.25
    b = np.array(vol.bounds)
    centre = 0.5 * (b[0::2] + b[1::2])
    print("| view | step (min cell widths) | max |alpha - exact| |")
    print("|---|--:|--:|")
    for view, u in (("along z", np.array([0.0, 0.0, -1.0])), ("oblique", np.array([0.3, 0.2, -1.0]))):
        u = u / np.linalg.norm(u)
        eye = centre - 10.0 * u
        up = (0.0, 1.0, 0.0)
        cam = hv.Camera(tuple(eye), tuple(centre), up, parallel_projection=True, parallel_scale=0.15)
        rays = cam.rays((8, 8))
        for step in args.steps:
            img = hv.render(vol, tf, cam, (8, 8), precision="float64", step=step, termination=0.0,
                            opacity_unit_distance=unit, progress_bar=False)
            err = 0.0
            for o, dvec, alpha in zip(rays.origins, rays.directions, img.rgba[..., 3].reshape(-1)):
                t0, t1 = 0.0, math.inf
                for ax in range(3):
                    if dvec[ax] != 0:
                        ta, tb = sorted(((b[2 * ax] - o[ax]) / dvec[ax], (b[2 * ax + 1] - o[ax]) / dvec[ax]))
                        t0, t1 = max(t0, ta), min(t1, tb)
                if t1 <= t0:
                    continue
                err = max(err, abs(alpha - analytic_alpha(coef, o, dvec, t0, t1, a_max, f_max, unit)))
            print(f"| {view} | {step} | {err:.2e} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--precision", default="float32")
    ap.add_argument("--step", type=float, default=0.5)
    ap.add_argument("--steps", type=float, nargs="+", default=[1.0, 0.5, 0.25])
    ap.add_argument("--uniform-only", action="store_true")
    ap.add_argument("--skip-accuracy", action="store_true")
    args = ap.parse_args(argv)
    timing(args)
    if not (args.uniform_only or args.skip_accuracy):
        accuracy(args)


if __name__ == "__main__":
    main()
