"""A state loaded after Reset Session follows its view: ``pvbatch reset_session.py DIR``
(plugin on PV_PLUGIN_PATH, engine from $PV_HDRVOL_DATA). A new session numbers its
proxies from the start again, and Load State replaces the view the session began with;
the filter must follow the state's view, keep its saved Image Size until that view
changes, then follow its size and camera. Run by tests/integrations/test_paraview.py."""
import os
import sys

from paraview import simple


def main(folder):
    assert hasattr(simple, "HDRVolumeRender"), "the plugin did not auto-load from PV_PLUGIN_PATH"
    reader = simple.OpenDataFile(os.path.join(os.environ["PV_HDRVOL_DATA"], "structured",
                                              "engine_256x256x128_uint8.vti"))
    view = simple.CreateView("RenderView")
    view.ViewSize = [300, 173]
    simple.SetActiveView(view)
    simple.Show(reader, view)
    simple.ResetCamera(view)
    render = simple.HDRVolumeRender(Input=reader)
    simple.Show(simple.OutputPort(render, 1), view)
    simple.Render(view)
    assert list(render.ImageSize) == [300, 173] and render.ImageSizeFollowsView == 1
    state = os.path.join(folder, "saved.pvsm")
    simple.SaveState(state)

    simple.ResetSession()
    simple.LoadState(state)
    view, render = simple.GetActiveView(), simple.FindSource("HDRVolumeRender1")
    simple.Render(view)
    assert list(render.ImageSize) == [300, 173], list(render.ImageSize)  # as saved
    view.ViewSize = [400, 300]
    view.GetActiveCamera().Azimuth(40)
    simple.Render(view)
    camera = view.GetActiveCamera()
    assert list(render.ImageSize) == [400, 300], list(render.ImageSize)  # the state's view, resized
    assert list(render.CameraPosition) == list(camera.GetPosition()), (list(render.CameraPosition),
                                                                       camera.GetPosition())
    print("followed the state's view after Reset Session", flush=True)


if __name__ == "__main__":
    from script_exit import run

    run(main, sys.argv[1])
