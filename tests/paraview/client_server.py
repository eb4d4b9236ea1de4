"""HDR Volume Render in client-server mode: ``pvpython client_server.py PORT`` against a
``pvserver --server-port=PORT`` on this machine (both with the plugin's environment).

The plugin is loaded on both sides (the filter runs on the server, the links and the
colour map are set by the client); the filter takes the array's colour map and the
view's camera, and the image fetched to the client equals ``pv_hdrvol.render`` of the
file with that colour map. Exits non-zero on failure. Run by tests/integrations/test_paraview.py.
"""
import os
import sys

import numpy as np
from paraview import servermanager, simple

import pv_hdrvol as hv
from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def main(port):
    connection = simple.Connect("localhost", port)
    assert connection is not None and connection.IsRemote(), "not connected to the pvserver"
    plugin = os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py")
    simple.LoadPlugin(plugin, remote=True, ns=vars(simple))
    simple.LoadPlugin(plugin, remote=False, ns=vars(simple))
    name = os.path.join(os.environ["PV_HDRVOL_DATA"], "structured", "engine_256x256x128_uint8.vti")
    reader = simple.XMLImageDataReader(FileName=[name])
    reader.UpdatePipeline()
    view = simple.CreateView("RenderView")
    view.ViewSize = [48, 40]
    simple.SetActiveView(view)
    simple.Show(reader, view)
    simple.ResetCamera(view)
    render = simple.HDRVolumeRender(Input=reader)
    lut, pwf = simple.GetColorTransferFunction("ImageFile"), simple.GetOpacityTransferFunction("ImageFile")
    assert render.LookupTable == lut, render.LookupTable
    assert list(render.CameraPosition) == list(view.CameraPosition)
    assert list(render.ImageSize) == [48, 40]
    image = hv.HDRImage.from_pyvista(servermanager.Fetch(render))
    # the same file read here, rendered with the colour map's function and the view's camera
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    local = vtkXMLImageDataReader()
    local.SetFileName(name)
    local.Update()
    camera = hv.Camera(position=tuple(view.CameraPosition), focal_point=tuple(view.CameraFocalPoint),
                       view_up=tuple(view.CameraViewUp), view_angle=view.CameraViewAngle)
    tf = transfer_function_from_vtk(lut.GetClientSideObject(), pwf.GetClientSideObject())
    expected = hv.render(local.GetOutput(), tf, camera, (48, 40), scalars="ImageFile", progress_bar=False)
    assert image.rgba[..., 3].max() > 0.05
    np.testing.assert_array_equal(image.rgba, expected.rgba)
    view.GetActiveCamera().Azimuth(40)
    simple.Render(view)
    turned = hv.HDRImage.from_pyvista(servermanager.Fetch(render))
    assert list(render.CameraPosition) == list(view.CameraPosition)
    assert not np.array_equal(turned.rgba, image.rgba)
    print("client-server: the array's colour map and the view's camera; the image equals hv.render", flush=True)
    simple.Disconnect()


if __name__ == "__main__":
    from script_exit import run

    run(main, int(sys.argv[1]))
