"""The rendered image as a surface in a 3-D view (HDR Volume Render's 'In View' output)."""
import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.integrations.vtk_surface import MIN_ALPHA, view_surface

pytest.importorskip("vtkmodules")


def _arrays(poly):
    from vtkmodules.util.numpy_support import vtk_to_numpy

    points = vtk_to_numpy(poly.GetPoints().GetData()).reshape(-1, 4, 3)
    colors = vtk_to_numpy(poly.GetCellData().GetArray("colors"))
    return points, colors


def _image(rows=6, cols=8, seed=3):
    rng = np.random.default_rng(seed)
    alpha = rng.uniform(0.2, 1.0, (rows, cols))
    alpha[0, 0] = 0.0  # left out
    alpha[1, 2] = MIN_ALPHA / 2  # left out
    depth = rng.uniform(5.0, 9.0, (rows, cols))
    depth[2, 3] = np.inf  # no depth: on the focal plane
    colors = np.clip(np.rint(alpha[..., None] * rng.uniform(0, 255, (rows, cols, 3))), 0, 255).astype(np.uint8)
    return alpha, depth, colors


@pytest.mark.parametrize("parallel", [False, True])
def test_each_quad_covers_its_pixel_at_its_depth(parallel):
    camera = hv.Camera(position=(1.0, -2.0, 10.0), focal_point=(0.5, 0.5, 0.0), view_up=(0.0, 1.0, 0.0),
                       view_angle=40.0, parallel_projection=parallel, parallel_scale=3.0)
    alpha, depth, colors = _image()
    rows, cols = alpha.shape
    poly = view_surface(alpha, depth, colors, camera)
    points, rgba = _arrays(poly)
    visible = alpha >= MIN_ALPHA
    assert poly.GetNumberOfCells() == visible.sum() == rows * cols - 2
    r, c = np.nonzero(visible)
    # the corners project onto the pixel's corners (row 0 at the top)
    corners = np.stack([np.stack(p, axis=-1) for p in ((c, r), (c + 1, r), (c + 1, r + 1), (c, r + 1))],
                       axis=1).astype(float)  # (n, 4, 2): col, row
    projected = camera.project(points.reshape(-1, 3), (cols, rows)).reshape(-1, 4, 2)
    np.testing.assert_allclose(projected, corners, atol=1e-9)
    # the pixel's ray meets the quad at the pixel's depth
    rays = camera.rays((cols, rows))
    k = r * cols + c
    expected_depth = np.where(np.isfinite(depth[r, c]), depth[r, c], np.nan)
    origin, direction = rays.origins[k], rays.directions[k]
    normal = camera.basis()[2]
    centre = points.mean(axis=1)
    t = ((centre - origin) @ normal) / (direction @ normal)  # ray-plane intersection
    finite = np.isfinite(expected_depth)
    np.testing.assert_allclose(t[finite], expected_depth[finite], rtol=1e-12)
    # no depth: on the focal plane
    focal = np.asarray(camera.focal_point)
    np.testing.assert_allclose((centre[~finite] - focal) @ normal, 0.0, atol=1e-9)
    # colours: straight alpha, over black they give the displayed colours back (uint8 rounding)
    over_black = rgba[:, :3].astype(float) * rgba[:, 3:4] / 255.0
    assert np.abs(over_black - colors[r, c]).max() <= 1.5
    np.testing.assert_array_equal(rgba[:, 3], np.rint(alpha[r, c] * 255).astype(np.uint8))


def test_input_is_checked():
    camera = hv.Camera.fit((0, 1, 0, 1, 0, 1))
    alpha, depth, colors = _image()
    with pytest.raises(TypeError, match="camera must be a pv_hdrvol Camera; got str"):
        view_surface(alpha, depth, colors, "iso")
    with pytest.raises(TypeError, match=r"colors must be uint8 \(tone-mapped\); got float64"):
        view_surface(alpha, depth, colors.astype(float), camera)
    with pytest.raises(ValueError, match="must agree; got"):
        view_surface(alpha, depth[:-1], colors, camera)
