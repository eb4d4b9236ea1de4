"""How visible a volume is in a PyVista scene on white, grey and black, against
PyVista's own ``add_volume`` on the same data and camera (issue 31, part 1).

    python3 benchmarks/scene_visibility.py                       # engine, 400 x 300
    python3 benchmarks/scene_visibility.py --image docs/images/scene_backgrounds.png

For each background it shoots three pictures (no text, no axes, no scalar bar):

- ``ours``: ``plotter.hdrvol.add_volume(engine)`` (default transfer function, Reinhard),
  composited as premultiplied colour with coverage ``max(alpha, max T(C))``;
- ``ours (before)``: the same tone-mapped render composited as it was before issue 31,
  ``T(C) + (1 - alpha) background``, recomputed here from the actor's HDR image;
- ``ours, viridis``: ours with the default function's colours replaced by PyVista's
  default colormap (``raycast.grid.default_transfer_function(volume, cmap="viridis")``), to tell
  the compositing from the colours;
- ``add_volume``: PyVista's ``add_volume(engine)`` with its defaults (``viridis``,
  ``opacity="linear"``), VTK's GPU/OpenGL volume mapper.

and measures over the volume's footprint (pixels our render covers with alpha > 0.01,
the same for all three): ``visibility``, the mean distance of a pixel from the
background (mean |shot - background| over the channels, 8-bit levels), and ``shown``,
the fraction of footprint pixels at least 16 levels away from it. Not a speed
benchmark: no timing. Prints a markdown table.
"""
import argparse
import os
import pathlib

import numpy as np

BACKGROUNDS = {"white": 1.0, "grey": 0.5, "black": 0.0}
ENGINE = pathlib.Path(__file__).resolve().parents[2] / "shared" / "data" / "structured" / "engine_256x256x128_uint8.vti"


def _camera(pl):
    pl.view_isometric()
    pl.camera.zoom(1.3)


def _ours(grid, grey, size, tf=None):
    import pyvista as pv

    ours = pv.Plotter(off_screen=True, window_size=size)
    ours.background_color = (grey,) * 3
    actor = ours.hdrvol.add_volume(grid, tf, show_scalar_bar=False)
    _camera(ours)
    shot = ours.screenshot(return_img=True).astype(int)
    ours.close()
    return shot, actor


def shoot(grid, grey, size):
    import pyvista as pv

    import pv_hdrvol as hv
    from pv_hdrvol.raycast.grid import default_transfer_function

    shot, actor = _ours(grid, grey, size)
    rgb, alpha = actor._display  # the tone-mapped render composited above
    bg = round(grey * 255)
    before = np.round(np.clip(rgb + (1.0 - alpha[..., None]) * (bg / 255), 0, 1) * 255).astype(int)
    footprint = actor.hdr.rgba[..., 3] > 0.01
    viridis, _ = _ours(grid, grey, size, default_transfer_function(hv.volume_from_dataset(grid), cmap="viridis"))
    peer = pv.Plotter(off_screen=True, window_size=size)
    peer.background_color = (grey,) * 3
    peer.add_volume(grid, show_scalar_bar=False)
    _camera(peer)
    theirs = peer.screenshot(return_img=True).astype(int)
    peer.close()
    return {"ours": shot, "ours (before)": before, "ours, viridis": viridis, "add_volume": theirs}, footprint, bg


def measure(pictures, footprint, bg):
    out = {}
    for name, picture in pictures.items():
        distance = np.abs(picture[footprint] - bg).mean(axis=-1)
        out[name] = (float(distance.mean()), float((distance >= 16).mean()))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", default=str(ENGINE))
    parser.add_argument("--size", type=int, nargs=2, default=(400, 300))
    parser.add_argument("--image", default=None, help="write the pictures as one PNG (rows: backgrounds)")
    args = parser.parse_args()
    import pyvista as pv

    import pv_hdrvol  # noqa: F401  (registers plotter.hdrvol)

    grid = pv.read(args.data)
    print(f"{pathlib.Path(args.data).name}, {args.size[0]} x {args.size[1]}, pyvista {pv.__version__}, "
          f"load {os.getloadavg()[0]:.2f}\n")
    print("| background | ours: visibility | shown | ours before: visibility | shown | ours, viridis: visibility "
          "| shown | add_volume: visibility | shown |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows = []
    for name, grey in BACKGROUNDS.items():
        pictures, footprint, bg = shoot(grid, grey, tuple(args.size))
        m = measure(pictures, footprint, bg)
        print(f"| {name} | " + " | ".join(f"{m[k][0]:.1f} | {100 * m[k][1]:.0f} %"
                                          for k in pictures) + " |")
        rows.append(np.concatenate(list(pictures.values()), axis=1))
    if args.image:
        import matplotlib.pyplot as plt

        plt.imsave(args.image, np.concatenate(rows, axis=0).astype(np.uint8))
        print(f"\nwrote {args.image} (rows: white, grey, black; columns: ours, ours before, ours with viridis, add_volume)")


if __name__ == "__main__":
    main()
