"""Clipping planes and a crop box: exact against Beer-Lambert, beside VTK's mapper, and their cost.

1. **Exactness.** A slab of constant extinction seen from above, cut by the plane
   ``z = c`` (the part below kept) for cuts ``c`` between voxels: the opacity of each
   pixel is ``1 - exp(-sigma c)``. Ours (float64 and float32, steps 1 and 0.5 voxel)
   against that; VTK's ``vtkFixedPointVolumeRayCastMapper`` with the same
   ``AddClippingPlane``, the same transfer function, opacity unit distance, sample
   distance and camera, read back in 8 bits (so ours is also shown rounded to 8 bits:
   that part of the error is the window's, not the cut's).
2. **Cost.** engine (256x256x128, bench_grid's transparent function) and the Blunt Fin
   tetrahedral mesh (187,395 tets) at ``--size``, iso view: no cut, a plane through the
   centre keeping the far half, the near half, and a crop box of the middle half per
   axis. Median of ``--frames`` after a warm-up, samples (cells) per render, the load.

    python3 benchmarks/bench_clip.py
    python3 benchmarks/bench_clip.py --size 256 --frames 1   # a quick look
"""
from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_grid import VTKWindow, data_dir, load, read_vti, transfer_functions  # noqa: E402

CUTS = (20.0, 20.25, 20.5, 20.75, 31.1)
ALPHA = 0.02  # the transfer function's opacity over one voxel (the unit distance)


def slab(hv, n=48):
    """A constant slab, points 0..n-1 along each axis (spacing 1), value 1."""
    values = np.ones((n, n, n))
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData

    image = vtkImageData()
    image.SetDimensions(n, n, n)
    image.SetSpacing(1.0, 1.0, 1.0)
    array = numpy_to_vtk(values.ravel(), deep=True)
    array.SetName("v")
    image.GetPointData().SetScalars(array)
    return image, hv.volume_from_array(values), hv.TransferFunction([0.0, 2.0], [[1.0, 1.0, 1.0]] * 2, [ALPHA, ALPHA])


def exactness(hv, size):
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (object factories)
    import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401
    from vtkmodules.vtkCommonDataModel import vtkPlane
    from vtkmodules.vtkRenderingVolume import vtkFixedPointVolumeRayCastMapper

    image, volume, tf = slab(hv)
    n = volume.dims[0]
    camera = hv.Camera((0.5 * (n - 1), 0.5 * (n - 1), 3.0 * n), (0.5 * (n - 1), 0.5 * (n - 1), 0.0), (0, 1, 0),
                       parallel_projection=True, parallel_scale=0.3 * n)
    sigma = -math.log1p(-ALPHA)
    print("\n## 1. Exactness: the slab cut at z = c (kept below), pixel opacity against 1 - exp(-sigma c)\n")
    print("| c | ours float64, step 1 / 0.5 | ours float32, step 1 / 0.5 | ours float64 in 8 bits | VTK fixed point, "
          "step 1 / 0.5 (8 bits) |\n|--:|--:|--:|--:|--:|")
    for c in CUTS:
        exact = -math.expm1(-sigma * c)
        cells, first = [], None
        for precision in ("float64", "float32"):
            errors = []
            for step in (1.0, 0.5):
                img = hv.render(volume, tf, camera, size, precision=precision, step=step, termination=0.0,
                                opacity_unit_distance=1.0, clip_planes=((0, 0, c), (0, 0, -1)), progress_bar=False)
                errors.append(float(np.abs(img.rgba[..., 3] - exact).max()))
                first = img if first is None else first
            cells.append(" / ".join(f"{e:.1e}" for e in errors))
        eight = float(np.abs(np.round(first.rgba[..., 0].astype(np.float64) * 255) / 255 - exact).max())
        vtk_errors = []
        for step in (1.0, 0.5):
            mapper = vtkFixedPointVolumeRayCastMapper()
            mapper.SetInputData(image)
            mapper.SetAutoAdjustSampleDistances(False)
            mapper.SetLockSampleDistanceToInputSpacing(False)
            mapper.SetSampleDistance(step)
            mapper.SetInteractiveSampleDistance(step)
            mapper.SetImageSampleDistance(1.0)
            plane = vtkPlane()
            plane.SetOrigin(0.0, 0.0, c)
            plane.SetNormal(0.0, 0.0, -1.0)
            mapper.AddClippingPlane(plane)
            window = VTKWindow(mapper, tf, camera, size, 1.0)
            window.render()
            _, rgb = window.luminance()
            window.close()
            vtk_errors.append(float(np.abs(rgb[..., 0].astype(np.float64) / 255.0 - exact).max()))
        print(f"| {c} | {cells[0]} | {cells[1]} | {eight:.1e} | {' / '.join(f'{e:.1e}' for e in vtk_errors)} |")


def timed(render, frames):
    render()  # warm-up (compiles)
    times = []
    for _ in range(frames):
        t = time.perf_counter()
        img = render()
        times.append(time.perf_counter() - t)
    return statistics.median(times), img


def cost(hv, size, frames):
    import pyvista as pv

    print(f"\n## 2. Cost at {size[0]}x{size[1]}, iso view (median of {frames}; load {load()})\n")
    image = read_vti(data_dir() / "structured" / "engine_256x256x128_uint8.vti")
    engine = hv.volume_from_dataset(pv.wrap(image))
    mesh = hv.tetmesh_from_dataset(pv.read(data_dir() / "unstructured" / "bluntfin_187395tets.vtu"))
    tf_engine = transfer_functions(hv)["transparent"]
    print("| data | cut | time (s) | / uncut | samples or cells |\n|---|---|--:|--:|--:|")
    for name, data, tf in (("engine", engine, tf_engine), ("Blunt Fin", mesh, None)):
        b = data.bounds
        centre = np.array([0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3]), 0.5 * (b[4] + b[5])])
        camera = hv.Camera.fit(b, "iso")
        towards = np.asarray(camera.position) - centre
        quarter = [0.25 * (b[2 * i + 1] - b[2 * i]) for i in range(3)]
        cuts = {
            "none": {},
            "plane, far half kept": {"clip_planes": (tuple(centre), tuple(-towards))},
            "plane, near half kept": {"clip_planes": (tuple(centre), tuple(towards))},
            "crop box, middle half per axis": {"crop_box": tuple(x for i in range(3) for x in
                                                                  (centre[i] - quarter[i], centre[i] + quarter[i]))},
        }
        base = None
        for label, clip in cuts.items():
            seconds, img = timed(lambda: hv.render(data, tf, camera, size, progress_bar=False, **clip), frames)
            base = seconds if base is None else base
            work = img.metadata.get("samples", img.metadata.get("cells"))
            print(f"| {name} | {label} | {seconds:.3f} | {seconds / base:.2f} | {work:,} |")
    print(f"\nload after: {load()}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--parts", nargs="+", default=["exactness", "cost"], choices=["exactness", "cost"])
    args = ap.parse_args(argv)

    import pv_hdrvol as hv

    print(f"load before: {load()}")
    if "exactness" in args.parts:
        exactness(hv, (64, 64))
    if "cost" in args.parts:
        cost(hv, (args.size, args.size), args.frames)


if __name__ == "__main__":
    main()
