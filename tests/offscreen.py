"""Offscreen VTK rendering without X for the tests that render with VTK.

``VTK_DEFAULT_OPENGL_WINDOW`` is set (unless already set) to ``vtkEGLRenderWindow``
when ``libEGL.so.1`` loads (Debian: libegl1 libegl-mesa0 libgl1-mesa-dri), else to
``vtkOSOpenGLRenderWindow`` when ``libOSMesa.so.8`` loads (Debian: libosmesa6).
Neither: the calling module is skipped, or fails when ``CI`` is set. Call
:func:`require_offscreen_vtk` before importing pyvista or VTK's rendering modules.
"""
import ctypes
import os

import pytest


def _pick_offscreen_window():
    """The VTK render-window class that can render here without an X server, or None."""
    for lib, window in (("libEGL.so.1", "vtkEGLRenderWindow"),
                        ("libOSMesa.so.8", "vtkOSOpenGLRenderWindow"),
                        ("libOSMesa.so.6", "vtkOSOpenGLRenderWindow")):
        try:
            ctypes.CDLL(lib)
        except OSError:
            continue
        return window
    return None


def require_offscreen_vtk():
    if "VTK_DEFAULT_OPENGL_WINDOW" in os.environ:
        return
    window = _pick_offscreen_window()
    if window is None:
        msg = ("no offscreen OpenGL for VTK: install libegl1 libegl-mesa0 libgl1-mesa-dri "
               "(EGL) or libosmesa6 (OSMesa)")
        if os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no"):  # as conftest.in_ci
            pytest.fail(msg, pytrace=False)
        pytest.skip(msg, allow_module_level=True)
    os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = window
