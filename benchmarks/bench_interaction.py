"""Interaction: coarse frames while orbiting, the first frame after a transfer-function
edit, full refinement, and what the coarse frame costs in error (issue 21).

For engine, bonsai (image volumes, 512^2 view) and Blunt Fin (tetrahedral mesh,
``Density``), with the renderer's default transfer function, float32:

- **orbit**: ``--views`` camera positions 5 degrees apart around the focal point (an
  iso view's orbit about its view-up), each rendered as the viewer renders it
  (:class:`~pv_hdrvol.viewer.progressive.ProgressiveRenderer`: the coarse frame at the
  factor its time budget chose, upsampled, then the full frame). Reported: coarse
  frames per second (1 / median coarse time, upsampling included), the factors used,
  the full frame's median time, and the coarse frame's error against the full frame:
  RMSE of linear premultiplied RGBA divided by the RMS of the full frame (relative), and
  the largest pixel difference of the tone-mapped (Reinhard, 8-bit) pictures' mean.
- **edit**: the editor's model moves an interior opacity point (x1.5, then back, ...);
  the time from the edit to the first (coarse) frame: the model's new function, a new
  plan (tables, skip structure) and the coarse render.
- **peer**: VTK's ``vtkFixedPointVolumeRayCastMapper`` (image volumes) with its own
  interactive level of detail (``AutoAdjustSampleDistances`` at a desired update rate
  of 10 frames/s; the render window's ``DesiredUpdateRate``) against its still frame:
  the same orbit, the same camera (``Camera.to_vtk()``) and control points, offscreen
  (Mesa llvmpipe here).

Usage::

    python3 benchmarks/bench_interaction.py                 # all three, ~6 minutes
    python3 benchmarks/bench_interaction.py --data engine --views 6 --size 256

The load average is printed with every row: the machine is shared (2 cores).
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time
from pathlib import Path

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.editor.model import TransferFunctionModel  # noqa: E402
from pv_hdrvol.viewer.progressive import ProgressiveRenderer  # noqa: E402

DATA = REPO.parent / "shared" / "data"
#: label, file, scalars
DATASETS = {
    "engine": ("structured/engine_256x256x128_uint8.vti", None),
    "bonsai": ("structured/bonsai_256x256x256_uint8.vti", None),
    "bluntfin": ("unstructured/bluntfin_187395tets.vtu", "Density"),
}


def load(name):
    import pyvista as pv

    path, scalars = DATASETS[name]
    dataset = pv.read(DATA / path)
    if isinstance(dataset, pv.UnstructuredGrid):
        return hv.tetmesh_from_dataset(dataset, scalars=scalars)
    return hv.volume_from_dataset(dataset, scalars=scalars)


def orbit(camera, degrees):
    """``camera`` turned by ``degrees`` about its view-up through its focal point."""
    p, f, up = (np.asarray(v, dtype=np.float64) for v in (camera.position, camera.focal_point, camera.view_up))
    k = up / np.linalg.norm(up)
    v = p - f
    a = math.radians(degrees)
    turned = v * math.cos(a) + np.cross(k, v) * math.sin(a) + k * np.dot(k, v) * (1 - math.cos(a))
    return hv.Camera(tuple(f + turned), tuple(f), tuple(up), view_angle=camera.view_angle,
                     parallel_projection=camera.parallel_projection, parallel_scale=camera.parallel_scale)


def load_note():
    return f"load {os.getloadavg()[0]:.2f}"


def rel_rmse(a, b):
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    return float(np.sqrt(np.mean((a - b) ** 2)) / max(np.sqrt(np.mean(b ** 2)), 1e-300))


def bench_orbit(name, volume, tf, size, views):
    renderer = ProgressiveRenderer(volume, tf, precision="float32")
    camera = hv.Camera.fit(volume.bounds, "iso")
    never = lambda: False  # noqa: E731
    renderer._full(renderer._plan, camera, (64, 64), None, 0, never)  # compile
    renderer._coarse(renderer._plan, camera, size, None, 0, never)
    coarse_t, full_t, factors, errors, display = [], [], [], [], []
    for i in range(views):
        cam = orbit(camera, 5.0 * (i + 1))
        coarse = renderer._coarse(renderer._plan, cam, size, None, 0, never)
        full = renderer._full(renderer._plan, cam, size, None, 0, never)
        coarse_t.append(coarse.seconds)
        full_t.append(full.seconds)
        factors.append(coarse.factor)
        errors.append(rel_rmse(coarse.image.rgba, full.image.rgba))
        a = hv.tonemap(full.image, "reinhard").rgb8.astype(float)
        b = hv.tonemap(coarse.image, "reinhard", fitted=hv.tonemap(full.image, "reinhard").fitted).rgb8.astype(float)
        display.append(float(np.mean(np.abs(a - b))))
    print(f"{name:9s} orbit {size[0]}^2  coarse {1 / statistics.median(coarse_t):5.1f} frames/s "
          f"(median {1000 * statistics.median(coarse_t):6.1f} ms, factors {sorted(set(factors))}), "
          f"full {statistics.median(full_t):5.2f} s (max {max(full_t):5.2f}), coarse error: RMSE "
          f"{statistics.median(errors):.3f} of the full frame's RMS, mean |8-bit diff| "
          f"{statistics.median(display):.1f}   [{load_note()}]", flush=True)
    return renderer, camera


def bench_edit(name, renderer, camera, tf, size, edits=6):
    model = TransferFunctionModel(tf)
    values, opacities = model.opacity_points
    index = int(np.argmax(opacities[1:-1])) + 1 if values.size > 2 else values.size - 1
    never = lambda: False  # noqa: E731
    times = []
    for i in range(edits):
        t0 = time.perf_counter()
        a = model.opacity_points[1][index]
        model.move_opacity_point(index, opacity=min(1.0, a * 1.5) if i % 2 == 0 else a / 1.5)
        renderer.set_scene(model.transfer_function())
        renderer._coarse(renderer._plan, camera, size, None, 0, never)
        times.append(time.perf_counter() - t0)
    print(f"{name:9s} edit  {size[0]}^2  first frame after an edit: median {1000 * statistics.median(times[1:]):6.1f}"
          f" ms (first edit {1000 * times[0]:6.1f} ms)   [{load_note()}]",
          flush=True)


def bench_peer(name, volume, tf, size, views):
    """VTK's fixed-point ray caster, still and at its interactive level of detail."""
    import pyvista as pv
    import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction, vtkVolume, vtkVolumeProperty
    from vtkmodules.vtkRenderingVolume import vtkFixedPointVolumeRayCastMapper

    grid = pv.ImageData(dimensions=volume.dims, spacing=volume.spacing, origin=volume.origin)
    grid.point_data["v"] = np.asarray(volume.values).reshape(-1)
    ctf, otf = vtkColorTransferFunction(), vtkPiecewiseFunction()
    for v, c, a in zip(tf.values, tf.colors, tf.opacities):
        ctf.AddRGBPoint(float(v), *map(float, np.clip(c, 0, 1)))
        otf.AddPoint(float(v), float(a))
    prop = vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetInterpolationTypeToLinear()
    prop.SetScalarOpacityUnitDistance(float(min(volume.spacing)))
    mapper = vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(grid)
    mapper.SetSampleDistance(0.5 * float(min(volume.spacing)))
    actor = vtkVolume()
    actor.SetMapper(mapper)
    actor.SetProperty(prop)
    pl = pv.Plotter(off_screen=True, window_size=size)
    pl.renderer.AddVolume(actor)
    pl.show(auto_close=False)
    rw = pl.render_window
    camera = hv.Camera.fit(volume.bounds, "iso")
    results = {}
    for mode, rate in (("interactive", 10.0), ("still", 0.0001)):
        mapper.SetAutoAdjustSampleDistances(1 if mode == "interactive" else 0)
        rw.SetDesiredUpdateRate(rate)
        times = []
        for i in range(views):
            pl.renderer.SetActiveCamera(orbit(camera, 5.0 * (i + 1)).to_vtk())
            pl.renderer.ResetCameraClippingRange()
            t0 = time.perf_counter()
            rw.Render()
            rw.WaitForCompletion()
            times.append(time.perf_counter() - t0)
        results[mode] = statistics.median(times[1:])
    pl.close()
    print(f"{name:9s} peer  {size[0]}^2  vtkFixedPointVolumeRayCastMapper: interactive (update rate 10) "
          f"{1 / results['interactive']:5.1f} frames/s ({1000 * results['interactive']:6.1f} ms), still "
          f"{results['still']:5.2f} s   [{load_note()}]", flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", nargs="+", choices=sorted(DATASETS), default=list(DATASETS))
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--views", type=int, default=12)
    parser.add_argument("--no-peer", action="store_true")
    args = parser.parse_args(argv)
    size = (args.size, args.size)
    print(f"pv_hdrvol {hv.__version__}, {os.cpu_count()} cores, numba threads "
          f"{__import__('numba').get_num_threads()}   [{load_note()}]", flush=True)
    for name in args.data:
        volume = load(name)
        from pv_hdrvol.raycast.grid import resolve_transfer_function

        tf = resolve_transfer_function(volume)
        renderer, camera = bench_orbit(name, volume, tf, size, args.views)
        bench_edit(name, renderer, camera, tf, size)
        if not args.no_peer and isinstance(volume, hv.GridVolume):
            bench_peer(name, volume, tf, size, args.views)


if __name__ == "__main__":
    main()
