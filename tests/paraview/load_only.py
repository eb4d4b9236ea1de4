"""Load the plugin and leave: one short line per process saying whether the plugin
named a foreign mpiexec while it loaded (short lines: the processes share the pipe).
Run by tests/integrations/test_paraview.py under an mpiexec that is not ParaView's MPI's, and under
Open MPI's."""
import os

from paraview import simple
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
window, previous = vtkStringOutputWindow(), vtkOutputWindow.GetInstance()
vtkOutputWindow.SetInstance(window)
simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))
vtkOutputWindow.SetInstance(previous)
said = "this process was started by an mpiexec of 2 processes, but ParaView runs as one" in window.GetOutput()
print(f"loaded: {hasattr(simple, 'HDRVolumeRender')}, named the mpiexec: {said}", flush=True)
# the script ends normally: pvbatch finalizes MPI (os._exit would make Open MPI's mpiexec fail)
