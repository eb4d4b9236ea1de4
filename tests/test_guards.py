"""Guards a newcomer met (issue 18): few kernel dtypes, empty renders that say why,
memory estimates, interruptible renders, PyVista's keywords."""
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
