"""The view-independent occlusion bound (../shared/notes/methods.md A.7): no block the
termination oracle R1 needs is culled, culled renders equal unculled ones bit for bit
under termination at the threshold, an exact count behind an opaque slab, the
per-basis bound of families, the lower-level function, and bad arguments."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.culling.bound import (OcclusionBound, group_extinction, group_ranges, march_slack, occluded_blocks,
                                     table_axis)
from pv_hdrvol.culling.reference import ert_oracle
from pv_hdrvol.params import RenderOptions
from pv_hdrvol.raycast.grid import as_volume
from pv_hdrvol.data.grid import volume_from_array

pytestmark = pytest.mark.core

TERMINATION = 0.05  # = 1 - the bound's threshold
WHITE = [[1, 1, 1]] * 2
N = 40


def _radius(n=N):
    x = (np.arange(n) - (n - 1) / 2) / (n / 2)
    return np.sqrt(x[:, None, None] ** 2 + x[None, :, None] ** 2 + x[None, None, :] ** 2)


def _ball():
    noise = np.random.default_rng(1).random((N, N, N))
    return np.where(_radius() < 0.8, 150 + 100 * noise, 20 * noise)


RAMP = hv.TransferFunction([0, 60, 100, 255], [(0, 0, 0), (1, 0.9, 0.8), (1, 0.9, 0.8), (1, 1, 1)],
                           [0, 0, 0.9, 0.99], table_size=256)


def _ortho(volume, d=(1.0, 0.7, 0.4)):
    b = np.asarray(as_volume(volume).bounds, dtype=np.float64)
    centre = 0.5 * (b[0::2] + b[1::2])
    radius = 0.5 * float(np.linalg.norm(b[1::2] - b[0::2]))
    d = np.asarray(d) / np.linalg.norm(d)
    return hv.Camera(tuple(centre + 3 * radius * d), tuple(centre), (0, 0, 1), parallel_projection=True,
                     parallel_scale=radius)


def _check(values, tf, camera, size, group, block=8, **options):
    """The bound's culled blocks (of ``block`` cells) against R1, and the culled render
    against the unculled one; returns the number culled."""
    volume = as_volume(values)
    opts = RenderOptions.from_kwargs(None, termination=TERMINATION, **options)
    needed, met, stats = OcclusionBound(group, block_size=block).blocks(volume, tf, camera, size, opts, block)
    culled = met & ~needed
    r1 = ert_oracle(volume, tf, camera, size, block_size=block, threshold=1 - TERMINATION, **options)
    assert not (culled & r1).any(), f"false culls: {int((culled & r1).sum())} (group {group})"
    full = hv.render(volume, tf, camera, size, termination=TERMINATION, progress_bar=False, **options)
    cut = hv.render(volume, tf, camera, size, termination=TERMINATION, cull=OcclusionBound(group),
                    progress_bar=False, **options)
    assert np.array_equal(full.rgba, cut.rgba), f"group {group}: max |diff| {np.abs(full.rgba - cut.rgba).max()}"
    assert cut.metadata["culling"]["group"] == group
    return int(culled.sum())


# -- analytic: an exact count --------------------------------------------------------------
@pytest.mark.parametrize("group", [1, 2, 4])
def test_opaque_slab_culls_the_blocks_behind_it_exactly(group):
    """Points x <= 8 are opaque (sigma = ln 10 per voxel at full opacity 0.9); rays along
    +x reach the target -ln 0.05 = 3.0 after two samples (0.5 and 1.5: depth >= 2 x 2.27),
    so of the 4 x 4 x 4 blocks of 4 cells, the 3 columns x = 1, 2, 3 (16 blocks each) are
    culled and column 0 is not: 48, for every group size whose groups in the slab are
    all opaque (the table's widened span reads entries 254 and 255: 2.268 per voxel)."""
    values = np.zeros((16, 16, 16))
    values[:, :, :9] = 1.0
    tf = hv.TransferFunction([0.0, 1.0], WHITE, [0.0, 0.9])
    camera = hv.Camera((-50, 7.5, 7.5), (7.5, 7.5, 7.5), (0, 0, 1), parallel_projection=True, parallel_scale=12)
    image = hv.render(values, tf, camera, (32, 32), cull=OcclusionBound(group), termination=TERMINATION, block_size=4,
                      progress_bar=False)
    stats = image.metadata["culling"]
    assert (stats["met"], stats["culled"]) == (64, 48)
    full = hv.render(values, tf, camera, (32, 32), termination=TERMINATION, block_size=4, progress_bar=False)
    assert np.array_equal(image.rgba, full.rgba)
    assert _check(values, tf, camera, (32, 32), group, block=4) == 48


def test_slab_thinner_than_the_target_culls_nothing():
    """One voxel of opacity 0.9: optical depth 2.3 < 3.0, nothing is occluded."""
    values = np.zeros((16, 16, 16))
    values[:, :, :2] = 1.0
    tf = hv.TransferFunction([0.0, 1.0], WHITE, [0.0, 0.9])
    camera = hv.Camera((-50, 7.5, 7.5), (7.5, 7.5, 7.5), (0, 0, 1), parallel_projection=True, parallel_scale=12)
    assert _check(values, tf, camera, (32, 32), 1, block=4) == 0


def test_slack_is_the_rounding_margin():
    target, slack = march_slack(0.95, "float32")
    assert target == pytest.approx(-math.log(0.05), rel=1e-15)
    assert slack == pytest.approx(2.0**-23 / 0.05, rel=1e-15)


# -- no false cull, images bit for bit ------------------------------------------------------
@pytest.mark.parametrize("group", [1, 2, 4])
def test_dense_ball(group):
    culled = _check(_ball(), RAMP, _ortho(_ball()), (48, 48), group)
    assert culled > 0


@pytest.mark.parametrize("group", [1, 2, 4])
def test_dense_ball_float64(group):
    _check(_ball(), RAMP, _ortho(_ball(), (-0.3, 1.0, -0.6)), (40, 40), group, precision="float64", step=0.7)


@pytest.mark.parametrize("group", [1, 2, 4])
def test_thin_shell(group):
    r = _radius()
    values = np.where(np.abs(r - 0.7) < 0.08, 200.0, 0.0)
    culled = _check(values, RAMP, _ortho(values), (48, 48), group)
    if group == 1:
        assert culled > 0  # the far side of the shell


@pytest.mark.parametrize("group", [1, 2, 4])
def test_sixteen_decades_log_transfer_function(group):
    values = 10.0 ** (16.0 * np.clip(1.0 - _radius(), 0, 1) - 8.0)  # 1e-8 at the corners to 1e8 at the centre
    tf = hv.TransferFunction([1e-8, 1.0, 1e8], [(0, 0, 1), (1, 1, 0), (1, 0, 0)], [0.0, 0.2, 1.0], scale="log")
    culled = _check(values, tf, _ortho(values, (0.2, -1.0, 0.5)), (48, 48), group)
    if group == 1:
        assert culled > 0


@pytest.mark.parametrize("group", [1, 2, 4])
def test_nan_regions(group):
    values = _ball()
    values[:, :, 20:24] = np.nan  # a NaN slab through the middle of the ball
    values[5:9, 5:30, 25:35] = np.nan
    vol = as_volume(values)
    lo, hi = group_ranges(vol.values, group)
    assert np.isnan(lo).any() and np.isnan(hi).any()
    culled = _check(values, RAMP, _ortho(values, (1.0, 0.1, 0.1)), (48, 48), group)
    assert culled > 0


@pytest.mark.parametrize("group", [1, 2, 4])
def test_perspective_camera_inside_the_volume(group):
    values = _ball()
    camera = hv.Camera((19.5, 19.5, 19.5), (40.0, 25.0, 22.0), (0, 0, 1), view_angle=70.0)
    _check(values, RAMP, camera, (40, 40), group)
    outside = hv.Camera((90.0, 60.0, 45.0), (19.5, 19.5, 19.5), (0, 0, 1), view_angle=30.0)
    assert _check(values, RAMP, outside, (40, 40), group) > 0


@pytest.mark.parametrize("group", [1, 2, 4])
def test_engine_iso(shared_data, group):
    pv = pytest.importorskip("pyvista")  # the core run (Debian's Python) has none

    volume = as_volume(pv.read(shared_data / "structured" / "engine_256x256x128_uint8.vti"))
    tf = hv.TransferFunction([0, 60, 100, 255], [(0, 0, 0), (1, 0.9, 0.8), (1, 0.9, 0.8), (1, 1, 1)],
                             [0, 0, 0.9, 0.99], table_size=256)
    camera = hv.Camera.fit(volume.bounds, "iso")
    assert _check(volume, tf, camera, (128, 128), group, block=16) > 0


# -- families ------------------------------------------------------------------------------
def test_family_per_basis_minima_bound_every_weight_vector():
    skin = hv.TransferFunction([0, 40, 80, 255], WHITE * 2, [0, 0.3, 0.3, 0.0], table_size=256)
    bone = hv.TransferFunction([0, 120, 200, 255], WHITE * 2, [0, 0, 0.95, 0.99], table_size=256)
    values = _ball()
    lo, hi = group_ranges(as_volume(values).values, 2)
    for k in ([1.0, 1.0], [0.25, 0.9], [0.0, 2.0], [3.0, 0.0]):
        family = hv.TransferFunction.family([skin, bone], k)
        per_basis = group_extinction(lo, hi, family.basis_tables(), table_axis(family), weights=k)
        direct = group_extinction(lo, hi, family.table()[1], table_axis(family))
        assert np.all(per_basis <= direct)
        # one basis alone: the per-basis bound is the family's own minimum (k scales it)
        single = group_extinction(lo, hi, family.basis_tables()[1], table_axis(family))
        if k[0] == 0:
            np.testing.assert_allclose(per_basis, k[1] * single, rtol=1e-6)
        _check(values, family, _ortho(values), (40, 40), 2)


def test_family_changes_of_weights_reuse_the_per_basis_minima():
    skin = hv.TransferFunction([0, 40, 80, 255], WHITE * 2, [0, 0.3, 0.3, 0.0], table_size=256)
    bone = hv.TransferFunction([0, 120, 200, 255], WHITE * 2, [0, 0, 0.95, 0.99], table_size=256)
    volume = as_volume(_ball())
    opts = RenderOptions.from_kwargs(None)
    bound = OcclusionBound(2)
    a, _ = bound.extinction(volume, hv.TransferFunction.family([skin, bone], [1.0, 1.0]), opts)
    entries = len(volume.cache["occlusion_minima"])
    b, _ = bound.extinction(volume, hv.TransferFunction.family([skin, bone], [0.5, 2.0]), opts)
    assert len(volume.cache["occlusion_minima"]) == entries
    assert not np.array_equal(a, b)


# -- the lower-level function ----------------------------------------------------------------
@pytest.mark.parametrize("group", [1, 2, 4])
@pytest.mark.parametrize("parallel", [True, False])
def test_occluded_blocks_from_ranges_equals_the_render_path(group, parallel):
    values = _ball()
    volume = as_volume(values)
    camera = _ortho(values) if parallel else hv.Camera((90.0, 60.0, 45.0), (19.5, 19.5, 19.5), (0, 0, 1))
    opts = RenderOptions.from_kwargs(None, termination=TERMINATION)
    needed, met, _ = OcclusionBound(group, block_size=8).blocks(volume, RAMP, camera, (40, 40), opts, 8)
    lo, hi = group_ranges(volume.values.astype(np.float32), group)  # what a float32 render samples
    sigma = RAMP.table(np.float64, 1.0, 1.0)[1]
    mask = occluded_blocks(lo, hi, sigma, table_axis(RAMP), origin=volume.origin, group_size=group,
                           rays=(camera, (40, 40)), step=0.5, box=(volume.origin, np.array(volume.dims) - 1.0),
                           block_groups=8 // group)
    np.testing.assert_array_equal(mask, met & ~needed)
    assert mask.any()


def test_occluded_blocks_world_geometry():
    """Spacing 2 and an offset origin: the same blocks as in voxel units."""
    values = _ball()
    tf = RAMP
    camera = hv.Camera((-100, 20.0, 10.0), (40.0, 40.0, 40.0), (0, 0, 1), parallel_projection=True,
                       parallel_scale=60)
    lo, hi = group_ranges(values.astype(np.float32), 2)
    sigma = tf.table(np.float64, 1.0, 2.0)[1]  # per world unit: a voxel is 2 long
    volume = volume_from_array(values, spacing=(2.0, 2.0, 2.0), origin=(1.0, 1.0, 1.0))
    mask = occluded_blocks(lo, hi, sigma, table_axis(tf), origin=(1.0, 1.0, 1.0), group_size=4.0,
                           rays=(camera, (40, 40)), step=1.0,  # the default 0.5 voxel
                           box=((1.0, 1.0, 1.0), 1.0 + 2.0 * (np.array(volume.dims) - 1)), block_groups=4)
    opts = RenderOptions.from_kwargs(None)
    needed, met, _ = OcclusionBound(2, block_size=8).blocks(volume, tf, camera, (40, 40), opts, 8)
    np.testing.assert_array_equal(mask, met & ~needed)


def test_all_nan_and_infinite_ranges_have_no_extinction():
    sigma = np.linspace(1.0, 2.0, 16)
    lo = np.array([[[np.nan, 0.0, -np.inf, 0.2]]])
    hi = np.array([[[np.nan, np.inf, 1.0, 0.3]]])
    ext = group_extinction(lo, hi, sigma, ("linear", 1.0, 0.0, 1.0))
    assert ext[0, 0, :3].tolist() == [0.0, 0.0, 0.0]
    # 0.2..0.3 reads entries 3..5 (positions 3.0..4.5), widened to 2..6: entry 2 is the minimum
    assert ext[0, 0, 3] == np.float32(sigma[2]) or ext[0, 0, 3] == np.nextafter(np.float32(sigma[2]), 0)
    assert ext[0, 0, 3] <= sigma[2]


def test_span_minimum_long_ranges():
    """The sparse table's queries against plain minima, over ranges of all lengths."""
    rng = np.random.default_rng(3)
    sigma = rng.random(1000)
    lo = rng.random(500)
    hi = np.minimum(lo + rng.random(500) ** 3, 1.0)
    ext = group_extinction(lo.reshape(5, 10, 10), hi.reshape(5, 10, 10), sigma, ("linear", 1.0, 0.0, 1.0))
    from pv_hdrvol.data.transfer import table_entry_span

    i0, i1 = table_entry_span(lo, hi, "linear", 1.0, 0.0, 1.0, 1000)
    i0, i1 = np.maximum(i0 - 1, 0), np.minimum(i1 + 1, 999)
    expected = np.array([sigma[a:b + 1].min() for a, b in zip(i0, i1)])
    assert np.all(ext.reshape(-1) <= expected)
    np.testing.assert_allclose(ext.reshape(-1), expected, rtol=2.0**-23)  # float32, rounded down


# -- bad arguments ---------------------------------------------------------------------------
def test_bad_arguments():
    with pytest.raises(ValueError, match="group must be a power of two; got 3"):
        OcclusionBound(group=3)
    with pytest.raises(TypeError, match="group must be an integer; got '2'"):
        OcclusionBound(group="2")
    with pytest.raises(ValueError, match="threshold"):
        OcclusionBound(threshold=1.0)
    with pytest.raises(ValueError, match="block_size must be a power of two; got 12"):
        OcclusionBound(block_size=12)
    values = _ball()
    camera = _ortho(values)
    with pytest.raises(ValueError, match="precision 'float32' or 'float64'.*got 'uint8'"):
        hv.render(values, RAMP, camera, (8, 8), cull=OcclusionBound(), precision="uint8", progress_bar=False)
    with pytest.raises(ValueError, match="blending='composite' without gradient_opacity"):
        hv.render(values, RAMP, camera, (8, 8), cull=OcclusionBound(), blending="maximum", progress_bar=False)
    lo, hi = group_ranges(values, 2)
    sigma = RAMP.table()[1]
    axis = table_axis(RAMP)
    with pytest.raises(ValueError, match=r"minimum and maximum must have one shape; got \(20, 20, 20\) and \(2,\)"):
        group_extinction(lo, hi[0, 0, :2], sigma, axis)
    with pytest.raises(ValueError, match="axis must be .*got 'linear'"):
        group_extinction(lo, hi, sigma, "linear")
    with pytest.raises(ValueError, match=r"weights must be 1 finite values >= 0.*got array\(\[-1.\]\)"):
        group_extinction(lo, hi, sigma, axis, weights=[-1.0])
    with pytest.raises(ValueError, match="sigma must be extinctions >= 0"):
        group_extinction(lo, hi, -sigma, axis)
    kw = dict(origin=(0, 0, 0), group_size=2, rays=(camera, (8, 8)), step=1.0)
    with pytest.raises(ValueError, match=r"group_size must be > 0; got \[0.0, 0.0, 0.0\]"):
        occluded_blocks(lo, hi, sigma, axis, **dict(kw, group_size=0))
    with pytest.raises(ValueError, match="step must be > 0"):
        occluded_blocks(lo, hi, sigma, axis, **dict(kw, step=0.0))
    with pytest.raises(TypeError, match="rays must be Rays or \\(Camera, size\\); got str"):
        occluded_blocks(lo, hi, sigma, axis, **dict(kw, rays="iso"))
    with pytest.raises(ValueError, match="precision must be one of"):
        occluded_blocks(lo, hi, sigma, axis, precision="uint8", **kw)
    with pytest.raises(ValueError, match=r"values must be a 3-D array with at least 2 points per axis; got shape"):
        group_ranges(np.zeros((1, 4, 4)), 2)


# -- block-wise (MPI) rendering ----------------------------------------------------------------
def test_render_parallel_with_the_bound():
    """Serial block-wise render: fewer blocks, and the image within what the culled
    blocks emit behind the threshold (blocks composite without termination across
    them); the tiles of 3 ranks (threads) cull the same blocks as one whole image."""
    from thread_comm import run_spmd

    from pv_hdrvol.parallel.render import render_parallel

    values = _ball()
    camera = hv.Camera((90.0, 60.0, 45.0), (19.5, 19.5, 19.5), (0, 0, 1), view_angle=30.0)  # perspective
    kw = dict(comm=None, block_size=8, termination=TERMINATION)
    plain = render_parallel(values, RAMP, camera, (40, 40), **kw)
    culled = render_parallel(values, RAMP, camera, (40, 40), bound=OcclusionBound(2), **kw)
    assert culled.metadata["parallel"]["culled_by_bound"]
    assert culled.metadata["parallel"]["visible"] < plain.metadata["parallel"]["visible"]
    assert float(np.abs(culled.rgba.astype(np.float64) - plain.rgba).max()) <= TERMINATION + 1e-6  # colours <= 1

    def one(comm):
        return render_parallel(values, RAMP, camera, (40, 40), bound=OcclusionBound(2), comm=comm, root=None,
                               block_size=8, termination=TERMINATION, threads=1).metadata["parallel"]["visible"]

    results, errors = run_spmd(3, one)
    assert errors == [None] * 3
    assert results == [culled.metadata["parallel"]["visible"]] * 3
    with pytest.raises(ValueError, match="pof= or bound=, not both"):
        render_parallel(values, RAMP, _ortho(values), (8, 8), bound=OcclusionBound(), pof=object(), comm=None)
    with pytest.raises(TypeError, match="bound must be an OcclusionBound; got str"):
        render_parallel(values, RAMP, camera, (8, 8), bound="yes", comm=None)


def test_a_window_culls_for_the_whole_image_rays():
    """A window (tile) of a culled render is that window of the whole culled render:
    the culling is computed for the whole image's rays, which include the window's
    (a window-sized image's rays would be other rays)."""
    values = _ball()
    camera = _ortho(values)
    kw = dict(termination=TERMINATION, cull=OcclusionBound(1), progress_bar=False)
    whole = hv.render(values, RAMP, camera, (40, 30), **kw)
    from pv_hdrvol.raycast.grid import GridPlan

    plan = GridPlan(values, RAMP, termination=TERMINATION)
    part = plan.execute(camera, (40, 30), window=(7, 5, 20, 12), cull=OcclusionBound(1), progress_bar=False)
    assert np.array_equal(part.rgba, whole.rgba[5:17, 7:27])
    assert part.metadata["culling"]["culled"] == whole.metadata["culling"]["culled"] > 0


def test_a_ray_box_integral_would_not_be_a_bound():
    """Why the march follows the samples: points x = 0, 1 are opaque (opacity 0.99 per
    voxel: sigma 4.6, over the target 3.0 in one voxel), the rest 0 but an opaque back
    wall at x >= 11; step 3 voxels. The exact ray-box integral of sigma_min counts cell
    [0, 1] (range {1}) at 4.6 and would cull the wall; the ray caster's first segment
    [0, 3] takes its extinction at its midpoint x = 1.5, value 0.5, opacity 0: the wall
    shows. The bound (at the samples) culls none of it, and the images are equal."""
    values = np.zeros((16, 16, 16))
    values[:, :, :2] = 1.0
    values[:, :, 11:] = 1.0
    tf = hv.TransferFunction([0.0, 0.9, 1.0], WHITE + [[1, 1, 1]], [0.0, 0.0, 0.99])
    camera = hv.Camera((-50, 7.5, 7.5), (7.5, 7.5, 7.5), (0, 0, 1), parallel_projection=True, parallel_scale=12)
    sigma = tf.table(np.float64, 1.0, 1.0)[1]
    assert sigma[-2] > -math.log(TERMINATION)  # one voxel of cell [0, 1] would pass the target
    full = hv.render(values, tf, camera, (32, 32), termination=TERMINATION, step=3.0, progress_bar=False)
    assert full.rgba[16, 16, 3] > 0.9  # the wall, seen through the first segment
    assert _check(values, tf, camera, (32, 32), 1, block=4, step=3.0) == 0
