"""Where a tetrahedral render's time goes, per cell crossed (an experiment, not a benchmark of peers).

1. **Knock-out** (``--part knockout``): the package as it is, and a copy of it whose walk
   composites a constant small opacity instead of integrating each segment (the
   ``_segment`` call and its table positions replaced), imported side by side in one
   process; frames interleaved. Both cross the same cells (the rays leave the mesh
   before they get opaque), so the difference per cell is the integration's cost.
2. **Cell order** (``--part order``): the same mesh with its cells and points in the
   file's order, in a random order and in Morton order (of cell centroids and points),
   rendered in turn; the images are checked to be equal.

Times are the renders' ``render_seconds`` (the walk, without the boundary pass),
medians; ``thread-ns/cell`` is that time times the threads over the cells crossed.

    python3 benchmarks/tet_cell_costs.py --part knockout --threads 1
    python3 benchmarks/tet_cell_costs.py --part order --meshes "FEA bracket" "LOX post"

docs/tetrahedra.md ("What the targets ask of each cell") has the results.
"""
from __future__ import annotations

import argparse
import importlib
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_tets import MESHES, OPAQUE, data_dir, load  # noqa: E402

#: what the knock-out replaces in raycast/_tet_kernels.py, and with what
INTEGRATION = """                x_in = x_prev if same else _tpos(s_in, n_table, p)
                x_out = _tpos(s_out, n_table, p)
                lit = unlit
                if p.shade:
                    gx = grads[cell, 0]
                    gy = grads[cell, 1]
                    gz = grads[cell, 2]
                    w = fade_weight(math.sqrt(gx * gx + gy * gy + gz * gz), 0.5 * (s_in + s_out), p.scale,
                                    p.axis_inv_range, p.linthresh, shading[SH_FADE])
                    lit = light_factors(gx, gy, gz, ex, ey, ez, w, shading, lights)
                state, np_, c_ok, c_prev = _segment(marker, prec, state, table, s_in, x_in, s_out, x_out,
                                                    c_ok and same, c_prev, (t_out - t_in) * p.length_scale, p, lit)"""
CONSTANT = """                x_in = 0.0
                x_out = 0.0
                state = _accumulate(marker, prec, state, 1e-6 * (t_out - t_in), s_in, s_out, 0.5)
                np_ = 1"""


def knockout_copy(into):
    """The working tree's package as ``pvh_knockout`` under ``into``, its integration knocked out."""
    target = Path(into) / "pvh_knockout"
    shutil.copytree(REPO / "pv_hdrvol", target, ignore=shutil.ignore_patterns("__pycache__"))
    kernels = target / "raycast" / "_tet_kernels.py"
    text = kernels.read_text()
    if INTEGRATION not in text:
        raise SystemExit("the walk's integration call changed: update INTEGRATION in this script")
    kernels.write_text(text.replace(INTEGRATION, CONSTANT))
    return "pvh_knockout"


def scene(hv, grid, scalars):
    """``(mesh, tf, camera, render options)`` of ``bench_tets``' scene, made with package ``hv``."""
    mesh = hv.tetmesh_from_dataset(grid, scalars)
    lo, hi = mesh.value_range
    tf = hv.TransferFunction.ramp(lo, hi, cmap="viridis", opacity=OPAQUE["opacity"])
    camera = hv.Camera.fit(mesh.bounds, "iso")
    return mesh, tf, camera, {"opacity_unit_distance": mesh.default_unit_distance() * OPAQUE["unit_factor"],
                              "progress_bar": False}


def timed(variants, size, frames, threads):
    """Per variant ``(median seconds, cells, thread-ns per cell, image)``, frames interleaved."""
    out = {}
    for key, (hv, mesh, tf, camera, opts) in variants.items():
        hv.render(mesh, tf, camera, (size, size), **opts)  # compiles, warms the caches
        out[key] = []
    images = {}
    for _ in range(frames):
        for key, (hv, mesh, tf, camera, opts) in variants.items():
            images[key] = hv.render(mesh, tf, camera, (size, size), **opts)
            out[key].append(images[key].metadata["render_seconds"])
    result = {}
    for key, ts in out.items():
        t = statistics.median(ts)
        cells = images[key].metadata["cells"]
        result[key] = (t, cells, 1e9 * t * threads / cells, images[key])
    return result


def morton(points, bits=10):
    """Morton (z-order) keys of ``points`` (n, 3) over their bounding box."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    q = ((points - lo) / np.maximum(hi - lo, 1e-300) * (2 ** bits - 1)).astype(np.uint64)
    key = np.zeros(len(points), dtype=np.uint64)
    for b in range(bits):
        for axis in range(3):
            key |= ((q[:, axis] >> np.uint64(b)) & np.uint64(1)) << np.uint64(3 * b + axis)
    return key


def reordered(grid, cell_order, point_order):
    """``grid`` (tetrahedra only) with its cells and points in the given orders."""
    import pyvista as pv

    cells = grid.cells_dict[pv.CellType.TETRA][cell_order]
    inverse = np.empty_like(point_order)
    inverse[point_order] = np.arange(len(point_order))
    out = pv.UnstructuredGrid({pv.CellType.TETRA: inverse[cells]}, np.asarray(grid.points)[point_order])
    for name in grid.point_data:
        out.point_data[name] = np.asarray(grid.point_data[name])[point_order]
    for name in grid.cell_data:
        out.cell_data[name] = np.asarray(grid.cell_data[name])[cell_order]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("knockout", "order"), default="knockout")
    ap.add_argument("--meshes", nargs="+", default=["SPX", "FEA bracket"])
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 1024])
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args(argv)
    import numba
    import pyvista as pv

    numba.set_num_threads(args.threads)
    print(f"{args.part}: {args.threads} thread(s), load {load()}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        sys.path.insert(0, tmp)
        base = importlib.import_module("pv_hdrvol")
        knocked = importlib.import_module(knockout_copy(tmp)) if args.part == "knockout" else None
        for file, scalars, label in MESHES:
            if label not in args.meshes:
                continue
            grid = pv.read(data_dir() / file)
            grid.set_active_scalars(scalars, preference="point" if scalars in grid.point_data else "cell")
            if args.part == "knockout":
                variants = {"integrated": (base, *scene(base, grid, scalars)),
                            "constant": (knocked, *scene(knocked, grid, scalars))}
            else:
                rng = np.random.default_rng(0)
                centroids = np.asarray(grid.points)[grid.cells_dict[pv.CellType.TETRA]].mean(axis=1)
                orders = {"file": grid,
                          "random": reordered(grid, rng.permutation(grid.n_cells), rng.permutation(grid.n_points)),
                          "morton": reordered(grid, np.argsort(morton(centroids), kind="stable"),
                                              np.argsort(morton(np.asarray(grid.points)), kind="stable"))}
                variants = {k: (base, *scene(base, g, scalars)) for k, g in orders.items()}
            for size in args.sizes:
                res = timed(variants, size, args.frames, args.threads)
                first = next(iter(res.values()))
                parts = []
                for key, (t, cells, per, img) in res.items():
                    parts.append(f"{key} {1e3 * t:.1f} ms, {per:.0f} thread-ns/cell, "
                                 f"{t / first[0]:.2f}x")
                    if args.part == "order" and not np.array_equal(img.rgba, first[3].rgba):
                        parts[-1] += " (image differs)"
                print(f"{label} {size}²: {first[1]:,} cells; " + "; ".join(parts) + f"; load {load()}", flush=True)


if __name__ == "__main__":
    main()
