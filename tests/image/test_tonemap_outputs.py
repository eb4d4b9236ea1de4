"""Detail measure, exposure bracket, pseudocolour, HDR sequences and movies."""
import math

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.image.detail import detail_preserved, display_levels
from pv_hdrvol.image.sequence import orbit, tonemap_sequence, write_movie, write_sequence
from pv_hdrvol.image.views import contact_sheet, pseudocolor


def scene(shape=(40, 60), decades=8.0, bright=None):
    r, c = np.mgrid[0:shape[0], 0:shape[1]]
    logl = -decades / 2 + decades * c / (shape[1] - 1) + 0.05 * np.sin(r * 1.3) * np.cos(c * 0.7)
    lum = 10.0 ** logl
    if bright is not None:
        lum[bright] = 1e6
    rgba = np.zeros(shape + (4,))
    rgba[..., :3] = lum[..., None]
    rgba[..., 3] = 1.0
    return hv.HDRImage(rgba)


# -- detail measure ------------------------------------------------------------------------
def test_detail_counts_flattened_and_reversed_pairs():
    ref = np.array([[1.0, 2.0, 4.0, 8.0]])
    same_order = np.array([[[10] * 3, [20] * 3, [30] * 3, [40] * 3]], np.uint8)
    flattened = np.array([[[10] * 3, [20] * 3, [20] * 3, [40] * 3]], np.uint8)
    reversed_ = np.array([[[10] * 3, [20] * 3, [15] * 3, [40] * 3]], np.uint8)
    assert detail_preserved(ref, same_order) == 1.0
    assert detail_preserved(ref, flattened) == pytest.approx(2 / 3)
    assert detail_preserved(ref, reversed_) == pytest.approx(2 / 3)
    # below the contrast threshold a pair is not detail at all
    assert math.isnan(detail_preserved(np.array([[1.0, 1.01]]), same_order[:, :2]))
    mask = np.array([[True, True, False, False]])
    assert detail_preserved(ref, flattened, mask=mask) == 1.0


def test_hdr_operators_keep_more_detail_than_an_8_bit_window():
    img = scene()
    linear = detail_preserved(img, hv.tonemap(img, "linear"))
    for name, params in [("reinhard", {}), ("drago", {}), ("durand", {}), ("reinhard", {"local": True})]:
        assert detail_preserved(img, hv.tonemap(img, name, **params)) > linear + 0.2, name
    assert linear < 0.6


def test_display_levels_of_floats_quantise_like_a_display():
    f = np.array([[[0.5, 0.5, 0.5], [1.2, 1.2, 1.2], [np.nan, 0, 0]]])
    assert display_levels(f).tolist() == [[128, 255, 0]]
    with pytest.raises(ValueError, match="display has shape \\(1, 3\\); the reference has \\(2, 2\\)"):
        detail_preserved(np.ones((2, 2)), f)
    with pytest.raises(ValueError, match="contrast must be > 0; got 0"):
        detail_preserved(np.ones((1, 3)), f, contrast=0)


# -- bracket and pseudocolour ----------------------------------------------------------------
def test_contact_sheet_tiles_are_the_linear_exposures():
    img = scene((10, 12))
    sheet, ev = contact_sheet(img, stops=[-2, 0, 2, 4], columns=2, gap=3)
    assert sheet.shape == (23, 27, 3)
    for i, e in enumerate(ev):
        r, c = divmod(i, 2)
        tile = sheet[r * 13:r * 13 + 10, c * 15:c * 15 + 12]
        assert np.array_equal(tile, hv.tonemap(img, "linear", exposure_stops=e).rgb8)
    assert ev[1] - ev[0] == pytest.approx(2.0)


def test_pseudocolor_follows_log_luminance():
    pytest.importorskip("matplotlib")
    img = scene((4, 50), decades=10.0)
    rgb, (lo, hi) = pseudocolor(img, "gray")
    assert hi - lo == pytest.approx(10.0, abs=0.2)
    row = rgb[0, :, 0].astype(int)
    assert np.all(np.diff(row) >= 0) and row[0] < 5 and row[-1] > 250
    black = scene((4, 5))
    black.rgba[0, 0] = 0
    assert pseudocolor(black)[0][0, 0].tolist() == [0, 0, 0]


# -- sequences -----------------------------------------------------------------------------
def test_orbit_turns_about_the_focal_point():
    cam = hv.Camera((1, 2, 8), (1, 2, 3), (0, 1, 0))
    cams = orbit(cam, 4)
    for c in cams:
        assert c.distance == pytest.approx(5.0)
        assert c.focal_point == cam.focal_point
    np.testing.assert_allclose(cams[1].position, (6, 2, 3), atol=1e-12)
    np.testing.assert_allclose(cams[2].position, (1, 2, -2), atol=1e-12)
    with pytest.raises(ValueError, match="n_frames must be an integer >= 1; got 0"):
        orbit(cam, 0)


def test_one_mapping_for_the_whole_sequence_does_not_flicker():
    spot = (slice(0, 3), slice(0, 3))
    frames = [scene(), scene(bright=spot), scene()]
    steady = tonemap_sequence(frames, "reinhard")
    elsewhere = (slice(10, None), slice(None))
    assert np.array_equal(steady[0].rgb[elsewhere], steady[1].rgb[elsewhere])
    per_frame = tonemap_sequence(frames, "reinhard", adapt="frame")
    assert not np.allclose(per_frame[0].rgb[elsewhere], per_frame[1].rgb[elsewhere], atol=1e-3)
    assert np.array_equal(per_frame[0].rgb, per_frame[2].rgb)
    # local operators share their anchors too
    durand = tonemap_sequence(frames, "durand")
    assert durand[0].fitted is durand[1].fitted
    with pytest.raises(ValueError, match="adapt must be one of \\('sequence', 'frame'\\); got 'shot'"):
        tonemap_sequence(frames, adapt="shot")


def test_write_sequence_and_movies(tmp_path):
    pytest.importorskip("OpenEXR")
    frames = [scene((16, 20)) for _ in range(3)]
    for i, f in enumerate(frames):
        f.rgba[:, : 5 * (i + 1), :3] *= 10.0  # frames differ (a GIF merges repeated frames)
    paths = write_sequence(frames, tmp_path / "seq", metadata={"sweep": "orbit"})
    assert [p.name for p in paths] == ["frame_0000.exr", "frame_0001.exr", "frame_0002.exr"]
    assert "frame" not in frames[1].metadata  # the caller's frames are not modified
    back = hv.load(paths[1])
    assert back.metadata["frame"] == 1 and back.metadata["sequence_length"] == 3
    assert back.metadata["sweep"] == "orbit"
    np.testing.assert_array_equal(back.rgba, frames[1].rgba.astype(np.float32))
    with pytest.raises(FileExistsError, match="frame_0000.exr exists"):
        write_sequence(frames, tmp_path / "seq")

    PIL = pytest.importorskip("PIL.Image")
    gif = write_movie(paths, tmp_path / "orbit.gif", "drago", fps=10)
    with PIL.open(gif) as im:
        assert im.n_frames == 3
    imageio = pytest.importorskip("imageio.v2")
    pytest.importorskip("imageio_ffmpeg")
    mp4 = write_movie(paths, tmp_path / "orbit.mp4", "reinhard", fps=10)
    got = imageio.mimread(mp4)
    assert len(got) == 3 and got[0].shape[:2] == (16, 20)
    with pytest.raises(ValueError, match="movie path must end in .gif or .mp4; got 'x.avi'"):
        write_movie(paths, tmp_path / "x.avi")


@pytest.mark.data
def test_every_operator_keeps_more_detail_than_the_8_bit_pipeline_on_real_hdr_data(shared_data):
    pv = pytest.importorskip("pyvista")
    grid = pv.read(shared_data / "hdr" / "m4_total_density_25x22x31_float32.vti")
    tf = hv.TransferFunction.ramp(1e-12, 0.5, scale="log", cmap="magma", opacity=(0.0, 0.5))
    kw = dict(size=(192, 192), global_alpha=0.05, progress_bar=False)
    ref = hv.render(grid, tf, precision="float64", **kw)
    base = detail_preserved(ref, hv.tonemap(hv.render(grid, tf, precision="uint8", **kw), "linear", exposure_stops=0))
    kept = {name: detail_preserved(ref, hv.tonemap(ref, name)) for name in ["linear", "reinhard", "drago", "durand", "fattal"]}
    assert base < 0.7
    for name, value in kept.items():
        assert value > base + 0.1, (name, value, base)
