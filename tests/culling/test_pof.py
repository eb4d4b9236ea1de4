"""Plenoptic opacity functions and culling (Gao et al. 2003; ../shared/notes/methods.md
section A.5): analytic block opacities, the lower-bound encodings, visibility order,
and a culled render equal to the unculled one bit for bit."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.culling import _kernels as K
from pv_hdrvol.culling.cull import render_mask, visibility_order, visible_blocks
from pv_hdrvol.culling.pof import (N_PHI, N_THETA, PlenopticOpacity, _poly_design, fit_polynomial, spike_filter,
                                   view_angles)
from pv_hdrvol.raycast.grid import BlockGrid, as_volume

pytestmark = pytest.mark.core

FLAT = hv.TransferFunction([0.0, 10.0], [[1, 1, 1]] * 2, [0.2, 0.2])
SIGMA = -math.log(0.8)  # per voxel


def _min_depth(values, frame, lo, hi, pitch=1.0, step=1.0, chord_min=1.0, tf=FLAT):
    sigma = np.ascontiguousarray(hv.TransferFunction.family([tf]).basis_tables(1.0, 1.0))
    a0, a1 = tf.axis_range
    out = np.empty((1, 1))
    K.block_min_depth(np.ascontiguousarray(values, dtype=np.float64), np.ones(3), sigma, 0, 1.0, a0, 1 / (a1 - a0),
                      np.array(lo), np.array(hi), np.array([frame], dtype=np.float64), pitch, step, chord_min, False, out,
                      np.empty((1, 1, 1)))
    return out[0, 0]


def test_homogeneous_block_seen_along_an_axis():
    """T-POF-15: every footprint pixel crosses 16 voxels: optical depth 16 sigma exactly."""
    values = np.full((33, 33, 33), 5.0)
    for frame in ([0, 0, 1, 1, 0, 0, 0, 1, 0], [1, 0, 0, 0, 1, 0, 0, 0, 1], [0, -1, 0, 0, 0, 1, 1, 0, 0]):
        assert _min_depth(values, frame, [16, 0, 16], [32, 16, 32]) == pytest.approx(16 * SIGMA, rel=1e-14)


def test_homogeneous_block_oblique_minimum_is_the_shortest_chord():
    """Oblique views: the minimum optical depth is sigma times the shortest chord (>= chord_min)
    among the lattice's pixel centres, computed here independently with numpy."""
    values = np.full((33, 33, 33), 5.0)
    rng = np.random.default_rng(4)
    for _ in range(5):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        right = np.cross(d, [0, 0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, d)
        lo, hi = np.array([0.0, 16, 0]), np.array([16.0, 32, 16])
        centre = 0.5 * (lo + hi)
        # pixel centres (i + 1/2, j + 1/2) in the view plane through the origin
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        u, w = corners @ right, corners @ up
        i = np.arange(math.floor(u.min()) - 1, math.ceil(u.max()) + 1) + 0.5
        j = np.arange(math.floor(w.min()) - 1, math.ceil(w.max()) + 1) + 0.5
        uu, ww = np.meshgrid(i, j)
        origins = uu[..., None] * right + ww[..., None] * up + (centre @ d - 40) * d
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (lo - origins) / d, (hi - origins) / d
        chord = np.minimum(ta, tb).max(-1), np.maximum(ta, tb).min(-1)
        length = chord[1] - chord[0]
        expected = length[length >= 1.0].min() * SIGMA
        got = _min_depth(values, np.concatenate([d, right, up]), lo.astype(int), hi.astype(int))
        assert got == pytest.approx(expected, rel=1e-12)


def test_empty_and_nan_blocks_have_zero_pof_and_are_never_visible():
    """T-POF-14: a block whose values meet no extinction has POF 0 and is never kept."""
    values = np.full((17, 17, 33), 5.0)
    values[:, :, 16:] = -1.0  # below the function's range: its first entry, opacity 0
    zero_at_start = hv.TransferFunction([0.0, 4.0, 10.0], [[1, 1, 1]] * 3, [0.0, 0.0, 0.5])
    pof = PlenopticOpacity.compute(values, [zero_at_start], block_size=16, threads=1)
    assert pof.nonempty[..., 0].tolist() == [[[True, False]]]
    # the empty block is 0; the other is not, though its face shares the empty side's
    # points (pixels crossing only that face see no opacity: its minimum may be 0)
    assert pof.table[0, 0, 1].max() == 0 and pof.table[0, 0, 0].max() > 0
    camera = hv.Camera.fit(as_volume(values).bounds, "iso", parallel_projection=True)
    result = visible_blocks(pof, values, camera, (32, 32))
    assert result.visible.tolist() == [[[True, False]]]
    assert result.statistics == {"blocks": 2, "nonempty": 1, "visible": 1, "culled": 0, "culled_fraction": 0.0}


def test_uint8_table_and_polynomial_stay_below_the_float_minimum():
    """T-POF-7, T-POF-8: floor quantisation and the shifted polynomial are lower bounds
    at all 1,296 sample views."""
    rng = np.random.default_rng(5)
    theta, phi = view_angles()
    design = _poly_design(theta[:, None], phi[None, :]).reshape(-1, 10)
    tables = np.clip(0.5 + 0.05 * rng.random((20, N_THETA, N_PHI)), 0, 1)
    coef = fit_polynomial(tables)
    assert coef.dtype == np.float32 and coef.shape == (20, 10)
    assert np.all(coef.astype(np.float64) @ design.T <= tables.reshape(20, -1))
    # a table that is itself a cubic in (theta, phi) comes back to float32 rounding
    cubic = (design @ (0.02 * rng.normal(size=(10, 20)))).T + 0.5
    fitted = fit_polynomial(cubic.reshape(20, N_THETA, N_PHI)).astype(np.float64) @ design.T
    assert np.all(fitted <= cubic) and np.max(cubic - fitted) < 1e-6
    q = np.floor(tables * 255).astype(np.uint8)
    assert np.all(q / 255.0 <= tables) and np.all(tables - q / 255.0 < 1 / 255)


def test_spike_filter_never_raises_and_removes_a_spike():
    table = np.full((N_THETA, N_PHI), 0.3)
    table[0, 5] = 0.9  # theta = 0 neighbours theta = 350 deg: the filter wraps
    table[7, 7] = 0.1
    out = spike_filter(table)
    assert np.all(out <= table)
    assert out[0, 5] == pytest.approx(0.3) and out[7, 7] == pytest.approx(0.1)


def test_visibility_order_puts_occluders_first():
    """T-POF-9: along random rays through a small block grid, the blocks a ray crosses
    appear in the order it crosses them."""
    shape = (3, 4, 5)
    rng = np.random.default_rng(6)
    for _ in range(30):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        rank = np.empty(int(np.prod(shape)), dtype=np.int64)
        rank[visibility_order(shape, d)] = np.arange(rank.size)
        start = rng.random(3) * np.array(shape[::-1]) - 20 * d
        t = np.linspace(0, 40, 4001)
        points = start + t[:, None] * d
        inside = np.all((points >= 0) & (points < np.array(shape[::-1])), axis=1)
        cells = np.floor(points[inside]).astype(int)
        flat = (cells[:, 2] * shape[1] + cells[:, 1]) * shape[2] + cells[:, 0]
        crossed = flat[np.r_[True, np.diff(flat) != 0]]
        assert np.all(np.diff(rank[crossed]) > 0)


def _opaque_scene():
    rng = np.random.default_rng(0)
    values = 0.6 + 0.4 * rng.random((33, 33, 33))
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [1, 0.5, 0.2], [1, 1, 1]], [0.0, 0.9, 0.99])
    return as_volume(values), tf


def test_culled_render_equals_the_unculled_render_bit_for_bit():
    """T-POF-3 in practice: with the ray caster's termination at the culling threshold
    (transmittance 0.05), rendering only the visible blocks changes no pixel."""
    volume, tf = _opaque_scene()
    pof = PlenopticOpacity.compute(volume, [tf], block_size=8)
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    result = visible_blocks(pof, volume, camera, (64, 64))
    stats = result.statistics
    assert stats["nonempty"] == 64 and stats["culled"] >= 8  # at least the hidden core
    mask = render_mask(result, pof, 4, BlockGrid.of(volume, 4).shape)
    full = hv.render(volume, tf, camera, (64, 64), termination=0.05, progress_bar=False)
    culled = hv.render(volume, tf, camera, (64, 64), termination=0.05, block_mask=mask, progress_bar=False)
    np.testing.assert_array_equal(culled.rgba, full.rgba)
    # a weaker family culls less: k scales extinction, the block opacities drop
    weak = visible_blocks(pof, volume, camera, (64, 64), k=[0.05]).statistics
    assert weak["culled"] < stats["culled"]


def test_save_load_and_bad_input(tmp_path):
    volume, tf = _opaque_scene()
    pof = PlenopticOpacity.compute(volume, [tf], block_size=16)
    path = tmp_path / "scene.pof.npz"
    pof.save(path)
    back = PlenopticOpacity.load(path)
    np.testing.assert_array_equal(back.table, pof.table)
    np.testing.assert_array_equal(back.poly, pof.poly)
    assert back.block_size == 16 and back.dims == pof.dims and back.bases[0].to_dict() == tf.to_dict()
    assert back.footprint == pof.footprint == "chord"
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    with pytest.raises(ValueError, match=r"these POFs describe a volume of \(33, 33, 33\) points; got \(33, 33, 17\)"):
        visible_blocks(pof, volume.values[:17], camera, (8, 8))
    with pytest.raises(ValueError, match="POF culling needs an orthographic camera"):
        visible_blocks(pof, volume, hv.Camera.fit(volume.bounds, "iso"), (8, 8))
    with pytest.raises(ValueError, match=r"k must be 1 finite weights >= 0; got \[-1.0\]"):
        visible_blocks(pof, volume, camera, (8, 8), k=[-1.0])
    with pytest.raises(ValueError, match="block_size must be a power of two; got 12"):
        PlenopticOpacity.compute(volume, [tf], block_size=12)
    with pytest.raises(ValueError, match=r"must be a multiple of the render's block_size \(32\)"):
        render_mask(visible_blocks(pof, volume, camera, (8, 8)), pof, 32, (1, 1, 1))


def test_render_with_cull_uses_the_family_weights_and_reports_counts():
    volume, tf = _opaque_scene()
    pof = PlenopticOpacity.compute(volume, [tf], block_size=8)
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    family = hv.TransferFunction.family([tf], [2.0])
    full = hv.render(volume, family, camera, (48, 48), termination=0.05, progress_bar=False)
    image = hv.render(volume, family, camera, (48, 48), termination=0.05, cull=pof, progress_bar=False)
    np.testing.assert_array_equal(image.rgba, full.rgba)
    stats = image.metadata["culling"]
    expected = visible_blocks(pof, volume, camera, (48, 48), k=[2.0]).statistics
    assert {key: stats[key] for key in expected} == expected and stats["culled"] > 0
    assert stats["threshold"] == 0.95 and stats["encoding"] == "table" and stats["seconds"] >= 0
    assert image.metadata["settings"]["not_stored"] == ["cull"]
    # the basis itself is the family with k = 1
    plain = hv.render(volume, tf, camera, (48, 48), termination=0.05, cull=pof, progress_bar=False)
    assert plain.metadata["culling"]["visible"] == visible_blocks(pof, volume, camera, (48, 48)).statistics["visible"]


def test_render_options_scale_the_weights_conservatively():
    from pv_hdrvol.culling.cull import Culling

    volume, tf = _opaque_scene()
    pof = PlenopticOpacity.compute(volume, [tf], block_size=16)
    culling = Culling(pof)
    family = hv.TransferFunction.family([tf], [1.5])
    # a longer unit distance divides every extinction by it: exactly k / 2
    k = culling.weights_for(family, hv.RenderOptions(opacity_unit_distance=2.0), 1.0)
    assert k.tolist() == [0.75]
    # global_alpha < 1: the smallest ratio of -ln(1 - a g) to -ln(1 - a) over the table
    k = culling.weights_for(family, hv.RenderOptions(global_alpha=0.5), 1.0)
    a = tf.opacity_at(np.linspace(0.5, 1.0, 1001))
    assert k[0] <= 1.5 * np.min(-np.log1p(-0.5 * a) / -np.log1p(-a)) + 1e-12


def test_cull_refuses_what_it_cannot_bound():
    volume, tf = _opaque_scene()
    pof = PlenopticOpacity.compute(volume, [tf], block_size=16)
    camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
    other = hv.TransferFunction([0.0, 1.0], [[1, 1, 1]] * 2, [0.5, 0.5])
    with pytest.raises(ValueError, match=r"cull= needs the render's tf to be TransferFunction.family\(pof.bases, k\)"):
        hv.render(volume, other, camera, (8, 8), cull=pof, progress_bar=False)
    with pytest.raises(ValueError, match="cull= applies to blending='composite' without gradient_opacity"):
        hv.render(volume, tf, camera, (8, 8), cull=pof, blending="maximum", progress_bar=False)
    with pytest.raises(ValueError, match="POF culling needs an orthographic camera"):
        hv.render(volume, tf, hv.Camera.fit(volume.bounds, "iso"), (8, 8), cull=pof, progress_bar=False)
    with pytest.raises(TypeError, match="cull must be a PlenopticOpacity, Culling or OcclusionBound; got str"):
        hv.render(volume, tf, camera, (8, 8), cull="pof", progress_bar=False)


def test_a_tiny_block_without_footprint_pixels_gets_zero_not_one():
    """A corner block one cell on each side has, at most views, no pixel crossing it over
    chord_min: its POF is 0 there (nothing known), never 1."""
    values = np.full((18, 18, 18), 5.0)  # block (1, 1, 1) holds the single cell 16..17 on each axis
    pof = PlenopticOpacity.compute(values, [FLAT], block_size=16, threads=1)
    tiny = pof.table[1, 1, 1, 0]
    assert tiny.max() <= math.floor(255 * (1 - math.exp(-SIGMA * math.sqrt(3))))  # no chord is longer
    assert (tiny == 0).any()


def test_nonempty_pixel_footprint_is_the_papers_unsafe_reading():
    """footprint="nonempty_pixels" ignores the pixels where the basis is 0: a half-empty
    block gets its full half's opacity (higher than the conservative minimum)."""
    values = np.full((17, 17, 17), 5.0)
    values[:, :, :9] = -1.0  # the x < 8 half is below the function's range: opacity 0
    zero_below = hv.TransferFunction([0.0, 4.0, 10.0], [[1, 1, 1]] * 3, [0.0, 0.0, 0.5])
    safe = PlenopticOpacity.compute(values, [zero_below], threads=1)
    paper = PlenopticOpacity.compute(values, [zero_below], footprint="nonempty_pixels", threads=1)
    assert safe.table.max() == 0  # every view has pixels through the empty half only
    assert np.all(paper.table >= safe.table) and paper.table.max() > 100


def _block_depths(values, sigma, tf, lo, hi, frames):
    """Minimum optical depth (V, p) and POF sets (V, p, p) of one block, from the kernel."""
    a0, a1 = tf.axis_range
    out, sets = np.empty((len(frames), sigma.shape[0])), np.empty((len(frames), sigma.shape[0], sigma.shape[0]))
    K.block_min_depth(values, np.ones(3), np.ascontiguousarray(sigma), 0, 1.0, a0, 1 / (a1 - a0), np.array(lo),
                      np.array(hi), frames, 1.0, 1.0, 1.0, False, out, sets)
    return out, sets


def test_multi_basis_bounds_conservative_below_and_pof_sets_above_the_true_minimum():
    """T-POF-4, T-POF-5 at every sample view of a block of random data with two bases:
    the conservative ``1 - prod (1 - POF_i)^{k_i}`` is at most the family's true minimum
    opacity over the footprint (the family rendered as one basis); the POF-set estimate
    (each basis's minimising pixel under the family) is at least that minimum, and
    equal to it where the minimising pixel is one of the candidates."""
    from pv_hdrvol.culling.pof import direction, view_frames

    rng = np.random.default_rng(11)
    values = np.ascontiguousarray(rng.uniform(0, 10, size=(9, 9, 9)))
    low = hv.TransferFunction([0.0, 5.0, 10.0], [[1, 0, 0]] * 3, [0.3, 0.0, 0.0])
    high = hv.TransferFunction([0.0, 5.0, 10.0], [[0, 0, 1]] * 3, [0.0, 0.05, 0.4])
    theta, phi = view_angles()
    frames = view_frames(direction(theta[:, None], phi[None, :]).reshape(-1, 3))
    sigma = hv.TransferFunction.family([low, high]).basis_tables(1.0, 1.0)
    depth, sets = _block_depths(values, sigma, low, [0, 0, 0], [8, 8, 8], frames)
    np.testing.assert_array_equal(np.diagonal(sets, axis1=1, axis2=2), depth)  # POF_ii is the basis's POF
    exceed = []
    for k in ([1.0, 1.0], [0.25, 2.0], [3.0, 0.1]):
        k = np.array(k)
        true, _ = _block_depths(values, (k[:, None] * sigma).sum(0, keepdims=True), low, [0, 0, 0], [8, 8, 8],
                                frames)
        conservative = depth @ k  # optical depths: 1 - prod (1 - a_i)^{k_i} = 1 - exp(-sum k_i D_i)
        estimate = (sets @ k).min(axis=1)
        assert np.all(conservative <= true[:, 0] * (1 + 1e-12))
        assert np.all(estimate >= true[:, 0] * (1 - 1e-12))
        exceed.append(np.mean(estimate > true[:, 0] * (1 + 1e-9)))
        assert np.mean(conservative < true[:, 0] * (1 - 1e-9)) > 0.5  # the bound is loose here
    assert max(exceed) > 0  # and the set estimate overshoots at some views: not a bound


def test_pof_sets_are_stored_looked_up_and_saved(tmp_path):
    values = np.full((17, 17, 33), 5.0)
    values[:, :, 16:] = 8.0
    low = hv.TransferFunction([0.0, 6.0, 10.0], [[1, 0, 0]] * 3, [0.3, 0.0, 0.0])
    high = hv.TransferFunction([0.0, 6.0, 10.0], [[0, 0, 1]] * 3, [0.0, 0.0, 0.4])
    plain = PlenopticOpacity.compute(values, [low, high], threads=1)
    assert plain.sets is None
    with pytest.raises(ValueError, match=r"method='sets' needs POF sets: PlenopticOpacity.compute\(..., sets=True\)"):
        plain.block_opacity([1.0, 0, 0], method="sets")
    pof = PlenopticOpacity.compute(values, [low, high], sets=True, threads=1)
    np.testing.assert_array_equal(pof.table, plain.table)
    assert pof.sets.shape == (1, 1, 2, 2, 2, N_THETA, N_PHI) and pof.sets.dtype == np.uint8
    for i in range(2):
        np.testing.assert_array_equal(pof.sets[..., i, i, :, :], pof.table[..., i, :, :])
    d = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    k = np.array([0.5, 2.0])
    sets = pof.block_opacity(d, k, method="sets")
    bound = pof.block_opacity(d, k)
    assert sets.shape == (1, 1, 2) and np.all(sets >= bound - 1e-15)
    # "nearest" takes one sample view: the formula on the stored uint8 sets by hand
    from pv_hdrvol.culling.pof import angles_of

    theta, phi = view_angles()
    t, f = angles_of(d)
    i = int(np.argmin(np.abs(np.angle(np.exp(1j * (theta - t))))))
    j = int(np.argmin(np.abs(phi - f)))
    q = pof.sets[..., i, j].astype(np.float64) / 255.0  # (1, 1, 2, i, j)
    expected = (1 - np.exp((np.log1p(-np.minimum(q, 1.0)) * k).sum(-1))).min(-1)
    np.testing.assert_allclose(pof.block_opacity(d, k, method="sets", lookup="nearest"), expected, rtol=1e-12)
    path = tmp_path / "sets.pof.npz"
    pof.save(path)
    np.testing.assert_array_equal(PlenopticOpacity.load(path).sets, pof.sets)
    from pv_hdrvol.culling.cull import Culling

    with pytest.raises(ValueError, match="method='sets' needs the table encoding and POFs computed with sets=True"):
        Culling(plain, method="sets")
    camera = hv.Camera.fit(as_volume(values).bounds, "iso", parallel_projection=True)
    # every stored set entry is >= the basis's (filtered, floored) POF, so the sets cull
    # at least what the conservative method culls
    assert np.all(pof.sets >= pof.table[..., None, :, :, :])  # sets[..., i, j] >= table[..., j]
    centre = np.array([16.0, 8.0, 8.0])
    for d in ([1.0, 0, 0.01], [-1.0, 0.2, 0.1], [0.6, 0.6, 0.5]):
        camera = hv.Camera(tuple(centre - 60 * np.array(d)), tuple(centre), (0.0, 0.0, 1.0), parallel_projection=True,
                           parallel_scale=20.0)
        kept = visible_blocks(pof, values, camera, (32, 32), k, method="sets").visible
        assert np.all(kept <= visible_blocks(pof, values, camera, (32, 32), k).visible)


def test_the_papers_worked_example_l_58_4_in_the_renderer_the_oracle_and_the_culling():
    """T-POF-1: samples of opacity 0.05 reach the threshold 0.95 after
    l = ln 0.05 / ln 0.95 = 58.404 of them, so the 59th is the last one that counts.
    Along x through blocks of 16 such samples: the ray caster's opacity after n samples is
    1 - 0.95^n; the oracle needs the first 4 blocks (sample 59 is in the 4th); with each
    block's opacity floor(255 (1 - 0.95^16)) / 255 (its POF seen along an axis), the
    culling keeps exactly those 4 and culls the other 4 of each row. (No sample view is
    along an axis, phi = (j + 1/2) 5 deg, and 2.5 deg off it pixels along the side faces
    cross a block over 1-2 voxels: the stored minimum there is under two samples' worth.)"""
    from pv_hdrvol.culling.reference import ert_oracle

    assert math.log(0.05) / math.log(0.95) == pytest.approx(58.404, abs=5e-4)
    flat = hv.TransferFunction([0.0, 10.0], [[1, 1, 1]] * 2, [0.05, 0.05])
    for n in (58, 59):  # a slab n cells long, seen along x: n unit samples
        slab = np.full((3, 3, n + 1), 5.0)
        camera = hv.Camera((-5.0, 1.0, 1.0), (0.0, 1.0, 1.0), (0, 0, 1), parallel_projection=True, parallel_scale=0.5)
        alpha = hv.render(slab, flat, camera, (1, 1), precision="float64", termination=0.0,
                          progress_bar=False).rgba[0, 0, 3]
        assert alpha == pytest.approx(1 - 0.95**n, rel=1e-12)
        assert (alpha >= 0.95) == (n == 59)
    values = np.full((33, 33, 129), 5.0)  # 8 blocks along x, 2 x 2 across
    camera = hv.Camera((-10.0, 16.0, 16.0), (0.0, 16.0, 16.0), (0, 0, 1), parallel_projection=True,
                       parallel_scale=8.0)  # the image lies inside the slab's cross-section
    pof = PlenopticOpacity.compute(values, [flat], threads=1)
    axis = math.floor(255 * (1 - math.exp(-_min_depth(values, [1, 0, 0, 0, 1, 0, 0, 0, 1], [0, 0, 0], [16, 16, 16],
                                                       tf=flat))))
    assert axis == math.floor(255 * (1 - 0.95**16)) == 142
    assert pof.table[0, 0, 0, 0, 0, N_PHI // 2] < 255 * (1 - 0.95**2)  # 2.5 deg off +x: under two samples' worth
    pof.table[...] = axis
    result = visible_blocks(pof, values, camera, (16, 16))
    expected = np.zeros((2, 2, 8), dtype=bool)
    expected[..., :4] = True
    np.testing.assert_array_equal(result.visible, expected)
    np.testing.assert_array_equal(ert_oracle(values, flat, camera, (16, 16)), expected)


def test_single_basis_weights_scale_the_optical_depth():
    """T-POF-2: at every sample view, the POF of k tau is 1 - (1 - POF(tau))^k: the kernel's
    minimum optical depth for k sigma is k times the one for sigma (k = 0, 0.1, 0.5, 1, 3)."""
    from pv_hdrvol.culling.pof import direction, view_frames

    rng = np.random.default_rng(12)
    values = np.ascontiguousarray(rng.uniform(0, 10, size=(9, 9, 9)))
    tf = hv.TransferFunction([0.0, 5.0, 10.0], [[1, 1, 1]] * 3, [0.0, 0.3, 0.1])
    theta, phi = view_angles()
    frames = view_frames(direction(theta[:, None], phi[None, :]).reshape(-1, 3))
    sigma = hv.TransferFunction.family([tf]).basis_tables(1.0, 1.0)
    depth, _ = _block_depths(values, sigma, tf, [0, 0, 0], [8, 8, 8], frames)
    assert depth.min() > 0
    for k in (0.0, 0.1, 0.5, 1.0, 3.0):
        scaled, _ = _block_depths(values, k * sigma, tf, [0, 0, 0], [8, 8, 8], frames)
        np.testing.assert_allclose(scaled, k * depth, rtol=1e-12, atol=0)
        np.testing.assert_allclose(-np.expm1(-scaled), 1 - np.exp(-depth) ** k, rtol=1e-12, atol=1e-300)


def test_visible_sets_are_ordered_exact_then_table_then_polynomial():
    """T-POF-12 at a sample view (nearest lookup): lowering block opacities can only keep
    more blocks, so R2 (per-pixel opacities) <= table <= shifted polynomial."""
    from pv_hdrvol.culling.reference import exact_sequential

    volume, tf = _opaque_scene()
    pof = PlenopticOpacity.compute(volume, [tf], block_size=8)
    theta, phi = view_angles()
    culled = []
    for i, j in ((0, 17), (4, 9), (21, 27)):
        d = np.array([np.sin(phi[j]) * np.cos(theta[i]), np.sin(phi[j]) * np.sin(theta[i]), np.cos(phi[j])])
        centre = np.array([16.0, 16.0, 16.0])  # the camera looks along the sample view d
        up = (0.0, 0.0, 1.0) if abs(d[2]) < 0.9 else (0.0, 1.0, 0.0)
        camera = hv.Camera(tuple(centre - 60 * d), tuple(centre), up, parallel_projection=True, parallel_scale=30.0)
        table = visible_blocks(pof, volume, camera, (48, 48), lookup="nearest")
        poly = visible_blocks(pof, volume, camera, (48, 48), lookup="nearest", encoding="poly").visible
        r2, _ = exact_sequential(volume, tf, camera, (48, 48), block_size=8, nonempty=table.nonempty)
        assert np.all(r2 <= table.visible) and np.all(table.visible <= poly)
        culled.append(int(table.nonempty.sum() - table.visible.sum()))
    assert min(culled) > 0  # not trivially: every view culls blocks


def test_block_ranges_are_the_min_and_max_of_each_blocks_points():
    """Blocks share their faces (points i bs .. (i + 1) bs, clipped); NaN is ignored, and
    a block of NaN only is NaN (empty)."""
    from pv_hdrvol.culling.pof import block_ranges
    from pv_hdrvol.raycast.grid import block_grid_shape

    rng = np.random.default_rng(13)
    for dims, bs in (((17, 9, 5), 4), ((33, 2, 34), 16), ((3, 3, 3), 8), ((20, 7, 11), 2)):
        values = rng.normal(size=dims[::-1])
        values[rng.random(values.shape) < 0.2] = np.nan
        values[:, :, :min(3, dims[0])] = np.nan  # whole blocks of NaN where bs <= 2
        lo, hi = block_ranges(values, bs)
        assert lo.shape == hi.shape == block_grid_shape(dims, bs)
        for k, j, i in np.ndindex(*lo.shape):
            block = values[k * bs:(k + 1) * bs + 1, j * bs:(j + 1) * bs + 1, i * bs:(i + 1) * bs + 1]
            if np.isnan(block).all():
                assert np.isnan(lo[k, j, i]) and np.isnan(hi[k, j, i])
            else:
                assert lo[k, j, i] == np.nanmin(block) and hi[k, j, i] == np.nanmax(block)


def _one_hot_block_volume():
    """64^3 zeros with the points of block (1, 2, 1) (block_size 16) at 100, and the
    blocks that hold any of those points (neighbours share their faces' points)."""
    values = np.zeros((65, 65, 65))
    values[17:32, 33:48, 17:32] = 100.0  # strictly inside block (z, y, x) = (1, 2, 1)
    expected = np.zeros((4, 4, 4), dtype=bool)
    expected[1, 2, 1] = True
    return values, expected


@pytest.mark.parametrize("tf", [hv.TransferFunction.ramp(50, 255),
                                hv.TransferFunction.ramp(1, 1000, scale="log"),
                                hv.TransferFunction.ramp(50, 255, scale="symlog")],
                         ids=["linear", "log", "symlog"])
def test_values_below_the_first_point_are_empty_for_every_consumer(tf):
    """A ramp is 0 at its first point and below: zeros meet no extinction. The POFs,
    the renderer's empty-space skipping and the parallel distribution all mark only the
    block holding the 100s (the POFs took the entry after the last one a block's range
    can reach too, so every block of zeros counted as non-empty)."""
    from pv_hdrvol.raycast.grid import GridPlan, _base_active

    values, expected = _one_hot_block_volume()
    pof = PlenopticOpacity.compute(values, [tf], block_size=16, threads=1)
    assert pof.nonempty[..., 0].tolist() == expected.tolist()
    for precision in ("float64", "float32"):  # the renderer's empty-space skipping, 16^3 blocks
        plan = GridPlan(values, tf, precision=precision, block_size=16)
        prep = plan._prepare()
        active = _base_active(prep.volume, prep.blocks, plan.options, None, plan.table, prep.params)
        assert active.astype(bool).tolist() == expected.tolist()
