"""Numerical stability at the extremes (tiny opacities, 16 decades, NaN/inf, odd shapes)."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.raycast import _composite_kernels as C, _kernels as K

pytestmark = pytest.mark.core

GREY = [[0.5, 0.5, 0.5], [0.5, 0.5, 0.5]]


def column(nz, value=1.0):
    return hv.volume_from_array(np.full((nz, 2, 2), value))


def looking_down(vol):
    b = vol.bounds
    return hv.Camera((0.5, 0.5, b[5] + 1.0), (0.5, 0.5, 0.0), (0, 1, 0), parallel_projection=True,
                     parallel_scale=0.25)


def tiny_opacity_render(precision):
    vol = column(4097)  # 4,096 unit cells
    tf = hv.TransferFunction([0.0, 2.0], GREY, [1e-7, 1e-7])
    return hv.render(vol, tf, looking_down(vol), (2, 2), precision=precision, step=1.0, termination=0.0)


EXACT_ALPHA = -math.expm1(4096 * math.log1p(-1e-7))  # 1 - (1 - 1e-7)**4096


def test_4096_samples_of_1e_7_in_float64():
    img = tiny_opacity_render("float64")
    np.testing.assert_allclose(img.rgba[..., 3], EXACT_ALPHA, rtol=1e-9)
    np.testing.assert_allclose(img.rgba[..., 0], 0.5 * EXACT_ALPHA, rtol=1e-9)


def test_4096_samples_of_1e_7_in_float32():
    # 1 - 1e-7 is not a float32 (it rounds to 1 - 1.19e-7): multiplying transmittance by
    # it would be 19% off. Optical depth with compensated sums stays within 1e-5.
    img = tiny_opacity_render("float32")
    assert img.rgba.dtype == np.float32
    np.testing.assert_allclose(img.rgba[..., 3], EXACT_ALPHA, rtol=1e-5)
    np.testing.assert_allclose(img.rgba[..., 0], 0.5 * EXACT_ALPHA, rtol=1e-5)
    naive = 1.0 - float(np.float32(1.0) - np.float32(1e-7)) ** 4096
    assert abs(naive / EXACT_ALPHA - 1) > 0.15  # the loss the formulation avoids


def test_conventional_buffers_lose_tiny_opacities():
    """A documented comparison: 16-bit float and 8-bit `over` buffers lose this signal."""
    half = tiny_opacity_render("float16").rgba[0, 0]
    with pytest.warns(hv.EmptyRenderWarning, match=r"opacity is 0 over the whole data range \[1, 1\] .*; "
                                                   r"precision='uint8' rounds the opacity of each step to a "
                                                   r"multiple of 1/255$"):
        u8 = tiny_opacity_render("uint8").rgba[0, 0]
    # half: alpha stalls at 2**-12 = 2.44e-4 (exact 4.10e-4), once a sample's 1.19e-7 is
    # below half an ulp of the accumulated opacity: 40% of the signal is lost
    assert half[3] == 2.0**-12
    assert abs(half[3] / EXACT_ALPHA - 1) > 0.4
    # 8 bit: each sample's opacity rounds to 0/255, nothing accumulates
    assert u8[3] == 0.0 and u8[0] == 0.0


def test_round_half_matches_numpy_float16():
    rng = np.random.default_rng(1)
    x = np.concatenate([
        rng.standard_normal(20000) * 10.0 ** rng.integers(-9, 5, 20000),
        [0.0, 6.1e-5, 5.96e-8, 2.98e-8, 65504.0, 65519.0, 65520.0, -1e-30, 1.0 + 2**-11, 1.0 + 3 * 2**-11],
    ])
    got = np.array([C.round_half(float(v)) for v in x])
    with np.errstate(over="ignore"):
        expected = x.astype(np.float16).astype(np.float64)
    np.testing.assert_array_equal(got, expected)


def test_round_u8_is_nearest_multiple_of_1_255():
    x = np.linspace(-0.1, 1.1, 2001)
    got = np.array([C.round_u8(float(v)) for v in x])
    np.testing.assert_array_equal(got, np.round(np.clip(x, 0, 1) * 255) / 255)


def _nan_past_the_end(a):
    """A copy of ``a`` followed in memory by NaN, as a reused heap block may be."""
    buf = np.full(a.size + 64, np.nan, a.dtype)
    buf[:a.size] = a.reshape(-1)
    return buf[:a.size].reshape(a.shape)


def test_uint8_lookup_of_the_last_entry_reads_only_that_entry():
    """The 8-bit lookup takes the nearest row; at the top of the axis that is the last
    row, and it must not touch the row past it (issue 18: 0.1-0.9 % of 8-bit renders of a
    freshly read dataset came out wrong when the heap past the table held NaN or inf)."""
    n = 256
    table = _nan_past_the_end(np.tile(np.array([0.25, 0.5, 0.75, 0.125], np.float32), n))
    sigma = _nan_past_the_end(np.full(n, 2.0, np.float32))
    p = K.GridParams(1.0, C.U8, C.LINEAR, 0.0, 1.0, 1.0, math.inf, 0.99, 2)
    for v in (1.0, 1.0 - 0.4 / (n - 1), 7.0):  # the last row, its nearest-row band, clamped
        r, g, b, a, i, f = C._lookup(table, v, n, p)
        assert (r, g, b, a, i, f) == (0.25, 0.5, 0.75, 0.125, n - 1, 0.0)
        assert C.sigma_at(sigma, i, f) == 2.0


@pytest.mark.parametrize("blending", ["composite", "maximum"])
def test_uint8_render_ignores_memory_past_the_table(monkeypatch, blending):
    """Every sample of a constant column at the top of the transfer function selects the
    table's last row (and the shorter last segment its last extinction): a render whose
    table and extinction are followed by NaN gives the same pixels as one followed by
    finite memory, grey where the function is grey. Before the fix, the NaN reached the
    colour of one channel or dropped a sample, deterministically."""
    from pv_hdrvol.raycast import _kernels_ext as KX

    vol = column(41, value=2.0)
    tf = hv.TransferFunction([0.0, 2.0], GREY, [0.05, 0.05])
    clean = hv.render(vol, tf, looking_down(vol), (2, 2), precision="uint8", step=0.7, blending=blending)
    tiles, levels = K.render_tiles, KX.render_levels

    def padded_tiles(marker, bricks, offs, table, sigma, *rest):
        return tiles(marker, bricks, offs, _nan_past_the_end(table), _nan_past_the_end(sigma), *rest)

    def padded_levels(*args):
        args = list(args)
        args[11], args[12] = _nan_past_the_end(args[11]), _nan_past_the_end(args[12])  # table, sigma
        return levels(*args)

    monkeypatch.setattr(K, "render_tiles", padded_tiles)
    monkeypatch.setattr(KX, "render_levels", padded_levels)
    dirty = hv.render(vol, tf, looking_down(vol), (2, 2), precision="uint8", step=0.7, blending=blending)
    np.testing.assert_array_equal(dirty.rgba, clean.rgba)
    px = clean.rgba[0, 0]
    assert px[3] > 0 and px[0] == px[1] == px[2]


def test_sixteen_decades_render_with_a_log_table():
    z, y, x = np.mgrid[0:33, 0:33, 0:33]
    r = np.sqrt((x - 16.0) ** 2 + (y - 16.0) ** 2 + (z - 16.0) ** 2)
    field = 10.0 ** (-17.0 * r / r.max())  # 1 at the centre, 1e-17 at the corners
    tf = hv.TransferFunction.ramp(1e-17, 1.0, scale="log", cmap="magma", opacity=(0.0, 0.05))
    for precision in ("float64", "float32"):
        img = hv.render(field, tf, None, (40, 40), precision=precision)
        assert np.isfinite(img.rgba).all() and np.isfinite(img.depth[np.isfinite(img.depth)]).all()
        assert img.stats()["covered_fraction"] > 0.3
        assert img.dynamic_range_decades > 3.0, precision


def test_global_alpha_of_1e_6_still_changes_the_image_linearly():
    vol = hv.volume_from_array(np.linspace(0.1, 1.0, 16**3).reshape(16, 16, 16))
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="viridis", opacity=(0.0, 1.0))
    a = hv.render(vol, tf, None, (16, 16), global_alpha=1e-6, precision="float32")
    b = hv.render(vol, tf, None, (16, 16), global_alpha=2e-6, precision="float32")
    covered = a.rgba[..., 3] > 0
    assert covered.mean() > 0.2
    # at such low opacity alpha is linear in global_alpha: doubling it doubles the image
    np.testing.assert_allclose(b.rgba[covered], 2 * a.rgba[covered], rtol=1e-5)


def test_nan_voxels_are_empty_and_inf_is_clamped_without_touching_the_input():
    vals = np.full((9, 9, 9), 0.5)
    vals[4, 4, 4] = np.nan
    vals[0, 0, 0] = np.inf
    vals[8, 8, 8] = -np.inf
    before = vals.copy()
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray", opacity=(0.2, 0.2))
    cam = hv.Camera((4, 4, 30), (4, 4, 0), (0, 1, 0), parallel_projection=True, parallel_scale=4.5)
    img = hv.render(vals, tf, cam, (9, 9), precision="float64")
    np.testing.assert_array_equal(vals, before)  # the caller's array is untouched
    assert np.isfinite(img.rgba).all()
    clean = np.full((9, 9, 9), 0.5)
    clean[0, 0, 0], clean[8, 8, 8] = 0.5, 0.5  # +inf -> finite max (0.5), -inf -> finite min (0.5)
    ref = hv.render(clean, tf, cam, (9, 9), precision="float64")
    # pixel centres at x, y = 0.5 + col: the one through the NaN point's cells sees less medium
    assert img.rgba[4, 4, 3] < ref.rgba[4, 4, 3]
    far = np.ones((9, 9), bool)
    far[3:6, 3:6] = False
    np.testing.assert_array_equal(img.rgba[far], ref.rgba[far])
    vol = hv.volume_from_array(vals)
    assert vol.has_nan and vol.value_range == (0.5, 0.5)


@pytest.mark.parametrize("value", [0.0, 1.0, -3.0])
def test_constant_and_all_zero_volumes(value):
    vals = np.full((6, 7, 8), value)
    tf = hv.TransferFunction.ramp(-5.0, 5.0, cmap="gray", opacity=(0.1, 0.1))
    img = hv.render(vals, tf, None, (16, 16), precision="float64")
    assert np.isfinite(img.rgba).all() and img.rgba[..., 3].max() > 0
    # default transfer function of a constant volume: a valid (empty) picture, not an
    # error, and a warning that says why it is empty
    with pytest.warns(hv.EmptyRenderWarning, match=r"the data is constant"):
        assert np.isfinite(hv.render(vals, None, None, (8, 8)).rgba).all()


def test_one_voxel_volume_has_no_thickness():
    with pytest.warns(hv.EmptyRenderWarning, match="the volume is flat"):
        img = hv.render(np.ones((1, 1, 1)), hv.TransferFunction.ramp(0, 2, cmap="gray"), None, (8, 8))
    assert not img.rgba.any()
    assert np.isinf(img.depth).all()


def test_a_flat_volume_renders_nothing_even_edge_on():
    vals = np.ones((5, 5, 1))  # one point thick along x
    tf = hv.TransferFunction.ramp(0, 2, cmap="gray", opacity=(1, 1))
    edge_on = hv.Camera((0.0, 2.0, 10.0), (0.0, 2.0, 0.0), (0, 1, 0), parallel_projection=True, parallel_scale=3)
    seen = []
    with pytest.warns(hv.EmptyRenderWarning, match="the volume is flat"):
        img = hv.render(vals, tf, edge_on, (8, 8), progress=seen.append)
    assert not img.rgba.any() and seen == [1.0]


@pytest.mark.parametrize("scale", [1e-15, 1e15])
def test_huge_and_tiny_spacing_give_the_same_picture(scale):
    vals = np.linspace(0, 1, 12 * 10 * 8).reshape(8, 10, 12)
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="viridis", opacity=(0.0, 0.3))
    cam = hv.Camera((20.0, 15.0, 25.0), (5.0, 4.0, 3.0), (0, 0, 1), view_angle=30.0)
    ref = hv.render(hv.volume_from_array(vals, spacing=(1.0, 1.2, 0.8)), tf, cam, (24, 24), precision="float64")
    scaled_cam = hv.Camera(tuple(np.multiply(cam.position, scale)), tuple(np.multiply(cam.focal_point, scale)),
                           (0, 0, 1), view_angle=30.0)
    vol = hv.volume_from_array(vals, spacing=(scale, 1.2 * scale, 0.8 * scale))
    img = hv.render(vol, tf, scaled_cam, (24, 24), precision="float64")
    # opacity is per voxel by default, so scaling the world changes nothing
    np.testing.assert_allclose(img.rgba, ref.rgba, rtol=0, atol=1e-9)
    np.testing.assert_allclose(img.depth[np.isfinite(ref.depth)] / scale, ref.depth[np.isfinite(ref.depth)],
                               rtol=1e-9)


def test_scaling_data_and_transfer_function_together_changes_nothing():
    rng = np.random.default_rng(3)
    vals = rng.random((10, 10, 10))
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[0, 0, 1], [0, 1, 0], [1, 0, 0]], [0.0, 0.2, 0.1])
    ref = hv.render(vals, tf, None, (16, 16), precision="float64")
    for k in (1e-12, 7.0, 1e12):
        tfk = hv.TransferFunction(np.array([0.0, 0.5, 1.0]) * k, tf.colors, tf.opacities)
        img = hv.render(vals * k, tfk, None, (16, 16), precision="float64")
        np.testing.assert_allclose(img.rgba, ref.rgba, rtol=0, atol=1e-9)


def test_native_integer_dtypes_match_float64():
    rng = np.random.default_rng(5)
    vals = rng.integers(0, 200, (9, 9, 9))
    tf = hv.TransferFunction.ramp(0, 255, cmap="viridis", opacity=(0, 0.3))
    ref = hv.render(vals.astype(np.float64), tf, None, (12, 12), precision="float64")
    for dt in (np.uint8, np.int16, np.uint16, np.int32, np.int64):
        img = hv.render(vals.astype(dt), tf, None, (12, 12), precision="float64")
        np.testing.assert_array_equal(img.rgba, ref.rgba, err_msg=str(dt))


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_float16_data_renders_like_its_float64_copy(precision):
    vals = np.linspace(0, 1, 10**3).reshape(10, 10, 10).astype(np.float16)
    tf = hv.TransferFunction.ramp(0, 1, cmap="gray", opacity=(0, 0.3))
    a = hv.render(vals, tf, None, (12, 12), precision=precision)
    b = hv.render(vals.astype(np.float64), tf, None, (12, 12), precision=precision)
    np.testing.assert_allclose(a.rgba, b.rgba, rtol=0, atol=1e-6)
