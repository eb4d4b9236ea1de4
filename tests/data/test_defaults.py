"""The default transfer function (issue 18, part 3): one default for every front end,
transparent over the background, deterministic, with the opacity of the stated rule."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.data.transfer import DEFAULT_TRANSMITTANCE, auto_transfer_function, scale_forward
from pv_hdrvol.raycast.grid import as_volume, default_transfer_function

pytestmark = pytest.mark.core


def ball_in_air(n=40, seed=0):
    """A noisy ball (values 100-200) in a background of low values (0-8): 90 % 'air'."""
    rng = np.random.default_rng(seed)
    z, y, x = np.mgrid[0:n, 0:n, 0:n] - (n - 1) / 2
    r = np.sqrt(x * x + y * y + z * z)
    values = rng.uniform(0, 8, (n, n, n))
    inside = r < n / 5
    values[inside] = 100 + 100 * (1 - r[inside] / (n / 5))
    return values, inside


def test_the_background_mode_is_transparent_and_the_structure_is_not():
    values, inside = ball_in_air()
    tf = default_transfer_function(hv.volume_from_array(values))
    assert tf.scale == "linear"
    assert np.all(tf.opacity_at(values[~inside]) == 0.0)  # every background value
    assert np.all(tf.opacity_at(values[inside]) > 0.0)
    assert 8.0 <= tf.vmin < 100.0 and tf.vmax > 180.0  # the 99.9th percentile of the ball


def test_pixels_outside_the_projected_support_stay_transparent():
    values, inside = ball_in_air()
    n = values.shape[0]
    cam = hv.Camera(((n - 1) / 2, (n - 1) / 2, 4.0 * n), ((n - 1) / 2,) * 3, (0, 1, 0), parallel_projection=True,
                    parallel_scale=n / 2)
    img = hv.render(values, None, cam, (40, 40))
    # the support projected along z, dilated by one voxel (a trilinear sample touches
    # the cells around a voxel): no pixel outside it may have any opacity
    support = np.zeros((n, n), bool)
    support[np.any(inside, axis=0)] = True
    grown = support.copy()
    for axis in (0, 1):
        grown |= np.roll(support, 1, axis) | np.roll(support, -1, axis)
    rows, cols = np.nonzero(img.rgba[..., 3] > 0)
    assert rows.size > 150  # the ball (radius 8) covers ~200 pixels
    # pixel (row, col) of a 40x40 view of 40 voxels: voxel (x = col, y = n - 1 - row)
    assert np.all(grown[n - 1 - rows, cols])


def wake_in_free_stream(n=40, seed=1):
    """A 'free stream' (values 0.98-1.02, 80 % of the volume) around a slow wake (0.1-0.9)
    and a fast jet (1.3-1.6): the background is the high mode, not the lowest value."""
    rng = np.random.default_rng(seed)
    z, y, x = np.mgrid[0:n, 0:n, 0:n] - (n - 1) / 2
    values = rng.uniform(0.98, 1.02, (n, n, n))
    wake = (np.abs(y) < n / 8) & (np.abs(z) < n / 8) & (x > 0)
    jet = (np.abs(y) < n / 8) & (np.abs(z) < n / 8) & (x < -n / 4)
    values[wake] = 0.1 + 0.8 * (x[wake] / (n / 2))
    values[jet] = 1.3 + 0.3 * rng.random(np.count_nonzero(jet))
    return values, wake | jet


def test_a_free_stream_mode_high_on_the_axis_is_transparent():
    values, structure = wake_in_free_stream()
    tf = default_transfer_function(hv.volume_from_array(values))
    assert np.all(tf.opacity_at(values[~structure]) == 0.0)  # the whole free stream
    # the wake (past its lowest 0.5 %, where every default's ramp starts) ...
    assert np.all(tf.opacity_at(values[structure & (values > 0.3) & (values < 0.85)]) > 0.0)
    assert np.all(tf.opacity_at(values[structure & (values > 1.3)]) > 0.0)  # ... and the jet
    n = values.shape[0]
    cam = hv.Camera(((n - 1) / 2, (n - 1) / 2, 4.0 * n), ((n - 1) / 2,) * 3, (0, 1, 0), parallel_projection=True,
                    parallel_scale=n / 2)
    alpha = hv.render(values, None, cam, (40, 40)).rgba[..., 3]
    # rows through the free stream only (|y| > n/8 + 1 voxel) stay transparent
    ys = n - 1 - np.arange(n) - (n - 1) / 2
    assert np.all(alpha[np.abs(ys) > n / 8 + 1] == 0.0) and alpha.max() > 0.1


def test_a_mesh_background_is_what_fills_space_not_what_has_most_points():
    """Mesh values are weighted by the volume they stand for: many tiny cells of value 5
    (a refined feature) do not make 5 the background; the big cells' value 1 is."""
    values = np.concatenate([np.full(5000, 1.0), np.linspace(1.0, 5.0, 2000), np.full(20000, 5.0)])
    weights = np.concatenate([np.ones(5000), np.full(2000, 0.1), np.full(20000, 0.001)])
    by_volume = auto_transfer_function(values, 10, weights=weights)
    assert by_volume.opacity_at(1.0) == 0.0 and by_volume.opacity_at(5.0) > 0.0
    by_count = auto_transfer_function(values, 10)
    assert by_count.opacity_at(5.0) == 0.0 and by_count.opacity_at(3.0) > 0.0
    assert by_volume.opacities.max() == pytest.approx(0.99)  # the average ray is mostly empty: the cap
    with pytest.raises(ValueError, match=r"weights must be finite, >= 0 and one per value \(27000\); got shape "
                                         r"\(3,\)"):
        auto_transfer_function(values, 10, weights=[1, 2, 3])


def test_the_densest_columns_keep_the_stated_transmittance():
    """The 95th percentile of the grid columns' optical depth, to first order in the
    opacity, is -ln(0.25)."""
    values, _ = ball_in_air()
    tf = default_transfer_function(hv.volume_from_array(values))
    a = tf.opacities.max()
    shape = np.interp(values, tf.values, tf.opacities) / a
    depths = np.concatenate([shape.sum(axis=k).ravel() for k in range(3)])
    assert math.isclose(a * np.percentile(depths, 95.0), -math.log(DEFAULT_TRANSMITTANCE), rel_tol=1e-9)


def test_a_mesh_average_ray_keeps_the_stated_transmittance():
    values, _ = ball_in_air(n=20)
    tf = auto_transfer_function(values.ravel(), ray_length=50.0)
    sigma = -np.log1p(-np.interp(values.ravel(), tf.values, tf.opacities))
    # the mean is taken over the shape binned in 4,096 bins: to 1e-3
    assert math.isclose(50.0 * sigma.mean(), -math.log(DEFAULT_TRANSMITTANCE), rel_tol=1e-3)


def test_axes_follow_the_decades():
    rng = np.random.default_rng(1)
    density = 10.0 ** rng.uniform(-12, 0, 5000)
    assert auto_transfer_function(density, 10).scale == "log"
    # zeros and a few stray tiny values do not make CT-like data logarithmic
    ct = np.concatenate([np.zeros(3000), rng.uniform(50, 255, 5000), [1e-3] * 10])
    assert auto_transfer_function(ct, 10).scale == "linear"
    signed = np.concatenate([density, -density])
    assert auto_transfer_function(signed, 10).scale == "symlog"
    # on a log axis the opacity is proportional to the value, 0 at the floor
    tf = auto_transfer_function(np.concatenate([np.full(4000, 1e-12), density]), 10)
    assert tf.scale == "log" and tf.opacities[0] == 0.0
    ratio = tf.opacities[1:] / (tf.values[1:] / tf.vmax)
    np.testing.assert_allclose(ratio, tf.opacities[-1], rtol=1e-9)


def test_overrides_replace_single_choices():
    values, _ = ball_in_air()
    vol = hv.volume_from_array(values)
    auto = default_transfer_function(vol)
    tf = default_transfer_function(vol, clim=(None, 150.0), cmap="gray", opacity=(0.0, 0.5))
    assert (tf.vmin, tf.vmax, tf.opacities[-1]) == (auto.vmin, 150.0, 0.5)
    np.testing.assert_array_equal(tf.colors[:, 0], tf.colors[:, 1])
    with pytest.raises(ValueError, match=r"clim must be finite with high > low; got \(5.0, 1.0\)"):
        default_transfer_function(vol, clim=(5.0, 1.0))
    # a binary field: all of the structure at one value
    binary = default_transfer_function(hv.volume_from_array((values > 50).astype(np.float32)))
    assert binary.opacity_at(0.0) == 0.0 and binary.opacity_at(1.0) > 0.0
    with pytest.raises(ValueError, match=r"scale='log' needs positive data; the values span \[-1, 0\]"):
        auto_transfer_function(np.linspace(-1.0, 0.0, 11), 10, scale="log")


def test_defaults_are_deterministic_and_shared_by_the_front_ends():
    pv = pytest.importorskip("pyvista")
    values, _ = ball_in_air(n=24)
    grid = pv.ImageData(dimensions=(24, 24, 24))
    grid["v"] = values.ravel()  # (z, y, x) C order is x fastest: VTK's point order
    a = default_transfer_function(as_volume(grid))
    b = default_transfer_function(hv.volume_from_array(values.copy()))
    for name in ("values", "colors", "opacities"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    cam = hv.Camera.fit(grid.bounds, "iso")
    first = hv.render(grid, None, cam, (20, 20))
    np.testing.assert_array_equal(hv.render(values, None, cam, (20, 20)).rgba, first.rgba)
    np.testing.assert_array_equal(grid.hdrvol.render(camera=cam, size=(20, 20)).rgba, first.rgba)
    np.testing.assert_array_equal(hv.render(grid.copy(), None, cam, (20, 20)).rgba, first.rgba)


def test_log_default_of_a_density_spans_its_decades():
    """Hydrogen-like data: a floor of 1e-6 holding 5 % of the voxels, then six decades:
    log axis, opacity 0 on the floor, the maximum at the top."""
    n = 32
    z, y, x = np.mgrid[0:n, 0:n, 0:n] - (n - 1) / 2
    density = np.maximum(np.exp(-0.05 * (x * x + y * y + z * z)), 1e-6)
    tf = default_transfer_function(hv.volume_from_array(density))
    assert tf.scale == "log"
    assert tf.opacity_at(1e-6) == 0.0 and tf.vmin > 1e-6
    assert scale_forward([tf.vmax], "log")[0] > -0.1  # the top decade is in the range


# -- issue 31: signed fields, and the classes of CT-like data ---------------------------------
def signed_blobs(n=32, span=8):
    """A positive blob (x < centre) and a negative one (x > centre), each spanning
    ``span`` decades from its peak (a shock's compression and rarefaction)."""
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float64)
    r2 = lambda cx: ((x - cx) ** 2 + (y - n / 2) ** 2 + (z - n / 2) ** 2) / (n / 6) ** 2  # noqa: E731
    return 9e10 * np.exp(-span * np.log(10) * r2(n / 4) / 4) - 2.4e10 * np.exp(-span * np.log(10) * r2(3 * n / 4) / 4)


def test_a_signed_field_shows_both_signs_with_zero_transparent():
    """Both signs: symmetric range, diverging colours (blue below zero, red above),
    opacity in proportion to the magnitude (0 at zero, equal at +-v), and a render shows
    the negative blob as well as the positive one (the old default started at the
    positive 5th percentile: the negative side was transparent)."""
    values = signed_blobs()
    volume = hv.volume_from_array(values)
    tf = default_transfer_function(volume)
    assert tf.scale == "symlog"
    assert tf.vmin == -tf.vmax and tf.vmax == pytest.approx(np.percentile(np.abs(values), 99.9))
    assert tf.opacity_at(0.0) == 0.0
    probe = np.array([1e4, 1e7, 1e9, 1e10])
    probe = probe[probe < tf.vmax]
    np.testing.assert_allclose(tf.opacity_at(-probe), tf.opacity_at(probe), rtol=1e-12)
    assert np.all(np.diff(tf.opacity_at(probe)) > 0)  # rising with the magnitude
    # in proportion to it at the control points (the ramp interpolates on the axis between them)
    nonzero = tf.values != 0
    ratio = tf.opacities[nonzero] / (np.abs(tf.values[nonzero]) / tf.vmax)
    np.testing.assert_allclose(ratio, tf.opacities.max(), rtol=1e-9)
    blue, red = tf.color_at(-1e9), tf.color_at(1e9)
    assert blue[2] > blue[0] and red[0] > red[2]
    img = hv.render(volume, tf, hv.Camera.fit(volume.bounds, "xy"), (64, 64), precision="float64")
    alpha = img.rgba[..., 3]
    left, right = alpha[:, :32].max(), alpha[:, 32:].max()  # x grows to the right in the xy view
    assert left > 0.3 and right > 0.3, (left, right)


def test_a_signed_field_of_few_decades_is_linear_and_noise_is_not_a_sign():
    rng = np.random.default_rng(2)
    velocity = rng.normal(0.0, 3.0, (20, 20, 20))
    tf = default_transfer_function(hv.volume_from_array(velocity))
    assert tf.scale == "linear" and tf.vmin == -tf.vmax and tf.opacity_at(0.0) == 0.0
    density = rng.uniform(1.0, 2.0, 4000)
    density[:20] = -1e-6  # 0.5 % of round-off below zero: not a signed field
    tf = auto_transfer_function(density, 10)
    assert tf.vmin > 0 and tf.opacity_at(tf.vmin) == 0.0
    # integer data with both signs are an offset scale (Hounsfield units), not a signed field
    hu = np.concatenate([np.full(3000, -1000.0), rng.integers(-100, 100, 3000), rng.integers(300, 1500, 1000)])
    tf = auto_transfer_function(hu.astype(float), 10, integer=True)
    assert tf.vmin > -1000 and tf.vmin != -tf.vmax


def ct_phantom(n=48, seed=3):
    """Air (0-10), a head of soft tissue (55-65) filling a sphere, a skull shell of
    bone (140-200) around it: the CT head's classes."""
    rng = np.random.default_rng(seed)
    z, y, x = np.mgrid[0:n, 0:n, 0:n] - (n - 1) / 2
    r = np.sqrt(x * x + y * y + z * z) / (n / 2)
    values = rng.integers(0, 11, (n, n, n)).astype(np.float64)
    soft, bone = r < 0.8, (r >= 0.8) & (r < 0.9)
    values[soft] = rng.integers(55, 66, int(soft.sum()))
    values[bone] = rng.integers(140, 201, int(bone.sum()))
    return values.astype(np.uint8), soft, bone


def test_ct_classes_the_soft_one_a_dim_veil_the_dense_ones_opaque():
    """Integer data: the most voluminous class above the air is a veil whose own
    columns keep a transmittance of 0.8 (95th percentile), dimmed to 0.05 of the
    colormap's first colour; the bone above it takes the opacity, and the whole still
    keeps the 0.25 rule."""
    from pv_hdrvol.data.transfer import CONTEXT_TRANSMITTANCE, VEIL_BRIGHTNESS

    values, soft, bone = ct_phantom()
    volume = hv.volume_from_array(values)
    assert volume.integer
    tf = default_transfer_function(volume)
    op = lambda v: np.interp(v, tf.values, tf.opacities)  # noqa: E731
    kink = int(np.argmax(np.abs(np.diff(tf.opacities, 2)))) + 1  # where the veil ends and the bone's ramp starts
    c, end = tf.opacities[kink], tf.values[kink]
    assert 65.0 <= end < 140.0  # past the tissue's values, below the bone's
    assert op(float(np.median(values[bone]))) > 10 * c  # the bone far above the tissue
    veil = np.minimum(op(values.astype(float)), c)  # the veil's part of the opacity
    veil_depths = np.concatenate([veil.sum(axis=k).ravel() for k in range(3)])
    assert math.isclose(np.percentile(veil_depths, 95.0), -math.log(CONTEXT_TRANSMITTANCE), rel_tol=0.05)
    whole = op(values.astype(float))
    depths = np.concatenate([whole.sum(axis=k).ravel() for k in range(3)])
    assert math.isclose(np.percentile(depths, 95.0), -math.log(DEFAULT_TRANSMITTANCE), rel_tol=0.05)
    dim = tf.color_at(float(np.median(values[soft])))
    first_dense = tf.color_at(float(tf.vmax))  # brightest; the first dense colour is darker still
    assert dim.max() <= VEIL_BRIGHTNESS * first_dense.max() + 1e-12
    # the same values as floats (not integer samples): no classes, the plain ramp
    plain = auto_transfer_function(values.astype(np.float64), 48.0, spacing=(1.0, 1.0, 1.0))
    assert np.interp(60.0, plain.values, plain.opacities) > 3 * c
