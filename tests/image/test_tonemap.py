"""Tone-mapping operators: defining equations, properties, inverse, ROI, errors."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.image import tonemap as T
from pv_hdrvol.image.display import srgb_encode

pytestmark = pytest.mark.core

GLOBAL = ["linear", "gamma", "reinhard", "drago"]
LOCAL = [("reinhard", {"local": True}), ("durand", {}), ("fattal", {})]


def grey(values):
    """An (rows, cols, 3) image with R = G = B = values (so luminance = values)."""
    v = np.asarray(values, dtype=np.float64)
    return np.repeat(v[..., None], 3, axis=-1)


def lum_of(values):
    return np.asarray(values, dtype=np.float64)


def hdr_scene(shape=(48, 64), seed=0):
    """Smooth HDR field spanning ~10 decades, with colour, a black corner and texture."""
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:shape[0], 0:shape[1]]
    logl = -6 + 10 * c / (shape[1] - 1) + 0.3 * np.sin(r / 3.0)
    lum = 10.0 ** logl
    rgb = lum[..., None] * np.array([1.0, 0.8, 0.6]) / (np.array([1.0, 0.8, 0.6]) @ T.LUMINANCE_WEIGHTS)
    rgb[:4, :4] = 0.0
    rgb *= 1 + 0.01 * rng.random(rgb.shape)
    return rgb


# -- defining equations ----------------------------------------------------------------
def test_linear_is_exposure_then_clamp():
    img = grey([[0.125, 0.25, 1.0, 4.0]])
    out = hv.tonemap(img, "linear", exposure_stops=2.0, encoding="linear")
    assert out.rgb[0, :, 0].tolist() == [0.5, 1.0, 1.0, 1.0]


def test_linear_auto_exposure_maps_the_percentile_to_one():
    v = np.linspace(1.0, 100.0, 101).reshape(1, -1)
    fit = T.Linear(percentile=50.0).fit(v)
    assert fit.display_luminance(np.array([[50.5]]))[0, 0] == pytest.approx(1.0, rel=1e-12)


def test_srgb_encoding_matches_the_standard_within_1e6():
    x = np.linspace(0.0, 1.0, 10001).reshape(1, -1)
    out = hv.tonemap(grey(x), "linear", exposure_stops=0.0)  # sRGB default
    assert np.abs(out.rgb[..., 0] - srgb_encode(x)).max() < 1e-6


def test_gamma_encoding_table_is_within_its_stated_error():
    x = np.concatenate([np.logspace(-12, 0, 4001), np.linspace(0, 1, 4001)])
    out = hv.tonemap(grey(x.reshape(1, -1)), "linear", exposure_stops=0.0, encoding=2.2).rgb[0, :, 0]
    err = np.abs(out.astype(np.float64) - x ** (1 / 2.2))
    assert err.max() < 2e-5 and err[x > 1e-4].max() < 2e-7


def test_drago_display_values_follow_the_exact_curve():
    y = np.exp(np.random.default_rng(0).normal(0, 6, (64, 64)))  # ~15 decades
    out = hv.tonemap(grey(y), "drago", encoding="linear")
    exact = np.clip(out.fitted.display_luminance(y), 0, 1)
    ok = exact > 1e-6  # float32 output: relative resolution 6e-8
    np.testing.assert_allclose(out.rgb[..., 0][ok], exact[ok], rtol=3e-6)


def test_gamma_operator_uses_a_power_law():
    out = hv.tonemap(grey([[0.25]]), "gamma", exposure_stops=0.0, gamma=2.0)
    assert out.rgb[0, 0, 0] == pytest.approx(0.5, abs=1e-7)


def test_reinhard_global_is_scaled_x_over_one_plus_x():
    v = np.array([[0.01, 0.1, 1.0, 10.0, 100.0]])
    log_avg = math.exp(np.log(v).mean())
    fit = T.Reinhard(key=0.18, white=math.inf).fit(v)
    lm = 0.18 * v / log_avg
    assert fit.stats["log_average"] == pytest.approx(log_avg, rel=1e-12)
    np.testing.assert_allclose(fit.display_luminance(v), lm / (1 + lm), rtol=1e-12)


def test_reinhard_white_point_burns_out_exactly_there():
    v = np.array([[0.01, 0.1, 1.0, 10.0, 100.0]])
    fit = T.Reinhard(key=0.5).fit(v)  # white = largest scaled luminance
    ld = fit.display_luminance(v)
    assert ld[0, -1] == pytest.approx(1.0, rel=1e-12)
    w = fit.stats["white"]
    lm = fit.stats["scale"] * v
    np.testing.assert_allclose(ld, lm * (1 + lm / w**2) / (1 + lm), rtol=1e-12)


def test_drago_bias_curve_at_known_points():
    # L_w = 2^stops L / L_wa; at L_w = 1 the bias term is 0.5^(ln b / ln 0.5) = b
    v = np.array([[0.25, 1.0, 4.0]])  # log-average 1, max 4
    fit = T.Drago(bias=0.7).fit(v)
    c = 1.0 / math.log10(5.0)
    ld = fit.display_luminance(v)
    assert ld[0, 1] == pytest.approx(c * math.log(2.0) / math.log(2 + 8 * 0.25 ** (math.log(0.7) / math.log(0.5))),
                                      rel=1e-12)
    assert ld[0, 0] == pytest.approx(c * math.log(1.25) / math.log(2 + 8 * (1 / 16) ** (math.log(0.7) / math.log(0.5))),
                                      rel=1e-12)
    # bias 0.5 makes the exponent 1: denominator ln(2 + 8 L_w / L_wmax), so L_wmax -> 1
    fit = T.Drago(bias=0.5).fit(v)
    assert fit.display_luminance(v)[0, 2] == pytest.approx(1.0, rel=1e-12)


def test_drago_matches_opencv_with_its_conventions():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(1)
    v = np.exp(rng.uniform(np.log(1e-3), np.log(1e3), (64, 64))).astype(np.float32)
    cv_out = cv2.createTonemapDrago(gamma=1.0, saturation=1.0, bias=0.85).process(grey(v).astype(np.float32))
    # OpenCV's conventions, applied to our operator: input rescaled to [0, 1] by
    # (v - min) / (max - min); log-average over all pixels with values clamped to >= 1e-4;
    # output rescaled the same way. Our operator takes the adaptation luminance through
    # exposure_stops, and holds its curve past the peak (OpenCV lets it fall), so only
    # pixels below the peak are compared.
    x = (v.astype(np.float64) - v.min()) / (v.max() - v.min())
    mean_cv = math.exp(np.log(np.maximum(x, 1e-4)).mean())
    lwa_ours = math.exp(np.log(x[x > 0]).mean())
    fit = T.Drago(bias=0.85, exposure_stops=math.log2(lwa_ours / mean_cv)).fit(x)
    ld = fit.display_luminance(x)
    ld = (ld - ld.min()) / (ld.max() - ld.min())
    below_peak = x * fit.stats["scale"] < fit.curve()[1][4]
    assert below_peak.mean() > 0.9
    np.testing.assert_allclose(ld[below_peak], cv_out[..., 0][below_peak], atol=2e-6)


def test_durand_leaves_a_constant_image_constant():
    out = hv.tonemap(grey(np.full((40, 50), 3.7)), "durand", encoding="linear")
    # base = log L everywhere, no detail: the brightest base maps to 1
    np.testing.assert_allclose(out.rgb, 1.0, rtol=1e-6)


def test_fattal_keeps_a_ramps_gradient_order():
    v = np.tile(10.0 ** np.linspace(-4, 4, 80), (30, 1))
    out = hv.tonemap(grey(v), "fattal", encoding="linear")
    lum = out.fitted.display_luminance(v)
    assert np.all(np.diff(lum, axis=1) > 0)  # strictly increasing along the ramp, every row
    assert np.all(np.diff(out.rgb8[..., 0].astype(int), axis=1) >= 0)


def test_reinhard_local_equals_global_on_a_constant_image():
    # no local contrast: every scale is accepted, V1 = Lm, so Ld = Lm / (1 + Lm)
    v = np.full((32, 32), 5.0)
    ld = T.Reinhard(local=True).fit(v).display_luminance(v)
    np.testing.assert_allclose(ld, 0.18 / 1.18, rtol=1e-9)


def _knee(m, k):
    """The knee operator's curve, written out: m up to k, then k + (1 - k)(1 - e^-(m - k)/(1 - k))."""
    m = np.asarray(m, dtype=np.float64)
    return np.where(m <= k, m, k + (1 - k) * (1 - np.exp(-(m - k) / (1 - k))))


@pytest.mark.parametrize("knee", [0.8, 0.5])
def test_knee_shows_colours_up_to_the_knee_as_they_are_and_keeps_hue_above(knee):
    rng = np.random.default_rng(3)
    img = rng.random((40, 50, 3)) * np.array([4.0, 1.0, 0.3])
    out = hv.tonemap(img, "knee", knee=knee)
    assert out.encoding == "linear"  # colour-map colours are display values: shown unencoded
    m = img.max(axis=-1)
    below = m <= knee
    assert below.sum() > 100 and (~below).sum() > 100
    np.testing.assert_allclose(out.rgb[below], img[below], rtol=0, atol=6e-8)  # float32 of the input
    # above: the colour scaled by g(m) / m, every channel alike
    want = img * (_knee(m, knee) / m)[..., None]
    np.testing.assert_allclose(out.rgb, want, rtol=2e-7, atol=6e-8)
    assert want.max() < 1.0 and out.rgb.max() <= 1.0  # approaches 1 (float32 may round to it)
    # exposure scales before the curve; sRGB on request
    np.testing.assert_allclose(hv.tonemap(img, "knee", knee=knee, exposure_stops=-1).rgb,
                               img * 0.5 * (_knee(m * 0.5, knee) / (m * 0.5))[..., None], rtol=2e-7, atol=6e-8)
    np.testing.assert_allclose(hv.tonemap(img, "knee", knee=knee, encoding="srgb").rgb, srgb_encode(want),
                               rtol=0, atol=2e-6)


def test_knee_extremes_and_inverse():
    v = np.concatenate([[0.0], np.logspace(-20, 20, 4001)]).reshape(1, -1)
    out = hv.tonemap(grey(v), "knee")
    assert out.rgb[0, 0, 0] == 0.0 and np.all(np.diff(out.rgb[0, :, 0]) >= 0) and out.rgb.max() <= 1.0
    odd = grey(np.ones((2, 2)))
    odd[0, 0, 1], odd[0, 1] = np.nan, np.inf
    odd[1, 0] = (1e30, 1e10, 0.0)
    got = hv.tonemap(odd, "knee").rgb
    assert got[0, 0].tolist() == [0.0, 0.0, 0.0] and got[0, 1].tolist() == [1.0, 1.0, 1.0]
    assert got[1, 0, 0] == 1.0 and got[1, 0, 1] < 1e-19 and got[1, 0, 2] == 0.0  # hue kept at 1e30
    img = hdr_scene()
    out = hv.tonemap(img, "knee", exposure_stops=-12)
    back = out.inverse()
    ok = (out.rgb.max(axis=-1) < 0.98) & (out.rgb.min(axis=-1) > 0.02)
    assert ok.sum() > 200
    np.testing.assert_allclose(back[ok], img[ok], rtol=5e-5)
    with pytest.raises(ValueError, match=r"knee must be in \(0, 1\): the display value where compression "
                                         r"begins; got 1.0"):
        hv.tonemap(img, "knee", knee=1.0)
    with pytest.raises(ValueError, match="knee keeps each colour's hue and chroma: its saturation is 1; got 0.5"):
        hv.tonemap(img, "knee", saturation=0.5)


# -- properties, every operator ------------------------------------------------------------
@pytest.mark.parametrize("name", GLOBAL)
def test_global_operators_are_monotone_and_map_zero_to_zero(name):
    v = np.concatenate([[0.0], np.logspace(-20, 20, 4001)]).reshape(1, -1)
    ld = T.make_operator(name).fit(v).display_luminance(v)
    assert ld[0, 0] == 0.0
    assert np.all(np.isfinite(ld))
    # non-decreasing up to rounding (a few ulps where the curve saturates at 1)
    assert np.all(np.diff(ld[0]) >= -4 * np.finfo(float).eps * ld[0, 1:])
    out = hv.tonemap(grey(v), name)
    assert np.all(np.diff(out.rgb[0, :, 0]) >= 0) and out.rgb[0, 0, 0] == 0.0


@pytest.mark.parametrize("name,params", [(n, {}) for n in GLOBAL] + LOCAL)
def test_extreme_inputs_give_finite_display_values(name, params):
    zeros = np.zeros((16, 16, 3))
    one_bright = zeros.copy()
    one_bright[8, 8] = 1e20
    wide = grey(np.logspace(-20, 20, 256).reshape(16, 16))
    nan = wide.copy()
    nan[3, 3, 1] = np.nan
    nan[4, 4] = np.inf
    for img in (zeros, one_bright, wide, nan):
        out = hv.tonemap(img, name, **params)
        assert np.all(np.isfinite(out.rgb)) and out.rgb.min() >= 0 and out.rgb.max() <= 1
    assert hv.tonemap(zeros, name, **params).rgb.max() == 0.0
    out = hv.tonemap(nan, name, **params)
    assert out.rgb[3, 3].tolist() == [0.0, 0.0, 0.0]  # NaN: black
    assert out.rgb[4, 4].tolist() == [1.0, 1.0, 1.0]  # +inf: white


@pytest.mark.parametrize("name,params", [(n, {}) for n in GLOBAL] + LOCAL)
def test_colour_follows_the_luminance_ratio(name, params):
    img = hdr_scene()
    s = 0.7
    out = hv.tonemap(img, name, encoding="linear", saturation=s, **params)
    y = img @ T.LUMINANCE_WEIGHTS
    ok = (out.rgb.max(axis=-1) < 0.99) & (out.rgb.min(axis=-1) > 1e-3)
    assert ok.sum() > 100
    # C_d / C_d,green = (C / C_green)^s
    got = out.rgb[ok][:, 0] / out.rgb[ok][:, 1]
    want = (img[ok][:, 0] / img[ok][:, 1]) ** s
    np.testing.assert_allclose(got, want, rtol=1e-4)
    assert np.all(y[:4, :4] == 0) and out.rgb[:4, :4].max() == 0.0


def test_the_caller_image_is_not_modified():
    img = hdr_scene()
    before = img.copy()
    for name, params in [(n, {}) for n in GLOBAL] + LOCAL:
        hv.tonemap(img, name, roi=(10, 10, 5), **params)
    np.testing.assert_array_equal(img, before)


# -- inverse -----------------------------------------------------------------------------
@pytest.mark.parametrize("name", GLOBAL)
@pytest.mark.parametrize("saturation", [1.0, 0.6])
def test_inverse_round_trip_of_global_operators(name, saturation):
    img = hdr_scene()
    out = hv.tonemap(img, name, saturation=saturation)
    back = out.inverse()
    ok = (out.rgb.max(axis=-1) < 0.98) & (out.rgb.min(axis=-1) > 0.02)
    assert ok.sum() > 200
    # float32 display values and the sRGB table (1e-7) bound the error; 1 / saturation amplifies it
    np.testing.assert_allclose(back[ok], img[ok], rtol=5e-5)
    # from 8-bit display values, where every code is >= 32 (a half step is <= 1/64
    # relative, raised to at most gamma / saturation = 2.4 / 0.6 = 4 on the way back)
    back8 = out.inverse(out.rgb8)
    ok8 = ok & (out.rgb8.min(axis=-1) >= 32)
    rel = np.abs(back8[ok8] / img[ok8] - 1)
    assert ok8.sum() > 100 and rel.max() < (1 + 1 / 64) ** 4 - 1 and np.median(rel) < 0.02


def test_inverse_of_a_local_operator_is_refused():
    out = hv.tonemap(hdr_scene(), "durand")
    with pytest.raises(TypeError, match="durand \\(local\\) has no inverse"):
        out.inverse()


# -- region of interest --------------------------------------------------------------------
def test_roi_tunes_the_mapping_to_the_region():
    v = np.where(np.arange(64)[None, :] < 32, 1e-4, 1e2) * np.ones((32, 64))
    v = v * (1 + 0.2 * np.sin(np.arange(64) / 2.0))  # detail in both halves
    img = grey(v)
    dark = np.zeros(v.shape, bool)
    dark[:, :32] = True
    on_dark = hv.tonemap(img, "drago", roi=dark)
    on_bright = hv.tonemap(img, "drago", roi=~dark)
    # tuned to the dark half: it is shown bright and textured; tuned to the bright half: near black
    assert on_dark.rgb[:, :32].mean() > 0.5 and on_bright.rgb[:, :32].mean() < 0.05
    assert np.ptp(on_dark.rgb8[:, :32, 0]) > 20
    circle = hv.tonemap(img, "reinhard", roi=(10, 16, 6))
    assert circle.fitted.stats["log_average"] == pytest.approx(v[16, 10], rel=0.2)


# -- user operators and errors --------------------------------------------------------------
def test_a_callable_is_an_operator():
    img = hdr_scene()
    out = hv.tonemap(img, lambda y: y / (1 + y), encoding="linear")
    y = img @ T.LUMINANCE_WEIGHTS
    ok = (y > 0) & (out.rgb.max(axis=-1) < 0.999)  # no channel clipped
    assert ok.sum() > 1000
    np.testing.assert_allclose(out.rgb[ok] @ T.LUMINANCE_WEIGHTS, (y / (1 + y))[ok], rtol=1e-5)
    with pytest.raises(TypeError, match="no inverse"):
        out.inverse()
    inv = hv.tonemap(img, T.Curve(function=lambda y: y / (1 + y), inverse=lambda d: d / (1 - d)))
    assert np.isfinite(inv.inverse()).all()


def test_hdrimage_method_and_uint8():
    img = hv.HDRImage(np.concatenate([hdr_scene(), np.ones((48, 64, 1))], axis=2).astype(np.float32))
    out = img.tonemap("reinhard")
    assert out.rgb.dtype == np.float32 and out.rgb8.dtype == np.uint8
    assert np.array_equal(out.rgb8, np.round(out.rgb * 255).astype(np.uint8))
    assert out._repr_png_().startswith(b"\x89PNG")


def test_errors_name_the_value():
    img = hdr_scene()
    with pytest.raises(ValueError, match="operator must be one of .* got 'mantiuk'"):
        hv.tonemap(img, "mantiuk")
    with pytest.raises(TypeError, match="reinhard takes parameters .* got unknown \\['bias'\\]"):
        hv.tonemap(img, "reinhard", bias=0.8)
    with pytest.raises(ValueError, match="bias must be in \\(0, 1\\); got 1.5"):
        hv.tonemap(img, "drago", bias=1.5)
    with pytest.raises(ValueError, match="key must be finite and > 0; got -0.18"):
        hv.tonemap(img, "reinhard", key=-0.18)
    with pytest.raises(ValueError, match="encoding must be 'srgb', 'linear' or a gamma > 0; got 'rec709'"):
        hv.tonemap(img, "linear", encoding="rec709")
    with pytest.raises(ValueError, match="roi radius must be > 0 pixels; got 0.0"):
        hv.tonemap(img, "linear", roi=(1, 1, 0))
    with pytest.raises(ValueError, match="roi covers no pixel"):
        hv.tonemap(img, "linear", roi=(-100, -100, 5))
    with pytest.raises(ValueError, match="roi mask must have the image's shape \\(48, 64\\)"):
        hv.tonemap(img, "linear", roi=np.ones((4, 4), bool))
    with pytest.raises(ValueError, match="image must be an HDRImage or an array of shape \\(rows, cols, 3 or 4\\)"):
        hv.tonemap(np.ones((4, 4)), "linear")
    with pytest.raises(TypeError, match="image must hold linear floats; got dtype uint8"):
        hv.tonemap(np.ones((4, 4, 3), np.uint8), "linear")
    with pytest.raises(ValueError, match="beta must be in \\(0, 1\\]; got 1.2"):
        hv.tonemap(img, "fattal", beta=1.2)


def test_screen_lab_gives_the_standard_cielab_of_srgb_colours():
    from pv_hdrvol.image.display import screen_lab

    # CIELAB (D65) of sRGB white, red and mid grey (#777777), as colour references give them
    got = screen_lab(np.array([[1.0, 1.0, 1.0], [1.0, 0.0, 0.0], [0x77 / 255] * 3]))
    np.testing.assert_allclose(got, [[100.0, 0.0, 0.0], [53.24, 80.09, 67.20], [50.03, 0.0, 0.0]], atol=0.01)


def test_colour_difference_is_zero_for_one_picture_and_the_mean_over_the_mask():
    from pv_hdrvol.image.display import colour_difference, screen_lab

    rng = np.random.default_rng(5)
    picture = rng.random((6, 7, 3))
    mask = rng.random((6, 7)) > 0.3
    assert colour_difference(picture, picture, mask) == (0.0, 1.0)
    grey = np.full((6, 7, 3), 0.5)  # no chroma: any coloured picture has more
    delta_e, chroma = colour_difference(grey, picture, mask)
    want = np.linalg.norm(screen_lab(grey) - screen_lab(picture), axis=-1)[mask].mean()
    assert delta_e == pytest.approx(want, rel=1e-12) and chroma == pytest.approx(0.0, abs=1e-6)
