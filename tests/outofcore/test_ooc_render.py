"""Out-of-core rendering of multiresolution stores (pv_hdrvol.outofcore.render).

Exactness against the in-core render at level 0, the level of detail against hand
computation, the cache's byte cap, coarse ancestors instead of holes while chunks load,
chunks never read (empty, outside the view), a damaged chunk named, and opacity across
levels against the analytic slab."""
import math
import os
import threading
import time

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.data.grid import volume_from_array  # noqa: E402
from pv_hdrvol.outofcore.cache import SLOT_VALUES  # noqa: E402
from pv_hdrvol.outofcore.render import MultiscalePlan, open_multiscale  # noqa: E402
from pv_hdrvol.outofcore.store import write_multiscale  # noqa: E402
from pv_hdrvol.raycast.grid import default_transfer_function  # noqa: E402

SPACING = (1.0, 1.25, 0.75)
SIZE = (48, 40)


def _field(shape=(150, 131, 140)):
    z, y, x = np.mgrid[0:shape[0], 0:shape[1], 0:shape[2]].astype(np.float64)
    return (np.sin(x / 9.0) * np.cos(y / 13.0) + z / shape[0] + 0.2 * np.sin((x + y + z) / 5.0)).astype(np.float32)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    values = _field()
    path = tmp_path_factory.mktemp("ooc") / "field.ome.zarr"
    write_multiscale(values, path, spacing=SPACING, progress_bar=False)
    volume = volume_from_array(values, SPACING)
    tf = default_transfer_function(volume)
    return values, volume, tf, path


def _slow_store(volume, seconds, gate=None):
    """Make ``volume``'s store read each chunk ``seconds`` late (after ``gate`` is set)."""
    read = volume.store.read_chunk

    def slow(level, index):
        if gate is not None:
            gate.wait(30)
        time.sleep(seconds)
        return read(level, index)
    volume.store.read_chunk = slow


@pytest.mark.parametrize("precision", ["float32", "float64", "float16"])
@pytest.mark.parametrize("view", ["iso", "parallel", "inside"])
def test_level_0_equals_the_in_core_render_bit_for_bit(case, precision, view):
    """With every block at level 0 (a screen error far below a voxel) the pages hold the
    in-core values, the stencil reads them with the same arithmetic: equal bits."""
    values, volume, tf, path = case
    if view == "iso":
        camera = hv.Camera.fit(volume.bounds, "iso")
    elif view == "parallel":
        camera = hv.Camera.fit(volume.bounds, "xz")
        camera = hv.Camera(camera.position, camera.focal_point, camera.view_up, parallel_projection=True,
                           parallel_scale=60.0)
    else:  # the eye inside the volume, looking along a diagonal
        camera = hv.Camera((70.0, 80.0, 50.0), (140.0, 160.0, 110.0), (0, 0, 1), view_angle=60.0)
    reference = hv.render(volume, tf, camera, SIZE, precision=precision, progress_bar=False)
    with open_multiscale(path, cache_bytes=2 ** 28) as ooc:
        image = ooc.render(tf, camera, SIZE, screen_error=1e-9, precision=precision)
    assert image.metadata["levels"][1:] == [0] * (len(image.metadata["levels"]) - 1)
    assert image.metadata["converged"] is True
    assert image.rgba.dtype == reference.rgba.dtype
    assert np.array_equal(image.rgba, reference.rgba)
    assert np.array_equal(image.depth, reference.depth)
    assert reference.rgba[..., 3].max() > 0.2  # something to compare


def test_given_rays_and_a_clip_plane_render_at_level_0_as_in_core(case):
    values, volume, tf, path = case
    camera = hv.Camera.fit(volume.bounds, "iso")
    rays = camera.rays(SIZE)
    plane = ((70.0, 80.0, 50.0), (1.0, 0.3, -0.2))
    reference = hv.render(volume, tf, rays, clip_planes=[plane], progress_bar=False)
    with open_multiscale(path, cache_bytes=2 ** 28) as ooc:
        image = ooc.render(tf, rays, screen_error=1e-9, clip_planes=[plane])
    assert image.metadata["camera"] == "rays"
    assert np.array_equal(image.rgba, reference.rgba)


def test_level_of_detail_is_the_coarsest_whose_voxels_project_within_the_screen_error(case):
    """Parallel projection: a pixel is 2 scale / height world units everywhere, so every
    block asks for level floor(log2(screen_error * pixel / largest spacing))."""
    values, volume, tf, path = case
    with open_multiscale(path, cache_bytes=2 ** 28) as ooc:
        plan = MultiscalePlan(ooc, tf)
        base = hv.Camera.fit(volume.bounds, "xy")
        for scale, error, expected in [(60.0, 1.0, 1), (60.0, 0.5, 0), (60.0, 4.0, 2), (200.0, 1.0, 2),
                                       (20.0, 1.0, 0)]:
            cam = hv.Camera(base.position, base.focal_point, base.view_up, parallel_projection=True,
                            parallel_scale=scale)
            levels = plan.desired_levels(cam, (100, 40), error)
            pixel = 2 * scale / 40
            hand = min(max(math.floor(math.log2(error * pixel / max(SPACING))), 0), ooc.n_levels - 1)
            assert hand == expected
            shown = levels[levels >= 0]
            assert shown.size > 0 and (shown == expected).all(), (scale, error, np.unique(shown))
        # perspective: the level grows with the distance of a block's nearest point
        cam = hv.Camera((70.0, 80.0, -100.0), (70.0, 80.0, 50.0), (0, 1, 0), view_angle=30.0)
        levels = plan.desired_levels(cam, (32, 32))
        pixel = plan.block_distance(cam) * 2 * math.tan(math.radians(15.0)) / 32
        hand = np.clip(np.floor(np.log2(pixel / max(SPACING))), 0, ooc.n_levels - 1)
        inside = levels >= 0
        assert np.array_equal(levels[inside], hand[inside])
        assert len(np.unique(levels[inside])) >= 2  # near blocks finer than far ones


def test_blocks_outside_the_view_are_never_read(case):
    """A narrow view down the z axis near the corner x = y = 0 (at most 30 units off it at
    the far side): only the blocks of the first column (64 cells in x and y) are seen;
    their samples read chunks 0 and 1 in x and y (point 64 is in chunk 1) and all 3 in
    z: 12 of the 27 chunks of level 0."""
    values, volume, tf, path = case
    camera = hv.Camera((20.0, 20.0, -60.0), (20.0, 20.0, 0.0), (0, 1, 0), view_angle=20.0)  # one corner
    reference = hv.render(volume, tf, camera, SIZE, progress_bar=False)
    with open_multiscale(path, cache_bytes=2 ** 28) as ooc:
        image = ooc.render(tf, camera, SIZE, screen_error=1e-9)
        read = image.metadata["chunks_read_per_level"][0]
        total = int(np.prod(ooc.store.levels[0].chunks))
    assert np.array_equal(image.rgba, reference.rgba)
    assert (read, total) == (12, 27)


def test_empty_blocks_are_never_read_and_the_image_is_unchanged(tmp_path):
    """x < 128 is 0, which the function makes transparent. The blocks of x cells 0..64 read
    only chunks 0 and 1 in x, both all zero by their stored ranges: not sampled, and chunk
    column 0 (9 of the 36 chunks of level 0) never read. The image is the in-core one."""
    values = _field((140, 140, 200))
    values[:, :, :128] = 0.0
    write_multiscale(values, tmp_path / "half.ome.zarr", progress_bar=False)
    volume = volume_from_array(values)
    tf = hv.TransferFunction([0.0, 0.05, 0.5, 1.4], [[0, 0, 0], [0.2, 0.1, 0.5], [1, 0.5, 0.2], [2, 2, 1]],
                             [0.0, 0.0, 0.02, 0.06])
    camera = hv.Camera.fit(volume.bounds, "iso")
    reference = hv.render(volume, tf, camera, SIZE, progress_bar=False)
    with open_multiscale(tmp_path / "half.ome.zarr", cache_bytes=2 ** 28) as ooc:
        assert ooc.store.levels[0].ranges[:, :, :2, 1].max() == 0.0
        image = ooc.render(tf, camera, SIZE, screen_error=1e-9)
        read = {k for k in ooc.cache()._slot_of if k[0] == 0}
    assert np.array_equal(image.rgba, reference.rgba)
    assert image.metadata["chunks_read_per_level"][0] == len(read) == 27
    assert not any(k[3] == 0 for k in read)


def test_the_cache_never_exceeds_its_bytes_coarsens_frames_and_converges_in_passes(case):
    """A cache of 12 slots for a frame that needs more: a frame that does not wait is
    coarsened to fit; the converged frame renders in passes (boxes of blocks whose chunks
    fit), composited per pixel -- the big cache's image to rounding, nothing coarsened;
    the pool never grows."""
    values, volume, tf, path = case
    camera = hv.Camera.fit(volume.bounds, "iso")
    with open_multiscale(path, cache_bytes=2 ** 28) as big:
        reference = big.render(tf, camera, SIZE, screen_error=1e-9)
    slot = SLOT_VALUES * 4
    with open_multiscale(path, cache_bytes=12 * slot) as ooc:
        quick = ooc.render(tf, camera, SIZE, screen_error=1e-9, wait=False)
        cache = ooc.cache()
        assert cache.pool.nbytes <= 12 * slot
        assert quick.metadata["coarsened"] >= 1 and quick.metadata["passes"] == 1
        assert quick.rgba[..., 3].max() > 0.1
        image = ooc.render(tf, camera, SIZE, screen_error=1e-9)
        assert image.metadata["passes"] >= 3 and image.metadata["converged"] is True
        assert image.metadata["levels"] == reference.metadata["levels"]
        assert cache.resident_bytes <= 12 * slot and cache.pool.nbytes <= 12 * slot
    assert np.abs(image.rgba - reference.rgba).max() < 1e-6
    with pytest.raises(ValueError, match=r"cache_bytes=1000 holds 0 chunks"):
        open_multiscale(path, cache_bytes=1000).cache()


def test_a_frame_before_chunks_arrive_shows_the_coarse_ancestors_never_a_hole(case):
    """A loader held back: the first frame samples the coarsest level (resident from the
    start) wherever finer chunks have not arrived -- bit for bit the render with every
    block at the coarsest level; once loaded, the converged frame is the level-0 one."""
    values, volume, tf, path = case
    camera = hv.Camera.fit(volume.bounds, "iso")
    with open_multiscale(path, cache_bytes=2 ** 28) as ooc:
        ooc.cache()  # the coarsest level, read now
        coarse = ooc.render(tf, camera, SIZE, screen_error=1e9)
        gate = threading.Event()
        _slow_store(ooc, 0.001, gate)
        early = ooc.render(tf, camera, SIZE, screen_error=1e-9, wait=False)
        assert early.metadata["converged"] is False and early.metadata["pending"] > 0
        assert early.metadata["levels"][-1] == sum(early.metadata["levels"])
        assert np.array_equal(early.rgba, coarse.rgba)
        gate.set()
        late = ooc.render(tf, camera, SIZE, screen_error=1e-9)
    reference = hv.render(volume, tf, camera, SIZE, progress_bar=False)
    assert late.metadata["converged"] is True
    assert np.array_equal(late.rgba, reference.rgba)


def test_frames_while_loading_never_show_a_hole(case):
    """Frames rendered while a slow loader fills the cache: every visible block of each
    frame samples a resident level at or above the one it asked for (the kernel's guard
    raises otherwise), and no pixel the converged image covers is empty in any frame."""
    values, volume, tf, path = case
    camera = hv.Camera.fit(volume.bounds, "iso")
    reference = hv.render(volume, tf, camera, SIZE, progress_bar=False)
    covered = reference.rgba[..., 3] > 0.05
    with open_multiscale(path, cache_bytes=2 ** 28) as ooc:
        ooc.cache()
        _slow_store(ooc, 0.02)
        frames = 0
        while True:
            image = ooc.render(tf, camera, SIZE, screen_error=1e-9, wait=False)
            frames += 1
            assert (image.rgba[..., 3][covered] > 0).all(), f"frame {frames} has a hole"
            if image.metadata["converged"]:
                break
            time.sleep(0.05)
    assert frames >= 3
    assert np.array_equal(image.rgba, reference.rgba)


def test_a_damaged_chunk_is_an_error_naming_it(tmp_path):
    """The one shard file of level 0 (all 8 of its chunks) removed: the render raises the
    loader thread's OSError naming a chunk and the file, not an image with a hole."""
    values = _field((100, 100, 100))
    store = write_multiscale(values, tmp_path / "bad.ome.zarr", progress_bar=False)
    os.remove(store.chunk_path(0, (1, 1, 1)))
    volume = volume_from_array(values)
    tf = default_transfer_function(volume)
    with open_multiscale(tmp_path / "bad.ome.zarr", cache_bytes=2 ** 28) as ooc:
        with pytest.raises(OSError, match=r"chunk \([01], [01], [01]\) of level 0 \(.*/0/c/0/0/0\) is missing"):
            ooc.render(tf, hv.Camera.fit(volume.bounds, "iso"), SIZE, screen_error=1e-9)


def test_every_level_gives_the_analytic_opacity_of_a_slab(tmp_path):
    """A constant volume of extinction sigma seen along x through L = 127 voxels (a multiple
    of every level's step): each level's alpha is 1 - exp(-sigma L) (opacity corrected
    for its step; methods.md T-HDR-10)."""
    values = np.full((128, 128, 128), 0.5, dtype=np.float32)
    write_multiscale(values, tmp_path / "slab.ome.zarr", progress_bar=False)
    tf = hv.TransferFunction([0.0, 1.0], [[1.0, 0.5, 0.25]] * 2, [0.01, 0.01])
    volume = volume_from_array(values)
    base = hv.Camera.fit(volume.bounds, "yz")
    camera = hv.Camera(base.position, base.focal_point, base.view_up, parallel_projection=True, parallel_scale=30.0)
    alpha = 1.0 - math.exp(math.log(1.0 - 0.01) * 127.0)  # opacity 0.01 per unit distance (1 voxel)
    reference = hv.render(volume, tf, camera, (8, 8), precision="float64", progress_bar=False)
    assert abs(reference.rgba[4, 4, 3] - alpha) < 1e-9
    with open_multiscale(tmp_path / "slab.ome.zarr", cache_bytes=2 ** 28) as ooc:
        for error, level in [(0.1, 0), (2 * 60 / 8 / 2, 1), (1e9, ooc.n_levels - 1)]:
            image = ooc.render(tf, camera, (8, 8), screen_error=error, precision="float64")
            assert image.metadata["levels"][level] == sum(image.metadata["levels"])
            assert abs(image.rgba[4, 4, 3] - alpha) < 1e-6, (level, image.rgba[4, 4, 3], alpha)
    assert 0.05 < alpha < 0.999


def test_renders_are_deterministic_and_eviction_changes_no_pixel(case):
    values, volume, tf, path = case
    camera = hv.Camera.fit(volume.bounds, "iso")
    with open_multiscale(path, cache_bytes=2 ** 28) as big:
        a = big.render(tf, camera, SIZE, screen_error=1.0)
        b = big.render(tf, camera, SIZE, screen_error=1.0)
    need = sum(a.metadata["chunks_read_per_level"]) + 8
    with open_multiscale(path, cache_bytes=need * SLOT_VALUES * 4) as small:
        small.render(tf, hv.Camera.fit(volume.bounds, "zx"), SIZE, screen_error=1e-9)  # fills it with others
        c = small.render(tf, camera, SIZE, screen_error=1.0)
    assert c.metadata["coarsened"] == 0
    assert np.array_equal(a.rgba, b.rgba) and np.array_equal(a.rgba, c.rgba)


def test_bad_arguments_are_refused_with_clear_messages(case, tmp_path):
    values, volume, tf, path = case
    with open_multiscale(path, cache_bytes=2 ** 28) as ooc:
        with pytest.raises(ValueError, match=r"shade=True is not supported"):
            ooc.render(tf, "iso", SIZE, shade=True)
        with pytest.raises(ValueError, match=r"screen_error"):
            ooc.render(tf, "iso", SIZE, screen_error=0)
        with pytest.raises(TypeError, match=r"tf must be a TransferFunction"):
            ooc.render("viridis", "iso", SIZE)
    with pytest.raises(FileNotFoundError, match=r"no multiresolution store"):
        open_multiscale(tmp_path / "nothing.ome.zarr")


def test_a_magnifier_asks_for_finer_blocks_inside_it_and_renders_as_in_core(case):
    """Given rays (a lens's): each block's level comes from the distance between
    neighbouring rays along each ray's stretch in it. Plain camera rays ask for the levels
    the camera path computes; a magnifier (factor 4) makes blocks under it finer; at
    level 0 the lens render is the in-core one bit for bit."""
    values, volume, tf, path = case
    camera = hv.Camera.fit(volume.bounds, "iso")
    size = (64, 64)
    lens = hv.Magnifier(center=(32, 32), radius=16, factor=4, antialias=False)
    with open_multiscale(path, cache_bytes=2 ** 28) as ooc:
        plan = MultiscalePlan(ooc, tf)
        by_camera = plan.desired_levels(camera, size)
        by_rays = plan.desired_levels(camera.rays(size), size)
        shown = by_camera >= 0
        assert (by_rays[shown] >= 0).all()
        # a footprint measured between neighbouring rays, not at a block's nearest corner:
        # never finer than the camera's by more than a level, and the same on most blocks
        assert (np.abs(by_rays[shown] - by_camera[shown]) <= 1).all()
        assert (by_rays[shown] == by_camera[shown]).mean() > 0.5
        magnified = plan.desired_levels(lens.rays(camera, size), size)
        assert (magnified[shown] <= by_rays[shown]).all() and (magnified[shown] < by_rays[shown]).any()
        image = ooc.render(tf, camera, size, screen_error=1e-9, lens=lens)
    reference = hv.render(volume, tf, camera, size, lens=lens, progress_bar=False)
    assert np.array_equal(image.rgba, reference.rgba)
    assert image.metadata["lens"] == repr(lens)


def test_the_out_of_core_page_prints_what_it_says(tmp_path, monkeypatch):
    import re

    from conftest import REPO_ROOT
    from docblocks import python_blocks, run_blocks

    page = REPO_ROOT / "docs" / "out_of_core.md"
    blocks, _ = python_blocks(page)
    expected = re.search(r"^prints\n\n```text\n(.*?)^```", page.read_text(), re.S | re.M).group(1)
    assert run_blocks(blocks, tmp_path, monkeypatch) == expected


def test_infinities_render_as_the_in_core_volume_reads_them(tmp_path):
    """+inf and -inf points (and NaN) at level 0: the store keeps them, its value range is
    the finite one, and the renderer reads them as the largest/smallest finite value, as
    an in-memory GridVolume does: the level-0 image is the in-core one bit for bit."""
    values = _field((100, 90, 80))
    values[40:44, 30:50, 20:60] = np.inf
    values[60:62, 10:20, 10:20] = -np.inf
    values[10:12, 10:12, 10:12] = np.nan
    store = write_multiscale(values, tmp_path / "inf.ome.zarr", progress_bar=False)
    assert np.isposinf(store.read_level(0)).sum() == 4 * 20 * 40
    volume = volume_from_array(values)
    assert store.value_range == volume.value_range
    tf = default_transfer_function(volume)
    camera = hv.Camera.fit(volume.bounds, "iso")
    reference = hv.render(volume, tf, camera, SIZE, progress_bar=False)
    with open_multiscale(tmp_path / "inf.ome.zarr", cache_bytes=2 ** 28) as ooc:
        image = ooc.render(tf, camera, SIZE, screen_error=1e-9)
    assert np.array_equal(image.rgba, reference.rgba)


def test_occluded_blocks_are_never_read_and_the_image_is_unchanged(tmp_path):
    """An opaque slab (z < 40) in front of a field seen from -z: the occlusion bound (the
    store's ranges per cube of 8 points) shows the blocks behind it are reached only
    after the rays stopped (termination 1e-3; at float32's default 1e-6 the bound's
    rounding margin, eps / 1e-6 per sample, outgrows the slab); the converged frame
    leaves them out -- not read, not sampled -- and its image equals the frame without
    the bound bit for bit, and the in-core one."""
    values = _field((200, 130, 140)) * 0.2
    values[:40] = 5.0
    write_multiscale(values, tmp_path / "slab.ome.zarr", progress_bar=False)
    volume = volume_from_array(values)
    tf = hv.TransferFunction([-1.0, 0.5, 4.0, 5.0], [[0.2, 0.3, 1.0]] * 4, [0.02, 0.02, 0.5, 0.5])
    base = hv.Camera.fit(volume.bounds, "xy")
    # parallel rays along +z: none enters behind the slab through a side face
    camera = hv.Camera((base.position[0], base.position[1], -300.0), base.focal_point, base.view_up,
                       parallel_projection=True, parallel_scale=60.0)
    reference = hv.render(volume, tf, camera, SIZE, termination=1e-3, progress_bar=False)
    with open_multiscale(tmp_path / "slab.ome.zarr", cache_bytes=2 ** 28) as ooc:
        culled = ooc.render(tf, camera, SIZE, screen_error=1e-9, termination=1e-3)
        read_culled = culled.metadata["chunks_read_per_level"][0]
        default = ooc.render(tf, camera, SIZE, screen_error=1e-9)
        assert default.metadata["occluded"] == 0  # float32 at termination 1e-6
    with open_multiscale(tmp_path / "slab.ome.zarr", cache_bytes=2 ** 28) as ooc:
        plain = ooc.render(tf, camera, SIZE, screen_error=1e-9, termination=1e-3, occlusion=False)
        read_plain = plain.metadata["chunks_read_per_level"][0]
    assert plain.metadata["occluded"] is None and culled.metadata["occluded"] > 0
    # the 4 chunk layers along z: the first (and the plane it shares) read; the last two not
    assert (read_plain, read_culled) == (4 * 3 * 3, 2 * 3 * 3)
    assert np.array_equal(culled.rgba, plain.rgba) and np.array_equal(culled.depth, plain.depth)
    assert np.array_equal(culled.rgba, reference.rgba)
    assert culled.rgba[5:-5, 5:-5, 3].min() > 0.99  # the slab covers the middle of the view
