"""The plugin in ParaView's GUI: ``paraview --script=gui_smoke.py`` under Xvfb, with
PV_PLUGIN_PATH and the shim from ``pv-hdrvol paraview`` (the plugin auto-loads).

Applies HDR Volume Render to engine in the GUI's render view, shows its tone-mapped
array, saves a screenshot to $PV_HDRVOL_SCREENSHOT and exits (the GUI stays open after
--script otherwise). Exit status 0 only when the filter ran and the screenshot shows it.
Run by tests/test_paraview.py.
"""
import os
import sys

from paraview import simple

try:
    data = os.environ["PV_HDRVOL_DATA"]
    shot = os.environ["PV_HDRVOL_SCREENSHOT"]
    assert hasattr(simple, "HDRVolumeRender"), "the plugin did not auto-load from PV_PLUGIN_PATH"
    reader = simple.OpenDataFile(os.path.join(data, "structured", "engine_256x256x128_uint8.vti"))
    view = simple.GetActiveViewOrCreate("RenderView")
    simple.Show(reader, view)
    simple.ResetCamera(view)
    render = simple.HDRVolumeRender(Input=reader, ImageSize=[200, 150])
    render.UpdatePipeline()
    error = render.GetClientSideObject().GetLastError()
    assert error is None, error
    assert list(render.CameraPosition) == list(view.CameraPosition), "the camera is not the view's"
    # show the image in the same view, as a user does after Apply: freeze the camera first
    render.FollowView = 0
    simple.Hide(reader, view)
    shown = simple.Show(render, view)
    simple.ColorBy(shown, ("POINTS", "tonemapped"))
    shown.MapScalars = 0  # the uint8 'tonemapped' array as colours
    view.InteractionMode = "2D"
    simple.ResetCamera(view)
    simple.Render(view)
    simple.SaveScreenshot(shot, view, ImageResolution=[400, 300])
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader

    png = vtkPNGReader()
    png.SetFileName(shot)
    png.Update()
    pixels = vtk_to_numpy(png.GetOutput().GetPointData().GetScalars())
    lit = float((pixels[:, :3].max(axis=1) > 40).mean())
    assert lit > 0.05, f"the screenshot is nearly black ({lit:.3f} of the pixels lit)"
    print(f"screenshot {shot}: {lit:.3f} of the pixels lit", flush=True)
    code = 0
except BaseException:
    import traceback

    traceback.print_exc()
    code = 1
sys.stdout.flush()
sys.stderr.flush()
os._exit(code)
