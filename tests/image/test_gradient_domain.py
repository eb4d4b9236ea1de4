"""Gradient-domain HDR compression (Fattal, Lischinski & Werman 2002): analytic checks."""
import doctest

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pv_hdrvol.image import gradient_domain as gd
from pv_hdrvol.image.gradient_domain import (
    attenuation, compress_log_luminance, gaussian_pyramid, laplacian_neumann, solve_poisson_neumann,
)

pytestmark = pytest.mark.core

SHAPES = [(2, 2), (2, 3), (3, 2), (5, 8), (17, 16), (33, 47), (64, 64), (101, 40)]


def _grid(rows, cols):
    return np.arange(rows, dtype=np.float64)[:, None], np.arange(cols, dtype=np.float64)[None, :]


def _texture_and_step(n=256):
    """Log luminance: a step of 10 (e**10 ~ 22000:1) at the middle column plus a small texture."""
    i, j = _grid(n, n)
    texture = 0.1 * np.sin(2 * np.pi * i / 8) * np.sin(2 * np.pi * j / 8)
    return 10.0 * (j >= n // 2) + texture


# -- Laplacian and Poisson solver ------------------------------------------------------

@pytest.mark.parametrize("shape", SHAPES)
def test_laplacian_matches_mirrored_ghost_cells(shape):
    I0 = np.random.default_rng(1).standard_normal(shape)
    p = np.pad(I0, 1, mode="edge")  # ghost cell = its mirror image across the edge
    expected = p[:-2, 1:-1] + p[2:, 1:-1] + p[1:-1, :-2] + p[1:-1, 2:] - 4 * I0
    np.testing.assert_allclose(laplacian_neumann(I0), expected, rtol=0, atol=1e-13)
    assert abs(laplacian_neumann(I0).sum()) < 1e-12


@pytest.mark.parametrize("shape", SHAPES + [(256, 300)])
def test_poisson_inverts_laplacian(shape):
    I0 = 5.0 * np.random.default_rng(2).standard_normal(shape) + 3.0
    I = solve_poisson_neumann(laplacian_neumann(I0))
    assert I.shape == shape and I.dtype == np.float64
    np.testing.assert_allclose(I, I0 - I0.mean(), rtol=0, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.integers(2, 40), st.integers(2, 40), st.integers(0, 2**32 - 1))
def test_poisson_inverts_laplacian_any_shape(rows, cols, seed):
    I0 = np.random.default_rng(seed).uniform(-100, 100, (rows, cols))
    I = solve_poisson_neumann(laplacian_neumann(I0))
    np.testing.assert_allclose(I, I0 - I0.mean(), rtol=0, atol=1e-9)


@pytest.mark.parametrize("rows, cols, ky, kx", [
    (8, 8, 0, 1), (8, 8, 1, 0), (37, 50, 3, 7), (37, 50, 36, 49), (2, 2, 1, 1), (5, 3, 4, 2),
])
def test_poisson_reproduces_dct_eigenfunction(rows, cols, ky, kx):
    i, j = _grid(rows, cols)
    e = np.cos(np.pi * kx * (j + 0.5) / cols) * np.cos(np.pi * ky * (i + 0.5) / rows)
    lam = 2 * np.cos(np.pi * kx / cols) + 2 * np.cos(np.pi * ky / rows) - 4
    np.testing.assert_allclose(laplacian_neumann(e), lam * e, rtol=0, atol=1e-12)
    np.testing.assert_allclose(solve_poisson_neumann(lam * e), e, rtol=0, atol=1e-9)


def test_poisson_projects_out_the_mean_of_div():
    div = laplacian_neumann(np.random.default_rng(3).standard_normal((20, 30)))
    I = solve_poisson_neumann(div)
    np.testing.assert_allclose(solve_poisson_neumann(div + 0.25), I, rtol=0, atol=1e-12)
    # ... which is the solution of the projected equation:
    np.testing.assert_allclose(laplacian_neumann(solve_poisson_neumann(div + 0.25)), div, rtol=0, atol=1e-12)
    assert abs(I.mean()) < 1e-15
    assert not solve_poisson_neumann(np.full((6, 9), 4.0)).any()  # a constant div is all "mean"


# -- pyramid ---------------------------------------------------------------------------

def test_pyramid_shapes_1000x700():
    levels = gaussian_pyramid(np.zeros((1000, 700)), min_size=32)
    assert [p.shape for p in levels] == [(1000, 700), (500, 350), (250, 175), (125, 88), (63, 44)]
    assert [p.shape for p in gaussian_pyramid(np.zeros((1000, 700)), min_size=44)][-1] == (63, 44)
    assert [p.shape for p in gaussian_pyramid(np.zeros((20, 700)), min_size=32)] == [(20, 700)]


def test_pyramid_level_is_binomial_blur_then_decimation():
    H = np.random.default_rng(4).standard_normal((13, 10))
    kernel = np.array([1, 4, 6, 4, 1]) / 16.0
    padded = np.pad(H, 2, mode="symmetric")
    rows_blurred = np.array([np.convolve(c, kernel, mode="valid") for c in padded.T]).T
    blurred = np.array([np.convolve(r, kernel, mode="valid") for r in rows_blurred])
    levels = gaussian_pyramid(H, min_size=5)
    assert len(levels) == 2
    np.testing.assert_array_equal(levels[0], H)
    np.testing.assert_allclose(levels[1], blurred[::2, ::2], rtol=0, atol=1e-14)


# -- attenuation -----------------------------------------------------------------------

@pytest.mark.parametrize("beta", [0.8, 0.85, 1.0, 1.2])
def test_phi_is_one_at_alpha_abs_and_follows_power_law(beta):
    # A ramp has the mean gradient magnitude everywhere, so alpha_abs = alpha * slope.
    i, j = _grid(30, 40)
    ramp = 0.5 * j + 0 * i
    assert np.all(attenuation(ramp, alpha=1.0, beta=beta, min_size=1000) == 1.0)
    np.testing.assert_allclose(attenuation(ramp, alpha=0.5, beta=beta, min_size=1000), 2.0 ** (beta - 1), rtol=1e-14)


def test_single_level_phi_matches_formula():
    H = np.random.default_rng(5).standard_normal((24, 31))
    H[:, :5] = 2.0  # flat: gradient 0 there, so the floor is used
    gy, gx = np.gradient(H)  # central differences / 2, one-sided at the edges
    g = np.hypot(gx, gy)
    alpha_abs = 0.1 * g.mean()
    expected = (np.maximum(g, gd.MAGNITUDE_FLOOR * alpha_abs) / alpha_abs) ** (0.85 - 1)
    np.testing.assert_allclose(attenuation(H, 0.1, 0.85, min_size=1000), expected, rtol=1e-13)
    assert attenuation(H, 0.1, 0.85, min_size=1000).max() == pytest.approx(1000 ** 0.15, rel=1e-13)


def test_two_level_phi_matches_formula():
    rng = np.random.default_rng(6)
    H = rng.standard_normal((21, 30))
    beta = 0.8
    H1 = gaussian_pyramid(H, min_size=8)[1]
    assert H1.shape == (11, 15) and len(gaussian_pyramid(H, min_size=8)) == 2
    g0 = np.hypot(*np.gradient(H))
    g1 = np.hypot(*np.gradient(H1, 2.0))  # level-1 pixels are 2 level-0 pixels
    alpha_abs = 0.1 * g0.mean()
    phi0 = (np.maximum(g0, 1e-3 * alpha_abs) / alpha_abs) ** (beta - 1)
    phi1 = (np.maximum(g1, 1e-3 * alpha_abs) / alpha_abs) ** (beta - 1)
    # bilinear, level-1 sample i at level-0 pixel 2i, clamped past the last sample
    up_rows = np.array([np.interp(np.arange(21) / 2, np.arange(11), c) for c in phi1.T]).T
    up = np.array([np.interp(np.arange(30) / 2, np.arange(15), r) for r in up_rows])
    np.testing.assert_allclose(attenuation(H, 0.1, beta, min_size=8), up * phi0, rtol=1e-13)


def test_large_gradients_are_attenuated_more_than_small():
    H = _texture_and_step()
    Phi = attenuation(H, beta=0.8)
    assert Phi[:, 127].max() < 0.2 * Phi[:, 30:100].min()


# -- the whole method --------------------------------------------------------------------

@pytest.mark.parametrize("shape", SHAPES + [(300, 257)])
def test_beta_one_reproduces_H(shape):
    H = np.log(np.random.default_rng(7).uniform(1e-4, 1e4, shape))
    I = compress_log_luminance(H, beta=1.0)
    np.testing.assert_allclose(I, H - H.mean(), rtol=0, atol=1e-9)


@pytest.mark.parametrize("value", [0.0, 1.0, -30.0, 1e6])
@pytest.mark.parametrize("shape", [(2, 2), (40, 70)])
def test_constant_H_gives_zero(value, shape):
    I = compress_log_luminance(np.full(shape, value))
    assert np.abs(I).max() <= 1e-12
    np.testing.assert_array_equal(attenuation(np.full(shape, value)), 1.0)


@pytest.mark.parametrize("slope_y, slope_x", [(0.0, 0.05), (0.3, 0.0), (0.3, 0.2), (-2.0, 1.0)])
def test_ramp_stays_strictly_monotone(slope_y, slope_x):
    i, j = _grid(100, 130)
    H = slope_y * i + slope_x * j
    I = compress_log_luminance(H, beta=0.8)
    for axis, slope in ((0, slope_y), (1, slope_x)):
        d = np.diff(I, axis=axis)
        if slope > 0:
            assert d.min() > 0
        elif slope < 0:
            assert d.max() < 0
        else:
            assert np.abs(d).max() < 1e-12


@settings(max_examples=25, deadline=None)
@given(st.floats(0.01, 5.0), st.floats(0.5, 1.0), st.integers(2, 70), st.integers(2, 70))
def test_row_ramp_stays_strictly_monotone_property(slope, beta, rows, cols):
    H = np.tile(slope * np.arange(cols, dtype=np.float64), (rows, 1))
    d = np.diff(compress_log_luminance(H, beta=beta, min_size=4), axis=1)
    assert d.min() > 0


def test_step_is_compressed_much_more_than_texture():
    H = _texture_and_step()
    I = compress_log_luminance(H, beta=0.8)
    patch = (slice(96, 160), slice(16, 48))  # texture far from the step
    range_ratio = np.ptp(I) / np.ptp(H)
    texture_ratio = I[patch].std() / H[patch].std()
    # The overall scale of I depends on alpha (see the attenuation Notes); relative to
    # the texture, the step's range shrinks by over 10x (measured: 33x).
    assert range_ratio < 0.1 * texture_ratio
    # and the step keeps its sign: averaged over rows (the texture averages out), every
    # column right of the step is brighter than every column left of it.
    profile = I.mean(axis=0)
    assert profile[128:].min() > profile[:128].max()


def test_beta_above_one_expands_contrast():
    H = _texture_and_step()
    I = compress_log_luminance(H, beta=1.2)
    patch = (slice(96, 160), slice(16, 48))
    assert np.ptp(I) / np.ptp(H) > 10 * I[patch].std() / H[patch].std()


def test_overflowing_beta_raises():
    with pytest.raises(ValueError, match=r"Phi overflows with beta=300.0: .* on each of 4 levels"):
        compress_log_luminance(_texture_and_step(), beta=300.0)


def test_output_has_zero_mean_and_float64():
    H = np.log(np.random.default_rng(8).uniform(1e-3, 1e3, (50, 60))).astype(np.float32)
    I = compress_log_luminance(H)
    assert I.dtype == np.float64 and abs(I.mean()) < 1e-12
    np.testing.assert_array_equal(I, compress_log_luminance(H.astype(np.float64)))


# -- weights -----------------------------------------------------------------------------

def _textured_ramp():
    i, j = _grid(96, 128)
    texture = 0.1 * np.sin(2 * np.pi * i / 16) * np.sin(2 * np.pi * j / 16)
    H = 0.5 * j + texture  # no gradient anywhere near the floor
    H[:, :40] += np.sin(2 * np.pi * i / 6) * np.ones((1, 40))  # a busier region
    return H


def test_weights_of_ones_equal_unweighted():
    H = _textured_ramp()
    np.testing.assert_allclose(compress_log_luminance(H, weights=np.ones(H.shape)), compress_log_luminance(H),
                               rtol=0, atol=1e-12)


def test_weights_act_through_alpha_abs_only():
    H = _textured_ramp()
    w = np.zeros(H.shape)
    w[:, :40] = 1.0
    g = np.hypot(*np.gradient(H))
    ratio = g[:, :40].mean() / g.mean()
    assert ratio > 1.2
    # documented: weights replace the mean in alpha_abs ...
    np.testing.assert_allclose(attenuation(H, 0.1, 0.85, weights=w), attenuation(H, 0.1 * ratio, 0.85), rtol=1e-12)
    # ... so away from the floor they scale the output by ratio ** ((1 - beta) * levels)
    n_levels = len(gaussian_pyramid(H))
    I_w = compress_log_luminance(H, 0.1, 0.85, weights=w)
    I = compress_log_luminance(H, 0.1, 0.85)
    np.testing.assert_allclose(I_w, ratio ** (0.15 * n_levels) * I, rtol=0, atol=1e-10 * np.abs(I).max())
    assert not np.allclose(I_w, I)
    np.testing.assert_array_equal(compress_log_luminance(H, 0.1, 0.85, weights=w > 0), I_w)  # a boolean mask


def test_weights_on_a_flat_region_raise():
    H = _textured_ramp()
    H[:10, :10] = 0.0
    w = np.zeros(H.shape)
    w[2:6, 2:6] = 1.0
    with pytest.raises(ValueError, match="weighted mean gradient magnitude of H is 0"):
        compress_log_luminance(H, weights=w)


# -- errors and the caller's data -------------------------------------------------------

def test_nan_and_inf_raise():
    H = np.zeros((8, 8))
    H[3, 4] = np.nan
    with pytest.raises(ValueError, match=r"H must be finite; got 1 NaN and 0 infinite values \(fill NaN"):
        compress_log_luminance(H)
    H[3, 4] = -np.inf
    with pytest.raises(ValueError, match="H must be finite; got 0 NaN and 1 infinite"):
        attenuation(H)
    with pytest.raises(ValueError, match="div must be finite"):
        solve_poisson_neumann(H)


@pytest.mark.parametrize("kwargs, error, match", [
    ({"alpha": 0.0}, ValueError, "alpha must be > 0.0; got 0.0"),
    ({"alpha": -1}, ValueError, "alpha must be > 0.0; got -1"),
    ({"alpha": float("nan")}, ValueError, "alpha must be finite"),
    ({"alpha": "0.1"}, TypeError, "alpha must be a real number"),
    ({"beta": 0.0}, ValueError, "beta must be > 0.0; got 0.0"),
    ({"beta": -0.5}, ValueError, "beta must be > 0.0"),
    ({"beta": float("inf")}, ValueError, "beta must be finite"),
    ({"min_size": 1}, ValueError, "min_size must be >= 2; got 1"),
    ({"min_size": 32.0}, TypeError, "min_size must be an integer"),
    ({"weights": np.ones((8, 9))}, ValueError, r"weights must have the shape of H, \(8, 8\); got \(8, 9\)"),
    ({"weights": -np.ones((8, 8))}, ValueError, "weights must be >= 0"),
    ({"weights": np.zeros((8, 8))}, ValueError, "weights must have a positive sum"),
    ({"weights": np.full((8, 8), np.nan)}, ValueError, "weights must be finite"),
    ({"weights": np.ones((8, 8), complex)}, TypeError, "weights must be an array of real numbers or booleans"),
])
def test_bad_parameters_raise(kwargs, error, match):
    H = np.random.default_rng(9).standard_normal((8, 8))
    for func in (compress_log_luminance, attenuation):
        with pytest.raises(error, match=match):
            func(H, **kwargs)


@pytest.mark.parametrize("func", [compress_log_luminance, attenuation, gaussian_pyramid, laplacian_neumann,
                                  solve_poisson_neumann])
def test_bad_shapes_and_dtypes_raise(func):
    name = "div" if func is solve_poisson_neumann else "I" if func is laplacian_neumann else "H"
    with pytest.raises(ValueError, match=rf"{name} must be a 2-D \(rows, cols\) array; got shape \(5,\)"):
        func(np.zeros(5))
    with pytest.raises(ValueError, match=rf"{name} must be a 2-D .* got shape \(2, 2, 3\)"):
        func(np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match=rf"{name} must be at least 2x2; got shape \(1, 5\)"):
        func(np.zeros((1, 5)))
    with pytest.raises(TypeError, match=rf"{name} must be an array of real numbers; got dtype complex128"):
        func(np.zeros((4, 4), complex))


def test_callers_arrays_are_not_modified():
    rng = np.random.default_rng(10)
    for dtype in (np.float64, np.float32):
        H = np.log(rng.uniform(1e-3, 1e3, (70, 90))).astype(dtype)
        w = rng.uniform(0, 1, H.shape)
        H_copy, w_copy = H.copy(), w.copy()
        H.setflags(write=False)
        w.setflags(write=False)
        compress_log_luminance(H, weights=w)
        attenuation(H, weights=w)
        gaussian_pyramid(H)
        laplacian_neumann(H)
        solve_poisson_neumann(H)
        np.testing.assert_array_equal(H, H_copy)
        np.testing.assert_array_equal(w, w_copy)


def test_docstring_examples():
    result = doctest.testmod(gd, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 5
    assert result.failed == 0
