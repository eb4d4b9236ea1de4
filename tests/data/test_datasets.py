"""The analytic hydrogen orbitals against textbook facts.

Marked ``core``: the numpy-only functions must work on Debian's numpy 1.24 / numba 0.56
(no pyvista, scipy or matplotlib there; tests that need them import them inside).
"""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.datasets import (ARRAY_NAME, default_extent, demo_transfer_function, hydrogen_density,
                                hydrogen_orbital, hydrogen_orbital_array)

pytestmark = pytest.mark.core

# (n, l, m) covering s, p, d, f, real cos and sin parts
ORBITALS = [(1, 0, 0), (2, 0, 0), (2, 1, 0), (2, 1, 1), (2, 1, -1), (3, 2, 0), (3, 2, 1), (3, 2, -2), (4, 3, 3)]


def test_textbook_values():
    # Griffiths' closed forms (a0 = 1): psi_100 = e^-r / sqrt(pi),
    # psi_210 = r e^(-r/2) cos(t) / (4 sqrt(2 pi)), psi_320 = r^2 e^(-r/3) (3 cos^2 t - 1) / (81 sqrt(6 pi))
    assert hydrogen_density(0, 0, 0, 1, 0, 0) == pytest.approx(1 / math.pi, rel=1e-15)
    assert hydrogen_density(0, 1, 0, 1, 0, 0) == pytest.approx(math.exp(-2) / math.pi, rel=1e-14)
    assert hydrogen_density(0, 0, 1, 2, 1, 0) == pytest.approx(math.exp(-1) / (32 * math.pi), rel=1e-14)
    assert hydrogen_density(0, 0, 3, 3, 2, 0) == pytest.approx(4 * math.exp(-2) / (81 * 6 * math.pi), rel=1e-14)
    # p_x along x equals p_z along z
    assert hydrogen_density(2.5, 0, 0, 2, 1, 1) == pytest.approx(hydrogen_density(0, 0, 2.5, 2, 1, 0), rel=1e-14)


def test_matches_scipy_special():
    special = pytest.importorskip("scipy.special")
    rng = np.random.default_rng(1)
    x, y, z = rng.normal(scale=6.0, size=(3, 200))
    r = np.sqrt(x * x + y * y + z * z)
    theta, phi = np.arccos(z / r), np.arctan2(y, x)
    for n in range(1, 5):
        for l in range(n):  # noqa: E741
            rho = 2 * r / n
            radial = (math.sqrt((2 / n) ** 3 * math.factorial(n - l - 1) / (2 * n * math.factorial(n + l)))
                      * np.exp(-rho / 2) * rho ** l * special.genlaguerre(n - l - 1, 2 * l + 1)(rho))
            for m in range(-l, l + 1):
                if hasattr(special, "sph_harm_y"):  # scipy >= 1.15
                    y_c = special.sph_harm_y(l, abs(m), theta, phi)
                else:  # older argument order: (m, l, azimuth, polar)
                    y_c = special.sph_harm(abs(m), l, phi, theta)
                y_r = y_c.real if m == 0 else math.sqrt(2) * (y_c.real if m > 0 else y_c.imag)
                np.testing.assert_allclose(hydrogen_density(x, y, z, n, l, m), (radial * y_r) ** 2,
                                           rtol=1e-11, atol=0, err_msg=f"n={n} l={l} m={m}")


@pytest.mark.parametrize("nlm", ORBITALS)
def test_normalisation(nlm):
    # The default extent leaves out < 1e-6 of the probability. The point sum converges
    # fast for densities that vanish smoothly at the nucleus (l > 0); s states have a
    # cusp there and need a finer grid (observed error 1.8e-3 at 64**3 for 2s, 1.2e-4 at 128**3).
    size, tol = (128, 1e-3) if nlm[1] == 0 else (64, 1e-4)
    values, spacing, _ = hydrogen_orbital_array(*nlm, size=size)
    total = values.sum() * spacing[0] ** 3
    assert abs(total - 1.0) < tol


def test_nodal_planes_are_exact_zeros():
    size = 33  # odd: the planes x = 0, y = 0, z = 0 are grid planes
    c = size // 2
    pz, _, _ = hydrogen_orbital_array(2, 1, 0, size=size, extent=10.0)
    assert np.all(pz[c] == 0.0) and np.all(np.delete(pz, c, axis=0) > 0)
    xz, _, _ = hydrogen_orbital_array(3, 2, 1, size=size, extent=20.0)  # d_xz: x = 0 and z = 0
    assert np.all(xz[:, :, c] == 0.0) and np.all(xz[c] == 0.0)
    xy, _, _ = hydrogen_orbital_array(3, 2, -2, size=size, extent=20.0)  # d_xy: x = 0 and y = 0
    assert np.all(xy[:, :, c] == 0.0) and np.all(xy[:, c] == 0.0)
    x2y2, _, _ = hydrogen_orbital_array(3, 2, 2, size=size, extent=20.0)  # d_x2-y2: |x| = |y|
    diag = np.arange(size)
    assert np.all(x2y2[:, diag, diag] == 0.0) and np.all(x2y2[:, diag, diag[::-1]] == 0.0)


def test_nodal_cones_and_radial_nodes():
    t = np.linspace(0.5, 30.0, 50)
    # d_z2: 3 cos^2(theta) = 1 along the cube diagonals (zero up to rounding of 3 z^2 - r^2)
    peak = hydrogen_density(0, 0, 6, 3, 2, 0)
    assert np.all(hydrogen_density(t, t, t, 3, 2, 0) < 1e-30 * peak)
    assert np.all(hydrogen_density(t, -t, t, 3, 2, 0) < 1e-30 * peak)
    corners = hydrogen_orbital_array(3, 2, 0, size=64)[0][::63, ::63, ::63]
    assert np.all(corners == 0.0)
    # 3s: L_2^1(rho) = (rho^2 - 6 rho + 6) / 2 vanishes at rho = 3 -+ sqrt(3), r = 3 rho / 2
    peak = hydrogen_density(0, 0, 0, 3, 0, 0)
    for rho in (3 - math.sqrt(3), 3 + math.sqrt(3)):
        assert hydrogen_density(1.5 * rho, 0, 0, 3, 0, 0) < 1e-28 * peak


def test_array_layout_and_dynamic_range():
    values, spacing, origin = hydrogen_orbital_array(size=64)
    assert values.shape == (64, 64, 64) and values.dtype == np.float64 and values.flags.c_contiguous
    assert origin == (-45.0, -45.0, -45.0) and spacing == pytest.approx((90 / 63,) * 3, rel=1e-15)
    assert default_extent(3) == 45.0
    positive = values[values > 0]
    assert np.log10(positive.max() / positive.min()) > 40  # far more than 10 decades
    assert np.all(values >= 0)
    # zyx order: values[k, j, i] sits at x = origin + i * spacing
    k, j, i = 40, 22, 7
    x, y, z = (o + idx * spacing[0] for o, idx in zip(origin, (i, j, k)))
    assert values[k, j, i] == pytest.approx(hydrogen_density(x, y, z), rel=1e-12)
    v32, _, _ = hydrogen_orbital_array(size=8, dtype=np.float32)
    assert v32.dtype == np.float32


def test_pyvista_grid():
    pytest.importorskip("pyvista")
    grid = hydrogen_orbital(3, 2, 1, size=17, extent=12.0)
    values, spacing, origin = hydrogen_orbital_array(3, 2, 1, size=17, extent=12.0)
    assert grid.dimensions == (17, 17, 17)
    assert grid.spacing == pytest.approx(spacing, rel=1e-15) and grid.origin == pytest.approx(origin, abs=0)
    assert grid.active_scalars_name == ARRAY_NAME == "probability_density"
    np.testing.assert_array_equal(grid.point_data[ARRAY_NAME], values.reshape(-1))
    pts = grid.points
    np.testing.assert_allclose(grid.point_data[ARRAY_NAME], hydrogen_density(*pts.T, 3, 2, 1),
                               rtol=1e-9, atol=1e-30)
    assert grid.field_data["quantum_numbers_nlm"].tolist() == [3, 2, 1]


@pytest.mark.parametrize(("kwargs", "exc", "match"), [
    ({"n": 3, "l": 3, "m": 0}, ValueError, r"l must satisfy 0 <= l < n = 3; got l=3"),
    ({"n": 3, "l": 1, "m": -2}, ValueError, r"m must satisfy -l <= m <= l = 1; got m=-2"),
    ({"n": 0, "l": 0, "m": 0}, ValueError, r"n must be >= 1; got 0"),
    ({"n": 2.0, "l": 0, "m": 0}, TypeError, r"n must be an integer; got 2.0"),
    ({"size": 1}, ValueError, r"size must be >= 2; got 1"),
    ({"extent": -1.0}, ValueError, r"extent must be > 0; got -1.0"),
    ({"dtype": np.int32}, TypeError, r"dtype must be float32 or float64; got int32"),
])
def test_bad_arguments(kwargs, exc, match):
    with pytest.raises(exc, match=match):
        hydrogen_orbital_array(**kwargs)


def test_demo_transfer_function_renders_hdr():
    tf = demo_transfer_function(cmap="gray")
    assert (tf.scale, tf.vmin, tf.vmax) == ("log", pytest.approx(1e-13, rel=1e-12), 1e-3)
    assert tf.opacity_at(1e-13) == 0.0 and tf.opacity_at(1e-3) == pytest.approx(0.1)
    # gray at the top is 1; halfway (1e-8) it is 0.5, times (1e-8 / 1e-3)**0.2 = 0.1
    assert tf.color_at(1e-3)[0] / tf.color_at(1e-8)[0] == pytest.approx(20.0, rel=0.01)
    values, spacing, origin = hydrogen_orbital_array(size=24)
    before = values.copy()
    volume = hv.volume_from_array(values, spacing, origin)
    img = hv.render(volume, tf, hv.Camera.fit(volume.bounds, "xz", zoom=1.5), size=16)
    np.testing.assert_array_equal(values, before)
    assert np.isfinite(img.rgba).all()
    assert img.dynamic_range_decades > 4
    with pytest.raises(ValueError, match=r"opacity must hold at least 2 values; got \(0.5,\)"):
        demo_transfer_function(opacity=(0.5,))


def test_demo_transfer_function_default_colormap():
    pytest.importorskip("matplotlib")
    tf = demo_transfer_function()
    np.testing.assert_allclose(tf.color_at(1e-3), [0.987053, 0.991438, 0.749504], atol=1e-6)  # magma's top

