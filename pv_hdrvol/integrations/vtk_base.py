"""What the package's VTK algorithms share: error reporting through VTK's pipeline and
the whole-extent request of image inputs."""
import traceback

from vtkmodules.util.vtkAlgorithm import VTKPythonAlgorithmBase
from vtkmodules.vtkCommonCore import vtkOutputWindow
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

_SDDP = vtkStreamingDemandDrivenPipeline


class ReportingAlgorithm(VTKPythonAlgorithmBase):
    """A Python VTK algorithm whose pipeline passes report their exceptions.

    VTK drops the Python traceback when any Python observer sees the error (PyVista
    installs one on import), so an exception raised by a pipeline pass is also written
    to the VTK output window, as VTK formats errors (``"<Class> (0x...): <Type>:
    <message>"``, the class named by :attr:`REPORT_NAME` or the object's own class), and
    kept for :meth:`GetLastError`; then it is raised again, so that VTK fails the update
    (``Update()`` returns ``False``, an ``ErrorEvent`` fires). Subclasses implement
    ``_execute(inInfo, outInfo)``, which ``RequestData`` runs.
    """

    #: The class name in error messages (``None``: the object's own class).
    REPORT_NAME = None

    def __init__(self, **ports):
        super().__init__(**ports)
        self._last_error = None

    def GetLastError(self):
        """``"<Type>: <message>"`` of the exception that made the last execution fail, else ``None``."""
        return self._last_error

    def _reporting(self, step, *args):
        try:
            return step(*args)
        except Exception as exc:
            self._last_error = f"{type(exc).__name__}: {exc}"
            # VTK's own message format, so that PyVista's logging and ParaView parse it
            where = traceback.extract_tb(exc.__traceback__)[-1]
            address = self.GetAddressAsString("vtkObject").replace("Addr=", "")
            vtkOutputWindow.GetInstance().DisplayErrorText(
                f"ERROR: In {where.filename}, line {where.lineno}\n"
                f"{self.REPORT_NAME or type(self).__name__} ({address}): {self._last_error}\n\n")
            raise

    def RequestData(self, request, inInfo, outInfo):
        self._last_error = None
        return self._reporting(self._execute, inInfo, outInfo)

    def _execute(self, inInfo, outInfo):
        raise NotImplementedError


def request_whole_extent(info):
    """Ask an image input for all of it (a no-op for datasets without extents)."""
    if info.Has(_SDDP.WHOLE_EXTENT()):
        info.Set(_SDDP.UPDATE_EXTENT(), info.Get(_SDDP.WHOLE_EXTENT()), 6)


__all__ = ["ReportingAlgorithm", "request_whole_extent"]
