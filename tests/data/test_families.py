"""Transfer-function families in extinction space (Gao et al. 2003, Eqs. 2-3):
``tau' = sum_i k_i tau_i`` gives every ray the opacity ``1 - prod_i (1 - a_i)^{k_i}``."""
import json

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.data.transfer import TransferFunctionFamily

pytestmark = pytest.mark.core

LEVELS = np.arange(256.0)


def _bases(n=2):
    rng = np.random.default_rng(7)
    out = []
    for i in range(n):
        opacity = np.clip(rng.random(256) * 0.08 - 0.02, 0.0, 1.0)
        colors = np.tile(rng.random(3) + 0.1, (256, 1))
        out.append(hv.TransferFunction(LEVELS, colors, opacity, table_size=256))
    return out


def _on_entries_volume():
    """Values vary along x only between rays, and every sample lands on a table entry:
    even integers, sampled halfway between points with step 1 along x."""
    rng = np.random.default_rng(3)
    return (2 * rng.integers(0, 128, size=(6, 5, 40))).astype(np.float64)


def _x_camera(values):
    nz, ny, nx = values.shape
    cy, cz = (ny - 1) / 2, (nz - 1) / 2
    cam = hv.Camera((-10.0, cy, cz), ((nx - 1) / 2, cy, cz), (0, 0, 1), parallel_projection=True,
                    parallel_scale=nz / 2)
    return cam, (ny, nz)


def _alpha(values, tf, precision="float64"):
    cam, size = _x_camera(values)
    image = hv.render(values, tf, cam, size, precision=precision, step=1.0, termination=0.0, progress_bar=False)
    return image.rgba[..., 3].astype(np.float64)


@pytest.mark.parametrize("k", [(0.0, 1.0), (0.25, 0.9), (0.8, 0.5), (3.0, 0.1)])
def test_family_ray_opacity_is_the_product_of_the_bases(k):
    """Eq. (3), per ray, in float64: exact up to rounding (1e-12)."""
    values = _on_entries_volume()
    skin, bone = _bases()
    family = hv.TransferFunction.family([skin, bone], k)
    a = _alpha(values, family)
    a_skin, a_bone = _alpha(values, skin), _alpha(values, bone)
    expected = 1.0 - (1.0 - a_skin) ** k[0] * (1.0 - a_bone) ** k[1]
    assert a.max() > 0.3  # the rays are far from transparent
    np.testing.assert_allclose(a, expected, rtol=0, atol=1e-12)


def test_scaling_opacity_instead_of_extinction_is_not_exact():
    """The counter-example: ``a -> k a`` overestimates the ray opacity for ``k < 1``
    (Bernoulli: ``1 - (1 - a)^k >= k a`` per sample, and products do not commute with it)."""
    values = _on_entries_volume()
    (skin,) = _bases(1)
    k = 0.25
    exact = 1.0 - (1.0 - _alpha(values, skin)) ** k
    by_extinction = _alpha(values, hv.TransferFunction.family([skin], [k]))
    by_opacity = _alpha(values, hv.TransferFunction(LEVELS, skin.colors, k * skin.opacities, table_size=256))
    np.testing.assert_allclose(by_extinction, exact, rtol=0, atol=1e-12)
    assert np.all(by_opacity <= exact + 1e-15)
    assert (exact - by_opacity).max() > 1e-3


def test_family_opacity_and_colour_at_values():
    skin, bone = _bases()
    family = TransferFunctionFamily([skin, bone], [0.5, 2.0])
    v = np.linspace(0, 255, 97)
    a0, a1 = skin.opacity_at(v), bone.opacity_at(v)
    np.testing.assert_allclose(family.opacity_at(v), 1 - (1 - a0) ** 0.5 * (1 - a1) ** 2.0, rtol=1e-14, atol=1e-16)
    s0, s1 = -0.5 * np.log1p(-a0), -2.0 * np.log1p(-a1)
    total = np.where(s0 + s1 > 0, s0 + s1, 1.0)
    mixed = (s0[:, None] * skin.color_at(v) + s1[:, None] * bone.color_at(v)) / total[:, None]
    where = (s0 + s1) > 0
    np.testing.assert_allclose(family.color_at(v)[where], mixed[where], rtol=1e-14)
    # the table's extinction is the weighted sum of the bases' on the same entries
    _, sigma = family.table(np.float64, 1.0, 2.0)
    np.testing.assert_allclose(sigma, (0.5 * skin.table(np.float64, 1.0, 2.0)[1]
                                       + 2.0 * bone.table(np.float64, 1.0, 2.0)[1]), rtol=1e-14, atol=0)


def test_changing_weights_keeps_the_bases_and_round_trips_through_json():
    skin, bone = _bases()
    family = hv.TransferFunction.family([skin, bone], [1.0, 1.0])
    other = family.with_weights([0.1, 0.7])
    assert other.bases == family.bases and other.k.tolist() == [0.1, 0.7]
    back = hv.TransferFunction.from_dict(json.loads(json.dumps(other.to_dict())))
    assert isinstance(back, TransferFunctionFamily)
    assert back.k.tolist() == [0.1, 0.7] and back.table_size == other.table_size
    np.testing.assert_array_equal(back.table()[1], other.table()[1])
    # a render keeps the family in its settings
    image = hv.render(_on_entries_volume(), other, size=(8, 8), progress_bar=False)
    assert isinstance(image.settings().tf, TransferFunctionFamily)


@pytest.mark.parametrize("bases, k, error, match", [
    ([], None, ValueError, "needs at least one basis; got none"),
    ("skin", None, TypeError, "bases must be a sequence of TransferFunction; got str"),
    ([1.0], None, TypeError, r"bases\[0\] must be a TransferFunction \(not a family\); got float"),
    (None, [1.0, -0.5], ValueError, r"family weights k must be finite and >= 0; got \[1.0, -0.5\]"),
    (None, [1.0], ValueError, r"k must have one weight per basis \(2\); got 1"),
])
def test_bad_families_are_refused(bases, k, error, match):
    if bases is None:
        bases = _bases()
    with pytest.raises(error, match=match):
        hv.TransferFunction.family(bases, k)


def test_bases_must_share_the_axis():
    lin = hv.TransferFunction([1.0, 10.0], [[1, 1, 1]] * 2, [0.1, 0.2])
    log = hv.TransferFunction([1.0, 10.0], [[1, 1, 1]] * 2, [0.1, 0.2], scale="log")
    with pytest.raises(ValueError, match="the bases of a family must share scale and linthresh"):
        hv.TransferFunction.family([lin, log])
