"""device="cuda" on an NVIDIA GPU: equality with the CPU, first-render (compile) time and
steady frame rates, beside VTK's GPU mapper on the same GPU where VTK can use it.

One prepared script for a machine with a GPU (the issue's reference: an H200 class
card). It

1. installs what it needs (``numba-cuda[cu13]`` if missing; VTK is optional) and says
   what it found: GPU, driver, versions, the machine's load;
2. checks GPU against CPU at 512^2 on the repository's datasets (engine, bonsai, the
   hydrogen orbital, the m4 density; float32 and float64, unshaded and shaded, and a
   maximum projection): the largest difference relative to the image's peak (goal:
   <= 1e-5);
3. times the first render of each kernel variant (numba-cuda compiles it then);
4. times steady frames at 1024^2 over a camera orbit for engine, bonsai and procedural
   512^3 and 1024^3 volumes, with a transparent transfer function (no ray terminates
   early, every sample composited) and an opaque one: the whole ``execute`` (frames/s,
   what a viewer gets) and the kernel alone (``metadata["device"]["kernel_seconds"]``);
5. renders the same scenes with ``vtkGPUVolumeRayCastMapper`` (EGL, offscreen) when VTK
   imports and makes a context, same camera, step and opacity unit (its 8-bit output and
   its own sampling: a speed peer, not an accuracy one);
6. prints a table of the goals (>= 60 frames/s for 512^3 at 1024^2, >= 15 for 1024^3,
   equality within 1e-5) and writes everything to ``--out`` (JSON).

Usage::

    python3 benchmarks/bench_gpu.py --prepare DIR     # here, with VTK: the datasets as .npz
    python3 benchmarks/bench_gpu.py --data DIR --out gpu.json
    NUMBA_ENABLE_CUDASIM=1 python3 benchmarks/bench_gpu.py --quick   # the script's own check, no GPU

On a machine that cannot reach a package index (the device machines here), numba-cuda
must already be there; the datasets come from ``--data`` (``.npz`` written by
``--prepare``), since reading ``.vti`` needs VTK.
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

DATASETS = {
    "engine": "structured/engine_256x256x128_uint8.vti",
    "bonsai": "structured/bonsai_256x256x256_uint8.vti",
    "hydrogen": "hdr/hydrogen_64x64x64_float32.vti",
    "m4": "hdr/m4_total_density_25x22x31_float32.vti",
}
STEP = 0.5
GOALS = {"512^3 frames/s at 1024^2": 60.0, "1024^3 frames/s at 1024^2": 15.0, "GPU vs CPU, relative": 1e-5}


def log(*args):
    print(*args, flush=True)


def load():
    return tuple(round(x, 2) for x in os.getloadavg())


# -- 1. what is needed --------------------------------------------------------------------------
def ensure_numba_cuda():
    try:
        import numba_cuda  # noqa: F401
    except ImportError:
        log("numba-cuda is missing: pip install 'numba-cuda[cu13]>=0.30'")
        subprocess.run([sys.executable, "-m", "pip", "install", "-q", "numba-cuda[cu13]>=0.30"], check=False)
    import numba_cuda  # noqa: F401  (fails here, with pip's message above, if it could not be installed)


def environment():
    import numba

    import pv_hdrvol as hv
    from pv_hdrvol.gpu import cuda_module

    cuda = cuda_module()
    info = {"date": datetime.datetime.now().isoformat(timespec="seconds"), "python": platform.python_version(),
            "numba": numba.__version__, "cpus": os.cpu_count(), "load": load(), "pv_hdrvol": hv.__version__}
    try:
        import numba_cuda

        info["numba_cuda"] = numba_cuda.__version__
    except (ImportError, AttributeError):
        pass
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        info["gpu"] = "numba-cuda simulator (no timing is meaningful)"
        return info
    dev = cuda.get_current_device()
    name = dev.name.decode() if isinstance(dev.name, bytes) else str(dev.name)
    info.update(gpu=name, compute_capability=list(dev.compute_capability),
                multiprocessors=dev.MULTIPROCESSOR_COUNT)
    try:
        out = subprocess.run(["nvidia-smi", "--query-gpu=driver_version,memory.total,clocks.max.sm",
                              "--format=csv,noheader"], capture_output=True, text=True, timeout=20)
        info["nvidia_smi"] = out.stdout.strip()
    except (OSError, subprocess.SubprocessError) as exc:
        info["nvidia_smi"] = f"not run: {exc}"
    return info


# -- data ---------------------------------------------------------------------------------------
def prepare(out_dir):
    """Read the .vti datasets with VTK and save them as .npz (values z, y, x; spacing; origin)."""
    from bench_grid import read_vti
    from vtkmodules.util.numpy_support import vtk_to_numpy

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    data = Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data"))
    for name, rel in DATASETS.items():
        image = read_vti(data / rel)
        nx, ny, nz = image.GetDimensions()
        values = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(nz, ny, nx)
        np.savez_compressed(out_dir / f"{name}.npz", values=values, spacing=np.array(image.GetSpacing()),
                            origin=np.array(image.GetOrigin()))
        log(f"{name}: {values.shape} {values.dtype} -> {out_dir / (name + '.npz')}")


def dataset(name, data_dir):
    import pv_hdrvol as hv

    path = Path(data_dir) / f"{name}.npz" if data_dir else None
    if path is not None and path.exists():
        z = np.load(path)
        return hv.volume_from_array(z["values"], spacing=tuple(z["spacing"]), origin=tuple(z["origin"]), name=name)
    import pyvista as pv

    data = Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data"))
    return hv.volume_from_dataset(pv.read(data / DATASETS[name]))


def procedural(n):
    """An n^3 float32 field with structure at every scale: a ball of nested shells,
    modulated, over a faint background (four decades)."""
    import numba

    @numba.njit(parallel=True, cache=False)
    def fill(out):
        m = out.shape[0]
        for k in numba.prange(m):
            z = (k + 0.5) / m - 0.5
            for j in range(m):
                y = (j + 0.5) / m - 0.5
                for i in range(m):
                    x = (i + 0.5) / m - 0.5
                    r = math.sqrt(x * x + y * y + z * z)
                    shells = 0.5 + 0.5 * math.cos(40.0 * r) * math.cos(7.0 * x) * math.cos(5.0 * y)
                    out[k, j, i] = 1e-4 + math.exp(-r * r / 0.04) * shells

    import pv_hdrvol as hv

    values = np.empty((n, n, n), np.float32)
    fill(values)
    return hv.volume_from_array(values, name=f"procedural {n}^3")


def transfer_functions(volume):
    import pv_hdrvol as hv

    lo, hi = (float(x) for x in volume.value_range)
    span = hi - lo
    return {
        "transparent": hv.TransferFunction.ramp(lo, hi, cmap="viridis", opacity=(0.0, 0.02)),
        "opaque": hv.TransferFunction.ramp(lo + 0.15 * span, lo + 0.8 * span, cmap="viridis", opacity=(0.0, 1.0)),
    }


# -- 2. equality --------------------------------------------------------------------------------
def equality(volumes, size):
    from pv_hdrvol.raycast.grid import GridPlan

    import pv_hdrvol as hv

    rows = []
    for name, volume in volumes.items():
        tf = transfer_functions(volume)["transparent"]
        camera = hv.Camera.fit(volume.bounds, "iso")
        for kw in (dict(precision="float32"), dict(precision="float64"), dict(precision="float32", shade=True),
                   dict(precision="float64", blending="maximum")):
            cpu = GridPlan(volume, tf, step=STEP, **kw).execute(camera, size)
            gpu = GridPlan(volume, tf, step=STEP, device="cuda", **kw).execute(camera, size)
            peak = float(np.abs(cpu.rgba).max())
            err = float(np.abs(gpu.rgba.astype(np.float64) - cpu.rgba).max() / peak) if peak > 0 else 0.0
            row = {"dataset": name, **kw, "max_rel": err, "samples_equal": gpu.metadata["samples"] ==
                   cpu.metadata["samples"], "cpu_s": cpu.metadata["render_seconds"],
                   "gpu_s": gpu.metadata["render_seconds"]}
            if cpu.value is not None:
                row["value_max_rel"] = float(np.nanmax(np.abs(gpu.value - cpu.value)) / np.nanmax(np.abs(cpu.value)))
            rows.append(row)
            log(f"  {name:9s} {kw}: max |GPU - CPU| / peak = {err:.2e}, samples equal {row['samples_equal']}")
    return rows


# -- 3. first renders ---------------------------------------------------------------------------
def first_renders(volume, size):
    """Seconds of the first frame of each variant in this process (numba-cuda compiles it),
    and of the second."""
    from pv_hdrvol.raycast.grid import GridPlan

    import pv_hdrvol as hv

    camera = hv.Camera.fit(volume.bounds, "iso")
    tf = transfer_functions(volume)["transparent"]
    rows = []
    for kw in (dict(precision="float32"), dict(precision="float64"), dict(precision="float32", shade=True),
               dict(precision="float32", blending="maximum")):
        plan = GridPlan(volume, tf, step=STEP, device="cuda", **kw)
        t = time.perf_counter()
        plan.execute(camera, size)
        first = time.perf_counter() - t
        t = time.perf_counter()
        plan.execute(camera, size)
        rows.append({**kw, "first_s": first, "second_s": time.perf_counter() - t})
        log(f"  {kw}: first {first:.2f} s, second {rows[-1]['second_s'] * 1e3:.1f} ms")
    return rows


# -- 4. steady frames -----------------------------------------------------------------------------
def orbit(volume, n):
    """``n`` cameras around the volume: the iso view turned about its view-up axis."""
    import dataclasses

    import pv_hdrvol as hv

    base = hv.Camera.fit(volume.bounds, "iso")
    fp, pos, up = (np.array(v) for v in (base.focal_point, base.position, base.view_up))
    u = up / np.linalg.norm(up)
    cams = []
    for i in range(n):
        a = 2.0 * math.pi * i / n
        r = pos - fp  # Rodrigues' rotation about u
        turned = r * math.cos(a) + np.cross(u, r) * math.sin(a) + u * (u @ r) * (1.0 - math.cos(a))
        cams.append(dataclasses.replace(base, position=tuple(fp + turned)))
    return cams


def steady(name, volume, size, frames, precisions=("float32",)):
    from pv_hdrvol.raycast.grid import GridPlan

    rows = []
    cams = orbit(volume, frames)
    for tf_name, tf in transfer_functions(volume).items():
        for prec in precisions:
            plan = GridPlan(volume, tf, step=STEP, device="cuda", precision=prec)
            plan.execute(cams[0], size)  # uploads and (first variant) compiles
            walls, kernels = [], []
            for cam in cams:
                t = time.perf_counter()
                img = plan.execute(cam, size)
                walls.append(time.perf_counter() - t)
                kernels.append(img.metadata["device"]["kernel_seconds"])
            wall, kern = statistics.median(walls), statistics.median(kernels)
            samples = img.metadata["samples"]
            rows.append({"dataset": name, "size": list(size), "tf": tf_name, "precision": prec, "frames": frames,
                         "median_frame_s": wall, "fps": 1.0 / wall, "median_kernel_s": kern,
                         "kernel_fps": 1.0 / kern, "samples_last_frame": samples,
                         "gsamples_per_s": samples / kern / 1e9, "load": load()})
            log(f"  {name:16s} {tf_name:11s} {prec}: {1 / wall:7.1f} frames/s ({wall * 1e3:.2f} ms; kernel "
                f"{kern * 1e3:.2f} ms, {samples / kern / 1e9:.2f} Gsamples/s)")
            del plan
    return rows


# -- 5. VTK's GPU mapper ---------------------------------------------------------------------------
def vtk_gpu(name, volume, size, frames):
    """Median seconds of VTK's GPU mapper frames on the same scenes, or why not."""
    try:
        from bench_grid import VTKScene
        from vtkmodules.util.numpy_support import numpy_to_vtk
        from vtkmodules.vtkCommonDataModel import vtkImageData
    except ImportError as exc:
        return {"dataset": name, "skipped": f"VTK does not import here: {exc}"}
    image = vtkImageData()
    nz, ny, nx = volume.values.shape
    image.SetDimensions(nx, ny, nz)
    image.SetSpacing(*map(float, volume.spacing))
    image.SetOrigin(*map(float, volume.origin))
    arr = numpy_to_vtk(np.ascontiguousarray(volume.values).reshape(-1), deep=False)
    arr.SetName("values")
    image.GetPointData().SetScalars(arr)
    rows = []
    cams = orbit(volume, frames)
    for tf_name, tf in transfer_functions(volume).items():
        try:
            scene = VTKScene("gpu", image, tf, cams[0], size, STEP, float(volume.spacing.min()))
            renderer = scene.gl_renderer()
            scene.render()
            times = []
            for cam in cams:
                scene.renderer.SetActiveCamera(cam.to_vtk())
                scene.renderer.ResetCameraClippingRange()
                times.append(scene.render())
            scene.close()
        except Exception as exc:  # no EGL, no context: say so, the rest of the run stands
            rows.append({"dataset": name, "tf": tf_name, "skipped": f"VTK GPU mapper failed: {exc}"})
            continue
        wall = statistics.median(times)
        rows.append({"dataset": name, "tf": tf_name, "gl_renderer": renderer, "median_frame_s": wall,
                     "fps": 1.0 / wall})
        log(f"  VTK GPU {name:12s} {tf_name:11s}: {1 / wall:7.1f} frames/s on {renderer}")
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--prepare", metavar="DIR", help="write the datasets as .npz into DIR (needs VTK) and stop")
    p.add_argument("--data", metavar="DIR", help="folder of .npz datasets from --prepare")
    p.add_argument("--out", default=None, help="JSON results")
    p.add_argument("--quick", action="store_true", help="tiny sizes: check the script (the simulator will do)")
    p.add_argument("--frames", type=int, default=20, help="frames per steady measurement (default 20)")
    p.add_argument("--skip-1024", action="store_true", help="leave out the 1024^3 volume")
    args = p.parse_args(argv)
    if args.prepare:
        prepare(args.prepare)
        return 0
    ensure_numba_cuda()
    from pv_hdrvol.gpu import DeviceUnavailableError

    try:
        env = environment()
    except DeviceUnavailableError as exc:
        log(f"no GPU to measure: {exc}")
        return 2
    log("environment:", json.dumps(env))
    quick = args.quick
    eq_size = (24, 24) if quick else (512, 512)
    size = (32, 32) if quick else (1024, 1024)
    frames = 2 if quick else args.frames
    results = {"environment": env, "step_voxels": STEP, "goals": GOALS}

    names = ["hydrogen", "m4"] if quick else list(DATASETS)
    volumes = {n: dataset(n, args.data) for n in names}
    if quick:
        import pv_hdrvol as hv

        volumes = {n: hv.volume_from_array(v.values[::4, ::4, ::4] if v.values.shape[0] > 32 else v.values,
                                           name=n) for n, v in volumes.items()}
    log(f"\n2. GPU against CPU at {eq_size[0]}^2")
    results["equality"] = equality(volumes, eq_size)

    small = procedural(16 if quick else 512)
    log(f"\n3. first renders ({size[0]}^2, {small.name})")
    results["first_renders"] = first_renders(small, size)

    log(f"\n4. steady frames at {size[0]}^2, orbit of {frames} views  (load {load()})")
    steady_rows = []
    vtk_rows = []
    scenes = [("engine", lambda: volumes.get("engine")), ("bonsai", lambda: volumes.get("bonsai")),
              ("procedural 512^3", lambda: small)]
    if not args.skip_1024:
        scenes.append(("procedural 1024^3", lambda: procedural(24 if quick else 1024)))
    for name, make in scenes:
        volume = make()
        if volume is None:
            continue
        precisions = ("float32", "float64") if name == "procedural 512^3" else ("float32",)
        steady_rows += steady(name, volume, size, frames, precisions)
        vtk_rows += vtk_gpu(name, volume, size, frames) if not quick else []
        del volume
    results["steady"] = steady_rows
    log(f"\n5. VTK's GPU mapper  (load {load()})")
    results["vtk_gpu"] = vtk_rows

    # 6. the goals
    def fps_of(dataset):
        rows = [r for r in steady_rows if r["dataset"] == dataset and r["precision"] == "float32"]
        return min(r["fps"] for r in rows) if rows else float("nan")

    worst_eq = max(r["max_rel"] for r in results["equality"])
    measured = {"512^3 frames/s at 1024^2": fps_of("procedural 512^3"),
                "1024^3 frames/s at 1024^2": fps_of("procedural 1024^3"), "GPU vs CPU, relative": worst_eq}
    results["measured"] = measured
    log("\n| goal | target | measured | met |\n| --- | --- | --- | --- |")
    for key, target in GOALS.items():
        value = measured[key]
        met = value <= target if "relative" in key else value >= target
        log(f"| {key} | {target:g} | {value:.3g} | {'yes' if met else 'no'} |")
    if args.out:
        with open(args.out, "w") as f:
            json.dump(results, f, indent=1)
        log(f"results: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
