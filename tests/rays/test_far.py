"""Rays stopped by opaque geometry (``far=``, issue 21 part 4): the volume in front of
a surface integrates exactly to its depth (Beer-Lambert), an infinite or distant limit
changes no pixel, a window cuts the limit with the image, for grids (every kernel) and
tetrahedral meshes."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from meshes import box_mesh
from pv_hdrvol.raycast.grid import GridPlan
from pv_hdrvol.raycast.tets import TetPlan

pytestmark = pytest.mark.core


def _slab():
    return hv.volume_from_array(np.full((9, 5, 5), 1.0), spacing=(1.0, 1.0, 0.5))  # z from 0 to 4


def _down(bounds, top=14.0, half_height=1.0):
    cx, cy = 0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3])
    return hv.Camera((cx, cy, top), (cx, cy, 0.0), (0, 1, 0), parallel_projection=True, parallel_scale=half_height)


def _tf(alpha=0.2):
    return hv.TransferFunction([0.0, 2.0], [[0.2, 0.5, 1.0]] * 2, [alpha, alpha])


@pytest.mark.parametrize("options", [{}, {"shade": True}, {"blending": "maximum"}],
                         ids=["plain", "extended", "projection"])
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_a_surface_inside_the_volume_stops_the_rays_there(options, precision):
    """The camera is 10 above the slab's top (z = 4): a surface at depth 10 + k hides
    all but k of the slab. Each column of pixels stops at another depth."""
    vol, tf = _slab(), _tf()
    camera = _down(vol.bounds)
    sigma = -math.log1p(-0.2) / 0.5
    k = np.array([0.0, 0.3, 1.0, 2.25, 3.9, 4.0])
    far = np.broadcast_to(10.0 + k, (4, 6)).copy()
    plan = GridPlan(vol, tf, precision=precision, termination=0.0, **options)
    image = plan.execute(camera, (6, 4), far=far)
    if options.get("blending") == "maximum":
        # the projection keeps the maximum over what it crossed: none where nothing was
        assert np.isnan(image.value[:, 0]).all() and np.all(image.value[:, 1:] == 1.0)
        return
    expected = -np.expm1(-sigma * k) if not options else None
    if expected is not None:
        np.testing.assert_allclose(image.rgba[..., 3], np.broadcast_to(expected, (4, 6)), rtol=0, atol=2e-6)
    assert np.all(image.rgba[:, 0] == 0) and np.all(np.diff(image.rgba[0, :, 3]) > 0)
    # beyond the volume, or infinite: the same pixels as no limit
    free = plan.execute(camera, (6, 4))
    for limit in (np.full((4, 6), 14.0), np.full((4, 6), np.inf)):
        np.testing.assert_array_equal(plan.execute(camera, (6, 4), far=limit).rgba, free.rgba)


def test_a_window_takes_its_part_of_the_limit():
    vol, tf = _slab(), _tf()
    camera = _down(vol.bounds)
    far = 10.0 + np.random.default_rng(1).uniform(0, 4, (16, 24))
    plan = GridPlan(vol, tf, precision="float64")
    full = plan.execute(camera, (24, 16), far=far)
    part = plan.execute(camera, (24, 16), far=far, window=(5, 3, 11, 9))
    np.testing.assert_array_equal(part.rgba, full.rgba[3:12, 5:16])


def test_a_tetrahedral_mesh_stops_at_the_surface_inside_a_cell():
    points, tets, values = box_mesh((2, 2, 2))  # the unit cubes of [0, 2]^3, value 1
    mesh = hv.tetmesh_from_arrays(points, tets, values)
    tf = hv.TransferFunction([0.0, 2.0], [[1.0, 1.0, 1.0]] * 2, [0.3, 0.3])
    camera = _down(mesh.bounds, top=12.0, half_height=0.5)  # the mesh's top at depth 10; all rays cross it
    plan = TetPlan(mesh, tf, precision="float64", opacity_unit_distance=1.0, termination=0.0)
    k = np.array([0.0, 0.25, 0.9, 1.6, 2.0])
    image = plan.execute(camera, (5, 3), far=np.broadcast_to(10.0 + k, (3, 5)))
    sigma = -math.log1p(-0.3)
    np.testing.assert_allclose(image.rgba[..., 3], np.broadcast_to(-np.expm1(-sigma * k), (3, 5)), rtol=0,
                               atol=1e-12)
    np.testing.assert_array_equal(plan.execute(camera, (5, 3), far=np.full((3, 5), np.inf)).rgba,
                                  plan.execute(camera, (5, 3)).rgba)


def test_bad_limits_are_named():
    plan = GridPlan(_slab(), _tf())
    with pytest.raises(ValueError, match=r"far must have the image's shape \(rows, cols\) = \(4, 6\); got \(6, 4\)"):
        plan.execute("xy", (6, 4), far=np.ones((6, 4)))
    with pytest.raises(ValueError, match="far must hold distances >= 0"):
        plan.execute("xy", (6, 4), far=np.full((4, 6), np.nan))
    with pytest.raises(TypeError, match="far must be a numeric array; got dtype <U1"):
        plan.execute("xy", (6, 4), far=np.full((4, 6), "a"))
