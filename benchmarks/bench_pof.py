"""Plenoptic opacity functions (POF) on real volumes: precompute cost, culling
effectiveness against the exact references, conservativeness, and render time.

For each dataset and transfer-function family (the paper's section 5 measures, with
stand-ins from ../shared/data, ../shared/notes/methods.md A.2):

* ``precompute``: seconds and microseconds per (non-empty block, view), all 1,296 views,
  ``--threads`` threads (paper: 64 us per block-view over all blocks);
* counts of non-empty blocks and of blocks visible by the POF table, by the shifted
  polynomial, by the paper's exact sequential culling (R2) and by the early-ray-
  termination oracle (R1: the blocks the ray caster samples while a ray is below the
  threshold);
* ``table/exact``: the share of the exact algorithm's culled blocks the table culls
  (goal >= 95 %);
* ``false culls``: blocks culled by the table that R1 needs; ``max err``: the largest
  pixel difference of the culled render against the unculled one, both without early
  termination, and the bound ``(1 - t) C_rest`` checked per pixel;
* render time unculled and culled (same options, ``--termination``), and the culling's
  own time;
* for families of several bases, the paper's POF sets: blocks they keep, and how often
  and by how much their estimate exceeds the family's true minimum over the footprint
  (the POF of the family as one basis, all block-views; not a bound, methods.md
  T-POF-5); the conservative bound is checked never to exceed it (by more than 1/255,
  the rounding of the two tables).

Run: ``python benchmarks/bench_pof.py [--size 256] [--datasets engine,bonsai,head,tooth]``
"""
from __future__ import annotations

import argparse
import os
import pathlib
import platform
import time

import numpy as np

import pv_hdrvol as hv
from pv_hdrvol.culling.cull import visible_blocks
from pv_hdrvol.culling.pof import PlenopticOpacity
from pv_hdrvol.culling.reference import ert_oracle, exact_sequential
from pv_hdrvol.raycast.grid import as_volume

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = pathlib.Path(os.environ.get("PV_HDRVOL_DATA", ROOT.parent / "shared" / "data"))


def _tent(lo, peak, hi, opacity, color):
    return hv.TransferFunction([0, lo, peak, hi, 255], [color] * 5, [0, 0, opacity, 0, 0], table_size=256)


def _ramp(lo, mid, opacity=(0.9, 0.99), color=(1.0, 0.9, 0.8)):
    return hv.TransferFunction([0, lo, mid, 255], [(0, 0, 0), color, color, (1, 1, 1)],
                               [0, 0, opacity[0], opacity[1]], table_size=256)


def scenes(names):
    import pyvista as pv

    structured = DATA / "structured"
    if "engine" in names:
        vol = as_volume(pv.read(structured / "engine_256x256x128_uint8.vti"))
        yield "engine (opaque)", vol, [_ramp(60, 100)], [[1.0]]
    if "bonsai" in names:
        vol = as_volume(pv.read(structured / "bonsai_256x256x256_uint8.vti"))
        yield "bonsai (opaque)", vol, [_ramp(40, 80)], [[1.0]]
    if "head" in names:
        vol = as_volume(pv.read(structured / "ct_head_120x120x130_uint8.vtk"))
        skin = _tent(30, 60, 90, 0.3, (1.0, 0.75, 0.6))
        bone = _ramp(90, 140, opacity=(0.6, 0.95), color=(1.0, 1.0, 0.95))
        yield "CT head (skin, bone)", vol, [skin, bone], [[0.05, 1.0], [0.25, 0.9], [0.8, 0.5]]
    if "tooth" in names:
        vol = as_volume(pv.read(structured / "tooth_103x94x161_uint8.nrrd"))
        bases = [_tent(20, 45, 70, 0.2, (0.8, 0.6, 0.5)), _tent(60, 90, 120, 0.4, (0.9, 0.8, 0.6)),
                 _tent(110, 140, 170, 0.7, (1.0, 0.95, 0.8)), _ramp(160, 200, opacity=(0.9, 0.99))]
        yield "tooth (4 bases)", vol, bases, [[1.0, 1.0, 1.0, 1.0]]


def set_overshoot(pof, vol, family, args):
    """(share of non-empty block-views where the POF-set estimate exceeds the family's
    true minimum by more than 2/255, largest excess, number where the conservative bound
    exceeds it by more than 1/255), the true minimum being the POF of the family as one
    basis (the same extinction at every table entry, linear between, as the sum)."""
    from pv_hdrvol.culling.pof import _family_opacity

    k = np.asarray(family.k, dtype=np.float64)
    x = np.linspace(*family.axis_range, family.table_size)
    plain = hv.TransferFunction(x, [(1, 1, 1)] * x.size, family.opacity_at(x), table_size=family.table_size)
    true = PlenopticOpacity.compute(vol, [plain], block_size=args.block_size, chord_min=args.chord_min,
                                    footprint=args.footprint, threads=args.threads).table[..., 0, :, :] / 255.0
    sets = np.moveaxis(pof.sets / 255.0, (3, 4), (-2, -1))  # (..., 36, 36, i, j)
    estimate = _family_opacity(sets, k).min(axis=-1)
    bound = _family_opacity(np.moveaxis(pof.table / 255.0, 3, -1), k)
    ne = pof.nonempty.any(axis=-1)
    e, t, c = estimate[ne], true[ne], bound[ne]
    return float(np.mean(e > t + 2 / 255)), float(np.max(e - t)), int(np.sum(c > t + 1 / 255))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--datasets", default="engine,bonsai,head,tooth")
    parser.add_argument("--threads", type=int, default=os.cpu_count())
    parser.add_argument("--termination", type=float, default=1e-6)
    parser.add_argument("--block-size", type=int, default=16)
    parser.add_argument("--chord-min", type=float, default=1.0)
    parser.add_argument("--footprint", default="chord", choices=("chord", "nonempty_pixels"),
                        help="nonempty_pixels: the paper's unsafe reading (false culls are counted)")
    args = parser.parse_args()
    size = (args.size, args.size)
    print(f"# bench_pof: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load {os.getloadavg()[0]:.2f}, size {args.size}, threads {args.threads}, blocks {args.block_size}^3, "
          f"footprint {args.footprint}, chord_min {args.chord_min}")
    rows = []
    for name, vol, bases, settings in scenes(args.datasets.split(",")):
        t = time.perf_counter()
        pof = PlenopticOpacity.compute(vol, bases, block_size=args.block_size, chord_min=args.chord_min,
                                       footprint=args.footprint, sets=len(bases) > 1, threads=args.threads)
        pre = time.perf_counter() - t
        n_compute = int(pof.nonempty.any(-1).sum())
        print(f"{name}: POF of {pof.nonempty.shape[:3]} blocks ({n_compute} non-empty for some basis) in {pre:.1f} s "
              f"= {pre / max(n_compute, 1) / 1296 * 1e6 * args.threads:.0f} us per block-view per thread")
        camera = hv.Camera.fit(vol.bounds, "iso", parallel_projection=True)
        for k in settings:
            family = hv.TransferFunction.family(bases, k)
            t = time.perf_counter()
            table = visible_blocks(pof, vol, camera, size, k)
            t_cull = time.perf_counter() - t
            poly = visible_blocks(pof, vol, camera, size, k, encoding="poly")
            ne = table.nonempty
            r1 = ert_oracle(vol, family, camera, size, block_size=args.block_size, nonempty=ne)
            t = time.perf_counter()
            r2, renders = exact_sequential(vol, family, camera, size, block_size=args.block_size, nonempty=ne)
            t_r2 = time.perf_counter() - t
            n_ne, n_tab, n_poly, n_r2, n_r1 = (int(x.sum()) for x in (ne, table.visible, poly.visible, r2, r1))
            false = int((r1 & ~table.visible).sum())
            culled_exact = n_ne - n_r2
            share = (n_ne - n_tab) / culled_exact if culled_exact else float("nan")

            def timed(**kw):
                best = None
                for _ in range(2):
                    t = time.perf_counter()
                    img = hv.render(vol, family, camera, size, progress_bar=False, **kw)
                    dt = time.perf_counter() - t
                    best = dt if best is None else min(best, dt)
                return best, img

            t_full, full = timed(termination=args.termination)
            t_culled, culled = timed(termination=args.termination, cull=pof)
            _, exact = timed(termination=0.0)
            _, exact_culled = timed(termination=0.0, cull=pof)
            err = float(np.abs(exact_culled.rgba - exact.rgba).max())
            row = dict(name=name, k=k, nonempty=n_ne, table=n_tab, poly=n_poly, exact=n_r2, oracle=n_r1,
                       share=share, false=false, err=err, t_full=t_full, t_culled=t_culled, t_cull=t_cull,
                       t_r2=t_r2, renders=renders, pre=pre)
            rows.append(row)
            print(f"  k={k}: non-empty {n_ne}, visible table {n_tab} ({1 - n_tab / n_ne:.1%} culled), poly {n_poly}, "
                  f"exact R2 {n_r2} ({1 - n_r2 / n_ne:.1%}), oracle R1 {n_r1}; table/exact {share:.1%}; "
                  f"false culls {false}; max pixel err (no ERT) {err:.3g}; render {t_full * 1e3:.0f} ms -> culled "
                  f"{t_culled * 1e3:.0f} ms ({t_full / t_culled:.2f}x), culling {t_cull * 1e3:.1f} ms")
            if pof.sets is not None:
                n_sets = int(visible_blocks(pof, vol, camera, size, k, method="sets").visible.sum())
                over, excess, loose = set_overshoot(pof, vol, family, args)
                print(f"  k={k}: POF sets keep {n_sets}; over all block-views the set estimate exceeds the true "
                      f"minimum by > 2/255 at {over:.1%}, by up to {excess:.2f}; conservative above it: {loose}")
    return rows


if __name__ == "__main__":
    main()
