"""Curvilinear (structured) grids through the tet path: the alternating split of each
hexahedron into 5 tetrahedra (``data/structured.py``, VTK's vtkDataSetTriangleFilter
split), exactness for linear fields, conformity,
blanking, bad and degenerate grids, caching. Small grids and 32^2 images, all in
float64 so that one compiled kernel serves every render."""
import math

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.data.structured import collapsed_tets, structured_tets, visible_cells
from pv_hdrvol.data.tets import tetmesh_from_structured
from pv_hdrvol.data.tets import FACE_CORNERS, as_tetmesh, is_unstructured

from meshes import WHITE, constant_tf, oblique_camera, slab_length

SIZE = (32, 32)


def warped_box(dims=(6, 5, 4), lengths=(2.0, 1.5, 1.0), amplitude=0.08):
    """A structured grid filling the box [0, lengths] whose interior lattice is curved:
    each coordinate moves by ``amplitude * sin(pi x / L) * (smooth function of the
    others)``, which vanishes on the faces it crosses, so the boundary points slide
    along the box's faces and the domain stays the box while no cell is a
    parallelepiped."""
    axes = [np.linspace(0.0, L, n) for n, L in zip(dims, lengths)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    lx, ly, lz = lengths
    xs = x + amplitude * lx * np.sin(np.pi * x / lx) * np.cos(2.0 * y + z)
    ys = y + amplitude * ly * np.sin(np.pi * y / ly) * np.cos(1.5 * x - z)
    zs = z + amplitude * lz * np.sin(np.pi * z / lz) * np.cos(x + 2.5 * y)
    return pv.StructuredGrid(xs, ys, zs)


def shell_sector(dims=(4, 7, 3), radii=(1.0, 2.0), angle=1.2, height=1.0):
    """A cylindrical-shell sector: its cells are convex with planar faces (prisms on
    annular trapezoids), so every split of a cell has the cell's volume."""
    r, th, z = np.meshgrid(np.linspace(*radii, dims[0]), np.linspace(0.0, angle, dims[1]),
                           np.linspace(0.0, height, dims[2]), indexing="ij")
    return pv.StructuredGrid(r * np.cos(th), r * np.sin(th), z)


def linear_field(points):
    return 0.2 + 0.3 * points[:, 0] / 2.0 + 0.2 * points[:, 1] / 1.5 + 0.25 * points[:, 2]


def test_linear_field_on_a_curved_grid_matches_the_closed_form():
    """Constant extinction, colour linear in the scalar, scalar linear in x: along a ray
    the colour is c_f a + (c_b - c_f) / L (1 - e^{-sL} (1 + sL)) / s, a = 1 - e^{-sL},
    with L the ray's length in the box and c_f, c_b the field at its ends. Every split
    into tetrahedra and trilinear hexahedra reproduce a linear field exactly."""
    grid = warped_box()
    grid.point_data["f"] = linear_field(np.asarray(grid.points))
    sigma = 0.7
    tf = hv.TransferFunction([0.0, 1.0], [[0.0, 0.5, 1.0], [1.0, 0.5, 0.0]], [-math.expm1(-sigma)] * 2)
    for parallel in (True, False):
        cam = oblique_camera((1.0, 0.75, 0.5), distance=6.0, parallel=parallel, scale=1.6)
        img = hv.render(grid, tf, cam, SIZE, precision="float64", opacity_unit_distance=1.0)
        rays = cam.rays(SIZE)
        o, d = rays.origins, rays.directions
        d = d / np.linalg.norm(d, axis=1)[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (0.0 - o) / d, (np.array([2.0, 1.5, 1.0]) - o) / d
        t0 = np.maximum(np.nanmax(np.minimum(ta, tb), axis=1), 0.0)
        length = slab_length(o, d, (0, 0, 0), (2.0, 1.5, 1.0))
        inside = length > 1e-9
        front = linear_field(o + t0[:, None] * d)
        back = linear_field(o + (t0 + length)[:, None] * d)
        L = length[inside]
        a = -np.expm1(-sigma * L)
        ramp = (1.0 - np.exp(-sigma * L) * (1.0 + sigma * L)) / sigma / L
        red = front[inside] * a + (back[inside] - front[inside]) * ramp
        blue = (1.0 - front[inside]) * a + (front[inside] - back[inside]) * ramp
        rgba = img.rgba.reshape(-1, 4).astype(np.float64)
        assert inside.sum() > 300
        np.testing.assert_allclose(rgba[inside, 3], a, rtol=0, atol=1e-12)
        np.testing.assert_allclose(rgba[inside, 0], red, rtol=0, atol=1e-10)
        np.testing.assert_allclose(rgba[inside, 2], blue, rtol=0, atol=1e-10)
        np.testing.assert_allclose(rgba[~inside], 0.0, rtol=0, atol=1e-12)


def test_the_warped_box_is_curved_and_keeps_its_box():
    """The grid of the test above: points move by up to ~0.1 of the box, the boundary
    stays on the box, every tetrahedron keeps a positive volume."""
    grid = warped_box()
    straight = warped_box(amplitude=0.0)
    moved = np.abs(np.asarray(grid.points) - np.asarray(straight.points)).max()
    assert moved > 0.05
    np.testing.assert_allclose(grid.bounds, (0.0, 2.0, 0.0, 1.5, 0.0, 1.0), atol=1e-12)
    grid.point_data["f"] = np.ones(grid.n_points)
    vols = tetmesh_from_structured(grid).cell_volumes()
    assert vols.min() > 0 and vols.sum() == pytest.approx(3.0, abs=1e-12)


def _faces(tets):
    """Sorted corner triples of every face of ``tets`` and how often each occurs."""
    faces = np.sort(tets[:, FACE_CORNERS].reshape(-1, 3), axis=1)
    return np.unique(faces, axis=0, return_counts=True)


def _on_boundary(faces, dims):
    nx, ny, nz = dims
    i, j, k = faces % nx, (faces // nx) % ny, faces // (nx * ny)
    return ((i == 0).all(1) | (i == nx - 1).all(1) | (j == 0).all(1) | (j == ny - 1).all(1)
            | (k == 0).all(1) | (k == nz - 1).all(1))


@pytest.mark.parametrize("dims", [(2, 2, 2), (4, 4, 4), (4, 3, 5)])
def test_the_split_is_conforming(dims):
    """Every interior face lies on exactly two tetrahedra and every boundary face on
    one; the boundary faces are exactly the two triangles of each boundary quad of the
    lattice (two cells of opposite parity cut their common face the same way)."""
    nx, ny, nz = dims
    tets = structured_tets(np.zeros((nx * ny * nz, 3)), dims)
    assert tets.shape == (5 * (nx - 1) * (ny - 1) * (nz - 1), 4) and tets.dtype == np.int64
    faces, counts = _faces(tets)
    boundary = _on_boundary(faces, dims)
    np.testing.assert_array_equal(counts[boundary], 1)
    np.testing.assert_array_equal(counts[~boundary], 2)
    quads = (nx - 1) * (ny - 1) + (ny - 1) * (nz - 1) + (nx - 1) * (nz - 1)
    assert boundary.sum() == 2 * 2 * quads
    # per cell: 4 corner tetrahedra (each one corner and its 3 edge neighbours) and
    # the central one (4 pairwise diagonal corners), which alternates with i + j + k
    assert (np.sort(tets, axis=1)[:, 1:] != np.sort(tets, axis=1)[:, :-1]).all()
    cells = tets.reshape(-1, 5, 4)
    i, j, k = cells % nx, (cells // nx) % ny, cells // (nx * ny)
    lo = [a.min(axis=(1, 2)) for a in (i, j, k)]
    for a, m in zip((i, j, k), lo):
        assert (a.max(axis=(1, 2)) - m == 1).all()  # every tetrahedron within its cell
    bits = (i - lo[0][:, None, None]) + 2 * (j - lo[1][:, None, None]) + 4 * (k - lo[2][:, None, None])
    central = np.sort(bits[:, 4], axis=1)
    odd = (lo[0] + lo[1] + lo[2]) % 2 == 1
    np.testing.assert_array_equal(central[~odd], np.broadcast_to([0, 3, 5, 6], central[~odd].shape))
    np.testing.assert_array_equal(central[odd], np.broadcast_to([1, 2, 4, 7], central[odd].shape))


def test_the_split_is_vtks():
    """The same tetrahedra as vtkDataSetTriangleFilter on a structured grid (up to
    their order and the order of their corners), blanked cells included."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkFiltersGeneral import vtkDataSetTriangleFilter

    grid = warped_box((5, 4, 6))
    grid.BlankCell(7)
    f = vtkDataSetTriangleFilter()
    f.SetInputData(grid)
    f.Update()
    out = f.GetOutput()
    assert out.GetNumberOfPoints() == grid.n_points  # the filter keeps the points in order
    theirs = vtk_to_numpy(out.GetCells().GetConnectivityArray()).reshape(-1, 4)
    ours = structured_tets(np.asarray(grid.points), grid.dimensions, visible_cells(grid))
    assert len(ours) == 5 * (grid.n_cells - 1)
    np.testing.assert_array_equal(np.unique(np.sort(ours, axis=1), axis=0),
                                  np.unique(np.sort(theirs, axis=1), axis=0))


def test_pieces_of_a_grid_split_as_the_grid():
    """A piece whose extent starts at an odd index (i0 = 3) takes its parity from the
    global i + j + k, so it cuts the face it shares with the rest as the whole grid
    does (VTK's filter, counting from the piece's first cell, would flip it)."""
    from pv_hdrvol.data.structured import grid_start

    dims = (7, 6, 5)
    whole = structured_tets(np.zeros((7 * 6 * 5, 3)), dims).reshape(4, 5, 6, 5, 4)  # (k, j, i, tet, corner)
    sg = pv.ImageData(dimensions=dims).cast_to_structured_grid()
    piece = sg.extract_subset((3, 6, 0, 5, 0, 4))
    assert grid_start(piece) == (3, 0, 0) and tuple(piece.dimensions) == (4, 6, 5)
    local = structured_tets(np.asarray(piece.points), piece.dimensions, start=grid_start(piece))
    i, jk = local % 4, local // 4  # local point index -> global: i + 3 + 7 * (j + 6 k)
    np.testing.assert_array_equal((i + 3 + 7 * jk).reshape(4, 5, 3, 5, 4), whole[:, :, 3:])
    with pytest.raises(ValueError, match=r"start must be three integers \(i0, j0, k0\); got \(1, 2\)"):
        structured_tets(np.zeros((8, 3)), (2, 2, 2), start=(1, 2))


def test_tet_volumes_sum_to_the_hexahedra():
    grid = shell_sector()
    nx, ny, nz = grid.dimensions
    points = np.asarray(grid.points)
    tets = structured_tets(points, grid.dimensions)
    a, b, c, d = (points[tets[:, q]] for q in range(4))
    vols = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0
    # each cell: an annular trapezoid (radii r0 < r1, angle dt) times dz
    r = np.linspace(1.0, 2.0, nx)
    dt, dz = 1.2 / (ny - 1), 1.0 / (nz - 1)
    hexes = 0.5 * math.sin(dt) * (r[1:] ** 2 - r[:-1] ** 2) * dz  # per i; same for every j, k
    per_cell = vols.reshape(-1, 5).sum(axis=1).reshape(nz - 1, ny - 1, nx - 1)
    np.testing.assert_allclose(per_cell, np.broadcast_to(hexes, per_cell.shape), rtol=1e-12)
    assert vols.min() > 0  # a right-handed lattice (r, theta, z) gives positive tetrahedra


def test_point_data_lands_on_the_right_corners():
    grid = warped_box((4, 3, 3))
    grid.point_data["f"] = linear_field(np.asarray(grid.points))
    mesh = as_tetmesh(grid)
    corners = mesh.world_points()[mesh.tets]  # (n, 4, 3)
    np.testing.assert_allclose(mesh.values, linear_field(corners.reshape(-1, 3)).reshape(-1, 4), atol=1e-14)
    assert mesh.association == "point" and mesh.name == "f" and mesh.n_cells == 5 * 3 * 2 * 2


def test_cell_data_is_constant_on_each_hexahedron():
    grid = pv.ImageData(dimensions=(4, 3, 5)).cast_to_structured_grid()
    grid.cell_data["id"] = np.arange(grid.n_cells, dtype=np.float32)
    grid.point_data["p"] = np.zeros(grid.n_points)
    mesh = as_tetmesh(grid, scalars="id")
    assert mesh.association == "cell"
    centroid = mesh.world_points()[mesh.tets].mean(axis=1)
    i, j, k = np.floor(centroid).astype(int).T
    np.testing.assert_array_equal(mesh.values, np.repeat((i + 3 * (j + 2 * k))[:, None], 4, axis=1))
    # preference picks the cell array of a name that is both
    grid.point_data["id"] = np.full(grid.n_points, -1.0)
    assert as_tetmesh(grid, scalars="id").association == "point"
    assert as_tetmesh(grid, scalars="id", preference="cell").association == "cell"


def _column(n_cells=3):
    """A 1 x 1 x n column of unit cubes as a structured grid, constant scalars."""
    grid = pv.ImageData(dimensions=(2, 2, n_cells + 1)).cast_to_structured_grid()
    grid.point_data["f"] = np.ones(grid.n_points)
    return grid


def _down_camera():
    return hv.Camera((0.5, 0.5, 10.0), (0.5, 0.5, 0.0), (0.0, 1.0, 0.0), parallel_projection=True,
                     parallel_scale=0.4)


def test_blanked_cells_give_no_tetrahedra_and_rays_cross_the_gap():
    grid = _column(3)
    grid.BlankCell(1)
    mesh = as_tetmesh(grid)
    assert mesh.n_cells == 10
    z = mesh.world_points()[mesh.tets].mean(axis=1)[:, 2]
    assert not np.any((z > 1) & (z < 2))
    sigma = 0.5
    img = hv.render(grid, constant_tf(-math.expm1(-sigma)), _down_camera(), (4, 4), precision="float64",
                    opacity_unit_distance=1.0)
    # 2 units of medium, not 3: the ray leaves at z = 2 and re-enters at z = 1
    np.testing.assert_allclose(img.rgba[..., 3], -math.expm1(-2 * sigma), rtol=0, atol=1e-12)


def test_blanking_matches_is_cell_visible():
    grid = pv.ImageData(dimensions=(5, 4, 4)).cast_to_structured_grid()
    grid.BlankCell(3)
    grid.BlankCell(20)
    grid.BlankPoint(37)
    visible = visible_cells(grid)
    expected = np.array([bool(grid.IsCellVisible(c)) for c in range(grid.n_cells)])
    assert (~expected).sum() > 3  # a blanked point hides the cells around it
    np.testing.assert_array_equal(visible, expected)
    assert visible_cells(pv.ImageData(dimensions=(3, 3, 3)).cast_to_structured_grid()) is None


def test_a_nan_point_of_a_blanked_cell_is_allowed():
    grid = _column(2)
    pts = np.array(grid.points)
    pts[-1] = np.nan  # a corner of the top cell only
    grid.points = pts
    with pytest.raises(ValueError, match=r"1 points of the structured grid have non-finite coordinates .*"
                                         r"the first is point 11 \(i, j, k\) = \(1, 1, 2\)"):
        tetmesh_from_structured(grid)
    grid.BlankCell(1)
    assert tetmesh_from_structured(grid).n_cells == 5


def test_bad_grids():
    flat = pv.ImageData(dimensions=(4, 4, 1)).cast_to_structured_grid()
    flat.point_data["f"] = np.ones(flat.n_points)
    with pytest.raises(ValueError, match=r"must be 3-D.*got dimensions \(4, 4, 1\)"):
        hv.render(flat, size=SIZE)
    grid = _column(1)
    grid.BlankCell(0)
    with pytest.raises(ValueError, match="every cell of the structured grid is hidden"):
        tetmesh_from_structured(grid)
    with pytest.raises(hv.ScalarsError, match="'nope' not found"):
        tetmesh_from_structured(_column(1), scalars="nope")
    with pytest.raises(TypeError, match="expected a pyvista.StructuredGrid / vtkStructuredGrid; got ImageData"):
        tetmesh_from_structured(pv.ImageData(dimensions=(2, 2, 2)))
    with pytest.raises(ValueError, match=r"points must have shape \(8, 3\) for dims \(2, 2, 2\); got \(7, 3\)"):
        structured_tets(np.zeros((7, 3)), (2, 2, 2))
    with pytest.raises(ValueError, match=r"dims must be three integers \(nx, ny, nz\); got \(2, 2\)"):
        structured_tets(np.zeros((4, 3)), (2, 2))
    with pytest.raises(ValueError, match=r"visible must have one entry per cell \(2\); got 3"):
        structured_tets(np.zeros((12, 3)), (2, 2, 3), visible=np.ones(3, bool))


def test_collapsed_and_inverted_cells_render():
    """A 270-degree polar grid whose first grid line (r = 0) collapses to the axis, as
    at the Blunt Fin's nose, with one interior point pushed through its neighbour
    (inverted tetrahedra): the render is finite and stops no ray. The 2 of 5
    tetrahedra of each axis cell that have two equal corners are dropped: kept, they
    leave a false boundary face inside the mesh ("the camera is inside the mesh")."""
    r, th, z = np.meshgrid(np.linspace(0.0, 1.0, 4), np.linspace(0.0, 1.5 * np.pi, 7), np.linspace(0.0, 1.0, 4),
                           indexing="ij")
    x, y = r * np.cos(th), r * np.sin(th)
    x[2, 3, 1] = x[1, 3, 1] - 0.2 * (x[2, 3, 1] - x[1, 3, 1])  # r = 2/3 moved inside r = 1/3
    y[2, 3, 1] = y[1, 3, 1] - 0.2 * (y[2, 3, 1] - y[1, 3, 1])
    grid = pv.StructuredGrid(x, y, z)
    grid.point_data["f"] = 0.5 + 0.5 * np.asarray(grid.points)[:, 2]
    points = np.asarray(grid.points)
    tets = structured_tets(points, grid.dimensions)
    collapsed = collapsed_tets(points, tets)
    assert collapsed.sum() == 2 * 6 * 3  # 2 per axis cell, 6 x 3 axis cells
    mesh = as_tetmesh(grid)
    vols = mesh.cell_volumes()
    assert mesh.n_cells == len(tets) - 2 * 6 * 3 and np.count_nonzero(vols < 0) > 0
    assert (np.sort(mesh.tets, axis=1)[:, 1:] != np.sort(mesh.tets, axis=1)[:, :-1]).all()
    tf = hv.TransferFunction([0.0, 1.0], WHITE, [0.2, 0.6])
    for parallel in (True, False):
        img = hv.render(grid, tf, oblique_camera((0.0, 0.0, 0.5), distance=5.0, parallel=parallel, scale=1.3),
                        SIZE, precision="float64")
        assert np.isfinite(img.rgba).all() and img.rgba[..., 3].max() > 0.1 and img.rgba[..., 3].max() <= 1.0
        assert img.metadata["stopped_rays"] == 0


def test_a_flat_layer_of_distinct_points_is_crossed():
    """A layer of cells squashed flat without merging points (z of the layer k = 1
    slid onto k = 0, its inner points shifted in x by 0.2) gives zero-volume
    tetrahedra with 4 distinct corners: kept and crossed in zero length, so the
    constant medium's picture is that of the box that remains."""
    x, y, z = np.meshgrid(np.linspace(0.0, 2.0, 4), np.linspace(0.0, 1.5, 3), np.array([0.0, 0.0, 0.5, 1.0]),
                          indexing="ij")
    x = x.copy()
    x[1:-1, :, 1] += 0.2  # distinct from the layer below; the boundary stays on the box
    grid = pv.StructuredGrid(x, y, z)
    grid.point_data["f"] = np.ones(grid.n_points)
    mesh = as_tetmesh(grid)
    vols = mesh.cell_volumes()
    # the layer's 30 tetrahedra: 8 in its end cells (i = 0, 3: points merged) dropped, 22 flat
    assert mesh.n_cells == 5 * 3 * 2 * 3 - 8 and np.count_nonzero(np.abs(vols) < 1e-15) == 22
    sigma = 0.5
    cam = oblique_camera((1.0, 0.75, 0.5), distance=6.0, parallel=True, scale=1.6)
    img = hv.render(grid, constant_tf(-math.expm1(-sigma)), cam, SIZE, precision="float64",
                    opacity_unit_distance=1.0)
    rays = cam.rays(SIZE)
    length = slab_length(rays.origins, rays.directions, (0, 0, 0), (2.0, 1.5, 1.0))
    np.testing.assert_allclose(img.rgba[..., 3].ravel(), -np.expm1(-sigma * length), rtol=0, atol=1e-12)
    assert img.metadata["stopped_rays"] == 0


def test_a_left_handed_grid_renders_the_same_box():
    """i running along -x makes every tetrahedron inverted; the picture of a constant
    medium is still the box's Beer-Lambert."""
    x, y, z = np.meshgrid(np.linspace(2.0, 0.0, 4), np.linspace(0.0, 1.5, 3), np.linspace(0.0, 1.0, 3),
                          indexing="ij")
    grid = pv.StructuredGrid(x, y, z)
    grid.point_data["f"] = np.ones(grid.n_points)
    assert as_tetmesh(grid).cell_volumes().max() < 0
    sigma = 0.5
    cam = oblique_camera((1.0, 0.75, 0.5), distance=6.0, parallel=True, scale=1.6)
    img = hv.render(grid, constant_tf(-math.expm1(-sigma)), cam, SIZE, precision="float64",
                    opacity_unit_distance=1.0)
    rays = cam.rays(SIZE)
    length = slab_length(rays.origins, rays.directions, (0, 0, 0), (2.0, 1.5, 1.0))
    np.testing.assert_allclose(img.rgba[..., 3].ravel(), -np.expm1(-sigma * length), rtol=0, atol=1e-12)


def _raw_vtk(grid):
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkStructuredGrid

    raw = vtkStructuredGrid()
    raw.SetDimensions(*grid.dimensions)
    points = vtkPoints()
    points.SetData(numpy_to_vtk(np.array(grid.points), deep=True))
    raw.SetPoints(points)
    arr = numpy_to_vtk(np.array(grid.point_data["f"]), deep=True)
    arr.SetName("f")
    raw.GetPointData().SetScalars(arr)
    return raw


def test_pyvista_and_raw_vtk_grids_render_alike_and_stay_unmodified():
    grid = warped_box((4, 3, 3))
    grid.point_data["f"] = linear_field(np.asarray(grid.points))
    raw = _raw_vtk(grid)
    assert is_unstructured(grid) and is_unstructured(raw)
    points, values = np.array(grid.points), np.array(grid.point_data["f"])
    tf = hv.TransferFunction([0.0, 1.0], WHITE, [0.1, 0.8])
    cam = oblique_camera((1.0, 0.75, 0.5), distance=6.0, parallel=False, scale=1.6)
    a = hv.render(grid, tf, cam, SIZE, precision="float64")
    b = hv.render(raw, tf, cam, SIZE, precision="float64")
    np.testing.assert_array_equal(a.rgba, b.rgba)
    assert a.rgba[..., 3].max() > 0.1
    np.testing.assert_array_equal(grid.points, points)
    np.testing.assert_array_equal(grid.point_data["f"], values)
    assert list(grid.point_data.keys()) == ["f"] and list(grid.cell_data.keys()) == []
    assert raw.GetPointData().GetNumberOfArrays() == 1 and raw.GetCellData().GetNumberOfArrays() == 0


def test_the_prepared_mesh_is_cached_and_rebuilt_after_an_edit():
    grid = _column(2)
    first = as_tetmesh(grid)
    assert as_tetmesh(grid) is first
    grid.point_data["f"][:] = 2.0  # in place: no Modified()
    second = as_tetmesh(grid)
    assert second is not first and second.value_range == (2.0, 2.0)
    grid.points[0, 0] = -0.5  # in place again, now the coordinates
    third = as_tetmesh(grid)
    assert third is not second and third.bounds[0] == -0.5
    grid.BlankCell(1)
    assert as_tetmesh(grid).n_cells == 5
