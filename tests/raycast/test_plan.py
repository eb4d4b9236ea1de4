"""A render plan validated and prepared once, executed many times (issue 18, part 6):
every execution gives the pixels of a one-off render_volume, bit for bit."""
import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.raycast.grid import BlockGrid, GridPlan

pytestmark = pytest.mark.core


@pytest.fixture(scope="module")
def volume():
    rng = np.random.default_rng(7)
    values = rng.random((20, 18, 16))
    values[5:9, 4:12, 3:7] += 3.0
    return hv.volume_from_array(values, spacing=(1.0, 0.8, 1.2))


TF = hv.TransferFunction([0.0, 1.0, 4.0], [[0.2, 0.4, 0.9], [0.9, 0.5, 0.2], [1.0, 1.0, 1.0]], [0.0, 0.05, 0.6])


@pytest.mark.parametrize("precision", ["float64", "float32", "uint8"])
def test_executions_at_several_sizes_and_cameras_match_one_off_renders(volume, precision):
    plan = GridPlan(volume, TF, precision=precision, shade=precision != "uint8")
    for camera, size in [("iso", (24, 20)), ("xz", (40, 12)), ("iso", (7, 7))]:
        got = plan.execute(camera, size)
        ref = hv.render_volume(volume, TF, camera, size, precision=precision, shade=precision != "uint8")
        np.testing.assert_array_equal(got.rgba, ref.rgba)
        np.testing.assert_array_equal(got.depth, ref.depth)
        assert got.metadata["settings"] == ref.metadata["settings"]


def test_block_masks_reuse_the_prepared_arrays(volume):
    plan = GridPlan(volume, TF, precision="float32", block_size=4)
    prepared = plan._prepare()
    shape = BlockGrid.of(prepared.volume, 4).shape
    rng = np.random.default_rng(1)
    for _ in range(3):
        mask = rng.random(shape) < 0.6
        got = plan.execute("iso", (16, 16), block_mask=mask)
        ref = hv.render_volume(volume, TF, "iso", (16, 16), precision="float32", block_mask=mask)
        np.testing.assert_array_equal(got.rgba, ref.rgba)
    assert plan._prepare() is prepared  # built once


def test_a_labelled_plan_builds_its_styles_once(volume):
    labels = (volume.values > 2.0).astype(np.int32)
    styles = {1: "maximum"}
    plan = GridPlan(volume, TF, labels=labels, label_styles=styles, precision="float64")
    first = plan.execute("iso", (12, 12))
    slots = plan._prepare().styles
    second = plan.execute("xy", (12, 10))
    assert plan._prepare().styles is slots
    np.testing.assert_array_equal(first.rgba, hv.render_volume(volume, TF, "iso", (12, 12), labels=labels,
                                                               label_styles=styles, precision="float64").rgba)
    np.testing.assert_array_equal(second.rgba, hv.render_volume(volume, TF, "xy", (12, 10), labels=labels,
                                                                label_styles=styles, precision="float64").rgba)


def test_construction_validates_before_any_execution(volume):
    with pytest.raises(ValueError, match="step must be > 0; got -1"):
        GridPlan(volume, TF, step=-1)
    with pytest.raises(TypeError, match="tf must be a TransferFunction; got str"):
        GridPlan(volume, "magma")
    with pytest.raises(ValueError, match="labels need a floating-point precision"):
        GridPlan(volume, TF, labels=np.zeros(volume.values.shape, int), precision="uint8")


def test_a_tet_plan_matches_one_off_renders():
    from meshes import box_mesh
    from pv_hdrvol.raycast.tets import TetPlan

    pts, tets, _ = box_mesh((4, 3, 5))
    mesh = hv.tetmesh_from_arrays(pts, tets, np.sin(pts[:, 0]) + pts[:, 2] * 0.3)
    tf = hv.TransferFunction.ramp(-1.0, 2.5, cmap="gray", opacity=(0.05, 0.4))
    for precision, shade in [("float64", False), ("float32", True)]:
        plan = TetPlan(mesh, tf, precision=precision, shade=shade)
        for camera, size in [("iso", (20, 16)), ("xz", (9, 9))]:
            got = plan.execute(camera, size)
            ref = hv.render_tets(mesh, tf, camera, size, precision=precision, shade=shade)
            np.testing.assert_array_equal(got.rgba, ref.rgba)
            np.testing.assert_array_equal(got.depth, ref.depth)


@pytest.mark.parametrize("kwargs", [{}, {"shade": True}, {"precision": "uint8"},
                                    {"lens": hv.Magnifier((12.0, 9.0), radius=7.0, factor=2.0)}])
def test_a_window_is_the_full_render_cut(volume, kwargs):
    kwargs = dict(kwargs)
    lens = kwargs.pop("lens", None)
    plan = GridPlan(volume, TF, **kwargs)
    full = plan.execute("iso", (24, 20), lens=lens)
    for window in [(0, 0, 24, 20), (5, 3, 9, 11), (23, 19, 1, 1)]:
        col, row, w, h = window
        part = plan.execute("iso", (24, 20), lens=lens, window=window)
        assert part.shape == (h, w)
        np.testing.assert_array_equal(part.rgba, full.rgba[row:row + h, col:col + w])
        np.testing.assert_array_equal(part.depth, full.depth[row:row + h, col:col + w])
    with pytest.raises(ValueError, match=r"window \(20, 0, 5, 5\) reaches outside the 24x20 image"):
        plan.execute("iso", (24, 20), window=(20, 0, 5, 5))
    with pytest.raises(TypeError, match=r"window must be \(col, row, width, height\); got 3"):
        plan.execute("iso", (24, 20), window=3)


def test_box_mask_leap_radii_are_safe():
    """A one-box block mask (a block of a parallel render) takes its leap radii from the
    box: 0 on active blocks, never larger than the dilation's (so no active block is
    leapt over)."""
    from pv_hdrvol.raycast.grid import _box_leap_radius, _mask_box, leap_radius

    rng = np.random.default_rng(3)
    for _ in range(20):
        shape = tuple(rng.integers(1, 9, size=3))
        lo = np.array([rng.integers(0, n) for n in shape])
        hi = np.array([rng.integers(a, n) for a, n in zip(lo, shape)])
        mask = np.zeros(shape, bool)
        mask[lo[0]:hi[0] + 1, lo[1]:hi[1] + 1, lo[2]:hi[2] + 1] = True
        active = mask & (rng.random(shape) < 0.6)
        box = _mask_box(mask)
        assert box is not None and np.array_equal(box[0], lo) and np.array_equal(box[1], hi)
        fast, exact = _box_leap_radius(active, box), leap_radius(active)
        assert np.array_equal(fast == 0, active) and np.all(fast <= np.maximum(exact, 1))
    two = np.zeros((3, 3, 3), bool)
    two[0, 0, 0] = two[2, 2, 2] = True
    assert _mask_box(two) is None
