"""An orbit and a transfer-function sweep as OpenEXR sequences, from pvbatch.

    eval "$(pv-hdrvol paraview)"
    xvfb-run -a pvbatch examples/pvbatch_sweep.py [FILE] [--array NAME] [--frames 24] [-o sweep]

Renders ``--frames`` views around the volume (the render view's camera turned by
``Azimuth``, which HDR Volume Render follows), then the same number of frames with the
global opacity swept over four decades, into ``OUT/orbit_0000.exr ...`` and
``OUT/opacity_0000.exr ...``. ``pv_hdrvol.write_movie`` or ``pv-hdrvol info`` read them
back in plain Python. Each frame is one property change and one ``SaveData``: the
filter re-executes, the volume's bricks are kept between frames.
"""
import argparse
import os

from paraview import simple

from pvpython_render import open_volume


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", help="a volume ParaView reads (default: the hydrogen orbital)")
    parser.add_argument("--array", help="point array to render (default: the file's first)")
    parser.add_argument("--frames", type=int, default=24)
    parser.add_argument("--size", type=int, nargs=2, default=(256, 256), metavar=("W", "H"))
    parser.add_argument("-o", "--output", default="sweep", help="folder for the two sequences")
    args = parser.parse_args()
    os.makedirs(args.output, exist_ok=True)

    reader, array = open_volume(args.file, args.array)
    view = simple.GetActiveViewOrCreate("RenderView")
    simple.Show(reader, view)
    simple.ResetCamera(view)

    render = simple.HDRVolumeRender(Input=reader, ImageSize=list(args.size), TransferFunction="pv_hdrvol default")
    render.Scalars = ["POINTS", array]
    for i in range(args.frames):
        simple.SaveData(os.path.join(args.output, f"orbit_{i:04d}.exr"), proxy=render)
        view.GetActiveCamera().Azimuth(360.0 / args.frames)
        simple.Render(view)
    for i in range(args.frames):
        render.GlobalAlpha = 10.0 ** (-4.0 * (1 - i / max(args.frames - 1, 1)))
        simple.SaveData(os.path.join(args.output, f"opacity_{i:04d}.exr"), proxy=render)
    print(f"wrote {2 * args.frames} frames into {args.output}/")


if __name__ == "__main__":
    main()
