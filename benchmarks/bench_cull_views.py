"""POF culling over many views (../shared/notes/methods.md T-POF-11): false culls
against the early-ray-termination oracle, image errors, and render time culled vs
unculled.

For each scene, the POFs are computed once; then for 100 random view directions
(uniform on the sphere, seed 0) and the 18 views of a turn about the y axis (every
20 deg), orthographic, ``--size`` pixels:

* ``visible``/``culled``: the table's visible set (``lookup`` min4 by default: the
  smallest of the four sample views around the direction) among the non-empty blocks;
* ``false culls``: blocks culled that the oracle R1 needs (the ray caster samples them
  while a ray's opacity is below the threshold); the rate is over all views'
  R1 blocks; also counted for the ``nearest`` and ``bilinear`` lookups (cheap: the
  culling pass only) and, for a family with POF sets, the ``sets`` method;
* images with the ray caster's termination at the threshold (transmittance 0.05):
  views where the culled image equals the unculled one bit for bit, and the largest
  and RMS difference of RGBA over all views;
* without termination (``termination=0``): the largest pixel error of the culled
  render against the unculled one, and the share of pixels where it exceeds the
  emission the unculled render receives behind the threshold (its image minus the
  image terminated at 0.05, per channel): the goal is none;
* render time, unculled and culled (termination 0.05, best of two), median over the
  views, and the culling pass's own time;
* where culling saves work, block-wise rendering (``render_parallel(comm=None)``, what
  each MPI rank does, with no early termination across blocks): time with and
  without the POFs at the first view of the turn, and the largest pixel difference
  (blocks composite without termination across them: a culled block changes a pixel by
  at most 1 - threshold of what it emits there).

With ``--bound 1,2,4`` (groups of the view-independent occlusion bound,
``hv.OcclusionBound``, methods.md A.7), per group size: blocks culled among the
non-empty, false culls against R1 over all views, the share of the exact sequential
algorithm R2's culls it reaches (R2 renders every non-empty block once per view: on
the first ``--r2-views`` views only), views whose render culled by the bound equals
the unculled one bit for bit (termination 0.05), and the march's time per view
(median; the per-group extinction is computed once per scene and cached).
``--no-pof`` skips the POF measurements (their precomputation takes minutes).

Run: ``python benchmarks/bench_cull_views.py [--scenes head-dense,engine,ball] [--size 256] [--views 100]``
``[--bound 1,2,4 [--r2-views 10] [--no-pof]]``
"""
from __future__ import annotations

import argparse
import os
import pathlib
import platform
import time

import numpy as np

import pv_hdrvol as hv
from pv_hdrvol.culling.bound import OcclusionBound
from pv_hdrvol.culling.cull import Culling, visible_blocks
from pv_hdrvol.culling.pof import PlenopticOpacity, nonempty_blocks
from pv_hdrvol.culling.reference import ert_oracle, exact_sequential
from pv_hdrvol.params import RenderOptions
from pv_hdrvol.raycast.grid import block_grid_shape
from pv_hdrvol.parallel.render import render_parallel
from pv_hdrvol.raycast.grid import as_volume

from bench_pof import _ramp, _tent  # the same transfer functions as bench_pof.py (benchmarks/ is on sys.path)

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = pathlib.Path(os.environ.get("PV_HDRVOL_DATA", ROOT.parent / "shared" / "data"))
TERMINATION = 0.05  # = 1 - the culling threshold


def scenes(names):
    """(name, volume, bases, k) of each scene asked for."""
    import pyvista as pv

    structured = DATA / "structured"
    for name in names:
        if name == "ball":  # dense: a noisy opaque ball filling most of a 128^3 grid
            n = 128
            x = (np.arange(n) - (n - 1) / 2) / (n / 2)
            r = np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)
            noise = np.random.default_rng(1).random((n, n, n))
            values = np.where(r < 0.9, 150 + 100 * noise, 20 * noise)
            yield "ball (dense, synthetic)", as_volume(values), [_ramp(60, 100)], [1.0]
        elif name == "head-dense":  # soft tissue opaque: the whole head is dense
            yield ("CT head, soft tissue opaque", as_volume(pv.read(structured / "ct_head_120x120x130_uint8.vtk")),
                   [_ramp(20, 50)], [1.0])
        elif name == "head-family":  # the paper's skin/bone family
            skin = _tent(30, 60, 90, 0.3, (1.0, 0.75, 0.6))
            bone = _ramp(90, 140, opacity=(0.6, 0.95), color=(1.0, 1.0, 0.95))
            yield ("CT head, skin + bone, k = (0.25, 0.9)",
                   as_volume(pv.read(structured / "ct_head_120x120x130_uint8.vtk")), [skin, bone], [0.25, 0.9])
        elif name == "engine":
            yield ("engine (opaque)", as_volume(pv.read(structured / "engine_256x256x128_uint8.vti")), [_ramp(60, 100)],
                   [1.0])
        elif name == "bonsai":
            yield ("bonsai (opaque)", as_volume(pv.read(structured / "bonsai_256x256x256_uint8.vti")), [_ramp(40, 80)],
                   [1.0])
        else:
            raise SystemExit(f"unknown scene {name!r}")


def directions(n_random):
    """``n_random`` directions uniform on the sphere (seed 0), then the 18 of a y turn."""
    d = np.random.default_rng(0).normal(size=(n_random, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    a = np.radians(np.arange(18) * 20.0 + 5.0)  # off the axes: no view exactly along one
    turn = np.stack([np.sin(a), np.full(18, 0.05), np.cos(a)], axis=1)
    return np.vstack([d, turn / np.linalg.norm(turn, axis=1, keepdims=True)])


def camera_along(volume, d):
    b = np.asarray(volume.bounds, dtype=np.float64)
    centre = 0.5 * (b[0::2] + b[1::2])
    radius = 0.5 * float(np.linalg.norm(b[1::2] - b[0::2]))
    up = (0.0, 0.0, 1.0) if abs(d[2]) < 0.9 else (0.0, 1.0, 0.0)
    return hv.Camera(tuple(centre - 3 * radius * d), tuple(centre), up, parallel_projection=True,
                     parallel_scale=radius)


def _timed(*args, **kw):
    best, image = None, None
    for _ in range(2):
        t = time.perf_counter()
        image = hv.render(*args, progress_bar=False, **kw)
        dt = time.perf_counter() - t
        best = dt if best is None else min(best, dt)
    return best, image


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="head-dense,ball,engine,head-family,bonsai")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--views", type=int, default=100, help="random views (plus 18 of a y turn)")
    parser.add_argument("--block-size", type=int, default=16)
    parser.add_argument("--bound", default="", help="group sizes of the occlusion bound to measure, e.g. 1,2,4")
    parser.add_argument("--r2-views", type=int, default=10, help="views on which R2 is computed (--bound)")
    parser.add_argument("--no-pof", action="store_true", help="skip the POF measurements")
    args = parser.parse_args()
    size = (args.size, args.size)
    print(f"# bench_cull_views: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.2f}, size {args.size}, blocks {args.block_size}^3, "
          f"{args.views} random views + 18 turn views")
    for name, volume, bases, k in scenes(args.scenes.split(",")):
        if args.bound:
            measure_bound(name, volume, bases, k, directions(args.views), size, args.block_size,
                          [int(g) for g in args.bound.split(",")], args.r2_views)
        if args.no_pof:
            continue
        t = time.perf_counter()
        pof = PlenopticOpacity.compute(volume, bases, block_size=args.block_size, sets=len(bases) > 1)
        print(f"{name}: POF {time.perf_counter() - t:.0f} s")
        tf = hv.TransferFunction.family(bases, k)
        n = dict(ne=0, vis=0, r1=0, false=0, false_views=0, exact_views=0, nearest=0, bilinear=0, sets=0,
                 sets_culled=0, over=0, pixels=0)
        err_max = err_sq = err0 = 0.0
        t_full, t_culled, t_cull = [], [], []
        views = directions(args.views)
        for d in views:
            camera = camera_along(volume, d)
            t = time.perf_counter()
            table = visible_blocks(pof, volume, camera, size, k)
            t_cull.append(time.perf_counter() - t)
            ne = table.nonempty
            r1 = ert_oracle(volume, tf, camera, size, block_size=args.block_size, nonempty=ne)
            false = int((r1 & ~table.visible).sum())
            n["ne"] += int(ne.sum())
            n["vis"] += int(table.visible.sum())
            n["r1"] += int(r1.sum())
            n["false"] += false
            n["false_views"] += false > 0
            for lookup in ("nearest", "bilinear"):
                other = visible_blocks(pof, volume, camera, size, k, lookup=lookup).visible
                n[lookup] += int((r1 & ~other).sum())
            if pof.sets is not None:
                sets = visible_blocks(pof, volume, camera, size, k, method="sets").visible
                n["sets"] += int((r1 & ~sets).sum())
                n["sets_culled"] += int((ne & ~sets).sum())
            dt_full, full = _timed(volume, tf, camera, size, termination=TERMINATION)
            dt_culled, culled = _timed(volume, tf, camera, size, termination=TERMINATION, cull=Culling(pof))
            t_full.append(dt_full)
            t_culled.append(dt_culled)
            diff = np.abs(culled.rgba.astype(np.float64) - full.rgba)
            n["exact_views"] += bool(np.all(diff == 0))
            err_max = max(err_max, float(diff.max()))
            err_sq += float((diff**2).sum())
            if table.visible.sum() < ne.sum():  # something culled: the bound without termination
                exact = hv.render(volume, tf, camera, size, termination=0.0, progress_bar=False).rgba
                exact_culled = hv.render(volume, tf, camera, size, termination=0.0, cull=Culling(pof),
                                         progress_bar=False).rgba
                behind = exact - full.rgba  # emission the unculled render receives behind the threshold
                e0 = np.abs(exact_culled.astype(np.float64) - exact)
                err0 = max(err0, float(e0.max()))
                n["over"] += int(np.any(e0 > behind + 1e-6, axis=-1).sum())
                n["pixels"] += e0.shape[0] * e0.shape[1]
        v = len(views)
        rmse = np.sqrt(err_sq / (v * size[0] * size[1] * 4))
        print(f"  {v} views: non-empty {n['ne'] / v:.0f}/view, visible {n['vis'] / v:.0f} "
              f"({1 - n['vis'] / n['ne']:.1%} culled), R1 {n['r1'] / v:.0f}")
        print(f"  false culls min4 {n['false']} of {n['r1']} R1 blocks ({n['false'] / n['r1']:.2%}; "
              f"{n['false_views']} views), nearest {n['nearest']}, bilinear {n['bilinear']}"
              + (f", POF sets {n['sets']} (culled {n['sets_culled'] / n['ne']:.1%})" if pof.sets is not None else ""))
        print(f"  termination 0.05: {n['exact_views']}/{v} views bit for bit, max |diff| {err_max:.3g}, "
              f"RMSE {rmse:.3g}; no termination: max |diff| {err0:.3g}, pixels above the emission behind the "
              f"threshold {n['over']} of {n['pixels']}")
        print(f"  render median {np.median(t_full) * 1e3:.0f} ms unculled, {np.median(t_culled) * 1e3:.0f} ms culled "
              f"({np.median(np.array(t_full) / np.array(t_culled)):.2f}x); culling pass median "
              f"{np.median(t_cull) * 1e3:.1f} ms")
        camera = camera_along(volume, views[args.views])
        times, images = [np.inf, np.inf], [None, None]
        for _ in range(3):  # alternating, best of three each (the first also warms up)
            for i, p in enumerate((None, pof)):
                t = time.perf_counter()
                images[i] = render_parallel(volume, tf, camera, size, pof=p, comm=None, termination=TERMINATION)
                times[i] = min(times[i], time.perf_counter() - t)
        blocks = [im.metadata["parallel"]["visible"] for im in images]
        split = ["/".join(f"{im.metadata['parallel']['per_rank'][0][key]:.2f}" for key in
                          ("cull_seconds", "render_seconds", "composite_seconds")) for im in images]
        diff = float(np.abs(images[0].rgba.astype(np.float64) - images[1].rgba).max())
        print(f"  block-wise (one rank): {blocks[0]} blocks {times[0]:.2f} s unculled, {blocks[1]} blocks "
              f"{times[1]:.2f} s culled ({times[0] / times[1]:.2f}x; cull/render/composite {split[0]} and "
              f"{split[1]} s, last run); max |diff| {diff:.3g}")


def measure_bound(name, volume, bases, k, views, size, block_size, groups, r2_views):
    """The occlusion bound's columns: culled, false culls vs R1, share of R2's culls,
    bit-for-bit views, march time."""
    tf = hv.TransferFunction.family(bases, k)
    family = hv.TransferFunctionFamily(bases, k)
    shape = block_grid_shape(volume.dims, block_size)
    sigma = family.basis_tables(1.0, 1.0) * family.k[:, None]
    ne = nonempty_blocks(np.asarray(volume.values, dtype=np.float64), shape, block_size, sigma, family).any(axis=-1)
    opts = RenderOptions.from_kwargs(None, termination=TERMINATION)
    rows = {g: dict(culled=0, false=0, false_views=0, exact=0, r2_hit=0, r2_in=0, march=[], first=None)
            for g in groups}
    n_r1 = n_r2 = r2_culled = 0
    t_r2 = 0.0
    for v, d in enumerate(views):
        camera = camera_along(volume, d)
        r1 = ert_oracle(volume, tf, camera, size, block_size=block_size, nonempty=ne)
        n_r1 += int(r1.sum())
        r2 = None
        if v < r2_views:
            t = time.perf_counter()
            r2, _ = exact_sequential(volume, tf, camera, size, block_size=block_size, nonempty=ne)
            t_r2 += time.perf_counter() - t
            r2_culled += int((ne & ~r2).sum())
            n_r2 += 1
        full = hv.render(volume, tf, camera, size, termination=TERMINATION, progress_bar=False)
        for g in groups:
            row = rows[g]
            t = time.perf_counter()
            needed, met, stats = OcclusionBound(g, block_size=block_size).blocks(volume, tf, camera, size, opts,
                                                                                  block_size)
            if row["first"] is None:
                row["first"] = (time.perf_counter() - t, stats["extinction_seconds"])
            else:
                row["march"].append(stats["march_seconds"])
            culled = met & ~needed & ne
            row["culled"] += int(culled.sum())
            false = int((culled & r1).sum())
            row["false"] += false
            row["false_views"] += false > 0
            if r2 is not None:
                row["r2_hit"] += int((culled & ~r2).sum())
                row["r2_in"] += int(culled.sum())
            image = hv.render(volume, tf, camera, size, termination=TERMINATION, cull=OcclusionBound(g),
                              progress_bar=False)
            row["exact"] += bool(np.array_equal(image.rgba, full.rgba))
    n = len(views)
    print(f"{name}: occlusion bound, {n} views at {size[0]}x{size[1]}, blocks {block_size}^3, non-empty "
          f"{int(ne.sum())}; R1 {n_r1 / n:.0f} blocks/view; R2 on {n_r2} views culls {r2_culled / max(n_r2, 1):.0f}"
          f"/view ({t_r2 / max(n_r2, 1):.1f} s/view)")
    print("  | group | culled/view (of non-empty) | share of R2's culls | false culls vs R1 | bit for bit "
          "| march ms/view (median) | first call s (extinction s) |")
    for g in groups:
        row = rows[g]
        share = row["r2_hit"] / r2_culled if r2_culled else float("nan")
        print(f"  | {g} | {row['culled'] / n:.0f} ({row['culled'] / (n * ne.sum()):.1%}) | {share:.0%} "
              f"({row['r2_in'] - row['r2_hit']} outside R2's) | {row['false']} ({row['false_views']} views) "
              f"| {row['exact']}/{n} | {np.median(row['march']) * 1e3:.1f} | {row['first'][0]:.2f} "
              f"({row['first'][1]:.2f}) |")


if __name__ == "__main__":
    main()
