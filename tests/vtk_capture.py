"""Test helper: what VTK writes to its output window while a block runs."""
from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow


class CapturedErrors:
    """Route the VTK output window to a string while the block runs (restoring the old one);
    ``.text`` holds what was written."""

    def __enter__(self):
        self.previous = vtkOutputWindow.GetInstance()
        self.window = vtkStringOutputWindow()
        vtkOutputWindow.SetInstance(self.window)
        return self

    def __exit__(self, *exc):
        vtkOutputWindow.SetInstance(self.previous)
        self.text = self.window.GetOutput()
