"""Out-of-core rendering of a store larger than memory: issue 34's goals, measured.

A procedural float32 volume of ``--n`` points a side (default 2048: 32 GiB) is written
straight into a store (never held whole), then rendered out of core in fresh processes
(their peak memory is theirs alone):

1. **build**: seconds and the writer's peak resident memory (goal: <= 15 min, <= 2 GiB);
2. **first image**: a 512^2 frame right after ``open_multiscale`` (kernels compiled
   before, on a small store), ``wait=False``: what is resident then, the coarsest level
   (goal: <= 1 s);
3. **converged**: the full view at 1024^2, 1 pixel of screen error, ``wait=True``, with a
   4 GiB cache: bytes read against level 0's size (goal: <= 16 %), seconds, and the
   process's peak memory (goal: <= 6 GiB); then the same with a 1 GiB cache (it must
   still finish: blocks coarsened to fit, ``coarsened``);
4. **rest**: the camera moved to another view (``xz``) and left at rest: 512^2 frames
   with ``wait=False`` (the viewer's way) until one shows finer blocks than the first;
   the time from rest to it (goal: <= 1 s).

5. **trade-off** (``--tradeoff``): ``screen_error`` against time, bytes read and error
   (against the level-0 render, which equals the in-core one bit for bit), at 512^2;
6. **rest** (``--rest``): the rest goal view by view, frame by frame (four views after a
   converged 512^2 iso frame);
7. **seams** (``--seams``): where a block at level 1 meets one at level 0, the jump of the
   sampled field at their face against the differences between neighbouring samples
   (a tenth of a voxel apart) inside each level, along lines across the face.

8. **proxy** (``--proxy``): issue 22's 100x goal at N = 1024 from a store: the 512^2 render
   of the blob of ``bench_proxy.py`` resampled to 1024^3 (written into a store), from the
   store at level 0 and at 1 pixel of screen error, against a synthesised frame of
   proxies (an opacity change; a relit layer). Synthesis reads only the 512^2 proxy
   images, whatever the volume (docs/proxy.md): its time is measured on proxies made
   from the blob at 512^3, which fits in memory here with the proxy pass's float64 copy.

    python3 benchmarks/bench_ooc_render.py --n 512      # a few minutes
    python3 benchmarks/bench_ooc_render.py              # 2048^3: the goals (about 30 min)
    python3 benchmarks/bench_ooc_render.py --n 512 --tradeoff --seams

The store is kept (``--store``, default in the system's temporary folder) and reused
when it is complete and of the same size.

Measured (2048^3, 2-core machine, 24 GiB, load average 0.7 before, 2.0 after; nothing
else running): build 481 s, 182 MiB peak; first 512^2 image 0.49 s (4 GiB cache) and
0.37 s (1 GiB); converged 1024^2 at 1 px: 2 passes, 57 s, 13.5 % of level 0 read, 5.1 GiB
peak (4 GiB cache), 12 passes, 59 s, 16.8 %, 3.0 GiB (1 GiB cache); at termination
1e-3, 12,887 of 32,768 blocks occluded, 9.0 % read, 42 s; rest: 1.21 s (4 GiB), 0.81 s
(1 GiB), 0.95-1.38 s over four views with ``--rest`` (one 512^2 frame of 53 M samples).
docs/out_of_core.md has the table and the decision the rest goal needs.
"""
from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import pv_hdrvol as hv  # noqa: E402
from bench_ooc_store import procedural  # noqa: E402

GiB = 2 ** 30


def _peak_mib():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _tf():
    """Tubes (300) and sheets (100) over a smooth field (1.5 .. 1000): opaque tubes, faint
    sheets, the field's core glowing."""
    return hv.TransferFunction([0.0, 50.0, 100.0, 200.0, 300.0, 1000.0],
                               [[0, 0, 0], [0.1, 0.1, 0.3], [0.3, 0.6, 1.0], [0.5, 0.5, 0.5], [1.0, 0.6, 0.2],
                                [4.0, 3.0, 2.0]],
                               [0.0, 0.0, 0.002, 0.001, 0.05, 0.02])


def _build(n, path, out):
    t = time.perf_counter()
    hv.write_multiscale(procedural(n), path, shape=(n, n, n), dtype="float32", overwrite=True, progress_bar=False)
    out.put({"seconds": time.perf_counter() - t, "peak_mib": _peak_mib()})


def _warm_up():
    """Compile the kernels on a small store (the numba cache keeps them)."""
    with tempfile.TemporaryDirectory() as tmp:
        hv.write_multiscale(procedural(96), Path(tmp) / "w.ome.zarr", shape=(96, 96, 96), dtype="float32",
                            progress_bar=False)
        with hv.open_multiscale(Path(tmp) / "w.ome.zarr") as v:
            v.render(_tf(), "iso", (32, 32), screen_error=1.0)


def _converged(path, cache, termination, out):
    """A converged 1024^2 frame in a fresh process: bytes read, blocks left out as
    occluded (the bound needs a termination float32 resolves: 1e-3, not the 1e-6 default)."""
    _warm_up()
    with hv.open_multiscale(path, cache_bytes=cache) as volume:
        camera = hv.Camera.fit(volume.bounds, "iso")
        t = time.perf_counter()
        image = volume.render(_tf(), camera, (1024, 1024), screen_error=1.0, termination=termination)
        level0 = int(np.prod(volume.store.levels[0].shape)) * volume.store.dtype.itemsize
        out.put({"seconds": time.perf_counter() - t, "termination": termination,
                 "occluded": image.metadata["occluded"], "levels": image.metadata["levels"],
                 "passes": image.metadata["passes"], "bytes_read": image.metadata["bytes_read"],
                 "bytes_read_share": image.metadata["bytes_read"] / level0, "peak_mib": _peak_mib()})


def _render(path, cache, out):
    _warm_up()
    result = {"peak_before_mib": _peak_mib()}
    tf = _tf()
    t = time.perf_counter()
    volume = hv.open_multiscale(path, cache_bytes=cache)
    camera = hv.Camera.fit(volume.bounds, "iso")
    first = volume.render(tf, camera, (512, 512), screen_error=1.0, wait=False)
    result["first_seconds"] = time.perf_counter() - t
    result["first_levels"] = first.metadata["levels"]
    t = time.perf_counter()
    image = volume.render(tf, camera, (1024, 1024), screen_error=1.0)
    result["converged_seconds"] = time.perf_counter() - t
    level0 = int(np.prod(volume.store.levels[0].shape)) * volume.store.dtype.itemsize
    for key in ("levels", "desired_levels", "coarsened", "passes", "converged", "bytes_read", "bytes_read_per_level",
                "chunks_read_per_level", "samples", "render_seconds"):
        result[key] = image.metadata[key]
    result["bytes_read_share"] = image.metadata["bytes_read"] / level0
    result["peak_mib"] = _peak_mib()
    # rest: turn the camera, then frames until a finer one shows
    turned = hv.Camera.fit(volume.bounds, "xz")
    coarse = volume.render(tf, turned, (512, 512), screen_error=1.0, wait=False)
    rest = time.perf_counter()
    finer = None
    while time.perf_counter() - rest < 120:
        frame = volume.render(tf, turned, (512, 512), screen_error=1.0, wait=False)
        if _finer(frame.metadata["levels"], coarse.metadata["levels"]) or frame.metadata["converged"]:
            finer = time.perf_counter() - rest
            result["rest_frame_levels"] = frame.metadata["levels"]
            break
        time.sleep(0.01)
    result["rest_coarse_levels"] = coarse.metadata["levels"]
    result["rest_seconds"] = finer
    volume.close()
    out.put(result)


def _tradeoff(path, out):
    _warm_up()
    tf = _tf()
    rows = []
    with hv.open_multiscale(path, cache_bytes=4 * GiB) as volume:
        camera = hv.Camera.fit(volume.bounds, "iso")
        reference = volume.render(tf, camera, (512, 512), screen_error=1e-9)
        ref = reference.rgba.astype(np.float64)
        peak = float(ref[..., :3].max())
        for error in (1e-9, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0):
            volume.close()  # a cold cache: what this error reads
            image = volume.render(tf, camera, (512, 512), screen_error=error)
            t = time.perf_counter()
            image = volume.render(tf, camera, (512, 512), screen_error=error)  # warm: the render alone
            seconds = time.perf_counter() - t
            diff = np.abs(image.rgba.astype(np.float64) - ref)
            rows.append({"screen_error": error, "seconds": seconds, "levels": image.metadata["levels"],
                         "bytes_read": image.metadata["bytes_read"], "samples": image.metadata["samples"],
                         "max_rel": float(diff[..., :3].max() / peak),
                         "rms_rel": float(np.sqrt((diff[..., :3] ** 2).mean()) / peak),
                         "alpha_max": float(diff[..., 3].max())})
    out.put(rows)


def _seams(path, out):
    """The reconstructed field on both sides of a face between a level-1 block and a
    level-0 block: along 64 lines in x across the face at x = 64 k (k the middle block
    face), each side sampled as the renderer samples it (trilinear in its level, level-1
    point j at 2 j + 1/2)."""
    store = hv.MultiscaleStore(path)
    n = store.levels[0].shape[2]
    face = 64 * (n // 128)
    lo = max(face - 64, 0)
    hi = min(face + 64, n - 1)
    fine = store.read_level(0)[:, :, lo:hi + 1].astype(np.float64)
    coarse = store.read_level(1).astype(np.float64)
    rng = np.random.default_rng(0)
    ys = rng.uniform(1, n - 2, 64)
    zs = rng.uniform(1, n - 2, 64)
    xs = np.arange(lo, hi, 0.1)

    def tri(values, x, y, z, offset):
        x = np.clip(x - offset, 0, values.shape[2] - 1)
        y = np.clip(y, 0, values.shape[1] - 1)
        z = np.clip(z, 0, values.shape[0] - 1)
        i, j, k = (np.minimum(np.floor(a).astype(int), m - 2) for a, m in
                   zip((x, y, z), (values.shape[2], values.shape[1], values.shape[0])))
        fx, fy, fz = x - i, y - j, z - k
        c = 0.0
        for dz in (0, 1):
            for dy in (0, 1):
                for dx in (0, 1):
                    w = (fx if dx else 1 - fx) * (fy if dy else 1 - fy) * (fz if dz else 1 - fz)
                    c = c + w * values[k + dz, j + dy, i + dx]
        return c

    jumps, steps0, steps1 = [], [], []
    for y, z in zip(ys, zs):
        f0 = tri(fine, xs, np.full_like(xs, y), np.full_like(xs, z), lo)
        f1 = tri(coarse, (xs - 0.5) / 2, np.full_like(xs, (y - 0.5) / 2), np.full_like(xs, (z - 0.5) / 2), 0)
        at = int(np.argmin(np.abs(xs - face)))
        jumps.append(abs(f1[at] - f0[at]))
        steps0.append(np.abs(np.diff(f0)).mean())
        steps1.append(np.abs(np.diff(f1)).mean())
    value_range = float(fine.max() - fine.min())
    out.put({"face_x": face, "lines": 64, "jump_mean": float(np.mean(jumps)), "jump_max": float(np.max(jumps)),
             "step_mean_level0": float(np.mean(steps0)), "step_mean_level1": float(np.mean(steps1)),
             "jump_max_over_range": float(np.max(jumps)) / value_range,
             "stored_error_max_level0": float(store.levels[0].ranges[..., 2].max())})


def _blob_box(n):
    """``f(box)`` of bench_proxy's blob at n^3 (on [-1, 1]^3), box by box."""
    def f(box):
        z, y, x = (np.arange(a, b, dtype=np.float32) / (n - 1) * 2 - 1 for a, b in box)
        z, y, x = z[:, None, None], y[None, :, None], x[None, None, :]
        v = np.zeros(tuple(b - a for a, b in box), dtype=np.float32)
        for cx, cy, cz, sx, sy, sz, w in ((0, 0, 0, 0.45, 0.35, 0.3, 1.0), (0.35, 0.2, 0.1, 0.2, 0.25, 0.2, 0.6),
                                          (-0.3, -0.25, 0.15, 0.25, 0.15, 0.2, 0.5),
                                          (0.1, 0.35, -0.3, 0.2, 0.2, 0.15, 0.5)):
            v += w * np.exp(-((x - cx) ** 2 / sx ** 2 + (y - cy) ** 2 / sy ** 2 + (z - cz) ** 2 / sz ** 2))
        v += 0.08 * np.clip(x, 0, None) * np.sin(18 * y) * np.sin(18 * z)
        return v
    return f


def _proxy(out):
    from bench_proxy import blob

    from pv_hdrvol.raycast.grid import default_transfer_function

    result = {}
    small = blob(512)
    tf = default_transfer_function(small)
    proxies = hv.make_proxies(small, "iso", 512, tf, intervals=16, layers=[0.35], training=2)
    k = {i: 0.3 for i in range(4, 8)}
    proxies.synthesize(k)
    times = []
    for _ in range(5):
        t = time.perf_counter()
        proxies.synthesize(k)
        times.append(time.perf_counter() - t)
    result["opacity_change_s"] = sorted(times)[2]
    times = []
    for _ in range(5):
        t = time.perf_counter()
        proxies.synthesize(layers={0: ((1, 1, 1), 1.0)}, light=hv.Light((1, 1, 1)))
        times.append(time.perf_counter() - t)
    result["relit_layer_s"] = sorted(times)[2]
    camera = proxies.camera
    del small, proxies
    n = 1024
    path = Path(tempfile.gettempdir()) / "pv_hdrvol_bench_blob_1024.ome.zarr"
    try:
        ok = hv.MultiscaleStore(path).levels[0].shape == (n, n, n)
    except (OSError, ValueError):
        ok = False
    if not ok:
        t = time.perf_counter()
        hv.write_multiscale(_blob_box(n), path, shape=(n, n, n), dtype="float32", spacing=(2.0 / (n - 1),) * 3,
                            origin=(-1.0, -1.0, -1.0), overwrite=True, progress_bar=False)
        result["store_build_s"] = time.perf_counter() - t
    with hv.open_multiscale(path, cache_bytes=6 * GiB) as volume:
        volume.render(tf, camera, (64, 64), screen_error=1e-9)  # compile; chunks of a small frame
        for label, error in (("level_0", 1e-9), ("screen_error_1", 1.0)):
            volume.render(tf, camera, (512, 512), screen_error=error)  # chunks in the cache
            t = time.perf_counter()
            image = volume.render(tf, camera, (512, 512), screen_error=error)
            result[f"render_{label}_s"] = time.perf_counter() - t
            result[f"render_{label}_levels"] = image.metadata["levels"]
            result[f"ratio_opacity_change_{label}"] = result[f"render_{label}_s"] / result["opacity_change_s"]
            result[f"ratio_relit_layer_{label}"] = result[f"render_{label}_s"] / result["relit_layer_s"]
    out.put(result)


def _rest(path, out):
    """The rest goal, view by view: a 512^2 converged iso frame fills the cache, then for
    each other view a coarse frame and 512^2 frames with ``wait=False`` until one shows
    finer blocks; each frame's time, levels, reads pending and samples."""
    _warm_up()
    tf = _tf()
    rows = {}
    with hv.open_multiscale(path, cache_bytes=4 * GiB) as volume:
        volume.render(tf, hv.Camera.fit(volume.bounds, "iso"), (512, 512), screen_error=1.0)
        for view in ("xz", "yz", "zy", "yx"):
            turned = hv.Camera.fit(volume.bounds, view)
            t0 = time.perf_counter()
            coarse = volume.render(tf, turned, (512, 512), screen_error=1.0, wait=False)
            rest = time.perf_counter()
            frames = [{"frame": "coarse", "seconds": rest - t0, "levels": coarse.metadata["levels"]}]
            while time.perf_counter() - rest < 60:
                t = time.perf_counter()
                frame = volume.render(tf, turned, (512, 512), screen_error=1.0, wait=False)
                frames.append({"since_rest": time.perf_counter() - rest, "seconds": time.perf_counter() - t,
                               "levels": frame.metadata["levels"], "pending": frame.metadata["pending"],
                               "samples": frame.metadata["samples"]})
                if _finer(frame.metadata["levels"], coarse.metadata["levels"]) or frame.metadata["converged"]:
                    break
            rows[view] = frames
    out.put(rows)


def _finer(levels, than):
    """Whether block counts ``levels`` have more blocks at finer levels than ``than``."""
    return np.cumsum(levels).tolist() > np.cumsum(than).tolist()


def _child(target, *args):
    q = multiprocessing.get_context("fork").Queue()
    p = multiprocessing.get_context("fork").Process(target=target, args=args + (q,))
    p.start()
    result = q.get()
    p.join()
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=2048)
    parser.add_argument("--store", help="the store's path (default: in the temporary folder)")
    parser.add_argument("--tradeoff", action="store_true", help="screen_error against time, bytes and error only")
    parser.add_argument("--seams", action="store_true", help="the jump at a face between levels 0 and 1 only")
    parser.add_argument("--proxy", action="store_true", help="issue 22's proxy ratio at N = 1024 from a store only")
    parser.add_argument("--rest", action="store_true", help="the rest goal view by view, frame by frame only")
    args = parser.parse_args(argv)
    n = args.n
    path = Path(args.store or Path(tempfile.gettempdir()) / f"pv_hdrvol_bench_{n}.ome.zarr")
    report = {"n": n, "volume_gib": n ** 3 * 4 / GiB, "load_before": os.getloadavg()}
    reuse = False
    try:
        reuse = hv.MultiscaleStore(path).levels[0].shape == (n, n, n)
    except (OSError, ValueError):
        pass
    if args.proxy:
        report["proxy"] = _child(_proxy)
    else:
        if not reuse:
            report["build"] = _child(_build, n, str(path))
        if args.tradeoff:
            report["tradeoff"] = _child(_tradeoff, str(path))
        if args.seams:
            report["seams"] = _child(_seams, str(path))
        if args.rest:
            report["rest"] = _child(_rest, str(path))
        if not (args.tradeoff or args.seams or args.rest):
            report["render_4GiB"] = _child(_render, str(path), 4 * GiB)
            report["render_1GiB"] = _child(_render, str(path), 1 * GiB)
            report["converged_4GiB_termination_1e-3"] = _child(_converged, str(path), 4 * GiB, 1e-3)
    report["load_after"] = os.getloadavg()
    print(json.dumps(report, indent=1))
    return report


if __name__ == "__main__":
    main()
