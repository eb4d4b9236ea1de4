"""Attenuation propagation and the TF colour model of "Visualization by Proxy" (§6).

Exact references: a stack of planar slabs per pixel composited by hand (methods.md
T-PX-13), colours that are linear in attenuation (T-PX-10), the LUT layout
(T-PX-11) and a brute-force nearest centroid (T-PX-12). numpy + scipy only.
"""
import numpy as np
import pytest

from pv_hdrvol.proxy.model import ColorModel, nearest_centroid, propagate, propagate_own

pytestmark = pytest.mark.core


# ----------------------------------------------------------------------------- references


def composite_slabs(beta, front_to_back):
    """Attenuation of slabs with opacities ``beta`` (L, P), crossed by each pixel's ray in
    the order ``front_to_back[:, p]`` (interval indices): the hand-written reference."""
    out = np.zeros_like(beta)
    for p in range(beta.shape[1]):
        transmittance = 1.0
        for i in front_to_back[:, p]:
            out[i, p] = beta[i, p] * transmittance
            transmittance *= 1.0 - beta[i, p]
    return out


def random_stack(rng, intervals=6, pixels=300):
    """Slab opacities (some 0, some 1 at the back, some tiny), a random depth order per
    pixel and the matching ``entry`` depths (inf where a slab has no opacity)."""
    beta = rng.uniform(0.0, 0.9, (intervals, pixels))
    beta[rng.random((intervals, pixels)) < 0.2] = 0.0
    beta[rng.random((intervals, pixels)) < 0.05] = 1e-9
    order = np.argsort(rng.random((intervals, pixels)), axis=0)
    opaque = rng.random(pixels) < 0.2  # an opaque slab at the back: nothing hidden behind it
    beta[order[-1, opaque], np.flatnonzero(opaque)] = 1.0
    depth = np.empty((intervals, pixels))
    np.put_along_axis(depth, order, np.arange(intervals, dtype=float)[:, None] + 0.5, axis=0)
    entry = np.where(beta > 0, depth, np.inf)
    return beta, order, entry


def new_opacity(beta, k):
    return 1.0 - (1.0 - beta) ** k[:, None]


# ----------------------------------------------------------------------------- propagation


def test_planar_stack_by_entry_depth_matches_recomposition():
    rng = np.random.default_rng(1)
    beta, order, entry = random_stack(rng)
    atten = composite_slabs(beta, order)
    k = np.array([0.0, 0.3, 1.0, 2.5, 1.0, 7.0])
    expected = composite_slabs(new_opacity(beta, k), order)
    got = propagate(atten, k, entry=entry)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    # the same through (L, rows, cols) and a dict of the changed intervals
    got3 = propagate(atten.reshape(6, 15, 20), {0: 0.0, 1: 0.3, 3: 2.5, 5: 7.0}, entry=entry.reshape(6, 15, 20))
    np.testing.assert_array_equal(got3.reshape(6, -1), got)


@pytest.mark.parametrize("order", ["ascending", "descending"])
def test_planar_stack_in_intensity_order(order):
    rng = np.random.default_rng(2)
    beta, _, _ = random_stack(rng, pixels=100)
    index = np.arange(6)[:, None] * np.ones((1, 100), dtype=int)
    if order == "descending":
        index = index[::-1]
    beta = np.minimum(beta, 0.9)  # an opaque slab only at the back: nothing hidden behind it
    beta[index[-1, :20], np.arange(20)] = 1.0
    atten = composite_slabs(beta, index)
    k = np.array([1.5, 0.0, 0.2, 1.0, 3.0, 0.5])
    got = propagate(atten, k, order=order)
    np.testing.assert_allclose(got, composite_slabs(new_opacity(beta, k), index), rtol=0, atol=1e-12)
    if order == "ascending":  # "depth" without entry means ascending
        np.testing.assert_array_equal(propagate(atten, k), got)


def test_order_by_entry_differs_from_order_by_index():
    # interval 1 is in front (entry 0.5), interval 0 behind it (entry 2); both beta = 0.5
    atten = np.array([[0.25], [0.5]])
    entry = np.array([[2.0], [0.5]])
    # removing the front interval uncovers the back one: its own 0.5
    np.testing.assert_allclose(propagate(atten, {1: 0.0}, entry=entry).ravel(), [0.5, 0.0], atol=1e-15)
    # by index, interval 0 is taken to be in front with beta = 0.25
    np.testing.assert_allclose(propagate(atten, {1: 0.0}, order="ascending").ravel(), [0.25, 0.0], atol=1e-15)
    np.testing.assert_allclose(propagate(atten, {1: 0.0}, order="descending").ravel(), [0.5, 0.0], atol=1e-15)


def test_entry_ties_and_inf_fall_back_to_index_order():
    beta = np.array([[0.5], [0.5], [0.5]])
    atten = composite_slabs(beta, np.array([[0], [1], [2]]))  # 0.5, 0.25, 0.125
    by_index = propagate(atten, {0: 0.0}, order="ascending")
    np.testing.assert_allclose(by_index.ravel(), [0.0, 0.5, 0.25], atol=1e-15)
    for entry in ([1.0, 1.0, 1.0], [np.inf, np.inf, np.inf], [3.0, np.inf, np.inf], [1.0, 2.0, 2.0]):
        np.testing.assert_array_equal(propagate(atten, {0: 0.0}, entry=np.array(entry)[:, None]), by_index)
    # finite depths come before inf: interval 1 (depth 1) is in front of 0 and 2 (inf)
    atten = composite_slabs(beta, np.array([[1], [0], [2]]))  # 0.25, 0.5, 0.125
    got = propagate(atten, {1: 0.0}, entry=np.array([[np.inf], [1.0], [np.inf]]))
    np.testing.assert_allclose(got.ravel(), [0.5, 0.0, 0.25], atol=1e-15)


def test_own_opacity_gives_exact_total_alpha_for_any_order():
    rng = np.random.default_rng(3)
    intervals, pixels = 5, 400
    own = rng.uniform(0, 1, (intervals, pixels))
    own[rng.random((intervals, pixels)) < 0.2] = 0.0
    own[0, :10] = 1.0
    # attenuation of nested shells (an interval crossed twice) is not a slab stack:
    # any attenuation with the right sums serves, the total must still be exact
    atten = rng.dirichlet(np.ones(intervals + 1), pixels).T[:intervals]
    k = rng.uniform(0, 3, intervals)
    k[2] = 0.0
    exact = 1.0 - np.prod((1.0 - own) ** k[:, None], axis=0)
    entries = [None, rng.random((intervals, pixels)), np.full((intervals, pixels), np.inf)]
    for entry in entries:
        got = propagate(atten, k, own=own, entry=entry)
        np.testing.assert_allclose(got.sum(axis=0), exact, rtol=0, atol=1e-14)
        assert np.all(got[2] == 0.0)
    for order in ("ascending", "descending"):
        got = propagate(atten, k, own=own, order=order)
        np.testing.assert_allclose(got.sum(axis=0), exact, rtol=0, atol=1e-14)
    # with slabs in the stated order, own opacity gives the exact split too
    order = np.argsort(rng.random((intervals, pixels)), axis=0)
    entry = np.empty((intervals, pixels))
    np.put_along_axis(entry, order, np.arange(intervals, dtype=float)[:, None], axis=0)
    got = propagate(composite_slabs(own, order), k, own=own, entry=entry)
    np.testing.assert_allclose(got, composite_slabs(new_opacity(own, k), order), rtol=0, atol=1e-14)


def test_zero_scale_removes_interval():
    rng = np.random.default_rng(4)
    beta, order, entry = random_stack(rng)
    atten = composite_slabs(beta, order)
    got = propagate(atten, {3: 0}, entry=entry)
    assert np.all(got[3] == 0.0)
    np.testing.assert_array_equal(propagate(atten, np.zeros(6), entry=entry), np.zeros_like(atten))
    # the own-opacity path too
    np.testing.assert_array_equal(propagate(atten, {3: 0.0}, own=beta)[3], 0.0)


def test_identity_returns_atten():
    rng = np.random.default_rng(5)
    beta, order, entry = random_stack(rng, intervals=16, pixels=500)
    atten = composite_slabs(beta, order)
    for kwargs in ({"entry": entry}, {}, {"order": "descending"}):
        np.testing.assert_array_equal(propagate(atten, np.ones(16), **kwargs), atten)
    saturated = np.array([[0.5], [0.5], [0.0]])  # alpha 1 reached in two intervals
    np.testing.assert_array_equal(propagate(saturated, {}), saturated)
    # own opacities of a slab stack reproduce it
    np.testing.assert_allclose(propagate(atten, np.ones(16), own=beta, entry=entry), atten, rtol=0, atol=1e-15)


def test_slabs_in_front_of_the_first_change_keep_their_attenuation():
    rng = np.random.default_rng(20)
    beta, order, entry = random_stack(rng, intervals=8, pixels=200)
    atten = composite_slabs(beta, order)
    got = propagate(atten, {5: 0.5}, entry=entry)
    in_front = entry < entry[5]
    np.testing.assert_array_equal(got[in_front], atten[in_front])
    np.testing.assert_allclose(got, composite_slabs(new_opacity(beta, np.array([1, 1, 1, 1, 1, 0.5, 1, 1])), order),
                               rtol=0, atol=1e-12)


def test_saturating_slab_does_not_leak():
    # slabs 0.3, 0.8, 1: the recovered opacity of the last is 1 - 4e-16 (rounding);
    # k = 0.1 would turn that into 3 % of light leaking through an opaque slab
    atten = composite_slabs(np.array([[0.3], [0.8], [1.0]]), np.array([[0], [1], [2]]))
    assert atten[2, 0] / (1 - atten[0, 0] - atten[1, 0]) < 1.0
    got = propagate(atten, {2: 0.1}, order="ascending")
    np.testing.assert_allclose(got, atten, rtol=0, atol=1e-15)
    got32 = propagate(atten.astype(np.float32), {2: 0.1}, order="ascending")
    np.testing.assert_allclose(got32.sum(), 1.0, rtol=0, atol=1e-6)


def test_tiny_opacities_keep_relative_accuracy():
    beta = np.full((3, 1), 1e-12)
    atten = composite_slabs(beta, np.array([[0], [1], [2]]))
    got = propagate(atten, [3.0, 0.5, 1.0], order="ascending")
    expected = np.array([3e-12 * (1 - 3e-12), 0.5e-12 * (1 - 3e-12) * (1 - 0.5e-12),
                         1e-12 * (1 - 3e-12) * (1 - 0.5e-12)])
    np.testing.assert_allclose(got.ravel(), expected, rtol=1e-9, atol=0)


def test_opaque_slab_stays_opaque():
    atten = np.array([[1.0], [0.0]])
    np.testing.assert_array_equal(propagate(atten, [0.01, 1.0], order="ascending"), atten)
    np.testing.assert_array_equal(propagate(atten, {0: 0.0}, own=np.array([[1.0], [0.7]])), [[0.0], [0.7]])


def test_propagate_own():
    own = np.array([[0.5, 1.0, 0.0], [0.75, 0.2, 1e-12]])
    got = propagate_own(own, [2.0, 0.5])
    np.testing.assert_allclose(got, [[0.75, 1.0, 0.0], [0.5, 1 - 0.8 ** 0.5, 0.5e-12]], rtol=1e-12, atol=0)
    np.testing.assert_array_equal(propagate_own(own, {1: 0.0})[1], 0.0)
    np.testing.assert_array_equal(propagate_own(own, {}), own)


def test_float32_input():
    atten = np.array([[0.5], [0.25]], dtype=np.float32)
    got = propagate(atten, {0: 0.0})
    assert got.dtype == np.float64
    np.testing.assert_allclose(got.ravel(), [0.0, 0.5])


# ----------------------------------------------------------------------------- colour model


def linear_scene(rng, intervals=16, pixels=3000, empty=(5, 11)):
    """Attenuation of random slab stacks (intervals in ``empty`` never populated) and the
    colour of piecewise-constant interval colours without shading: c = sum_i C_i a_i."""
    beta = rng.uniform(0.0, 0.3, (intervals, pixels))
    beta[list(empty)] = 0.0
    order = np.argsort(rng.random((intervals, pixels)), axis=0)
    atten = np.zeros_like(beta)
    transmittance = np.ones(pixels)
    for m in range(intervals):  # vectorised twin of composite_slabs for speed
        idx = order[m], np.arange(pixels)
        atten[idx] = beta[idx] * transmittance
        transmittance *= 1.0 - beta[idx]
    return atten


def test_linear_colour_identity_k1():
    rng = np.random.default_rng(6)
    interval_rgb = rng.uniform(0, 4, (16, 3))  # HDR: above 1
    atten = linear_scene(rng)
    colors = atten.T @ interval_rgb
    model = ColorModel.fit(atten, colors, clusters=1)
    assert model.clusters == 1 and model.intervals == 16
    populated = np.setdiff1d(np.arange(16), [5, 11])
    np.testing.assert_allclose(model.jacobians[0][:, populated], interval_rgb[populated].T, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(model.jacobians[0][:, [5, 11]], 0.0)
    assert model.residuals[0] < 1e-12
    assert model.counts.tolist() == [3000]
    new = linear_scene(np.random.default_rng(7), pixels=500)
    np.testing.assert_allclose(model.predict(new), new.T @ interval_rgb, rtol=0, atol=1e-9)
    # (L, rows, cols) in -> (rows, cols, 3) out
    image = new.reshape(16, 20, 25)
    np.testing.assert_allclose(model.predict(image), np.einsum("lrc,lk->rck", image, interval_rgb), atol=1e-9)


def test_linear_colour_identity_many_clusters():
    rng = np.random.default_rng(8)
    interval_rgb = rng.uniform(0, 1, (16, 3))
    atten = linear_scene(rng, pixels=4000)
    model = ColorModel.fit(atten, atten.T @ interval_rgb, clusters=6, seed=3)
    assert model.clusters == 6
    assert np.all(model.residuals < 1e-12)
    new = linear_scene(np.random.default_rng(9), pixels=500)
    np.testing.assert_allclose(model.predict(new), new.T @ interval_rgb, rtol=0, atol=1e-9)


def test_colour_at_centroid_is_mean_member_colour_for_one_cluster():
    rng = np.random.default_rng(10)
    atten = linear_scene(rng, intervals=4, pixels=200, empty=())
    colors = rng.uniform(0, 2, (200, 3))  # not linear: the fit has residuals
    model = ColorModel.fit(atten, colors, clusters=1)
    np.testing.assert_allclose(model.centroids[0], atten.mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(model.colors[0], colors.mean(axis=0), rtol=1e-12)
    fitted = model.predict(atten)
    np.testing.assert_allclose(model.residuals[0], np.sqrt(np.mean((fitted - colors) ** 2)), rtol=1e-12)
    # the fit is ordinary least squares with intercept
    design = np.concatenate([np.ones((200, 1)), atten.T], axis=1)
    np.testing.assert_allclose(fitted, design @ np.linalg.lstsq(design, colors, rcond=None)[0], atol=1e-12)


def test_empty_pixels_are_ignored_in_fit_and_black_in_predict():
    rng = np.random.default_rng(11)
    atten = linear_scene(rng, intervals=4, pixels=300, empty=())
    colors = rng.uniform(0, 1, (300, 3))
    padded_a = np.concatenate([atten, np.zeros((4, 50))], axis=1)
    padded_c = np.concatenate([colors, np.full((50, 3), 7.0)], axis=0)
    a = ColorModel.fit(atten, colors, clusters=5)
    b = ColorModel.fit(padded_a, padded_c, clusters=5)
    np.testing.assert_array_equal(a.lut(), b.lut())
    assert np.all(b.predict(np.zeros((4, 3, 2))) == 0.0)


def test_list_of_images_equals_concatenated_pixels():
    rng = np.random.default_rng(12)
    images = [linear_scene(rng, intervals=8, pixels=600, empty=()).reshape(8, 20, 30) for _ in range(3)]
    colors = [rng.uniform(0, 1, (20, 30, 3)) for _ in range(3)]
    flat_a = np.concatenate([im.reshape(8, -1) for im in images], axis=1)
    flat_c = np.concatenate([c.reshape(-1, 3) for c in colors], axis=0)
    a = ColorModel.fit(images, colors, clusters=7, seed=4)
    b = ColorModel.fit(flat_a, flat_c, clusters=7, seed=4)
    np.testing.assert_array_equal(a.lut(), b.lut())
    assert a.counts.sum() == 1800


def test_lut_layout_and_exact_round_trip():
    rng = np.random.default_rng(13)
    atten = linear_scene(rng, pixels=3000, empty=())
    colors = rng.uniform(0, 3, (3000, 3))
    model = ColorModel.fit(atten, colors, clusters=24)
    assert model.clusters == 24 and model.requested_clusters == 24
    lut = model.lut()
    assert lut.shape == (67, 24) and lut.dtype == np.float64
    k = 7
    np.testing.assert_array_equal(lut[:16, k], model.jacobians[k][0])
    np.testing.assert_array_equal(lut[16:32, k], model.jacobians[k][1])
    np.testing.assert_array_equal(lut[32:48, k], model.jacobians[k][2])
    np.testing.assert_array_equal(lut[48:64, k], model.centroids[k])
    np.testing.assert_array_equal(lut[64:, k], model.colors[k])
    back = ColorModel.from_lut(lut)
    assert back.lut().tobytes() == lut.tobytes()
    assert back.residuals is None and back.counts is None
    new = linear_scene(np.random.default_rng(14), pixels=400, empty=())
    assert back.predict(new).tobytes() == model.predict(new).tobytes()
    # through a file, as the proxy bundle's sidecar stores it
    assert ColorModel.from_lut(np.array(lut.tolist())).lut().tobytes() == lut.tobytes()


def test_same_seed_same_model():
    rng = np.random.default_rng(15)
    atten = linear_scene(rng, intervals=8, pixels=2500, empty=())
    colors = rng.uniform(0, 1, (2500, 3))
    for subsample in (200_000, 700):  # all pixels, and centroids from a subsample
        a = ColorModel.fit(atten, colors, clusters=10, seed=5, max_fit_samples=subsample)
        b = ColorModel.fit(atten, colors, clusters=10, seed=5, max_fit_samples=subsample)
        assert a.lut().tobytes() == b.lut().tobytes()
        assert a.counts.sum() == 2500  # every pixel is assigned and used


def test_clusters_shrink_to_distinct_vectors():
    atten = np.repeat(np.array([[0.1, 0.2], [0.3, 0.0], [0.0, 0.5]]).T, 40, axis=1)  # 3 distinct
    colors = np.repeat(np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]), 40, axis=0)
    model = ColorModel.fit(atten, colors, clusters=10)
    assert model.clusters == 3 and model.requested_clusters == 10
    assert "clusters=3 (of 10 requested)" in repr(model)
    np.testing.assert_allclose(model.predict(atten), colors, atol=1e-15)
    assert np.all(model.counts == 40)


def test_repr_and_properties():
    model = ColorModel(np.zeros((2, 3)), np.ones((2, 3)), np.zeros((2, 3, 3)))
    assert (model.clusters, model.intervals) == (2, 3)
    assert repr(model) == "ColorModel(clusters=2, intervals=3)"
    with pytest.raises(ValueError, match="read-only"):
        model.centroids[0, 0] = 1.0


# ----------------------------------------------------------------------------- nearest centroid


def brute_force_nearest(atten, centroids):
    d = ((atten[:, None, :] - centroids[None, :, :]) ** 2).sum(axis=2)
    return np.argmin(d, axis=1)


def test_nearest_centroid_matches_brute_force():
    rng = np.random.default_rng(16)
    atten = rng.random((20000, 16))  # more than one block of pixels
    centroids = rng.random((48, 16))
    np.testing.assert_array_equal(nearest_centroid(atten, centroids), brute_force_nearest(atten, centroids))


def test_nearest_centroid_ties_go_to_lowest_index():
    rng = np.random.default_rng(17)
    # integer centroids with duplicates; points on the half-integer grid are often
    # exactly equidistant from several of them (all values exact in binary)
    base = rng.integers(0, 3, (6, 4)).astype(float)
    centroids = np.concatenate([base, base[[4, 1]], base[:2]])
    atten = rng.integers(0, 7, (3000, 4)) / 2.0
    d = ((atten[:, None, :] - centroids[None, :, :]) ** 2).sum(axis=2)
    ties = (d == d.min(axis=1, keepdims=True)).sum(axis=1) > 1
    assert ties.sum() > 100
    got = nearest_centroid(atten, centroids)
    np.testing.assert_array_equal(got, np.argmin(d, axis=1))
    assert np.all(got < 6)  # the duplicates 6..9 never win
    assert nearest_centroid([[0.5, 0.5]], [[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]]).tolist() == [0]


def test_nearest_centroid_near_coincident_centroids():
    # |a|^2 - 2 a.c + |c|^2 would lose this 1e-9 separation to cancellation
    centroids = np.array([[1.0, 1.0], [1.0 + 1e-9, 1.0]])
    atten = np.array([[1.0 + 0.9e-9, 1.0], [1.0 + 0.1e-9, 1.0]])
    assert nearest_centroid(atten, centroids).tolist() == [1, 0]


# ----------------------------------------------------------------------------- bad inputs


def test_bad_propagate_inputs():
    atten = np.full((4, 2, 3), 0.1)
    with pytest.raises(ValueError, match=r"interval 4 is out of range; the attenuation has 4 intervals, 0..3"):
        propagate(atten, {4: 0.5})
    with pytest.raises(ValueError, match=r"interval -1 is out of range"):
        propagate(atten, {-1: 0.5})
    with pytest.raises(TypeError, match="scale keys must be interval indices"):
        propagate(atten, {"1": 0.5})
    with pytest.raises(ValueError, match=r"scale of interval 2 must be finite and >= 0; got -0.5"):
        propagate(atten, [1, 1, -0.5, 1])
    with pytest.raises(ValueError, match=r"scale of interval 1 must be finite and >= 0; got nan"):
        propagate(atten, {1: float("nan")})
    with pytest.raises(ValueError, match=r"scale of interval 0 must be finite and >= 0; got inf"):
        propagate(atten, [np.inf, 1, 1, 1])
    with pytest.raises(ValueError, match=r"scale must have one entry per interval \(4\)"):
        propagate(atten, [1, 1, 1])
    with pytest.raises(ValueError, match="atten must be finite; found 1 NaN"):
        bad = atten.copy()
        bad[1, 0, 0] = np.nan
        propagate(bad, {})
    with pytest.raises(ValueError, match="atten must be >= 0"):
        propagate(-atten, {})
    with pytest.raises(ValueError, match="atten must sum to at most 1"):
        propagate(atten * 3, {})
    with pytest.raises(TypeError, match="atten must be an array of real numbers; got dtype"):
        propagate(atten.astype(complex), {})
    with pytest.raises(ValueError, match=r"own must have the shape of atten \(4, 2, 3\); got \(4, 3, 2\)"):
        propagate(atten, {}, own=np.zeros((4, 3, 2)))
    with pytest.raises(ValueError, match=r"own must lie in \[0, 1\]"):
        propagate(atten, {}, own=np.full((4, 2, 3), 1.5))
    with pytest.raises(ValueError, match=r"entry must have the shape of atten"):
        propagate(atten, {}, entry=np.zeros((3, 2, 3)))
    with pytest.raises(ValueError, match="entry must not contain NaN"):
        propagate(atten, {}, entry=np.full((4, 2, 3), np.nan))
    with pytest.raises(ValueError, match="cannot be combined with order='descending'"):
        propagate(atten, {}, entry=np.zeros((4, 2, 3)), order="descending")
    with pytest.raises(ValueError, match=r"order must be one of \['depth', 'ascending', 'descending'\]"):
        propagate(atten, {}, order="intensity")
    with pytest.raises(ValueError, match="own must lie in"):
        propagate_own([[0.5], [-0.1]], {})


def test_bad_model_inputs():
    rng = np.random.default_rng(18)
    atten = linear_scene(rng, intervals=4, pixels=50, empty=())
    colors = rng.random((50, 3))
    with pytest.raises(ValueError, match="clusters must be >= 1; got 0"):
        ColorModel.fit(atten, colors, clusters=0)
    with pytest.raises(TypeError, match="clusters must be an integer; got 2.5"):
        ColorModel.fit(atten, colors, clusters=2.5)
    with pytest.raises(ValueError, match=r"colors must have shape \(50, 3\)"):
        ColorModel.fit(atten, colors[:40], clusters=2)
    with pytest.raises(ValueError, match=r"colors must have shape \(50, 3\)"):
        ColorModel.fit(atten, rng.random((50, 4)), clusters=2)
    with pytest.raises(ValueError, match="atten and colors must list the same number of images; got 2 and 1"):
        ColorModel.fit([atten, atten], [colors], clusters=2)
    with pytest.raises(ValueError, match=r"atten\[1\] has 3 intervals but atten\[0\] has 4"):
        ColorModel.fit([atten, atten[:3]], [colors, colors], clusters=2)
    bad = atten.copy()
    bad[0, 3] = np.nan
    with pytest.raises(ValueError, match="atten must be finite"):
        ColorModel.fit(bad, colors, clusters=2)
    with pytest.raises(ValueError, match="colors must be finite"):
        ColorModel.fit(atten, np.full((50, 3), np.inf), clusters=2)
    with pytest.raises(ValueError, match="no training pixel has non-zero attenuation"):
        ColorModel.fit(np.zeros((4, 50)), colors, clusters=2)
    with pytest.raises(ValueError, match=r"atten must have shape \(L, N\) or \(L, rows, cols\)"):
        ColorModel.fit(atten[:, 0], colors[0], clusters=2)
    model = ColorModel.fit(atten, colors, clusters=2)
    with pytest.raises(ValueError, match=r"atten has 5 intervals \(axis 0\) but the model has 4"):
        model.predict(np.zeros((5, 10)))
    with pytest.raises(ValueError, match="atten must be finite"):
        model.predict(np.full((4, 10), np.nan))
    with pytest.raises(ValueError, match=r"lut must have shape \(\(3 \+ 1\) L \+ 3, K\)"):
        ColorModel.from_lut(np.zeros((24, 67)))
    with pytest.raises(ValueError, match=r"centroids must have shape \(K, L\) with K >= 1"):
        ColorModel(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3, 3)))
    with pytest.raises(ValueError, match=r"jacobians must have shape \(K, 3, L\) = \(2, 3, 3\)"):
        ColorModel(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3, 4)))
    with pytest.raises(ValueError, match=r"atten has 3 intervals per row but centroids have 2"):
        nearest_centroid(np.zeros((5, 3)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"centroids must have shape \(K, L\) with K >= 1"):
        nearest_centroid(np.zeros((5, 3)), np.zeros((0, 3)))
    with pytest.raises(ValueError, match="atten must be finite"):
        nearest_centroid(np.full((5, 3), np.nan), np.zeros((4, 3)))


def test_inputs_are_not_modified():
    rng = np.random.default_rng(19)
    beta, order, entry = random_stack(rng, pixels=50)
    atten = composite_slabs(beta, order)
    inputs = [atten, beta, entry]
    saved = [x.copy() for x in inputs]
    propagate(atten, np.full(6, 0.5), own=beta, entry=entry)
    propagate(atten, np.full(6, 2.0), entry=entry)
    propagate(atten, {0: 0.0}, order="descending")
    propagate_own(beta, np.full(6, 0.5))
    colors = rng.random((50, 3))
    images, image_colors = [atten.reshape(6, 5, 10)], [colors.reshape(5, 10, 3)]
    saved_colors = colors.copy()
    model = ColorModel.fit(images, image_colors, clusters=3)
    model.predict(atten)
    lut = model.lut()
    saved_lut = lut.copy()
    ColorModel.from_lut(lut)
    centroids = model.centroids.copy()
    nearest_centroid(atten.T, centroids)
    for x, y in zip(inputs, saved):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(colors, saved_colors)
    np.testing.assert_array_equal(lut, saved_lut)
    np.testing.assert_array_equal(model.centroids, centroids)
