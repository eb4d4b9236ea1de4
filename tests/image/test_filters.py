"""Image filters for tone mapping: gaussian_blur (exact) and bilateral_grid (approximate).

References are written here with numpy alone: a direct float64 convolution on an
explicitly reflected image, and a brute-force exact bilateral filter on small images.
"""
import doctest

import numpy as np
import pytest

import pv_hdrvol.image.filters as filters
from pv_hdrvol.image.filters import bilateral_grid, gaussian_blur

pytestmark = pytest.mark.core


# -- references -------------------------------------------------------------------------
def gaussian_taps(sigma, truncate=4.0):
    """The normalised sampled Gaussian at offsets -r .. r."""
    r = int(truncate * sigma + 0.5)
    k = np.arange(-r, r + 1)
    g = np.exp(-0.5 * (k / sigma) ** 2)
    return g / g.sum()


def reference_blur(image, sigma, truncate=4.0):
    """Direct float64 convolution of the image padded with np.pad(mode="symmetric")
    (d c b a | a b c d | d c b a; numpy pads repeatedly when the pad is wider than
    the image)."""
    g = gaussian_taps(sigma, truncate)
    r = g.size // 2
    padded = np.pad(np.asarray(image, dtype=np.float64), r, mode="symmetric")
    rows = np.array([np.convolve(row, g, mode="valid") for row in padded])
    return np.array([np.convolve(col, g, mode="valid") for col in rows.T]).T


def exact_bilateral(image, sigma_spatial, sigma_range, edge=None):
    """Brute-force bilateral filter over the whole (small) image; NaN pixels weigh 0
    and come out NaN."""
    e = np.asarray(image if edge is None else edge, dtype=np.float64).ravel()
    v = np.asarray(image, dtype=np.float64).ravel()
    rows, cols = np.shape(image)
    yy, xx = np.divmod(np.arange(rows * cols), cols)
    d2 = (yy[:, None] - yy[None, :]) ** 2 + (xx[:, None] - xx[None, :]) ** 2
    valid = ~(np.isnan(v) | np.isnan(e))
    de = np.where(valid[:, None] & valid[None, :], e[:, None] - e[None, :], 0.0)
    w = np.exp(-d2 / (2.0 * sigma_spatial**2) - de**2 / (2.0 * sigma_range**2)) * valid[None, :]
    out = (w @ np.where(valid, v, 0.0)) / w.sum(axis=1)
    out[~valid] = np.nan
    return out.reshape(rows, cols)


def smooth_edges_image(n=48, seed=0):
    """Smooth shading, three steps and a little noise; values span about 2.6."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n, 0:n] / n
    img = (0.6 * np.sin(5 * x + 2 * y) + 1.0 * (x > 0.45) - 0.8 * ((x - 0.3) ** 2 + (y - 0.7) ** 2 < 0.03)
           + 0.5 * (y > 0.6) * (x < 0.3))
    return img + 0.05 * rng.standard_normal((n, n))


def test_docstring_examples():
    result = doctest.testmod(filters, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0
    assert result.failed == 0


# -- gaussian_blur --------------------------------------------------------------------------
@pytest.mark.parametrize("sigma", [0.5, 3.0, 12.0, 60.0])
@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int32])
def test_gaussian_constant_stays_constant(sigma, dtype):
    image = np.full((23, 41), 7, dtype=dtype)
    out = gaussian_blur(image, sigma)
    assert out.dtype == np.float64 and out.shape == image.shape
    np.testing.assert_allclose(out, 7.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("sigma", [1.5, 4.0, 10.0])
def test_gaussian_interior_delta_keeps_its_sum(sigma):
    delta = np.zeros((101, 101))
    delta[50, 50] = 3.0
    out = gaussian_blur(delta, sigma)
    # the truncated kernel is normalised, so nothing is lost while it stays inside
    assert abs(out.sum() - 3.0) < 1e-12
    assert out.min() >= 0.0


@pytest.mark.parametrize("sigma", [0.7, 2.5, 9.0, 15.0, 40.0])
def test_gaussian_matches_direct_reference(sigma):
    # 40: the kernel is wider than the image (folded taps); 9, 15: "large" sigma
    image = np.random.default_rng(1).random((23, 37))
    out = gaussian_blur(image, sigma)
    # documented: equals the float64 convolution to rounding (max abs error 2e-15)
    assert np.abs(out - reference_blur(image, sigma)).max() <= 2e-15


def test_gaussian_truncate_changes_the_radius():
    image = np.random.default_rng(2).random((30, 30))
    np.testing.assert_allclose(gaussian_blur(image, 2.0, truncate=1.5), reference_blur(image, 2.0, 1.5),
                               rtol=0, atol=2e-15)
    assert np.abs(gaussian_blur(image, 2.0, truncate=1.5) - gaussian_blur(image, 2.0)).max() > 1e-4


@pytest.mark.parametrize("sigma", [2.0, 5.0, 9.0])
def test_gaussian_impulse_response_has_variance_sigma_squared(sigma):
    n = 121
    delta = np.zeros((n, n))
    delta[60, 60] = 1.0
    out = gaussian_blur(delta, sigma)
    k = np.arange(n) - 60.0
    for axis in (0, 1):
        profile = out.sum(axis=1 - axis)
        mean = (profile * k).sum()
        variance = (profile * k**2).sum() - mean**2
        assert abs(mean) < 1e-12
        assert abs(variance / sigma**2 - 1.0) < 0.01


def test_gaussian_reflect_boundary_repeats_the_edge_sample():
    # d c b a | a b c d: position -1 reads column 0 itself, so a lit first column
    # gives g0 + g1 there (mirror-without-repeat would give g0 alone)
    image = np.zeros((9, 12))
    image[:, 0] = 1.0
    g = gaussian_taps(1.0)
    r = g.size // 2
    out = gaussian_blur(image, 1.0)
    np.testing.assert_allclose(out[:, 0], g[r] + g[r + 1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(out[:, 1], g[r + 1] + g[r + 2], rtol=0, atol=1e-15)
    # and the whole result equals the convolution of the explicitly padded image
    rng = np.random.default_rng(3)
    image = rng.random((17, 11))
    for sigma in (1.0, 3.0, 6.0):
        r = int(4 * sigma + 0.5)
        padded = np.pad(image, r, mode="symmetric")
        h = gaussian_taps(sigma)
        brute = np.zeros_like(image)
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                brute += h[dy + r] * h[dx + r] * padded[r + dy:r + dy + 17, r + dx:r + dx + 11]
        np.testing.assert_allclose(gaussian_blur(image, sigma), brute, rtol=0, atol=1e-14)


def test_gaussian_nan_pixels_are_left_out():
    rng = np.random.default_rng(4)
    image = rng.random((40, 50))
    holes = np.zeros(image.shape, bool)
    holes[10:14, 20:23] = True
    holes[30, 5] = True
    holed = np.where(holes, np.nan, image)
    sigma = 1.5
    out = gaussian_blur(holed, sigma)
    # documented: B(I w) / B(w); every pixel has a non-NaN pixel in reach here
    w = (~holes).astype(float)
    expected = reference_blur(np.where(holes, 0.0, image), sigma) / reference_blur(w, sigma)
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out, expected, rtol=1e-13, atol=0)
    # far from the holes it is the plain blur
    np.testing.assert_allclose(out[:, 35:], gaussian_blur(image, sigma)[:, 35:], rtol=1e-13)
    # a constant image with holes stays that constant, holes filled
    np.testing.assert_allclose(gaussian_blur(np.where(holes, np.nan, 5.0), 3.0), 5.0, rtol=0, atol=1e-12)


def test_gaussian_nan_only_where_no_weight_reaches():
    image = np.full((20, 20), np.nan)
    image[0, 0] = 2.0
    sigma = 1.0
    r = int(4 * sigma + 0.5)
    out = gaussian_blur(image, sigma)
    reach = np.zeros(image.shape, bool)
    reach[: r + 1, : r + 1] = True  # offsets up to r, reflection at the corner
    assert np.array_equal(np.isfinite(out), reach)
    np.testing.assert_allclose(out[reach], 2.0, rtol=1e-14)
    assert np.isnan(gaussian_blur(np.full((5, 6), np.nan), 2.0)).all()


def test_gaussian_infinity_spreads():
    image = np.zeros((15, 15))
    image[7, 7] = np.inf
    out = gaussian_blur(image, 1.0)
    assert np.isposinf(out[7, 7]) and np.isposinf(out[3, 11]) and out[0, 0] == 0.0


def test_gaussian_sigma_zero_and_tiny_return_a_copy():
    image = np.arange(12, dtype=np.int16).reshape(3, 4)
    for sigma in (0, 0.0, 1e-3):
        out = gaussian_blur(image, sigma)
        assert out.dtype == np.float64
        np.testing.assert_array_equal(out, image)
    f = np.ones((3, 4))
    out = gaussian_blur(f, 0.0)
    out[0, 0] = 5.0
    assert f[0, 0] == 1.0


def test_gaussian_dtypes_agree():
    rng = np.random.default_rng(5)
    ints = rng.integers(0, 1000, (20, 30))
    np.testing.assert_allclose(gaussian_blur(ints, 2.0), gaussian_blur(ints.astype(np.float64), 2.0), rtol=0, atol=0)
    f32 = rng.random((20, 30)).astype(np.float32)
    np.testing.assert_allclose(gaussian_blur(f32, 2.0), gaussian_blur(f32.astype(np.float64), 2.0), rtol=0, atol=0)
    # non-contiguous input
    big = rng.random((40, 60))
    np.testing.assert_allclose(gaussian_blur(big[::2, ::2], 1.5), gaussian_blur(big[::2, ::2].copy(), 1.5), atol=0)


def test_gaussian_errors():
    image = np.zeros((4, 4))
    with pytest.raises(ValueError, match=r"sigma must be >= 0.0; got -1"):
        gaussian_blur(image, -1)
    with pytest.raises(ValueError, match=r"sigma must be finite; got nan"):
        gaussian_blur(image, float("nan"))
    with pytest.raises(TypeError, match=r"sigma must be a real number; got '2'"):
        gaussian_blur(image, "2")
    with pytest.raises(ValueError, match=r"image must be a 2-D array \(rows, cols\); got shape \(4, 4, 3\)"):
        gaussian_blur(np.zeros((4, 4, 3)), 1.0)
    with pytest.raises(ValueError, match=r"image must be a 2-D array \(rows, cols\); got shape \(4,\)"):
        gaussian_blur(np.zeros(4), 1.0)
    with pytest.raises(TypeError, match=r"image must be a real float or integer array; got dtype complex128"):
        gaussian_blur(np.zeros((4, 4), complex), 1.0)
    with pytest.raises(TypeError, match=r"got dtype bool"):
        gaussian_blur(np.zeros((4, 4), bool), 1.0)
    with pytest.raises(ValueError, match=r"truncate must be > 0.0; got 0"):
        gaussian_blur(image, 1.0, truncate=0)
    with pytest.raises(ValueError, match=r"kernel radius .* = 4000000000 pixels .* above the 1048576 allowed"):
        gaussian_blur(image, 1e9)


def test_gaussian_does_not_modify_input():
    rng = np.random.default_rng(6)
    for image in (rng.random((12, 9)), rng.random((12, 9)).astype(np.float32),
                  np.where(rng.random((12, 9)) < 0.2, np.nan, rng.random((12, 9)))):
        before = image.copy()
        out = gaussian_blur(image, 2.0)
        assert out is not image
        np.testing.assert_array_equal(image, before)


def test_gaussian_degenerate_shapes():
    assert gaussian_blur(np.zeros((0, 5)), 2.0).shape == (0, 5)
    np.testing.assert_allclose(gaussian_blur(np.array([[4.0]]), 3.0), [[4.0]], atol=1e-14)
    row = np.random.default_rng(7).random((1, 30))
    np.testing.assert_allclose(gaussian_blur(row, 2.0), reference_blur(row, 2.0), atol=2e-15)


# -- bilateral_grid -------------------------------------------------------------------------
@pytest.mark.parametrize("sigma_spatial, sigma_range", [(4.0, 0.4), (0.7, 0.1), (30.0, 5.0)])
@pytest.mark.parametrize("value", [3.7, -12.5])
def test_bilateral_constant_stays_constant(sigma_spatial, sigma_range, value):
    image = np.full((37, 53), value)
    np.testing.assert_allclose(bilateral_grid(image, sigma_spatial, sigma_range), value, rtol=0, atol=1e-9)
    # joint: whatever the edge image, averaging a constant gives the constant
    edge = np.random.default_rng(8).random((37, 53))
    np.testing.assert_allclose(bilateral_grid(image, sigma_spatial, sigma_range, edge=edge), value, rtol=0, atol=1e-9)


def test_bilateral_preserves_a_step_that_gaussian_blur_smears():
    sigma_spatial, sigma_range = 4.0, 0.25
    height = 10 * sigma_range
    rng = np.random.default_rng(9)
    rows, cols, at = 64, 96, 48
    clean = np.where(np.arange(cols) < at, 1.0, 1.0 + height)[None, :].repeat(rows, axis=0)
    image = clean + 0.1 * sigma_range * rng.standard_normal((rows, cols))
    out = bilateral_grid(image, sigma_spatial, sigma_range)
    far = np.abs(np.arange(cols) - (at - 0.5)) >= 2 * sigma_spatial
    assert np.abs(out - clean)[:, far].max() < 0.01 * height
    # in fact right up to the step: the two sides are 10 range cells apart
    assert np.abs(out - clean).max() < 0.01 * height
    blurred = gaussian_blur(image, sigma_spatial)
    assert np.abs(blurred - clean)[:, far].max() > 0.015 * height  # fails the same 1 % test there
    jump_bilateral = np.median(out[:, at] - out[:, at - 1])
    jump_gaussian = np.median(blurred[:, at] - blurred[:, at - 1])
    assert jump_bilateral > 0.98 * height
    assert jump_gaussian < 0.15 * height


def test_bilateral_with_huge_sigma_range_is_a_gaussian_blur():
    rng = np.random.default_rng(10)
    image = gaussian_blur(rng.random((96, 96)), 2.0)
    image = (image - image.min()) / np.ptp(image)
    sigma_spatial = 4.0
    out = bilateral_grid(image, sigma_spatial, 1e6)
    diff = np.abs(out - gaussian_blur(image, sigma_spatial))
    m = int(3 * sigma_spatial)  # the grid normalises at the border, gaussian_blur reflects
    interior = diff[m:-m, m:-m]
    # measured 0.020 and 0.0029 of the data range (grid splat/blur/slice vs exact kernel)
    assert interior.max() < 0.03
    assert interior.mean() < 0.005
    assert diff.max() < 0.06


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("sigma_spatial, sigma_range", [(3.0, 0.25), (2.0, 0.1), (4.0, 0.5), (6.0, 0.3)])
def test_bilateral_approximates_the_exact_filter(seed, sigma_spatial, sigma_range):
    image = smooth_edges_image(48, seed)
    out = bilateral_grid(image, sigma_spatial, sigma_range)
    err = np.abs(out - exact_bilateral(image, sigma_spatial, sigma_range)) / sigma_range
    # documented: mean 0.015 sigma_range (worst case 0.018), max 0.17 sigma_range
    assert err.mean() < 0.025
    assert err.max() < 0.25
    # for scale: the exact filter moves the image by much more than that
    moved = np.abs(exact_bilateral(image, sigma_spatial, sigma_range) - image).mean() / sigma_range
    assert moved > 5 * err.mean()


def test_bilateral_joint_takes_weights_from_edge():
    rng = np.random.default_rng(11)
    rows, cols, at = 40, 64, 32
    sigma_spatial, sigma_range = 4.0, 1.0
    edge = np.where(np.arange(cols) < at, 0.0, 10.0)[None, :].repeat(rows, axis=0)
    image = 10.0 * rng.random((rows, cols))  # noise far larger than sigma_range
    image[:, at:] += 100.0
    out = bilateral_grid(image, sigma_spatial, sigma_range, edge=edge)
    # no averaging across edge's step: each side equals the side filtered alone (the
    # cells line up because ``at`` is a multiple of sigma_spatial)
    left = bilateral_grid(image[:, :at], sigma_spatial, sigma_range, edge=edge[:, :at])
    right = bilateral_grid(image[:, at:], sigma_spatial, sigma_range, edge=edge[:, at:])
    np.testing.assert_allclose(out[:, :at], left, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out[:, at:], right, rtol=0, atol=1e-9)
    assert out[:, :at].max() < 10.0
    # the weights come from edge (flat on each side), not from the noisy image: the
    # noise is smoothed away, which range weights from image would have prevented
    assert out[:, 4:at - 4].std() < 0.2 * image[:, :at].std()
    alone = bilateral_grid(image, sigma_spatial, sigma_range)
    assert np.abs(alone - image)[:, :at].mean() < 0.3 * np.abs(out - image)[:, :at].mean()
    # with a flat edge image it is a plain (cross-step) blur
    flat = bilateral_grid(image, sigma_spatial, sigma_range, edge=np.zeros_like(image))
    assert flat[:, at - 1].mean() > 30.0


def test_bilateral_joint_matches_exact_filter():
    rng = np.random.default_rng(12)
    edge = smooth_edges_image(40, 3)
    image = rng.random((40, 40))
    out = bilateral_grid(image, 3.0, 0.25, edge=edge)
    err = np.abs(out - exact_bilateral(image, 3.0, 0.25, edge=edge))
    assert err.mean() < 0.02 * np.ptp(image)


def test_bilateral_nan_pixels_are_skipped_and_stay_nan():
    rng = np.random.default_rng(13)
    image = smooth_edges_image(48, 2)
    holes = rng.random(image.shape) < 0.05
    holes[20:26, 20:26] = True
    holed = np.where(holes, np.nan, image)
    out = bilateral_grid(holed, 3.0, 0.25)
    assert np.array_equal(np.isnan(out), holes)
    err = np.abs(out - exact_bilateral(holed, 3.0, 0.25))[~holes] / 0.25
    assert err.mean() < 0.025
    # a constant with holes stays constant where defined
    const = bilateral_grid(np.where(holes, np.nan, 2.0), 3.0, 0.25)
    np.testing.assert_allclose(const[~holes], 2.0, rtol=0, atol=1e-9)
    assert np.isnan(bilateral_grid(np.full((6, 7), np.nan), 2.0, 0.5)).all()
    # joint: NaN in edge also comes out NaN; NaN in image does too
    edge = image.copy()
    edge[5, 5] = np.nan
    joint = bilateral_grid(holed, 3.0, 0.25, edge=edge)
    assert np.array_equal(np.isnan(joint), holes | np.isnan(edge))


def test_bilateral_too_many_range_cells():
    image = np.linspace(0.0, 300.0, 20 * 30).reshape(20, 30)
    with pytest.raises(ValueError, match=r"the data range \[0, 300\] \(span 300\) with sigma_range=0.5 needs 602 "
                                         r"range cells; at most 512 are allowed"):
        bilateral_grid(image, 2.0, 0.5)
    with pytest.raises(ValueError, match=r"needs about 3e\+302 range cells; at most 512 are allowed"):
        bilateral_grid(image, 2.0, 1e-300)
    bilateral_grid(image, 2.0, 300.0 / 510.5)  # 512 cells: allowed
    # joint: the range is edge's
    with pytest.raises(ValueError, match=r"the data range \[0, 300\]"):
        bilateral_grid(np.zeros((20, 30)), 2.0, 0.5, edge=image)


def test_bilateral_too_many_grid_cells():
    with pytest.raises(ValueError, match=r"sigma_spatial=0.001 and sigma_range=1.0 need a grid of about .* cells for "
                                         r"a 20 x 30 image; at most 33554432 are allowed"):
        bilateral_grid(np.zeros((20, 30)), 0.001, 1.0)


def test_bilateral_errors():
    image = np.zeros((8, 9))
    with pytest.raises(ValueError, match=r"sigma_spatial must be > 0.0; got 0"):
        bilateral_grid(image, 0, 0.4)
    with pytest.raises(ValueError, match=r"sigma_range must be > 0.0; got -0.4"):
        bilateral_grid(image, 2.0, -0.4)
    with pytest.raises(ValueError, match=r"sigma_range must be finite; got inf"):
        bilateral_grid(image, 2.0, float("inf"))
    with pytest.raises(ValueError, match=r"image must be a 2-D array \(rows, cols\); got shape \(8, 9, 1\)"):
        bilateral_grid(image[..., None], 2.0, 0.4)
    with pytest.raises(ValueError, match=r"edge must have the shape of image \(8, 9\); got \(9, 8\)"):
        bilateral_grid(image, 2.0, 0.4, edge=image.T)
    with pytest.raises(TypeError, match=r"edge must be a real float or integer array; got dtype complex128"):
        bilateral_grid(image, 2.0, 0.4, edge=image.astype(complex))
    inf = image.copy()
    inf[2, 3] = -np.inf
    with pytest.raises(ValueError, match=r"image holds \+-inf at 1 pixel\(s\); bilateral_grid needs finite values"):
        bilateral_grid(inf, 2.0, 0.4)
    with pytest.raises(ValueError, match=r"image or edge holds \+-inf at 1 pixel"):
        bilateral_grid(image, 2.0, 0.4, edge=inf)


def test_bilateral_does_not_modify_input():
    rng = np.random.default_rng(14)
    image = np.where(rng.random((30, 40)) < 0.1, np.nan, rng.random((30, 40)))
    edge = rng.random((30, 40)).astype(np.float32)
    before_image, before_edge = image.copy(), edge.copy()
    out = bilateral_grid(image, 3.0, 0.2, edge=edge)
    out2 = bilateral_grid(image, 3.0, 0.2)
    assert out is not image and out2 is not image
    np.testing.assert_array_equal(image, before_image)
    np.testing.assert_array_equal(edge, before_edge)


def test_bilateral_dtypes_and_shapes():
    rng = np.random.default_rng(15)
    ints = rng.integers(0, 20, (25, 35))
    np.testing.assert_array_equal(bilateral_grid(ints, 3.0, 2.0), bilateral_grid(ints.astype(float), 3.0, 2.0))
    f32 = rng.random((25, 35)).astype(np.float32)
    out = bilateral_grid(f32, 3.0, 0.2)
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, bilateral_grid(f32.astype(np.float64), 3.0, 0.2))
    assert bilateral_grid(np.zeros((0, 4)), 2.0, 0.1).shape == (0, 4)
    np.testing.assert_allclose(bilateral_grid(np.array([[1.25]]), 2.0, 0.1), [[1.25]], atol=1e-12)
    row = rng.random((1, 50))
    np.testing.assert_allclose(bilateral_grid(row, 2.0, 1e6), gaussian_blur(row, 2.0), atol=0.1)
