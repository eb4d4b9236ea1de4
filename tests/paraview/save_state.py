"""Save a ParaView state with HDR Volume Render shown in a render view, as a pvbatch
user would: ``pvbatch save_state.py OUT.pvsm`` (plugin on PV_PLUGIN_PATH, engine from
$PV_HDRVOL_DATA). tests/integrations/test_paraview.py loads it in the GUI."""
import os
import sys

from paraview import simple


def main(out):
    assert hasattr(simple, "HDRVolumeRender"), "the plugin did not auto-load from PV_PLUGIN_PATH"
    reader = simple.OpenDataFile(os.path.join(os.environ["PV_HDRVOL_DATA"], "structured",
                                              "engine_256x256x128_uint8.vti"))
    view = simple.GetActiveViewOrCreate("RenderView")
    view.ViewSize = [600, 400]
    simple.Show(reader, view)
    simple.ResetCamera(view)
    view.GetActiveCamera().Elevation(20)
    render = simple.HDRVolumeRender(Input=reader)
    assert render.LookupTable is not None, "the filter did not take the array's colour map"
    simple.Show(simple.OutputPort(render, 1), view)
    simple.Render(view)
    simple.SaveState(out)
    print(f"saved {out}", flush=True)


if __name__ == "__main__":
    from script_exit import run

    run(main, sys.argv[1])
