"""Loading the plugin where ParaView's Python has no numba must not break ParaView.

Run by tests/test_paraview.py under pvbatch with a PYTHONPATH whose ``numba`` fails to
import. The plugin must load without an exception, say why in the output window, and
ParaView must go on working.
"""
import os
import sys

from paraview import simple

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
try:
    simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))
    assert not hasattr(simple, "HDRVolumeRender"), "filters were registered without numba"
    sphere = simple.Sphere()
    sphere.UpdatePipeline()
    assert sphere.GetDataInformation().GetNumberOfPoints() > 0
    print("ParaView works on", flush=True)
    code = 0
except BaseException:
    import traceback

    traceback.print_exc()
    code = 1
sys.stdout.flush()
sys.stderr.flush()
os._exit(code)
