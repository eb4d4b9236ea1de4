"""How far the shown colours of a render are from VTK's volume mapper's, in CIELAB.

ParaView's Volume representation (and VTK's volume mappers) composite the colour map's
values front to back and write them to the 8-bit window as they are: no sRGB encoding,
no exposure (``tests/integrations/test_vtk_compare.py`` measured this: a pixel is
``round(255 * C)``). A display that encodes pv_hdrvol's linear image for the screen
(sRGB) or fits an exposure to it (Reinhard's key) shows the same colour map paler. This
script renders a CT volume with VTK's ``vtkFixedPointVolumeRayCastMapper`` and with
``hv.render`` (same camera, colour map, opacity function, opacity unit distance and
sample distance), then shows the HDR image through candidate displays and reports, over
the pixels either covers, the mean CIE76 colour difference to VTK's screenshot and the
ratio of their mean CIELAB chroma:

    python3 benchmarks/display_colours.py                 # engine and CT head, 256^2
    python3 benchmarks/display_colours.py --size 128 --data engine

The colour map is ParaView's default, "Cool to Warm" (Moreland's diverging map between
(0.230, 0.299, 0.754) and (0.706, 0.016, 0.150) in VTK's diverging colour space), and the
opacity ParaView's default ramp from 0 at the data's minimum to 1 at its maximum.
Offscreen VTK rendering: see tests/offscreen.py.
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

FILES = {"engine": "structured/engine_256x256x128_uint8.vti", "ct_head": "structured/ct_head_120x120x130_uint8.vtk"}
STEP = 0.5  # of the smallest spacing, both renderers


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", nargs="+", choices=sorted(FILES), default=sorted(FILES))
    ap.add_argument("--size", type=int, default=256)
    args = ap.parse_args(argv)
    from offscreen import require_offscreen_vtk, vtk_volume_screenshot

    require_offscreen_vtk()
    import pyvista as pv
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

    import pv_hdrvol as hv
    from pv_hdrvol.image.display import colour_difference
    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    data_root = Path(os.environ.get("PV_HDRVOL_DATA", ROOT.parent / "shared" / "data"))
    print(f"# display colours against vtkFixedPointVolumeRayCastMapper, {args.size}^2, Cool to Warm, "
          f"ParaView's default opacity ramp; load {os.getloadavg()[0]:.2f}\n")
    print("| data | display | mean CIELAB Delta E | chroma / VTK's |")
    print("|---|---|--:|--:|")
    for name in args.data:
        ds = pv.read(data_root / FILES[name])
        lo, hi = ds.get_data_range()
        ctf = vtkColorTransferFunction()
        ctf.SetColorSpaceToDiverging()
        ctf.AddRGBPoint(lo, 0.231373, 0.298039, 0.752941)
        ctf.AddRGBPoint(hi, 0.705882, 0.0156863, 0.14902)
        otf = vtkPiecewiseFunction()
        otf.AddPoint(lo, 0.0)
        otf.AddPoint(hi, 1.0)
        unit = float(min(ds.spacing))
        camera = hv.Camera.fit(ds, "iso")
        reference = vtk_volume_screenshot(ds, camera, ctf, otf, unit, STEP * unit, args.size).astype(np.float64)

        tf = transfer_function_from_vtk(ctf, otf)
        image = hv.render(ds, tf, camera, args.size, step=STEP, opacity_unit_distance=unit, precision="float32",
                          progress_bar=False)
        mask = (image.rgba[..., 3] > 0.02) | (reference.max(axis=-1) > 5)
        displays = {
            "knee (HDR Volume Render's default display)": hv.tonemap(image, "knee").rgb,
            "reinhard, sRGB (HDR Volume Render's display before knee)": hv.tonemap(image, "reinhard").rgb,
            "linear, auto exposure, sRGB": hv.tonemap(image, "linear").rgb,
            "linear, exposure 0, sRGB": hv.tonemap(image, "linear", exposure_stops=0.0).rgb,
            "linear, exposure 0, no encoding (VTK's)": hv.tonemap(image, "linear", exposure_stops=0.0,
                                                                   encoding="linear").rgb,
        }
        for label, rgb in displays.items():
            de, chroma = colour_difference(rgb, reference / 255.0, mask)
            print(f"| {name} | {label} | {de:.1f} | {chroma:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
