"""Lighting of depth and attenuation proxies (pv_hdrvol.proxy.lighting) against analytic values.

notes/methods.md Part B: T-PX-7 (normals from depth), T-PX-8 (ambient occlusion and the
unsharp-masking baseline), T-PX-15 (depth-aware enhancement); also Blinn-Phong against
the ray caster's own shading helper and the compositing of semi-transparent layers.
"""
import doctest
import math

import numpy as np
import pytest

from pv_hdrvol.params import Light
from pv_hdrvol.proxy import lighting
from pv_hdrvol.proxy.lighting import (ambient_occlusion, composite_layers, enhance, normals_from_depth,
                                      occlusion_sum, shade, unsharp_occlusion)

pytestmark = pytest.mark.core

PITCH = 0.5
RADIUS = 30.0  # world units: 60 pixels
CENTRE = 100.0  # depth of the sphere's centre


def eye_grid(rows, cols, pitch):
    """World ``(x, y)`` of the pixel centres: x right, y up, origin at the image centre."""
    x = (np.arange(cols) + 0.5 - cols / 2) * pitch
    y = (rows / 2 - np.arange(rows) - 0.5) * pitch
    return np.meshgrid(x, y)


def sphere(concave=False, size=160):
    """Depth of the front (or, ``concave``, the inside of the back) of a sphere; inf outside."""
    x, y = eye_grid(size, size, PITCH)
    r2 = x * x + y * y
    h = np.sqrt(np.maximum(RADIUS**2 - r2, 0.0))
    z = np.where(r2 < RADIUS**2, CENTRE + h if concave else CENTRE - h, np.inf)
    return x, y, np.sqrt(r2), z


def away_from_silhouette(r, pixels=3):
    return r < RADIUS - pixels * PITCH


# -- T-PX-7: normals -------------------------------------------------------------------
def test_tilted_plane_normals_are_exact_everywhere_even_beside_holes():
    x, y = eye_grid(40, 50, PITCH)
    a, b = 0.37, -1.3  # dZ/dx, dZ/dy (world per world)
    z = 7.0 + a * x + b * y
    z[10:13, 20:30] = np.inf  # a hole: one-sided differences around it
    z[30, 5] = np.nan
    n = normals_from_depth(z, PITCH)
    expected = np.array([a, b, 1.0]) / math.sqrt(a * a + b * b + 1.0)
    hit = np.isfinite(z)
    assert np.abs(n[hit] - expected).max() < 1e-12
    assert np.isnan(n[~hit]).all()


def test_sphere_normals_within_2_degrees_away_from_the_silhouette():
    x, y, r, z = sphere()
    n = normals_from_depth(z, PITCH)
    analytic = np.stack([x, y, np.sqrt(np.maximum(RADIUS**2 - r * r, 0.0))], axis=-1) / RADIUS
    inside = away_from_silhouette(r)
    angle = np.degrees(np.arccos(np.clip(np.sum(n * analytic, axis=-1), -1.0, 1.0)))
    assert angle[inside].max() <= 2.0
    # orientation: right half faces right, top half faces up, all face the viewer
    assert (n[inside & (x > 1.0), 0] > 0).all() and (n[inside & (x < -1.0), 0] < 0).all()
    assert (n[inside & (y > 1.0), 1] > 0).all() and (n[inside & (y < -1.0), 1] < 0).all()
    assert (n[np.isfinite(z), 2] > 0).all()
    assert np.isnan(n[~np.isfinite(z)]).all()
    np.testing.assert_allclose(np.linalg.norm(n[np.isfinite(z)], axis=-1), 1.0, rtol=0, atol=1e-14)


def test_depth_step_between_two_planes_keeps_each_planes_normal():
    x, y = eye_grid(20, 30, 1.0)
    z = 3.0 + 0.5 * x - 0.25 * y
    z[:, 15:] += 40.0  # a step of 40 pixels: an edge, not a slope
    n = normals_from_depth(z, 1.0)
    expected = np.array([0.5, -0.25, 1.0]) / math.sqrt(1.3125)
    assert np.abs(n - expected).max() < 1e-12
    # a slope of 3 pitch per pixel is below the threshold of 4, so it is a slope
    n = normals_from_depth(3.0 * x, 1.0)
    expected = np.broadcast_to(np.array([3.0, 0.0, 1.0]) / math.sqrt(10.0), n.shape)
    np.testing.assert_allclose(n, expected, rtol=0, atol=1e-12)
    # with discontinuity=2 the same slope is taken for edges on both sides: the smaller
    # one-sided difference (both 3) is still the slope
    np.testing.assert_allclose(normals_from_depth(3.0 * x, 1.0, discontinuity=2.0), n, rtol=0, atol=1e-12)


def test_isolated_pixel_faces_the_viewer_and_mirroring_negates_x():
    z = np.full((5, 5), np.inf)
    z[2, 2] = 4.0
    np.testing.assert_array_equal(normals_from_depth(z, 1.0)[2, 2], [0.0, 0.0, 1.0])
    rng = np.random.default_rng(3)
    z = rng.random((17, 19)) * 6.0
    z[rng.random(z.shape) < 0.2] = np.inf
    n = normals_from_depth(z, 0.7)
    m = normals_from_depth(z[:, ::-1], 0.7)[:, ::-1]
    np.testing.assert_array_equal(m[..., 0], -n[..., 0])
    np.testing.assert_array_equal(m[..., 1:], n[..., 1:])


# -- T-PX-8: ambient occlusion -------------------------------------------------------
def test_planes_are_not_occluded():
    rows, cols = np.mgrid[0:48, 0:48].astype(float)
    dyadic = 5.0 + 0.25 * rows - 0.5 * cols  # every operation exact: the sum is 0 exactly
    ao, count = occlusion_sum(dyadic, 1.0)
    assert (ao == 0.0).all()
    assert count[24, 24] == 196 and count[0, 0] == 57  # the disc of radius 8 without its centre; its quarter
    x, y = eye_grid(48, 48, 0.3)
    plane = 11.0 + 0.37 * x + 1.7 * y
    ao, _ = occlusion_sum(plane, 0.3)
    assert ao.max() < 196 * 16 * np.finfo(float).eps * np.abs(plane).max()  # rounding of 196 terms
    assert (ambient_occlusion(plane, 0.3) > 1.0 - 1e-12).all()


def test_convex_sphere_is_not_occluded_away_from_the_silhouette():
    _, _, r, z = sphere()
    ao, _ = occlusion_sum(z, PITCH)
    inside = away_from_silhouette(r)
    assert ao[inside].max() <= 1e-12
    assert np.isnan(ao[~np.isfinite(z)]).all()
    factor = ambient_occlusion(z, PITCH)
    assert factor[inside].min() >= 1.0 - 1e-12
    assert (factor[~np.isfinite(z)] == 1.0).all()


def brute_force_gradient(z, i, j, threshold):
    """The documented derivative rule at one pixel, with plain Python: (d/drow, d/dcol)."""
    rows, cols = z.shape

    def one(axis):
        def at(k):
            ii, jj = (i + k, j) if axis == 0 else (i, j + k)
            if 0 <= ii < rows and 0 <= jj < cols and math.isfinite(z[ii, jj]):
                return z[ii, jj]
            return None
        lo, hi = at(-1), at(1)
        fwd = None if hi is None else hi - z[i, j]
        bwd = None if lo is None else z[i, j] - lo
        if fwd is not None and bwd is not None and abs(fwd) <= threshold and abs(bwd) <= threshold:
            return 0.5 * (hi - lo)
        sides = [d for d in (fwd, bwd) if d is not None]
        if not sides:
            return 0.0
        if len(sides) == 2 and abs(fwd) == abs(bwd):
            return 0.5 * (hi - lo)
        return min(sides, key=abs)
    return one(0), one(1)


def brute_force_eq5(z, i, j, radius, threshold):
    """Eq. (5) at pixel (i, j) by a loop over the disc; and the number of neighbours."""
    gr, gc = brute_force_gradient(z, i, j, threshold)
    total, count = 0.0, 0
    for qi in range(i - radius, i + radius + 1):
        for qj in range(j - radius, j + radius + 1):
            if (qi, qj) == (i, j) or (qi - i) ** 2 + (qj - j) ** 2 > radius * radius:
                continue
            if not (0 <= qi < z.shape[0] and 0 <= qj < z.shape[1]) or not math.isfinite(z[qi, qj]):
                continue
            count += 1
            total += max(0.0, z[i, j] + gr * (qi - i) + gc * (qj - j) - z[qi, qj])
    return total, count


def test_concave_bowl_is_occluded_and_matches_a_direct_evaluation_of_eq5():
    _, _, r, z = sphere(concave=True)
    ao, count = occlusion_sum(z, PITCH)
    inside = away_from_silhouette(r, pixels=10)
    assert ao[inside].min() > 0.0
    factor = ambient_occlusion(z, PITCH)
    assert factor[inside].max() < 1.0
    for i, j in [(80, 80), (60, 95), (45, 70), (110, 40), (27, 60)]:
        total, n = brute_force_eq5(z, i, j, 8, 4.0 * PITCH)
        assert count[i, j] == n
        assert ao[i, j] == pytest.approx(total, rel=1e-12, abs=1e-12)
        assert factor[i, j] == pytest.approx(1.0 - min(total / (n * 8 * PITCH), 1.0), rel=1e-12)


def test_occlusion_sum_matches_the_direct_evaluation_on_rough_depth_with_misses():
    rng = np.random.default_rng(7)
    z = rng.random((20, 23)) * 3.0
    z[rng.random(z.shape) < 0.25] = np.inf
    z[5, 5] = np.nan
    ao, count = occlusion_sum(z, 0.5, radius=3, discontinuity=2.0)
    for i in range(z.shape[0]):
        for j in range(z.shape[1]):
            if not math.isfinite(z[i, j]):
                assert math.isnan(ao[i, j]) and count[i, j] == 0
                continue
            total, n = brute_force_eq5(z, i, j, 3, 2.0 * 0.5)
            assert count[i, j] == n
            assert ao[i, j] == pytest.approx(total, rel=1e-12, abs=1e-13)


def test_strength_scales_and_clips_the_occlusion():
    _, _, r, z = sphere(concave=True)
    ao, count = occlusion_sum(z, PITCH)
    norm = ao / (count * 8 * PITCH)
    i, j = 80, 80
    for strength in (0.0, 0.5, 3.0, 1e6):
        f = ambient_occlusion(z, PITCH, strength=strength)
        assert f[i, j] == pytest.approx(1.0 - min(strength * norm[i, j], 1.0), rel=1e-12, abs=1e-15)
        assert ((f >= 0.0) & (f <= 1.0)).all()
    assert (ambient_occlusion(z, PITCH, strength=0.0) == 1.0).all()
    assert (ambient_occlusion(z, PITCH, strength=1e6)[away_from_silhouette(r, 10)] == 0.0).all()


def test_unsharp_baseline_darkens_the_sphere_silhouette_and_ours_does_not():
    _, _, r, z = sphere()
    ours = ambient_occlusion(z, PITCH)
    baseline = unsharp_occlusion(z, PITCH)
    pixels = (RADIUS - r) / PITCH  # from the silhouette
    rim = (pixels >= 3) & (pixels < 5)
    assert ours[rim].min() >= 1.0 - 1e-12
    assert baseline[rim].max() < 0.99 and baseline[rim].min() < 0.7
    # the outermost 3 pixels: the baseline is dark (black at the edge); ours barely
    # darkens where the slope is steeper than the discontinuity threshold
    edge = (pixels >= 0) & (pixels < 3)
    assert baseline[edge].mean() < 0.5 and baseline[edge].min() == 0.0
    assert ours[edge].min() > 0.9
    # the centre's neighbourhood is farther away: no darkening there in either method
    assert (baseline[r < RADIUS / 2] == 1.0).all()
    assert (baseline[~np.isfinite(z)] == 1.0).all()
    assert ((baseline >= 0.0) & (baseline <= 1.0)).all()
    # the bowl's neighbourhood is nearer: the baseline darkens its middle as well
    _, _, _, bowl = sphere(concave=True)
    assert unsharp_occlusion(bowl, PITCH)[r < RADIUS / 2].max() < 1.0


def test_unsharp_baseline_is_the_normalised_gaussian_difference():
    z = np.full((50, 50), np.inf)
    z[10:40, 10:40] = 5.0
    z[18:22, 18:22] = 4.0  # a nearer block in the middle of a flat square
    f = unsharp_occlusion(z, 1.0, radius=4)
    # the flat square next to the block sees a nearer neighbourhood: darker
    assert f[17, 20] < 1.0 and f[20, 16] < 1.0
    # the block's top is nearer than its surroundings: not darkened; misses stay 1
    assert f[20, 20] == 1.0 and f[0, 0] == 1.0
    # beyond the kernel's reach (8 pixels) from the block the square is flat, and the
    # missing pixels around it are left out
    assert f[36, 36] == pytest.approx(1.0, abs=1e-12) and f[10, 36] == pytest.approx(1.0, abs=1e-12)
    # the value at one pixel, by a direct sum of the sampled Gaussian (sigma = 2, 8 taps)
    k = np.arange(-8, 9)
    g = np.exp(-0.5 * (k / 2.0) ** 2)
    w = np.outer(g, g)
    patch = z[9:26, 12:29]  # centred on (17, 20)
    ok = np.isfinite(patch)
    blur = np.sum(w[ok] * patch[ok]) / np.sum(w[ok])
    assert f[17, 20] == pytest.approx(1.0 - max(z[17, 20] - blur, 0.0) / 4.0, rel=1e-12)


# -- Blinn-Phong -----------------------------------------------------------------------
def test_shade_equals_a_hand_computed_blinn_phong_value():
    n = np.array([0.6, 0.0, 0.8])
    normals = np.tile(n, (2, 3, 1))
    color = np.array([0.2, 0.5, 1.0])
    # a world light along +x with the identity camera frame looking down -z: eye l = (1, 0, 0)
    basis = (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, -1.0]))
    light = Light((2.0, 0.0, 0.0), intensity=(1.0, 0.5, 2.0))
    out = shade(normals, color, [light], ambient=0.1, diffuse=0.7, specular=0.3, specular_power=4.0,
                basis=basis)
    ndl = 0.6
    ndh = (0.6 + 0.8) / math.sqrt(2.0)  # h = (1, 0, 1) / sqrt(2)
    intensity = np.array([1.0, 0.5, 2.0])
    expected = color * (0.1 + 0.7 * intensity * ndl) + 0.3 * intensity * ndh**4
    np.testing.assert_allclose(out, np.broadcast_to(expected, out.shape), rtol=1e-14, atol=0)
    # the default headlight: n.l = n.h = 0.8
    out = shade(normals, color)
    np.testing.assert_allclose(out[0, 0], color * (0.1 + 0.7 * 0.8) + 0.2 * 0.8**10, rtol=1e-14)


def test_shade_is_two_sided_skips_lights_behind_and_leaves_no_surface_black():
    normals = np.zeros((2, 2, 3))
    normals[0, 0] = (0.0, 0.0, 1.0)
    normals[0, 1] = (0.0, 0.0, -3.0)  # turned towards the eye, any length
    normals[1, 0] = np.nan
    # normals[1, 1] is the zero vector: no direction, no surface
    color = np.full((2, 2, 3), 0.5)
    color[0, 1] = (1.0, 2.0, 4.0)  # per-pixel HDR colour
    out = shade(normals, color, ambient=0.25, diffuse=0.5, specular=0.0)
    np.testing.assert_allclose(out[0, 0], 0.5 * 0.75, rtol=1e-15)
    np.testing.assert_allclose(out[0, 1], np.array([1.0, 2.0, 4.0]) * 0.75, rtol=1e-15)
    assert (out[1] == 0.0).all()
    # a light behind the surface: ambient only (no diffuse and no highlight)
    basis = (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, -1.0]))
    out = shade(normals, color, [Light((0.0, 0.0, -1.0))], ambient=0.25, specular=1.0, basis=basis)
    np.testing.assert_allclose(out[0, 0], 0.5 * 0.25, rtol=1e-15)


def test_shade_matches_the_ray_casters_light_factors():
    from pv_hdrvol.raycast import _shading_kernels as SK

    rng = np.random.default_rng(11)
    # a camera frame (right, up, forward) of some rotation
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    right, up, back = q[:, 0], q[:, 1], q[:, 2]
    forward = -back  # right x up = back = -forward: a right-handed eye frame
    lights = [Light(), Light(tuple(rng.normal(size=3)), intensity=(0.3, 1.2, 0.7)),
              Light(tuple(rng.normal(size=3)), intensity=0.6)]
    normals = rng.normal(size=(4, 5, 3))
    color = rng.random((4, 5, 3)) * 2.0
    ka, kd, ks, p = 0.15, 0.6, 0.4, 7.0
    out = shade(normals, color, lights, ambient=ka, diffuse=kd, specular=ks, specular_power=p,
                basis=(right, up, forward))

    shading = np.zeros(SK.SHADING_SIZE)
    shading[SK.SH_AMBIENT], shading[SK.SH_DIFFUSE], shading[SK.SH_SPECULAR], shading[SK.SH_POWER] = ka, kd, ks, p
    table = np.zeros((len(lights), SK.LIGHT_COLUMNS))
    for k, light in enumerate(lights):
        if light.is_headlight:
            table[k, 6] = 1.0
        else:
            table[k, :3] = light.unit_direction
        table[k, 3:6] = light.intensity
    eye = -forward
    for i in range(4):
        for j in range(5):
            g = normals[i, j, 0] * right + normals[i, j, 1] * up + normals[i, j, 2] * back  # eye -> world
            m0, m1, m2, k0, k1, k2 = SK.light_factors(g[0], g[1], g[2], eye[0], eye[1], eye[2], 1.0, shading, table)
            expected = np.array([m0, m1, m2]) * color[i, j] + np.array([k0, k1, k2])
            np.testing.assert_allclose(out[i, j], expected, rtol=1e-12, atol=1e-14)


def test_shade_rejects_world_lights_without_a_frame_and_bad_frames():
    normals = np.zeros((1, 1, 3))
    normals[..., 2] = 1.0
    with pytest.raises(ValueError, match=r"lights\[1\] has the world direction .* pass basis="):
        shade(normals, (1, 1, 1), [Light(), Light((1, 0, 0))])
    with pytest.raises(ValueError, match="basis must be orthonormal"):
        shade(normals, (1, 1, 1), [(1, 0, 0)], basis=((1, 0, 0), (1, 1, 0), (0, 0, 1)))
    with pytest.raises(ValueError, match=r"basis must be \(right, up, forward\), three 3-vectors; got shape"):
        shade(normals, (1, 1, 1), basis=((1, 0, 0), (0, 1, 0)))
    with pytest.raises(ValueError, match=r"color must have shape \(3,\) or \(1, 1, 3\)"):
        shade(normals, (1, 1))
    with pytest.raises(ValueError, match=r"normals must have shape \(rows, cols, 3\)"):
        shade(np.zeros((3, 3)), (1, 1, 1))
    with pytest.raises(ValueError, match="specular_power must be >= 1"):
        shade(normals, (1, 1, 1), specular_power=0.5)
    with pytest.raises(ValueError, match="ambient must be >= 0"):
        shade(normals, (1, 1, 1), ambient=-0.1)
    with pytest.raises(TypeError, match="lights must be None, a Light"):
        shade(normals, (1, 1, 1), lights=5)
    # a headlight needs no frame
    assert shade(normals, (1, 1, 1), Light()).shape == (1, 1, 3)


# -- T-PX-15: enhancement --------------------------------------------------------------
def test_constant_attenuation_leaves_the_colour_exactly_unchanged():
    rng = np.random.default_rng(5)
    color = rng.random((12, 14, 3)) * 5.0
    atten = np.stack([np.full((12, 14), v) for v in (0.1, 0.0, 0.35, 0.2)])
    out = enhance(color, atten, strength=3.0, contrast=0.3)
    np.testing.assert_array_equal(out, color)
    rgba = rng.random((12, 14, 4))
    np.testing.assert_array_equal(enhance(rgba, atten), rgba)


def test_linear_attenuation_ramps_give_the_analytic_factor():
    rows, cols, L = 10, 16, 5
    slopes = np.array([0.01, -0.02, 0.005, 0.0, 0.03])  # per pixel, along x (columns)
    atten = slopes[:, None, None] * np.arange(cols)[None, None, :] + np.zeros((L, rows, 1))
    color = np.full((rows, cols, 3), 2.0)
    for strength, contrast in [(1.0, 0.5), (2.0, 0.7), (5.0, 1.0)]:
        out = enhance(color, atten, strength=strength, contrast=contrast)
        r = min(strength * np.sum(slopes**2) ** contrast, 1.0)
        np.testing.assert_allclose(out, 2.0 * (1.0 - r), rtol=1e-12)  # np.gradient is exact on a line
    # the same slope g in every interval, along y: r = strength (L g^2)^contrast
    g = 0.04
    atten = g * np.arange(rows)[None, :, None] + np.zeros((L, 1, cols))
    out = enhance(color, atten, strength=0.5, contrast=0.5)
    np.testing.assert_allclose(out, 2.0 * (1.0 - 0.5 * math.sqrt(L * g * g)), rtol=1e-12)
    # r clips at 1: black
    assert (enhance(color, 100.0 * atten) == 0.0).all()


def test_enhancement_scales_premultiplied_colour_and_keeps_alpha():
    atten = 0.1 * np.arange(8.0)[None, None, :] + np.zeros((1, 6, 1))
    rgba = np.zeros((6, 8, 4))
    rgba[...] = (0.2, 0.4, 0.1, 0.5)
    out = enhance(rgba, atten)
    np.testing.assert_allclose(out[..., :3], rgba[..., :3] * 0.9, rtol=1e-12)
    np.testing.assert_array_equal(out[..., 3], 0.5)


def test_enhancement_edges_are_darkened_where_attenuation_changes():
    atten = np.zeros((2, 9, 9))
    atten[0, :, 5:] = 0.3  # an edge between columns 4 and 5
    out = enhance(np.ones((9, 9, 3)), atten)
    np.testing.assert_allclose(out[:, 4], 0.85, rtol=1e-12)  # central difference 0.15
    np.testing.assert_allclose(out[:, 5], 0.85, rtol=1e-12)
    assert (out[:, :4] == 1.0).all() and (out[:, 6:] == 1.0).all()


# -- semi-transparent layers -----------------------------------------------------------
def test_composite_layers_sorts_by_depth_per_pixel():
    red, green, blue = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    colors = np.zeros((3, 1, 3, 3))
    colors[0], colors[1], colors[2] = red, green, blue
    depths = np.array([[[3.0, 1.0, 2.0]],    # red
                       [[1.0, np.inf, 5.0]],  # green misses pixel 1
                       [[2.0, 2.0, np.nan]]])  # blue misses pixel 2
    opacities = np.array([0.5, 0.25, 0.8])
    out = composite_layers(colors, opacities, depths)

    def over(layers):
        c, a = np.zeros(3), 0.0
        for rgb, alpha in layers:
            c = c + (1.0 - a) * alpha * np.array(rgb)
            a = a + (1.0 - a) * alpha
        return np.append(c, a)
    np.testing.assert_allclose(out[0, 0], over([(green, 0.25), (blue, 0.8), (red, 0.5)]), rtol=1e-15)
    np.testing.assert_allclose(out[0, 1], over([(red, 0.5), (blue, 0.8)]), rtol=1e-15)
    np.testing.assert_allclose(out[0, 2], over([(red, 0.5), (green, 0.25)]), rtol=1e-15)
    # by hand, pixel 0: green 0.25; blue 0.75 * 0.8 = 0.6; red 0.15 * 0.5 = 0.075
    np.testing.assert_allclose(out[0, 0], [0.075, 0.25, 0.6, 0.925], rtol=1e-15)


def test_composite_layers_per_pixel_opacity_ties_and_no_hits():
    colors = np.zeros((2, 2, 2, 3))
    colors[0] = (1.0, 1.0, 1.0)
    colors[1] = np.nan  # never read: layer 1 misses every pixel
    depths = np.full((2, 2, 2), np.inf)
    depths[0, 0, 0] = 1.0
    opacities = np.zeros((2, 2, 2))
    opacities[0, 0, 0] = 0.3
    out = composite_layers(colors, opacities, depths)
    np.testing.assert_allclose(out[0, 0], [0.3, 0.3, 0.3, 0.3], rtol=1e-15)
    assert (out.reshape(-1, 4)[1:] == 0.0).all()
    # equal depths keep the given order
    colors = np.zeros((2, 1, 1, 3))
    colors[0], colors[1] = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    out = composite_layers(colors, [1.0, 1.0], np.ones((2, 1, 1)))
    np.testing.assert_array_equal(out[0, 0], [1.0, 0.0, 0.0, 1.0])


# -- validation, extremes, the caller's arrays ---------------------------------------
def test_bad_inputs_are_rejected_with_the_value_and_what_is_allowed():
    z = np.zeros((8, 8))
    with pytest.raises(ValueError, match="radius must be >= 1 pixel; got 0"):
        ambient_occlusion(z, 1.0, radius=0)
    with pytest.raises(TypeError, match=r"radius must be an integer number of pixels; got 2.5"):
        occlusion_sum(z, 1.0, radius=2.5)
    with pytest.raises(ValueError, match="radius must be <= 256 pixels; got 300"):
        unsharp_occlusion(z, 1.0, radius=300)
    with pytest.raises(ValueError, match="pitch must be > 0.0; got 0"):
        normals_from_depth(z, 0)
    with pytest.raises(TypeError, match="pitch must be a real number"):
        normals_from_depth(z, "1")
    with pytest.raises(ValueError, match="discontinuity must be > 0.0; got -1"):
        normals_from_depth(z, 1.0, discontinuity=-1)
    with pytest.raises(ValueError, match=r"depth must be a 2-D array \(rows, cols\); got shape \(2, 8, 8\)"):
        ambient_occlusion(np.zeros((2, 8, 8)), 1.0)
    with pytest.raises(TypeError, match="depth must be a real float or integer array; got dtype complex128"):
        normals_from_depth(z.astype(complex), 1.0)
    with pytest.raises(ValueError, match="strength must be >= 0.0; got -2"):
        ambient_occlusion(z, 1.0, strength=-2)
    with pytest.raises(ValueError, match="contrast must be > 0.0; got 0"):
        enhance(np.zeros((8, 8, 3)), np.zeros((1, 8, 8)), contrast=0)
    with pytest.raises(ValueError, match=r"atten must have shape \(L, rows, cols\) = \(L, 8, 8\)"):
        enhance(np.zeros((8, 8, 3)), np.zeros((1, 8, 7)))
    with pytest.raises(ValueError, match="atten must be finite"):
        enhance(np.zeros((8, 8, 3)), np.full((1, 8, 8), np.nan))
    with pytest.raises(ValueError, match=r"color must have shape \(rows, cols, 3\) or \(rows, cols, 4\)"):
        enhance(np.zeros((8, 8, 2)), np.zeros((1, 8, 8)))
    with pytest.raises(ValueError, match=r"opacities must be in \[0, 1\]"):
        composite_layers(np.zeros((1, 8, 8, 3)), [1.5], np.zeros((1, 8, 8)))
    with pytest.raises(ValueError, match=r"opacities must have shape \(k,\) = \(1,\)"):
        composite_layers(np.zeros((1, 8, 8, 3)), [0.5, 0.5], np.zeros((1, 8, 8)))
    with pytest.raises(ValueError, match=r"colors must have shape \(k, rows, cols, 3\) = \(1, 8, 8, 3\)"):
        composite_layers(np.zeros((2, 8, 8, 3)), [0.5], np.zeros((1, 8, 8)))
    with pytest.raises(ValueError, match=r"depths must have shape \(k, rows, cols\)"):
        composite_layers(np.zeros((1, 8, 8, 3)), [0.5], np.zeros((8, 8)))


def test_all_misses_one_pixel_and_float32():
    miss = np.full((6, 7), np.inf)
    assert np.isnan(normals_from_depth(miss, 1.0)).all()
    assert (ambient_occlusion(miss, 1.0) == 1.0).all()
    assert (unsharp_occlusion(miss, 1.0) == 1.0).all()
    assert (shade(normals_from_depth(miss, 1.0), (1, 1, 1)) == 0.0).all()
    one = np.array([[2.0]])
    np.testing.assert_array_equal(normals_from_depth(one, 1.0)[0, 0], [0.0, 0.0, 1.0])
    assert ambient_occlusion(one, 1.0)[0, 0] == 1.0
    assert occlusion_sum(one, 1.0)[1][0, 0] == 0.0
    np.testing.assert_array_equal(enhance(np.ones((1, 1, 3)), np.zeros((3, 1, 1))), 1.0)
    x, y = eye_grid(16, 16, 1.0)
    plane = (3.0 + 0.5 * x).astype(np.float32)  # exact in float32
    np.testing.assert_allclose(normals_from_depth(plane, 1.0)[..., 0], 0.5 / math.sqrt(1.25), rtol=1e-15)
    assert normals_from_depth(plane, 1.0).dtype == np.float64


def test_the_callers_arrays_are_not_modified():
    _, _, _, z = sphere(size=48)
    z[3, 3] = np.nan
    z.setflags(write=False)  # any write raises
    before = z.copy()
    n = normals_from_depth(z, PITCH)
    occlusion_sum(z, PITCH)
    ambient_occlusion(z, PITCH)
    unsharp_occlusion(z, PITCH)
    n.setflags(write=False)
    color = np.full(n.shape, 0.5)
    color.setflags(write=False)
    shade(n, color)
    atten = np.stack([np.where(np.isfinite(z), 0.5, 0.0), np.zeros(z.shape)])
    atten.setflags(write=False)
    enhance(color, atten)
    depths = np.stack([z, z + 1.0])
    depths.setflags(write=False)
    colors = np.stack([color, color])
    colors.setflags(write=False)
    composite_layers(colors, np.array([0.5, 0.5]), depths)
    np.testing.assert_array_equal(z, before)


def test_docstring_examples():
    result = doctest.testmod(lighting, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0
    assert result.failed == 0
