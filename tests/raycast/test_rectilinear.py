"""Rectilinear grids (issue 33, part 1): non-uniform axes sampled exactly as the
trilinear field of their own cells (``GridVolume.axes``, ``_kernels.warp_at``)."""
import math

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.data.grid import volume_from_rectilinear
from pv_hdrvol.raycast.grid import point_volumes, rectilinear_gradient, warp_arrays

WHITE = [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]


def graded(n, lo, hi, ratio):
    """``n`` coordinates from ``lo`` to ``hi``, cells fine in the middle and ``ratio``
    times wider at both ends."""
    s = np.linspace(-1.0, 1.0, n - 1)
    widths = 1.0 + (ratio - 1.0) * s * s
    c = np.concatenate([[0.0], np.cumsum(widths)])
    return lo + (hi - lo) * c / c[-1]


COEF = (0.2, 0.5, 0.3, 0.4)


def linear_grid(n=14, ratio=3.0):
    x, y, z = graded(n, 0.0, 2.0, ratio), graded(n - 2, -1.0, 1.0, ratio), graded(n + 1, 0.0, 1.5, ratio)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    a, b, c, d = COEF
    return np.ascontiguousarray((a + b * X + c * Y + d * Z).transpose(2, 1, 0)), (x, y, z)


def exact_alpha(o, u, t0, t1, a_max, f_max, unit):
    """``1 - exp(-int sigma)`` along ``o + t u`` of opacity ``a_max f / f_max`` per ``unit``."""
    a, b, c, d = COEF
    f0 = a + b * o[0] + c * o[1] + d * o[2]
    df = b * u[0] + c * u[1] + d * u[2]
    k = a_max / f_max

    def prim(t):
        w = 1.0 - k * (f0 + df * t)
        return (w * math.log(w) - w) / (k * df)
    return 1.0 - math.exp(-(prim(t1) - prim(t0)) / unit)


@pytest.mark.parametrize("view", [(0.0, 0.0, -1.0), (0.3, 0.2, -1.0)], ids=["axis", "oblique"])
def test_linear_field_matches_the_closed_form(view):
    """A linear field is exact under trilinear interpolation in any cell, so the render
    differs from the closed-form integral by the quadrature and table errors only,
    which shrink with the step as they do on uniform grids."""
    values, axes = linear_grid()
    vol = volume_from_rectilinear(values, *axes)
    assert vol.axes is not None
    f_max, a_max, unit = 2.0 * vol.value_range[1], 0.5, 0.25
    tf = hv.TransferFunction([0.0, f_max], WHITE, [0.0, a_max])
    b = np.array(vol.bounds)
    centre = 0.5 * (b[0::2] + b[1::2])
    u = np.array(view) / np.linalg.norm(view)
    cam = hv.Camera(tuple(centre - 10.0 * u), tuple(centre), (0.0, 1.0, 0.0), parallel_projection=True,
                    parallel_scale=0.3)
    rays = cam.rays((6, 6))
    img = hv.render(vol, tf, cam, (6, 6), precision="float64", step=0.05, termination=0.0,
                    opacity_unit_distance=unit)
    errors = []
    for o, d, alpha in zip(rays.origins, rays.directions, img.rgba[..., 3].reshape(-1)):
        t0, t1 = 0.0, math.inf
        for ax in range(3):
            ta, tb = sorted(((b[2 * ax] - o[ax]) / d[ax], (b[2 * ax + 1] - o[ax]) / d[ax])) if d[ax] else (-1, 1e9)
            t0, t1 = max(t0, ta), min(t1, tb)
        assert t1 > t0  # every ray crosses the grid
        errors.append(abs(alpha - exact_alpha(o, d, t0, t1, a_max, f_max, unit)))
    assert max(errors) < 2e-5, max(errors)
    # a uniform resampling at the same dimensions would be wrong by far more: the warp matters
    uniform = hv.volume_from_array(values, vol.spacing, vol.origin)
    wrong = hv.render(uniform, tf, cam, (6, 6), precision="float64", step=0.05, termination=0.0,
                      opacity_unit_distance=unit)
    assert np.abs(wrong.rgba[..., 3] - img.rgba[..., 3]).max() > 50 * max(errors)


def test_a_uniform_rectilinear_grid_is_the_image():
    image = pv.ImageData(dimensions=(9, 7, 6), spacing=(0.5, 0.25, 0.75), origin=(1.0, -2.0, 0.5))
    image["f"] = np.random.default_rng(3).random(image.n_points)
    rect = image.cast_to_rectilinear_grid()
    assert rect.GetClassName() == "vtkRectilinearGrid"
    a = hv.render(rect, None, "iso", (16, 12), precision="float64")
    b = hv.render(image, None, "iso", (16, 12), precision="float64")
    np.testing.assert_array_equal(a.rgba, b.rgba)
    assert hv.raycast.grid.as_volume(rect).axes is None


@pytest.mark.parametrize("precision,tol", [("float64", 1e-12), ("float32", 2e-6)])
def test_the_warp_on_even_axes_is_the_uniform_render_to_rounding(precision, tol):
    values = np.random.default_rng(5).random((7, 8, 9))
    uniform = hv.volume_from_array(values, (0.5, 0.25, 0.75), (1.0, -2.0, 0.5))
    axes = [o + h * np.arange(n) for o, h, n in zip(uniform.origin, uniform.spacing, uniform.dims)]
    forced = hv.GridVolume(uniform.values, uniform.origin, uniform.spacing, uniform.value_range, False,
                           axes=tuple(axes))  # the rectilinear path, kept on even axes
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="viridis", opacity=(0.0, 0.6))
    a = hv.render(forced, tf, "iso", (16, 12), precision=precision)
    b = hv.render(uniform, tf, "iso", (16, 12), precision=precision)
    assert b.rgba[..., 3].max() > 0.2
    np.testing.assert_allclose(a.rgba, b.rgba, rtol=0, atol=tol)


def test_empty_space_skipping_changes_no_pixel():
    x, y, z = graded(40, 0.0, 4.0, 4.0), graded(30, 0.0, 3.0, 0.25), graded(20, 0.0, 2.0, 2.0)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    f = np.exp(-((X - 2.5) ** 2 + (Y - 1.0) ** 2 + (Z - 1.2) ** 2) / 0.05).transpose(2, 1, 0)
    vol = volume_from_rectilinear(np.ascontiguousarray(f), x, y, z)
    tf = hv.TransferFunction.ramp(0.2, 1.0, cmap="magma", opacity=(0.0, 0.8))  # transparent below 0.2
    for view in ("iso", "xy", "yz"):
        on = hv.render(vol, tf, view, (24, 20), precision="float64", block_size=4)
        off = hv.render(vol, tf, view, (24, 20), precision="float64", skip_empty=False)
        np.testing.assert_array_equal(on.rgba, off.rgba)
        assert on.rgba[..., 3].max() > 0.1
        assert on.metadata["samples"] < off.metadata["samples"]


def test_shading_uses_the_world_gradient_of_the_cells():
    """A linear field's gradient is the same everywhere: the points' central differences
    over their true neighbours give it exactly, in world units, in cells of any width.
    With a parallel camera (one view direction) every lit sample is then the unlit one
    times one factor (without the specular term, which adds light); a gradient scaled by the wrong cell widths would vary it."""
    values, axes = linear_grid(n=10, ratio=2.5)
    grad = rectilinear_gradient(values, axes)
    for axis, g in enumerate(COEF[1:]):
        np.testing.assert_allclose(grad[axis], g, rtol=1e-12)
    vol = volume_from_rectilinear(values, *axes)
    tf = hv.TransferFunction.ramp(0.0, 2.0, cmap="gray", opacity=(0.0, 0.7))
    cam = hv.Camera.fit(vol.bounds, "iso", parallel_projection=True)
    lit = hv.render(vol, tf, cam, (12, 10), precision="float64", shade=True, specular=0.0)  # (specular adds)
    flat = hv.render(vol, tf, cam, (12, 10), precision="float64")
    # one light, one normal: every lit sample is the flat one times the same factor
    inside = flat.rgba[..., 3] > 0.05
    ratio = lit.rgba[..., 0][inside] / flat.rgba[..., 0][inside]
    assert ratio.std() < 1e-9 * ratio.mean() and abs(ratio.mean() - 1.0) > 1e-3


def test_what_rectilinear_grids_do_not_take_yet_is_named():
    values, axes = linear_grid(n=6)
    vol = volume_from_rectilinear(values, *axes)
    with pytest.raises(ValueError, match=r"^lens= is not supported for rectilinear grids yet; resample the grid "):
        hv.render(vol, None, "iso", (8, 8), lens=hv.Fisheye())
    with pytest.raises(ValueError, match=r"^blending='maximum' is not supported for rectilinear grids yet"):
        hv.render(vol, None, "iso", (8, 8), blending="maximum")


def test_bad_axes_are_named():
    v = np.zeros((2, 2, 3))
    with pytest.raises(ValueError, match=r"^x coordinates must be strictly increasing; x\[2\] = 1.0 <= x\[1\] = 1.0$"):
        volume_from_rectilinear(v, [0.0, 1.0, 1.0], [0, 1], [0, 1])
    with pytest.raises(ValueError, match=r"^y coordinates must be strictly increasing; y\[1\] = -1.0 <= y\[0\] = 0.0$"):
        volume_from_rectilinear(v, [0.0, 1.0, 2.0], [0, -1], [0, 1])
    with pytest.raises(ValueError, match=r"^z coordinates must be finite; z\[1\] = nan$"):
        volume_from_rectilinear(v, [0.0, 1.0, 2.0], [0, 1], [0, np.nan])
    with pytest.raises(ValueError, match=r"^x has 4 coordinates but the values have 3 points along x"):
        volume_from_rectilinear(v, [0.0, 1.0, 2.0, 3.0], [0, 1], [0, 1])
    grid = pv.RectilinearGrid(np.array([0.0, 1.0, 3.0]), np.array([0.0, 1.0]), np.array([0.0]))
    grid["f"] = np.ones(grid.n_points)
    with pytest.raises(ValueError, match=r"^a rectilinear grid must be 3-D"):
        hv.render(grid, None, "iso", (8, 8))


def test_caller_data_is_untouched_and_nan_is_empty():
    values, axes = linear_grid(n=8)
    values[3, 2, 4] = np.nan
    kept = [a.copy() for a in axes], values.copy()
    vol = volume_from_rectilinear(values, *axes)
    img = hv.render(vol, None, "iso", (10, 10), precision="float64")
    assert np.isfinite(img.rgba).all() and vol.has_nan
    for a, b in zip(axes, kept[0]):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(values, kept[1])


def test_warp_tables_and_point_volumes():
    x = np.array([0.0, 0.1, 0.3, 1.0])
    vol = volume_from_rectilinear(np.zeros((2, 2, 4)), x, [0.0, 1.0], [0.0, 2.0])
    cu, inv_w, first, bases, scales = warp_arrays(vol)
    np.testing.assert_allclose(cu[:4], [0.0, 0.3, 0.9, 3.0])
    np.testing.assert_allclose(inv_w[:3], [1 / 0.3, 1 / 0.6, 1 / 2.1])
    assert warp_arrays(vol) is warp_arrays(vol)  # cached on the volume
    w = point_volumes(vol.axes)
    assert w.shape == (2, 2, 4)
    np.testing.assert_allclose(w.sum(), 1.0 * 1.0 * 2.0)  # the dual cells tile the box


def test_proxies_name_what_they_are_made_of():
    values, axes = linear_grid(n=6)
    with pytest.raises(TypeError, match=r"^proxies are made of image data \(ImageData\); got a rectilinear grid"):
        hv.make_proxies(volume_from_rectilinear(values, *axes), "iso", (8, 8))


@pytest.mark.parametrize("shade", [False, True])
def test_pieces_of_a_rectilinear_grid_composite_to_the_whole(shade):
    """Three pieces (owned boxes tiling the grid, a ghost layer for shading) rendered
    with ``piece=`` in the whole grid's nominal frame and composited in depth order give
    the whole render to rounding."""
    from pv_hdrvol.params import RenderOptions
    from pv_hdrvol.parallel.pieces import composite_pieces, split_boxes
    from pv_hdrvol.raycast.grid import GridPlan, VolumePiece

    def graded(n, lo, hi, ratio):
        s = np.linspace(-1.0, 1.0, n - 1)
        c = np.concatenate([[0.0], np.cumsum(1.0 + (ratio - 1.0) * s * s)])
        return lo + (hi - lo) * c / c[-1]

    x, y, z = graded(23, -1, 1, 3.0), graded(19, -1, 1.2, 2.0), np.linspace(-0.7, 0.8, 17)
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    values = np.exp(-3 * (xx ** 2 + (yy - 0.2) ** 2 + zz ** 2)) + 0.2 * xx
    tf = hv.TransferFunction([-0.2, 1.2], [[1, 0.4, 0.1], [0.1, 0.5, 1]], [0.0, 0.6])
    camera = hv.Camera((4, -3, 2.5), (0, 0.1, 0), (0, 0, 1))
    options = RenderOptions(precision="float64", shade=shade, termination=0.0)
    whole = GridPlan(hv.volume_from_rectilinear(values, x, y, z), tf, options).execute(camera, (40, 32))
    ghosts = 1 if shade else 0
    images, boxes = [], []
    for lo, hi in split_boxes((23, 19, 17), 3):
        a = np.maximum(np.array(lo) - ghosts, 0)
        b = np.minimum(np.array(hi) + ghosts, np.array([22, 18, 16]))
        part = hv.volume_from_rectilinear(values[a[2]:b[2] + 1, a[1]:b[1] + 1, a[0]:b[0] + 1], x[a[0]:b[0] + 1],
                                          y[a[1]:b[1] + 1], z[a[2]:b[2] + 1])
        piece = VolumePiece.from_rectilinear((x, y, z), a, lo, hi)
        images.append(GridPlan(part, tf, piece.options_for(options, part)).execute(camera, (40, 32), piece=piece))
        boxes.append(piece.world_box(None))
    combined = composite_pieces(images, boxes, camera.rays((40, 32)))
    assert whole.rgba[..., 3].max() > 0.9
    np.testing.assert_allclose(combined.rgba, whole.rgba, rtol=0, atol=1e-12)
