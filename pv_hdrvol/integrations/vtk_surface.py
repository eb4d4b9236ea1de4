"""The rendered image as geometry in a 3-D view: one quad per visible pixel, placed
on the pixel's ray at the volume's depth and facing the camera.

Seen from the camera that rendered it, the surface covers exactly the pixels of the
image, with their tone-mapped colours; its depth is the volume's, so opaque meshes
drawn in the same view hide the volume where they are in front of it and are hidden
where they are behind it. ParaView shows it in the render view whose camera drives
the render (HDR Volume Render's second output): rotating the view re-renders the
volume for the new camera and the surface faces the camera again. Pure VTK + numpy.
"""
from __future__ import annotations

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

from ..rays.camera import Camera

#: Pixels whose alpha is below this are left out (they add less than half a display
#: level over any background), so the background and meshes behind show there.
MIN_ALPHA = 0.5 / 255.0


def view_surface(alpha, depth, colors, camera, *, min_alpha=MIN_ALPHA):
    """A ``vtkPolyData`` of one quad per visible pixel, at the pixel's depth.

    Parameters
    ----------
    alpha : ndarray, shape (rows, cols)
        The render's alpha (row 0 at the top, as :class:`~pv_hdrvol.HDRImage`).
    depth : ndarray, shape (rows, cols)
        Distance along each pixel's ray (``HDRImage.depth``); where it is not finite
        (the ray never reached the depth threshold) the quad lies on the focal plane.
    colors : ndarray, shape (rows, cols, 3), uint8
        The displayed (tone-mapped, sRGB) colours of the premultiplied image, i.e.
        the picture over black.
    camera : Camera
        The camera that rendered the image.
    min_alpha : float
        Pixels with less alpha are left out.

    Returns
    -------
    vtkPolyData
        Quads (4 points each) with the cell array ``"colors"``: uint8 RGBA of straight
        alpha (``colors / alpha``, clipped), so that blending over black gives
        ``colors`` back and over anything else shows what is behind; the cell
        array ``"depth"`` (float64). ``"colors"`` is the active scalars: shown
        with scalar mapping off (ParaView's Map Scalars), the surface draws the
        image with its own colours.
    """
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a pv_hdrvol Camera; got {type(camera).__name__}")
    alpha = np.asarray(alpha, dtype=np.float64)
    depth = np.asarray(depth, dtype=np.float64)
    colors = np.asarray(colors)
    if alpha.ndim != 2 or depth.shape != alpha.shape or colors.shape != alpha.shape + (3,):
        raise ValueError(f"alpha (rows, cols), depth (rows, cols) and colors (rows, cols, 3) must agree; got "
                         f"{alpha.shape}, {depth.shape}, {colors.shape}")
    if colors.dtype != np.uint8:
        raise TypeError(f"colors must be uint8 (tone-mapped); got {colors.dtype}")
    rows, cols = alpha.shape
    right, up, fwd = camera.basis()
    half_h = camera.parallel_scale if camera.parallel_projection else np.tan(np.radians(camera.view_angle) / 2)
    half_w = half_h * cols / rows
    # pixel corners on the view plane (unit distance for perspective), row 0 at the top
    xs = (np.arange(cols + 1) * (2.0 / cols) - 1.0) * half_w
    ys = (1.0 - np.arange(rows + 1) * (2.0 / rows)) * half_h
    xc = 0.5 * (xs[:-1] + xs[1:])
    yc = 0.5 * (ys[:-1] + ys[1:])
    visible = np.nan_to_num(alpha, nan=0.0) >= min_alpha
    r, c = np.nonzero(visible)
    pos = np.asarray(camera.position, dtype=np.float64)
    d = depth[r, c]
    if camera.parallel_projection:
        z = np.where(np.isfinite(d), d, camera.distance)  # along fwd from the view plane
    else:
        # the ray through the pixel's centre has length sqrt(1 + x^2 + y^2) per unit of fwd
        z = np.where(np.isfinite(d), d / np.sqrt(1.0 + xc[c] ** 2 + yc[r] ** 2), camera.distance)
    corners = []
    for dr, dc in ((0, 0), (0, 1), (1, 1), (1, 0)):  # counter-clockwise seen from the camera
        x, y = xs[c + dc], ys[r + dr]
        if camera.parallel_projection:
            p = pos + x[:, None] * right + y[:, None] * up + z[:, None] * fwd
        else:
            p = pos + z[:, None] * (fwd + x[:, None] * right + y[:, None] * up)
        corners.append(p)
    points = np.stack(corners, axis=1).reshape(-1, 3)
    n = r.size
    poly = vtkPolyData()
    vtk_points = vtkPoints()
    vtk_points.SetData(numpy_to_vtk(np.ascontiguousarray(points), deep=True))
    poly.SetPoints(vtk_points)
    quads = vtkCellArray()
    offsets = np.arange(0, 4 * n + 1, 4, dtype=np.int64)
    quads.SetData(numpy_to_vtkIdTypeArray(offsets, deep=True),
                  numpy_to_vtkIdTypeArray(np.arange(4 * n, dtype=np.int64), deep=True))
    poly.SetPolys(quads)
    a = alpha[r, c]
    straight = np.clip(np.rint(colors[r, c].astype(np.float64) / np.maximum(a, min_alpha)[:, None]), 0, 255)
    rgba = np.empty((n, 4), dtype=np.uint8)
    rgba[:, :3] = straight
    rgba[:, 3] = np.clip(np.rint(a * 255.0), 0, 255)
    for name, values in (("colors", rgba), ("depth", np.where(np.isfinite(d), d, np.nan))):
        array = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
        array.SetName(name)
        poly.GetCellData().AddArray(array)
    poly.GetCellData().SetActiveScalars("colors")
    return poly


__all__ = ["MIN_ALPHA", "view_surface"]
