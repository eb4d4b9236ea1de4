"""Blinn-Phong shading by the gradient (issue 18): analytic checks on both ray casters.

* A sphere (a distance field) under a headlight follows Lambert's cosine law: with only
  diffuse light, a pixel's colour over its opacity is ``cos`` of the angle between the
  ray and the sphere's normal where the ray met it (read from the depth image).
* A linear field is a plane of constant gradient: every pixel has the same lit colour,
  equal to the Blinn-Phong formula evaluated by hand (the central differences of a
  linear field, and a tet's gradient, are exact).
* Lighting that changes nothing (ambient 1, no diffuse or specular; a field without
  gradient) gives the unshaded pixels bit for bit, in every precision.
* The two grid loops that shade (the batched plain loop of a shaded render and the
  extended loop of a labelled one) light a sample alike, bit for bit.
"""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from meshes import box_mesh

pytestmark = pytest.mark.core

WHITE4 = [[1.0, 1.0, 1.0]] * 4
N = 40
R = 15.0


def sphere_volume():
    """|x - centre| on an N^3 grid of unit spacing."""
    z, y, x = np.mgrid[0:N, 0:N, 0:N].astype(float) - (N - 1) / 2
    return hv.volume_from_array(np.sqrt(x * x + y * y + z * z))


def sphere_tf():
    """Opaque inside radius R, empty outside (a thin ramp at the surface)."""
    return hv.TransferFunction([0.0, R - 0.01, R + 0.01, 2.0 * N], WHITE4, [1.0, 1.0, 0.0, 0.0])


def down_z(center, half, distance=100.0):
    c = np.asarray(center, dtype=float)
    return hv.Camera(tuple(c + (0, 0, distance)), tuple(c), (0, 1, 0), parallel_projection=True,
                     parallel_scale=half)


def lambert_errors(img, center, half, distance=100.0):
    """``colour / alpha - cos`` at the opaque pixels of a sphere centred at ``center`` seen
    down -z by ``down_z``; cos at the point where the ray's depth was recorded."""
    h, w = img.shape
    rows, cols = np.nonzero(img.rgba[..., 3] > 0.999)
    x = center[0] - half + (cols + 0.5) * 2 * half / w
    y = center[1] + half - (rows + 0.5) * 2 * half / h
    z = center[2] + distance - img.depth[rows, cols]
    p = np.stack([x - center[0], y - center[1], z - center[2]], axis=1)
    cos = p[:, 2] / np.linalg.norm(p, axis=1)
    lit = img.rgba[rows, cols, 0].astype(float) / img.rgba[rows, cols, 3]
    return lit - cos


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("gradient", ["sampled", "interpolated"])
def test_grid_sphere_under_a_headlight_follows_lamberts_law(precision, gradient):
    vol = sphere_volume()
    c = ((N - 1) / 2,) * 3
    img = hv.render(vol, sphere_tf(), down_z(c, c[0]), (48, 48), precision=precision, step=0.05, shade=True,
                    ambient=0.0, diffuse=1.0, specular=0.0, shade_gradient=gradient)
    err = lambert_errors(img, c, c[0])
    assert err.size > 1000  # the disc of radius 15 covers ~1,100 of 48^2 pixels (a 39.5-wide view)
    # measured: max 0.0098, mean 0.0008 (the ray's recorded depth lies up to a step inside)
    assert np.abs(err).max() < 0.015
    assert np.abs(err).mean() < 0.002


def test_sampled_and_interpolated_gradients_agree():
    """For a trilinear field, central differences at the sample are the interpolated
    central differences of the grid points: the two options give the same picture to
    rounding."""
    vol = sphere_volume()
    cam = hv.Camera.fit(vol.bounds, "iso")
    a = hv.render(vol, sphere_tf(), cam, (32, 32), precision="float64", shade=True, shade_gradient="sampled")
    b = hv.render(vol, sphere_tf(), cam, (32, 32), precision="float64", shade=True, shade_gradient="interpolated")
    np.testing.assert_allclose(a.rgba, b.rgba, rtol=0, atol=1e-12)


def blinn_phong(colour, gradient, lights, ka, kd, ks, power, eye=(0.0, 0.0, 1.0)):
    """The lit colour of a two-sided surface with normal along ``gradient``, by hand."""
    e = np.asarray(eye, float)
    n = np.asarray(gradient, float) / np.linalg.norm(gradient)
    if n @ e < 0:
        n = -n
    diffuse = specular = 0.0
    for direction in lights:
        l_vec = np.asarray(direction, float) / np.linalg.norm(direction)
        if n @ l_vec > 0:
            half = (l_vec + e) / np.linalg.norm(l_vec + e)
            diffuse += n @ l_vec
            specular += max(n @ half, 0.0) ** power
    return colour * (ka + kd * diffuse) + ks * specular


GRAD = np.array([1.0, -2.0, 3.0])  # of the linear field (world units)


@pytest.mark.parametrize("lights, power", [(None, 7.0), ([(0.3, 0.5, 1.0)], 7.0),
                                           ([(0.3, 0.5, 1.0), (-1.0, 0.2, 0.4)], 7.0),
                                           ([(0.3, 0.5, 1.0), (-1.0, 0.2, 0.4)], 7.5)])
def test_grid_plane_is_lit_evenly_by_the_formula(lights, power):
    """Integral specular powers are taken by repeated squaring, others by pow()."""
    n = 24
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(float) * 0.5  # spacing 0.5: world = index / 2
    vol = hv.volume_from_array(GRAD[0] * x + GRAD[1] * y + GRAD[2] * z, spacing=(0.5, 0.5, 0.5))
    lo, hi = vol.value_range
    tf = hv.TransferFunction([lo, hi], [[0.5, 0.5, 0.5]] * 2, [0.02, 0.02])
    c = np.array(vol.bounds).reshape(3, 2).mean(axis=1)
    img = hv.render(vol, tf, down_z(c, 3.0, distance=30.0), (16, 16), precision="float64", shade=True,
                    ambient=0.15, diffuse=0.6, specular=0.4, specular_power=power, lights=lights)
    expected = blinn_phong(0.5, GRAD, [(0, 0, 1)] if lights is None else lights, 0.15, 0.6, 0.4, power)
    a = img.rgba[..., 3]
    assert a.min() > 0.3  # 24 voxels of 0.02: 1 - 0.98**23 = 0.37
    np.testing.assert_allclose(img.rgba[..., :3] / a[..., None], expected, rtol=1e-9)


@pytest.mark.parametrize("precision", hv.PRECISIONS)
def test_lighting_that_changes_nothing_gives_the_unshaded_bits(precision):
    vol = sphere_volume()
    tf = hv.TransferFunction.ramp(0.0, 2.0 * N, cmap="gray", opacity=(0.08, 0.0))
    cam = hv.Camera.fit(vol.bounds, "iso")
    plain = hv.render(vol, tf, cam, (24, 24), precision=precision)
    neutral = hv.render(vol, tf, cam, (24, 24), precision=precision, shade=True, ambient=1.0, diffuse=0.0,
                        specular=0.0)
    np.testing.assert_array_equal(neutral.rgba, plain.rgba)
    np.testing.assert_array_equal(neutral.depth, plain.depth)
    lit = hv.render(vol, tf, cam, (24, 24), precision=precision, shade=True)
    assert not np.array_equal(lit.rgba, plain.rgba)


@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_shaded_plain_loop_is_the_extended_loop_bit_for_bit(precision):
    """A shaded render without labels runs the batched plain loop (``render_tiles``),
    one with a single composite label the extended loop (``render_ext``). Both call the
    same lighting (``_kernels.lit``) at the same sample positions, so their pixels are
    equal bit for bit: interior samples (the 32-point stencil), samples within a voxel
    of a face (``_edge_gradient``), both gradient options, a headlight and a directional
    light with specular, a log axis, and a perspective camera."""
    n = 20
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(float)
    field = 1.0 + np.sqrt((x - 9.3) ** 2 + (y - 10.1) ** 2 + (z - 8.7) ** 2) + 0.3 * np.sin(0.7 * x + 0.4 * y)
    vol = hv.volume_from_array(field, spacing=(1.0, 0.8, 1.2))
    tf = hv.TransferFunction([1.0, 6.0, 9.0, 16.0], [[1, 0.8, 0.6], [0.2, 0.9, 0.4], [0.9, 0.3, 0.2], [1, 1, 1]],
                             [0.0, 0.3, 0.6, 0.05], scale="log")
    cam = hv.Camera.fit(vol.bounds, "iso", view_angle=40.0)
    labels = np.zeros(field.shape, np.int32)
    for gradient in ("sampled", "interpolated"):
        kw = dict(precision=precision, shade=True, shade_gradient=gradient, specular=0.6, specular_power=12.0,
                  lights=[hv.Light(), hv.Light((1.0, -0.5, 0.7), 0.8)], step=0.4)
        batched = hv.render(vol, tf, cam, (40, 40), **kw)
        extended = hv.render(vol, tf, cam, (40, 40), labels=labels, label_styles={0: "composite"}, **kw)
        assert batched.rgba[..., 3].max() > 0.5
        np.testing.assert_array_equal(batched.rgba, extended.rgba)
        np.testing.assert_array_equal(batched.depth, extended.depth)


def test_no_gradient_no_light_and_nan_stays_unlit():
    """A constant field has no normal: shading fades out completely (bit for bit); NaN
    voxels stay empty and never reach a pixel."""
    cam = hv.Camera.fit((0, 7, 0, 7, 0, 7), "iso")
    tf = hv.TransferFunction([0.0, 2.0], [[0.3, 0.6, 0.9]] * 2, [0.1, 0.1])
    const = np.full((8, 8, 8), 1.0)
    np.testing.assert_array_equal(hv.render(const, tf, cam, (16, 16), shade=True).rgba,
                                  hv.render(const, tf, cam, (16, 16)).rgba)
    holes = const.copy()
    holes[2:5, 3:6, 1:7] = np.nan
    holes[5, 5, 5] = 1.5
    img = hv.render(holes, tf, cam, (16, 16), shade=True, shade_threshold=0.0)
    assert np.all(np.isfinite(img.rgba))


def test_highlights_are_not_clamped():
    """HDR: a strong specular highlight exceeds 1 and is kept."""
    vol = sphere_volume()
    c = ((N - 1) / 2,) * 3
    img = hv.render(vol, sphere_tf(), down_z(c, c[0]), (32, 32), precision="float32", step=0.1, shade=True,
                    specular=4.0, lights=[hv.Light("headlight", 2.0)])
    assert img.rgba[..., :3].max() > 4.0


def test_shade_threshold_fades_weak_gradients():
    """Shading grows linearly with the gradient up to the threshold: a field changing by
    1 % of the axis per voxel is fully lit at threshold 0.01 and half lit at 0.02."""
    n = 16
    x = np.mgrid[0:n, 0:n, 0:n][2].astype(float)
    vol = hv.volume_from_array(0.01 * x)  # the TF axis below spans 1.0: 1 % per voxel
    tf = hv.TransferFunction([0.0, 1.0], [[1.0, 1.0, 1.0]] * 2, [0.05, 0.05])
    cam = down_z(((n - 1) / 2,) * 3, 4.0, distance=50.0)  # gradient along x, light along z: n.l = 0
    plain = hv.render(vol, tf, cam, (8, 8), precision="float64")
    base = plain.rgba[..., 0] / plain.rgba[..., 3]

    def lit(threshold):
        img = hv.render(vol, tf, cam, (8, 8), precision="float64", shade=True, ambient=0.2, diffuse=1.0,
                        specular=0.0, shade_threshold=threshold)
        return img.rgba[..., 0] / img.rgba[..., 3]

    np.testing.assert_allclose(lit(0.01), 0.2 * base, rtol=1e-9)
    np.testing.assert_allclose(lit(0.02), 0.6 * base, rtol=1e-9)  # w = 0.5: 1 + 0.5 (0.2 - 1)


# -- tetrahedra ----------------------------------------------------------------------------
def test_tet_plane_is_lit_evenly_by_the_formula():
    pts, tets, _ = box_mesh((5, 5, 5), spacing=1.0)
    values = pts @ GRAD
    mesh = hv.tetmesh_from_arrays(pts, tets, values)
    lo, hi = mesh.value_range
    tf = hv.TransferFunction([lo, hi], [[0.5, 0.5, 0.5]] * 2, [0.2, 0.2])
    lights = [(0.3, 0.5, 1.0)]
    img = hv.render(mesh, tf, down_z((2.5, 2.5, 2.5), 1.5, distance=30.0), (12, 12), precision="float64",
                    shade=True, ambient=0.15, diffuse=0.6, specular=0.4, specular_power=7.0, lights=lights)
    expected = blinn_phong(0.5, GRAD, lights, 0.15, 0.6, 0.4, 7.0)
    a = img.rgba[..., 3]
    assert a.min() > 0.5
    np.testing.assert_allclose(img.rgba[..., :3] / a[..., None], expected, rtol=1e-9)


def tet_sphere_errors(n):
    """Lambert errors of a sphere of radius ``n / 2 - 1.5`` in a box of ``n^3`` unit cubes."""
    pts, tets, _ = box_mesh((n, n, n), spacing=1.0)
    c = np.full(3, n / 2)
    radius = n / 2 - 1.5
    mesh = hv.tetmesh_from_arrays(pts, tets, np.linalg.norm(pts - c, axis=1))
    tf = hv.TransferFunction([0.0, radius - 0.01, radius + 0.01, 2.0 * n], WHITE4, [1.0, 1.0, 0.0, 0.0])
    img = hv.render(mesh, tf, down_z(c, radius + 0.5), (40, 40), precision="float64", shade=True, ambient=0.0,
                    diffuse=1.0, specular=0.0, depth_threshold=0.5)
    return lambert_errors(img, c, radius + 0.5)


def test_tet_sphere_under_a_headlight_follows_lamberts_law():
    """A cell's gradient is its linear interpolant's: the normal of a facet of a
    polyhedral sphere, off the true normal by about a cell over the radius. The error
    falls as the cells shrink relative to the sphere (measured RMS 0.036 at radius 4.5,
    0.014 at 10.5; max 0.12 and 0.047)."""
    coarse = tet_sphere_errors(12)
    fine = tet_sphere_errors(24)
    assert coarse.size > 900 and fine.size > 900
    rms = [float(np.sqrt(np.mean(e ** 2))) for e in (coarse, fine)]
    assert rms[1] < 0.02 and np.abs(fine).max() < 0.07
    assert rms[0] / rms[1] > 2.0  # first order in cell size over radius (4.5 -> 10.5)


def test_tet_cell_data_has_no_gradient_and_stays_unlit():
    pts, tets, _ = box_mesh((3, 3, 3))
    values = np.arange(len(tets), dtype=float)
    mesh = hv.tetmesh_from_arrays(pts, tets, values, association="cell")
    tf = hv.TransferFunction([0.0, float(len(tets))], [[0.2, 0.5, 0.9]] * 2, [0.3, 0.3])
    cam = hv.Camera.fit(mesh.bounds, "iso")
    for precision in ("float64", "float32"):
        np.testing.assert_array_equal(hv.render(mesh, tf, cam, (16, 16), precision=precision, shade=True).rgba,
                                      hv.render(mesh, tf, cam, (16, 16), precision=precision).rgba)


# -- options --------------------------------------------------------------------------------
def test_shading_options_are_validated():
    with pytest.raises(ValueError, match="shade applies to blending='composite' only; got blending='maximum'"):
        hv.RenderOptions(shade=True, blending="maximum")
    with pytest.raises(ValueError, match="specular_power must be >= 1; got 0.5"):
        hv.RenderOptions(specular_power=0.5)
    with pytest.raises(ValueError, match="ambient must be >= 0; got -0.1"):
        hv.RenderOptions(ambient=-0.1)
    with pytest.raises(TypeError, match="shade must be a bool; got 1"):
        hv.RenderOptions(shade=1)
    with pytest.raises(ValueError, match=r"shade_gradient must be one of \['sampled', 'interpolated'\]"):
        hv.RenderOptions(shade_gradient="sobel")
    with pytest.raises(ValueError, match="Light direction must not be the zero vector"):
        hv.RenderOptions(lights=[(0, 0, 0)])
    with pytest.raises(ValueError, match="Light intensity must be >= 0"):
        hv.Light((0, 0, 1), (1.0, -1.0, 1.0))
    with pytest.raises(ValueError, match="at most 8 lights; got 9"):
        hv.RenderOptions(lights=[(0, 0, 1)] * 9)
    opts = hv.RenderOptions(shade=True, lights=(1, 2, 2))
    assert opts.lights == (hv.Light((1, 2, 2)),)
    np.testing.assert_allclose(opts.lights[0].unit_direction, (1 / 3, 2 / 3, 2 / 3), rtol=1e-15)
    assert hv.RenderOptions(shade=True).light_list == (hv.Light(),)


def test_metadata_records_the_lighting():
    img = hv.render(np.random.default_rng(0).random((8, 8, 8)), None, None, (8, 8), shade=True,
                    lights=[hv.Light((0, 0, 1), 2.0)])
    assert img.metadata["shading"] == {
        "ambient": 0.1, "diffuse": 0.7, "specular": 0.2, "specular_power": 10.0, "shade_gradient": "sampled",
        "shade_threshold": 0.01, "lights": [{"direction": (0.0, 0.0, 1.0), "intensity": [2.0, 2.0, 2.0]}]}
    assert math.isfinite(float(img.rgba.sum()))
