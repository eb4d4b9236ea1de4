"""Radiance .hdr (RGBE) reading and writing: pv_hdrvol.image.rgbe and HDRImage .hdr."""
import doctest
import json
import pathlib
import re

import numpy as np
import pytest

from pv_hdrvol.image import rgbe
from pv_hdrvol.image.hdr import HDRImage
from pv_hdrvol.image.rgbe import read_hdr, write_hdr

pytestmark = pytest.mark.core


def _log_uniform(shape, lo, hi, seed=0):
    rng = np.random.default_rng(seed)
    return np.exp(rng.uniform(np.log(lo), np.log(hi), shape))


def _step(rgb):
    """One mantissa step ``2**(e - 8)`` per pixel, e the exponent of its largest component."""
    _, e = np.frexp(np.asarray(rgb, np.float64).max(axis=2))
    return np.ldexp(1.0, e - 8)[..., None]


def _body(path):
    """The bytes after the resolution line."""
    data = pathlib.Path(path).read_bytes()
    return data[data.index(b"\n\n") + 2:].split(b"\n", 1)[1]


def _file(tmp_path, resolution, body, header=b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n", name="hand.hdr"):
    path = tmp_path / name
    path.write_bytes(header + resolution + b"\n" + bytes(body))
    return path


def test_docstring_examples():
    result = doctest.testmod(rgbe, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


@pytest.mark.parametrize("rle", [True, False])
def test_round_trip_30_decades_within_half_a_step(tmp_path, rle):
    """Each component comes back within half a mantissa step, ``2**(e - 9)``.

    ``e`` is the exponent of the pixel's largest component ``v = m 2**e``: the file keeps
    ``floor(c 2**(8 - e))`` and the reader returns the bin centre, so the error is at most
    ``2**(e - 9)``, half the ``2**(e - 8)`` of the brief; float32 output rounding adds at
    most ``2**(e - 24)``. The input is not modified.
    """
    rgb = _log_uniform((33, 41, 3), 1e-30, 1e30)
    before = rgb.copy()
    write_hdr(tmp_path / "x.hdr", rgb, rle=rle)
    out, header = read_hdr(tmp_path / "x.hdr")
    np.testing.assert_array_equal(rgb, before)
    assert out.dtype == np.float32 and out.shape == rgb.shape
    assert header == {"format": "32-bit_rle_rgbe", "exposure": 1.0, "metadata": {}, "lines": []}
    err = np.abs(out.astype(np.float64) - rgb)
    bound = _step(rgb) * (0.5 + 2.0 ** -16)
    assert np.all(err <= bound), float((err / _step(rgb)).max())
    # and not trivially: errors use most of the half step
    assert (err / _step(rgb)).max() > 0.45


@pytest.mark.parametrize("rle", [True, False])
def test_rewriting_a_decoded_image_gives_the_same_bytes(tmp_path, rle):
    rgb = _log_uniform((16, 300, 3), 1e-20, 1e20, seed=1)
    write_hdr(tmp_path / "a.hdr", rgb, rle=rle)
    once, _ = read_hdr(tmp_path / "a.hdr")
    write_hdr(tmp_path / "b.hdr", once, rle=rle)
    assert (tmp_path / "a.hdr").read_bytes() == (tmp_path / "b.hdr").read_bytes()


def test_rle_and_flat_files_decode_identically(tmp_path):
    rgb = _log_uniform((20, 50, 3), 1e-3, 1e3, seed=2)
    rgb[5:9] = 7.0  # runs
    write_hdr(tmp_path / "r.hdr", rgb, rle=True)
    write_hdr(tmp_path / "f.hdr", rgb, rle=False)
    np.testing.assert_array_equal(read_hdr(tmp_path / "r.hdr")[0], read_hdr(tmp_path / "f.hdr")[0])
    assert len(_body(tmp_path / "f.hdr")) == 20 * 50 * 4


def test_below_1e_32_is_black_and_1e_32_is_not(tmp_path):
    rgb = np.array([[[9.99e-33, 1e-40, 0.0], [0.0, 0.0, 0.0], [1e-300, 0.0, 5e-33], [1e-32, 0.0, 0.0]]])
    write_hdr(tmp_path / "x.hdr", rgb)
    out, _ = read_hdr(tmp_path / "x.hdr")
    assert np.all(out[0, :3] == 0.0)
    assert abs(out[0, 3, 0] - 1e-32) <= 2.0 ** (-106 - 9) * 1.001  # e = -106 for 1e-32
    assert out[0, 3, 1] > 0  # the bin centre: a black component of a lit pixel reads as half a step


def test_bin_centres_round_trip_exactly(tmp_path):
    """``(b + 0.5) 2**(e - 8)`` with ``b >= 128`` for the largest component is stored and read exactly."""
    exact = np.array([[[255.5 / 128, 128.5 / 128, 64.5 / 128], [0.5 / 128, 0.5 / 128, 128.5 / 128],
                       [128.5 * 2.0 ** 92, 3.5 * 2.0 ** 92, 200.5 * 2.0 ** 92],
                       [130.5 * 2.0 ** -100, 255.5 * 2.0 ** -100, 0.5 * 2.0 ** -100]]])
    for rle in (True, False):
        write_hdr(tmp_path / "x.hdr", exact, rle=rle)
        out, _ = read_hdr(tmp_path / "x.hdr")
        np.testing.assert_array_equal(out, exact.astype(np.float32))
        assert np.all(out.astype(np.float64) == exact)
    # 1.0 itself is not a bin centre: it reads back as 128.5 / 128
    write_hdr(tmp_path / "one.hdr", np.ones((1, 1, 3)))
    assert read_hdr(tmp_path / "one.hdr")[0][0, 0, 0] == np.float32(128.5 / 128)


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64, np.int32, np.uint8])
def test_real_dtypes_and_str_path(tmp_path, dtype):
    rgb = (np.arange(2 * 9 * 3).reshape(2, 9, 3) % 7).astype(dtype)
    write_hdr(str(tmp_path / "x.hdr"), rgb)
    out, _ = read_hdr(str(tmp_path / "x.hdr"))
    ref = rgb.astype(np.float64)
    assert np.all(np.abs(out - ref) <= _step(ref) / 2)


def test_constant_image_uses_runs(tmp_path):
    rgb = np.full((256, 256, 3), 0.75)
    rgb[..., 2] = 0.25
    write_hdr(tmp_path / "rle.hdr", rgb)
    write_hdr(tmp_path / "flat.hdr", rgb, rle=False)
    rle, flat = _body(tmp_path / "rle.hdr"), _body(tmp_path / "flat.hdr")
    assert len(flat) == 256 * 256 * 4
    # per scanline: 2,2,1,0 then per component runs of 127, 127 and 2 (two bytes each)
    assert len(rle) == 256 * (4 + 4 * 3 * 2)
    assert rle[:10] == bytes([2, 2, 1, 0, 128 + 127, 192, 128 + 127, 192, 128 + 2, 192])
    assert len(flat) / len(rle) > 30
    out_rle, out_flat = read_hdr(tmp_path / "rle.hdr")[0], read_hdr(tmp_path / "flat.hdr")[0]
    np.testing.assert_array_equal(out_rle, out_flat)
    assert np.all(out_rle == np.float32([192.5 / 256, 192.5 / 256, 64.5 / 256]))


def test_literal_packets_hold_at_most_128_bytes(tmp_path):
    # R bytes 0..255 cycling (no runs) over 300 pixels: literals of 128, 128 and 44
    r = (np.arange(300) % 256 + 0.25) / 256.0
    rgb = np.stack([r, np.full(300, 0.999), np.zeros(300)], axis=-1)[None]
    write_hdr(tmp_path / "x.hdr", rgb)
    body = _body(tmp_path / "x.hdr")
    assert body[4] == 128 and body[4 + 129] == 128 and body[4 + 258] == 44
    out, _ = read_hdr(tmp_path / "x.hdr")
    assert np.all(np.abs(out - rgb) <= _step(rgb) / 2)


@pytest.mark.parametrize("cols", [7, 40000])
def test_too_narrow_or_wide_for_rle_is_flat(tmp_path, cols):
    rgb = _log_uniform((3 if cols == 7 else 1, cols, 3), 1e-5, 1e5, seed=cols)
    write_hdr(tmp_path / "x.hdr", rgb, rle=True)
    body = _body(tmp_path / "x.hdr")
    assert len(body) == rgb.shape[0] * cols * 4
    out, _ = read_hdr(tmp_path / "x.hdr")
    assert np.all(np.abs(out - rgb) <= _step(rgb) / 2 * (1 + 2.0 ** -15))


def test_hand_built_rle_scanline(tmp_path):
    body = [2, 2, 0, 8,
            128 + 8, 128,                              # R: one run of 8
            8, 0, 10, 20, 30, 40, 50, 60, 70,          # G: one literal of 8
            128 + 2, 255, 6, 1, 2, 3, 4, 5, 6,         # B: a run of 2 then a literal of 6
            128 + 3, 129, 0, 5, 129, 129, 129, 129, 129]  # E: a run of 3, an empty literal, a literal of 5
    rgb, header = read_hdr(_file(tmp_path, b"-Y 1 +X 8", body))
    expected = np.stack([np.full(8, 128.5), np.arange(8) * 10 + 0.5,
                         np.array([255, 255, 1, 2, 3, 4, 5, 6]) + 0.5], axis=-1)[None] / 128
    np.testing.assert_array_equal(rgb, expected.astype(np.float32))
    assert header["format"] == "32-bit_rle_rgbe"


def test_hand_built_bottom_to_top_flat(tmp_path):
    bottom = [128, 0, 0, 129] * 8
    top = [0, 0, 128, 130] * 8
    rgb, _ = read_hdr(_file(tmp_path, b"+Y 2 +X 8", bottom + top))
    np.testing.assert_array_equal(rgb[0], np.tile([0.5 / 64, 0.5 / 64, 128.5 / 64], (8, 1)))
    np.testing.assert_array_equal(rgb[1], np.tile([128.5 / 128, 0.5 / 128, 0.5 / 128], (8, 1)))
    # the same pixels in the standard orientation: first scanline on top
    rgb, _ = read_hdr(_file(tmp_path, b"-Y 2 +X 8", bottom + top))
    assert rgb[0, 0, 0] == np.float32(128.5 / 128) and rgb[1, 0, 2] == np.float32(128.5 / 64)


def test_hand_built_old_style_runs_and_header(tmp_path):
    a, b = [200, 100, 0, 128], [0, 0, 255, 127]
    # width 5: a, then "repeat 3 times", then b; second scanline: repeat b (previous scanline's last) 5 times
    body = a + [1, 1, 1, 3] + b + [1, 1, 1, 5]
    header = b"#?RGBE\nSOFTWARE=hand\nEXPOSURE=2\nEXPOSURE= 0.25\nPV_HDRVOL={\"k\": [1, 2]}\nFORMAT=32-bit_rle_rgbe\n\n"
    rgb, head = read_hdr(_file(tmp_path, b"-Y 2 +X 5", body, header))
    pa = np.float32(np.array(a[:3]) + 0.5) / 256
    pb = np.float32(np.array(b[:3]) + 0.5) / 512
    np.testing.assert_array_equal(rgb[0], [pa, pa, pa, pa, pb])
    np.testing.assert_array_equal(rgb[1], [pb] * 5)
    assert head == {"format": "32-bit_rle_rgbe", "exposure": 0.5, "metadata": {"k": [1, 2]}, "lines": ["SOFTWARE=hand"]}


def test_metadata_round_trip(tmp_path):
    meta = {"precision": "float64", "step": 0.5, "size": [640, 480], "samples": 12, "ok": True,
            "note": "two\nlines, ünïcode", "none": None, "nested": {"a": [1.5, "x"]}}
    write_hdr(tmp_path / "m.hdr", np.ones((2, 8, 3)), meta)
    _, header = read_hdr(tmp_path / "m.hdr")
    assert header["metadata"] == meta
    text = (tmp_path / "m.hdr").read_bytes()
    line = b"PV_HDRVOL=" + json.dumps(meta).encode() + b"\n"
    assert text.startswith(b"#?RADIANCE\n" + line + b"FORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 8\n")


def test_bad_input_values(tmp_path):
    rgb = np.ones((2, 4, 3))
    rgb[0, 0] = np.nan
    rgb[1, 1, 2] = -1e-9
    with pytest.raises(ValueError, match=re.escape(
            "Radiance RGBE stores finite non-negative values; rgb has 3 NaN, 0 infinite and 1 negative values")):
        write_hdr(tmp_path / "never.hdr", rgb)
    rgb = np.ones((2, 4, 3))
    rgb[0, 0, :2] = [np.inf, -np.inf]
    with pytest.raises(ValueError, match="rgb has 0 NaN, 2 infinite and 0 negative values"):
        write_hdr(tmp_path / "never.hdr", rgb)
    with pytest.raises(ValueError, match=r"below 2\*\*127 .* rgb has 1 values at or above it"):
        write_hdr(tmp_path / "never.hdr", np.full((1, 1, 3), 1.0) * [1, 1, 2.0 ** 127])
    assert not (tmp_path / "never.hdr").exists()


@pytest.mark.parametrize("shape", [(4, 4), (4, 4, 4), (2, 2, 2, 3), (0, 4, 3)])
def test_bad_shape(tmp_path, shape):
    with pytest.raises(ValueError, match=re.escape(f"got {shape}") if len(shape) != 3 or shape[2] != 3
                       else r"at least one row and one column; got shape \(0, 4, 3\)"):
        write_hdr(tmp_path / "x.hdr", np.zeros(shape))


def test_bad_types(tmp_path):
    with pytest.raises(TypeError, match="rgb must hold real numbers .* got dtype complex128"):
        write_hdr(tmp_path / "x.hdr", np.zeros((2, 2, 3), complex))
    with pytest.raises(TypeError, match="got dtype bool"):
        write_hdr(tmp_path / "x.hdr", np.zeros((2, 2, 3), bool))
    with pytest.raises(TypeError, match="metadata must be JSON-serialisable .* not JSON serializable"):
        write_hdr(tmp_path / "x.hdr", np.zeros((2, 2, 3)), {"when": object()})
    with pytest.raises(TypeError, match="metadata must be a dict or None; got list"):
        write_hdr(tmp_path / "x.hdr", np.zeros((2, 2, 3)), [1, 2])
    with pytest.raises(TypeError):
        write_hdr(42.0, np.zeros((2, 2, 3)))


def test_bad_files(tmp_path):
    with pytest.raises(ValueError, match="is not a Radiance picture: it starts with b'P6"):
        read_hdr(_file(tmp_path, b"", b"", header=b"P6\n8 8\n255\n"))
    with pytest.raises(ValueError, match="XYZE is not supported"):
        read_hdr(_file(tmp_path, b"-Y 1 +X 1", [128] * 4, header=b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n"))
    with pytest.raises(ValueError, match=r"unsupported orientation '-Y 1 -X 1'; only '-Y rows \+X cols'"):
        read_hdr(_file(tmp_path, b"-Y 1 -X 1", [128] * 4))
    with pytest.raises(ValueError, match="unsupported orientation '\\+X 1 -Y 1'"):
        read_hdr(_file(tmp_path, b"+X 1 -Y 1", [128] * 4))
    with pytest.raises(ValueError, match="bad resolution string"):
        read_hdr(_file(tmp_path, b"640x480", [128] * 4))
    with pytest.raises(ValueError, match="the header has no end"):
        read_hdr(_file(tmp_path, b"", b"", header=b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe"))
    with pytest.raises(ValueError, match="bad run-length data in scanline 1 of 1"):
        read_hdr(_file(tmp_path, b"-Y 1 +X 8", [2, 2, 0, 8, 128 + 9, 1]))
    with pytest.raises(ValueError, match="scanline 1 of 1 does not have the width 8"):
        read_hdr(_file(tmp_path, b"-Y 1 +X 8", [2, 2, 0, 9]))
    with pytest.raises(ValueError, match="scanline 1 of 1 starts with a repeat of a previous pixel"):
        read_hdr(_file(tmp_path, b"-Y 1 +X 2", [1, 1, 1, 2]))


@pytest.mark.parametrize("rle", [True, False])
def test_truncated(tmp_path, rle):
    rgb = _log_uniform((64, 20, 3), 1e-3, 1e3, seed=3)
    write_hdr(tmp_path / "x.hdr", rgb, rle=rle)
    data = (tmp_path / "x.hdr").read_bytes()
    body_start = len(data) - len(_body(tmp_path / "x.hdr"))
    # cut inside the 17th scanline (flat: 80 bytes each); for RLE, halfway through the data
    cut = body_start + 16 * 80 + 5 if not rle else (len(data) + body_start) // 2
    (tmp_path / "x.hdr").write_bytes(data[:cut])
    with pytest.raises(ValueError, match=r"truncated scanline \d+ of 64" if rle else "truncated scanline 17 of 64"):
        read_hdr(tmp_path / "x.hdr")
    (tmp_path / "x.hdr").write_bytes(data[:body_start])
    with pytest.raises(ValueError, match="truncated scanline 1 of 64: the file ends after 0 bytes"):
        read_hdr(tmp_path / "x.hdr")


def test_hdrimage_save_load(tmp_path):
    rng = np.random.default_rng(4)
    alpha = rng.uniform(0.0, 1.0, (12, 10, 1))
    rgba = np.concatenate([_log_uniform((12, 10, 3), 1e-6, 1e6, seed=5) * alpha, alpha], axis=2).astype(np.float32)
    meta = {"precision": "float32", "step": 0.25, "size": [10, 12], "samples": np.int64(7)}
    img = HDRImage(rgba.copy(), np.full((12, 10), 3.0), meta)
    assert img.save(tmp_path / "img.HDR") == tmp_path / "img.HDR"
    back = HDRImage.load(str(tmp_path / "img.HDR"))
    np.testing.assert_array_equal(img.rgba, rgba)
    rgb = rgba[..., :3].astype(np.float64)
    assert np.all(np.abs(back.rgba[..., :3] - rgb) <= _step(rgb) / 2 * (1 + 2.0 ** -15))
    assert back.rgba.dtype == np.float32 and np.all(back.rgba[..., 3] == 1.0)
    assert np.all(back.depth == np.inf)
    assert back.metadata == {"precision": "float32", "step": 0.25, "size": [10, 12], "samples": "7"}


def test_opencv_reads_ours_and_we_read_opencvs(tmp_path):
    """OpenCV decodes ``b 2**(E - 136)`` (no half step): exactly half a step below ours."""
    cv2 = pytest.importorskip("cv2")
    rgb = _log_uniform((24, 40, 3), 1e-4, 1e4, seed=6)
    write_hdr(tmp_path / "ours.hdr", rgb)
    theirs = cv2.imread(str(tmp_path / "ours.hdr"), cv2.IMREAD_ANYDEPTH | cv2.IMREAD_COLOR)
    assert theirs is not None and theirs.dtype == np.float32
    ours, _ = read_hdr(tmp_path / "ours.hdr")
    diff = ours.astype(np.float64) - theirs[..., ::-1]
    assert np.all(diff == _step(rgb) / 2)

    bgr = _log_uniform((24, 40, 3), 1e-4, 1e4, seed=7).astype(np.float32)
    assert cv2.imwrite(str(tmp_path / "cv.hdr"), bgr)
    back, header = read_hdr(tmp_path / "cv.hdr")
    original = bgr[..., ::-1].astype(np.float64)
    err = np.abs(back - original)
    assert np.all(err <= _step(original) / 2 * (1 + 2.0 ** -15))
    assert header["format"] == "32-bit_rle_rgbe"
