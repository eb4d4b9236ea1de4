"""Loading the plugin where ParaView's Python has no numba must not break ParaView.

Run by tests/integrations/test_paraview.py under pvbatch with a PYTHONPATH whose ``numba`` fails to
import. The plugin must load without an exception, say why in the output window, and
ParaView must go on working.
"""
import os

from paraview import simple

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def main():
    simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))
    assert not hasattr(simple, "HDRVolumeRender"), "filters were registered without numba"
    sphere = simple.Sphere()
    sphere.UpdatePipeline()
    assert sphere.GetDataInformation().GetNumberOfPoints() > 0
    print("ParaView works on", flush=True)


if __name__ == "__main__":
    from script_exit import run

    run(main)
