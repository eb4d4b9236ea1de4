"""Lenses as ray generators: identity where the lens does nothing, the homothety's
geometry on the focal plane, continuity and no folds, level of detail, the exact EDT,
projected features, the fisheye, and bad input."""
import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pv_hdrvol.data.grid import volume_from_array
from pv_hdrvol.rays.camera import Camera
from pv_hdrvol.rays.lenses import (FeatureLens, Fisheye, Lens, Magnifier, SamplingRateLens,
                                   distance_transform)

pytestmark = pytest.mark.core

SIZE = (64, 48)
W, H = SIZE
# An oblique view, so that no axis-aligned coincidence hides an error.
PERSP = Camera((3.0, -4.0, 11.0), (0.4, 0.2, -0.3), (0.1, 1.0, 0.2), view_angle=35.0)
PARA = Camera((3.0, -4.0, 11.0), (0.4, 0.2, -0.3), (0.1, 1.0, 0.2), parallel_projection=True, parallel_scale=2.5)
CAMERAS = pytest.mark.parametrize("cam", [PERSP, PARA], ids=["perspective", "parallel"])
CENTER = (32.5, 24.5)  # the centre of pixel (col 32, row 24)
CENTER_INDEX = 24 * W + 32
SCALE = 12.0  # size of the scene, for absolute tolerances

YY, XX = np.mgrid[:H, :W] + 0.5
MASK = (XX - 28) ** 2 / 12**2 + (YY - 20) ** 2 / 7**2 < 1  # an ellipse
POLYGON = np.array([[10.0, 8.0], [50.0, 12.0], [44.0, 40.0], [14.0, 30.0]])


def magnifiers(factor):
    return {
        "circle": Magnifier(CENTER, radius=12, transition=4, factor=factor),
        "square": Magnifier(CENTER, radius=10, transition=3, factor=factor, shape="square"),
        "mask": Magnifier(shape=MASK, transition=5, factor=factor),
        "polygon": Magnifier(shape=POLYGON, transition=6, factor=factor),
    }


def focal_hits(rays, cam):
    """Where each ray meets the camera's focal plane."""
    _, _, fwd = cam.basis()
    fp = np.asarray(cam.focal_point)
    t = ((fp - rays.origins) @ fwd) / (rays.directions @ fwd)
    return rays.origins + t[:, None] * rays.directions


def assert_same_rays(a, b, where=slice(None)):
    assert np.array_equal(a.origins[where], b.origins[where])
    assert np.array_equal(a.directions[where], b.directions[where])


# -- identity -------------------------------------------------------------------------------------
@CAMERAS
@pytest.mark.parametrize("shape", ["circle", "square", "mask", "polygon"])
def test_factor_one_gives_the_camera_rays_exactly(cam, shape):
    rays = magnifiers(1.0)[shape].rays(cam, SIZE)
    assert_same_rays(rays, cam.rays(SIZE))
    assert rays.lod is None and (rays.width, rays.height) == SIZE


@CAMERAS
def test_factor_one_feature_and_sampling_lenses_are_the_identity(cam):
    feature = FeatureLens(np.ones((2, 2, 2), bool), origin=(0, 0, 0), spacing=(0.5, 0.5, 0.5), factor=1.0)
    for lens in (feature, SamplingRateLens(CENTER, 12, factor=1.0)):
        rays = lens.rays(cam, SIZE)
        assert_same_rays(rays, cam.rays(SIZE))
        assert rays.lod is None


@CAMERAS
@pytest.mark.parametrize("shape", ["circle", "square", "mask", "polygon"])
def test_rays_where_the_scale_is_one_are_the_camera_rays(cam, shape):
    lens = magnifiers(2.5)[shape]
    s, _ = lens.scale(cam, SIZE)
    outside = (s == 1.0).reshape(-1)
    assert 0 < outside.sum() < W * H
    rays, plain = lens.rays(cam, SIZE), cam.rays(SIZE)
    assert_same_rays(rays, plain, outside)
    moved = ~outside
    if shape in ("circle", "square"):
        # the centre of pixel (32, 24) is these lenses' centre, the zoom's fixed point: its
        # ray is the camera's to rounding (bit for bit on some CPUs, not on others)
        assert not outside[CENTER_INDEX]
        moved[CENTER_INDEX] = False
        np.testing.assert_allclose(rays.origins[CENTER_INDEX], plain.origins[CENTER_INDEX], rtol=0,
                                   atol=1e-12 * SCALE)
        np.testing.assert_allclose(rays.directions[CENTER_INDEX], plain.directions[CENTER_INDEX], rtol=0, atol=1e-14)
    # every other ray in the lens moves
    if cam.parallel_projection:  # a lateral zoom: origins move, directions stay
        assert not np.any(np.all(rays.origins[moved] == plain.origins[moved], axis=1))
        assert np.array_equal(rays.directions, plain.directions)
    else:  # an angular zoom: every ray still leaves the camera position
        assert not np.any(np.all(rays.directions[moved] == plain.directions[moved], axis=1))
        assert np.array_equal(rays.origins, plain.origins)
    np.testing.assert_allclose(np.linalg.norm(rays.directions, axis=1), 1.0, rtol=1e-15)


@CAMERAS
def test_outside_the_radius_nothing_changes(cam):
    r = np.hypot(XX - CENTER[0], YY - CENTER[1]).reshape(-1)
    linf = np.maximum(abs(XX - CENTER[0]), abs(YY - CENTER[1])).reshape(-1)
    plain = cam.rays(SIZE)
    off_centre = np.hypot(XX - 5.2, YY - 7.9).reshape(-1)
    cases = [(Magnifier(CENTER, 12, factor=3.0), r >= 12),
             (Magnifier(CENTER, 9, factor=3.0, shape="square"), linf >= 9),
             (SamplingRateLens(CENTER, 12), r >= 12),
             (SamplingRateLens((5.2, 7.9), 15.5, rate="linear"), off_centre >= 15.5)]
    for lens, outside in cases:
        rays = lens.rays(cam, SIZE)
        assert_same_rays(rays, plain, outside)
        assert not (np.array_equal(rays.origins, plain.origins) and np.array_equal(rays.directions, plain.directions))


def test_the_lens_leaves_its_inputs_alone():
    mask, polygon, feature = MASK.copy(), POLYGON.copy(), np.zeros((3, 4, 5), bool)
    feature[1, 2, 3] = True
    lenses = [Magnifier(shape=mask), Magnifier(shape=polygon), FeatureLens(feature)]
    for lens in lenses:
        lens.rays(PERSP, SIZE)
    assert np.array_equal(mask, MASK) and np.array_equal(polygon, POLYGON) and feature.sum() == 1
    # and keeps its own copy: changing the caller's array afterwards changes nothing
    before = lenses[0].rays(PERSP, SIZE)
    mask[:] = True
    assert_same_rays(lenses[0].rays(PERSP, SIZE), before)


# -- geometry of the homothety ------------------------------------------------------------------
@pytest.mark.parametrize("shape", ["circle", "square", "mask", "polygon"])
def test_perspective_magnification_region_is_magnified_exactly_on_the_focal_plane(shape):
    m = 2.5
    lens = magnifiers(m)[shape]
    s, center = lens.scale(PERSP, SIZE)
    rays, plain = lens.rays(PERSP, SIZE), PERSP.rays(SIZE)
    region = (s == 1 / m).reshape(-1)
    assert region.sum() > 10
    x, hit = focal_hits(plain, PERSP), focal_hits(rays, PERSP)
    # P0: the focal-plane point under the lens centre; bilinear in pixels since the plane is flat
    p0 = _focal_point_at(PERSP, center)
    np.testing.assert_allclose(hit[region], p0 + (x[region] - p0) / m, rtol=0, atol=1e-9 * SCALE)
    # they all leave the camera position (an angular zoom: nothing in front is cut away) and
    # meet the focal plane where the rays of a camera at the virtual focal point V would
    assert np.array_equal(rays.origins[region], plain.origins[region])
    v = lens.focal_point(PERSP, SIZE)
    d = plain.directions[region]  # the camera's directions, cast from V instead of E
    _, _, fwd = PERSP.basis()
    t = ((p0 - v) @ fwd) / (d @ fwd)
    np.testing.assert_allclose(v + t[:, None] * d, hit[region], rtol=0, atol=1e-9 * SCALE)


def _focal_point_at(cam, position):
    """Where the camera ray through continuous pixel position(s) (col, row) meets the focal plane."""
    right, up, fwd = cam.basis()
    half_h = cam.parallel_scale if cam.parallel_projection else math.tan(math.radians(cam.view_angle) / 2)
    x = np.asarray((np.asarray(position[0], dtype=float) * 2 / W - 1) * half_h * W / H)[..., None]
    y = np.asarray((1 - np.asarray(position[1], dtype=float) * 2 / H) * half_h)[..., None]
    pos = np.asarray(cam.position)
    if cam.parallel_projection:
        return pos + x * right + y * up + cam.distance * fwd
    return pos + cam.distance * (fwd + x * right + y * up)


def test_centre_ray_passes_through_the_focal_point():
    lens = Magnifier(CENTER, 12, factor=3.0)
    rays = lens.rays(PERSP, SIZE)
    v = lens.focal_point(PERSP, SIZE)
    o, d = rays.origins[CENTER_INDEX], rays.directions[CENTER_INDEX]
    assert np.linalg.norm(np.cross(v - o, d)) < 1e-9 * SCALE
    np.testing.assert_allclose(d, PERSP.rays(SIZE).directions[CENTER_INDEX], rtol=0, atol=1e-15)
    # V lies on the camera ray through the centre, (1 - 1/M) of the way to P0
    e, p0 = np.asarray(PERSP.position), _focal_point_at(PERSP, CENTER)
    np.testing.assert_allclose(v, e + (p0 - e) * (1 - 1 / 3.0), atol=1e-12 * SCALE)


@CAMERAS
@pytest.mark.parametrize("lens", [Magnifier(CENTER, 12, factor=2.0), Magnifier((20.3, 30.8), 9, factor=0.8),
                                  Magnifier(shape=MASK, factor=3.0), SamplingRateLens((30.2, 20.7), 14),
                                  SamplingRateLens(CENTER, 30, rate=lambda x: 1 + 5 * np.sin(3 * x) ** 2)],
                         ids=["magnifier", "minifier", "mask", "sampling", "sampling-callable"])
def test_every_ray_meets_the_focal_plane_at_its_source_pixel(cam, lens):
    """The homothety: the ray of p passes through the focal-plane point of the camera ray
    through q(p) = c + s(p) (p - c), for either camera."""
    s, center = lens.scale(cam, SIZE)
    p0 = _focal_point_at(cam, center)
    hit, x = focal_hits(lens.rays(cam, SIZE), cam), focal_hits(cam.rays(SIZE), cam)
    np.testing.assert_allclose(hit, p0 + s.reshape(-1, 1) * (x - p0), rtol=0, atol=1e-9 * SCALE)
    q = lens.source_map(cam, SIZE).reshape(-1, 2)
    np.testing.assert_allclose(hit, _focal_point_at(cam, (q[:, 0], q[:, 1])), rtol=0, atol=1e-9 * SCALE)


def test_parallel_rays_stay_parallel_and_zoom_laterally():
    m = 3.0
    lens = Magnifier(CENTER, 12, factor=m)
    rays, plain = lens.rays(PARA, SIZE), PARA.rays(SIZE)
    assert np.array_equal(rays.directions, plain.directions)
    s, _ = lens.scale(PARA, SIZE)
    region = (s == 1 / m).reshape(-1)
    oc = plain.origins[CENTER_INDEX]  # the centre is a pixel centre
    np.testing.assert_allclose(rays.origins[region], oc + (plain.origins[region] - oc) / m, atol=1e-12 * SCALE)
    # origins stay on the camera plane
    _, _, fwd = PARA.basis()
    np.testing.assert_allclose((rays.origins - np.asarray(PARA.position)) @ fwd, 0, atol=1e-12 * SCALE)


def test_focal_distance_sets_the_magnification():
    d = np.linalg.norm(_focal_point_at(PERSP, CENTER) - np.asarray(PERSP.position))
    for fd in (0.0, 3.0, 0.9 * d):
        lens = Magnifier(CENTER, 12, focal_distance=fd)
        assert lens.magnification(PERSP, SIZE) == pytest.approx(d / (d - fd), rel=1e-12)
        v = lens.focal_point(PERSP, SIZE)
        assert np.linalg.norm(v - np.asarray(PERSP.position)) == pytest.approx(fd, abs=1e-9 * SCALE)
    # focal_distance 0 is the camera itself: M = 1, the identity
    assert_same_rays(Magnifier(CENTER, 12, focal_distance=0.0).rays(PERSP, SIZE), PERSP.rays(SIZE))


def test_focal_distance_for_a_feature_and_a_sampling_lens():
    lens = SamplingRateLens(CENTER, 12, rate="cubic", focal_distance=4.0)
    d = np.linalg.norm(_focal_point_at(PERSP, CENTER) - np.asarray(PERSP.position))
    m = d / (d - 4.0)
    assert lens.magnification(PERSP, SIZE) == pytest.approx(m, rel=1e-12)
    s, _ = lens.scale(PERSP, SIZE)
    assert s.reshape(-1)[CENTER_INDEX] == pytest.approx(1 / m, rel=1e-12)  # the centre pixel sits at r = 0
    feature = FeatureLens(np.ones((1, 1, 1), bool), spacing=(2, 2, 2), focal_distance=4.0)
    v = feature.focal_point(PERSP, SIZE)
    assert np.linalg.norm(v - np.asarray(PERSP.position)) == pytest.approx(4.0, rel=1e-12)


# -- continuity, Lipschitz bounds, no folds ----------------------------------------------------------
@CAMERAS
@pytest.mark.parametrize("shape", ["circle", "square"])
@pytest.mark.parametrize("m, radius, transition", [(2.0, 12, 4), (4.0, 15, 5), (0.8, 12, 4), (8.0, 10, 1.5)])
def test_transition_is_lipschitz_along_a_radial_line(cam, shape, m, radius, transition):
    """Along the row through the centre r changes by 1 per pixel, so |ds| <= |1 - 1/M| / T,
    perspective apexes move by |ds| |E - P0|, parallel lateral offsets by at most
    max drho/dr = max(1/M, 1 + R |1 - 1/M| / T) pixels."""
    lens = Magnifier(CENTER, radius, transition, m, shape=shape)
    s, _ = lens.scale(cam, SIZE)
    row = s[24]
    bound = abs(1 - 1 / m) / transition
    assert np.abs(np.diff(row)).max() <= bound * (1 + 1e-12)
    assert np.abs(np.diff(row)).max() > 0.5 * bound  # the band is really crossed
    origins = lens.rays(cam, SIZE).origins.reshape(H, W, 3)[24]
    step = np.linalg.norm(np.diff(origins, axis=0), axis=1)
    if cam.parallel_projection:
        pixel = 2 * cam.parallel_scale / H
        assert step.max() <= max(1 / m, 1 + radius * abs(1 - 1 / m) / transition) * pixel * (1 + 1e-12)
    else:
        d = np.linalg.norm(_focal_point_at(cam, CENTER) - np.asarray(cam.position))
        assert step.max() <= bound * d * (1 + 1e-12)
    # the source radius rho = s r grows strictly along the line: no fold
    r = np.abs(np.arange(W) + 0.5 - CENTER[0])
    right = slice(32, None)
    assert np.all(np.diff(row[right] * r[right]) > 0)


@settings(max_examples=40, deadline=None)
@given(radius=st.floats(2, 40), tfrac=st.floats(0, 0.95), m=st.floats(0.05, 20),
       shape=st.sampled_from(["circle", "square"]), cx=st.floats(-5, 69), cy=st.floats(-5, 53))
def test_no_accepted_magnifier_folds(radius, tfrac, m, shape, cx, cy):
    transition = tfrac * radius
    if m < 1 and not m > radius / (radius + transition):
        with pytest.raises(ValueError, match="folds the transition band"):
            Magnifier((cx, cy), radius, transition, m, shape=shape)
        return
    lens = Magnifier((0.0, 0.5), radius, transition, m, shape=shape)
    # rho(r) along the one row of an image that starts at the centre: r = col + 0.5
    s, _ = lens.scale(PERSP, (int(radius) + 3, 1))
    r = np.arange(s.shape[1]) + 0.5
    assert np.all(np.diff(s[0] * r) > 0)


def test_minifier_at_the_fold_limit():
    radius, transition = 12.0, 4.0
    limit = radius / (radius + transition)
    Magnifier(CENTER, radius, transition, limit * (1 + 1e-9))
    with pytest.raises(ValueError, match=r"factor > radius / \(radius \+ transition\) = 0\.75"):
        Magnifier(CENTER, radius, transition, limit)


# -- sampling-rate lens ---------------------------------------------------------------------------
def test_sampling_rate_fills_the_lens_exactly_and_never_folds():
    for rate in ("cubic", "quadratic", "linear", lambda x: np.exp(4 * np.cos(7 * x))):
        lens = SamplingRateLens(CENTER, 17.0, rate=rate) if isinstance(rate, str) else \
            SamplingRateLens(CENTER, 17.0, rate=rate, table_size=999)
        r = np.linspace(0, 17.0, 20001)
        rho = lens.source_radius(r)
        assert rho[0] == 0 and abs(rho[-1] - 17.0) < 1e-9
        assert abs(lens.source_radius(np.nextafter(17.0, 0)) - 17.0) < 1e-9
        assert np.all(np.diff(rho) > 0)
        np.testing.assert_array_equal(lens.source_radius([17.0, 20.0, 1e6]), [17.0, 20.0, 1e6])


@pytest.mark.parametrize("factor", [0.3, 3.0, 11.0])
def test_linear_rate_matches_the_closed_form_inverse(factor):
    """f = 1 + a (1 - x) is linear: the table is exact and rho(r) is the root of
    (a/2) x^2 - (1 + a) x + u F(1) = 0, F(1) = 1 + a/2, x = rho / R, u = r / R."""
    radius, a = 20.0, factor - 1.0
    lens = SamplingRateLens(CENTER, radius, rate="linear", factor=factor, table_size=16)
    u = np.linspace(0, 1, 1001)
    c = u * (1 + a / 2)
    x = 2 * c / ((1 + a) + np.sqrt((1 + a) ** 2 - 2 * a * c))
    np.testing.assert_allclose(lens.source_radius(u * radius), np.where(u < 1, x * radius, radius),
                               rtol=0, atol=1e-11 * radius)
    assert lens.magnification(PERSP, SIZE) == pytest.approx(factor / (1 + a / 2), rel=1e-12)
    s, _ = lens.scale(PERSP, SIZE)
    assert s.reshape(-1)[CENTER_INDEX] == pytest.approx((1 + a / 2) / factor, rel=1e-12)  # F(1)/f(0) at r = 0


@pytest.mark.parametrize("table_size, low, high", [(1024, 1.1e-5, 1.2e-5), (4096, 6.9e-7, 7.5e-7)])
def test_the_table_error_is_what_the_docs_say(table_size, low, high):
    """docs/lenses.md (and benchmarks/bench_lenses.py's table): the cubic rate, factor
    6, radius 200 px, against a 2**20-entry table, largest error of the source radius
    over 2,001 radii: 1.15e-5 px at 1,024 entries, 7.2e-7 px at 4,096 (the default),
    each asserted within about 5 %."""
    r = np.linspace(0.0, 200.0, 2001)
    ref = SamplingRateLens((256.0, 256.0), 200.0, factor=6.0, table_size=2**20).source_radius(r)
    rho = SamplingRateLens((256.0, 256.0), 200.0, factor=6.0, table_size=table_size).source_radius(r)
    assert low < np.max(np.abs(rho - ref)) < high
    assert SamplingRateLens((0.0, 0.0), 1.0).table_size == 4096


@settings(max_examples=30, deadline=None)
@given(c=st.floats(1e-3, 1e3), radius=st.floats(1.5, 60), cx=st.floats(0, 64), cy=st.floats(0, 48),
       n=st.integers(16, 5000))
def test_constant_rate_is_the_identity(c, radius, cx, cy, n):
    lens = SamplingRateLens((cx, cy), radius, rate=lambda x: np.full_like(x, c), table_size=n)
    s, _ = lens.scale(PERSP, SIZE)
    np.testing.assert_allclose(s, 1.0, rtol=0, atol=1e-12)
    r = np.linspace(0, radius, 101)
    np.testing.assert_allclose(lens.source_radius(r), r, rtol=0, atol=1e-12 * radius)


@settings(max_examples=30, deadline=None)
@given(factor=st.floats(0.05, 50), radius=st.floats(2, 40), rate=st.sampled_from(["linear", "quadratic", "cubic"]))
def test_named_rates_never_fold(factor, radius, rate):
    lens = SamplingRateLens((0.0, 0.5), radius, rate=rate, factor=factor)
    s, _ = lens.scale(PERSP, (int(radius) + 3, 1))
    r = np.arange(s.shape[1]) + 0.5
    assert np.all(np.diff(s[0] * r) > 0)
    np.testing.assert_allclose(s[0][r >= radius], 1.0, rtol=0, atol=0)


# -- level of detail ----------------------------------------------------------------------------
@CAMERAS
def test_lod_is_none_without_sparser_rays(cam):
    assert Magnifier(CENTER, 12, factor=1.0).rays(cam, SIZE).lod is None
    assert Magnifier(CENTER, 12, factor=4.0, antialias=False).rays(cam, SIZE).lod is None
    assert SamplingRateLens(CENTER, 12, antialias=False).rays(cam, SIZE).lod is None
    assert Fisheye(180, antialias=False).rays(cam, SIZE).lod is None
    assert Fisheye(10).rays(cam, SIZE).lod is None  # rays denser than the camera's


@CAMERAS
def test_lod_is_positive_exactly_in_the_compressed_band(cam):
    m, radius, transition = 4.0, 12.0, 4.0
    lens = Magnifier(CENTER, radius, transition, m)
    lod = lens.rays(cam, SIZE).lod
    r = np.hypot(XX - CENTER[0], YY - CENTER[1]).reshape(-1)
    band = (r > radius - transition) & (r < radius)
    assert lod.shape == (W * H,) and lod.dtype == np.float64
    np.testing.assert_array_equal(lod > 0, band)
    # analytic: rho = s r, drho/dr = s + r s' (> s, the tangential stretch)
    k = 24 * W + 32 + 10  # r = 10
    s = 1 / m + (1 - 1 / m) * (10 - (radius - transition)) / transition
    assert lod[k] == pytest.approx(math.log2(s + 10 * (1 - 1 / m) / transition), rel=1e-12)


def test_lod_of_a_minifier_is_positive_in_the_minified_region():
    lod = Magnifier(CENTER, 12, 4, 0.8).rays(PERSP, SIZE).lod
    assert lod[CENTER_INDEX] == pytest.approx(math.log2(1 / 0.8), rel=1e-12)


@pytest.mark.parametrize("shape", ["mask", "polygon"])
def test_mask_lod_is_the_finite_difference_jacobian(shape):
    """lod = max(0, log2 sigma_max(dq/dp)), central differences, one-sided at the border."""
    lens = dataclasses.replace(magnifiers(4.0)[shape], transition=3.0)
    q = lens.source_map(PERSP, SIZE)
    a, b = np.gradient(q[..., 0], axis=1), np.gradient(q[..., 0], axis=0)
    c, d = np.gradient(q[..., 1], axis=1), np.gradient(q[..., 1], axis=0)
    sigma = np.linalg.svd(np.stack([a, b, c, d], -1).reshape(-1, 2, 2), compute_uv=False)[:, 0]
    expected = np.maximum(0, np.log2(sigma))
    lod = lens.rays(PERSP, SIZE).lod
    np.testing.assert_allclose(lod, expected, rtol=0, atol=1e-12)
    assert lod.max() > 1


def test_sampling_lod_is_the_radial_stretch():
    lens = SamplingRateLens(CENTER, 20, rate="linear", factor=3.0)
    lod = lens.rays(PERSP, SIZE).lod
    # near the rim x ~ 1: f = 1, drho/dr = F(1) / f = 2 > s ~ 1
    k = 24 * W + 32 + 19  # r = 19, x = rho / R close to 1
    x = lens.source_radius(19.0) / 20
    assert lod[k] == pytest.approx(math.log2(2.0 / (1 + 2 * (1 - x))), rel=1e-9)
    assert lod[CENTER_INDEX] == 0


# -- shapes ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("shape, density", [((48, 64), 0.01), ((48, 64), 0.3), ((1, 40), 0.1), ((37, 1), 0.1),
                                            ((100, 7), 0.002), ((5, 5), 1.0)])
def test_distance_transform_matches_scipy(shape, density):
    ndimage = pytest.importorskip("scipy.ndimage")
    rng = np.random.default_rng(int(density * 1000) + shape[0])
    for _ in range(5):
        mask = rng.random(shape) < density
        mask.flat[rng.integers(mask.size)] = True
        np.testing.assert_allclose(distance_transform(mask), ndimage.distance_transform_edt(~mask),
                                   rtol=0, atol=1e-12)


def test_distance_transform_of_an_empty_mask_is_infinite():
    assert np.all(np.isinf(distance_transform(np.zeros((3, 4), bool))))
    with pytest.raises(TypeError, match="mask must be a 2-D bool array"):
        distance_transform(np.zeros((3, 4)))


def test_polygon_rasterises_pixel_centres_even_odd():
    rect = Magnifier(shape=[(10, 5), (20, 5), (20, 9), (10, 9)], transition=2, factor=2.0)
    s, center = rect.scale(PERSP, SIZE)
    expected = np.zeros((H, W), bool)
    expected[5:9, 10:20] = True
    np.testing.assert_array_equal(s == 0.5, expected)
    assert center == (15.0, 7.0)
    # a pentagram: even-odd leaves its centre pentagon out
    t = np.pi / 2 + np.arange(5) * 4 * np.pi / 5
    star = np.stack([32 + 20 * np.cos(t), 24 - 20 * np.sin(t)], 1)
    s, _ = Magnifier(shape=star, center=(5.5, 5.5), factor=2.0).scale(PERSP, SIZE)
    assert s[24, 32] != 0.5 and s[24 - 14, 32] == 0.5


def test_mask_band_follows_the_distance_to_the_shape():
    lens = Magnifier(shape=MASK, transition=5, factor=3.0)
    s, center = lens.scale(PERSP, SIZE)
    d = distance_transform(MASK)
    expected = np.where(d >= 5, 1.0, 1 / 3 + (1 - 1 / 3) * d / 5)
    np.testing.assert_allclose(s, expected, rtol=0, atol=1e-15)
    j, i = np.nonzero(MASK)
    assert center == pytest.approx((i.mean() + 0.5, j.mean() + 0.5))


# -- feature lens ---------------------------------------------------------------------------------
def test_feature_box_projects_to_the_hand_computed_rectangle():
    """Voxels i 3..5, j 1..2, k 2..3 with origin (-4, -4, -4), spacing 1: x in [-1.5, 1.5],
    y in [-3.5, -1.5]. A parallel camera looking down -z, 8 units high on 32 pixels: 4
    pixels per unit, col = 4 (x + 4), row = 16 - 4 y: cols [10, 22], rows [22, 30]; the
    pixel centres inside are cols 10..21, rows 22..29."""
    feature = np.zeros((6, 5, 8), bool)
    feature[2:4, 1:3, 3:6] = True
    cam = Camera((0, 0, 20), (0, 0, 0), (0, 1, 0), parallel_projection=True, parallel_scale=4)
    lens = FeatureLens(feature, origin=(-4, -4, -4), spacing=(1, 1, 1), factor=2.0)
    expected = np.zeros((32, 32), bool)
    expected[22:30, 10:22] = True
    np.testing.assert_array_equal(lens.projected_mask(cam, 32), expected)
    s, center = lens.scale(cam, 32)
    np.testing.assert_array_equal(s == 0.5, expected)
    assert center == (16.0, 26.0)


def test_feature_projection_is_the_set_of_pixel_rays_that_hit_a_voxel():
    """In perspective: a pixel centre lies in a cube's projection iff its camera ray hits the cube."""
    feature = np.zeros((3, 3, 3), bool)
    feature[0, :, 0] = feature[:, 0, 2] = feature[2, 2, :] = True
    origin, spacing = np.array([-1.0, -0.8, -1.2]), np.array([0.7, 0.9, 0.8])
    lens = FeatureLens(feature, origin=origin, spacing=spacing)
    rays = PERSP.rays(SIZE)
    hit = np.zeros(W * H, bool)
    for k, j, i in np.argwhere(feature):
        lo = origin + (np.array([i, j, k]) - 0.5) * spacing
        hi = lo + spacing
        with np.errstate(divide="ignore", invalid="ignore"):
            t0, t1 = (lo - rays.origins) / rays.directions, (hi - rays.origins) / rays.directions
        near, far = np.minimum(t0, t1).max(1), np.maximum(t0, t1).min(1)
        hit |= (near <= far) & (far > 0)
    assert hit.sum() > 50
    np.testing.assert_array_equal(lens.projected_mask(PERSP, SIZE), hit.reshape(H, W))


def test_feature_from_labels_and_range():
    values = np.zeros((4, 5, 6))
    values[1, 2, 3] = 7
    values[2, 2, 3] = 9
    vol = volume_from_array(values, spacing=(0.5, 0.5, 0.5), origin=(-1, -1, -1))
    by_label = FeatureLens.from_labels(vol, 7)
    assert by_label.feature.sum() == 1 and by_label.origin == (-1, -1, -1) and by_label.spacing == (0.5,) * 3
    assert FeatureLens.from_labels(values.astype(int), [7, 9], origin=(1, 2, 3)).feature.sum() == 2
    by_range = FeatureLens.from_range(vol, 8, 10, factor=3.0)
    assert by_range.feature[2, 2, 3] and by_range.feature.sum() == 1 and by_range.factor == 3.0
    with pytest.raises(ValueError, match="no voxel has label 5"):
        FeatureLens.from_labels(vol, 5)
    with pytest.raises(ValueError, match="lo must be <= hi"):
        FeatureLens.from_range(vol, 2, 1)
    with pytest.raises(ValueError, match="origin and spacing come from the volume"):
        FeatureLens.from_range(vol, 0, 1, origin=(0, 0, 0))


def test_feature_behind_or_around_the_eye():
    cam = Camera((0, 0, 0), (0, 0, -1), (0, 1, 0))
    behind = FeatureLens(np.ones((1, 1, 1), bool), origin=(0, 0, 5))
    with pytest.raises(ValueError, match="the feature projects outside the 64x48 image"):
        behind.rays(cam, SIZE)
    around = FeatureLens(np.ones((1, 1, 1), bool), origin=(0, 0, 0))  # the eye is inside the voxel
    assert around.projected_mask(cam, SIZE).all()


# -- fisheye --------------------------------------------------------------------------------------
def _angle(d, fwd):
    return np.arctan2(np.linalg.norm(np.cross(d, fwd), axis=-1), d @ fwd)


@CAMERAS
@pytest.mark.parametrize("fov", [30.0, 180.0, 270.0, 360.0])
def test_fisheye_angles(cam, fov):
    lens = Fisheye(fov)
    right, up, fwd = cam.basis()
    odd = (65, 49)
    rays = lens.rays(cam, odd)
    assert np.allclose(rays.directions[24 * 65 + 32], fwd, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(rays.directions, axis=1), 1, rtol=0, atol=1e-12)
    assert np.all(rays.origins == np.asarray(cam.position))
    half = math.radians(fov) / 2
    for corner in [(0, 0), (65, 0), (0, 49), (65, 49)]:
        assert _angle(lens.direction_at(cam, odd, corner), fwd) == pytest.approx(half, abs=1e-12)
    r_corner = math.hypot(32.5, 24.5)
    r_centre = math.hypot(32.0, 24.0)  # the corner pixel's centre
    assert _angle(rays.directions[0], fwd) == pytest.approx(r_centre / r_corner * half, abs=1e-12)
    # azimuth: right of the centre looks right, above the centre looks up
    d_right = lens.direction_at(cam, odd, (50.0, 24.5))
    d_up = lens.direction_at(cam, odd, (32.5, 10.0))
    assert d_right @ right > 0 and abs(d_right @ up) < 1e-15
    assert d_up @ up > 0 and abs(d_up @ right) < 1e-15
    many = lens.direction_at(cam, odd, np.array([[0.0, 0.0], [32.5, 24.5]]))
    assert many.shape == (2, 3)


def test_fisheye_360_corners_look_backwards():
    _, _, fwd = PERSP.basis()
    for corner in [(0, 0), (64, 48), (64, 0)]:
        np.testing.assert_allclose(Fisheye(360).direction_at(PERSP, SIZE, corner), -fwd, rtol=0, atol=1e-12)


def test_fisheye_lod():
    cam = Camera((0, 0, 5), (0, 0, 0), (0, 1, 0), view_angle=30)
    lod = Fisheye(180).rays(cam, SIZE).lod
    ratio = (math.pi / 2 / math.hypot(32, 24)) / (math.radians(30) / 48)
    np.testing.assert_allclose(lod, math.log2(ratio), rtol=1e-12)


# -- objects --------------------------------------------------------------------------------------
def test_repr_eq_hash_replace():
    lens = Magnifier(CENTER, 12, factor=3.0)
    assert repr(lens) == ("Magnifier(center=(32.5, 24.5), radius=12.0, transition=4.0, factor=3.0, shape='circle', "
                          "focal_distance=None, antialias=True)")
    assert lens == Magnifier(CENTER, 12.0, 4.0, 3.0) and hash(lens) == hash(Magnifier(CENTER, 12.0, 4.0, 3.0))
    assert dataclasses.replace(lens, factor=2.0).factor == 2.0
    masked = Magnifier(shape=MASK)
    assert "shape=<bool array (48, 64)" in repr(masked) and masked == Magnifier(shape=MASK.copy())
    assert "<polygon of 4 vertices>" in repr(Magnifier(shape=POLYGON))
    assert repr(Fisheye(90)) == "Fisheye(fov_degrees=90.0, antialias=True)"
    assert repr(SamplingRateLens(CENTER, 10)).startswith("SamplingRateLens(center=(32.5, 24.5), radius=10.0, "
                                                         "rate='cubic', factor=4.0, table_size=4096")
    assert "feature=<bool array (1, 1, 1), 1 True>" in repr(FeatureLens(np.ones((1, 1, 1), bool)))
    with pytest.raises(dataclasses.FrozenInstanceError):
        lens.factor = 2.0
    for obj in (lens, masked, Fisheye(), SamplingRateLens(CENTER, 3), FeatureLens(np.ones((1, 1, 1), bool))):
        assert isinstance(obj, Lens)


# -- bad input ------------------------------------------------------------------------------------
@pytest.mark.parametrize("make, error, message", [
    (lambda: Magnifier(CENTER, 0), ValueError, r"radius must be > 0; got 0"),
    (lambda: Magnifier(CENTER, 10, 10), ValueError, r"transition must be < radius; got transition=10.0, radius=10.0"),
    (lambda: Magnifier(CENTER, 10, 11), ValueError, r"transition must be < radius"),
    (lambda: Magnifier(CENTER, 10, -1), ValueError, r"transition must be >= 0; got -1"),
    (lambda: Magnifier(CENTER, 10, factor=0), ValueError, r"factor must be > 0; got 0"),
    (lambda: Magnifier(CENTER, 10, factor=-2.0), ValueError, r"factor must be > 0; got -2.0"),
    (lambda: Magnifier(CENTER, 10, factor=float("inf")), ValueError, r"factor must be finite; got inf"),
    (lambda: Magnifier(CENTER, 10, factor=float("nan")), ValueError, r"factor must be finite; got nan"),
    (lambda: Magnifier(CENTER, 12, 4, 0.7), ValueError, r"factor 0.7 folds the transition band"),
    (lambda: Magnifier(CENTER, 10, shape="hexagon"), ValueError,
     r"shape must be one of \['circle', 'square'\], a bool mask \(height, width\) or a \(k, 2\) polygon; "
     r"got 'hexagon'"),
    (lambda: Magnifier(shape=np.zeros((48, 64), bool)), ValueError, r"the mask is empty"),
    (lambda: Magnifier(shape=[(0, 0), (5, 5)]), ValueError, r"a polygon must have at least 3 vertices; got 2"),
    (lambda: Magnifier(shape=np.zeros((4, 3))), ValueError, r"a \(k, 2\) polygon of \(col, row\) vertices"),
    (lambda: Magnifier(shape=MASK, radius=4), ValueError, r"radius must be None for a mask or polygon shape"),
    (lambda: Magnifier(shape=MASK, transition=0), ValueError, r"transition must be > 0; got 0"),
    (lambda: Magnifier(None, 10), ValueError, r"center is required for shape 'circle'"),
    (lambda: Magnifier(CENTER), ValueError, r"radius is required for shape 'circle'"),
    (lambda: Magnifier(CENTER, 10, factor=2, focal_distance=1), ValueError, r"give factor or focal_distance, not both"),
    (lambda: Magnifier(CENTER, 10, focal_distance=-1), ValueError, r"focal_distance must be >= 0; got -1"),
    (lambda: Magnifier((1, 2, 3), 10), ValueError, r"center must have 2 entries"),
    (lambda: Magnifier(CENTER, 10, antialias=1), TypeError, r"antialias must be a bool; got 1"),
    (lambda: SamplingRateLens(CENTER, 10, rate=lambda x: np.where(x > 0.5, np.nan, 1.0)), ValueError,
     r"rate\(x\) must return finite values on \[0, 1\]; got f\(0.500244\) = nan"),
    (lambda: SamplingRateLens(CENTER, 10, rate=lambda x: 1 - 2 * x), ValueError,
     r"rate\(x\) must return values > 0 on \[0, 1\]; got f\(0.5\) = 0.0"),
    (lambda: SamplingRateLens(CENTER, 10, rate=lambda x: np.ones(3)), ValueError,
     r"rate\(x\) must return one value per x"),
    (lambda: SamplingRateLens(CENTER, 10, rate="sine"), ValueError,
     r"rate must be one of \['linear', 'quadratic', 'cubic'\]; got 'sine'"),
    (lambda: SamplingRateLens(CENTER, 10, rate=3), TypeError, r"rate must be one of .* or a callable f\(x\); got 3"),
    (lambda: SamplingRateLens(CENTER, 10, rate=np.exp, factor=2), ValueError, r"factor applies to the named rates"),
    (lambda: SamplingRateLens(CENTER, 10, rate=np.exp, focal_distance=2), ValueError,
     r"focal_distance needs a named rate"),
    (lambda: SamplingRateLens(CENTER, 10, table_size=8), ValueError, r"table_size must be >= 16; got 8"),
    (lambda: SamplingRateLens(CENTER, 10, table_size=2**20 + 1), ValueError, r"table_size must be <= 1048576"),
    (lambda: SamplingRateLens(CENTER, -1), ValueError, r"radius must be > 0; got -1"),
    (lambda: Fisheye(0), ValueError, r"fov_degrees must be > 0; got 0"),
    (lambda: Fisheye(361), ValueError, r"fov_degrees must be <= 360; got 361"),
    (lambda: FeatureLens(np.zeros((2, 2, 2), bool)), ValueError, r"the feature is empty: no True voxel"),
    (lambda: FeatureLens(np.ones((2, 2, 2))), TypeError, r"feature must be a 3-D bool array \(z, y, x\); got float64"),
    (lambda: FeatureLens(np.ones((2, 2, 2), bool), spacing=(1, 0, 1)), ValueError, r"spacing must be > 0"),
])
def test_bad_construction(make, error, message):
    with pytest.raises(error, match=message):
        make()


@pytest.mark.parametrize("lens, camera, message", [
    (Magnifier((200, 10), 12), PERSP, r"the lens at center \(200, 10\) with radius 12 lies entirely outside the "
                                      r"64x48 image"),
    (Magnifier((-12, 10), 12, shape="square"), PERSP, r"lies entirely outside the 64x48 image"),
    (SamplingRateLens((10, 60.5), 12), PERSP, r"lies entirely outside the 64x48 image"),
    (Magnifier(shape=np.ones((40, 64), bool)), PERSP,
     r"mask shape \(40, 64\) does not match the image: size \(64, 48\) needs a mask of shape \(height, width\) "
     r"= \(48, 64\)"),
    (Magnifier(shape=[(100, 100), (120, 100), (110, 120)]), PERSP, r"the polygon covers no pixel centre"),
    (Magnifier(CENTER, 10, focal_distance=50.0), PERSP, r"focal_distance must be < D = 12\.\d+, the distance from "
                                                         r"the camera position .*; got focal_distance=50\.0"),
    (Magnifier(CENTER, 10, focal_distance=1.0), PARA, r"focal_distance needs a perspective camera"),
    (SamplingRateLens(CENTER, 10, focal_distance=9.5), PERSP,
     r"asks for a centre magnification 4\.35\d+; the cubic rate reaches only magnifications < 4"),
    (FeatureLens(np.ones((1, 1, 1), bool), origin=(300, 0, 0)), PERSP, r"the feature projects outside"),
])
def test_bad_rendering(lens, camera, message):
    with pytest.raises(ValueError, match=message):
        lens.rays(camera, SIZE)


def test_bad_arguments_to_methods():
    lens = Magnifier(CENTER, 10)
    with pytest.raises(ValueError, match="a parallel camera has no focal point"):
        lens.focal_point(PARA, SIZE)
    with pytest.raises(TypeError, match="camera must be a pv_hdrvol.Camera; got str"):
        lens.rays("camera", SIZE)
    with pytest.raises(TypeError, match="size must be an int or a"):
        lens.rays(PERSP, "big")
    with pytest.raises(ValueError, match=r"position must be \(col, row\)"):
        Fisheye().direction_at(PERSP, SIZE, (1, 2, 3))
