"""Visualization by proxy: the paper's experiments on ../shared/data stand-ins (issue 22).

Sections (``--only`` picks some):

- **views** (paper Fig. 6a, P1): an isosurface's depth synthesised for rotations of
  0-60 degrees about the view-up axis from multi-perspective proxies (and, for
  comparison, from the plain depth layer), against the depth the ray caster finds for
  the rotated view: Pearson correlation over pixels valid in both, coverage (the
  fraction of the true surface's pixels the synthesis covers), median |error| in
  voxels; and the radiality histogram's mass below 30 degrees (Fig. 6b-d). CT head,
  engine, an analytic asymmetric blob. Orthographic iso view.
- **tf** (Figs. 12-13, P6-P7): the colour predicted after an opacity change against
  the render with that change. Observations: the outer half of the visible intervals
  fades, k = 1.0 -> 0.1 in 10 steps; training sets of 1, 2, 3 renders (the function,
  then random interval scales), K = 1, 8, 24, 48 clusters. SSD summed over the
  observations; with the true attenuation (rendered) it is the model's error alone,
  the rest is the propagation's. Hydrogen (smooth, 6 decades), a synthetic turbulent
  field (k^-5/3 spectrum), CT head.
- **light** (Figs. 8-9, P3-P4): a depth layer relit (a white light from (1, 1, 1))
  against the ray caster's shaded opaque isosurface (RMSE of RGB over the surface,
  the original view and 30 degrees turned); proxy ambient occlusion (Eq. 5) and the
  unsharp-masking baseline against ambient occlusion computed in the volume (32
  hemisphere rays per surface pixel, as far as the proxy AO's radius): correlation and
  RMSE of the shading factors. CT head skin, blob.
- **cost** (Fig. 15, P9): time of a synthesised frame (opacity change; rotation;
  relighting; layers with AO) against the ray caster's render of the same view (its
  defaults: float32, early termination; and the proxies' reference settings: float64,
  no termination); proxy bytes against volume bytes, and the paper's storage table.

Usage::

    python3 benchmarks/bench_proxy.py                  # everything, 512^2 views, ~15 min
    python3 benchmarks/bench_proxy.py --only views --size 256

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

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.proxy import lighting as LT  # noqa: E402
from pv_hdrvol.proxy import synthesis as S  # noqa: E402
from pv_hdrvol.proxy.generate import ProxyPass, make_proxies  # noqa: E402
from pv_hdrvol.proxy.model import ColorModel, propagate  # noqa: E402
from pv_hdrvol.proxy.proxies import storage_ratio  # noqa: E402
from pv_hdrvol.raycast.grid import default_transfer_function  # noqa: E402

DATA = REPO.parent / "shared" / "data"


def load_note():
    return f"load {os.getloadavg()[0]:.2f}"


def read(path):
    import pyvista as pv

    return hv.volume_from_dataset(pv.read(DATA / path))


def blob(n=128):
    """An asymmetric blob: four anisotropic Gaussians, high-frequency bumps on the +x side."""
    z, y, x = (a.astype(np.float32) / (n - 1) * 2 - 1 for a in np.ogrid[0:n, 0:n, 0:n])
    v = np.zeros((n, n, n), dtype=np.float32)
    for cx, cy, cz, sx, sy, sz, w in ((0, 0, 0, 0.45, 0.35, 0.3, 1.0), (0.35, 0.2, 0.1, 0.2, 0.25, 0.2, 0.6),
                                      (-0.3, -0.25, 0.15, 0.25, 0.15, 0.2, 0.5), (0.1, 0.35, -0.3, 0.2, 0.2, 0.15, 0.5)):
        v += w * np.exp(-((x - cx) ** 2 / sx ** 2 + (y - cy) ** 2 / sy ** 2 + (z - cz) ** 2 / sz ** 2))
    v += 0.08 * np.clip(x, 0, None) * np.sin(18 * y) * np.sin(18 * z)
    return hv.volume_from_array(v, spacing=(2.0 / (n - 1),) * 3, origin=(-1.0, -1.0, -1.0))


def turbulence(n=128, seed=0):
    """A random-phase field with a k^-5/3 energy spectrum, positive (exp of it)."""
    rng = np.random.default_rng(seed)
    k = np.fft.fftfreq(n) * n
    kk = np.sqrt(k[:, None, None] ** 2 + k[None, :, None] ** 2 + k[None, None, :] ** 2)
    amp = np.where(kk > 0, kk ** (-11.0 / 6.0), 0.0)  # |u_k| ~ k^(-11/6): E(k) ~ k^-5/3 in 3-D
    phase = np.exp(2j * np.pi * rng.random((n, n, n)))
    f = np.real(np.fft.ifftn(amp * phase))
    f = (f - f.mean()) / f.std()
    return hv.volume_from_array(np.exp(1.5 * f))


#: name -> (loader, isovalue of the depth layer)
VIEW_DATA = {
    "ct_head": (lambda: read("structured/ct_head_120x120x130_uint8.vtk"), 40.0),
    "engine": (lambda: read("structured/engine_256x256x128_uint8.vti"), 100.0),
    "blob": (blob, 0.35),
}
TF_DATA = {
    "hydrogen": lambda: read("hdr/hydrogen_64x64x64_float32.vti"),
    "turbulence": turbulence,
    "ct_head": lambda: read("structured/ct_head_120x120x130_uint8.vtk"),
}


def voxel(volume):
    return float(volume.spacing.min())


# -- views ----------------------------------------------------------------------------
def bench_views(size, angles):
    print(f"\n== view synthesis (Fig. 6a): {size}^2, rotation about view-up, orthographic iso view ==")
    for name, (load, iso) in VIEW_DATA.items():
        volume = load()
        t0 = time.perf_counter()
        p = make_proxies(volume, "iso", size, intervals=2, layers=[iso], multi_perspective=True, training=0)
        made = time.perf_counter() - t0
        counts, edges = p.radiality(0)
        low = counts[edges[1:] <= 30].sum() / max(counts.sum(), 1)
        print(f"{name}: proxies {made:.1f} s; radiality of the multi-perspective layer: {100 * low:.0f}% of "
              f"pixels below 30 deg (plain layer {100 * _low(p.radiality(0, False)):.0f}%)   [{load_note()}]")
        for angle in angles:
            cam = S.rotated_camera(p.camera, (angle, 0))
            truth = make_proxies(volume, cam, size, intervals=2, layers=[iso], training=0).depth[0]
            rows = []
            for label, synth in (("multi", p.layer_depth(0, rotate=(angle, 0)) if angle else
                                  S.warp_depth(p.mp_camera, p.size, p.mp_depth[0], p.mp_dist[0], cam,
                                               jump=4 * p.pitch)),
                                 ("plain", S.warp_depth(p.camera, p.size, p.depth[0], None, cam, jump=4 * p.pitch))):
                r, cov = S.depth_correlation(synth, truth)
                both = np.isfinite(synth) & np.isfinite(truth)
                med = float(np.median(np.abs(synth[both] - truth[both]))) / voxel(volume) if both.any() else math.nan
                rows.append(f"{label} r {r:.4f} coverage {cov:.3f} median |dz| {med:.2f} vox")
            print(f"  {angle:3d} deg: " + " | ".join(rows), flush=True)


def _low(hist):
    counts, edges = hist
    return counts[edges[1:] <= 30].sum() / max(counts.sum(), 1)


# -- transfer functions ---------------------------------------------------------------
def bench_tf(size, observations=10):
    print(f"\n== transfer-function prediction (Figs. 12-13): {size}^2, SSD summed over {observations} "
          f"observations ==")
    for name, load in TF_DATA.items():
        volume = load()
        tf = default_transfer_function(volume)
        pp = None
        base = make_proxies(volume, "iso", size, tf, intervals=16, training=3, clusters=1)
        pp = ProxyPass(volume, tf, 16, [])
        rays = base.camera.rays(base.size)
        shown = np.flatnonzero(base.atten.reshape(16, -1).sum(axis=1) > 1e-3 * base.atten.sum())
        outer = shown[:max(1, len(shown) // 2)]
        truths = []
        for k in np.linspace(1.0, 0.1, observations):
            scale = np.ones(16)
            scale[outer] = k
            rgba, a = pp.run(rays, scale)[:2]
            truths.append((scale, rgba[:, :3].reshape(size, size, 3), a.T.reshape(16, size, size)))
        # the training renders (the same rays: 1, 2, 3 of them) are those make_proxies makes
        from pv_hdrvol.proxy.generate import training_scales

        scales = training_scales(3, 16, seed=0)
        train = [pp.run(rays, s)[:2] for s in scales]
        prop = [base.attenuation(s)[0] for s, _, _ in truths]
        plain = [propagate(base.atten, s, own=base.own, entry=base.entry) for s, _, _ in truths]
        prop_err = sum(float(np.abs(a - t).sum(axis=0).mean()) for a, (_, _, t) in zip(prop, truths)) / observations
        plain_err = sum(float(np.abs(a - t).sum(axis=0).mean()) for a, (_, _, t) in zip(plain, truths)) / observations
        print(f"{name}: outer intervals {outer.tolist()} of the visible {shown.tolist()}; mean per-pixel "
              f"sum|a'-a| of the propagation {prop_err:.2e} (plain slab model {plain_err:.2e})   [{load_note()}]")
        for n in (1, 2, 3):
            a_tr = np.concatenate([t[1].T for t in train[:n]], axis=1)
            c_tr = np.concatenate([t[0][:, :3] for t in train[:n]], axis=0)
            cells = []
            for clusters in (1, 8, 24, 48):
                t0 = time.perf_counter()
                model = ColorModel.fit(a_tr, c_tr, clusters=clusters, seed=0)
                fit = time.perf_counter() - t0
                ssd = sum(float(((_predict(model, a) - c) ** 2).sum()) for a, (_, c, _) in zip(prop, truths))
                ssd_true = sum(float(((_predict(model, t) - c) ** 2).sum()) for _, c, t in truths)
                cells.append(f"K={clusters:2d} {ssd:9.3e} (true a' {ssd_true:9.3e}, fit {fit:4.1f} s)")
            print(f"  {n} training: " + " | ".join(cells), flush=True)


def _predict(model, atten):
    rgb = model.predict(atten)
    rgb[atten.sum(axis=0) <= 0] = 0.0
    return rgb


# -- lighting ---------------------------------------------------------------------------
def volume_ao(volume, iso, camera, depth, radius_world, rays=32, steps=8, seed=0):
    """Ambient occlusion of the isosurface points seen at ``depth`` by marching the
    volume: the fraction of ``rays`` hemisphere directions about the gradient normal
    that reach a value >= ``iso`` within ``radius_world``."""
    from scipy.ndimage import map_coordinates

    pts, idx = S.surface_points(camera, depth.shape[::-1], depth)
    values = np.asarray(volume.values, dtype=np.float64)
    grads = np.gradient(values, *volume.spacing[::-1])

    def sample(arr, p):
        q = ((p - volume.origin) / volume.spacing)[:, ::-1].T
        return map_coordinates(arr, q, order=1, mode="nearest")

    n = -np.stack([sample(grads[2 - a], pts) for a in range(3)], axis=1)  # outward: values fall outside
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    rng = np.random.default_rng(seed)
    dirs = rng.normal(size=(rays, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    occluded = np.zeros(len(pts))
    for d in dirs:
        dd = np.where((n @ d)[:, None] < 0, -d, d)
        hit = np.zeros(len(pts), dtype=bool)
        for s in range(1, steps + 1):
            p = pts + n * (0.75 * voxel(volume)) + dd * (radius_world * s / steps)
            hit |= sample(values, p) >= iso
        occluded += hit
    out = np.full(depth.size, np.nan)
    out[idx] = 1.0 - occluded / rays
    return out.reshape(depth.shape)


def interior(volume, camera, depth, margin=1.5):
    """Pixels whose surface point lies more than ``margin`` voxels inside the volume's
    box: where a dataset is cut by its box (the CT head's top), the layer is the box face
    and the shaded render lights the material behind it: not the same surface."""
    pts, idx = S.surface_points(camera, depth.shape[::-1], depth)
    b = np.asarray(volume.bounds).reshape(3, 2)
    m = margin * voxel(volume)
    inside = np.all((pts > b[:, 0] + m) & (pts < b[:, 1] - m), axis=1)
    out = np.zeros(depth.size, dtype=bool)
    out[idx[inside]] = True
    return out.reshape(depth.shape)


def bench_light(size):
    print(f"\n== relighting and ambient occlusion (Figs. 8-9): {size}^2 ==")
    light = hv.Light((1.0, 1.0, 1.0))
    rgb = (0.9, 0.75, 0.6)
    for name in ("ct_head", "blob"):
        load, iso = VIEW_DATA[name]
        volume = load()
        p = make_proxies(volume, "iso", size, intervals=2, layers=[iso], multi_perspective=True, training=0)
        step = 0.1
        tf = hv.TransferFunction([volume.value_range[0] - 1, iso, iso + 1e-6 * max(1, abs(iso)),
                                  volume.value_range[1] + 1], [rgb] * 4, [0, 0, 1, 1])
        for angle in (0, 30):
            cam = S.rotated_camera(p.camera, (angle, 0))
            img = p.synthesize(layers={0: (rgb, 1.0)}, light=light, rotate=(angle, 0) if angle else None)
            t0 = time.perf_counter()
            ref = hv.render(volume, tf, cam, size, shade=True, lights=[light], shade_threshold=0.0, precision="float64", step=step,
                            termination=0.0, opacity_unit_distance=step * voxel(volume), progress_bar=False)
            t_ref = time.perf_counter() - t0
            z = p.layer_depth(0, rotate=(angle, 0)) if angle else p.depth[0]
            both = (img.rgba[..., 3] > 0) & (ref.rgba[..., 3] > 0.99) & interior(volume, cam, np.where(
                np.isfinite(z), z, np.inf))
            err = float(np.sqrt(np.mean((img.rgba[both, :3] - ref.rgba[both, :3]) ** 2)))
            print(f"{name} {angle:2d} deg: relit layer RMSE {err:.4f} of RGB (peak {ref.rgba[both, :3].max():.2f}) "
                  f"over {both.sum()} px inside the box; shaded render {t_ref:.1f} s   [{load_note()}]", flush=True)
        depth = p.depth[0]
        radius = 8
        gt = volume_ao(volume, iso, p.camera, depth, radius * p.pitch)
        ours = LT.ambient_occlusion(depth, p.pitch, radius=radius)
        base = LT.unsharp_occlusion(depth, p.pitch, radius=radius)
        ok = np.isfinite(gt) & np.isfinite(depth) & interior(volume, p.camera, depth)
        for label, f in (("proxy AO (Eq. 5)", ours), ("unsharp masking", base)):
            r = float(np.corrcoef(f[ok], gt[ok])[0, 1])
            rmse = float(np.sqrt(np.mean((f[ok] - gt[ok]) ** 2)))
            print(f"  {label:17s}: correlation with volume AO {r:.3f}, RMSE of the factor {rmse:.3f}")


# -- cost -------------------------------------------------------------------------------
def bench_cost(size, repeats=5):
    print(f"\n== cost (Fig. 15): {size}^2 ==")
    for name, (load, iso) in VIEW_DATA.items():
        volume = load()
        tf = default_transfer_function(volume)
        t0 = time.perf_counter()
        p = make_proxies(volume, "iso", size, tf, intervals=16, layers=[iso], multi_perspective=True, training=3)
        made = time.perf_counter() - t0
        hv.render(volume, tf, p.camera, 32, progress_bar=False)  # compile
        hv.render(volume, tf, p.camera, 32, precision="float64", termination=0.0, progress_bar=False)
        t_def = _median(lambda: hv.render(volume, tf, p.camera, size, progress_bar=False), repeats)
        t_ref = _median(lambda: hv.render(volume, tf, p.camera, size, precision="float64", termination=0.0,
                                          progress_bar=False), 2)
        k = {i: 0.3 for i in range(4, 8)}
        rows = [("opacity change", lambda: p.synthesize(k)),
                ("rotation 30 deg", lambda: p.synthesize(rotate=(30, 0))),
                ("relight", lambda: p.synthesize(light=hv.Light((1, 1, 1)))),
                ("layer, relit", lambda: p.synthesize(layers={0: ((1, 1, 1), 1.0)}, light=hv.Light((1, 1, 1)))),
                ("layer, relit + AO", lambda: p.synthesize(layers={0: ((1, 1, 1), 1.0)}, light=hv.Light((1, 1, 1)),
                                                           ambient_occlusion=1.0))]
        st = p.storage()
        print(f"{name}: proxies made in {made:.1f} s; render {t_def * 1e3:.0f} ms (defaults: float32, early "
              f"termination), {t_ref * 1e3:.0f} ms (float64, no termination); proxies "
              f"{st['proxy_bytes'] / 2 ** 20:.1f} MiB ({st['channels']} channels) for a "
              f"{st['volume_bytes'] / 2 ** 20:.1f} MiB volume (ratio {st['ratio']:.2f})   [{load_note()}]")
        for label, f in rows:
            f()
            t = _median(f, repeats)
            print(f"  {label:18s} {t * 1e3:7.1f} ms: {t_def / t:6.1f}x faster than the default render, "
                  f"{t_ref / t:6.1f}x than the reference settings", flush=True)
    print("\nscaling with the volume (the blob resampled to N^3; the same 512^2 view; 16 intervals, K=24):")
    for n in (128, 256, 384, 512):
        volume = blob(n)
        tf = default_transfer_function(volume)
        t0 = time.perf_counter()
        p = make_proxies(volume, "iso", size, tf, intervals=16, layers=[0.35], training=2)
        made = time.perf_counter() - t0
        hv.render(volume, tf, p.camera, 32, progress_bar=False)
        t_def = _median(lambda: hv.render(volume, tf, p.camera, size, progress_bar=False), 3)
        k = {i: 0.3 for i in range(4, 8)}
        p.synthesize(k)
        t_k = _median(lambda: p.synthesize(k), repeats)
        t_l = _median(lambda: p.synthesize(layers={0: ((1, 1, 1), 1.0)}, light=hv.Light((1, 1, 1))), repeats)
        st = p.storage()
        print(f"  N={n}: proxies {made:6.1f} s, render {t_def * 1e3:7.0f} ms; opacity change {t_k * 1e3:5.0f} ms "
              f"({t_def / t_k:5.1f}x), relit layer {t_l * 1e3:5.0f} ms ({t_def / t_l:5.1f}x); proxy/volume bytes "
              f"{st['ratio']:.3f}   [{load_note()}]", flush=True)
        del volume, p
    print("storage, the paper's pessimistic case (k = N/10 images of 512^2 against N^3):",
          ", ".join(f"N={n}: {storage_ratio(n, 512, n / 10):.4g}" for n in (128, 256, 512, 1024, 2048, 4096)))


def _median(f, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="+", choices=("views", "tf", "light", "cost"), default=None)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--tf-size", type=int, default=256, help="image size of the tf section (default 256)")
    ap.add_argument("--angles", type=int, nargs="+", default=list(range(0, 61, 5)))
    args = ap.parse_args(argv)
    print(f"pv_hdrvol {hv.__version__}, numba threads {os.environ.get('NUMBA_NUM_THREADS', 'default')}, "
          f"{os.cpu_count()} cpus, {load_note()}")
    only = set(args.only or ("views", "tf", "light", "cost"))
    if "views" in only:
        bench_views(args.size, args.angles)
    if "tf" in only:
        bench_tf(args.tf_size)
    if "light" in only:
        bench_light(args.size)
    if "cost" in only:
        bench_cost(args.size)


if __name__ == "__main__":
    main()
