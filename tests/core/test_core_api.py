"""Transfer functions, cameras, options and HDRImage: definitions, round trips, bad input."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pv_hdrvol as hv
from pv_hdrvol.image.display import srgb_decode, srgb_encode

pytestmark = pytest.mark.core


# -- transfer functions ------------------------------------------------------------------
def test_log_ramp_interpolates_on_the_log_axis():
    tf = hv.TransferFunction.ramp(1e-3, 1e4, scale="log", cmap="gray", opacity=(0.0, 1.0))
    np.testing.assert_allclose(tf.opacity_at([1e-3, 1e-1, 10.0, 1e4, 1e9, 0.0, -1.0]),
                               [0, 2 / 7, 4 / 7, 1, 1, 0, 0], atol=1e-12)


def test_symlog_axis_is_odd_and_linear_near_zero():
    tf = hv.TransferFunction.ramp(-1e6, 1e6, scale="symlog", cmap="gray", opacity=(0.0, 1.0), linthresh=1.0)
    a = tf.opacity_at([-1e6, 0.0, 1e6, 999.0, -999.0])
    np.testing.assert_allclose(a[:3], [0.0, 0.5, 1.0], atol=1e-12)
    assert a[3] - 0.5 == pytest.approx(0.5 - a[4])
    assert a[3] == pytest.approx(0.5 + 0.5 * 3 / math.log10(1 + 1e6), abs=1e-12)  # log10(1 + 999) = 3


def test_hsv_interpolation_goes_the_short_way_round():
    tf = hv.TransferFunction([0, 1], [[1, 0, 0], [0, 0, 1]], [1, 1], color_space="hsv")
    np.testing.assert_allclose(tf.color_at([0.5])[0], [1.0, 0.0, 1.0], atol=1e-12)  # magenta, not green
    rgb = hv.TransferFunction([0, 1], [[1, 0, 0], [0, 0, 1]], [1, 1])
    np.testing.assert_allclose(rgb.color_at([0.5])[0], [0.5, 0.0, 0.5])


@pytest.mark.parametrize("size", [256, 65536, 2**20])
def test_table_extinction_is_opacity_corrected(size):
    tf = hv.TransferFunction([0.0, 1.0], [[1, 1, 1]] * 2, [0.0, 0.5], table_size=size)
    rgb, sigma = tf.table(np.float64, global_alpha=0.5, unit_distance=2.0)
    assert rgb.shape == (size, 3) and sigma.shape == (size,)
    assert sigma[-1] == pytest.approx(-math.log1p(-0.25) / 2.0, rel=1e-15)
    assert np.all(np.diff(sigma) >= 0)


def test_opaque_entries_stay_finite():
    tf = hv.TransferFunction([0.0, 1.0], [[1, 1, 1]] * 2, [1.0, 1.0])
    assert np.isfinite(tf.table()[1]).all()


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0, 1), min_size=2, max_size=6))
def test_table_matches_control_points(opacities):
    n = len(opacities)
    values = np.linspace(-3.0, 5.0, n)
    tf = hv.TransferFunction(values, np.tile([0.2, 0.4, 0.6], (n, 1)), opacities, table_size=(n - 1) * 256 + 1)
    _, sigma = tf.table(np.float64, 1.0, 1.0)
    alpha = -np.expm1(-sigma)
    np.testing.assert_allclose(alpha[::256], np.minimum(opacities, 1 - 2.0**-52), atol=1e-12)


# -- the table size a function needs ---------------------------------------------------------
@pytest.mark.parametrize("size", [256, 1024, 4096])
def test_table_error_of_a_kink_is_the_analytic_interpolation_error(size):
    """Grey rising to a kink at k and flat after, opacity constant a: between the two
    entries around the kink (fraction theta of the way), linear interpolation misses
    the colour by slope * h * theta (1 - theta); the emitted colour by a times that."""
    k, a = 0.3001, 0.5
    tf = hv.TransferFunction([0.0, k, 1.0], [[0, 0, 0], [1, 1, 1], [1, 1, 1]], [a, a, a])
    h = 1.0 / (size - 1)
    theta = k / h - math.floor(k / h)
    assert tf.table_error(size) == pytest.approx(a * (1 / k) * h * theta * (1 - theta), rel=1e-9)


def test_required_table_size_is_the_smallest_power_of_two_within_tolerance():
    tf = hv.TransferFunction([0.0, 0.3001, 1.0], [[0, 0, 0], [1, 1, 1], [1, 1, 1]], [0.5] * 3)
    errors = {n: tf.table_error(n) for n in (256 * 2**k for k in range(9))}
    for tol in (1e-3, 1e-4, 1e-5):
        expected = min(n for n, e in errors.items() if e <= tol)
        assert tf.required_table_size(tol) == expected
    assert tf.table_size == tf.required_table_size(1e-4) and tf.table_size_auto
    assert tf.table_error(tf.table_size) <= 1e-4 < tf.table_error(tf.table_size // 2)


def test_control_points_on_the_256_values_of_8bit_data_need_256_entries():
    """The HDR VolVis rule: a table whose entries are the 256 values is exact for a
    function linear between them; the same function shifted off them is not. (With
    opacity varying between neighbours, the extinction's curvature adds up to
    (a_i+1 - a_i)^2 / 8 halfway; constant here.)"""
    rng = np.random.default_rng(5)
    values = np.arange(256.0)
    colors, opacities = rng.random((256, 3)), np.full(256, 0.3)
    on = hv.TransferFunction(values, colors, opacities)
    assert on.table_error(256) < 1e-12 and on.table_size == 256
    halves = np.r_[0.0, np.arange(0.5, 255.0), 255.0]  # the same range, control points between the values
    off = hv.TransferFunction(halves, rng.random((257, 3)), np.full(257, 0.3))
    assert off.table_error(256) > 1e-2 and off.table_size > 256


def test_a_step_gets_the_largest_default_table_and_a_given_size_is_kept():
    step = hv.TransferFunction([0.0, 0.5, 0.5 + 1e-9, 1.0], [[1, 1, 1]] * 4, [0.0, 0.0, 0.5, 0.5])
    assert step.table_size == 65536 and step.table_error(65536) > 1e-4
    # opacity 1: the extinction jumps to 36 per unit; short segments see the difference
    opaque = hv.TransferFunction([0.0, 1.0], [[1, 1, 1]] * 2, [0.0, 1.0])
    assert opaque.table_size == 65536 and opaque.table_error(65536) > 0.1
    capped = hv.TransferFunction([0.0, 1.0], [[1, 1, 1]] * 2, [0.0, 0.99])
    assert capped.table_size < 65536
    fixed = hv.TransferFunction([0.0, 1.0], [[1, 1, 1]] * 2, [0.0, 0.5], table_size=1024)
    assert fixed.table_size == 1024 and not fixed.table_size_auto
    assert fixed.to_dict()["table_size"] == 1024


def test_the_chosen_size_is_kept_in_settings_and_renders_the_same():
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="magma", opacity=(0.0, 0.8))
    back = hv.TransferFunction.from_dict(tf.to_dict())
    assert back.table_size == tf.table_size and not back.table_size_auto
    vol = np.linspace(0.0, 1.0, 6 * 7 * 8).reshape(6, 7, 8)
    a = hv.render(vol, tf, "iso", (16, 16), progress_bar=False)
    b = hv.render(vol, back, "iso", (16, 16), progress_bar=False)
    assert np.array_equal(a.rgba, b.rgba)


def test_a_default_table_renders_within_its_tolerance_of_a_fine_one():
    """A demanding function (13 control points on a 6-decade log axis, the frontier's
    hydrogen function): the default table's render stays within 1e-5 of a 2^20-entry one."""
    values = np.logspace(-6.0, 0.0, 13)
    opacity = 0.5 * values
    opacity[0] = 0.0
    colors = hv.TransferFunction.ramp(1e-6, 1.0, scale="log", cmap="magma").color_at(values)
    tf = hv.TransferFunction(values, colors, opacity, scale="log")
    fine = hv.TransferFunction(values, colors, opacity, scale="log", table_size=2**20)
    assert 256 < tf.table_size < 65536
    vol = hv.datasets.hydrogen_orbital_array(size=24)[0]
    vol = vol / vol.max()
    a = hv.render(vol, tf, "iso", (24, 24), precision="float64", progress_bar=False).rgba
    b = hv.render(vol, fine, "iso", (24, 24), precision="float64", progress_bar=False).rgba
    assert np.abs(a - b).max() < 1e-5


@pytest.mark.parametrize("kwargs,exc,msg", [
    (dict(values=[0, 1], colors=[[1, 1, 1]] * 2, opacities=[0, 2]), ValueError, r"opacities must lie in \[0, 1\]"),
    (dict(values=[1, 0], colors=[[1, 1, 1]] * 2, opacities=[0, 1]), ValueError, "strictly increasing"),
    (dict(values=[0], colors=[[1, 1, 1]], opacities=[0]), ValueError, "at least 2 control points; got 1"),
    (dict(values=[0, 1], colors=[[1, 1]] * 2, opacities=[0, 1]), ValueError, r"colors must have shape \(2, 3\)"),
    (dict(values=[0, 1], colors=[[1, 1, 1]] * 2, opacities=[0, 1], scale="log"), ValueError,
     "scale='log' needs positive control-point values; got vmin=0.0"),
    (dict(values=[0, 1], colors=[[1, 1, 1]] * 2, opacities=[0, 1], scale="ln"), ValueError,
     r"scale must be one of \['linear', 'log', 'symlog'\]; got 'ln'"),
    (dict(values=[0, 1], colors=[[1, 1, 1]] * 2, opacities=[0, 1], table_size=100), ValueError,
     "table_size must be >= 256; got 100"),
    (dict(values=[0, 1], colors=[[1, 1, 1]] * 2, opacities=[0, 1], table_size=2**24 + 1), ValueError,
     "table_size must be <= 16777216"),
])
def test_transfer_function_rejects_bad_input(kwargs, exc, msg):
    with pytest.raises(exc, match=msg):
        hv.TransferFunction(**kwargs)


def test_ramp_rejects_bad_ranges_and_colormaps():
    with pytest.raises(ValueError, match="vmax must be > vmin; got vmin=2.0, vmax=1.0"):
        hv.TransferFunction.ramp(2.0, 1.0)
    with pytest.raises(ValueError, match="scale='log' needs vmin > 0; got vmin=-1.0"):
        hv.TransferFunction.ramp(-1.0, 1.0, scale="log")
    with pytest.raises(ValueError, match="cmap 'no_such_map' is not a matplotlib colormap name"):
        hv.TransferFunction.ramp(0.0, 1.0, cmap="no_such_map")


# -- options and render arguments ---------------------------------------------------------
@pytest.mark.parametrize("kwargs,exc,msg", [
    (dict(step=-1.0), ValueError, "step must be > 0; got -1.0"),
    (dict(step=0), ValueError, "step must be > 0; got 0"),
    (dict(step="1"), TypeError, "step must be a real number; got '1'"),
    (dict(precision="float128"), ValueError,
     r"precision must be one of \['float64', 'float32', 'float16', 'uint8'\]; got 'float128'"),
    (dict(global_alpha=0.0), ValueError, "global_alpha must be > 0; got 0.0"),
    (dict(global_alpha=2.0), ValueError, "global_alpha must be <= 1; got 2.0"),
    (dict(termination=1.0), ValueError, "termination must be < 1; got 1.0"),
    (dict(block_size=6), ValueError, "block_size must be a power of two; got 6"),
    (dict(stepp=1.0), TypeError, r"unknown render option\(s\) \['stepp'\]"),
])
def test_render_rejects_bad_options(kwargs, exc, msg):
    with pytest.raises(exc, match=msg):
        hv.render(np.ones((4, 4, 4)), None, None, (4, 4), **kwargs)


@pytest.mark.parametrize("data,size,exc,msg", [
    (np.ones((4, 4)), (4, 4), ValueError, r"volume values must be a 3-D array; got 2-D with shape \(4, 4\)"),
    (np.ones((0, 4, 4)), (4, 4), ValueError, "volume values must not be empty"),
    (np.ones((4, 4, 4), bool), (4, 4), TypeError, "volume values must have a real numeric dtype; got bool"),
    (np.ones((4, 4, 4)), (0, 4), ValueError, r"size\[0\] \(width\) must be >= 1; got 0"),
    (np.ones((4, 4, 4)), "big", TypeError, "size must be an int or a"),
])
def test_render_rejects_bad_data_and_sizes(data, size, exc, msg):
    with pytest.raises(exc, match=msg):
        hv.render(data, None, None, size)


def test_render_rejects_bad_spacing_and_arguments():
    with pytest.raises(ValueError, match=r"spacing must be > 0 on every axis; got \(1.0, 0.0, 1.0\)"):
        hv.volume_from_array(np.ones((3, 3, 3)), spacing=(1, 0, 1))
    with pytest.raises(TypeError, match="tf must be a TransferFunction; got dict"):
        hv.render(np.ones((3, 3, 3)), {"a": 1})
    with pytest.raises(TypeError, match="camera must be None, a view name such as 'iso' or 'xy', a pv_hdrvol "
                                        "Camera or Rays, a pyvista.Plotter, a pyvista.Camera or a vtkCamera; got int"):
        hv.render(np.ones((3, 3, 3)), None, 3)
    with pytest.raises(ValueError, match=r"view must be one of \['iso', 'xy', 'yx', 'xz', 'zx', 'yz', 'zy'\]; "
                                         r"got 'top'"):
        hv.render(np.ones((3, 3, 3)), None, "top")
    with pytest.raises(ValueError, match="scalars names an array of a dataset"):
        hv.render(np.ones((3, 3, 3)), scalars="density")


def test_progress_callback_and_abort(monkeypatch):
    import pv_hdrvol.raycast.frame as frame

    # a clock that stands still: the chunks do not depend on how fast this machine is
    monkeypatch.setattr(frame, "_clock", lambda: 0.0)
    seen = []
    with pytest.warns(hv.EmptyRenderWarning):  # constant data, default transfer function
        hv.render(np.ones((8, 8, 8)), None, None, (16, 64), progress=seen.append)
    assert seen[-1] == 1.0 and seen == sorted(seen) and len(seen) == 2
    with pytest.raises(RuntimeError, match="render aborted"), pytest.warns(hv.EmptyRenderWarning):
        hv.render(np.ones((8, 8, 8)), None, None, (16, 64), progress=lambda f: False)


# -- cameras ---------------------------------------------------------------------------------
def test_rays_are_unit_length_and_row_zero_is_the_top():
    cam = hv.Camera((0, 0, 10), (0, 0, 0), (0, 1, 0), view_angle=60)
    rays = cam.rays((5, 3))
    np.testing.assert_allclose(np.linalg.norm(rays.directions, axis=1), 1.0, rtol=1e-15)
    top, bottom = rays.directions[0], rays.directions[-1]
    assert top[1] > 0 > bottom[1]
    # the centre pixel looks at the focal point; the vertical half-angle is 30 degrees
    np.testing.assert_allclose(rays.directions[7], [0, 0, -1], atol=1e-15)
    top_centre = rays.directions[2]
    np.testing.assert_allclose(np.arctan2(top_centre[1], -top_centre[2]),
                               np.arctan(math.tan(math.radians(30)) * 2 / 3), rtol=1e-12)


def test_project_inverts_rays():
    cam = hv.Camera((3, -4, 5), (0, 0, 0), (0, 0, 1), view_angle=40)
    rays = cam.rays((7, 5))
    points = rays.origins + 2.5 * rays.directions
    cols, rows = np.meshgrid(np.arange(7) + 0.5, np.arange(5) + 0.5)
    np.testing.assert_allclose(cam.project(points, (7, 5)), np.stack([cols.ravel(), rows.ravel()], -1), atol=1e-9)


def test_fit_frames_the_bounding_sphere_like_vtk_reset_camera():
    cam = hv.Camera.fit((0, 2, 0, 2, 0, 2), "iso", view_angle=30)
    r = math.sqrt(3)
    assert cam.distance == pytest.approx(r / math.sin(math.radians(15)))
    np.testing.assert_allclose(np.subtract(cam.position, cam.focal_point) / cam.distance, [1 / r] * 3)
    assert cam.focal_point == (1.0, 1.0, 1.0) and cam.parallel_scale == pytest.approx(r)
    xy = hv.Camera.fit((0, 2, 0, 2, 0, 2), "xy")
    assert xy.position[2] > 1.0 and xy.view_up == (0.0, 1.0, 0.0)


def test_camera_rejects_bad_input():
    with pytest.raises(ValueError, match="position and focal_point must differ"):
        hv.Camera((1, 1, 1), (1, 1, 1))
    with pytest.raises(ValueError, match="must not be parallel to the view direction"):
        hv.Camera((0, 0, 1), (0, 0, 0), (0, 0, 5))
    with pytest.raises(ValueError, match=r"view_angle must be < 180; got 180"):
        hv.Camera(view_angle=180)
    with pytest.raises(ValueError, match=r"view must be one of \['iso', 'xy'"):
        hv.Camera.fit((0, 1, 0, 1, 0, 1), "top")


# -- HDRImage --------------------------------------------------------------------------------
def hdr_test_image():
    rng = np.random.default_rng(0)
    rgba = (10.0 ** rng.uniform(-10, 3, (6, 5, 4))).astype(np.float32)
    rgba[0, 0] = 0.0
    depth = rng.uniform(1, 100, (6, 5))
    depth[1, 1] = np.inf
    return hv.HDRImage(rgba, depth, {"precision": "float32", "step_voxels": 0.5})


def test_statistics():
    rgba = np.zeros((2, 2, 4), np.float32)
    rgba[0, 0, :3] = 1e-6
    rgba[1, 1, :3] = 100.0
    img = hv.HDRImage(rgba)
    assert img.peak_luminance == pytest.approx(100.0, rel=1e-6)
    assert img.min_nonzero_luminance == pytest.approx(1e-6, rel=1e-6)
    assert img.dynamic_range_decades == pytest.approx(8.0, abs=1e-6)
    assert img.stats()["distinct_luminance_levels"] == 2
    assert hv.HDRImage(np.zeros((2, 2, 4))).dynamic_range_decades == 0.0


def test_npy_round_trip_is_exact(tmp_path):
    img = hdr_test_image()
    back = hv.load(img.save(tmp_path / "x.npy"))
    np.testing.assert_array_equal(back.rgba, img.rgba)
    np.testing.assert_array_equal(back.depth, img.depth.astype(np.float32))


def test_exr_round_trip_float32_is_bit_exact_and_half_within_its_precision(tmp_path):
    pytest.importorskip("OpenEXR")  # optional on ParaView's Python
    img = hdr_test_image()
    back = hv.load(img.save(tmp_path / "x.exr"))
    np.testing.assert_array_equal(back.rgba, img.rgba)
    np.testing.assert_array_equal(back.depth, img.depth.astype(np.float32))
    assert back.metadata == img.metadata
    half = hv.load(img.save(tmp_path / "h.exr", pixel_type="float16"))
    ok = (img.rgba > 6.2e-5) & (img.rgba < 65504)  # half's normal range
    np.testing.assert_allclose(half.rgba[ok], img.rgba[ok], rtol=4.9e-4)
    with pytest.raises(ValueError, match=r"pixel_type must be one of \['float32', 'float16'\]; got 'int'"):
        img.save(tmp_path / "y.exr", pixel_type="int")


def test_save_rejects_unknown_extensions(tmp_path):
    with pytest.raises(ValueError, match="unknown image extension '.jpg'; use .exr, .hdr, .npy or .png"):
        hdr_test_image().save(tmp_path / "x.jpg")


def test_display_mapping_and_exposures():
    rgba = np.zeros((1, 3, 4))
    rgba[0, :, :3] = [[0.25], [0.5], [1.0]]
    rgba[0, :, 3] = 1.0
    img = hv.HDRImage(rgba)
    out = img.to_display(exposure_stops=1.0)
    np.testing.assert_array_equal(out[0, :, 0], np.round(srgb_encode([0.5, 1.0, 1.0]) * 255))
    brackets = img.exposures([-1, 0, 1])
    assert len(brackets) == 3 and all(b.dtype == np.uint8 and b.shape == (1, 3, 3) for b in brackets)
    assert brackets[0][0, 2, 0] < brackets[1][0, 2, 0] <= brackets[2][0, 2, 0]
    np.testing.assert_allclose(srgb_decode(srgb_encode(np.linspace(0, 1, 11))), np.linspace(0, 1, 11), atol=1e-12)


def test_png_output_is_a_valid_png(tmp_path):
    import zlib

    img = hdr_test_image()
    data = img._repr_png_()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    # decode the single IDAT chunk and compare with the display mapping
    idat = data[data.index(b"IDAT") + 4:data.index(b"IEND") - 8]
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(6, 1 + 5 * 3)
    np.testing.assert_array_equal(raw[:, 1:].reshape(6, 5, 3), img.to_display())


def test_hdrimage_rejects_bad_arrays():
    with pytest.raises(ValueError, match=r"rgba must have shape \(rows, cols, 4\); got \(2, 2, 3\)"):
        hv.HDRImage(np.zeros((2, 2, 3)))
    with pytest.raises(TypeError, match="rgba must be float32 or float64; got uint8"):
        hv.HDRImage(np.zeros((2, 2, 4), np.uint8))
    with pytest.raises(ValueError, match=r"depth must have shape \(2, 2\); got \(3,\)"):
        hv.HDRImage(np.zeros((2, 2, 4)), np.zeros(3))


def test_vtk_round_trip_flips_rows_and_keeps_everything():
    pytest.importorskip("vtkmodules")  # VTK is optional on ParaView's bare Python
    from vtkmodules.util.numpy_support import vtk_to_numpy

    img = hdr_test_image()
    vimg = img.to_vtk()
    assert vimg.GetDimensions() == (5, 6, 1)
    flat = vtk_to_numpy(vimg.GetPointData().GetArray("rgba"))
    np.testing.assert_array_equal(flat[:5], img.rgba[-1])  # VTK's first row is our bottom row
    back = hv.HDRImage.from_pyvista(vimg)
    np.testing.assert_array_equal(back.rgba, img.rgba)
    np.testing.assert_array_equal(back.depth, img.depth)
    assert back.metadata == img.metadata


def test_progress_bar_appears_only_when_asked_or_for_slow_renders(capsys, monkeypatch):
    import pv_hdrvol.raycast.frame as frame

    vol = np.linspace(0, 1, 16**3).reshape(16, 16, 16)
    plain = hv.render(vol, None, None, (64, 64), progress_bar=False)
    fast = hv.render(vol, None, None, (64, 64))  # default None: a quick render prints nothing
    assert capsys.readouterr().err == ""
    np.testing.assert_array_equal(fast.rgba, plain.rgba)
    pytest.importorskip("tqdm")
    monkeypatch.setattr(frame, "AUTO_BAR_SECONDS", 0.0)  # every render now counts as slow
    slow = hv.render(vol, None, None, (64, 64))
    assert capsys.readouterr().err == ""  # stderr is no terminal here: no bar in logs
    monkeypatch.setattr(frame, "auto_bar_wanted", lambda: True)  # as on a terminal
    slow = hv.render(vol, None, None, (64, 64))
    assert "Rendering" in capsys.readouterr().err
    np.testing.assert_array_equal(slow.rgba, plain.rgba)  # chunking changes no pixel
    hv.render(vol, None, None, (16, 16), progress_bar=True)
    assert "Rendering" in capsys.readouterr().err
    with pytest.raises(TypeError, match="progress_bar must be True, False or None"):
        hv.render(vol, None, None, (16, 16), progress_bar="yes")


def test_every_front_end_takes_a_view_name_for_the_camera():
    """hv.render takes what the accessor takes: a view name frames the data as Camera.fit."""
    values = np.random.default_rng(3).random((6, 7, 8))
    vol = hv.volume_from_array(values, spacing=(0.5, 1.0, 2.0))
    for view in ("iso", "xz"):
        np.testing.assert_array_equal(hv.render(vol, None, view, (9, 7)).rgba,
                                      hv.render(vol, None, hv.Camera.fit(vol.bounds, view), (9, 7)).rgba)
