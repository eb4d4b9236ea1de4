"""Load the plugin and leave: what it says at load time. Run by tests/test_paraview.py
(under an mpiexec that is not ParaView's MPI's)."""
import os

from paraview import simple

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))
print("loaded:", hasattr(simple, "HDRVolumeRender"), flush=True)
# the script ends normally: pvbatch finalizes MPI (os._exit would make Open MPI's mpiexec fail)
