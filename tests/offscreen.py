"""Offscreen VTK rendering without X for the tests that render with VTK.

``VTK_DEFAULT_OPENGL_WINDOW`` is set (unless already set) to ``vtkEGLRenderWindow``
when ``libEGL.so.1`` loads (Debian: libegl1 libegl-mesa0 libgl1-mesa-dri), else to
``vtkOSOpenGLRenderWindow`` when ``libOSMesa.so.8`` loads (Debian: libosmesa6).
Neither: the calling module is skipped, or fails when ``CI`` is set. Call
:func:`require_offscreen_vtk` before importing pyvista or VTK's rendering modules.
"""
import ctypes
import os

import numpy as np
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


def vtk_volume_screenshot(ds, camera, color, opacity, unit, sample_distance, size):
    """``ds`` through VTK's ``vtkFixedPointVolumeRayCastMapper`` as ``(size, size, 3)``
    uint8, row 0 on top: colour and opacity functions ``color``/``opacity``
    (``vtkColorTransferFunction``, ``vtkPiecewiseFunction``), scalar opacity unit distance
    ``unit``, sample distance ``sample_distance`` (world units, not adjusted), one ray per
    pixel, linear interpolation, no shading, a black background, ``camera`` (an
    ``hv.Camera``). Call :func:`require_offscreen_vtk` first."""
    import pyvista as pv
    import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401 - registers vtkRayCastImageDisplayHelper
    from vtkmodules.vtkRenderingCore import vtkVolume, vtkVolumeProperty
    from vtkmodules.vtkRenderingVolume import vtkFixedPointVolumeRayCastMapper

    prop = vtkVolumeProperty()
    prop.SetColor(color)
    prop.SetScalarOpacity(opacity)
    prop.SetScalarOpacityUnitDistance(unit)
    prop.SetInterpolationTypeToLinear()
    prop.ShadeOff()
    mapper = vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(ds)
    mapper.SetAutoAdjustSampleDistances(False)
    mapper.SetSampleDistance(sample_distance)
    mapper.SetInteractiveSampleDistance(sample_distance)
    mapper.SetImageSampleDistance(1.0)
    volume = vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    plotter = pv.Plotter(off_screen=True, window_size=(size, size))
    try:
        plotter.ren_win.SetMultiSamples(0)
        plotter.set_background("black")
        plotter.renderer.AddVolume(volume)
        plotter.renderer.SetActiveCamera(camera.to_vtk())
        plotter.renderer.ResetCameraClippingRange()
        plotter.camera_set = True  # keep our camera: no reset on first render
        shot = plotter.screenshot(return_img=True)
    finally:
        plotter.close()
    assert shot.shape == (size, size, 3) and shot.dtype == np.uint8
    return shot
