"""Analytic checks of the grid ray caster: Beer-Lambert, closed forms, exact clipping."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv

pytestmark = pytest.mark.core

WHITE = [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]


def constant_tf(alpha, color=(1.0, 1.0, 1.0)):
    return hv.TransferFunction([0.0, 2.0], [color, color], [alpha, alpha])


def slab(nz=9, spacing=(1.0, 1.0, 0.5), value=1.0, nxy=5):
    """A constant slab; its thickness along z is (nz - 1) * spacing[2]."""
    return hv.volume_from_array(np.full((nz, nxy, nxy), value), spacing=spacing)


def down_camera(volume, size=8):
    """Parallel camera looking down -z at the middle of the volume."""
    b = volume.bounds
    cx, cy = 0.5 * (b[0] + b[1]), 0.5 * (b[2] + b[3])
    return hv.Camera((cx, cy, b[5] + 10.0), (cx, cy, b[4]), (0, 1, 0), parallel_projection=True,
                     parallel_scale=0.25 * (b[3] - b[2]))


@pytest.mark.parametrize("step", [0.05, 0.37, 1.0, 3.3, 1000.0])
@pytest.mark.parametrize("precision,tol", [("float64", 1e-6), ("float32", 1e-6)])
def test_constant_slab_matches_beer_lambert_at_any_step(step, precision, tol):
    vol = slab()
    alpha = 0.1  # per opacity unit distance = the smallest spacing, 0.5
    sigma = -math.log1p(-alpha) / 0.5
    length = 8 * 0.5
    img = hv.render(vol, constant_tf(alpha, (0.2, 0.5, 1.0)), down_camera(vol), (6, 6), step=step,
                    precision=precision, termination=0.0)
    expected = 1.0 - math.exp(-sigma * length)
    np.testing.assert_allclose(img.rgba[..., 3], expected, rtol=0, atol=tol)
    np.testing.assert_allclose(img.rgba[..., :3], np.broadcast_to(np.array([0.2, 0.5, 1.0]) * expected, (6, 6, 3)),
                               rtol=0, atol=tol)


def test_opacity_unit_distance_sets_extinction_per_world_unit():
    vol = slab()
    img = hv.render(vol, constant_tf(0.3), down_camera(vol), (4, 4), precision="float64",
                    opacity_unit_distance=2.0, step=0.5)
    # 4 world units of a medium that reaches 0.3 over 2 units: 1 - 0.7**2
    np.testing.assert_allclose(img.rgba[..., 3], 1 - 0.7**2, rtol=0, atol=1e-12)


def test_linear_ramp_slab_matches_closed_form():
    # data rises linearly with z from 0 to 1; opacity rises linearly with data from 0 to a1,
    # so sigma(z) = -ln(1 - a1 z / L) / u. Its integral has the closed form below.
    nz, sz, a1 = 65, 0.125, 0.5
    length = (nz - 1) * sz
    z = np.linspace(0.0, 1.0, nz)
    vol = hv.volume_from_array(np.broadcast_to(z[:, None, None], (nz, 4, 4)).copy(), spacing=(1, 1, sz))
    tf = hv.TransferFunction([0.0, 1.0], WHITE, [0.0, a1])
    unit = sz  # default opacity unit distance: the smallest spacing
    beta = a1 / length
    w = 1.0 - beta * length
    optical_depth = ((w * math.log(w) - w) - (0.0 - 1.0)) / beta / unit
    expected = 1.0 - math.exp(-optical_depth)
    img = hv.render(vol, tf, down_camera(vol), (4, 4), precision="float64", step=0.05, termination=0.0)
    # midpoint-rule error ~ L * h^2 / 24 * max|sigma''| is below 2e-7 here; the table adds < 1e-9
    np.testing.assert_allclose(img.rgba[..., 3], expected, rtol=0, atol=1e-6)
    # looking up from below integrates the same ramp the other way round
    b = vol.bounds
    up = hv.Camera((1.5, 1.5, -10.0), (1.5, 1.5, 0.0), (0, 1, 0), parallel_projection=True, parallel_scale=0.75)
    img_up = hv.render(vol, tf, up, (4, 4), precision="float64", step=0.05, termination=0.0)
    np.testing.assert_allclose(img_up.rgba[..., 3], expected, rtol=0, atol=1e-6)
    assert b[5] == pytest.approx(length)


def test_parallel_silhouette_lands_on_analytic_pixels():
    # a 10 x 6 box seen from +z; the view spans x in [-5, 15], y in [-5, 11] on 40 x 32 pixels
    vol = hv.volume_from_array(np.ones((4, 7, 11)), spacing=(1.0, 1.0, 1.0))
    cam = hv.Camera((5.0, 3.0, 20.0), (5.0, 3.0, 0.0), (0, 1, 0), parallel_projection=True, parallel_scale=8.0)
    img = hv.render(vol, constant_tf(0.5), cam, (40, 32), precision="float64")
    cols = -5.0 + (np.arange(40) + 0.5) * 0.5
    rows = 11.0 - (np.arange(32) + 0.5) * 0.5  # row 0 at the top
    expected = (rows[:, None] >= 0) & (rows[:, None] <= 6) & (cols[None, :] >= 0) & (cols[None, :] <= 10)
    np.testing.assert_array_equal(img.rgba[..., 3] > 0, expected)


def test_perspective_silhouette_is_the_projected_near_face():
    # camera on the box's axis: the silhouette is the near face, scaled by similar triangles
    vol = hv.volume_from_array(np.ones((5, 5, 9)), spacing=(1.0, 1.0, 1.0))  # x in [0, 8], y in [0, 4], z in [0, 4]
    d_near = 6.0
    cam = hv.Camera((4.0, 2.0, 4.0 + d_near), (4.0, 2.0, 0.0), (0, 1, 0), view_angle=90.0)
    w, h = 64, 48
    img = hv.render(vol, constant_tf(0.5), cam, (w, h), precision="float64")
    half_h = math.tan(math.radians(45.0))
    x_ndc = ((np.arange(w) + 0.5) * 2 / w - 1) * half_h * w / h  # tangent of the ray's angle
    y_ndc = (1 - (np.arange(h) + 0.5) * 2 / h) * half_h
    inside_x = np.abs(x_ndc) * d_near <= 4.0
    inside_y = np.abs(y_ndc) * d_near <= 2.0
    expected = inside_y[:, None] & inside_x[None, :]
    np.testing.assert_array_equal(img.rgba[..., 3] > 0, expected)


def test_camera_inside_the_volume_integrates_from_the_eye():
    vol = hv.volume_from_array(np.ones((11, 11, 11)))  # [0, 10]^3
    alpha = 0.05
    sigma = -math.log1p(-alpha)
    cam = hv.Camera((5.0, 5.0, 3.0), (5.0, 5.0, 10.0), (0, 1, 0), view_angle=10.0)
    img = hv.render(vol, constant_tf(alpha), cam, (5, 5), precision="float64", step=0.3, termination=0.0)
    np.testing.assert_allclose(img.rgba[2, 2, 3], 1 - math.exp(-sigma * 7.0), rtol=0, atol=1e-9)


def test_depth_is_distance_to_threshold_crossing():
    vol = slab(nz=21, spacing=(1, 1, 1))
    alpha = 0.1
    cam = down_camera(vol)
    img = hv.render(vol, constant_tf(alpha), cam, (4, 4), precision="float64", step=0.5, depth_threshold=0.5)
    sigma = -math.log1p(-alpha)
    # opacity 0.5 is passed inside the segment that ends at optical depth >= ln 2
    n = math.ceil(math.log(2) / sigma / 0.5)
    expected = 10.0 + (n - 0.5) * 0.5  # camera is 10 above the top; depth is the sample's midpoint
    np.testing.assert_allclose(img.depth, expected, rtol=0, atol=1e-9)
    assert np.isinf(hv.render(vol, constant_tf(1e-4), cam, (4, 4), depth_threshold=0.5).depth).all()


@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_termination_counts_exactly_the_samples_composited(precision):
    # The plain loop samples a few values ahead (batches of 2, 4, 8, 8, ...) before it
    # composites them; a ray that terminates inside a batch must count and composite
    # exactly the samples up to the one that crossed, wherever that falls in a batch.
    # Constant opacity a per step: after n samples alpha = 1 - (1 - a)**n, so a
    # termination threshold of (1 - a)**(n - 1/2) stops the ray at sample n exactly.
    a = 0.2
    vol = slab(nz=41, spacing=(1, 1, 1))
    cam = down_camera(vol)
    for nan_plane in (None, 37):
        values = np.ones((41, 5, 5))
        if nan_plane is not None:
            values[nan_plane] = np.nan  # the two samples whose stencils touch it are empty
        for n in range(1, 26):
            img = hv.render(values, constant_tf(a), cam, (2, 2), precision=precision, step=1.0,
                            termination=(1 - a) ** (n - 0.5), depth_threshold=1 - (1 - a) ** (n - 0.5))
            assert img.metadata["samples"] == 4 * n, (nan_plane, n)
            np.testing.assert_allclose(img.rgba[..., 3], 1 - (1 - a) ** n, rtol=1e-6)
            skipped = 2 if nan_plane is not None and n >= 40 - nan_plane else 0  # samples 3 and 4
            np.testing.assert_allclose(img.depth, 10.0 + n + skipped - 0.5, rtol=0, atol=1e-9)


def test_empty_space_skipping_changes_no_pixel():
    rng = np.random.default_rng(7)
    z, y, x = np.mgrid[0:40, 0:37, 0:33]
    field = np.exp(-((x - 16) ** 2 + (y - 18) ** 2 + (z - 20) ** 2) / 60.0) + 0.01 * rng.random((40, 37, 33))
    field[:, :, :5] = np.nan
    for scale, tf in [("linear", hv.TransferFunction.ramp(0.3, 1.0, cmap="gray", opacity=(0, 0.2))),
                      ("log", hv.TransferFunction.ramp(0.05, 1.0, scale="log", cmap="gray", opacity=(0, 0.2)))]:
        for precision in ("float64", "float32", "uint8"):
            kw = dict(precision=precision, step=0.7)
            a = hv.render(field, tf, None, (48, 40), skip_empty=True, **kw)
            b = hv.render(field, tf, None, (48, 40), skip_empty=False, **kw)
            np.testing.assert_array_equal(a.rgba, b.rgba, err_msg=f"{scale} {precision}")
            np.testing.assert_array_equal(a.depth, b.depth)
            assert a.metadata["samples"] < b.metadata["samples"], (scale, precision)


def test_block_mask_restricts_the_render():
    vol = hv.volume_from_array(np.ones((17, 17, 17)))
    tf = constant_tf(0.05)
    grid = hv.BlockGrid.of(vol, 8)
    assert grid.shape == (2, 2, 2)
    full = hv.render(vol, tf, None, (24, 24), block_size=8)
    same = hv.render(vol, tf, None, (24, 24), block_size=8, block_mask=np.ones(grid.shape, bool))
    np.testing.assert_array_equal(full.rgba, same.rgba)
    none = hv.render(vol, tf, None, (24, 24), block_size=8, block_mask=np.zeros(grid.shape, bool))
    assert not none.rgba.any()
    half = np.zeros(grid.shape, bool)
    half[:, :, 0] = True  # x < 8 only
    cam = hv.Camera((8, 8, 40), (8, 8, 0), (0, 1, 0), parallel_projection=True, parallel_scale=8)
    img = hv.render(vol, tf, cam, (32, 32), block_size=8, block_mask=half)
    cols = -0.0 + (np.arange(32) + 0.5) * 0.5  # x of each pixel column
    assert (img.rgba[:, cols < 7.9, 3] > 0).all() and not img.rgba[:, cols > 8.1, 3].any()
    with pytest.raises(ValueError, match=r"block_mask must have shape \(2, 2, 2\)"):
        hv.render(vol, tf, None, (8, 8), block_size=8, block_mask=np.ones((2, 2), bool))
    with pytest.raises(TypeError, match="block_mask must be a bool array"):
        hv.render(vol, tf, None, (8, 8), block_size=8, block_mask=np.ones(grid.shape))


def test_opacity_correction_keeps_the_picture_across_steps():
    z, y, x = np.mgrid[0:32, 0:32, 0:32]
    field = np.sin(x / 5.0) * np.cos(y / 7.0) + z / 32.0
    tf = hv.TransferFunction.ramp(-1.0, 2.0, cmap="viridis", opacity=(0.0, 0.1))
    ref = hv.render(field, tf, None, (32, 32), precision="float64", step=0.05, termination=0.0)
    for step, tol in [(0.25, 2e-3), (1.0, 2e-2)]:
        img = hv.render(field, tf, None, (32, 32), precision="float64", step=step, termination=0.0)
        assert np.abs(img.rgba - ref.rgba).max() < tol, step


def test_early_termination_error_is_bounded_by_the_threshold():
    vol = hv.volume_from_array(np.linspace(0, 1, 40**3).reshape(40, 40, 40))
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="viridis", opacity=(0.3, 0.9))
    exact = hv.render(vol, tf, None, (24, 24), precision="float64", termination=0.0)
    for term in (1e-2, 1e-4):
        img = hv.render(vol, tf, None, (24, 24), precision="float64", termination=term)
        assert np.abs(img.rgba - exact.rgba).max() <= term  # colours are <= 1
        assert img.metadata["samples"] < exact.metadata["samples"]


# -- rays made in the kernel ---------------------------------------------------------------------
@pytest.mark.parametrize("parallel", [False, True])
def test_kernel_camera_rays_are_camera_rays_bit_for_bit(parallel):
    from pv_hdrvol.rays._kernels import camera_ray

    vol = hv.volume_from_array(np.random.default_rng(3).random((9, 8, 7)), spacing=(0.7, 1.3, 2.1),
                               origin=(-4.0, 2.5, 1e3))
    cam = hv.Camera.fit(vol, "iso", parallel_projection=parallel)
    size = (23, 17)
    # a render with a Camera makes its rays in the kernel; with Rays it reads them
    by_camera = hv.render(vol, None, cam, size, precision="float64")
    by_rays = hv.render(vol, None, cam.rays(size), precision="float64")
    np.testing.assert_array_equal(by_camera.rgba, by_rays.rgba)
    np.testing.assert_array_equal(by_camera.depth, by_rays.depth)
    assert by_camera.metadata["samples"] == by_rays.metadata["samples"] > 0
    # camera_ray was just compiled inside a fused kernel; called alone it must still give
    # Camera.rays' bits (a helper that inherited the caller's FMA contraction would not)
    rays = cam.rays(size)
    ka = cam.kernel_array(size)
    got = np.array([camera_ray(ka, c, r, size[0], size[1]) for r in range(size[1]) for c in range(size[0])])
    np.testing.assert_array_equal(got[:, :3], rays.origins)
    np.testing.assert_array_equal(got[:, 3:], rays.directions)


def test_skip_structures_are_reused_per_transfer_function_and_mask():
    # float64 data rendered in float64: the structures live on this volume (float32
    # renders of float64 data cache them on a derived float32 copy)
    vol = hv.volume_from_array(np.linspace(0.0, 1.0, 17**3).reshape(17, 17, 17))
    cam = hv.Camera.fit(vol, "iso")
    upper = hv.TransferFunction.ramp(0.5, 1.0, cmap="gray", opacity=(0.0, 0.3))
    lower = hv.TransferFunction.ramp(0.0, 0.5, cmap="gray", opacity=(0.3, 0.0))
    first = hv.render(vol, upper, cam, 16, block_size=4, precision="float64")
    assert len(vol.cache["skip_structures"]) == 1
    other = hv.render(vol, lower, cam, 16, block_size=4, precision="float64")
    assert len(vol.cache["skip_structures"]) == 2
    again = hv.render(vol, upper, cam, 16, block_size=4, precision="float64")
    assert len(vol.cache["skip_structures"]) == 2  # found, not rebuilt
    np.testing.assert_array_equal(again.rgba, first.rgba)
    assert again.metadata["samples"] == first.metadata["samples"] != other.metadata["samples"]
    # a fresh volume (no cache) renders the same pixels
    fresh = hv.render(hv.volume_from_array(np.asarray(vol.values)), upper, cam, 16, block_size=4, precision="float64")
    np.testing.assert_array_equal(fresh.rgba, first.rgba)
    # a mask is part of the key; the cache keeps the last four structures
    grid = hv.BlockGrid.of(vol, 4)
    half = np.zeros(grid.shape, bool)
    half[:, :, :2] = True
    masked = hv.render(vol, upper, cam, 16, block_size=4, block_mask=half, precision="float64")
    assert masked.metadata["samples"] < first.metadata["samples"]
    # only which entries are transparent matter: other opacities (or steps) share a structure
    for opacity in (0.1, 0.2, 0.4):
        tf = hv.TransferFunction.ramp(0.5, 1.0, cmap="gray", opacity=(0.0, opacity))
        hv.render(vol, tf, cam, 16, block_size=4, precision="float64")
    hv.render(vol, upper, cam, 16, block_size=4, precision="float64", step=1.5)
    assert len(vol.cache["skip_structures"]) == 3
    for start in (0.6, 0.7):
        tf = hv.TransferFunction.ramp(start, 1.0, cmap="gray", opacity=(0.0, 0.3))
        hv.render(vol, tf, cam, 16, block_size=4, precision="float64")
    assert len(vol.cache["skip_structures"]) == 4
