"""Depth layers of a mesh boundary (and reference depths of volumes) and the
upsampling filters they guide: nearest, bilinear, joint bilateral."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.data.tets import tetmesh_from_arrays

from meshes import box_mesh, constant_tf, slab_length

pytestmark = pytest.mark.core


def two_boxes():
    p1, t1, v1 = box_mesh((2, 2, 1))
    p2, t2, v2 = box_mesh((2, 2, 1), origin=(0.0, 0.0, 2.0))
    return tetmesh_from_arrays(np.concatenate([p1, p2]), np.concatenate([t1, t2 + len(p1)]), np.concatenate([v1, v2]))


TOP = hv.Camera((1.0, 1.0, 10.0), (1.0, 1.0, 0.0), (0.0, 1.0, 0.0), parallel_projection=True, parallel_scale=1.5)


def test_depth_layers_of_two_boxes_are_their_four_faces():
    layers = hv.depth_layers(two_boxes(), TOP, (12, 12))
    assert layers.n_layers == 4 and layers.layers_needed == 4
    rays = TOP.rays((12, 12))
    x = rays.origins[:, 0].reshape(12, 12)
    y = rays.origins[:, 1].reshape(12, 12)
    inside = (x > 0) & (x < 2) & (y > 0) & (y < 2)
    assert np.all(layers.counts[inside] == 4) and np.all(layers.counts[~inside] == 0)
    # the camera is at z = 10 looking down: faces at z = 3, 2, 1, 0
    for k, z in enumerate((3.0, 2.0, 1.0, 0.0)):
        np.testing.assert_allclose(layers.depth[k][inside], 10.0 - z, rtol=0, atol=1e-12)
        assert np.all(np.isinf(layers.depth[k][~inside]))
    two = hv.depth_layers(two_boxes(), TOP, (12, 12), max_layers=2)
    assert two.n_layers == 2 and two.layers_needed == 4
    g = layers.normalized()
    assert g.shape == (12, 12, 4)
    np.testing.assert_allclose(g[inside][:, 0], 0.0, atol=1e-12)
    np.testing.assert_allclose(g[inside][:, 3], 1.0, atol=1e-12)
    assert np.all(g[~inside] == 2.0)
    assert repr(layers).startswith("DepthLayers(12x12, 4 layers kept, 4 needed, ")
    # the thickness sums all crossings, also those past max_layers
    for kept in (layers, two):
        np.testing.assert_allclose(kept.thickness[inside], 2.0, rtol=0, atol=1e-12)
        assert np.all(kept.thickness[~inside] == 0.0)
    np.testing.assert_allclose(layers.normalized_thickness()[inside], 1.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("parallel", [True, False])
def test_thickness_is_the_length_of_the_ray_inside_the_mesh(parallel):
    """A box seen from an oblique camera: the thickness is the exact ray-box length,
    from the entry and exit crossings alone (rays over edges and corners included)."""
    pts, tets, values = box_mesh((3, 2, 2), spacing=0.5, origin=(-0.75, -0.5, -0.5))
    mesh = tetmesh_from_arrays(pts, tets, values)
    direction = np.array([0.31, -0.52, 0.79]) / np.linalg.norm([0.31, -0.52, 0.79])
    cam = hv.Camera(tuple(6.0 * direction), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), parallel_projection=parallel,
                    parallel_scale=1.2, view_angle=25.0)
    layers = hv.depth_layers(mesh, cam, (40, 30), max_layers=1)
    rays = cam.rays((40, 30))
    expected = slab_length(rays.origins, rays.directions, (-0.75, -0.5, -0.5), (0.75, 0.5, 0.5)).reshape(30, 40)
    np.testing.assert_allclose(layers.thickness, expected, rtol=0, atol=1e-12)
    assert layers.thickness.max() > 1.0 and np.count_nonzero(layers.thickness == 0.0) > 100


def test_faces_behind_a_perspective_camera_are_not_layers():
    """The camera between the two boxes, looking down: the upper box lies behind it (its
    faces get the whole image as their box, and no crossing at t >= 0), the lower one
    gives two layers and its exact ray-box length."""
    cam = hv.Camera((1.0, 1.0, 1.5), (1.0, 1.0, 0.0), (0.0, 1.0, 0.0), view_angle=140.0)
    layers = hv.depth_layers(two_boxes(), cam, (24, 20))
    rays = cam.rays((24, 20))
    length = slab_length(rays.origins, rays.directions, (0.0, 0.0, 0.0), (2.0, 2.0, 1.0)).reshape(20, 24)
    hit = length > 0
    assert 0 < hit.sum() < hit.size
    assert np.all(layers.counts[hit] == 2) and np.all(layers.counts[~hit] == 0)
    np.testing.assert_allclose(layers.thickness, length, rtol=0, atol=1e-12)
    # the first layer is the top face z = 1, 0.5 below the camera along the axis
    cos = -rays.directions[:, 2].reshape(20, 24)
    top = hit & (layers.depth[0] * cos < 0.5 + 1e-9)
    np.testing.assert_allclose((layers.depth[0] * cos)[top], 0.5, rtol=0, atol=1e-12)


def test_the_reference_of_a_volume_guides_by_its_layers():
    volume = hv.volume_from_array(np.linspace(0.0, 1.0, 4 * 4 * 4).reshape(4, 4, 4))
    cam = hv.Camera((1.5, 1.5, 8.0), (1.5, 1.5, 0.0), (0.0, 1.0, 0.0), parallel_projection=True, parallel_scale=2.0)
    layers = hv.depth_layers(volume, cam, (8, 8), isovalue=0.5)
    assert layers.thickness is None
    low = hv.HDRImage(np.random.default_rng(2).random((4, 4, 4)).astype(np.float32))
    img = hv.upsample(low, layers, 2)
    assert img.metadata["upsampled"]["guide"] == "layers" and img.metadata["upsampled"]["spatial"] == "gaussian"
    np.testing.assert_array_equal(img.rgba, hv.upsample(low, layers.normalized(), 2).rgba)


def test_thickness_guide_beats_bilinear_where_the_layers_lose():
    """A transparent box seen obliquely: the picture is 1 - exp(-sigma L), continuous down
    to the silhouette, where the layers jump. Guided by the thickness, the joint bilateral
    filter is closer to the full render than bilinear; guided by the layers (the paper's
    filter), farther (measured: 0.95x and 2.1x bilinear's RMSE)."""
    pts, tets, values = box_mesh((3, 2, 2), spacing=0.5, origin=(-0.75, -0.5, -0.5))
    mesh = tetmesh_from_arrays(pts, tets, values)
    direction = np.array([0.31, -0.52, 0.79]) / np.linalg.norm([0.31, -0.52, 0.79])
    cam = hv.Camera(tuple(6.0 * direction), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), parallel_projection=True,
                    parallel_scale=1.2)
    tf = constant_tf(0.05)
    full = hv.render_tets(mesh, tf, cam, (96, 96), precision="float64").rgba
    low = hv.render_tets(mesh, tf, cam, (24, 24), precision="float64")
    layers = hv.depth_layers(mesh, cam, (96, 96))

    def rmse(img):
        return float(np.sqrt(np.mean((img.rgba - full) ** 2)))

    thick = hv.upsample(low, layers, 4)
    assert thick.metadata["upsampled"] == {"method": "joint_bilateral", "factor": 4.0, "from": [24, 24],
                                           "guide": "thickness", "spatial": "bilinear", "sigma_range": 0.2}
    by_layers = hv.upsample(low, layers, 4, guide="layers")
    bilinear = hv.upsample(low, layers, 4, method="bilinear")
    assert rmse(thick) < 0.97 * rmse(bilinear) and rmse(by_layers) > 1.5 * rmse(bilinear)
    # guide="layers" is the paper's filter: the normalised layers as an array, Gaussian, sigma 0.01
    np.testing.assert_array_equal(by_layers.rgba, hv.upsample(low, layers.normalized(), 4).rgba)
    # guide="thickness" the normalised thickness as an array, bilinear weights, sigma 0.2
    # (the kernel compares raw thicknesses with sigma scaled alike: equal to rounding)
    np.testing.assert_allclose(thick.rgba, hv.upsample(low, layers.normalized_thickness(), 4,
                                                       spatial="bilinear", sigma_range=0.2).rgba, rtol=0, atol=1e-12)


def test_bilinear_spatial_weights_with_a_flat_guide_are_bilinear_upsampling():
    rng = np.random.default_rng(3)
    low = rng.random((5, 7, 6))  # six channels: two groups of four in the kernel
    flat = hv.upsample(low, np.full((20, 28, 1), 0.3), 4, spatial="bilinear")
    np.testing.assert_allclose(flat, hv.upsample(low, factor=4, method="bilinear"), rtol=0, atol=1e-12)
    # 1 at the full-resolution pixels nearest the low centres (factor 4: index 4 i + 2), 0
    # elsewhere: those pixels match all four neighbours, every other one none of them
    # (every range weight underflows) and falls back to the bilinear weights
    guide = np.zeros((20, 28, 1))
    guide[2::4, 2::4] = 1.0
    far = hv.upsample(low, guide, 4, spatial="bilinear", sigma_range=1e-200)
    np.testing.assert_allclose(far, hv.upsample(low, factor=4, method="bilinear"), rtol=0, atol=1e-12)


def test_background_shortcut_changes_no_pixel():
    """Output pixels whose four low pixels are all zero are written as zero without
    their weights; every other pixel is filtered. The filter's weights sum to 1, so
    adding 1 to the image adds 1 to the output: the shifted image (no zero anywhere,
    no shortcut) checks every pixel next to the zero regions, including those that
    read a clamped last row or column, and a NaN tap is never taken as zero."""
    rng = np.random.default_rng(5)
    low = rng.random((9, 11, 4))
    low[:4, :5] = 0.0  # a zero block in the corner
    low[6:, 8:] = 0.0  # and one reaching the last row and column
    low[2, 2, 1] = np.nan  # one channel of one pixel not zero
    guide = rng.random((36, 44, 1))
    out = hv.upsample(low, guide, 4, spatial="bilinear", sigma_range=0.3)
    shifted = hv.upsample(low + 1.0, guide, 4, spatial="bilinear", sigma_range=0.3) - 1.0
    nan = np.isnan(shifted)
    np.testing.assert_array_equal(np.isnan(out), nan)
    assert 0 < nan.sum() < out.size // 10
    np.testing.assert_allclose(out[~nan], shifted[~nan], rtol=0, atol=1e-12)
    zero = np.all(out == 0.0, axis=2)
    assert zero[:6, :14].all() and zero[-3:, -6:].all()  # the shortcut did apply

def test_nearest_and_bilinear():
    low = np.arange(12.0).reshape(3, 4, 1) * np.array([1.0, -2.0])  # linear in row and column
    near = hv.upsample(low, factor=2, method="nearest")
    np.testing.assert_array_equal(near, np.repeat(np.repeat(low, 2, axis=0), 2, axis=1))
    lin = hv.upsample(low, factor=2, method="bilinear")
    rows, cols = np.mgrid[0:6, 0:8]
    u = np.clip((cols + 0.5) / 2 - 0.5, 0, 3)
    v = np.clip((rows + 0.5) / 2 - 0.5, 0, 2)
    np.testing.assert_allclose(lin[..., 0], 4 * v + u, atol=1e-12)  # a linear image is reproduced


def test_joint_bilateral_keeps_an_edge_the_guide_shows():
    """Full resolution: a step at column 13 (not on a low-resolution boundary), a guide
    with the same step. Bilinear blurs it; the joint bilateral filter keeps it."""
    H, W, f = 16, 32, 4
    cols = np.arange(W)
    full = np.where(cols < 13, 1.0, 0.0)[None, :, None] * np.ones((H, 1, 1))
    guide = np.where(cols < 13, 0.2, 0.8)[None, :, None] * np.ones((H, 1, 1))
    low = full[f // 2::f, f // 2::f]  # point samples at the low pixel centres (+-1/2 pixel)
    jbu = hv.upsample(low, guide, f)
    lin = hv.upsample(low, guide, f, method="bilinear")
    err_j = np.sqrt(np.mean((jbu - full) ** 2))
    err_b = np.sqrt(np.mean((lin - full) ** 2))
    assert err_j < 1e-6 < err_b
    # flat guide, smooth image: the filter only smooths (a constant stays constant)
    const = hv.upsample(np.full((4, 8, 2), 3.5), np.zeros((16, 32, 1)), 4)
    np.testing.assert_allclose(const, 3.5, rtol=0, atol=1e-12)


def test_denoising_at_factor_one_preserves_edges():
    rng = np.random.default_rng(1)
    H, W = 24, 24
    clean = np.where(np.arange(W) < 12, 1.0, 0.2)[None, :, None] * np.ones((H, 1, 1))
    noisy = clean + rng.normal(0, 0.05, clean.shape)
    guide = np.where(np.arange(W) < 12, 0.0, 1.0)[None, :, None] * np.ones((H, 1, 1))
    out = hv.upsample(noisy, guide, 1.0, support=4.0)
    assert np.sqrt(np.mean((out - clean) ** 2)) < 0.5 * np.sqrt(np.mean((noisy - clean) ** 2))
    assert abs(out[:, 11].mean() - 1.0) < 0.05 and abs(out[:, 12].mean() - 0.2) < 0.05


def test_render_with_upsampling_is_the_three_steps():
    mesh = two_boxes()
    tf = constant_tf(0.3)
    img = hv.render_tets(mesh, tf, TOP, (32, 24), upsample=4, precision="float64")
    low = hv.render_tets(mesh, tf, TOP, (8, 6), precision="float64")
    layers = hv.depth_layers(mesh, TOP, (32, 24))
    np.testing.assert_array_equal(img.rgba, hv.upsample(low, layers, 4).rgba)
    meta = img.metadata
    assert meta["upsampled"] == {"method": "joint_bilateral", "factor": 4.0, "from": [8, 6], "guide": "thickness",
                                 "spatial": "bilinear", "sigma_range": 0.2}
    assert meta["layers_needed"] == 4 and meta["reference_layers"] == 0  # the thickness guide keeps no layer
    assert all(meta[k] >= 0 for k in ("low_render_seconds", "reference_seconds", "upsample_seconds"))
    # inside the boxes' footprint the picture is uniform: upsampling reproduces it exactly
    # (no low-resolution ray grazes an edge of the boxes at this size)
    sigma = -math.log(1 - 0.3) / mesh.default_unit_distance()
    full = -math.expm1(-2 * sigma)
    assert img.rgba[12, 16, 3] == pytest.approx(full, abs=1e-12)


@pytest.mark.parametrize("call, error, message", [
    (lambda: hv.upsample(np.zeros((2, 2, 4)), factor=2, method="cubic"), ValueError,
     r"method must be one of \['joint_bilateral', 'bilinear', 'nearest'\]; got 'cubic'"),
    (lambda: hv.upsample(np.zeros((2, 2, 4)), factor=2), ValueError,
     r"method='joint_bilateral' needs the full-resolution layers"),
    (lambda: hv.upsample(np.zeros((2, 2, 4)), np.zeros((5, 4, 1))), ValueError,
     r"layers of 4x5 pixels are not the image's 2x2 times factor 2.5"),
    (lambda: hv.upsample(np.zeros((2, 2, 4), dtype=int), factor=2, method="nearest"), TypeError,
     r"image must hold floats; got dtype int64"),
    (lambda: hv.upsample(np.zeros((2, 2, 4)), np.full((4, 4, 1), np.inf)), ValueError,
     r"layers must be finite"),
    (lambda: hv.render_tets(two_boxes(), None, TOP, (10, 8), upsample=4), ValueError,
     r"size 10x8 must be a multiple of upsample=4"),
    (lambda: hv.depth_layers(two_boxes(), TOP, 8, isovalue=0.5), ValueError,
     r"isovalue= and tf= pick a reference for image volumes; a mesh's reference is its boundary"),
    (lambda: hv.depth_layers(np.zeros((3, 3, 3)), TOP, 8), ValueError,
     r"image volumes need isovalue= or tf= to define a reference depth"),
    (lambda: hv.depth_layers(two_boxes(), TOP, 8, max_layers=0), ValueError, r"max_layers must be >= 1; got 0"),
    (lambda: hv.upsample(np.zeros((2, 2, 4)), hv.depth_layers(two_boxes(), TOP, 4), guide="depth"), ValueError,
     r"guide must be one of \['thickness', 'layers'\]; got 'depth'"),
    (lambda: hv.upsample(np.zeros((2, 2, 4)), np.zeros((4, 4, 1)), spatial="box"), ValueError,
     r"spatial must be one of \['bilinear', 'gaussian'\]; got 'box'"),
    (lambda: hv.upsample(np.zeros((2, 2, 4)), np.zeros((4, 4, 1)), spatial="bilinear", support=3), ValueError,
     r"support=3 sets the width of spatial='gaussian'; spatial='bilinear' reads the four nearest low-resolution "
     r"pixels"),
    (lambda: hv.upsample(np.zeros((2, 2, 4)), np.zeros((4, 4, 1)), guide="layers"), ValueError,
     r"guide='layers' chooses from DepthLayers; an array of layers is the guide itself"),
    (lambda: hv.DepthLayers(np.zeros((1, 2, 2)), np.ones((2, 2)), source="isosurface 0.5").normalized_thickness(),
     ValueError, r"these layers have no thickness \(they are the isosurface 0.5\); only a mesh's boundary layers do"),
    (lambda: hv.upsample(np.zeros((2, 2, 4)), hv.DepthLayers(np.zeros((1, 4, 4)), np.ones((4, 4)), source="isosurface 1"),
                         guide="thickness"), ValueError,
     r"guide='thickness' needs the boundary layers of a mesh; these layers have no thickness \(they are the "
     r"isosurface 1\)"),
])
def test_bad_input(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_vanishing_range_sigma_keeps_equal_guides_and_drops_the_rest():
    # sigma_range = 1e-200 squares to 0: the weights must not become 0 * inf = NaN
    rng = np.random.default_rng(0)
    low = rng.random((8, 8, 4))
    guide = np.zeros((32, 32, 2))
    guide[:, 16:] = 1.0  # two flat regions, a step between low columns 3 and 4
    tiny = hv.upsample(low, guide, 4, sigma_range=1e-200)
    small = hv.upsample(low, guide, 4, sigma_range=1e-6)
    assert np.all(np.isfinite(tiny))
    np.testing.assert_array_equal(tiny, small)
    # the output left of the step averages only low pixels left of it
    assert tiny[:, :16].max() <= low[:, :4].max() and tiny[:, :16].min() >= low[:, :4].min()
