"""
Visualization by proxy: exploring the CT head from its proxy images alone
=========================================================================

``hv.make_proxies`` casts the CT head once (the heavy pass, where the volume is); the
proxy folder then answers, without the volume: another opacity per intensity
interval (the colour model, paper §6), a turned view (the distortion camera's
multi-perspective proxies, §4), relit depth layers with the proxy ambient occlusion
(§5) and depth-aware enhancement (Eq. 11). Each synthesised image stands beside the
ray caster's render of the same setting, its ground truth.

Run::

    python3 examples/plot_proxy.py      # writes docs/images/proxy_gallery.png
"""
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.proxy import synthesis as S  # noqa: E402
from pv_hdrvol.proxy.generate import ProxyPass  # noqa: E402

try:
    ROOT = Path(__file__).resolve().parents[1]
except NameError:  # sphinx-gallery runs examples without __file__, in examples/
    ROOT = Path.cwd().resolve().parent
# the figures go to docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", ROOT / "docs" / "images"))


def main(size=384):
    volume = hv.volume_from_dataset(pv.read(ROOT.parent / "shared" / "data" / "structured" /
                                            "ct_head_120x120x130_uint8.vtk"))
    tf = hv.TransferFunction([0, 30, 45, 60, 70, 90, 140, 255],
                             [[0, 0, 0], [0.9, 0.6, 0.45], [0.95, 0.7, 0.55], [0.8, 0.4, 0.3], [0.7, 0.3, 0.25],
                              [1, 1, 0.9], [1, 1, 1], [1, 1, 1]],
                             [0, 0, 0.02, 0.03, 0.03, 0.2, 0.6, 0.8])
    # the scan's head points to -z: look at the face with -z up
    cam = hv.Camera.fit(volume.bounds, "xz", parallel_projection=True)
    cam = hv.Camera(cam.position, cam.focal_point, (0, 0, -1), parallel_projection=True,
                    parallel_scale=cam.parallel_scale)
    p = hv.make_proxies(volume, cam, size, tf, intervals=16, layers=[40.0, 90.0], multi_perspective=True,
                        training=3, clusters=24)
    pp = ProxyPass(volume, tf, 16, [])
    skin = [i for i in range(16) if p.edges[i + 1] <= 85 and p.edges[i] >= 20]
    fade = {i: 0.05 for i in skin}
    k = hv.proxy.proxies.as_scale(fade, 16)
    truth_fade = pp.run(p.camera.rays(p.size), k)[0].reshape(size, size, 4)
    turned = S.rotated_camera(p.camera, (30, 0))
    truth_turn = hv.render(volume, tf, turned, size, precision="float64", termination=0.0, progress_bar=False)
    panels = [
        ("reference render (proxies' own)", p.rgba),
        ("skin intervals x0.05: synthesised", p.synthesize(fade).rgba),
        ("... rendered", truth_fade),
        ("turned 30 deg: synthesised", p.synthesize(rotate=(30, 0)).rgba),
        ("... rendered", truth_turn.rgba),
        ("layers relit, proxy AO", p.synthesize(layers={0: ((0.95, 0.7, 0.55), 0.35), 1: ((1, 1, 0.95), 1.0)},
                                                light=hv.Light((1, -1, 1)), ambient_occlusion=1.0).rgba),
        ("layers turned 40 deg, relit", p.synthesize(layers={0: ((0.95, 0.7, 0.55), 0.35), 1: ((1, 1, 0.95), 1.0)},
                                                     light=hv.Light((1, -1, 1)), rotate=(40, 0)).rgba),
        ("depth-aware enhancement 0.5", p.synthesize(fade, enhance=0.5).rgba),
    ]
    fig, axes = plt.subplots(2, 4, figsize=(16, 8.6))
    fitted = hv.HDRImage(np.asarray(p.rgba, dtype=np.float32)).tonemap("reinhard").fitted
    for ax, (title, rgba) in zip(axes.ravel(), panels):
        img = hv.HDRImage(np.asarray(rgba, dtype=np.float32))
        ax.imshow(img.tonemap("reinhard", fitted=fitted).rgb8)
        ax.set_title(title, fontsize=11)
        ax.axis("off")
    fig.suptitle(f"CT head, {size}^2: proxies made in {p.info['seconds']:.0f} s; everything but the 'rendered' "
                 f"panels is synthesised from the proxy folder alone", fontsize=12)
    fig.tight_layout()
    OUT.mkdir(exist_ok=True)
    fig.savefig(OUT / "proxy_gallery.png", dpi=72)
    print(f"wrote {OUT / 'proxy_gallery.png'}")


if __name__ == "__main__":
    main()
