"""HDR Volume Render looks like ParaView's own Volume representation by default: the
same colour map (Cool to Warm), opacity ramp, Scalar Opacity Unit Distance and camera
give the same colours where nothing exceeds the display range.

Measured as a person compares two pictures: mean CIELAB Delta E over the pixels either
covers, and the ratio of mean chroma (a paler picture has less), between ParaView's
screenshot of its Volume representation and the ``tonemapped`` array the filter shows
(its default Display Tone Map), both made by paraview_volume.py here.
benchmarks/paraview_colours.py prints the same numbers for other displays.

Run by tests/paraview/run.py inside pvbatch (see there); not collected by the main suite.
"""
import pytest
from paraview import simple

import pv_hdrvol as hv
from pv_hdrvol.image.display import colour_difference
from paraview_volume import filter_display, volume_screenshot

SIZE = 128
CASES = {"ct_head": ("structured", "ct_head_120x120x130_uint8.vtk", "nrrd94920"),
         "bluntfin": ("unstructured", "bluntfin_187395tets.vtu", "Density")}


@pytest.mark.parametrize("case", sorted(CASES))
def test_default_display_has_paraviews_colours(plugin, shared_data, case):
    folder, name, array = CASES[case]
    reader = simple.OpenDataFile(str(shared_data / folder / name))
    reader.UpdatePipeline()
    camera = hv.Camera.fit(reader.GetDataInformation().GetBounds(), "iso")
    view, display, paraview = volume_screenshot(reader, array, camera, SIZE)
    shown, alpha = filter_display(plugin["HDRVolumeRender"], reader, array, display, camera, SIZE)
    covered = (alpha > 0.02) | (paraview.max(axis=-1) > 5 / 255)
    assert covered.mean() > 0.2
    delta_e, chroma = colour_difference(shown, paraview, covered)
    # measured 1.6 / 0.99 (CT head) and 4.2 / 1.04 (Blunt Fin) at 256^2; the display
    # before knee (reinhard, sRGB): 31.0 / 0.62 and 29.7 / 0.58
    assert delta_e <= 12.0 and chroma >= 0.8, (delta_e, chroma)
    simple.Delete(display)
    simple.Delete(view)
    simple.Delete(reader)
