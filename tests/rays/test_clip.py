"""Clipping planes and a crop box (issue 33 part 4): each ray keeps one interval of the
convex kept set, cut exactly (Beer-Lambert to the cut, not to a sample), for grids
(every kernel), rectilinear grids, tetrahedral meshes (the cut inside a cell) and
blocks; a plane that keeps everything changes no pixel; bad planes are named."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from meshes import box_mesh
from test_far import _down, _slab, _tf  # the slab z in [0, 4], a camera looking down on it
from pv_hdrvol.params import ClipPlane, RenderOptions, as_clip_planes
from pv_hdrvol.raycast.grid import GridPlan
from pv_hdrvol.raycast.tets import TetPlan
from pv_hdrvol.rays.clip import clip_spans
from pv_hdrvol.settings import options_from_dict, options_to_dict

pytestmark = pytest.mark.core

SIGMA = -math.log1p(-0.2) / 0.5  # extinction of opacity 0.2 over the unit distance 0.5


# rays straight down through the slab [0, 4] in z: what each clip keeps of it
KEPT = [
    ({"clip_planes": ((0, 0, 3.0), (0, 0, -1))}, 3.0),  # keep below z = 3
    ({"clip_planes": ClipPlane((0, 0, 0.7), (0, 0, 5))}, 3.3),  # keep above z = 0.7 (normal of any length)
    ({"crop_box": (-9, 9, -9, 9, 1.0, 2.3)}, 1.3),
    ({"clip_planes": [((0, 0, 3.0), (0, 0, -1)), ((0, 0, 0.7), (0, 0, 1))], "crop_box": (-9, 9, -9, 9, 0, 2.9)}, 2.2),
]


@pytest.mark.parametrize("clip, length", KEPT, ids=["below", "above", "crop", "both"])
@pytest.mark.parametrize("options", [{}, {"shade": True}], ids=["plain", "extended"])
@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_the_kept_slab_integrates_exactly(clip, length, options, precision):
    vol = _slab()
    plan = GridPlan(vol, _tf(), precision=precision, termination=0.0, **clip, **options)
    image = plan.execute(_down(vol.bounds), (6, 4))
    atol = 1e-12 if precision == "float64" else 2e-7
    np.testing.assert_allclose(image.rgba[..., 3], -math.expm1(-SIGMA * length), rtol=0, atol=atol)


def test_an_oblique_plane_cuts_each_ray_where_it_meets_it():
    """Keep ``z <= 2 + tan(a) (y - yc)``: the kept length varies along y, row by row."""
    vol = _slab()
    bounds = vol.bounds
    yc = 0.5 * (bounds[2] + bounds[3])
    a = math.radians(35.0)
    plan = GridPlan(vol, _tf(), precision="float64", termination=0.0,
                    clip_planes=((0.0, yc, 2.0), (0.0, math.sin(a), -math.cos(a))))
    image = plan.execute(_down(bounds, half_height=2.0), (3, 8))
    y = yc + (1.0 - (np.arange(8) + 0.5) * (2.0 / 8)) * 2.0  # the rows' rays (row 0 on top)
    length = np.clip(2.0 + math.tan(a) * (y - yc), 0.0, 4.0)
    np.testing.assert_allclose(image.rgba[..., 3], np.broadcast_to(-np.expm1(-SIGMA * length)[:, None], (8, 3)),
                               rtol=0, atol=1e-12)


def test_the_maximum_projection_sees_only_the_kept_part():
    values = np.zeros((9, 5, 5))
    values[8] = 2.0  # the top layer (z = 4; values are z, y, x) is the maximum
    vol = hv.volume_from_array(values, spacing=(1.0, 1.0, 0.5))
    plan = GridPlan(vol, _tf(), precision="float64", blending="maximum", clip_planes=((0, 0, 3.7), (0, 0, -1)))
    image = plan.execute(_down(vol.bounds), (6, 4))
    # the field falls linearly from 2 at z = 4 to 0 at z = 3.5; below z = 3.7 its maximum is at the cut
    np.testing.assert_allclose(image.value, (3.7 - 3.5) / 0.5 * 2.0, rtol=0, atol=1e-12)


def test_keeping_everything_changes_no_pixel_and_keeping_nothing_draws_nothing():
    vol = _slab()
    camera = hv.Camera.fit(vol.bounds, "iso")
    free = GridPlan(vol, _tf(), precision="float32").execute(camera, (12, 10))
    around = GridPlan(vol, _tf(), precision="float32", clip_planes=((0, 0, -1.0), (0, 0, 1)),
                      crop_box=(-50, 50, -50, 50, -50, 50)).execute(camera, (12, 10))
    np.testing.assert_array_equal(around.rgba, free.rgba)
    np.testing.assert_array_equal(around.depth, free.depth)
    gone = GridPlan(vol, _tf(), precision="float32", clip_planes=((0, 0, 5.0), (0, 0, 1))).execute(camera, (12, 10))
    assert not gone.rgba.any() and np.isinf(gone.depth).all()
    # two planes facing apart keep an empty set
    apart = GridPlan(vol, _tf(), precision="float32",
                     clip_planes=[((0, 0, 3.0), (0, 0, 1)), ((0, 0, 1.0), (0, 0, -1))]).execute(camera, (12, 10))
    assert not apart.rgba.any()


def test_clip_and_far_take_the_nearer_end():
    vol = _slab()
    camera = _down(vol.bounds)
    far = np.broadcast_to(10.0 + np.array([0.5, 1.0, 2.0, 3.0, 3.5, 4.0]), (4, 6)).copy()
    plan = GridPlan(vol, _tf(), precision="float64", termination=0.0, clip_planes=((0, 0, 3.0), (0, 0, -1)),
                    crop_box=(-9, 9, -9, 9, 1.0, 9))
    image = plan.execute(camera, (6, 4), far=far)
    # kept: z in [1, 3], i.e. depths [11, 13]; far cuts at 10 + k
    length = np.clip(np.minimum(far, 13.0) - 11.0, 0.0, None)
    np.testing.assert_allclose(image.rgba[..., 3], -np.expm1(-SIGMA * length), rtol=0, atol=1e-12)


def test_a_rectilinear_grid_is_cut_exactly():
    z = np.array([0.0, 0.3, 1.0, 2.2, 4.0])
    vol = hv.volume_from_rectilinear(np.ones((5, 3, 3)), [0.0, 1.0, 2.0], [0.0, 1.0, 2.0], z)
    plan = GridPlan(vol, _tf(), precision="float64", termination=0.0, opacity_unit_distance=0.5,
                    clip_planes=((0, 0, 2.9), (0, 0, -1)), crop_box=(-9, 9, -9, 9, 0.45, 9))
    image = plan.execute(_down(vol.bounds, half_height=0.5), (4, 4))
    np.testing.assert_allclose(image.rgba[..., 3], -math.expm1(-SIGMA * (2.9 - 0.45)), rtol=0, atol=1e-12)


@pytest.mark.parametrize("clip, length", [({"clip_planes": ((0, 0, 1.3), (0, 0, -1))}, 1.3),
                                          ({"clip_planes": ((0, 0, 1.3), (0, 0, 1))}, 0.7),
                                          ({"crop_box": (-9, 9, -9, 9, 0.45, 1.7)}, 1.25)],
                         ids=["below", "above", "crop"])
def test_a_mesh_is_cut_inside_its_cells(clip, length):
    points, tets, values = box_mesh((2, 2, 2))  # the unit cubes of [0, 2]^3, value 1
    mesh = hv.tetmesh_from_arrays(points, tets, values)
    tf = hv.TransferFunction([0.0, 2.0], [[1.0, 1.0, 1.0]] * 2, [0.3, 0.3])
    plan = TetPlan(mesh, tf, precision="float64", opacity_unit_distance=1.0, termination=0.0, **clip)
    image = plan.execute(_down(mesh.bounds, top=12.0, half_height=0.5), (5, 3))
    np.testing.assert_allclose(image.rgba[..., 3], -math.expm1(math.log1p(-0.3) * length), rtol=0, atol=1e-12)


def test_grid_and_mesh_agree_on_a_linear_field_under_oblique_cuts():
    """A linear field is exact under trilinear and piecewise-linear interpolation: the
    grid (at a fine step) and the tetrahedral mesh of it, cut by two oblique planes and
    a box through their cells, give the same picture (to the grid's sampling error),
    which the cut changes by far more than that."""
    points, tets, _ = box_mesh((4, 4, 4), spacing=0.5)
    mesh = hv.tetmesh_from_arrays(points, tets, points[:, 2] + 0.5 * points[:, 0])
    z, _, x = np.meshgrid(*(np.arange(5) * 0.5,) * 3, indexing="ij")
    vol = hv.volume_from_array(z + 0.5 * x, spacing=(0.5,) * 3)
    tf = hv.TransferFunction([0.0, 3.0], [[1.0, 0.2, 0.1], [0.1, 0.3, 1.0]], [0.05, 0.6])
    camera = hv.Camera((5, -4, 6.0), (1, 1, 1), (0, 0, 1))
    clip = {"clip_planes": [((1, 1, 1), (0.3, 0.5, -1)), ((0.2, 0, 0), (1, 0.1, 0))],
            "crop_box": (-1, 1.8, -1, 5, -1, 5)}
    common = {"precision": "float64", "termination": 0.0, "opacity_unit_distance": 0.5}
    grid = GridPlan(vol, tf, step=0.01, **common, **clip).execute(camera, (24, 24))
    tet = TetPlan(mesh, tf, **common, **clip).execute(camera, (24, 24))
    whole = TetPlan(mesh, tf, **common).execute(camera, (24, 24))
    assert np.abs(grid.rgba - tet.rgba).max() < 1e-5
    assert np.abs(whole.rgba - tet.rgba).max() > 0.1


def test_a_clipped_render_split_into_pieces_is_the_whole():
    from pv_hdrvol.parallel.pieces import composite_pieces, split_volume

    rng = np.random.default_rng(3)
    vol = hv.volume_from_array(rng.uniform(0.0, 2.0, (12, 10, 9)))
    tf = hv.TransferFunction([0.0, 2.0], [[1.0, 0.5, 0.2], [0.2, 0.5, 1.0]], [0.0, 0.4])
    clip = {"clip_planes": ((5, 4, 4), (1, 0.4, 0.7)), "crop_box": (1.5, 9.0, -1, 20, 0.5, 6.6)}
    camera = hv.Camera((30, -20, 25), (5, 4, 4), (0, 0, 1))
    whole = GridPlan(vol, tf, precision="float64", **clip).execute(camera, (20, 16))
    parts = split_volume(vol, 3, ghosts=0)
    rays = camera.rays((20, 16))
    images = [GridPlan(part, tf, precision="float64", **clip).execute(camera, (20, 16), piece=piece)
              for part, piece in parts]
    boxes = [piece.world_box(vol.spacing) for _, piece in parts]
    combined = composite_pieces(images, boxes, rays)
    np.testing.assert_allclose(combined.rgba, whole.rgba, rtol=0, atol=1e-12)


def test_planes_take_every_form_and_travel_with_the_settings():
    vtk = pytest.importorskip("vtkmodules.vtkCommonDataModel")
    plane = vtk.vtkPlane()
    plane.SetOrigin(1, 2, 3)
    plane.SetNormal(0, 0, -2)
    collection = vtk.vtkPlaneCollection()
    collection.AddItem(plane)
    collection.AddItem(plane)
    expected = ClipPlane((1, 2, 3), plane.GetNormal())  # vtkPlane keeps its normal as set (-2 here)
    assert as_clip_planes(plane) == (expected,)
    assert as_clip_planes(collection) == (expected, expected)
    assert as_clip_planes(((1, 2, 3), plane.GetNormal())) == (expected,)
    assert as_clip_planes([{"origin": (1, 2, 3), "normal": plane.GetNormal()}]) == (expected,)
    assert as_clip_planes(None) == ()
    options = RenderOptions(clip_planes=[plane, ((0, 0, 0), (1, 0, 0))], crop_box=(0, 1, 0, 2, 0, 3))
    assert options_from_dict(options_to_dict(options)) == options


@pytest.mark.parametrize("value, error, message", [
    (((0, 0, 0), (0, 0, 0)), ValueError, "a clip plane's normal must not be the zero vector; got (0, 0, 0)"),
    (((0, 0, np.nan), (0, 0, 1)), ValueError, "clip plane origin must be finite; got (0, 0, nan)"),
    ("z", TypeError, "clip_planes must be None, a plane (ClipPlane, (origin, normal) or a vtkPlane) or a sequence"),
    ([((0, 0, 0), (0, 0, 1)), 3], TypeError, "clip_planes[1] must be a ClipPlane, (origin, normal) or a vtkPlane; "
                                             "got 3"),
    ([((0, 0, 0), (0, 0, 1))] * 33, ValueError, "at most 32 clip planes; got 33"),
])
def test_bad_planes_are_named(value, error, message):
    with pytest.raises(error) as info:
        RenderOptions(clip_planes=value)
    assert message in str(info.value)


@pytest.mark.parametrize("value, error, message", [
    ((0, 1, 0, 1, 0), ValueError, "crop_box must be 6 numbers (xmin, xmax, ymin, ymax, zmin, zmax); got (0, 1, 0, 1, 0)"),
    ((0, 1, 2, 2, 0, 1), ValueError, "crop_box needs min < max on every axis (infinite ends allowed); got (0, 1, 2, 2, 0, 1)"),
    ((0, 1, 0, np.nan, 0, 1), ValueError, "crop_box needs min < max on every axis"),
    ("box", TypeError, "crop_box must be (xmin, xmax, ymin, ymax, zmin, zmax); got 'box'"),
])
def test_bad_crop_boxes_are_named(value, error, message):
    with pytest.raises(error) as info:
        RenderOptions(crop_box=value)
    assert message in str(info.value)


def test_spans_of_rays_in_a_plane_or_outside_the_box():
    origins = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [5.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    directions = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    near, far = clip_spans(origins, directions, (ClipPlane((0, 0, 0), (0, 0, 1)),), (-2, 2, -2, 2, -2, 2))
    # in the plane's kept side, parallel to it: all of the box; on the cut side: nothing
    assert (near[0], far[0]) == (0.0, 2.0)
    assert not far[1] >= near[1]
    assert not far[2] >= near[2]  # parallel to the box's x faces, outside them
    assert (near[3], far[3]) == (0.0, 2.0)


def test_the_clipping_page_prints_what_it_says(tmp_path, monkeypatch):
    import re

    pytest.importorskip("pyvista")  # hv.datasets makes PyVista grids

    from conftest import REPO_ROOT
    from docblocks import python_blocks, run_blocks

    page = REPO_ROOT / "docs" / "clipping.md"
    blocks, _ = python_blocks(page)
    expected = re.search(r"^prints\n\n```text\n(.*?)^```", page.read_text(), re.S | re.M).group(1)
    assert run_blocks(blocks, tmp_path, monkeypatch) == expected


def test_blocks_are_cut_as_the_whole_they_make():
    """A volume split into 8 blocks (gathered), the same rendered block by block
    (composited in ray order), and mesh blocks: each cut as the unsplit volume is."""
    pv = pytest.importorskip("pyvista")  # the core run (Debian's Python) has no PyVista

    from pv_hdrvol.data.blocks import flatten, image_blocks
    from pv_hdrvol.parallel.pieces import split_boxes
    from pv_hdrvol.raycast.blocks import render_image_blocks

    img = pv.ImageData(dimensions=(17, 13, 11), spacing=(0.5, 0.7, 0.9), origin=(1.0, -2.0, 3.0))
    x, y, z = ((img.points - np.array(img.center)) / np.array([4.0, 4.2, 4.5])).T
    img.point_data["f"] = np.exp(-(x * x + y * y + z * z) * 2.0) + 0.3 * np.sin(3 * x) * np.cos(2 * y) ** 2
    blocks = pv.MultiBlock([img.extract_subset((lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]))
                            for lo, hi in split_boxes(img.dimensions, 8)])
    tf = hv.TransferFunction([-0.3, 1.2], [[1.0, 0.4, 0.1], [0.2, 0.5, 1.0]], [0.0, 0.7])
    c = np.array(img.center)
    clip = {"clip_planes": (tuple(c), (1.0, 0.5, -0.3)), "crop_box": (c[0] - 3, c[0] + 9, -9, 9, c[2] - 3.3, 20)}
    cam = hv.Camera.fit(img.bounds, "iso")
    whole = hv.render(img, tf, cam, (40, 32), precision="float64", **clip)
    assert np.abs(whole.rgba - hv.render(img, tf, cam, (40, 32), precision="float64").rgba).max() > 0.05
    np.testing.assert_array_equal(hv.render(blocks, tf, cam, (40, 32), precision="float64", **clip).rgba, whole.rgba)
    one_by_one = render_image_blocks(image_blocks(flatten(blocks)[0], "f", False), tf, cam, (40, 32), name="f",
                                     precision="float64", step=0.1, **clip)
    fine = hv.render(img, tf, cam, (40, 32), precision="float64", step=0.1, **clip)
    assert np.abs(one_by_one.rgba - fine.rgba).max() < 5e-5  # the samples differ block by block, as unclipped
    mesh = img.cast_to_unstructured_grid().triangulate()
    xc = mesh.cell_centers().points[:, 0]
    halves = pv.MultiBlock([mesh.extract_cells(np.flatnonzero(xc < c[0])), mesh.extract_cells(np.flatnonzero(xc >= c[0]))])
    np.testing.assert_allclose(hv.render(halves, tf, cam, (40, 32), precision="float64", **clip).rgba,
                               hv.render(mesh, tf, cam, (40, 32), precision="float64", **clip).rgba, rtol=0, atol=1e-12)


def test_the_accessor_cuts_as_render_does():
    pytest.importorskip("pyvista")  # the core run (Debian's Python) has no PyVista
    grid = hv.datasets.hydrogen_orbital(size=20)
    clip = {"clip_planes": ((0, 0, 0), (1, 0, 0)), "crop_box": (-30, 30, -45, 45, -45, 45)}
    mine = grid.hdrvol.render(camera="iso", size=24, **clip)
    np.testing.assert_array_equal(mine.rgba, hv.render(grid, None, "iso", 24, **clip).rgba)
    assert mine.settings().options.clip_planes == (ClipPlane((0, 0, 0), (1, 0, 0)),)
