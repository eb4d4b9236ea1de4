"""Tetrahedral meshes: our ray caster against VTK's three unstructured volume mappers,
and joint bilateral upsampling against nearest and bilinear (Callahan & Silva's Table 1).

1. **Peers** (``--part peers``). SPX, Blunt Fin, the FEA bracket and the LOX post from
   ../shared/data, same camera (``Camera.to_vtk()``), same transfer-function control
   points and opacity unit distance, at each ``--sizes``:
   ``vtkUnstructuredGridVolumeRayCastMapper``, ``vtkProjectedTetrahedraMapper`` and
   ``vtkUnstructuredGridVolumeZSweepMapper`` (offscreen, Mesa llvmpipe here) against
   our float32 render. Frames are interleaved (one of each renderer per round) and the
   median is reported. Then, at a low opacity (``global_alpha`` 0.02), the number of
   distinct output levels: distinct luminance values of the covered pixels (ours:
   float32; theirs: the 8-bit frame buffer).
2. **Upsampling** (``--part upsample``). A 1024^2 target rendered in full, and from
   512^2, 256^2 and 128^2: the time of the low-resolution render (I), of the full-size
   reference layers (R) and of the upsampling (U), the total and the speedup over the
   full render; the RMSE (linear premultiplied RGBA) against the full render of
   nearest, bilinear and joint bilateral upsampling (the default, guided by the
   thickness, and the paper's filter, guided by the depth layers); how many boundary
   layers each mesh has. ``--figure`` writes the rate-distortion plot to docs/images.
3. **Integration** (``--part tau``). Time and error of ``tau_max`` (the largest optical
   depth of one integration piece) against ``tau_max = 0.002``, float64, at 256^2.
4. **Table size** (``--part table``). Time and error of the transfer function's
   ``table_size`` (float32, at 256^2) against a float64 render with 2^20 rows; the
   sizes' frames interleaved. The walk reads the table at every cell: 72 bytes a row,
   4.7 MB at the default 65,536 rows, more than this machine's L2 cache.

Usage::

    python3 benchmarks/bench_tets.py                         # both parts, ~10 minutes
    python3 benchmarks/bench_tets.py --part peers --sizes 512 --repeat 3
    python3 benchmarks/bench_tets.py --part upsample --figure docs/images/upsample_rd.png
    python3 benchmarks/bench_tets.py --part tau         # error and time against tau_max
    python3 benchmarks/bench_tets.py --part table       # error and time against table_size

The load average is printed beside every row: the machine is shared.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np

REPO = Path(__file__).resolve().parents[1]
for _path in (REPO, REPO / "benchmarks"):  # the package, and bench_grid's VTKWindow
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

#: file, scalars, label
MESHES = [
    ("spx_12936tets.vtk", "scalars", "SPX"),
    ("bluntfin_187395tets.vtu", "Density", "Blunt Fin"),
    ("fea_bracket_56786tets.vtu", "Equivalent (von-Mises) Stress (psi)", "FEA bracket"),
    ("post_513375tets.vtu", "VelocityMagnitude", "LOX post"),
]
PEERS = ("raycast", "projected", "zsweep")
LOW_OPACITY = 0.02
#: range sigmas of the thickness guide measured by --part upsample (the default is 0.2)
SIGMAS = (0.05, 0.1, 0.2, 0.4)
#: untimed render(upsample=f) calls before the timed ones (see part_upsample)
UPSAMPLE_WARMUP = 2


def data_dir():
    return Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data")) / "unstructured"


def load():
    return round(os.getloadavg()[0], 2)


#: --opaque: the transfer function's opacity ramp goes to 1 over 1/8 of a typical cell
OPAQUE = {"opacity": (0.0, 0.3), "unit_factor": 1.0}


def scene(name, scalars):
    import pyvista as pv

    import pv_hdrvol as hv

    grid = pv.read(data_dir() / name)
    grid.set_active_scalars(scalars, preference="point" if scalars in grid.point_data else "cell")
    mesh = hv.tetmesh_from_dataset(grid, scalars)
    lo, hi = mesh.value_range
    tf = hv.TransferFunction.ramp(lo, hi, cmap="viridis", opacity=OPAQUE["opacity"])
    camera = hv.Camera.fit(mesh.bounds, "iso")
    return grid, mesh, tf, camera, mesh.default_unit_distance() * OPAQUE["unit_factor"]


def vtk_scene(kind, grid, tf, camera, size, unit, global_alpha=1.0):
    """A ``bench_grid.VTKWindow`` with one of VTK's unstructured volume mappers."""
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (object factories)
    import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401
    from vtkmodules.vtkRenderingVolume import (
        vtkProjectedTetrahedraMapper, vtkUnstructuredGridVolumeRayCastMapper, vtkUnstructuredGridVolumeZSweepMapper,
    )

    from bench_grid import VTKWindow

    mapper = {"raycast": vtkUnstructuredGridVolumeRayCastMapper, "projected": vtkProjectedTetrahedraMapper,
              "zsweep": vtkUnstructuredGridVolumeZSweepMapper}[kind]()
    mapper.SetInputData(grid)
    if hasattr(mapper, "SetImageSampleDistance"):
        mapper.SetImageSampleDistance(1.0)  # every pixel, as ours
    if hasattr(mapper, "SetAutoAdjustSampleDistances"):
        mapper.SetAutoAdjustSampleDistances(0)
    return VTKWindow(mapper, tf, camera, size, unit, global_alpha)


def vtk_levels(scene):
    """Distinct luminance levels of the covered pixels of a window's 8-bit frame buffer."""
    lum = scene.luminance()[0]
    return int(np.unique(lum[lum > 0]).size)


def our_levels(img):
    rgba = np.asarray(img.rgba, dtype=np.float32)
    lum = rgba[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])
    return int(np.unique(lum[lum > 0]).size)


def part_peers(sizes, repeat, peers):
    import pv_hdrvol as hv

    rows = []
    for name, scalars, label in MESHES:
        grid, mesh, tf, camera, unit = scene(name, scalars)
        for size in sizes:
            wh = (size, size)
            load0 = load()
            ours = lambda: hv.render(mesh, tf, camera, wh, precision="float32", opacity_unit_distance=unit,  # noqa: E731
                                     progress_bar=False)
            ours()  # warm-up: JIT and the mesh cache
            scenes = {k: vtk_scene(k, grid, tf, camera, wh, unit) for k in peers}
            for s in scenes.values():
                s.render()  # warm-up: VTK builds its structures on the first frame
            times = {"ours": []} | {k: [] for k in scenes}
            for _ in range(repeat):
                t = time.perf_counter()
                ours()
                times["ours"].append(time.perf_counter() - t)
                for k, s in scenes.items():
                    times[k].append(s.render())
            for s in scenes.values():
                s.close()
            med = {k: statistics.median(v) for k, v in times.items()}
            # distinct levels at low opacity (one frame each)
            faint = hv.render(mesh, tf, camera, wh, precision="float32", global_alpha=LOW_OPACITY,
                              opacity_unit_distance=unit, progress_bar=False)
            levels = {"ours": our_levels(faint)}
            for k in peers:
                s = vtk_scene(k, grid, tf, camera, wh, unit, global_alpha=LOW_OPACITY)
                s.render()
                levels[k] = vtk_levels(s)
                s.close()
            row = {"mesh": label, "tets": mesh.n_cells, "size": size, "seconds": med, "levels": levels,
                   "load": (load0, load())}
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2)))


def part_upsample(target, lows, repeat):
    import pv_hdrvol as hv

    rows = []
    for name, scalars, label in MESHES:
        grid, mesh, tf, camera, unit = scene(name, scalars)
        size = (target, target)
        opts = {"opacity_unit_distance": unit, "progress_bar": False}
        hv.render(mesh, tf, camera, (64, 64), **opts)  # warm-up: JIT
        hv.render(mesh, tf, camera, size, **opts)  # one full-size frame untimed, as below
        full_t = []
        for _ in range(repeat):
            t = time.perf_counter()
            full = hv.render(mesh, tf, camera, size, **opts)
            full_t.append(time.perf_counter() - t)
        t_full = statistics.median(full_t)
        layers = hv.depth_layers(mesh, camera, size)
        for low in lows:
            f = target // low
            parts = {"I": [], "R": [], "U": [], "total": []}
            # untimed: the first call compiles the layer and filter kernels (or loads them
            # from numba's cache), which the 64^2 warm-up above does not use. (Frames that
            # get memory the machine has not touched before still run tens of ms slower
            # at 1024^2: compare the medians with the load and with a second run.)
            for _ in range(UPSAMPLE_WARMUP):
                hv.render(mesh, tf, camera, size, upsample=f, **opts)
            for _ in range(repeat):
                t = time.perf_counter()
                img = hv.render(mesh, tf, camera, size, upsample=f, **opts)
                parts["total"].append(time.perf_counter() - t)
                parts["I"].append(img.metadata["low_render_seconds"])
                parts["R"].append(img.metadata["reference_seconds"])
                parts["U"].append(img.metadata["upsample_seconds"])
            med = {k: statistics.median(v) for k, v in parts.items()}
            small = hv.render(mesh, tf, camera, (low, low), **opts)
            errors = {m: rmse(hv.upsample(small, layers, f, method=m).rgba, full.rgba)
                      for m in ("nearest", "bilinear", "joint_bilateral")}
            # the paper's filter as published: the depth layers, a Gaussian of one low pixel
            errors["joint_bilateral_layers"] = rmse(hv.upsample(small, layers, f, guide="layers").rgba, full.rgba)
            # the range sigma of the thickness guide, with either spatial kernel
            sweep = {f"{spatial} {sigma}": rmse(hv.upsample(small, layers, f, spatial=spatial,
                                                            sigma_range=sigma).rgba, full.rgba)
                     for spatial in ("bilinear", "gaussian") for sigma in SIGMAS}
            row = {"mesh": label, "tets": mesh.n_cells, "target": target, "low": low, "full_seconds": t_full,
                   "seconds": med, "speedup": t_full / med["total"], "rmse": errors, "sweep": sweep,
                   "layers_needed": layers.layers_needed, "load": load()}
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def part_tau(size, repeat, values=(1.0, 0.5, 0.25, 0.1, 0.05, 0.02)):
    """Error and time against ``tau_max``: reference ``tau_max = 0.002``, float64."""
    import pv_hdrvol as hv

    rows = []
    for name, scalars, label in MESHES:
        grid, mesh, tf, camera, unit = scene(name, scalars)
        ref = hv.render(mesh, tf, camera, (size, size), precision="float64", tau_max=0.002, progress_bar=False)
        for tau in values:
            ts = []
            for _ in range(repeat):
                img = hv.render(mesh, tf, camera, (size, size), precision="float64", tau_max=tau, progress_bar=False)
                ts.append(img.metadata["render_seconds"])
            err = np.abs(np.asarray(img.rgba, np.float64) - ref.rgba)
            row = {"mesh": label, "size": size, "tau_max": tau, "seconds": statistics.median(ts),
                   "pieces": img.metadata["pieces"], "cells": img.metadata["cells"], "max_error": float(err.max()),
                   "rmse": float(np.sqrt(np.mean(err ** 2))), "load": load()}
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


#: table sizes measured by --part table, and the reference's
TABLE_SIZES = (65536, 16384, 4096, 1024, 256)
TABLE_REFERENCE = 2**20


def part_table(size, repeat, sizes=TABLE_SIZES):
    """Time and error of the table size (float32) against float64 with ``TABLE_REFERENCE`` rows."""
    import pv_hdrvol as hv

    rows = []
    for name, scalars, label in MESHES:
        grid, mesh, tf, camera, unit = scene(name, scalars)
        lo, hi = mesh.value_range
        tfs = {n: hv.TransferFunction.ramp(lo, hi, cmap="viridis", opacity=OPAQUE["opacity"], table_size=n)
               for n in (TABLE_REFERENCE, *sizes)}
        opts = {"opacity_unit_distance": unit, "progress_bar": False}
        ref = np.asarray(hv.render(mesh, tfs[TABLE_REFERENCE], camera, (size, size), precision="float64",
                                   **opts).rgba, np.float64)
        imgs = {n: hv.render(mesh, tfs[n], camera, (size, size), **opts) for n in sizes}  # warm-up
        ts = {n: [] for n in sizes}
        for _ in range(repeat):
            for n in sizes:
                ts[n].append(hv.render(mesh, tfs[n], camera, (size, size), **opts).metadata["render_seconds"])
        for n in sizes:
            err = np.abs(np.asarray(imgs[n].rgba, np.float64) - ref)
            row = {"mesh": label, "size": size, "table_size": n, "seconds": statistics.median(ts[n]),
                   "max_error": float(err.max()), "rmse": float(np.sqrt(np.mean(err ** 2))), "load": load()}
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def markdown(peers, ups, taus=(), tables=()):
    lines = [f"Machine: {platform.platform()}, {os.cpu_count()} CPUs.", ""]
    if peers:
        names = [k for k in PEERS if k in peers[0]["seconds"]]
        lines += ["| mesh | tets | size | ours f32 s | " + " | ".join(f"VTK {k} s" for k in names)
                  + " | " + " | ".join(f"ours / {k}" for k in names) + " | levels ours | "
                  + " | ".join(f"levels {k}" for k in names) + " | load |",
                  "|---|--:|--:|--:|" + "--:|" * (3 * len(names) + 1) + "--:|"]
        for r in peers:
            s, lv = r["seconds"], r["levels"]
            lines.append(f"| {r['mesh']} | {r['tets']:,} | {r['size']}² | {s['ours']:.3f} | "
                         + " | ".join(f"{s[k]:.3f}" for k in names) + " | "
                         + " | ".join(f"{s['ours'] / s[k]:.2f}" for k in names) + f" | {lv['ours']:,} | "
                         + " | ".join(f"{lv[k]:,}" for k in names) + f" | {r['load'][0]}-{r['load'][1]} |")
        lines.append("")
    if ups:
        lines += ["| mesh | layers | low | full s | I s | R s | U s | total s | speedup | RMSE nearest | "
                  "RMSE bilinear | RMSE joint bilateral (thickness) | / bilinear | RMSE paper's filter (layers) | "
                  "/ bilinear | load |",
                  "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|"]
        for r in ups:
            s, e = r["seconds"], r["rmse"]
            lines.append(f"| {r['mesh']} | {r['layers_needed']} | {r['low']}² | {r['full_seconds']:.3f} | "
                         f"{s['I']:.3f} | {s['R']:.3f} | {s['U']:.3f} | {s['total']:.3f} | {r['speedup']:.1f}x | "
                         f"{e['nearest']:.2e} | {e['bilinear']:.2e} | {e['joint_bilateral']:.2e} | "
                         f"{e['joint_bilateral'] / e['bilinear']:.2f} | {e['joint_bilateral_layers']:.2e} | "
                         f"{e['joint_bilateral_layers'] / e['bilinear']:.2f} | {r['load']} |")
        if "sweep" in ups[0]:
            keys = list(ups[0]["sweep"])
            lines += ["", "RMSE / bilinear's of the thickness guide by spatial kernel and sigma_range:", "",
                      "| mesh | low | " + " | ".join(keys) + " |", "|---|--:|" + "--:|" * len(keys)]
            for r in ups:
                lines.append(f"| {r['mesh']} | {r['low']}² | "
                             + " | ".join(f"{r['sweep'][k] / r['rmse']['bilinear']:.3f}" for k in keys) + " |")
    if taus:
        lines += ["", "| mesh | tau_max | march s | pieces / cell | max error | RMSE | load |",
                  "|---|--:|--:|--:|--:|--:|--:|"]
        for r in taus:
            lines.append(f"| {r['mesh']} | {r['tau_max']} | {r['seconds']:.3f} | {r['pieces'] / r['cells']:.2f} | "
                         f"{r['max_error']:.1e} | {r['rmse']:.1e} | {r['load']} |")
    if tables:
        lines += ["", "| mesh | table size | march s | / 65,536 rows | max error | RMSE | load |",
                  "|---|--:|--:|--:|--:|--:|--:|"]
        base = {r["mesh"]: r["seconds"] for r in tables if r["table_size"] == 65536}
        for r in tables:
            ratio = f"{r['seconds'] / base[r['mesh']]:.2f}" if r["mesh"] in base else "-"
            lines.append(f"| {r['mesh']} | {r['table_size']:,} | {r['seconds']:.3f} | {ratio} | "
                         f"{r['max_error']:.1e} | {r['rmse']:.1e} | {r['load']} |")
    return "\n".join(lines)


def figure(ups, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    meshes = list(dict.fromkeys(r["mesh"] for r in ups))
    fig, axes = plt.subplots(1, len(meshes), figsize=(3.6 * len(meshes), 3.4), squeeze=False)
    for ax, mesh in zip(axes[0], meshes):
        rs = [r for r in ups if r["mesh"] == mesh]
        for method, style, label in (("nearest", "s:", "nearest"), ("bilinear", "o--", "bilinear"),
                                     ("joint_bilateral_layers", "v-.", "joint bilateral, layers (paper)"),
                                     ("joint_bilateral", "^-", "joint bilateral, thickness")):
            ax.plot([r["seconds"]["total"] for r in rs], [r["rmse"][method] for r in rs], style, label=label)
        for r in rs:
            ax.annotate(f"{r['low']}²", (r["seconds"]["total"], r["rmse"]["bilinear"]), fontsize=7,
                        textcoords="offset points", xytext=(3, 3))
        ax.set_xlabel("seconds per 1024² frame")
        ax.set_title(f"{mesh} (full: {rs[0]['full_seconds']:.2f} s)", fontsize=9)
        ax.set_yscale("log")
    axes[0][0].set_ylabel("RMSE against the full render")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--part", choices=("peers", "upsample", "tau", "table", "both"), default="both",
                    help="both: peers and upsample; tau, table: the tau_max and table-size trades (at --target / 4)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024])
    ap.add_argument("--peers", nargs="+", choices=PEERS, default=list(PEERS))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--target", type=int, default=1024)
    ap.add_argument("--lows", type=int, nargs="+", default=[512, 256, 128])
    ap.add_argument("--meshes", nargs="+", help="labels to run (default all)")
    ap.add_argument("--opaque", action="store_true",
                    help="opacity ramp to 1 per 1/8 of a typical cell (default: to 0.3 per cell)")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--figure", type=Path)
    args = ap.parse_args(argv)
    if args.meshes:
        MESHES[:] = [m for m in MESHES if m[2] in args.meshes]
    if args.opaque:
        OPAQUE.update(opacity=(0.0, 1.0), unit_factor=1.0 / 8.0)
    import numba

    print(f"numba threads {numba.get_num_threads()}, load {load()}", flush=True)
    peers = part_peers(args.sizes, args.repeat, args.peers) if args.part in ("peers", "both") else []
    ups = part_upsample(args.target, args.lows, args.repeat) if args.part in ("upsample", "both") else []
    taus = part_tau(args.target // 4, args.repeat) if args.part == "tau" else []
    tables = part_table(args.target // 4, args.repeat) if args.part == "table" else []
    print(markdown(peers, ups, taus, tables))
    if args.out:
        args.out.write_text(json.dumps({"peers": peers, "upsample": ups, "tau": taus, "table": tables}, indent=1))
    if args.figure and ups:
        figure(ups, args.figure)


if __name__ == "__main__":
    main()
