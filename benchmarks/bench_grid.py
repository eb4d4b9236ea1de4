"""Grid ray caster against VTK's CPU and GPU volume mappers, same scene, same sampling.

Renders the engine (256x256x128) and bonsai (256^3) CT volumes at 512^2 and 1024^2 with
a transparent transfer function (no ray terminates early) and a mostly-opaque one, with

- pv_hdrvol in float32 and float64,
- ``vtkFixedPointVolumeRayCastMapper`` (VTK's multithreaded CPU ray caster), and
- ``vtkGPUVolumeRayCastMapper`` (on this machine: Mesa llvmpipe, i.e. software GL),

all with the same camera (``Camera.to_vtk()``), the same transfer-function control
points, the same opacity unit distance and the same sampling distance (``step`` voxels,
no automatic adjustment, no jittering). Frames are timed interleaved (one frame of each
renderer per round) so that load from other processes hits all of them alike; the
numbers to compare are the ratios within a row.

Also measured: JIT compile time (fresh process, empty ``NUMBA_CACHE_DIR``), start-up
with a warm cache (fresh process: import + read + first 512^2 frame, wall clock), peak
numpy memory (tracemalloc) and ``ru_maxrss`` of the subprocesses, and how well the
pictures agree (Pearson correlation of luminance against the fixed-point mapper).

Usage::

    python3 benchmarks/bench_grid.py                 # full run, a few minutes
    python3 benchmarks/bench_grid.py --quick         # engine at 256^2 only
    python3 benchmarks/bench_grid.py --out results.json --images imgs/

Offscreen VTK on a machine without X: the script sets
``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` when ``DISPLAY`` is unset, before VTK
is imported; with the pip ``vtk`` wheel and Mesa's EGL (Debian: ``libegl1
libegl-mesa0 libgl1-mesa-dri``) that gives a surfaceless llvmpipe context. Without the
variable VTK first tries X, warns "bad X server connection", then falls back to EGL.

The data directory is ``../shared/data`` relative to the repository root, or
``$PV_HDRVOL_DATA``.
"""
from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

if not os.environ.get("DISPLAY"):
    # must precede the first import of vtkRenderingOpenGL2
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

DATASETS = {
    "engine": "structured/engine_256x256x128_uint8.vti",
    "bonsai": "structured/bonsai_256x256x256_uint8.vti",
}
STEP = 0.5  # voxels, for every renderer
STARTUP_SIZE = 512
REC709 = (0.2126, 0.7152, 0.0722)


def data_dir():
    """``$PV_HDRVOL_DATA`` or ``<repo>/../shared/data``."""
    return Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data"))


def transfer_functions(hv=None):
    """The two transfer functions, keyed by name (data are uint8, 0..255), made with the
    package ``hv`` (default: ``pv_hdrvol``; ``ab_grid.py`` passes each revision's).

    ``transparent``: opacity ramps from 0 to 0.02 per voxel over the whole range, so
    only value 0 is empty and no ray gets anywhere near the termination threshold.
    ``opaque``: opacity ramps from 0 at 40 to 1 per voxel at 200; rays stop a few
    voxels into the material.
    """
    if hv is None:
        import pv_hdrvol as hv

    return {
        "transparent": hv.TransferFunction.ramp(0.0, 255.0, cmap="gray", opacity=(0.0, 0.02)),
        "opaque": hv.TransferFunction.ramp(40.0, 200.0, cmap="gray", opacity=(0.0, 1.0)),
    }


def read_vti(path):
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    reader = vtkXMLImageDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    return reader.GetOutput()


def load():
    return tuple(round(x, 2) for x in os.getloadavg())


# -- VTK side ---------------------------------------------------------------------------------

class VTKWindow:
    """One offscreen render window showing ``mapper`` with our transfer function's control
    points, opacity unit distance and camera (any VTK volume mapper)."""

    def __init__(self, mapper, tf, camera, size, unit_distance, global_alpha=1.0, shading=None):
        from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
        from vtkmodules.vtkRenderingCore import (
            vtkColorTransferFunction, vtkRenderer, vtkRenderWindow, vtkVolume, vtkVolumeProperty,
        )

        ctf = vtkColorTransferFunction()
        for v, c in zip(tf.values, tf.colors):
            ctf.AddRGBPoint(float(v), *map(float, c))
        otf = vtkPiecewiseFunction()
        for v, a in zip(tf.values, tf.opacities):
            otf.AddPoint(float(v), float(a) * global_alpha)
        prop = vtkVolumeProperty()
        prop.SetColor(ctf)
        prop.SetScalarOpacity(otf)
        prop.SetInterpolationTypeToLinear()
        if shading is None:
            prop.ShadeOff()
        else:  # (ambient, diffuse, specular, specular power), lit by the renderer's headlight
            prop.ShadeOn()
            ambient, diffuse, specular, power = shading
            prop.SetAmbient(ambient)
            prop.SetDiffuse(diffuse)
            prop.SetSpecular(specular)
            prop.SetSpecularPower(power)
        # ours: alpha is reached over opacity_unit_distance
        prop.SetScalarOpacityUnitDistance(unit_distance)

        volume = vtkVolume()
        volume.SetMapper(mapper)
        volume.SetProperty(prop)
        ren = vtkRenderer()
        ren.SetBackground(0.0, 0.0, 0.0)
        ren.AddVolume(volume)
        ren.SetActiveCamera(camera.to_vtk())
        ren.ResetCameraClippingRange()  # near/far must enclose the volume
        rw = vtkRenderWindow()
        rw.SetOffScreenRendering(True)
        rw.SetMultiSamples(0)
        rw.SetSize(*size)
        rw.AddRenderer(ren)
        self.mapper, self.renderer, self.window = mapper, ren, rw
        self.size = size

    def render(self):
        """Seconds of one ``Render()``, waiting for GL to finish."""
        t = time.perf_counter()
        self.window.Render()
        self.window.WaitForCompletion()
        return time.perf_counter() - t

    def luminance(self):
        """Rec. 709 luminance of the window in [0, 1], (rows, cols), row 0 at the top."""
        import numpy as np
        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkRenderingCore import vtkWindowToImageFilter

        grab = vtkWindowToImageFilter()
        grab.SetInput(self.window)
        grab.SetInputBufferTypeToRGB()
        grab.ReadFrontBufferOff()
        grab.Update()
        w, h = self.size
        rgb = vtk_to_numpy(grab.GetOutput().GetPointData().GetScalars()).reshape(h, w, 3)[::-1]
        return (rgb.astype(np.float64) / 255.0) @ np.array(REC709), rgb

    def gl_renderer(self):
        info = self.window.ReportCapabilities()
        for line in info.splitlines():
            if "renderer string" in line:
                return line.split(":", 1)[1].strip()
        return "?"

    def close(self):
        self.window.Finalize()


class VTKScene(VTKWindow):
    """``VTKWindow`` with VTK's fixed-point (``"fixed"``) or GPU (``"gpu"``) image mapper,
    sampling as ours does (``step`` voxels, no automatic adjustment, no jittering);
    ``shading``: ``(ambient, diffuse, specular, specular power)`` to light it."""

    def __init__(self, kind, image, tf, camera, size, step, unit_distance, shading=None):
        import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (object factories)
        import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401
        from vtkmodules.vtkRenderingVolume import vtkFixedPointVolumeRayCastMapper, vtkGPUVolumeRayCastMapper

        spacing = min(image.GetSpacing())
        sample_distance = step * spacing
        if kind == "fixed":
            mapper = vtkFixedPointVolumeRayCastMapper()
            mapper.SetInteractiveSampleDistance(sample_distance)
        elif kind == "gpu":
            mapper = vtkGPUVolumeRayCastMapper()
            mapper.SetUseJittering(False)
        else:
            raise ValueError(f"kind must be 'fixed' or 'gpu'; got {kind!r}")
        mapper.SetInputData(image)
        mapper.SetBlendModeToComposite()
        mapper.SetAutoAdjustSampleDistances(False)  # also switches off interactive adjustment
        mapper.SetLockSampleDistanceToInputSpacing(False)
        mapper.SetSampleDistance(sample_distance)
        mapper.SetImageSampleDistance(1.0)
        super().__init__(mapper, tf, camera, size, unit_distance, shading=shading)
        self.kind = kind
        self.sample_distance = sample_distance


# -- agreement -------------------------------------------------------------------------------

def our_luminance(img):
    """Luminance of our premultiplied image over black, clipped to [0, 1] as a window would."""
    import numpy as np

    rgb = np.clip(np.asarray(img.rgba[..., :3], dtype=np.float64), 0.0, 1.0)
    return rgb @ np.array(REC709)


def pearson(a, b):
    a = a.ravel() - a.mean()
    b = b.ravel() - b.mean()
    den = math.sqrt(float(a @ a) * float(b @ b))
    return float(a @ b) / den if den > 0 else float("nan")


def agreement(a, b):
    """Pearson r of two luminance images, and their mean absolute difference in 8-bit levels."""
    import numpy as np

    return {"pearson": pearson(a, b), "mean_abs_diff_levels": float(np.abs(a - b).mean() * 255.0)}


# -- one case ------------------------------------------------------------------------------------

_WARM = set()  # precisions already rendered once in this process


def run_case(name, image, volume, tf_name, tf, size, repeat, images_dir=None):
    import tracemalloc

    import numpy as np

    import pv_hdrvol as hv

    camera = hv.Camera.fit(volume, "iso")
    unit = float(volume.spacing.min())  # our default opacity_unit_distance
    case = {"dataset": name, "size": list(size), "tf": tf_name, "step_voxels": STEP, "load_before": load()}
    print(f"\n{name} {size[0]}x{size[1]} {tf_name}  (load {case['load_before']})", flush=True)

    ours = {p: (lambda p=p: hv.render(volume, tf, camera, size, step=STEP, precision=p)) for p in ("float32", "float64")}
    scenes = {k: VTKScene(k, image, tf, camera, size, STEP, unit) for k in ("fixed", "gpu")}
    case["vtk_sample_distance"] = scenes["fixed"].sample_distance
    case["opacity_unit_distance"] = unit

    # warm-up: one untimed frame under tracemalloc (numpy reports its allocations to
    # it) that also gives the pictures compared for agreement
    imgs, mem = {}, {}
    for p, fn in ours.items():
        if p not in _WARM:  # first frame in this process: JIT compile or cache load
            fn()
            _WARM.add(p)
        tracemalloc.start()
        imgs[p] = fn()
        mem[p] = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
    first_vtk = {k: s.render() for k, s in scenes.items()}

    times = {k: [] for k in ("float32", "float64", "fixed", "gpu")}
    kernel = {p: [] for p in ours}
    samples = {p: imgs[p].metadata["samples"] for p in ours}
    for r in range(repeat):
        for p, fn in ours.items():
            t = time.perf_counter()
            out = fn()
            times[p].append(time.perf_counter() - t)
            kernel[p].append(out.metadata["render_seconds"])
        for k, s in scenes.items():
            times[k].append(s.render())
        print("  round", r + 1, {k: f"{v[-1] * 1e3:.0f} ms" for k, v in times.items()}, flush=True)

    lum = {p: our_luminance(imgs[p]) for p in ours}
    vtk_lum, vtk_rgb = {}, {}
    for k, s in scenes.items():
        vtk_lum[k], vtk_rgb[k] = s.luminance()
    case["agreement"] = {
        "float32_vs_fixed": agreement(lum["float32"], vtk_lum["fixed"]),
        "float64_vs_fixed": agreement(lum["float64"], vtk_lum["fixed"]),
        "float32_vs_gpu": agreement(lum["float32"], vtk_lum["gpu"]),
        "gpu_vs_fixed": agreement(vtk_lum["gpu"], vtk_lum["fixed"]),
    }
    case["mean_luminance"] = {"float32": float(lum["float32"].mean()), "fixed": float(vtk_lum["fixed"].mean()),
                              "gpu": float(vtk_lum["gpu"].mean())}
    case["max_abs_float32_vs_float64"] = float(np.abs(imgs["float32"].rgba - imgs["float64"].rgba).max())
    if images_dir is not None:
        _save_images(images_dir, f"{name}_{size[0]}_{tf_name}", imgs["float32"], vtk_rgb)

    case["renderers"] = {}
    for k, ts in times.items():
        med = statistics.median(ts)
        entry = {"ms_median": med * 1e3, "ms_min": min(ts) * 1e3, "ms_all": [t * 1e3 for t in ts]}
        if k in ours:
            entry["samples"] = samples[k]
            entry["samples_per_s"] = samples[k] / med
            entry["kernel_ms_median"] = statistics.median(kernel[k]) * 1e3
            entry["tracemalloc_peak_mib"] = mem[k]
        else:
            entry["first_render_ms"] = first_vtk[k] * 1e3
        case["renderers"][k] = entry
    med = {k: case["renderers"][k]["ms_median"] for k in times}
    case["time_ratio"] = {
        "float32/fixed": med["float32"] / med["fixed"],
        "float64/fixed": med["float64"] / med["fixed"],
        "float32/gpu": med["float32"] / med["gpu"],
    }
    case["load_after"] = load()
    case["gl_renderer"] = scenes["gpu"].gl_renderer()
    for s in scenes.values():
        s.close()
    a = case["agreement"]["float32_vs_fixed"]["pearson"]
    print(f"  f32/FP {case['time_ratio']['float32/fixed']:.2f}  f64/FP {case['time_ratio']['float64/fixed']:.2f}"
          f"  r(f32,FP) {a:.4f}", flush=True)
    return case


def _save_images(directory, stem, ours, vtk_rgb):
    import numpy as np
    from PIL import Image

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    rgb = np.clip(np.asarray(ours.rgba[..., :3], dtype=np.float64), 0, 1)
    Image.fromarray(np.round(rgb * 255).astype(np.uint8)).save(d / f"{stem}_ours.png")
    for k, v in vtk_rgb.items():
        Image.fromarray(np.ascontiguousarray(v)).save(d / f"{stem}_vtk_{k}.png")


# -- start-up in fresh processes ---------------------------------------------------------------

class _VTKCameraSpec:
    """Stands in for :class:`pv_hdrvol.Camera` in a process that imports only VTK."""

    def __init__(self, spec):
        self.spec = spec

    def to_vtk(self):
        from vtkmodules.vtkRenderingCore import vtkCamera

        c = vtkCamera()
        c.SetPosition(self.spec["position"])
        c.SetFocalPoint(self.spec["focal_point"])
        c.SetViewUp(self.spec["view_up"])
        c.SetViewAngle(self.spec["view_angle"])
        return c


def _child(kind, path, size, spec_json):
    """Body of a fresh process: import, read, first frame; prints one JSON line."""
    t0 = time.perf_counter()
    spec = json.loads(spec_json)
    out = {}
    if kind == "ours":
        import numpy  # noqa: F401
        import pyvista

        import pv_hdrvol as hv

        t1 = time.perf_counter()
        data = pyvista.read(path)
        t2 = time.perf_counter()
        tf = transfer_functions()["transparent"]
        img = hv.render(data, tf, hv.Camera.fit(data, "iso"), size, step=STEP, precision="float32")
        t3 = time.perf_counter()
        out["since_spawn_s"] = time.time() - spec["spawn_time"]
        out["render_seconds"] = img.metadata["render_seconds"]
        hv.render(data, tf, hv.Camera.fit(data, "iso"), size, step=STEP, precision="float32")
        out["second_frame_s"] = time.perf_counter() - t3
    else:
        # VTK alone: camera and transfer function come from the parent as plain numbers
        from types import SimpleNamespace

        import vtkmodules.vtkIOXML  # noqa: F401
        import vtkmodules.vtkRenderingCore  # noqa: F401
        import vtkmodules.vtkRenderingOpenGL2  # noqa: F401
        import vtkmodules.vtkRenderingVolume  # noqa: F401
        import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401

        t1 = time.perf_counter()
        image = read_vti(path)
        t2 = time.perf_counter()
        tf = SimpleNamespace(**spec["tf"])
        scene = VTKScene("fixed", image, tf, _VTKCameraSpec(spec["camera"]), (size, size), STEP, spec["unit"])
        scene.render()
        t3 = time.perf_counter()
        out["since_spawn_s"] = time.time() - spec["spawn_time"]
        out["second_frame_s"] = scene.render()
    # peak RSS is taken after the second frame: that frame allocates nothing the first did not
    out.update(import_s=t1 - t0, read_s=t2 - t1, first_frame_s=t3 - t2, in_process_s=t3 - t0,
               maxrss_mib=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, peak_rss_mib=_vm_hwm_mib())
    print("RESULT " + json.dumps(out), flush=True)


def _vm_hwm_mib():
    """Peak resident set of this process image, from /proc (None where there is none).

    Linux keeps ``ru_maxrss`` across ``execve``: a child started by a big parent reports
    at least the parent's peak. ``VmHWM`` belongs to the new image only.
    """
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return None


def _spawn(kind, path, size, env, spec=None):
    spec = dict(spec or {}, spawn_time=time.time())  # wall clock: the child measures its first frame from here
    spec = json.dumps(spec)
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--_child", kind, str(path), str(size), spec],
                          env=env, capture_output=True, text=True, cwd=str(REPO))
    wall = time.perf_counter() - t
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    if proc.returncode != 0 or not lines:
        return {"error": (proc.stderr or proc.stdout)[-2000:], "wall_s": wall}
    res = json.loads(lines[-1][len("RESULT "):])
    res["wall_s"] = wall
    return res


def startup(path, size=STARTUP_SIZE):
    """Cold (empty numba cache) and warm start of ours, and the fixed-point mapper's start."""
    results = {"size": size, "dataset": Path(path).name, "load_before": load()}
    with tempfile.TemporaryDirectory(prefix="numba_cache_") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=os.pathsep.join(
            [str(REPO)] + ([os.environ["PYTHONPATH"]] if os.environ.get("PYTHONPATH") else [])))
        print("\nstart-up: cold numba cache ...", flush=True)
        results["ours_cold_cache"] = _spawn("ours", path, size, env)
        before = _cache_files(cache)
        print("start-up: warm numba cache ...", flush=True)
        results["ours_warm_cache"] = _spawn("ours", path, size, env)
        after = _cache_files(cache)
        results["ours_warm_cache"]["cache_files_written"] = sorted(
            str(Path(p).name) for p, m in after.items() if before.get(p) != m)
        results["cache_files"] = len(after)
    print("start-up: VTK fixed-point ...", flush=True)
    import pv_hdrvol as hv

    tf = transfer_functions()["transparent"]
    image = read_vti(path)
    cam = hv.Camera.fit(image.GetBounds(), "iso")
    spec = {"tf": {"values": tf.values.tolist(), "colors": tf.colors.tolist(), "opacities": tf.opacities.tolist()},
            "camera": {"position": cam.position, "focal_point": cam.focal_point, "view_up": cam.view_up,
                       "view_angle": cam.view_angle},
            "unit": min(image.GetSpacing())}
    results["vtk_fixed"] = _spawn("vtk", path, size, dict(os.environ), spec)
    results["load_after"] = load()
    return results


def _cache_files(directory):
    return {str(p): p.stat().st_mtime_ns for p in Path(directory).rglob("*") if p.is_file()}


# -- report ------------------------------------------------------------------------------------

def markdown(results):
    lines = []
    meta = results["meta"]
    lines.append(f"Machine: {meta['cpu_count']} cores, {meta['platform']}; numba threads {meta['numba_threads']}; "
                 f"GPU mapper on {meta.get('gl_renderer', '?')}. {meta['date']}.")
    src = meta.get("source", {})
    if src:
        mod = f", uncommitted changes in {', '.join(src['modified'])}" if src.get("modified") else ""
        lines.append(f"Source: commit {src.get('commit', '?')}{mod}; _kernels.py sha1 {src['kernel_sha1']}.")
    lines.append(f"Load average (1, 5, 15 min) at start {meta['load_start']}, at end {meta['load_end']}. "
                 f"step = {STEP} voxel for all renderers; median of {meta['repeat']} frames after a warm-up, "
                 "renderers interleaved.")
    lines.append("")
    lines.append("| data | size | TF | ours f32 ms | ours f64 ms | VTK FP ms | VTK GPU ms | f32/FP | f64/FP | f32/GPU "
                 "| f32 Msamples/s | r(f32,FP) | r(GPU,FP) | load |")
    lines.append("|---|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    for c in results["cases"]:
        if "error" in c:
            lines.append(f"| {c['dataset']} | {c['size'][0]}² | {c['tf']} | error: {c['error'][:60]} |")
            continue
        r = c["renderers"]
        q = c["time_ratio"]
        a = c["agreement"]
        lines.append(
            f"| {c['dataset']} | {c['size'][0]}² | {c['tf']} | {r['float32']['ms_median']:.0f} | "
            f"{r['float64']['ms_median']:.0f} | {r['fixed']['ms_median']:.0f} | {r['gpu']['ms_median']:.0f} | "
            f"{q['float32/fixed']:.2f} | {q['float64/fixed']:.2f} | {q['float32/gpu']:.2f} | "
            f"{r['float32']['samples_per_s'] / 1e6:.1f} | {a['float32_vs_fixed']['pearson']:.3f} | "
            f"{a['gpu_vs_fixed']['pearson']:.3f} | {c['load_before'][0]:.1f} |")
    lines.append("")
    lines.append("Ratios are frame-time ratios (< 1: ours faster; the targets are f32/FP <= 0.5 and "
                 "f64/FP <= 1). r: Pearson correlation of luminance over pixels with the fixed-point image.")
    lines.append("")
    lines.append("| data | size | TF | f32/FP by min | f64/FP by min | tracemalloc peak f32 MiB | f64 MiB "
                 "| mean abs diff f32 vs FP (8-bit levels) | max abs f32-f64 |")
    lines.append("|---|---|---|--:|--:|--:|--:|--:|--:|")
    for c in results["cases"]:
        if "error" in c:
            continue
        r = c["renderers"]
        lines.append(f"| {c['dataset']} | {c['size'][0]}² | {c['tf']} "
                     f"| {r['float32']['ms_min'] / r['fixed']['ms_min']:.2f} "
                     f"| {r['float64']['ms_min'] / r['fixed']['ms_min']:.2f} "
                     f"| {r['float32']['tracemalloc_peak_mib']:.1f} "
                     f"| {r['float64']['tracemalloc_peak_mib']:.1f} "
                     f"| {c['agreement']['float32_vs_fixed']['mean_abs_diff_levels']:.2f} "
                     f"| {c['max_abs_float32_vs_float64']:.1e} |")
    lines.append("")
    lines.append("By min: the same ratios from each renderer's fastest frame, a second estimator under load.")
    ok = [c for c in results["cases"] if "error" not in c]
    if ok:
        f32 = sum(c["time_ratio"]["float32/fixed"] <= 0.5 for c in ok)
        f64 = sum(c["time_ratio"]["float64/fixed"] <= 1.0 for c in ok)
        lines.append("")
        lines.append(f"Targets: float32 at least 2x faster than the fixed-point mapper in {f32} of {len(ok)} cases; "
                     f"float64 no slower in {f64} of {len(ok)}.")
    s = results.get("startup")
    if s:
        lines.append("")
        lines.append(f"Start-up, fresh process, {s['dataset']} transparent, {s['size']}² "
                     f"(load {s['load_before'][0]:.1f}):")
        lines.append("")
        lines.append("| process | import s | read s | first frame s | second frame s | start to first frame s "
                     "| process wall s | peak RSS MiB |")
        lines.append("|---|--:|--:|--:|--:|--:|--:|--:|")
        for key, label in (("ours_cold_cache", "ours, empty numba cache (JIT)"),
                           ("ours_warm_cache", "ours, warm numba cache"),
                           ("vtk_fixed", "VTK fixed-point")):
            e = s[key]
            if "error" in e:
                lines.append(f"| {label} | error | | | | | {e['wall_s']:.2f} | |")
                continue
            rss = e["peak_rss_mib"] if e.get("peak_rss_mib") is not None else e["maxrss_mib"]
            lines.append(f"| {label} | {e['import_s']:.2f} | {e['read_s']:.2f} | {e['first_frame_s']:.2f} | "
                         f"{e['second_frame_s']:.2f} | {e['since_spawn_s']:.2f} | {e['wall_s']:.2f} | {rss:.0f} |")
        lines.append("")
        lines.append("First frame: `hv.render` (or the first `Render()`) including JIT compilation or cache "
                     "loading; first minus second frame is that one-off cost. Start to first frame: wall clock from "
                     "the parent's spawn to the end of the first frame (interpreter start, imports, read, frame). "
                     "Process wall: spawn to exit, including the second frame. Peak RSS: the child's VmHWM.")
        w = s["ours_warm_cache"]
        if "error" not in w:
            lines.append(f"Target (warm cache, first frame within 3 s of process start): {w['since_spawn_s']:.2f} s "
                         f"({'met' if w['since_spawn_s'] < 3 else 'not met'}), of which {w['second_frame_s']:.2f} s "
                         f"is what any later frame takes; one-off start-up cost "
                         f"{w['since_spawn_s'] - w['second_frame_s']:.2f} s.")
        if "cache_files_written" in w and w["cache_files_written"]:
            lines.append("")
            lines.append(f"Note: the warm run wrote {len(w['cache_files_written'])} cache files (a cache miss: "
                         "was the kernel source edited between the two runs?).")
    return "\n".join(lines)


def _source_state():
    """Git commit and a hash of the kernel source, to tell which kernel was measured."""
    import hashlib

    state = {"kernel_sha1": hashlib.sha1((REPO / "pv_hdrvol/raycast/_kernels.py").read_bytes()).hexdigest()[:12]}
    try:
        state["commit"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                                         text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "pv_hdrvol"], cwd=REPO, capture_output=True,
                               text=True, check=True).stdout.split("\n")
        state["modified"] = sorted(ln[3:] for ln in dirty if ln.strip())
    except (OSError, subprocess.CalledProcessError):
        pass
    return state


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="engine at 256^2 only, to check the script works")
    parser.add_argument("--data", nargs="+", choices=sorted(DATASETS), help="datasets to run (default: all)")
    parser.add_argument("--sizes", nargs="+", type=int, help="image sizes in pixels (default: 512 1024)")
    parser.add_argument("--repeat", type=int, default=3, help="timed frames per renderer after a warm-up (>= 3)")
    parser.add_argument("--out", type=Path, help="write the results as JSON here")
    parser.add_argument("--images", type=Path, help="save 8-bit PNGs of every case's pictures here")
    parser.add_argument("--skip-startup", action="store_true", help="skip the fresh-process start-up measurements")
    parser.add_argument("--report", type=Path, metavar="JSON", help="print the tables of an earlier --out file")
    parser.add_argument("--_child", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args._child:
        kind, path, size, spec = args._child
        return _child(kind, path, int(size), spec)
    if args.report:
        print(markdown(json.loads(args.report.read_text())))
        return 0
    if args.repeat < 3:
        parser.error(f"--repeat must be >= 3; got {args.repeat}")

    import numba
    import numpy as np
    import vtk

    import pv_hdrvol as hv

    ddir = data_dir()
    names = ["engine"] if args.quick else (args.data or ["engine", "bonsai"])
    sizes = [(256, 256)] if args.quick else [(n, n) for n in (args.sizes or [512, 1024])]
    for n in names:
        if not (ddir / DATASETS[n]).exists():
            parser.error(f"missing {ddir / DATASETS[n]} (set PV_HDRVOL_DATA to the data directory)")
    results = {"meta": {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "command": " ".join([Path(sys.executable).name] + sys.argv),
        "platform": platform.platform(), "cpu_count": os.cpu_count(), "numba_threads": numba.get_num_threads(),
        "versions": {"python": platform.python_version(), "numpy": np.__version__, "numba": numba.__version__,
                     "vtk": vtk.vtkVersion.GetVTKVersion(), "pv_hdrvol": hv.__version__},
        "vtk_default_opengl_window": os.environ.get("VTK_DEFAULT_OPENGL_WINDOW"),
        "repeat": args.repeat, "step_voxels": STEP, "load_start": load(), "source": _source_state(),
    }, "cases": []}
    tfs = transfer_functions()
    for n in names:
        path = ddir / DATASETS[n]
        image = read_vti(path)
        volume = hv.volume_from_dataset(image)
        for size in sizes:
            for tf_name, tf in tfs.items():
                try:
                    case = run_case(n, image, volume, tf_name, tf, size, args.repeat, args.images)
                except Exception as exc:  # keep going: the kernel may be mid-edit
                    case = {"dataset": n, "size": list(size), "tf": tf_name, "error": f"{type(exc).__name__}: {exc}"}
                    print("  ERROR", case["error"], flush=True)
                results["cases"].append(case)
                if "gl_renderer" in case:
                    results["meta"]["gl_renderer"] = case["gl_renderer"]
    if not args.skip_startup:
        results["startup"] = startup(ddir / DATASETS["engine"])
    results["meta"]["load_end"] = load()
    table = markdown(results)
    results["markdown"] = table
    print("\n" + table)
    if args.out:
        args.out.write_text(json.dumps(results, indent=1))
        print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
