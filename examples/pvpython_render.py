"""HDR volume rendering in a ParaView script (pvpython or pvbatch).

    eval "$(pv-hdrvol paraview)"                  # the plugin and ParaView 5.11's shim
    pvbatch examples/pvpython_render.py           # the hydrogen 3d_z2 orbital (47 decades)
    pvbatch examples/pvpython_render.py engine.vti --array ImageFile -o engine.exr

Loads the plugin, reads a volume, colours it in a render view with a ParaView preset on a
log scale, and applies **HDR Volume Render**: it takes that view's camera (and follows
it) and that array's colour map and opacity, the ones the Color Map Editor shows. The
HDR image goes to an OpenEXR file (ParaView's Python needs the OpenEXR package:
docs/paraview.md), the tone-mapped one to a PNG. Debian's ParaView renders only under X:
run pvbatch under ``xvfb-run -a`` on a machine without a display.
"""
import argparse
import os
import tempfile

from paraview import simple

HERE = os.path.dirname(os.path.abspath(__file__))
PLUGIN = os.path.join(os.path.dirname(HERE), "paraview_plugin", "pv_hdrvol_plugin.py")


def demo_volume(folder):
    """The hydrogen orbital of ``pv-hdrvol demo`` as a .vti file (ParaView reads files)."""
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData
    from vtkmodules.vtkIOXML import vtkXMLImageDataWriter

    from pv_hdrvol.datasets import ARRAY_NAME, hydrogen_orbital_array

    values, spacing, origin = hydrogen_orbital_array(3, 2, 0, size=64)
    image = vtkImageData()
    image.SetDimensions(*values.shape[::-1])
    image.SetSpacing(*spacing)
    image.SetOrigin(*origin)
    array = numpy_to_vtk(values.reshape(-1), deep=True)
    array.SetName(ARRAY_NAME)
    image.GetPointData().SetScalars(array)
    path = os.path.join(folder, "hydrogen_3d_z2.vti")
    writer = vtkXMLImageDataWriter()
    writer.SetFileName(path)
    writer.SetInputData(image)
    writer.Write()
    return path, ARRAY_NAME


def open_volume(path=None, array=None):
    """Load the plugin (unless PV_PLUGIN_PATH did), read ``path`` (default: the hydrogen
    orbital) and return ``(reader, array name)`` (default: its first point array)."""
    if not hasattr(simple, "HDRVolumeRender"):  # not auto-loaded from PV_PLUGIN_PATH
        simple.LoadPlugin(PLUGIN, ns=vars(simple))
    if path is None:
        path, array = demo_volume(tempfile.mkdtemp())
    reader = simple.OpenDataFile(path)
    reader.UpdatePipeline()
    return reader, array or reader.PointData.keys()[0]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", help="a volume ParaView reads (default: the hydrogen orbital)")
    parser.add_argument("--array", help="point array to render (default: the file's first)")
    parser.add_argument("-o", "--output", default="pvpython_render.exr", help="HDR image (.exr or .hdr)")
    parser.add_argument("--size", type=int, nargs=2, default=(512, 512), metavar=("W", "H"))
    args = parser.parse_args()

    reader, array = open_volume(args.file, args.array)
    lo, hi = reader.PointData[array].GetRange()

    # what a GUI user does: show the data, colour it, pick a preset and a log scale
    view = simple.GetActiveViewOrCreate("RenderView")
    view.ViewSize = list(args.size)
    display = simple.Show(reader, view)
    simple.ColorBy(display, ("POINTS", array))
    simple.ResetCamera(view)
    lut = simple.GetColorTransferFunction(array)
    opacity = simple.GetOpacityTransferFunction(array)
    lut.ApplyPreset("Inferno (matplotlib)", True)
    if lo <= 0 or hi / lo > 1e3:  # many decades: a log axis over the top ten
        low = hi * 1e-10 if lo <= 0 else lo
        lut.RescaleTransferFunction(low, hi)
        opacity.RescaleTransferFunction(low, hi)
        lut.UseLogScale = 1
        opacity.UseLogScale = 1
        # pv-hdrvol demo's opacities, spread evenly over the ten decades
        opacity.Points = [low, 0.0, 0.5, 0.0, hi * 10 ** (-20 / 3), 0.005, 0.5, 0.0,
                          hi * 10 ** (-10 / 3), 0.02, 0.5, 0.0, hi, 0.1, 0.5, 0.0]

    # the filter takes the view's camera and the array's colour map by itself
    render = simple.HDRVolumeRender(Input=reader, ImageSize=list(args.size))
    render.Scalars = ["POINTS", array]
    view.GetActiveCamera().Elevation(20)  # the render follows the view
    simple.Render(view)
    simple.SaveData(args.output, proxy=render)
    simple.SaveData(os.path.splitext(args.output)[0] + ".png", proxy=render)  # the tone-mapped array
    print(f"wrote {args.output} and {os.path.splitext(args.output)[0]}.png ({args.size[0]}x{args.size[1]}, "
          f"{array} over [{lo:.3g}, {hi:.3g}])")


if __name__ == "__main__":
    main()
