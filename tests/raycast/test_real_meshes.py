"""Renders of the tetrahedral meshes of ../shared/data: SPX, Blunt Fin, the FEA bracket
and the LOX post (see its README for their origin).

Each mesh is rendered at 96x96 from ``Camera.fit(mesh, "iso")`` with a gray transfer
function (luminance 0.2 to 1.0), so every pixel obeys ``0.2 A <= Y <= A``; no ray may
hit the traversal guard; covered pixels are exactly those whose ray crosses the
boundary (every cell has a non-zero opacity); float32 matches float64.
"""
import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv

pytestmark = pytest.mark.data

SIZE = 96
MESHES = {
    "spx": ("spx_12936tets.vtk", "scalars", 12936, 2896),
    "bluntfin": ("bluntfin_187395tets.vtu", "Density", 187395, 40921),
    "bracket": ("fea_bracket_56786tets.vtu", "Equivalent (von-Mises) Stress (psi)", 56786, 16468),
    "post": ("post_513375tets.vtu", "VelocityMagnitude", 513375, 108300),
}


@pytest.fixture(scope="module", params=sorted(MESHES))
def case(request, shared_data):
    name, scalars, n_tets, n_points = MESHES[request.param]
    grid = pv.read(shared_data / "unstructured" / name)
    mesh = hv.tetmesh_from_dataset(grid, scalars)
    lo, hi = mesh.value_range
    tf = hv.TransferFunction([lo, hi], [[0.2, 0.2, 0.2], [1.0, 1.0, 1.0]], [0.05, 0.4])
    cam = hv.Camera.fit(mesh.bounds, "iso")
    images = {p: hv.render(mesh, tf, cam, SIZE, precision=p) for p in ("float64", "float32")}
    layers = hv.depth_layers(mesh, cam, SIZE, max_layers=8)
    return request.param, grid, mesh, n_tets, n_points, images, layers


def test_mesh_preparation(case):
    key, grid, mesh, n_tets, n_points, _, _ = case
    assert mesh.n_cells == n_tets and len(mesh.points) == n_points
    vols = mesh.cell_volumes()
    if key == "bluntfin":  # the collapsed grid line of the PLOT3D grid (README)
        assert np.count_nonzero(np.abs(vols) < 1e-12 * np.abs(vols).max()) == 77
    # the boundary is closed: every edge of a boundary face is shared by an even number of them
    edges = np.sort(mesh.boundary[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts % 2 == 0)


def test_every_ray_finishes_and_pixels_are_bounded(case):
    *_, images, layers = case
    for img in images.values():
        assert img.metadata["stopped_rays"] == 0
        rgba = np.asarray(img.rgba, dtype=np.float64)
        assert np.all(np.isfinite(rgba))
        a = rgba[..., 3]
        y = rgba[..., :3] @ np.array([0.2126, 0.7152, 0.0722])
        assert np.all((a >= 0) & (a <= 1))
        assert np.all(y >= 0.2 * a - 1e-6) and np.all(y <= a + 1e-6)


def test_covered_pixels_are_those_crossing_the_boundary(case):
    *_, images, layers = case
    covered = images["float64"].rgba[..., 3] > 0
    assert np.array_equal(covered, layers.counts > 0)
    assert np.all(layers.counts % 2 == 0)  # every ray that enters leaves
    assert layers.layers_needed == layers.counts.max() >= 2
    assert layers.n_layers == min(8, layers.layers_needed)


def test_float32_matches_float64(case):
    *_, images, _ = case
    assert np.abs(images["float32"].rgba - images["float64"].rgba).max() < 1e-5
