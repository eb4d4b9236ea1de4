"""Curvilinear (PLOT3D) grids: accuracy and time of our split (VTK's alternating 5 tets per hexahedron).

Measured on the original PLOT3D files in ../shared/data/unstructured/plot3d_original
(Blunt Fin 40x32x32, "Density"; LOX post 38x76x38, "StagnationEnergy"), read with
``vtkMultiBlockPLOT3DReader`` (block 0: the vtkStructuredGrid), one transfer function
(``ramp`` over the data range, viridis, opacity 0 -> 0.3), camera "iso", float64, and
one opacity unit distance for every render of a grid (the native mesh's default).

1. **Accuracy against the trilinear field** (``--part accuracy``). A hexahedral walker
   with trilinear interpolation is the reference model. It is approximated by refining
   every hexahedron r x r x r in logical (i, j, k) space (positions and values by
   trilinear interpolation of the cell's 8 corners: a ((nx-1)r+1, ...) grid), splitting
   that the same way (``structured_tets``) and rendering it. For each r the RMS and max
   error of the premultiplied RGBA against the finest r, relative to the finest image's
   peak, and the ratio to the previous r's error (about 4 for each halving of h when
   the O(h^2) term dominates: the error of r = 1 against the limit is then ~ 4/3 of its
   error against r = 2).
2. **Time** (``--part time``). (a) our split (``tetmesh_from_structured``) through
   the tet ray caster: prepare seconds, median of 3 renders after a warm-up;
   (b) VTK's ``vtkDataSetTriangleFilter`` (5 tets per hexahedron) through the same
   caster (prepare = filter + ``tetmesh_from_dataset``); (c) VTK's
   ``vtkUnstructuredGridVolumeRayCastMapper`` on the filtered grid, offscreen (median of
   3 renders after a warm-up), or why it cannot run. Tet counts; the RMS/max difference
   of images (a) and (b) relative to the peak, and each one's error against the finest
   trilinear reference of part 1. Whether the raw split (``structured_tets``, before
   collapsed tets are dropped) is the filter's, tet for tet up to order ("same tets").

Usage::

    python3 benchmarks/bench_curvilinear.py                    # both parts, 256^2
    python3 benchmarks/bench_curvilinear.py --size 128 --refine-bluntfin 1 2 --refine-post 1 2
    python3 benchmarks/bench_curvilinear.py --part time --no-vtk

The load average (1 min) is printed beside every row: the machine is shared.

Measured 2026-12-06 with the 5-tet split on this 2-core machine (shared; load average 0.69
at the start, 1.80 at the end, 2 numba threads; VTK's mapper offscreen), 2 min 13 s wall:

    python3 benchmarks/bench_curvilinear.py --refine-bluntfin 1 2 3 4 --refine-post 1 2 3

Accuracy of our 5-tet split against the trilinear field (256², float64; error of the premultiplied RGBA against the finest r, relative to its peak):

| grid | r | grid points | tets | prepare s | render s | RMS / peak | max / peak | RMS ratio to previous r | load |
|---|--:|---|--:|--:|--:|--:|--:|--:|--:|
| Blunt Fin | 1 | 40x32x32 | 187,318 | 0.22 | 0.09 | 3.85e-04 | 7.66e-03 | - | 0.69 |
| Blunt Fin | 2 | 79x63x63 | 1,498,854 | 4.11 | 0.17 | 7.02e-05 | 1.50e-03 | 5.48 | 0.72 |
| Blunt Fin | 3 | 118x94x94 | 5,059,140 | 14.67 | 0.27 | 3.08e-05 | 9.37e-04 | 2.28 | 1.0 |
| Blunt Fin | 4 (reference) | 157x125x125 | 11,992,060 | 32.83 | 0.39 | 0.00e+00 | 0.00e+00 | - | 1.04 |
| LOX post | 1 | 38x76x38 | 513,375 | 0.63 | 0.09 | 1.69e-05 | 5.25e-04 | - | 1.04 |
| LOX post | 2 | 75x151x75 | 4,107,000 | 8.06 | 0.17 | 3.05e-06 | 1.34e-04 | 5.56 | 1.03 |
| LOX post | 3 (reference) | 112x226x112 | 13,861,125 | 41.83 | 0.85 | 0.00e+00 | 0.00e+00 | - | 1.3 |

Time (256², float64, median of renders after a warm-up) and the two piecewise-linear models (a: ours, tetmesh_from_structured, 5 tets/hex less collapsed ones; b: vtkDataSetTriangleFilter 5 tets/hex):

| grid | tets a | tets b | prepare a s | prepare b s | render a s | render b s | VTK UG ray cast (on b) s | a vs b RMS / peak | a vs b max / peak | a vs trilinear RMS | b vs trilinear RMS | a vs trilinear max | b vs trilinear max | same tets | load |
|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|--:|
| Blunt Fin | 187,318 | 187,395 | 0.193 | 0.178 | 0.086 | 0.122 | 0.230 | 2.72e-17 | 1.21e-15 | 3.85e-04 | 3.85e-04 | 7.66e-03 | 7.66e-03 | yes (187,395) | 1.04-1.04 |
| LOX post | 513,375 | 513,375 | 1.093 | 0.846 | 0.231 | 0.358 | 0.800 | 7.99e-17 | 5.12e-15 | 1.69e-05 | 1.69e-05 | 5.25e-04 | 5.25e-04 | yes (513,375) | 1.43-1.8 |

A second ``--part time --repeat 5`` right after (load 2.2-2.3) gave render a / b 0.088 /
0.088 s (Blunt Fin) and 0.240 / 0.241 s (LOX post), VTK's mapper 0.246 and 0.839 s: the
a/b render gap of the first run was the load, the tets being the same.

The raw split (``structured_tets``) is the filter's tet for tet (up to order); ours then
drops the 77 Blunt Fin tets with two equal corners (its collapsed grid line), which
cover no volume, so the images of (a) and (b) agree to 1e-15 of the peak. At native
resolution the split is 3.85e-4 (Blunt Fin) and 1.69e-5 (LOX post) RMS of the peak from
the trilinear field (max 7.7e-3 and 5.3e-4), against 9.04e-4 and 9.87e-5 (max 1.6e-2 and
2.5e-3) for the 6-tet Kuhn split it replaces (2026-12-05, same command): 2.3x and 5.8x
lower. (Each run's reference is the finest r split its own way, so the two runs'
references differ by their own O(h^2/r^2) error; against the Kuhn reference the 5-tet
split was 3.97e-4 and 2.06e-5, 2.3x and 4.8x.) The LOX post and the Blunt Fin's first
step converge as h^2 (RMS ratio 5.5-5.6 against a finite reference); the Blunt Fin's
r = 3 step (ratio 2.3) is measured against r = 4 only. VTK's UG ray cast mapper took
2.7-2.8x (Blunt Fin) and 3.5x (LOX post) our render time of (a) in the two runs. Render
seconds of different runs are not comparable here: the Kuhn run's (b), the same tets as
now, took 0.21 s on the Blunt Fin where this run's took 0.09-0.12 s.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np

REPO = Path(__file__).resolve().parents[1]
for _path in (REPO, REPO / "benchmarks"):
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

#: label, xyz file, q file, scalars
GRIDS = [
    ("Blunt Fin", "bluntfinxyz.bin", "bluntfinq.bin", "Density"),
    ("LOX post", "postxyz.bin", "postq.bin", "StagnationEnergy"),
]


def data_dir():
    return Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data")) / "unstructured" / "plot3d_original"


def load():
    return round(os.getloadavg()[0], 2)


def read_plot3d(xyz, q):
    from vtkmodules.vtkIOParallel import vtkMultiBlockPLOT3DReader

    r = vtkMultiBlockPLOT3DReader()
    r.SetXYZFileName(str(data_dir() / xyz))
    r.SetQFileName(str(data_dir() / q))
    r.SetAutoDetectFormat(1)
    r.Update()
    return r.GetOutput().GetBlock(0)


def refine(points, values, dims, r, visible=None):
    """The structured grid refined r x r x r per cell by trilinear interpolation in index
    space: (points, values, dims, visible) of a ((nx-1)r+1, (ny-1)r+1, (nz-1)r+1) grid."""
    nx, ny, nz = dims
    a = np.concatenate([points.reshape(nz, ny, nx, 3), values.reshape(nz, ny, nx, 1)], axis=-1).astype(np.float64)
    for axis, n in ((2, nx), (1, ny), (0, nz)):  # i, j, k: the tensor product of linear interpolations
        idx = np.arange((n - 1) * r + 1)
        c = np.minimum(idx // r, n - 2)
        t = (idx - c * r) / r
        shape = [1, 1, 1, 1]
        shape[axis] = -1
        t = t.reshape(shape)
        a = np.take(a, c, axis=axis) * (1.0 - t) + np.take(a, c + 1, axis=axis) * t
    fdims = ((nx - 1) * r + 1, (ny - 1) * r + 1, (nz - 1) * r + 1)
    fvis = None
    if visible is not None:
        v = visible.reshape(nz - 1, ny - 1, nx - 1)
        fvis = np.repeat(np.repeat(np.repeat(v, r, 0), r, 1), r, 2).ravel()
    return a[..., :3].reshape(-1, 3), a[..., 3].ravel(), fdims, fvis


def split_mesh(points, values, dims, visible, name):
    """As ``tetmesh_from_structured`` does it, from arrays (point scalars)."""
    from pv_hdrvol.data.structured import collapsed_tets, structured_tets
    from pv_hdrvol.data.tets import tetmesh_from_arrays

    tets = structured_tets(points, dims, visible)
    tets = tets[~collapsed_tets(points, tets)]
    return tetmesh_from_arrays(points, tets, values, association="point", name=name)


def grid_arrays(grid, scalars):
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from pv_hdrvol.data.structured import grid_dims, visible_cells

    pts = vtk_to_numpy(grid.GetPoints().GetData()).astype(np.float64)
    vals = vtk_to_numpy(grid.GetPointData().GetArray(scalars)).astype(np.float64)
    return pts, vals, grid_dims(grid), visible_cells(grid)


def setup(grid, scalars):
    import pv_hdrvol as hv
    from pv_hdrvol.data.tets import tetmesh_from_structured

    mesh = tetmesh_from_structured(grid, scalars)
    lo, hi = mesh.value_range
    tf = hv.TransferFunction.ramp(lo, hi, cmap="viridis", opacity=(0.0, 0.3))
    camera = hv.Camera.fit(mesh.bounds, "iso")
    return mesh, tf, camera, mesh.default_unit_distance()


def render(mesh, tf, camera, size, unit):
    import pv_hdrvol as hv

    return hv.render(mesh, tf, camera, (size, size), precision="float64", opacity_unit_distance=unit,
                     progress_bar=False)


def rgba(img):
    return np.asarray(img.rgba, np.float64)


def errors(a, ref):
    """(RMS, max) of a - ref over all RGBA channels, relative to ref's peak."""
    d = a - ref
    peak = float(ref.max())
    return float(np.sqrt(np.mean(d ** 2))) / peak, float(np.abs(d).max()) / peak


def part_accuracy(label, grid, scalars, size, rs):
    mesh0, tf, camera, unit = setup(grid, scalars)
    pts, vals, dims, vis = grid_arrays(grid, scalars)
    imgs, rows = {}, []
    for r in sorted(rs):
        t = time.perf_counter()
        fp, fv, fd, fvis = refine(pts, vals, dims, r, vis) if r > 1 else (pts, vals, dims, vis)
        mesh = split_mesh(fp, fv, fd, fvis, scalars)
        t_prep = time.perf_counter() - t
        img = render(mesh, tf, camera, size, unit)
        imgs[r] = rgba(img)
        rows.append({"grid": label, "r": r, "dims": fd, "tets": mesh.n_cells, "prepare": t_prep,
                     "render": img.metadata.get("render_seconds", float("nan")), "load": load()})
        del mesh
        print(f"  {label} r={r}: {rows[-1]}", flush=True)
    finest = max(rs)
    prev = None
    for row in rows:
        rms, mx = errors(imgs[row["r"]], imgs[finest])
        row.update(rms=rms, max=mx, ratio=(prev / rms if prev and rms > 0 else None), finest=finest)
        prev = rms
    if 1 in imgs:  # sanity: our arrays path is tetmesh_from_structured's
        same = errors(rgba(render(mesh0, tf, camera, size, unit)), imgs[1])[1]
        print(f"  {label}: tetmesh_from_structured vs arrays path, max diff / peak {same:.1e}", flush=True)
    return rows, imgs[finest]


def triangle_filter(grid, scalars):
    from vtkmodules.vtkFiltersGeneral import vtkDataSetTriangleFilter

    f = vtkDataSetTriangleFilter()
    f.SetInputData(grid)
    f.Update()
    ug = f.GetOutput()
    ug.GetPointData().SetActiveScalars(scalars)
    return ug


def same_tets(grid, ug):
    """'yes' when structured_tets (before dropping collapsed tets) gives the filter's
    tetrahedra up to their order and corner order, on the same points; else what differs."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from pv_hdrvol.data.structured import grid_dims, grid_start, structured_tets, visible_cells

    gp = vtk_to_numpy(grid.GetPoints().GetData())
    up = vtk_to_numpy(ug.GetPoints().GetData())
    if gp.shape != up.shape or not np.array_equal(gp.astype(np.float32), up.astype(np.float32)):
        return "no (points differ)"
    ours = structured_tets(gp, grid_dims(grid), visible_cells(grid), grid_start(grid))
    theirs = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).reshape(-1, 4)
    a, b = np.sort(np.sort(ours, axis=1), axis=0), np.sort(np.sort(theirs, axis=1), axis=0)
    if a.shape == b.shape and np.array_equal(np.unique(a, axis=0), np.unique(b, axis=0)):
        return f"yes ({len(a):,})"
    return f"no ({len(a):,} vs {len(b):,})"


def part_time(label, grid, scalars, size, repeat, ref, use_vtk):
    import pv_hdrvol as hv
    from pv_hdrvol.data.tets import tetmesh_from_structured

    _, tf, camera, unit = setup(grid, scalars)  # the same tf, camera and unit as part 1
    out = {"grid": label, "load0": load()}
    t = time.perf_counter()
    ka = tetmesh_from_structured(grid, scalars)
    out["a_prep"] = time.perf_counter() - t
    t = time.perf_counter()
    ug = triangle_filter(grid, scalars)
    kb = hv.tetmesh_from_dataset(ug, scalars)
    out["b_prep"] = time.perf_counter() - t
    out["a_tets"], out["b_tets"] = ka.n_cells, kb.n_cells
    out["same"] = same_tets(grid, ug)
    imgs = {}
    for key, m in (("a", ka), ("b", kb)):
        render(m, tf, camera, size, unit)  # warm-up
        ts = []
        for _ in range(repeat):
            t = time.perf_counter()
            img = render(m, tf, camera, size, unit)
            ts.append(time.perf_counter() - t)
        out[f"{key}_render"] = statistics.median(ts)
        imgs[key] = rgba(img)
    out["ab_rms"], out["ab_max"] = errors(imgs["b"], imgs["a"])
    if ref is not None:
        out["a_ref_rms"], out["a_ref_max"] = errors(imgs["a"], ref)
        out["b_ref_rms"], out["b_ref_max"] = errors(imgs["b"], ref)
    out["vtk"] = None
    if use_vtk:
        try:
            from bench_tets import vtk_scene

            s = vtk_scene("raycast", ug, tf, camera, (size, size), unit)
            s.render()  # warm-up: VTK builds its structures on the first frame
            out["vtk"] = statistics.median([s.render() for _ in range(repeat)])
            s.close()
        except Exception as e:  # no OpenGL context, missing module...
            out["vtk_error"] = f"{type(e).__name__}: {e}"
    else:
        out["vtk_error"] = "--no-vtk"
    out["load1"] = load()
    print(f"  {label}: {out}", flush=True)
    return out


def tables(acc, tim, size):
    lines = []
    if acc:
        lines += [f"Accuracy of our 5-tet split against the trilinear field ({size}², float64; error of the "
                  "premultiplied RGBA against the finest r, relative to its peak):", "",
                  "| grid | r | grid points | tets | prepare s | render s | RMS / peak | max / peak | "
                  "RMS ratio to previous r | load |", "|---|--:|---|--:|--:|--:|--:|--:|--:|--:|"]
        for r in acc:
            ratio = f"{r['ratio']:.2f}" if r["ratio"] else "-"
            ref = " (reference)" if r["r"] == r["finest"] else ""
            lines.append(f"| {r['grid']} | {r['r']}{ref} | {'x'.join(map(str, r['dims']))} | {r['tets']:,} | "
                         f"{r['prepare']:.2f} | {r['render']:.2f} | {r['rms']:.2e} | {r['max']:.2e} | {ratio} | "
                         f"{r['load']} |")
        lines.append("")
    if tim:
        lines += [f"Time ({size}², float64, median of renders after a warm-up) and the two piecewise-linear "
                  "models (a: ours, tetmesh_from_structured, 5 tets/hex less collapsed ones; b: vtkDataSetTriangleFilter "
                  "5 tets/hex):", "",
                  "| grid | tets a | tets b | prepare a s | prepare b s | render a s | render b s | "
                  "VTK UG ray cast (on b) s | a vs b RMS / peak | a vs b max / peak | a vs trilinear RMS | "
                  "b vs trilinear RMS | a vs trilinear max | b vs trilinear max | same tets | load |",
                  "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|--:|"]
        for r in tim:
            vtk = f"{r['vtk']:.3f}" if r["vtk"] is not None else "n/a"
            ref = (f"{r['a_ref_rms']:.2e} | {r['b_ref_rms']:.2e} | {r['a_ref_max']:.2e} | {r['b_ref_max']:.2e}"
                   if "a_ref_rms" in r else "- | - | - | -")
            lines.append(f"| {r['grid']} | {r['a_tets']:,} | {r['b_tets']:,} | {r['a_prep']:.3f} | "
                         f"{r['b_prep']:.3f} | {r['a_render']:.3f} | {r['b_render']:.3f} | {vtk} | "
                         f"{r['ab_rms']:.2e} | {r['ab_max']:.2e} | {ref} | {r['same']} | {r['load0']}-{r['load1']} |")
        errs = [f"{r['grid']}: {r['vtk_error']}" for r in tim if r.get("vtk_error")]
        if errs:
            lines += ["", "VTK ray cast not run: " + "; ".join(errs)]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--part", choices=("accuracy", "time", "both"), default="both")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--refine-bluntfin", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--refine-post", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--grids", nargs="+", help="labels to run (default all)")
    ap.add_argument("--no-vtk", action="store_true", help="skip VTK's ray cast mapper")
    args = ap.parse_args(argv)
    import numba

    print(f"numba threads {numba.get_num_threads()}, load {load()}, loadavg {os.getloadavg()}", flush=True)
    acc, tim = [], []
    for label, xyz, q, scalars in GRIDS:
        if args.grids and label not in args.grids:
            continue
        grid = read_plot3d(xyz, q)
        rs = args.refine_bluntfin if label == "Blunt Fin" else args.refine_post
        ref = None
        if args.part in ("accuracy", "both"):
            rows, ref = part_accuracy(label, grid, scalars, args.size, rs)
            acc += rows
        if args.part in ("time", "both"):
            tim.append(part_time(label, grid, scalars, args.size, args.repeat, ref, not args.no_vtk))
    print()
    print(tables(acc, tim, args.size))
    print(f"\nloadavg {os.getloadavg()}")


if __name__ == "__main__":
    main()
