"""Inside pvbatch: what a turn of the render view costs with HDR Volume Render shown in
it (the 'In View' output, the image size following the view's), against ``hv.render``
of the same data, transfer function, camera and size in the same process.

    xvfb-run -a pvbatch benchmarks/paraview_turn.py [DATA_ROOT] [WIDTH HEIGHT]

with ``pv-hdrvol paraview``'s environment. Each of 7 turns: the view's camera turned by
20 degrees and one ``Render`` (the filter re-executes for the new camera inside it: the
links update its camera, the view updates its representations), then ``hv.render``
with that camera. Prints the medians, their ratio and the load average.
"""
import os
import statistics
import sys
import time

from paraview import simple

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def main(data_root, width, height, turns=7):
    import pv_hdrvol as hv
    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))
    path = os.path.join(data_root, "structured", "engine_256x256x128_uint8.vti")
    reader = simple.OpenDataFile(path)
    reader.UpdatePipeline()
    view = simple.CreateView("RenderView")
    view.ViewSize = [width, height]
    simple.SetActiveView(view)
    simple.Show(reader, view)
    simple.ResetCamera(view)
    render = simple.HDRVolumeRender(Input=reader)
    simple.Show(simple.OutputPort(render, 1), view)
    simple.Render(view)  # the first render (numba's cache loaded)
    assert list(render.ImageSize) == [width, height]
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    local = vtkXMLImageDataReader()
    local.SetFileName(path)
    local.Update()
    tf = transfer_function_from_vtk(render.LookupTable.GetClientSideObject(),
                                    render.ScalarOpacityFunction.GetClientSideObject())
    in_view, direct = [], []
    for _ in range(turns):
        view.GetActiveCamera().Azimuth(20)
        t = time.perf_counter()
        simple.Render(view)
        in_view.append(time.perf_counter() - t)
        assert list(render.CameraPosition) == list(view.CameraPosition)
        camera = hv.Camera(position=tuple(view.CameraPosition), focal_point=tuple(view.CameraFocalPoint),
                           view_up=tuple(view.CameraViewUp), view_angle=view.CameraViewAngle)
        t = time.perf_counter()
        hv.render(local.GetOutput(), tf, camera, (width, height), scalars="ImageFile", progress_bar=False)
        direct.append(time.perf_counter() - t)
    a, b = statistics.median(in_view), statistics.median(direct)
    print(f"engine {width}x{height}: a turn in the view {a:.3f} s (render and display), hv.render {b:.3f} s, "
          f"ratio {a / b:.2f}; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    root = args[0] if args else os.path.join(os.path.dirname(ROOT), "shared", "data")
    size = (int(args[1]), int(args[2])) if len(args) >= 3 else (844, 279)
    main(root, *size)
