"""ParaView's own Volume representation beside HDR Volume Render, for comparing their
colours (tests/paraview/pv_colours.py, benchmarks/paraview_colours.py): both inside
pvbatch, ParaView's defaults (the array's colour map rescaled to the data, the opacity
ramp, the representation's Scalar Opacity Unit Distance), a black background, one
camera. Not a check itself (no ``pv_`` prefix: run.py does not collect it)."""
import os
import tempfile

import numpy as np
from paraview import servermanager, simple


def volume_screenshot(reader, array, camera, size):
    """``(view, display, pixels)``: a render view of ``size`` x ``size`` showing
    ``array`` of ``reader`` as ParaView's Volume representation from ``camera`` (a
    pv_hdrvol Camera), and its screenshot as display values in [0, 1], row 0 at the top."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader

    view = simple.CreateView("RenderView")
    view.ViewSize = [size, size]
    view.OrientationAxesVisibility = 0
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    view.Background = [0.0, 0.0, 0.0]
    display = simple.Show(reader, view)
    simple.ColorBy(display, ("POINTS", array))
    display.SetRepresentationType("Volume")
    display.RescaleTransferFunctionToDataRange(True, False)
    active = view.GetActiveCamera()
    active.SetPosition(*camera.position)
    active.SetFocalPoint(*camera.focal_point)
    active.SetViewUp(*camera.view_up)
    active.SetViewAngle(camera.view_angle)
    view.CenterOfRotation = list(camera.focal_point)
    simple.Render(view)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "view.png")
        simple.SaveScreenshot(path, view, ImageResolution=[size, size], TransparentBackground=0)
        png = vtkPNGReader()
        png.SetFileName(path)
        png.Update()
        image = png.GetOutput()
        cols, rows, _ = image.GetDimensions()
        pixels = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(rows, cols, -1)[::-1, :, :3] / 255.0
    return view, display, pixels


def filter_display(make_filter, reader, array, display, camera, size):
    """``(shown, alpha)``: what HDR Volume Render (made by ``make_filter``, the proxy's
    constructor) shows with its default Display Tone Map for ``camera``, the array's
    colour map and ``display``'s unit distance: its ``tonemapped`` array as display
    values in [0, 1] and its alpha, rows top first. The filter is deleted again."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    render = make_filter(Input=reader, FollowView=0, ImageSize=[size, size],
                         LookupTable=simple.GetColorTransferFunction(array),
                         ScalarOpacityFunction=simple.GetOpacityTransferFunction(array),
                         OpacityUnitDistance=display.ScalarOpacityUnitDistance)
    render.Scalars = ["POINTS", array]
    render.CameraPosition = list(camera.position)
    render.CameraFocalPoint = list(camera.focal_point)
    render.CameraViewUp = list(camera.view_up)
    render.CameraViewAngle = camera.view_angle
    assert render.DisplayToneMap == "knee", render.DisplayToneMap
    data = servermanager.Fetch(render).GetPointData()
    shown = vtk_to_numpy(data.GetArray("tonemapped")).reshape(size, size, 3)[::-1] / 255.0
    alpha = vtk_to_numpy(data.GetArray("rgba"))[:, 3].reshape(size, size)[::-1].astype(np.float64)
    simple.Delete(render)
    return shown, alpha
