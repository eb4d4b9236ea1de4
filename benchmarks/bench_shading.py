"""What shading costs: shaded / unshaded time of ours and of VTK's mappers, same scenes.

Renders engine and bonsai (bench_grid.py's transparent and opaque transfer functions,
iso camera, step 0.5 voxel) at 512^2 with shading off and on (Blinn-Phong, ambient 0.1,
diffuse 0.7, specular 0.2, power 10, one headlight: VTK's defaults) with

- pv_hdrvol in float32, the gradient by central differences at each sample
  (``shade_gradient="sampled"``, the default) and interpolated from the grid points'
  (``"interpolated"``),
- ``vtkFixedPointVolumeRayCastMapper`` (VTK's CPU ray caster; it shades with
  precomputed, quantised gradient normals) and
- ``vtkGPUVolumeRayCastMapper`` (Mesa llvmpipe here: software GL),

frames interleaved (one of each renderer per round) so load hits all alike. The
numbers to compare are the ratios shaded/unshaded within one renderer, and across
renderers within a row. The machine's load average is printed with each row.

    python3 benchmarks/bench_shading.py                    # engine and bonsai, 512^2
    python3 benchmarks/bench_shading.py --data engine --size 256 --frames 3
    python3 benchmarks/bench_shading.py --breakdown        # where a shaded sample's time goes

``--breakdown`` renders engine at 256^2 (transparent) on one thread with ours only:
the plain loop unshaded; the extended loop unshaded (gradient-magnitude opacity) and
shaded (one composite label: how every shaded render ran before issue 32); and the
plain loop shaded with lighting that changes nothing, without specular, the default,
a non-integral specular power and the interpolated gradient; it prints
thread-nanoseconds per sample.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_grid import DATASETS, STEP, VTKScene, data_dir, load, read_vti, transfer_functions  # noqa: E402

SHADING = (0.1, 0.7, 0.2, 10.0)  # ambient, diffuse, specular, specular power


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", nargs="+", default=list(DATASETS), choices=list(DATASETS))
    ap.add_argument("--tfs", nargs="+", default=["transparent", "opaque"])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--peers", nargs="*", default=["fixed", "gpu"], choices=["fixed", "gpu"])
    ap.add_argument("--breakdown", action="store_true", help="where a shaded sample's time goes (ours only)")
    args = ap.parse_args(argv)
    if args.breakdown:
        return breakdown(args.frames)

    import pv_hdrvol as hv

    ka, kd, ks, power = SHADING
    lit = dict(shade=True, ambient=ka, diffuse=kd, specular=ks, specular_power=power)
    size = (args.size, args.size)
    print("| data | TF | renderer | unshaded (s) | shaded (s) | shaded / unshaded | load |")
    print("|---|---|---|--:|--:|--:|---|")
    for name in args.data:
        image = read_vti(data_dir() / DATASETS[name])
        volume = hv.volume_from_dataset(image)
        camera = hv.Camera.fit(volume.bounds, "iso")
        unit = float(min(image.GetSpacing()))
        for tf_name in args.tfs:
            tf = transfer_functions()[tf_name]

            def ours(**kw):
                def frame():
                    t = time.perf_counter()
                    hv.render(volume, tf, camera, size, step=STEP, progress_bar=False, **kw)
                    return time.perf_counter() - t
                return frame

            runs = {
                ("ours float32", False): ours(),
                ("ours float32, sampled gradient", True): ours(**lit),
                ("ours float32, interpolated gradient", True): ours(**lit, shade_gradient="interpolated"),
            }
            scenes = []
            for kind in args.peers:
                for shaded in (False, True):
                    scene = VTKScene(kind, image, tf, camera, size, STEP, unit, shading=SHADING if shaded else None)
                    scenes.append(scene)
                    runs[(f"VTK {kind}", shaded)] = scene.render
            for frame in runs.values():
                frame()  # compile, build caches, first GL frame
            times = {key: [] for key in runs}
            load_before = load()
            for _ in range(args.frames):
                for key, frame in runs.items():
                    times[key].append(frame())
            load_after = load()
            med = {key: statistics.median(v) for key, v in times.items()}
            base = med[("ours float32", False)]
            rows = [("ours float32, sampled gradient", base), ("ours float32, interpolated gradient", base)]
            rows += [(f"VTK {kind}", med[(f"VTK {kind}", False)]) for kind in args.peers]
            for label, unshaded in rows:
                shaded = med[(label, True)]
                print(f"| {name} | {tf_name} | {label} | {unshaded:.3f} | {shaded:.3f} | {shaded / unshaded:.2f} | "
                      f"{load_before[0]}-{load_after[0]} |", flush=True)
            for scene in scenes:
                scene.close()


def breakdown(frames, size=(256, 256)):
    import numba

    import pv_hdrvol as hv

    numba.set_num_threads(1)
    volume = hv.volume_from_dataset(read_vti(data_dir() / DATASETS["engine"]))
    camera = hv.Camera.fit(volume.bounds, "iso")
    tf = transfer_functions()["transparent"]
    import numpy as np

    one_label = dict(labels=np.zeros(volume.values.shape, np.int32), label_styles={0: "composite"})
    variants = {
        "plain loop, unshaded": {},
        "extended loop, unshaded (gradient-magnitude opacity)": dict(gradient_opacity=(0.0, 1e-9)),
        "extended loop, shaded (one composite label: the path of every shaded render before)":
            dict(shade=True, **one_label),
        "plain loop, shaded, lighting that changes nothing": dict(shade=True, ambient=1.0, diffuse=0.0,
                                                                  specular=0.0),
        "plain loop, shaded, no specular": dict(shade=True, specular=0.0),
        "plain loop, shaded, default": dict(shade=True),
        "plain loop, shaded, non-integral specular power (pow)": dict(shade=True, specular_power=10.5),
        "plain loop, shaded, interpolated gradient": dict(shade=True, shade_gradient="interpolated"),
    }
    for kw in variants.values():
        hv.render(volume, tf, camera, size, step=STEP, progress_bar=False, **kw)
    times = {key: [] for key in variants}
    load_before = load()
    for _ in range(frames):
        for key, kw in variants.items():
            t = time.perf_counter()
            img = hv.render(volume, tf, camera, size, step=STEP, progress_bar=False, **kw)
            times[key].append(time.perf_counter() - t)
    samples = img.metadata["samples"]
    print(f"engine {size[0]}x{size[1]}, transparent, 1 thread, {samples} samples, load {load_before} -> {load()}")
    print("| variant | seconds | thread-ns per sample |\n|---|--:|--:|")
    for key, values in times.items():
        med = statistics.median(values)
        print(f"| {key} | {med:.3f} | {med * 1e9 / samples:.0f} |")


if __name__ == "__main__":
    main()
