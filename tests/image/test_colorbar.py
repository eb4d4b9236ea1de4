"""The colour bar beside a preview: the transfer function's colours at their values, ticks in data units."""
import numpy as np
import pytest

import pv_hdrvol as hv

pytest.importorskip("matplotlib")
from pv_hdrvol.image.colorbar import colorbar_figure  # noqa: E402


def _bar_colour(fig, value):
    """The 8-bit RGB the drawn figure shows in the middle of the bar at data ``value``."""
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())
    x, y = fig.axes[0].transData.transform((0.5, value))
    return pixels[pixels.shape[0] - 1 - int(round(y)), int(round(x)), :3].astype(int)


@pytest.mark.parametrize(("scale", "vmin", "vmax", "probes"), [
    ("log", 1e-12, 1e-3, [3e-12, 1e-9, 4e-6, 5e-4]),
    ("linear", -2.0, 3.0, [-1.9, 0.0, 1.5, 2.9]),
    ("symlog", -1e3, 1e4, [-500.0, -0.5, 0.0, 2.0, 5e3]),
])
def test_bar_shows_the_transfer_function_colour_at_each_value(scale, vmin, vmax, probes):
    tf = hv.TransferFunction.ramp(vmin, vmax, scale=scale, cmap="viridis", linthresh=0.1)
    fig = colorbar_figure(np.zeros((300, 40, 3), np.uint8), tf, label="density")
    for v in probes:
        expected = np.round(tf.color_at(v) * 255).astype(int)
        assert np.abs(_bar_colour(fig, v) - expected).max() <= 3, (v, _bar_colour(fig, v), expected)


def test_log_axis_has_power_of_ten_ticks_over_the_range():
    tf = hv.TransferFunction.ramp(1e-12, 1e-3, scale="log", cmap="magma")
    fig = colorbar_figure(np.zeros((64, 64, 3), np.uint8), tf, label="density (g/cm^3)")
    bar = fig.axes[0]
    fig.canvas.draw()
    assert bar.get_yscale() == "log"
    assert bar.get_ylim() == pytest.approx((1e-12, 1e-3))
    ticks = [t for t in bar.get_yticks() if 1e-12 <= t <= 1e-3]
    exponents = np.log10(ticks)
    assert len(ticks) >= 3 and np.allclose(exponents, np.round(exponents))
    assert bar.get_ylabel() == "density (g/cm^3)"


def test_linear_axis_ticks_in_data_units():
    tf = hv.TransferFunction.ramp(200.0, 300.0, cmap="gray")
    fig = colorbar_figure(np.zeros((64, 64, 3), np.uint8), tf)
    bar = fig.axes[0]
    fig.canvas.draw()
    assert bar.get_yscale() == "linear" and bar.get_ylim() == pytest.approx((200.0, 300.0))
    ticks = [t for t in bar.get_yticks() if 200 <= t <= 300]
    assert len(ticks) >= 3 and ticks == pytest.approx(np.round(ticks, 6))


def test_picture_is_placed_pixel_for_pixel():
    rng = np.random.default_rng(1)
    picture = rng.integers(0, 256, (250, 90, 3), dtype=np.uint8)
    fig = colorbar_figure(picture, hv.TransferFunction.ramp(0.0, 1.0, cmap="gray"))
    fig.canvas.draw()
    pixels = np.asarray(fig.canvas.buffer_rgba())[..., :3]
    assert pixels.shape[0] == 250 and pixels.shape[1] > 90
    np.testing.assert_array_equal(pixels[:, :90], picture)


def test_hdr_emission_keeps_its_hue_in_the_bar():
    tf = hv.TransferFunction([0.0, 1.0], [[4.0, 2.0, 0.0], [4.0, 2.0, 0.0]], [0.5, 0.5])
    fig = colorbar_figure(np.zeros((300, 40, 3), np.uint8), tf)
    np.testing.assert_allclose(_bar_colour(fig, 0.5), [255, 128, 0], atol=1)


def test_picture_must_be_8_bit_rgb():
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray")
    with pytest.raises(ValueError, match=r"picture must be a uint8 array of shape \(rows, cols, 3\); got float64 "
                                         r"\(4, 4, 3\)"):
        colorbar_figure(np.zeros((4, 4, 3)), tf)
