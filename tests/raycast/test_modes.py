"""Rendering modes: projections, gradient-modulated opacity, two-level (label) rendering,
and mip-mapped sampling for rays that carry a level of detail."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv

pytestmark = pytest.mark.core

GRAY = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray")


def axis_rays(shape, axis, forward=True):
    """Parallel rays along ``axis`` (0: z, 1: y, 2: x of a (z, y, x) array) through every
    grid point of the other two axes, built exactly (no camera arithmetic).

    Pixel ``(row, col)`` sees the points ``[a, b]`` of the remaining axes in (z, y, x)
    order with ``a = row``, ``b = col``: the result compares with ``values.max(axis)``.
    """
    nz, ny, nx = shape
    others = [a for a in range(3) if a != axis]
    n = [shape[a] for a in others]
    rr, cc = np.mgrid[0:n[0], 0:n[1]]
    pts = np.zeros((rr.size, 3))  # (x, y, z) voxel coordinates
    xyz_of = {0: 2, 1: 1, 2: 0}  # array axis -> coordinate index
    pts[:, xyz_of[others[0]]] = rr.ravel()
    pts[:, xyz_of[others[1]]] = cc.ravel()
    d = np.zeros(3)
    d[xyz_of[axis]] = 1.0 if forward else -1.0
    pts[:, xyz_of[axis]] = -10.0 if forward else shape[axis] + 9.0
    return hv.Rays(pts, np.tile(d, (rr.size, 1)), n[1], n[0])


@pytest.fixture(scope="module")
def random_volume():
    return np.random.default_rng(7).random((6, 5, 7))


# -- projections ------------------------------------------------------------------------------
@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("forward", [True, False])
def test_orthographic_mip_equals_max_along_axis(random_volume, axis, forward):
    vals = random_volume
    vol = hv.volume_from_array(vals)
    rays = axis_rays(vals.shape, axis, forward)
    img = hv.render(vol, GRAY, rays, blending="maximum", step=1.0, precision="float64")
    assert np.array_equal(img.value, vals.max(axis=axis))
    low = hv.render(vol, GRAY, rays, blending="minimum", step=1.0, precision="float64")
    assert np.array_equal(low.value, vals.min(axis=axis))


def test_float32_mip_is_the_max_of_the_float32_data(random_volume):
    vals = random_volume
    img = hv.render(vals, GRAY, axis_rays(vals.shape, 0), blending="maximum", step=1.0, precision="float32")
    assert np.array_equal(img.value, vals.astype(np.float32).max(axis=0).astype(np.float64))


def test_uint8_mip_is_the_max_of_the_8bit_levels(random_volume):
    # the 8-bit pipeline quantises the data to the table's 256 levels first; the early
    # stop must use those levels' maximum, not the caller's data range
    vals = random_volume
    img = hv.render(vals, GRAY, axis_rays(vals.shape, 0), blending="maximum", step=1.0, precision="uint8")
    assert np.array_equal(img.value, np.round(vals * 255).max(axis=0))


def test_flat_volume_projection_has_an_empty_value_image():
    with pytest.warns(hv.EmptyRenderWarning, match="the volume is flat"):
        img = hv.render(np.ones((1, 4, 4)), GRAY, size=3, blending="maximum")
    assert img.value.shape == (3, 3) and np.isnan(img.value).all()


def test_mip_colour_is_the_transfer_function_at_the_maximum():
    vals = np.zeros((5, 3, 3))
    vals[2, 1, 1] = 0.8
    tf = hv.TransferFunction([0.0, 1.0], [[0.0, 0.0, 0.0], [1.0, 0.5, 0.25]], [0.0, 0.5])
    rays = axis_rays(vals.shape, 0)
    img = hv.render(vals, tf, rays, blending="maximum", step=1.0, precision="float64")
    a = 1.0 - (1.0 - 0.4) ** 1.0  # opacity 0.4 per unit distance (= 1 voxel)
    px = img.rgba[1, 1]
    assert px[3] == pytest.approx(a, rel=1e-12)
    assert px[:3] == pytest.approx([a * 0.8, a * 0.4, a * 0.2], rel=1e-12)
    assert img.depth[1, 1] == pytest.approx(10.0 + 2.0)  # where the maximum was met
    assert img.rgba[0, 0, 3] == 0.0 and img.value[0, 0] == 0.0


def test_xray_of_a_slab_is_its_line_integral():
    c, nz, dz = 0.3, 9, 0.5
    vol = hv.volume_from_array(np.full((nz, 4, 4), c), spacing=(1.0, 1.0, dz))
    alpha = 0.2  # per unit distance = smallest spacing 0.5
    tf = hv.TransferFunction([0.0, 1.0], [[0.5, 1.0, 0.25]] * 2, [alpha, alpha])
    rays = hv.Rays(np.array([[1.5, 1.5, 20.0]]), np.array([[0.0, 0.0, -1.0]]), 1, 1)
    for step in (0.1, 0.37, 2.0, 100.0):
        img = hv.render(vol, tf, rays, blending="additive", step=step, precision="float64")
        length = (nz - 1) * dz
        sigma = -math.log1p(-alpha) / dz
        assert img.value[0, 0] == pytest.approx(c * length, rel=1e-12)
        assert img.rgba[0, 0, :3] == pytest.approx(np.array([0.5, 1.0, 0.25]) * sigma * length, rel=1e-12)
        assert img.rgba[0, 0, 3] == pytest.approx(1.0 - math.exp(-sigma * length), rel=1e-12)
        avg = hv.render(vol, tf, rays, blending="average", step=step, precision="float64")
        assert avg.value[0, 0] == pytest.approx(c, rel=1e-12)


def test_xray_of_a_ramp_is_exact_for_the_piecewise_linear_field(random_volume):
    vals = random_volume
    img = hv.render(vals, GRAY, axis_rays(vals.shape, 0), blending="additive", step=0.25, precision="float64")
    trapezoid = 0.5 * (vals[1:] + vals[:-1]).sum(axis=0)
    np.testing.assert_allclose(img.value, trapezoid, rtol=1e-13)


def test_projections_of_empty_rays_and_nan(random_volume):
    # a NaN point empties every sample whose trilinear stencil touches it
    vals = random_volume.copy()
    vals[1, 0, 0] = np.nan
    vals[0, 0, 0] = 2.0  # only in stencils that also hold the NaN
    img = hv.render(vals, GRAY, axis_rays(vals.shape, 0), blending="maximum", step=1.0, precision="float64")
    assert img.value[0, 0] == vals[2:, 0, 0].max()
    assert img.value[0, 1] == vals[:, 0, 1].max()
    vals[:, 0, 0] = np.nan
    img = hv.render(vals, GRAY, axis_rays(vals.shape, 0), blending="maximum", step=1.0, precision="float64")
    assert np.isnan(img.value[0, 0]) and img.rgba[0, 0].tolist() == [0.0, 0.0, 0.0, 0.0]
    miss = hv.Rays(np.array([[50.0, 50.0, 50.0]]), np.array([[0.0, 0.0, 1.0]]), 1, 1)
    out = hv.render(vals, GRAY, miss, blending="average")
    assert np.isnan(out.value[0, 0]) and out.depth[0, 0] == math.inf


def test_composite_render_has_no_value_image(random_volume):
    assert hv.render(random_volume, GRAY, size=4).value is None


# -- gradient-magnitude opacity -----------------------------------------------------------------
def test_gradient_opacity_scales_extinction_by_the_ramp():
    g = 0.05  # data units per world unit
    nz = 11
    z = np.arange(nz, dtype=float)[:, None, None] * np.ones((1, 4, 4))
    vol = hv.volume_from_array(g * z)
    alpha = 0.1
    tf = hv.TransferFunction([0.0, 1.0], [[1.0, 1.0, 1.0]] * 2, [alpha, alpha])
    rays = hv.Rays(np.array([[1.5, 1.5, 30.0]]), np.array([[0.0, 0.0, -1.0]]), 1, 1)
    sigma = -math.log1p(-alpha)
    for lo, hi, factor in [(0.0, 0.1, 0.5), (0.0, 0.02, 1.0), (0.06, 0.2, 0.0), (0.04, 0.08, 0.25)]:
        img = hv.render(vol, tf, rays, gradient_opacity=(lo, hi), precision="float64", termination=0.0)
        assert img.rgba[0, 0, 3] == pytest.approx(1.0 - math.exp(-sigma * factor * (nz - 1)), rel=1e-9, abs=1e-15)


def test_gradient_opacity_hides_a_constant_volume():
    img = hv.render(np.full((5, 5, 5), 0.5), GRAY, size=8, gradient_opacity=(1e-9, 1.0))
    assert img.rgba.max() == 0.0


# -- two-level rendering ---------------------------------------------------------------------
@pytest.mark.parametrize("precision", ["float64", "float32", "float16"])
def test_one_composite_label_is_the_plain_render(random_volume, precision):
    vol = hv.volume_from_array(random_volume)
    cam = hv.Camera.fit(vol, "iso")
    plain = hv.render(vol, GRAY, cam, 24, precision=precision)
    labels = np.full(random_volume.shape, 3)
    two = hv.render(vol, GRAY, cam, 24, precision=precision, labels=labels, label_styles={3: GRAY})
    assert np.array_equal(plain.rgba, two.rgba)
    assert np.array_equal(plain.depth, two.depth)


@pytest.mark.parametrize("blending", ["maximum", "minimum"])
def test_one_projection_label_is_the_projection(random_volume, blending):
    vol = hv.volume_from_array(random_volume)
    cam = hv.Camera.fit(vol, "iso")
    mip = hv.render(vol, GRAY, cam, 24, precision="float64", blending=blending)
    two = hv.render(vol, GRAY, cam, 24, precision="float64", labels=np.zeros(random_volume.shape, np.int32),
                    label_styles={0: blending})
    assert np.array_equal(mip.rgba, two.rgba)


def test_two_labels_composite_then_maximum_front_to_back():
    # along +z: points z = 0..4 label 0 (constant 0.5, composited), z = 5..9 label 1 (MIP)
    vals = np.full((10, 3, 3), 0.5)
    vals[5:, 1, 1] = [0.2, 0.9, 0.4, 0.6, 0.1]
    labels = np.zeros(vals.shape, np.int64)
    labels[5:] = 1
    a0 = 0.05
    tf0 = hv.TransferFunction([0.0, 1.0], [[1.0, 0.0, 0.0]] * 2, [a0, a0])
    tf1 = hv.TransferFunction([0.0, 1.0], [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [0.0, 1.0])
    rays = hv.Rays(np.array([[1.0, 1.0, -5.0]]), np.array([[0.0, 0.0, 1.0]]), 1, 1)
    img = hv.render(vals, tf0, rays, step=0.5, precision="float64", termination=0.0, labels=labels,
                    label_styles={1: (tf1, "maximum")})
    # label 0 holds the midpoints below z = 4.5 (nearest point <= 4): 4.5 voxels of opacity a0 per voxel
    front = 1.0 - (1.0 - a0) ** 4.5
    back = 0.9  # tf1's opacity at the maximum 0.9, over one voxel
    px = img.rgba[0, 0]
    # 1e-8: the table interpolates extinction -ln(1 - 0.9 v) linearly between 65,536 entries
    assert px[3] == pytest.approx(front + (1.0 - front) * back, rel=1e-8)
    assert px[0] == pytest.approx(front, rel=1e-12)
    assert px[1] == pytest.approx((1.0 - front) * back * 0.9, rel=1e-8)


def test_labels_are_not_modified(random_volume):
    labels = np.zeros(random_volume.shape, np.int16)
    labels[2:] = 5
    keep = labels.copy()
    hv.render(random_volume, GRAY, size=8, labels=labels, label_styles={5: "maximum"})
    assert np.array_equal(labels, keep)


# -- levels of detail (lens rays) -----------------------------------------------------------------
@pytest.mark.parametrize("blending", ["maximum", "minimum", "average", "additive"])
def test_a_projections_rays_at_level_zero_are_the_projection_without_levels(random_volume, blending):
    """A projection with per-ray levels of detail runs the mip-map loop kernel
    (``render_levels``), one without them ``render_tiles``: the same loop with the
    projection's compositor, so rays at level 0 give the same bits, and rays with a
    level sample the mip-map (other values, same coverage)."""
    vol = hv.volume_from_array(random_volume)
    rays = hv.Camera.fit(vol, "iso").rays((12, 10))
    plain = hv.render(vol, GRAY, rays, blending=blending, precision="float64")
    lod = np.where(np.arange(120) % 3 == 0, 1.5, 0.0)
    img = hv.render(vol, GRAY, rays._replace(lod=lod), blending=blending, precision="float64")
    at0 = lod.reshape(10, 12) == 0.0
    assert at0.sum() == 80
    np.testing.assert_array_equal(img.value[at0], plain.value[at0])
    np.testing.assert_array_equal(img.rgba[at0], plain.rgba[at0])
    np.testing.assert_array_equal(img.depth[at0], plain.depth[at0])
    assert np.array_equal(np.isnan(img.value), np.isnan(plain.value))
    assert not np.array_equal(img.value[~at0], plain.value[~at0])


def test_mip_sampling_keeps_constant_and_linear_fields():
    z, y, x = np.mgrid[0:33, 0:33, 0:33].astype(float)
    lin = 0.01 * x + 0.02 * y + 0.005 * z
    vol = hv.volume_from_array(lin)
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray", opacity=(0.0, 0.05))
    # rays through the middle, away from the edges where the filter repeats the edge
    o = np.array([[12.0 + i, 14.0 + 0.5 * j, 40.0] for i in range(4) for j in range(3)])
    d = np.tile([0.0, 0.0, -1.0], (12, 1))
    plain = hv.render(vol, tf, hv.Rays(o, d, 3, 4), blending="average", precision="float64")
    for level in (0.5, 1.0, 2.3):
        img = hv.render(vol, tf, hv.Rays(o, d, 3, 4, np.full(12, level)), blending="average", precision="float64")
        # the tent filter preserves linear functions; the average along z includes the
        # repeated edge only within 2**(level + 1) voxels of the faces
        np.testing.assert_allclose(img.value[:, :], plain.value, rtol=0.02)
    const = hv.volume_from_array(np.full((9, 9, 9), 0.4))
    cam = hv.Camera.fit(const, "iso")
    r = cam.rays(12)
    base = hv.render(const, tf, r, precision="float64")
    lod = np.linspace(0.0, 3.0, r.origins.shape[0])
    np.testing.assert_allclose(hv.render(const, tf, r._replace(lod=lod), precision="float64").rgba, base.rgba,
                               rtol=1e-12, atol=1e-15)


def test_level_zero_rays_are_bit_identical_to_plain(random_volume):
    vol = hv.volume_from_array(random_volume)
    r = hv.Camera.fit(vol, "iso").rays(16)
    lod = np.zeros(r.origins.shape[0])
    lod[:40] = 1.5  # some rays coarse, the rest at level 0
    plain = hv.render(vol, GRAY, r, precision="float32")
    mixed = hv.render(vol, GRAY, r._replace(lod=lod), precision="float32")
    assert np.array_equal(plain.rgba.reshape(-1, 4)[40:], mixed.rgba.reshape(-1, 4)[40:])
    assert not np.array_equal(plain.rgba.reshape(-1, 4)[:40], mixed.rgba.reshape(-1, 4)[:40])


def test_lens_pixels_outside_it_are_the_plain_render(random_volume):
    vol = hv.volume_from_array(random_volume)
    cam = hv.Camera.fit(vol, "iso")
    plain = hv.render(vol, GRAY, cam, 32)
    same = hv.render(vol, GRAY, cam, 32, lens=hv.Magnifier((16.0, 16.0), radius=8, factor=1.0))
    assert np.array_equal(plain.rgba, same.rgba) and np.array_equal(plain.depth, same.depth)
    lens = hv.Magnifier((12.5, 14.5), radius=8, transition=3, factor=3.0)
    img = hv.render(vol, GRAY, cam, 32, lens=lens)
    s, _ = lens.scale(cam, 32)
    outside = s == 1.0
    assert lens.rays(cam, 32).lod is not None  # the band is anti-aliased, the rest is not touched
    assert np.array_equal(img.rgba[outside], plain.rgba[outside])
    assert not np.array_equal(img.rgba[~outside], plain.rgba[~outside])


def test_mipmap_ignores_nan_neighbours():
    from pv_hdrvol.raycast._kernels_ext import downsample

    v = np.full((5, 5, 5), 2.0)
    v[2, 2, 3] = np.nan
    out = np.empty((3, 3, 3))
    downsample(v, out)
    assert np.all(out == 2.0)
    out_nan = np.empty((2, 2, 2))
    downsample(np.full((3, 3, 3), np.nan), out_nan)
    assert np.all(np.isnan(out_nan))


# -- bad input -----------------------------------------------------------------------------------
def test_bad_mode_input(random_volume):
    v = random_volume
    with pytest.raises(ValueError, match=r"blending must be one of \['composite', 'maximum', 'minimum', 'average', "
                                         r"'additive'\]; got 'mip'"):
        hv.render(v, GRAY, size=4, blending="mip")
    with pytest.raises(ValueError, match=r"gradient_opacity must be \(low, high\) with high > low >= 0; got \(1, 1\)"):
        hv.render(v, GRAY, size=4, gradient_opacity=(1, 1))
    with pytest.raises(TypeError, match="gradient_opacity must be None or \\(low, high\\); got 0.5"):
        hv.render(v, GRAY, size=4, gradient_opacity=0.5)
    with pytest.raises(ValueError, match="gradient_opacity applies to blending='composite' only; got "
                                         "blending='maximum'"):
        hv.render(v, GRAY, size=4, gradient_opacity=(0, 1), blending="maximum")
    with pytest.raises(ValueError, match=r"labels must have the volume's shape \(6, 5, 7\) \(z, y, x\); got \(6, 5\)"):
        hv.render(v, GRAY, size=4, labels=np.zeros((6, 5), int))
    with pytest.raises(TypeError, match="labels must be an integer or bool array; got dtype float64"):
        hv.render(v, GRAY, size=4, labels=np.zeros(v.shape))
    labels = np.zeros(v.shape, int)
    with pytest.raises(ValueError, match=r"label 4 of label_styles does not occur in labels \(labels present: \[0\]\)"):
        hv.render(v, GRAY, size=4, labels=labels, label_styles={4: "maximum"})
    with pytest.raises(ValueError, match=r"the blending of label 0 must be one of \['composite', 'maximum', "
                                         r"'minimum'\]; got 'additive'"):
        hv.render(v, GRAY, size=4, labels=labels, label_styles={0: "additive"})
    with pytest.raises(TypeError, match="the style of label 0 must be a TransferFunction"):
        hv.render(v, GRAY, size=4, labels=labels, label_styles={0: 3})
    with pytest.raises(TypeError, match="label_styles keys must be integer labels; got 'a'"):
        hv.render(v, GRAY, size=4, labels=labels, label_styles={"a": "maximum"})
    with pytest.raises(ValueError, match="labels need a floating-point precision"):
        hv.render(v, GRAY, size=4, labels=labels, precision="uint8")
    r = hv.Camera.fit(hv.volume_from_array(v)).rays(4)
    with pytest.raises(ValueError, match=r"Rays.lod must have one value per ray \(16\); got 3"):
        hv.render(v, GRAY, r._replace(lod=np.ones(3)))
    with pytest.raises(ValueError, match="Rays.lod must be finite and >= 0"):
        hv.render(v, GRAY, r._replace(lod=np.full(16, -1.0)))
