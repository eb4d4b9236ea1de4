"""Inside pvbatch: the colours of ParaView's own Volume representation against displays
of ``hv.render``'s HDR image, in CIELAB (the companion of ``display_colours.py``, which
compares with VTK's CPU mapper outside ParaView).

ParaView's defaults throughout: the array's colour map (Cool to Warm) and opacity ramp
rescaled to the data range, the representation's Scalar Opacity Unit Distance, a black
background, the same camera (``hv.Camera.fit(bounds, "iso")`` set on the view). The HDR
image is rendered in the same process with the transfer function read from ParaView's
colour map (``transfer_function_from_vtk``) and that unit distance, then shown through
each candidate display; the first row is HDR Volume Render itself (the plugin's filter
given the array's colour map, that unit distance and the view's camera, its default
Display Tone Map, the ``tonemapped`` array it shows); the table gives the mean CIE76 difference over the pixels either
image covers and the ratio of mean chroma:

    PYTHONPATH=paraview_plugin/shim:.:.paraview-site xvfb-run -a -s '-screen 0 1280x1024x24' \\
        pvbatch benchmarks/paraview_colours.py [--size 256] [--data engine bluntfin ct_head]

(The PYTHONPATH gives ParaView's Python pv_hdrvol and the packages of
``PV_HDRVOL_PARAVIEW_SITE``, as tests/integrations/test_paraview.py does.)
"""
import argparse
import os
import sys

from paraview import servermanager, simple

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "tests", "paraview"))  # paraview_volume: the same views as the check
DATA = {"engine": ("structured/engine_256x256x128_uint8.vti", "ImageFile"),
        "ct_head": ("structured/ct_head_120x120x130_uint8.vtk", "nrrd94920"),
        "bluntfin": ("unstructured/bluntfin_187395tets.vtu", "Density")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", nargs="+", choices=sorted(DATA), default=["ct_head", "engine", "bluntfin"])
    ap.add_argument("--size", type=int, default=256)
    args = ap.parse_args(argv)
    simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))

    import pv_hdrvol as hv
    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk
    from paraview_volume import filter_display, volume_screenshot

    from pv_hdrvol.image.display import colour_difference

    data_root = os.environ.get("PV_HDRVOL_DATA", os.path.join(os.path.dirname(ROOT), "shared", "data"))
    print(f"# ParaView {servermanager.vtkSMProxyManager.GetParaViewSourceVersion()}: Volume representation against "
          f"hv.render's displays, {args.size}^2, Cool to Warm, the default opacity ramp; load "
          f"{os.getloadavg()[0]:.2f}\n")
    print("| data | display | mean CIELAB Delta E | chroma / ParaView's |")
    print("|---|---|--:|--:|")
    for name in args.data:
        path, array = DATA[name]
        reader = simple.OpenDataFile(os.path.join(data_root, path))
        reader.UpdatePipeline()
        camera = hv.Camera.fit(reader.GetDataInformation().GetBounds(), "iso")
        view, display, reference = volume_screenshot(reader, array, camera, args.size)
        lut = simple.GetColorTransferFunction(array)
        pwf = simple.GetOpacityTransferFunction(array)
        unit = float(display.ScalarOpacityUnitDistance)
        tf = transfer_function_from_vtk(lut.GetClientSideObject(), pwf.GetClientSideObject())
        data = servermanager.Fetch(reader)
        image = hv.render(data, tf, camera, args.size, scalars=array, opacity_unit_distance=unit, progress_bar=False)
        mask = (image.rgba[..., 3] > 0.02) | (reference.max(axis=-1) > 5 / 255)
        displays = {
            "HDR Volume Render, its default display (knee)": filter_display(simple.HDRVolumeRender, reader, array,
                                                                            display, camera, args.size)[0],
            "knee (hv.tonemap default encoding: none)": hv.tonemap(image, "knee").rgb,
            "reinhard, sRGB (the filter's display before knee)": hv.tonemap(image, "reinhard").rgb,
            "linear, exposure 0, sRGB": hv.tonemap(image, "linear", exposure_stops=0.0).rgb,
            "linear, exposure 0, no encoding": hv.tonemap(image, "linear", exposure_stops=0.0, encoding="linear").rgb,
        }
        for label, rgb in displays.items():
            de, chroma = colour_difference(rgb, reference, mask)
            print(f"| {name} | {label} | {de:.1f} | {chroma:.2f} |", flush=True)
        simple.Delete(view)
    return 0


if __name__ == "__main__":
    main(sys.argv[1:])
