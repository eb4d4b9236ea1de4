"""``dataset.hdrvol``: the PyVista accessor, found through the entry point."""
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import pyvista as pv
from vtkmodules.vtkRenderingCore import vtkCamera

import pv_hdrvol as hv
from pv_hdrvol.integrations.pyvista_accessor import HDRVolAccessor

SIZE = (24, 16)


@pytest.fixture
def grid():
    g = pv.ImageData(dimensions=(12, 10, 9), spacing=(1.0, 0.5, 2.0), origin=(-3.0, 1.0, 0.0))
    x, y, z = g.points.T
    g.point_data["density"] = np.exp(-0.5 * ((x + 1) ** 2 / 4 + (y - 3) ** 2 + (z - 8) ** 2 / 16)) * 1e3
    g.point_data["other"] = np.linspace(0.0, 1.0, g.n_points)
    g.cell_data["other"] = np.linspace(1.0, 0.0, g.n_cells)
    g.set_active_scalars("density")
    return g


def _snapshot(g):
    return ({k: np.array(g.point_data[k]) for k in g.point_data}, {k: np.array(g.cell_data[k]) for k in g.cell_data},
            g.active_scalars_name, g.GetMTime(), g.bounds)


def _assert_unchanged(g, snap):
    points, cells, active, mtime, bounds = snap
    assert sorted(g.point_data) == sorted(points) and sorted(g.cell_data) == sorted(cells)
    for k, v in points.items():
        np.testing.assert_array_equal(g.point_data[k], v)
    for k, v in cells.items():
        np.testing.assert_array_equal(g.cell_data[k], v)
    assert g.active_scalars_name == active and g.GetMTime() == mtime and g.bounds == bounds


def test_entry_point_discovery_without_importing_pv_hdrvol():
    code = textwrap.dedent("""
        import sys
        import pyvista as pv
        g = pv.ImageData(dimensions=(8, 8, 8))
        before = "pv_hdrvol" in sys.modules
        listed = "hdrvol" in dir(g)
        accessor = g.hdrvol
        print(before, listed, type(accessor).__module__, type(accessor).__name__, accessor is g.hdrvol)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.split() == ["False", "True", "pv_hdrvol.integrations.pyvista_accessor", "HDRVolAccessor",
                                  "True"]


def test_render_equals_core_render_and_leaves_dataset_alone(grid):
    snap = _snapshot(grid)
    tf = hv.TransferFunction.ramp(1e-3, 1e3, scale="log", cmap="gray", opacity=(0.0, 0.3))
    img = grid.hdrvol.render(tf=tf, size=SIZE, step=0.7, precision="float64")
    ref = hv.render(grid, tf, hv.Camera.fit(grid.bounds, "iso"), SIZE, step=0.7, precision="float64")
    assert img.shape == (16, 24) and img.rgba.dtype == np.float64
    np.testing.assert_array_equal(img.rgba, ref.rgba)
    np.testing.assert_array_equal(img.depth, ref.depth)
    assert img.rgba[..., 3].max() > 0  # something was hit
    _assert_unchanged(grid, snap)


def test_scalars_and_preference(grid):
    snap = _snapshot(grid)
    for preference in ("point", "cell"):
        img = grid.hdrvol.render(scalars="other", preference=preference, size=SIZE, step=1.0)
        ref = hv.render(grid, None, hv.Camera.fit(grid, "iso"), SIZE, scalars="other", preference=preference,
                        step=1.0)
        np.testing.assert_array_equal(img.rgba, ref.rgba)
        assert img.metadata["scalars"] == "other"
    with pytest.raises(hv.ScalarsError, match=r"scalars 'nope' not found; point arrays: \['density', 'other'\]"):
        grid.hdrvol.render(scalars="nope", size=SIZE)
    _assert_unchanged(grid, snap)


def test_cameras(grid):
    cam = hv.Camera((30.0, -20.0, 15.0), (0.0, 3.0, 8.0), (0.0, 0.0, 1.0), view_angle=40.0)
    ref = hv.render(grid, None, cam, SIZE, step=1.0)
    np.testing.assert_array_equal(grid.hdrvol.render(camera=cam, size=SIZE, step=1.0).rgba, ref.rgba)
    vcam = vtkCamera()
    vcam.SetPosition(cam.position)
    vcam.SetFocalPoint(cam.focal_point)
    vcam.SetViewUp(cam.view_up)
    vcam.SetViewAngle(cam.view_angle)
    np.testing.assert_array_equal(grid.hdrvol.render(camera=vcam, size=SIZE, step=1.0).rgba, ref.rgba)
    pcam = pv.Camera()
    pcam.position, pcam.focal_point, pcam.up, pcam.view_angle = cam.position, cam.focal_point, cam.view_up, 40.0
    np.testing.assert_array_equal(grid.hdrvol.render(camera=pcam, size=SIZE, step=1.0).rgba, ref.rgba)
    xy = grid.hdrvol.render(camera="xy", size=SIZE, step=1.0)
    np.testing.assert_array_equal(xy.rgba, hv.render(grid, None, hv.Camera.fit(grid, "xy"), SIZE, step=1.0).rgba)
    with pytest.raises(ValueError, match=r"view must be one of \['iso', 'xy', .*\]; got 'top'"):
        grid.hdrvol.render(camera="top", size=SIZE)
    with pytest.raises(TypeError, match=r"camera must be None, a view name such as 'iso' or 'xy', .*; got int"):
        grid.hdrvol.render(camera=3, size=SIZE)


def test_plotter_camera(grid):
    plotter = pv.Plotter(off_screen=True)
    try:
        plotter.camera_position = [(30.0, -20.0, 15.0), (0.0, 3.0, 8.0), (0.0, 0.0, 1.0)]
        img = grid.hdrvol.render(camera=plotter, size=SIZE, step=1.0)
        ref = hv.render(grid, None, hv.Camera.from_pyvista(plotter.camera), SIZE, step=1.0)
        np.testing.assert_array_equal(img.rgba, ref.rgba)
    finally:
        plotter.close()


def test_progress_and_abort(grid):
    seen = []
    grid.hdrvol.render(size=(16, 64), progress=seen.append)
    assert seen[-1] == 1.0 and seen == sorted(seen)
    with pytest.raises(RuntimeError, match="render aborted"):
        grid.hdrvol.render(size=(16, 64), progress=lambda f: False)


def test_option_errors(grid):
    with pytest.raises(TypeError, match=r"unknown render option\(s\) \['stepsize'\]"):
        grid.hdrvol.render(size=SIZE, stepsize=0.5)
    with pytest.raises(ValueError, match=r"step must be > 0; got -1"):
        grid.hdrvol.render(size=SIZE, step=-1)


def test_other_datasets_are_refused():
    from pv_hdrvol.data.kinds import SUPPORTED

    with pytest.raises(TypeError) as info:
        pv.Sphere().hdrvol.render(size=SIZE)
    assert str(info.value) == (f"pv_hdrvol renders {SUPPORTED}; got PolyData: a surface or point cloud has no "
                               f"volume to render; sample it onto an ImageData (pyvista.ImageData(...).sample(data)) "
                               f"or interpolate it (data.interpolate)")
    with pytest.raises(TypeError, match=r"pv_hdrvol renders .*; got Table$"):
        pv.Table().hdrvol.render(size=SIZE)
    # attribute access itself never raises: dir() and hasattr() keep working
    assert hasattr(pv.Sphere(), "hdrvol")
    assert repr(pv.Sphere().hdrvol) == ("<hdrvol accessor of PolyData: not renderable (not a volume: see "
                                        "pv_hdrvol.data.kinds)>")


def test_tetrahedral_meshes_render_through_the_accessor():
    """A tetrahedralised image renders like the image itself (same camera, same tf)."""
    grid = pv.ImageData(dimensions=(5, 4, 6), spacing=(0.5, 0.5, 0.5))
    x, y, z = grid.points.T
    grid["s"] = 0.2 * x + 0.3 * y + 0.1 * z
    tets = grid.triangulate()
    tets["other"] = np.arange(tets.n_cells, dtype=float)
    assert isinstance(tets, pv.UnstructuredGrid)
    tf = hv.TransferFunction.ramp(0.0, 1.2, cmap="viridis", opacity=(0.0, 0.6))
    unit = 0.5
    a = tets.hdrvol.render(scalars="s", tf=tf, size=SIZE, precision="float64", opacity_unit_distance=unit)
    b = grid.hdrvol.render(scalars="s", tf=tf, size=SIZE, precision="float64", opacity_unit_distance=unit, step=0.02)
    assert a.metadata["renderer"] == "pv_hdrvol tetrahedral ray caster"
    assert np.abs(a.rgba - b.rgba).max() < 2e-4
    assert "5x4x6" not in repr(tets.hdrvol) and f"{tets.n_cells} cells" in repr(tets.hdrvol)
    with pytest.raises(ValueError, match=r"lens= is not supported for tetrahedral meshes"):
        tets.hdrvol.render(scalars="s", size=SIZE, lens=hv.Fisheye())
    with pytest.raises(ValueError, match=r"tetrahedral meshes support blending='composite' only; got 'maximum'"):
        tets.hdrvol.render(scalars="s", size=SIZE, blending="maximum")


def test_tet_mesh_cache_follows_the_grid():
    """The prepared mesh is reused until the grid changes, and does not keep it alive."""
    import gc

    from pv_hdrvol.data import tets as T

    mesh = pv.ImageData(dimensions=(4, 3, 3)).triangulate()
    mesh["s"] = np.linspace(0.0, 1.0, mesh.n_points)
    first = T.as_tetmesh(mesh)
    assert T.as_tetmesh(mesh) is first
    mesh["s"] = np.linspace(1.0, 2.0, mesh.n_points)  # PyVista marks the grid modified
    second = T.as_tetmesh(mesh)
    assert second is not first and second.value_range == (1.0, 2.0)
    mtime = mesh.GetMTime()
    mesh["s"].view(np.ndarray)[:] = 3.0  # an in-place edit that calls no Modified()
    assert mesh.GetMTime() == mtime
    third = T.as_tetmesh(mesh)
    assert third is not second and third.value_range == (3.0, 3.0)
    mesh.points.view(np.ndarray)[0] += 0.25  # moved points, in place
    assert mesh.GetMTime() == mtime
    assert T.as_tetmesh(mesh) is not third
    assert T.as_tetmesh(mesh) is T.as_tetmesh(mesh)
    key = id(mesh)
    del mesh
    gc.collect()
    entry = T._MESH_CACHE.get(key)
    assert entry is None or entry[0]() is None  # held weakly


def test_repr_and_cache(grid):
    accessor = grid.hdrvol
    assert accessor is grid.hdrvol and isinstance(accessor, HDRVolAccessor)
    assert repr(accessor) == ("<hdrvol accessor of ImageData (12, 10, 9); arrays: point 'density', point 'other', "
                              "cell 'other'; active scalars: 'density'; call .render(scalars=, tf=, camera=, size=, "
                              "**options)>")


def test_second_render_reuses_the_prepared_volume_until_the_dataset_changes():
    grid = pv.ImageData(dimensions=(9, 9, 9))
    grid["v"] = np.linspace(0.0, 1.0, grid.n_points)
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray", opacity=(0.0, 0.3))
    first = grid.hdrvol.render(tf=tf, size=(8, 8), precision="float64")
    volume = grid.hdrvol._volumes.get(grid, None, "point")
    again = grid.hdrvol.render(tf=tf, size=(8, 8), precision="float64")
    assert grid.hdrvol._volumes.get(grid, None, "point") is volume  # bricks built once
    np.testing.assert_array_equal(first.rgba, again.rgba)
    grid["v"][:] = 0.0  # in-place edit, then tell VTK, as its pipelines require
    grid.Modified()
    with pytest.warns(hv.EmptyRenderWarning, match=r"opacity is 0 over the whole data range \[0, 0\]"):
        changed = grid.hdrvol.render(tf=tf, size=(8, 8), precision="float64")
    assert grid.hdrvol._volumes.get(grid, None, "point") is not volume
    assert not changed.rgba.any()


def test_a_dataset_keeps_its_prepared_volume_until_its_data_change():
    import gc

    from pv_hdrvol.data import grid as data_grid
    from pv_hdrvol.raycast.grid import as_volume

    grid = pv.ImageData(dimensions=(12, 11, 10), spacing=(1.0, 0.5, 2.0))
    grid["v"] = np.linspace(0.0, 1.0, grid.n_points)
    first = as_volume(grid)
    assert as_volume(grid) is first  # bricks and block grids on it are reused
    before = grid["v"].copy()
    mtime = grid.GetMTime()
    grid["v"].view(np.ndarray)[:5] = 7.0  # an in-place edit that calls no Modified(): still seen
    assert grid.GetMTime() == mtime
    edited = as_volume(grid)
    assert edited is not first and edited.value_range == (float(grid["v"][5]), 7.0)
    grid.spacing = (1.0, 1.0, 1.0)
    assert as_volume(grid) is not edited
    # the render of a cached volume equals a fresh one
    again = hv.render(grid, None, None, 16, precision="float64")
    fresh = hv.render(hv.volume_from_dataset(grid), None, None, 16, precision="float64")
    np.testing.assert_array_equal(again.rgba, fresh.rgba)
    np.testing.assert_array_equal(grid["v"][5:], before[5:])  # the caller's data are untouched
    # the cache holds datasets weakly, and forgets a dataset that is gone
    key = id(grid)
    assert key in data_grid._VOLUME_CACHE
    del grid, first, edited
    gc.collect()
    assert key not in data_grid._VOLUME_CACHE
