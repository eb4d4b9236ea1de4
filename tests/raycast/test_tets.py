"""The tetrahedral ray caster: exact integration, watertight traversal, non-convex meshes,
extremes and bad input. Meshes are built with numpy (Kuhn triangulations of boxes), so
these tests need no VTK."""
import math

import numba
import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.data.tets import tetmesh_from_arrays
from pv_hdrvol.raycast import _layer_kernels as LK

from meshes import box_mesh, constant_tf, oblique_camera, slab_length

pytestmark = pytest.mark.core


# -- exact integration ----------------------------------------------------------------------
def test_single_tet_constant_opacity_matches_the_thickness():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    mesh = tetmesh_from_arrays(pts, np.array([[0, 1, 2, 3]]), np.full(4, 0.5))
    cam = hv.Camera((0.25, 0.25, 10.0), (0.25, 0.25, 0.0), (0.0, 1.0, 0.0), parallel_projection=True,
                    parallel_scale=0.5)
    img = hv.render(mesh, constant_tf(0.5), cam, (16, 16), precision="float64", opacity_unit_distance=1.0)
    rays = cam.rays((16, 16))
    x, y = rays.origins[:, 0], rays.origins[:, 1]
    thickness = np.where((x > 0) & (y > 0) & (x + y < 1), 1.0 - x - y, 0.0)
    expected = -np.expm1(math.log(0.5) * thickness)
    np.testing.assert_allclose(img.rgba[..., 3].ravel(), expected, rtol=0, atol=1e-14)
    # premultiplied white: colour equals opacity
    np.testing.assert_allclose(img.rgba[..., 0], img.rgba[..., 3], rtol=0, atol=1e-15)


def test_linear_colour_along_the_ray_matches_the_closed_form():
    """Constant extinction, colour linear in the scalar, scalar linear in z: the pixel's
    colour is c0 a + (c1 - c0)/L (1 - e^{-sL}(1 + sL))/s, the alpha 1 - e^{-sL}."""
    pts, tets, _ = box_mesh((1, 1, 4), spacing=0.5)
    values = pts[:, 2] / 2.0  # 0 .. 1 over z in [0, 2]
    mesh = tetmesh_from_arrays(pts, tets, values)
    tf = hv.TransferFunction([0.0, 1.0], [[0.0, 0.2, 1.0], [1.0, 0.2, 0.0]], [0.9, 0.9])
    cam = hv.Camera((0.25, 0.25, 10.0), (0.25, 0.25, 0.0), (0.0, 1.0, 0.0), parallel_projection=True,
                    parallel_scale=0.1)
    sigma = -math.log(1 - 0.9)
    length = 2.0
    a = -math.expm1(-sigma * length)
    # the ray goes down z: the scalar runs from 1 (front) to 0 (back); red = s, blue = 1 - s
    front, back = 1.0, 0.0
    ramp = (1.0 - math.exp(-sigma * length) * (1.0 + sigma * length)) / sigma / length
    red = front * a + (back - front) * ramp
    blue = (1 - front) * a + (front - back) * ramp
    for tau_max in (1.0, 0.25, 0.01):  # the emission is exact when the extinction is constant
        img = hv.render(mesh, tf, cam, (2, 2), precision="float64", opacity_unit_distance=1.0, tau_max=tau_max)
        px = img.rgba[0, 0]
        assert px[3] == pytest.approx(a, abs=1e-13)
        assert px[1] == pytest.approx(0.2 * a, abs=1e-13)
        assert px[0] == pytest.approx(red, abs=1e-10) and px[2] == pytest.approx(blue, abs=1e-10)


def test_varying_extinction_and_colour_converge_with_tau_max():
    """Extinction and colour both vary along the ray: against a quadrature of
    int c sigma exp(-int sigma), the error falls quickly with tau_max."""
    pts, tets, _ = box_mesh((1, 1, 4), spacing=0.5)
    mesh = tetmesh_from_arrays(pts, tets, pts[:, 2] / 2.0)
    # 65,536 entries: the table's own error (interpolating sigma = -ln(1 - a)) below 1e-9;
    # the default size holds it to TABLE_TOLERANCE, 1e-4
    tf = hv.TransferFunction([0.0, 1.0], [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], [0.05, 0.95], table_size=65536)
    cam = hv.Camera((0.25, 0.25, 10.0), (0.25, 0.25, 0.0), (0.0, 1.0, 0.0), parallel_projection=True,
                    parallel_scale=0.1)
    # along the ray (z from 2 down to 0) the scalar s = z / 2 goes from 1 to 0
    t = np.linspace(0.0, 2.0, 2_000_001)
    s = 1.0 - t / 2.0
    sigma = -np.log1p(-(0.05 + 0.9 * s))
    tau = np.concatenate([[0.0], np.cumsum(0.5 * (sigma[1:] + sigma[:-1]) * np.diff(t))])
    f = s * sigma * np.exp(-tau)
    red = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(t)))
    errors = {}
    for tau_max in (1.0, 0.25, 0.05):
        img = hv.render(mesh, tf, cam, (2, 2), precision="float64", opacity_unit_distance=1.0, tau_max=tau_max)
        assert img.rgba[0, 0, 3] == pytest.approx(-np.expm1(-tau[-1]), abs=1e-9)
        errors[tau_max] = abs(img.rgba[0, 0, 0] - red)
    assert errors[1.0] < 2e-3 and errors[0.25] < 1e-4 and errors[0.05] < 1e-6
    assert errors[0.05] < errors[0.25] < errors[1.0]


def test_tetrahedralised_linear_field_matches_the_grid_ray_caster():
    """A field linear in x, y, z is the same function on the tets and on the grid:
    the exact tet integral and the grid's midpoint rule at a fine step agree."""
    shape = (6, 5, 7)
    spacing = 0.5
    origin = (-1.0, 0.5, 2.0)
    coef = np.array([0.3, -0.2, 0.25])
    pts, tets, values = box_mesh(shape, spacing, origin, field=lambda p: 1.0 + p @ coef)
    mesh = tetmesh_from_arrays(pts, tets, values)
    grid_values = np.empty((shape[2] + 1, shape[1] + 1, shape[0] + 1))
    zz, yy, xx = np.meshgrid(*(np.arange(n + 1) for n in shape[::-1]), indexing="ij")
    world = np.stack([xx, yy, zz], axis=-1) * spacing + np.asarray(origin)
    grid_values[:] = 1.0 + world @ coef
    volume = hv.volume_from_array(grid_values, spacing=(spacing,) * 3, origin=origin)
    tf = hv.TransferFunction.ramp(0.0, 3.0, cmap="viridis", opacity=(0.0, 0.7))
    cam = hv.Camera.fit(volume.bounds, "iso")
    a = hv.render(mesh, tf, cam, (24, 20), precision="float64", opacity_unit_distance=0.5, tau_max=0.002)
    b = hv.render(volume, tf, cam, (24, 20), precision="float64", opacity_unit_distance=0.5, step=0.02)
    assert a.rgba[..., 3].max() > 0.5
    assert np.abs(a.rgba - b.rgba).max() < 5e-5


# -- traversal ------------------------------------------------------------------------------
@pytest.mark.parametrize("shared", [True, False])
def test_no_ray_leaks_through_edges_and_vertices(shared):
    """Rays aimed at grid lines and vertices of a Kuhn mesh (and an oblique view) see the
    exact box thickness: a crack would let one through with less opacity."""
    pts, tets, values = box_mesh((4, 4, 4), shared=shared)
    mesh = tetmesh_from_arrays(pts, tets, values)
    sigma = 0.3
    tf = constant_tf(-math.expm1(-sigma))
    for cam, size in (
            # 9 x 9 pixel centres on x, y = 0, 0.5, ... 4: rays along grid lines (tet edges)
            (hv.Camera((2.0, 2.0, 20.0), (2.0, 2.0, 0.0), (0.0, 1.0, 0.0), parallel_projection=True,
                       parallel_scale=2.25), (9, 9)),
            # 17 x 17 centres every 0.25: through edges, vertices and the diagonal faces
            (hv.Camera((20.0, 2.0, 2.0), (0.0, 2.0, 2.0), (0.0, 0.0, 1.0), parallel_projection=True,
                       parallel_scale=2.125), (17, 17)),
            (oblique_camera((2.0, 2.0, 2.0), parallel=False), (48, 40))):
        img = hv.render(mesh, tf, cam, size, precision="float64", opacity_unit_distance=1.0)
        rays = cam.rays(size)
        length = slab_length(rays.origins, rays.directions, (0, 0, 0), (4, 4, 4))
        expected = -np.expm1(-sigma * length).reshape(size[::-1])
        # rays on the outer faces graze the box: either answer is right there
        inner = (slab_length(rays.origins, rays.directions, (1e-9,) * 3, (4 - 1e-9,) * 3) > 0).reshape(size[::-1])
        assert inner.sum() > 40
        np.testing.assert_allclose(img.rgba[..., 3][inner], expected[inner], rtol=0, atol=1e-12)
        assert img.metadata["stopped_rays"] == 0


def test_zero_volume_and_inverted_cells_are_crossed():
    """A collapsed layer of grid points (as the Blunt Fin's collapsed grid line) makes a
    layer of zero-volume cells with repeated corners; every other cell is inverted."""
    pts, tets, values = box_mesh((3, 3, 3))
    pts = pts.copy()
    pts[pts[:, 2] == 1.0, 2] = 0.0  # plane z = 1 onto z = 0: the bottom layer of cells is flat
    values = 1.0 + 0.1 * pts[:, 0]
    tets = tets.copy()
    tets[::2, [0, 1]] = tets[::2, [1, 0]]
    mesh = tetmesh_from_arrays(pts, tets, values)
    vols = mesh.cell_volumes()
    assert np.count_nonzero(vols == 0) == 54 and np.count_nonzero(vols < 0) > 50
    sigma = 0.5
    cam = oblique_camera((1.5, 1.5, 1.5), parallel=True, scale=2.6)
    img = hv.render(mesh, constant_tf(-math.expm1(-sigma)), cam, (40, 40), precision="float64",
                    opacity_unit_distance=1.0)
    rays = cam.rays((40, 40))
    length = slab_length(rays.origins, rays.directions, (0, 0, 0), (3, 3, 3))
    inner = length > 1e-6
    np.testing.assert_allclose(img.rgba[..., 3].ravel()[inner], -np.expm1(-sigma * length[inner]), rtol=0,
                               atol=1e-12)
    assert img.metadata["stopped_rays"] == 0


def test_cell_records_hold_the_mesh_and_wide_records_render_the_same(monkeypatch):
    """The walk's records (64 bytes a cell: corners, neighbour codes, values) hold the
    mesh's arrays; the int64 records of meshes too large for int32 render the same."""
    from pv_hdrvol.raycast import tets as T

    pts, tets, values = box_mesh((3, 2, 2), field=lambda p: 0.2 + 0.1 * p[:, 0] + 0.05 * p[:, 1])
    mesh = tetmesh_from_arrays(pts, tets, values)
    cells_i, cells_f = T._cell_records(mesh)
    col = 4  # the last four float64 columns hold the values
    assert cells_i.dtype == np.int32 and cells_f.shape == (mesh.n_cells, 8)
    assert cells_f.ctypes.data % 64 == 0
    np.testing.assert_array_equal(cells_i[:, :4], mesh.tets)
    codes = cells_i[:, 4:8]
    np.testing.assert_array_equal(np.where(codes >= 0, codes >> 2, -1), mesh.neighbors)
    np.testing.assert_array_equal(codes[codes >= 0] & 3, mesh.neighbor_faces[codes >= 0])
    np.testing.assert_array_equal(cells_f[:, col:col + 4], mesh.values)
    tf = hv.TransferFunction.ramp(0.2, 0.6, cmap="viridis", opacity=(0.1, 0.6))
    cam = oblique_camera((1.5, 1.0, 1.0))
    narrow = hv.render(mesh, tf, cam, (24, 24), precision="float64")
    monkeypatch.setattr(T, "INT32_RECORDS", 0)
    wide_mesh = tetmesh_from_arrays(pts, tets, values)
    cells_i, cells_f = T._cell_records(wide_mesh)
    assert cells_i.dtype == np.int64 and cells_f.shape == (mesh.n_cells, 12)
    np.testing.assert_array_equal(cells_f[:, 8:12], wide_mesh.values)
    wide = hv.render(wide_mesh, tf, cam, (24, 24), precision="float64")
    assert narrow.metadata["cells"] > 100
    np.testing.assert_array_equal(wide.rgba, narrow.rgba)
    np.testing.assert_array_equal(wide.depth, narrow.depth)


def test_rays_reenter_a_non_convex_mesh():
    """Two boxes one behind the other (a gap between them): each ray adds both lengths."""
    p1, t1, v1 = box_mesh((2, 2, 1))
    p2, t2, v2 = box_mesh((2, 2, 1), origin=(0.5, 0.0, 2.0))
    pts = np.concatenate([p1, p2])
    tets = np.concatenate([t1, t2 + len(p1)])
    mesh = tetmesh_from_arrays(pts, tets, np.concatenate([v1, v2]))
    sigma = 0.7
    cam = oblique_camera((1.2, 1.0, 1.5), parallel=False, distance=8.0)
    img = hv.render(mesh, constant_tf(-math.expm1(-sigma)), cam, (40, 36), precision="float64",
                    opacity_unit_distance=1.0)
    rays = cam.rays((40, 36))
    la = slab_length(rays.origins, rays.directions, (0, 0, 0), (2, 2, 1))
    lb = slab_length(rays.origins, rays.directions, (0.5, 0, 2), (2.5, 2, 3))
    both = (la > 1e-6) & (lb > 1e-6)
    assert both.sum() > 50
    ok = (la > 1e-6) | (lb > 1e-6)
    np.testing.assert_allclose(img.rgba[..., 3].ravel()[ok], -np.expm1(-sigma * (la + lb)[ok]), rtol=0,
                               atol=1e-12)


@numba.njit(cache=False)
def _plucker_all(points, tri, normals, cam, width, height, out):
    """``out[pixel, face]``: the distance of every crossing by the Plücker test."""
    for row in range(height):
        for col in range(width):
            for f in range(tri.shape[0]):
                t, enter = LK._plucker_hit(points, tri, normals, f, cam, col, row, width, height)
                if t >= 0.0 and t < math.inf:
                    out[row * width + col, f] = t


def _plucker_crossings(mesh, camera, size):
    """Per pixel, the sorted distances of every boundary face the ray crosses, by the
    ray caster's Plücker test on every pixel and face (no rasteriser, no boxes)."""
    from pv_hdrvol.raycast.tets import _boundary_normals, camera_array

    width, height = size
    cam = camera_array(camera, mesh, width, height)
    out = np.full((width * height, len(mesh.boundary)), np.inf)
    _plucker_all(mesh.points, mesh.boundary, _boundary_normals(mesh), cam, width, height, out)
    return [np.sort(row[np.isfinite(row)]) for row in out]


@pytest.mark.parametrize("parallel", [False, True])
def test_boundary_rasteriser_makes_the_plucker_decisions(parallel):
    """The renderer's boundary crossings (the rasteriser, with its row spans and the
    Plücker test for rays within rounding of an edge) are those of the Plücker test
    run on every pixel and face: on a jittered non-convex mesh seen close up (faces
    leave the image; the perspective eye is inside the second block, so 20 faces reach
    behind it), also at a size of 8 bands of rows (faces reach into several), and on a
    Kuhn box seen along z (parallel: every pixel centre on its edges and vertices;
    perspective: the central ray through a vertex)."""
    from pv_hdrvol.raycast.tets import boundary_crossings

    rng = np.random.default_rng(7)
    p1, t1, v1 = box_mesh((3, 2, 2))
    p2, t2, v2 = box_mesh((2, 2, 1), origin=(0.5, 0.0, 2.5))
    pts = np.concatenate([p1 + rng.uniform(-0.2, 0.2, p1.shape), p2])
    jittered = tetmesh_from_arrays(pts, np.concatenate([t1, t2 + len(p1)]), np.concatenate([v1, v2]))
    box = tetmesh_from_arrays(*box_mesh((4, 4, 4)))
    close = oblique_camera((1.5, 1.0, 1.5), distance=1.5 if not parallel else 8.0, parallel=parallel, scale=1.2)
    cases = [(jittered, close, (37, 29)), (jittered, close, (23, 131)),
             (box, hv.Camera((2.0, 2.0, 20.0), (2.0, 2.0, 0.0), (0.0, 1.0, 0.0), parallel_projection=parallel,
                             parallel_scale=2.25, view_angle=12.8), (9, 9))]
    for mesh, cam, size in cases:
        hits = boundary_crossings(mesh, cam, size)
        expected = _plucker_crossings(mesh, cam, size)
        counts = hits.counts().ravel()
        assert counts.sum() > 100
        np.testing.assert_array_equal(counts, [len(e) for e in expected])
        for pix, e in enumerate(expected):
            lo, hi = hits.offsets[pix], hits.offsets[pix + 1]
            np.testing.assert_allclose(hits.t[lo:hi], e, rtol=1e-12, atol=1e-12)


def test_rays_leave_and_reenter_through_a_non_conforming_interface():
    """Two blocks touching at x = 2 whose faces there are split by opposite diagonals
    (the second block is turned a quarter about x), as the LOX post's symmetry plane:
    the faces do not match, so a ray leaves the first block and enters the second at
    the same distance, which the rasteriser and the walk round differently. Rotated and
    oblique, so no distance is exact: the opacity is the whole length through both."""
    p1, t1, v1 = box_mesh((2, 3, 3), spacing=1.0)
    p2, t2, v2 = box_mesh((2, 3, 3), spacing=1.0)
    p2 = np.column_stack([p2[:, 0] + 2.0, 3.0 - p2[:, 2], p2[:, 1]])  # a quarter turn about x, then along x
    angle = 0.37
    rot = np.array([[math.cos(angle), -math.sin(angle), 0.0], [math.sin(angle), math.cos(angle), 0.0],
                    [0.0, 0.0, 1.0]])
    pts = np.concatenate([p1, p2]) @ rot.T + 0.1
    mesh = tetmesh_from_arrays(pts, np.concatenate([t1, t2 + len(p1)]), np.concatenate([v1, v2]))
    sigma = 0.45
    for parallel in (False, True):
        cam = oblique_camera(rot @ (2.0, 1.5, 1.5) + 0.1, parallel=parallel, distance=9.0, scale=2.6)
        img = hv.render(mesh, constant_tf(-math.expm1(-sigma)), cam, (61, 57), precision="float64",
                        opacity_unit_distance=1.0)
        rays = cam.rays((61, 57))
        # the same rays in the blocks' own frame (R is orthogonal: x R is R^T x)
        length = slab_length((rays.origins - 0.1) @ rot, rays.directions @ rot, (0, 0, 0), (4, 3, 3))
        crossing = slab_length((rays.origins - 0.1) @ rot, rays.directions @ rot, (1.9, 0, 0), (2.1, 3, 3)) > 1e-6
        inner = (length > 1e-6) & crossing
        assert inner.sum() > 150
        np.testing.assert_allclose(img.rgba[..., 3].ravel()[inner], -np.expm1(-sigma * length[inner]), rtol=0,
                                   atol=1e-9)


# -- precisions and extremes ----------------------------------------------------------------
def test_faint_opacity_over_thousands_of_cells():
    """Opacity 1e-7 per unit over 2,000 cells along the ray: float64 to 1e-12 relative,
    float32 (compensated sums) to 1e-6."""
    pts, tets, values = box_mesh((1, 1, 2000), spacing=1.0)
    mesh = tetmesh_from_arrays(pts, tets, values)
    tf = constant_tf(1e-7)
    cam = hv.Camera((0.3, 0.6, 3000.0), (0.3, 0.6, 0.0), (0.0, 1.0, 0.0), parallel_projection=True,
                    parallel_scale=0.01)
    expected = -math.expm1(2000 * math.log1p(-1e-7))
    for prec, rtol in (("float64", 1e-12), ("float32", 1e-6)):
        img = hv.render(mesh, tf, cam, (1, 1), precision=prec, opacity_unit_distance=1.0, termination=0.0)
        assert img.rgba[0, 0, 3] == pytest.approx(expected, rel=rtol)
        assert img.metadata["cells"] >= 2000 * 3  # at least three tets per cube along the ray
    half = hv.render(mesh, tf, cam, (1, 1), precision="float16", opacity_unit_distance=1.0, termination=0.0)
    assert abs(half.rgba[0, 0, 3] - expected) > 1e-3 * expected  # a 16-bit buffer loses it


@pytest.mark.parametrize("factor", [1e-9, 1e9])
def test_tiny_and_huge_coordinates_give_the_same_picture(factor):
    pts, tets, _ = box_mesh((3, 2, 2))
    values = pts @ np.array([0.2, 0.3, 0.1])
    tf = hv.TransferFunction.ramp(0.0, 1.2, cmap="viridis", opacity=(0.05, 0.6))
    ref = hv.render(tetmesh_from_arrays(pts, tets, values), tf, oblique_camera((1.5, 1, 1), parallel=False),
                    (20, 16), precision="float64", opacity_unit_distance=1.0)
    cam = oblique_camera((1.5 * factor, factor, factor), distance=10.0 * factor, parallel=False)
    img = hv.render(tetmesh_from_arrays(pts * factor, tets, values), tf, cam, (20, 16), precision="float64",
                    opacity_unit_distance=factor)
    assert ref.rgba[..., 3].max() > 0.3
    np.testing.assert_allclose(img.rgba, ref.rgba, rtol=0, atol=1e-12)
    np.testing.assert_allclose(img.depth[np.isfinite(ref.depth)] / factor, ref.depth[np.isfinite(ref.depth)],
                               rtol=1e-9)


def test_non_finite_values_make_their_cells_empty():
    pts, tets, values = box_mesh((2, 2, 2))
    values = values.copy()
    values[0] = np.nan
    values[-1] = np.inf
    mesh = tetmesh_from_arrays(pts, tets, values)
    img = hv.render(mesh, constant_tf(0.3), oblique_camera((1, 1, 1)), (16, 16), precision="float64")
    assert np.all(np.isfinite(img.rgba))
    full = hv.render(tetmesh_from_arrays(pts, tets, np.ones(len(pts))), constant_tf(0.3),
                     oblique_camera((1, 1, 1)), (16, 16), precision="float64")
    assert np.all(img.rgba[..., 3] <= full.rgba[..., 3] + 1e-15)
    assert np.any(img.rgba[..., 3] < full.rgba[..., 3] - 1e-3)


def test_active_cells_are_reused_per_transfer_function():
    pts, tets, values = box_mesh((3, 3, 3), field=lambda p: p[:, 0] / 3.0)
    mesh = tetmesh_from_arrays(pts, tets, values)
    cam = oblique_camera((1.5, 1.5, 1.5))
    upper = hv.TransferFunction.ramp(0.5, 1.0, cmap="gray", opacity=(0.0, 0.3))
    lower = hv.TransferFunction.ramp(0.0, 0.5, cmap="gray", opacity=(0.3, 0.0))
    first = hv.render(mesh, upper, cam, (16, 16), precision="float64")
    other = hv.render(mesh, lower, cam, (16, 16), precision="float64")
    assert len(mesh.cache["active_cells"]) == 2
    again = hv.render(mesh, upper, cam, (16, 16), precision="float64")
    assert len(mesh.cache["active_cells"]) == 2  # found, not rebuilt
    np.testing.assert_array_equal(again.rgba, first.rgba)
    assert not np.array_equal(other.rgba, first.rgba)
    # the same mask as a fresh mesh computes
    fresh = hv.render(tetmesh_from_arrays(pts, tets, values), upper, cam, (16, 16), precision="float64")
    np.testing.assert_array_equal(fresh.rgba, first.rgba)
    for opacity in (0.1, 0.2, 0.4):
        hv.render(mesh, hv.TransferFunction.ramp(0.5, 1.0, cmap="gray", opacity=(0.0, opacity)), cam, (8, 8))
    assert len(mesh.cache["active_cells"]) == 4


def test_cell_scalars_and_discontinuous_point_values():
    """Cell data: piecewise constant. Duplicated points carrying different values keep
    their jump: the lower and upper halves of a stack integrate their own opacity."""
    pts, tets, _ = box_mesh((1, 1, 2), shared=False)
    upper = pts[tets].mean(axis=1)[:, 2] > 1.0
    cell_values = np.where(upper, 1.5, 0.5)
    tf = hv.TransferFunction([0.0, 1.0, 2.0], [[1, 1, 1]] * 3, [0.0, 0.2, 0.6], table_size=65536)
    cam = hv.Camera((0.5, 0.4, 10.0), (0.5, 0.4, 0.0), (0.0, 1.0, 0.0), parallel_projection=True,
                    parallel_scale=0.01)
    a = hv.render(tetmesh_from_arrays(pts, tets, cell_values, association="cell"), tf, cam, (1, 1),
                  precision="float64", opacity_unit_distance=1.0)
    point_values = np.where(pts[:, 2] > 1.0, 1.5, 0.5)
    # points at z = 1 belong to both cubes: the lower cube's copies (own points) carry 0.5
    owner_upper = np.zeros(len(pts), dtype=bool)
    owner_upper[tets[upper].ravel()] = True
    point_values = np.where(owner_upper, 1.5, 0.5)
    b = hv.render(tetmesh_from_arrays(pts, tets, point_values), tf, cam, (1, 1), precision="float64",
                  opacity_unit_distance=1.0)
    sig_lo, sig_hi = -math.log(1 - 0.1), -math.log(1 - 0.4)
    expected = -math.expm1(-(sig_lo + sig_hi))
    # 1e-9: the table interpolates sigma = -ln(1 - a) linearly between its 65,536 entries
    assert a.rgba[0, 0, 3] == pytest.approx(expected, abs=1e-9)
    assert b.rgba[0, 0, 3] == pytest.approx(expected, abs=1e-9)


def test_caller_arrays_are_not_modified():
    pts, tets, values = box_mesh((2, 1, 1))
    pts32 = pts.astype(np.float32)
    copies = [pts32.copy(), tets.copy(), values.copy()]
    mesh = tetmesh_from_arrays(pts32, tets, values)
    hv.render(mesh, constant_tf(0.3), oblique_camera((1, 0.5, 0.5)), (8, 8))
    for before, after in zip(copies, (pts32, tets, values)):
        np.testing.assert_array_equal(before, after)


def test_mesh_properties():
    pts, tets, values = box_mesh((2, 1, 1), spacing=2.0, origin=(1.0, 2.0, 3.0), shared=False)
    mesh = tetmesh_from_arrays(pts, tets, values)
    assert mesh.bounds == (1.0, 5.0, 2.0, 4.0, 3.0, 5.0)
    assert len(mesh.world_points()) == 12  # duplicates merged: 3 x 2 x 2 grid points
    vols = mesh.cell_volumes()
    assert np.abs(vols).sum() == pytest.approx(16.0) and np.all(np.abs(np.abs(vols) - 16.0 / 12) < 1e-12)
    # 2 cubes x 6 faces x 2 triangles on the boundary, none inside
    assert len(mesh.boundary) == 20 and np.count_nonzero(mesh.neighbors >= 0) == 4 * 12 - 20
    assert repr(mesh).startswith("TetMesh(12 tets, 12 points, 20 boundary faces, scalars='' (point)")


# -- bad input -----------------------------------------------------------------------------
@pytest.mark.parametrize("args, kwargs, error, message", [
    ((np.zeros((4, 2)), [[0, 1, 2, 3]], np.zeros(4)), {}, ValueError,
     r"points must be a real array of shape \(m, 3\); got shape \(4, 2\)"),
    ((np.zeros((4, 3)), [[0, 1, 2]], np.zeros(4)), {}, ValueError,
     r"tets must be an integer array of shape \(n, 4\); got shape \(1, 3\)"),
    ((np.zeros((4, 3)), np.zeros((0, 4), dtype=int), np.zeros(4)), {}, ValueError, r"the mesh has no tetrahedra"),
    ((np.zeros((4, 3)), [[0, 1, 2, 4]], np.zeros(4)), {}, ValueError,
     r"tets index points 0..3; got indices 0..4"),
    ((np.zeros((4, 3)), [[0, 1, 2, 3]], np.zeros(5)), {}, ValueError,
     r"scalars '' has 5 values; the mesh has 4 points"),
    ((np.zeros((4, 3)), [[0, 1, 2, 3]], np.zeros(4)), {"association": "cell"}, ValueError,
     r"scalars '' has 4 values; the mesh has 1 cells"),
    ((np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0], [0, 0, 1.0]]), [[0, 1, 2, 3]], np.zeros(4)), {},
     ValueError, r"1 points of the tetrahedra have non-finite coordinates"),
    ((np.zeros((4, 3)), [[0, 1, 2, 3]], np.zeros(4)), {"association": "face"}, ValueError,
     r"association must be one of \['point', 'cell'\]; got 'face'"),
])
def test_bad_meshes(args, kwargs, error, message):
    with pytest.raises(error, match=message):
        tetmesh_from_arrays(*args, **kwargs)


def test_bad_render_arguments():
    pts, tets, values = box_mesh((1, 1, 1))
    mesh = tetmesh_from_arrays(pts, tets, values)
    with pytest.raises(ValueError, match=r"the camera is inside the mesh: \d+ rays start inside it"):
        hv.render(mesh, constant_tf(0.1), hv.Camera((0.5, 0.5, 0.5), (0.5, 0.5, 0.0), (0, 1, 0)), (8, 8))
    with pytest.raises(ValueError, match=r"tau_max must be > 0.0; got 0"):
        hv.render_tets(mesh, tau_max=0)
    with pytest.raises(ValueError, match=r"gradient_opacity is not supported for tetrahedral meshes"):
        hv.render(mesh, gradient_opacity=(0.0, 1.0))
    with pytest.raises(ValueError, match=r"labels= is not supported for tetrahedral meshes"):
        hv.render(mesh, labels=np.zeros(3))
    with pytest.raises(TypeError, match=r"camera must be a Camera, a view name or a PyVista/VTK camera \(not Rays: "
                                        r"a tetrahedral render makes its own rays\); got Rays"):
        hv.render(mesh, None, hv.Camera.fit(mesh).rays(4))
    with pytest.raises(ValueError, match=r"scalars names an array of a dataset; a TetMesh has its scalars already"):
        hv.render(mesh, scalars="x")
