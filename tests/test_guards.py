"""Guards a newcomer met (issue 18): few kernel dtypes, empty renders that say why,
memory estimates, interruptible renders, PyVista's keywords."""
import re

import numpy as np
import pytest

import pv_hdrvol as hv

pytestmark = pytest.mark.core

TF = hv.TransferFunction.ramp(-200.0, 200.0, cmap="gray", opacity=(0.0, 0.3))


def _integers(dtype, shape=(9, 10, 11)):
    info = np.iinfo(dtype)
    rng = np.random.default_rng(18)
    return rng.integers(max(info.min, -200), min(info.max, 200), size=shape, endpoint=True).astype(dtype)


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.uint16, np.int32, np.uint32, np.int64])
def test_integer_volumes_reach_the_kernels_as_float32(dtype):
    vals = _integers(dtype)
    vol = hv.volume_from_array(vals)
    assert vol.values.dtype == np.float32 and vol.integer
    np.testing.assert_array_equal(vol.values, vals.astype(np.float64))
    assert vals.dtype == dtype  # the caller's array is untouched


def test_only_three_dtypes_reach_the_kernels():
    assert hv.volume_from_array(np.zeros((2, 2, 2), np.uint8)).values.dtype == np.uint8
    assert hv.volume_from_array(np.zeros((2, 2, 2), np.float16)).values.dtype == np.float32
    assert hv.volume_from_array(np.zeros((2, 2, 2), np.float64)).values.dtype == np.float64
    # integers beyond 2**24 do not all fit in float32: float64
    big = np.full((2, 2, 2), 2**24, np.int64)
    assert hv.volume_from_array(big).values.dtype == np.float32
    big[0, 0, 0] = 2**24 + 1
    assert hv.volume_from_array(big).values.dtype == np.float64
    assert hv.volume_from_array(-big).values.dtype == np.float64
    assert hv.volume_from_array(np.full((2, 2, 2), 2**40, np.uint64)).values.dtype == np.float64


@pytest.mark.parametrize("dtype", [np.int8, np.int16])
@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_int8_and_int16_render_bit_identically_to_their_float32_copies(dtype, precision):
    vals = _integers(dtype)
    a = hv.render(vals, TF, None, (24, 24), precision=precision)
    b = hv.render(vals.astype(np.float32), TF, None, (24, 24), precision=precision)
    np.testing.assert_array_equal(a.rgba, b.rgba)
    np.testing.assert_array_equal(a.depth, b.depth)


def test_integer_data_keeps_a_linear_default_transfer_function():
    # as before the conversion: integer data (CT numbers) spanning > 3 decades is not
    # put on a log axis, only floating-point data is
    from pv_hdrvol.raycast.grid import default_transfer_function

    vals = np.arange(1, 5001, dtype=np.int16).reshape(10, 20, 25)
    assert default_transfer_function(hv.volume_from_array(vals)).scale == "linear"
    assert default_transfer_function(hv.volume_from_array(vals.astype(np.float32))).scale == "log"


# -- empty renders say why ------------------------------------------------------------
from pv_hdrvol.raycast.grid import EmptyRenderWarning  # noqa: E402

GRAY_TF = hv.TransferFunction.ramp(0.0, 2.0, cmap="gray", opacity=(0.5, 0.5))


def _no_warning(*args, **kwargs):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", EmptyRenderWarning)
        return hv.render(*args, **kwargs)


@pytest.mark.parametrize("shape", [(5, 5, 1), (1, 4, 4), (1, 1, 1)])
def test_a_flat_numpy_volume_renders_empty_with_a_warning(shape):
    with pytest.warns(EmptyRenderWarning, match=r"^the volume is flat \(one point thick along an axis\): rays "
                                                r"cross no thickness, so the image is empty; a 2-D image cannot "
                                                r"be volume rendered$"):
        img = hv.render(np.ones(shape), GRAY_TF, None, (8, 8))
    assert not img.rgba.any()


@pytest.mark.parametrize("fill", [np.nan, np.inf, -np.inf])
def test_a_volume_without_finite_values_warns(fill):
    vals = np.full((4, 5, 6), fill)
    with pytest.warns(EmptyRenderWarning, match=r"^the volume has no finite value \(all NaN or \+-inf\), so the "
                                                r"image is empty$"):
        img = hv.render(vals, None, None, (8, 8))
    assert not img.rgba.any()
    assert np.isnan(vals).all() or np.isinf(vals).all()  # the caller's data is untouched


def test_constant_data_with_the_default_transfer_function_warns():
    with pytest.warns(EmptyRenderWarning) as record:
        img = hv.render(np.full((4, 5, 6), 3.0), None, None, (8, 8))
    assert not img.rgba.any()
    assert str(record[0].message) == (
        "the transfer function's opacity is 0 over the whole data range [3, 3] (transfer function range [3, 4], "
        "scale='linear'), so the image is empty; the data is constant (3) and the default transfer function's "
        "opacity is 0 there: pass a tf with opacity at that value")
    # with a transfer function that is opaque there, the same data renders and says nothing
    assert _no_warning(np.full((4, 5, 6), 3.0), hv.TransferFunction.ramp(0, 4, opacity=(1, 1)), None,
                       (8, 8)).rgba[..., 3].max() > 0


def test_a_log_axis_over_data_without_positive_values_warns():
    tf = hv.TransferFunction.ramp(1e-3, 1e3, scale="log", cmap="gray")
    vals = -np.linspace(0, 5, 4 * 5 * 6).reshape(4, 5, 6)
    with pytest.warns(EmptyRenderWarning) as record:
        img = hv.render(vals, tf, None, (8, 8))
    assert not img.rgba.any()
    assert str(record[0].message) == (
        "the transfer function's opacity is 0 over the whole data range [-5, -0] (transfer function range "
        "[0.001, 1000], scale='log'), so the image is empty; a log axis maps values <= 0 below its range and "
        "the data has no positive value")


def test_a_valid_render_does_not_warn_and_a_projection_keeps_its_values():
    vals = np.linspace(0, 1, 4 * 5 * 6).reshape(4, 5, 6)
    assert _no_warning(vals, None, None, (8, 8)).rgba[..., 3].max() > 0
    # a zero-opacity transfer function still gives a projection its value image
    zero = hv.TransferFunction.ramp(0, 1, cmap="gray", opacity=(0, 0))
    assert np.nanmax(_no_warning(vals, zero, None, (8, 8), blending="maximum").value) > 0


@pytest.mark.parametrize("dims,preference,got", [
    ((8, 8, 1), "point", "dimensions (8, 8, 1)"),
    ((1, 1, 1), "point", "dimensions (1, 1, 1)"),
    ((6, 6, 2), "cell", "(5, 5, 1) cells of cell data 'c'"),
])
def test_a_2d_image_dataset_is_refused_like_a_2d_array(dims, preference, got):
    pv = pytest.importorskip("pyvista")
    grid = pv.ImageData(dimensions=dims)
    if preference == "cell":
        grid["c"] = np.ones(grid.n_cells)
    else:
        grid["p"] = np.ones(grid.n_points)
    what = "cells" if preference == "cell" else "points"
    with pytest.raises(ValueError, match=rf"^image data must be 3-D, with at least 2 {what} along every axis; "
                                         rf"got {re.escape(got)}: a 2-D image or a single voxel has no "
                                         rf"thickness to render$"):
        hv.render(grid, GRAY_TF, None, (8, 8))
    with pytest.raises(ValueError, match=r"^volume values must be a 3-D array; got 2-D"):
        hv.render(np.ones((8, 8)), GRAY_TF, None, (8, 8))


def test_a_mesh_with_constant_values_warns():
    pv = pytest.importorskip("pyvista")
    mesh = pv.ImageData(dimensions=(3, 3, 3)).triangulate()
    mesh["s"] = np.full(mesh.n_points, 2.0)
    with pytest.warns(EmptyRenderWarning, match=r"^the transfer function's opacity is 0 over the whole data "
                                                r"range \[2, 2\] .*the data is constant \(2\)"):
        img = hv.render(mesh, None, None, (8, 8))
    assert not img.rgba.any()
    mesh["s"] = np.full(mesh.n_points, np.nan)
    with pytest.warns(EmptyRenderWarning, match=r"^the mesh has no finite value"):
        hv.render(mesh, None, None, (8, 8))


def test_the_cli_prints_the_warning_on_stderr(tmp_path):
    pv = pytest.importorskip("pyvista")
    import os
    import subprocess
    import sys

    grid = pv.ImageData(dimensions=(6, 6, 6))
    grid["v"] = np.full(grid.n_points, 2.0)
    grid.save(tmp_path / "const.vti")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root, "PYTHONWARNINGS": ""}
    result = subprocess.run([sys.executable, "-m", "pv_hdrvol.integrations.cli", "render", str(tmp_path / "const.vti"),
                             "-o", str(tmp_path / "c.npy"), "--size", "8", "--no-progress"],
                            capture_output=True, text=True, timeout=600, env=env)
    assert result.returncode == 0, result.stderr
    assert "EmptyRenderWarning: the transfer function's opacity is 0 over the whole data range [2, 2]" \
        in result.stderr
