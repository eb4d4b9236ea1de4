"""HDR Volume Render looks like ParaView's own Volume representation by default: the
same colour map (Cool to Warm), opacity ramp, Scalar Opacity Unit Distance and camera
give the same colours where nothing exceeds the display range.

Measured as a person compares two pictures: mean CIELAB Delta E over the pixels either
covers, and the ratio of mean chroma (a paler picture has less), between ParaView's
screenshot of its Volume representation and the ``tonemapped`` array the filter shows
(its default Display Tone Map). benchmarks/paraview_colours.py prints the same numbers
for other displays.

Run by tests/paraview/run.py inside pvbatch (see there); not collected by the main suite.
"""
import os
import tempfile

import numpy as np
import pytest
from paraview import servermanager, simple

import pv_hdrvol as hv
from pv_hdrvol.image.display import screen_lab

SIZE = 128
CASES = {"ct_head": ("structured", "ct_head_120x120x130_uint8.vtk", "nrrd94920"),
         "bluntfin": ("unstructured", "bluntfin_187395tets.vtu", "Density")}


def _screenshot(view):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "view.png")
        simple.SaveScreenshot(path, view, ImageResolution=[SIZE, SIZE], TransparentBackground=0)
        reader = vtkPNGReader()
        reader.SetFileName(path)
        reader.Update()
        image = reader.GetOutput()
        cols, rows, _ = image.GetDimensions()
        return vtk_to_numpy(image.GetPointData().GetScalars()).reshape(rows, cols, -1)[::-1, :, :3] / 255.0


@pytest.mark.parametrize("case", sorted(CASES))
def test_default_display_has_paraviews_colours(plugin, shared_data, case):
    folder, name, array = CASES[case]
    reader = simple.OpenDataFile(str(shared_data / folder / name))
    reader.UpdatePipeline()
    view = simple.CreateView("RenderView")
    view.ViewSize = [SIZE, SIZE]
    view.OrientationAxesVisibility = 0
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    view.Background = [0.0, 0.0, 0.0]
    display = simple.Show(reader, view)
    simple.ColorBy(display, ("POINTS", array))
    display.SetRepresentationType("Volume")
    display.RescaleTransferFunctionToDataRange(True, False)
    camera = hv.Camera.fit(reader.GetDataInformation().GetBounds(), "iso")
    active = view.GetActiveCamera()
    active.SetPosition(*camera.position)
    active.SetFocalPoint(*camera.focal_point)
    active.SetViewUp(*camera.view_up)
    active.SetViewAngle(camera.view_angle)
    simple.Render(view)
    paraview = _screenshot(view)

    render = plugin["HDRVolumeRender"](Input=reader, FollowView=0, ImageSize=[SIZE, SIZE],
                                       LookupTable=simple.GetColorTransferFunction(array),
                                       ScalarOpacityFunction=simple.GetOpacityTransferFunction(array),
                                       OpacityUnitDistance=display.ScalarOpacityUnitDistance)
    render.Scalars = ["POINTS", array]
    render.CameraPosition = list(camera.position)
    render.CameraFocalPoint = list(camera.focal_point)
    render.CameraViewUp = list(camera.view_up)
    render.CameraViewAngle = camera.view_angle
    assert render.DisplayToneMap == "knee"
    out = servermanager.Fetch(render)
    from vtkmodules.util.numpy_support import vtk_to_numpy

    shown = vtk_to_numpy(out.GetPointData().GetArray("tonemapped")).reshape(SIZE, SIZE, 3)[::-1] / 255.0
    alpha = vtk_to_numpy(out.GetPointData().GetArray("rgba"))[:, 3].reshape(SIZE, SIZE)[::-1]
    covered = (alpha > 0.02) | (paraview.max(axis=-1) > 5 / 255)
    assert covered.mean() > 0.2
    lab, lab_paraview = screen_lab(shown), screen_lab(paraview)
    delta_e = float(np.linalg.norm(lab - lab_paraview, axis=-1)[covered].mean())
    chroma = float(np.hypot(lab[..., 1], lab[..., 2])[covered].mean()
                   / np.hypot(lab_paraview[..., 1], lab_paraview[..., 2])[covered].mean())
    # measured 1.6 / 0.99 (CT head) and 4.2 / 1.04 (Blunt Fin) at 256^2; the display
    # before knee (reinhard, sRGB): 31.0 / 0.62 and 29.7 / 0.58
    assert delta_e <= 12.0 and chroma >= 0.8, (delta_e, chroma)
    simple.Delete(render)
    simple.Delete(display)
    simple.Delete(view)
    simple.Delete(reader)
