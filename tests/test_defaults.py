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
