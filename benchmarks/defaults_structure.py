"""How much structure the default transfer function shows on the CT-like datasets,
against a function set by hand for each (issue 31, part 5b).

    python3 benchmarks/defaults_structure.py              # 256 x 256, isometric, unshaded and shaded
    python3 benchmarks/defaults_structure.py --size 128   # quicker

Structure is measured on the Reinhard display (``img.tonemap("reinhard").rgb``, sRGB
values in [0, 1]) as ``mean |grad L| / mean L`` over the covered pixels (alpha > 0.01),
``L`` the display's luminance (Rec. 709 weights) and ``grad`` numpy's central
differences in pixels: edges and texture inside the volume, relative to its brightness.
A uniform fog scores low, a picture of surfaces and their edges high. The hand-set
functions: engine, bonsai and CT head those of ``examples/plot_shading.py`` (the docs'
shading gallery); tooth and headsq set the same way here (background transparent, a
little opacity for the soft class, most for the dense one). The goal (issue 31): the
default reaches at least half the hand-set function's structure on every dataset.
Prints a markdown table, with the load average; no timing.
"""
import argparse
import os
import pathlib

import numpy as np

DATA = pathlib.Path(os.environ.get("PV_HDRVOL_DATA", pathlib.Path(__file__).resolve().parents[2] / "shared" / "data"))


def hand_set():
    import pv_hdrvol as hv

    return {
        "engine": ("structured/engine_256x256x128_uint8.vti", hv.TransferFunction(
            [0, 60, 120, 200, 255], [[0.9, 0.5, 0.3], [0.9, 0.5, 0.3], [0.95, 0.8, 0.6], [1, 1, 1], [1, 1, 1]],
            [0, 0, 0.03, 0.3, 0.8])),
        "bonsai": ("structured/bonsai_256x256x256_uint8.vti", hv.TransferFunction(
            [0, 40, 70, 150, 255], [[0.4, 0.8, 0.3], [0.4, 0.8, 0.3], [0.5, 0.9, 0.4], [0.8, 0.6, 0.4], [1, 1, 1]],
            [0, 0, 0.1, 0.5, 0.9])),
        "CT head": ("structured/ct_head_120x120x130_uint8.vtk", hv.TransferFunction(
            [0, 70, 90, 150, 255], [[0.9, 0.6, 0.5], [0.9, 0.6, 0.5], [0.95, 0.75, 0.65], [1, 1, 0.95], [1, 1, 1]],
            [0, 0, 0.04, 0.6, 0.9])),
        "tooth": ("structured/tooth_103x94x161_uint8.nrrd", hv.TransferFunction(
            [0, 100, 140, 175, 220, 255], [[0.9, 0.6, 0.5], [0.9, 0.6, 0.5], [0.95, 0.75, 0.65], [1, 0.95, 0.85],
                                           [1, 1, 1], [1, 1, 1]], [0, 0, 0.05, 0.3, 0.8, 0.9])),
        "headsq": ("structured/headsq_64x64x93_int16le.nhdr", hv.TransferFunction(
            [0, 900, 1200, 1600, 2500, 3926], [[0.9, 0.6, 0.5], [0.9, 0.6, 0.5], [0.95, 0.75, 0.65], [1, 1, 0.95],
                                               [1, 1, 1], [1, 1, 1]], [0, 0, 0.03, 0.4, 0.8, 0.9])),
    }


def structure(img):
    """``mean |grad L| / mean L`` of the Reinhard display over the covered pixels."""
    rgb = img.tonemap("reinhard").rgb.astype(np.float64)
    lum = rgb @ np.array([0.2126, 0.7152, 0.0722])
    covered = np.asarray(img.rgba[..., 3]) > 0.01
    gy, gx = np.gradient(lum)
    mean = lum[covered].mean() if covered.any() else 0.0
    return float(np.hypot(gx, gy)[covered].mean() / mean) if mean > 0 else 0.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--image", default=None, help="write default and hand-set pictures side by side (PNG)")
    args = parser.parse_args()
    import pyvista as pv

    import pv_hdrvol as hv
    from pv_hdrvol.raycast.grid import as_volume, default_transfer_function

    print(f"{args.size} x {args.size}, isometric, Reinhard; load {os.getloadavg()[0]:.2f}\n")
    print("| dataset | shading | default | hand-set | default / hand-set |")
    print("|---|---|---|---|---|")
    tiles = []
    worst = np.inf
    for name, (path, manual) in hand_set().items():
        volume = as_volume(pv.read(DATA / path))
        auto = default_transfer_function(volume)
        camera = hv.Camera.fit(volume.bounds, "iso")
        for shade in (False, True):
            images = [hv.render(volume, tf, camera, (args.size, args.size), shade=shade, progress_bar=False)
                      for tf in (auto, manual)]
            s_auto, s_hand = (structure(i) for i in images)
            worst = min(worst, s_auto / s_hand)
            print(f"| {name} | {'shaded' if shade else 'unshaded'} | {s_auto:.3f} | {s_hand:.3f} | "
                  f"{s_auto / s_hand:.2f} |")
            tiles.append(np.concatenate([i.tonemap("reinhard").rgb8 for i in images], axis=1))
    print(f"\nsmallest ratio: {worst:.2f} (goal: >= 0.5)")
    if args.image:
        import matplotlib.pyplot as plt

        rows = [np.concatenate(tiles[k:k + 2], axis=1) for k in range(0, len(tiles), 2)]
        plt.imsave(args.image, np.concatenate(rows, axis=0))
        print(f"wrote {args.image} (per row: unshaded default, hand-set; shaded default, hand-set)")


if __name__ == "__main__":
    main()
