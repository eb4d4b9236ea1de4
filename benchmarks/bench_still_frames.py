"""Still frames against VTK at each renderer's defaults: the comparison a user makes by
eye when switching from ``add_volume`` (issue 32, part 4).

Scenes: the frontier's (bench_frontier.py: engine with a transparent function, bonsai
with an opaque one, hydrogen on a log axis) and the interaction scenes
(bench_interaction.py: engine, bonsai and the Blunt Fin with the renderer's default
transfer function), iso camera, ``--size`` (default 512^2).

Each is rendered by

- ours at today's defaults (float32, step 0.5 voxel), in float64 at ``--steps`` (1 and
  2 voxels: candidates for new defaults) and at ``tolerance=`` 1e-2, 3e-3, 1e-3 (pilot
  included in the time),
- VTK's ``vtkFixedPointVolumeRayCastMapper`` and ``vtkGPUVolumeRayCastMapper`` (Mesa
  llvmpipe here) at *their* defaults: sample distance 1 world unit, automatic
  adjustment on (a still render), no jittering, every pixel -- the mappers as
  ``add_volume`` makes them; the Blunt Fin by ``vtkUnstructuredGridVolumeRayCastMapper``
  at its defaults,

with the same transfer-function control points, opacity unit distance and camera.
Error: RMS over every pixel and RGB channel of the picture a window shows (ours
clipped to [0, 1] over black; VTK's 8-bit window read back) against the converged
render (float64, step 0.05 voxel or ``tau_max`` 0.002, a 2^20 / 2^16-entry table, no
termination) clipped the same way, relative to the latter's peak. Time: median of
``--frames``, renderers interleaved per round; the load is printed.

    python3 benchmarks/bench_still_frames.py
    python3 benchmarks/bench_still_frames.py --size 256 --frames 3 --scenes engine_default
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_frontier import hydrogen_tf  # noqa: E402
from bench_grid import DATASETS, VTKWindow, data_dir, load, read_vti, transfer_functions  # noqa: E402

TOLERANCES = (1e-2, 3e-3, 1e-3)
SCENES = ("engine_transparent", "bonsai_opaque", "hydrogen_log", "engine_default", "bonsai_default", "bluntfin")


def scenes(hv, which):
    """``{name: (vtk dataset, our data, tf, kind)}``."""
    import pyvista as pv

    tfs = transfer_functions(hv)
    out = {}
    for name, key, tf_name in (("engine_transparent", "engine", "transparent"), ("bonsai_opaque", "bonsai", "opaque"),
                               ("engine_default", "engine", None), ("bonsai_default", "bonsai", None)):
        if name in which:
            image = read_vti(data_dir() / DATASETS[key])
            vol = hv.volume_from_dataset(image)
            tf = tfs[tf_name] if tf_name else hv.raycast.grid.resolve_transfer_function(vol, None)
            out[name] = (image, vol, tf, "grid")
    if "hydrogen_log" in which:
        image = read_vti(data_dir() / "hdr" / "hydrogen_64x64x64_float32.vti")
        out["hydrogen_log"] = (image, hv.volume_from_dataset(image), hydrogen_tf(hv), "grid")
    if "bluntfin" in which:
        grid = pv.read(data_dir() / "unstructured" / "bluntfin_187395tets.vtu")
        mesh = hv.tetmesh_from_dataset(grid)
        grid.set_active_scalars(mesh.name, preference="point" if mesh.name in grid.point_data else "cell")
        out["bluntfin"] = (grid, mesh, hv.raycast.grid.resolve_transfer_function(mesh, None), "mesh")
    return out


def vtk_default(kind, dataset, tf, camera, size, unit):
    """VTK's mapper of ``kind`` as ``add_volume`` makes it: its own sample distances."""
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (object factories)
    import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401
    from vtkmodules.vtkRenderingVolume import (
        vtkFixedPointVolumeRayCastMapper, vtkGPUVolumeRayCastMapper, vtkUnstructuredGridVolumeRayCastMapper,
    )

    mapper = {"fixed": vtkFixedPointVolumeRayCastMapper, "gpu": vtkGPUVolumeRayCastMapper,
              "unstructured": vtkUnstructuredGridVolumeRayCastMapper}[kind]()
    mapper.SetInputData(dataset)
    return VTKWindow(mapper, tf, camera, size, unit)


def shown(rgb):
    return np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES)
    ap.add_argument("--tolerances", type=float, nargs="+", default=list(TOLERANCES))
    ap.add_argument("--steps", type=float, nargs="*", default=[1.0, 2.0],
                    help="float64 steps rendered as candidates for a new default (grids)")
    args = ap.parse_args(argv)

    import pv_hdrvol as hv

    warnings.simplefilter("ignore")
    size = (args.size, args.size)
    print(f"load before: {load()}")
    print("| scene | renderer | time (s) | error | vs VTK fixed-point: time, error |\n|---|---|--:|--:|---|")
    for name, (dataset, data, tf, kind) in scenes(hv, args.scenes).items():
        cam = hv.Camera.fit(data.bounds, "iso")
        unit = float(data.spacing.min()) if kind == "grid" else data.default_unit_distance()
        render = hv.render if kind == "grid" else hv.render_tets
        big = 2**20 if kind == "grid" else 2**16
        fine = hv.TransferFunction(tf.values, tf.colors, tf.opacities, scale=tf.scale, linthresh=tf.linthresh,
                                   color_space=tf.color_space, table_size=big)
        knob = {"step": 0.05} if kind == "grid" else {"tau_max": 0.002}
        ref = shown(render(data, fine, cam, size, precision="float64", termination=0.0, progress_bar=False,
                           **knob).rgba[..., :3])
        peak = float(ref.max())

        frames = {"ours, defaults": lambda: render(data, tf, cam, size, progress_bar=False)}
        if kind == "grid":  # candidates for new defaults
            for step in args.steps:
                frames[f"ours, float64, step {step:g}"] = lambda step=step: render(
                    data, tf, cam, size, precision="float64", step=step, progress_bar=False)
        for tol in args.tolerances:
            frames[f"ours, tolerance {tol:g}"] = lambda tol=tol: render(data, tf, cam, size, tolerance=tol,
                                                                        progress_bar=False)
        peers = {}
        for kind_vtk in (("fixed", "gpu") if kind == "grid" else ("unstructured",)):
            peers[f"VTK {kind_vtk}, defaults"] = vtk_default(kind_vtk, dataset, tf, cam, size, unit)
        errors = {}
        for key, f in frames.items():
            errors[key] = float(np.sqrt(np.mean((shown(f().rgba[..., :3]) - ref) ** 2)) / peak)
        for key, scene in peers.items():
            scene.render()
            rgb = scene.luminance()[1].astype(np.float64) / 255.0
            errors[key] = float(np.sqrt(np.mean((rgb - ref) ** 2)) / peak)
        times = {key: [] for key in list(frames) + list(peers)}
        for _ in range(args.frames):
            for key in times:
                if key in frames:
                    t0 = time.perf_counter()
                    frames[key]()
                    times[key].append(time.perf_counter() - t0)
                else:
                    times[key].append(peers[key].render())
        t_fixed = statistics.median(times["VTK fixed, defaults"]) if "VTK fixed, defaults" in times else None
        e_fixed = errors.get("VTK fixed, defaults")
        for key in times:
            t = statistics.median(times[key])
            versus = f"{t / t_fixed:.2f}x, {errors[key] / e_fixed:.2f}x" if t_fixed else "-"
            print(f"| {name} | {key} | {t:.3f} | {errors[key]:.2e} | {versus} |", flush=True)
        for scene in peers.values():
            scene.close()
    print(f"load after: {load()}")


if __name__ == "__main__":
    main()
