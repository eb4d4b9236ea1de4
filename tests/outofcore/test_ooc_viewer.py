"""The progressive front ends on a store larger than memory (issue 34, part 4): a coarse
level at once, finer levels as their chunks arrive while the camera rests, the converged
frame bit for bit the waiting render, never a hole, and a new view starts again from a
coarse frame. The loader is slowed on purpose so that frames come before their chunks."""
import threading
import time

import numpy as np
import pytest

pytest.importorskip("zarr")

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.viewer.progressive import ProgressiveRenderer, level_text  # noqa: E402
from stores import slow_loader, write_store  # noqa: E402

SIZE = (96, 80)
SCREEN_ERROR = 0.5  # level 0 near the camera at this size, coarser behind


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    return write_store(tmp_path_factory.mktemp("ooc_viewer") / "smooth.ome.zarr")


def _mean_level(image):
    counts = np.asarray(image.metadata["levels"], dtype=np.float64)
    return float((counts * np.arange(counts.size)).sum() / counts.sum())


def _reference(store, tf, camera):
    """The waiting render (wait=True) on a volume of its own (a cold cache)."""
    with hv.open_multiscale(store, cache_bytes=2 ** 28) as volume:
        return hv.render(volume, tf, camera, SIZE, screen_error=SCREEN_ERROR, precision="float32",
                         progress_bar=False)


def _no_hole(frames, reference):
    covered = reference.rgba[..., 3] > 0.05
    assert covered.sum() > 500
    for i, frame in enumerate(frames):
        assert (frame.image.rgba[..., 3][covered] > 0).all(), f"frame {i} ({frame.level}) has a hole"


def test_frames_refine_from_the_coarsest_level_to_the_converged_render(store):
    camera = hv.Camera.fit((0, 129, 0, 129, 0, 129), "iso")
    with hv.open_multiscale(store, cache_bytes=2 ** 28) as volume:
        slow_loader(volume, 0.01)
        renderer = ProgressiveRenderer(volume, precision="float32", screen_error=SCREEN_ERROR)
        assert renderer.multiscale and not renderer.tets
        frames = renderer.frames(camera, SIZE)
        tf = renderer.tf
    levels = [f.level for f in frames]
    assert levels[0] == "coarse" and levels[-1] == "full" and set(levels[1:-1]) <= {"refining"}
    assert len(frames) >= 3, levels
    first, last = frames[0].image.metadata, frames[-1].image.metadata
    n_levels = len(first["levels"])
    # the first frame: only the coarsest level (resident from the start), read nothing first
    assert first["levels"][-1] == sum(first["levels"]) > 0
    assert first["chunks_read_per_level"][:-1] == [0] * (n_levels - 1)  # it waited for no read
    # finer as chunks arrive: no block's level goes up while the camera rests
    means = [_mean_level(f.image) for f in frames[1:]]
    assert all(b <= a for a, b in zip(means, means[1:])), means
    assert means[-1] < _mean_level(frames[0].image) and last["levels"][0] > 0
    assert last["converged"] is True and all(not f.image.metadata["converged"] for f in frames[1:-1])
    assert level_text(frames[-1].image, "full").endswith("; converged") and n_levels == 3
    reference = _reference(store, tf, camera)
    np.testing.assert_array_equal(frames[-1].image.rgba, reference.rgba)
    np.testing.assert_array_equal(frames[-1].image.depth, reference.depth)
    _no_hole(frames, reference)


def test_without_refining_the_one_frame_waits_for_its_chunks(store):
    camera = hv.Camera.fit((0, 129, 0, 129, 0, 129), "xz")
    with hv.open_multiscale(store, cache_bytes=2 ** 28) as volume:
        slow_loader(volume, 0.002)
        renderer = ProgressiveRenderer(volume, precision="float32", screen_error=SCREEN_ERROR)
        (frame,) = renderer.frames(camera, SIZE, coarse=False, refine=False)
        tf = renderer.tf
    assert frame.level == "full" and frame.image.metadata["converged"] is True
    np.testing.assert_array_equal(frame.image.rgba, _reference(store, tf, camera).rgba)


def test_a_new_view_while_refining_starts_again_from_a_coarse_frame(store):
    first_camera = hv.Camera.fit((0, 129, 0, 129, 0, 129), "iso")
    second_camera = hv.Camera.fit((0, 129, 0, 129, 0, 129), "xy", zoom=1.3)
    frames, refining, done = [], threading.Event(), threading.Event()
    errors = []

    def on_frame(frame):
        frames.append(frame)
        if frame.level == "refining":
            refining.set()
        if frame.level == "full" and frame.generation == 2:
            done.set()

    with hv.open_multiscale(store, cache_bytes=2 ** 28) as volume:
        slow_loader(volume, 0.03)
        with ProgressiveRenderer(volume, precision="float32", screen_error=SCREEN_ERROR, on_frame=on_frame,
                                 on_error=errors.append) as renderer:
            assert renderer.request(first_camera, SIZE) == 1
            assert refining.wait(120), "no refining frame"
            assert renderer.request(second_camera, SIZE) == 2
            assert done.wait(120) and not errors, errors
            tf = renderer.tf
    generations = [f.generation for f in frames]
    assert generations == sorted(generations)  # nothing of the first view after the second began
    old = [f for f in frames if f.generation == 1]
    new = [f for f in frames if f.generation == 2]
    assert old[0].level == "coarse" and "full" not in [f.level for f in old]
    assert new[0].level == "coarse" and new[-1].level == "full" and len(new) >= 2
    assert _mean_level(new[0].image) > _mean_level(new[-1].image)
    reference = _reference(store, tf, second_camera)
    np.testing.assert_array_equal(new[-1].image.rgba, reference.rgba)
    _no_hole(new, reference)


def test_the_in_core_options_that_do_not_apply_are_named(store):
    with hv.open_multiscale(store) as volume:
        with pytest.raises(ValueError, match="scalars= picks an array of a dataset"):
            ProgressiveRenderer(volume, scalars="v")
        with pytest.raises(ValueError, match="shade=True is not supported for it yet"):
            ProgressiveRenderer(volume, shade=True)
        renderer = ProgressiveRenderer(volume)
        with pytest.raises(ValueError, match=r"lenses are not supported for out-of-core volumes"):
            renderer.frames("iso", (8, 8), lens=hv.Magnifier(center=(4, 4), radius=2, factor=2))
    with pytest.raises(ValueError, match=r"screen_error= is the level of detail of an out-of-core volume"):
        ProgressiveRenderer(np.zeros((4, 4, 4)), screen_error=1.0)


def test_the_notebook_editor_shows_the_levels_and_converges(store):
    pytest.importorskip("ipywidgets")
    from pv_hdrvol.viewer.notebook import TransferFunctionEditor

    with hv.open_multiscale(store, cache_bytes=2 ** 28) as volume:
        ed = TransferFunctionEditor(volume, size=SIZE, live=False, precision="float32", screen_error=SCREEN_ERROR)
        image = ed.refresh()
        assert ed.level == "full" and "converged" in ed.status.value and "level 0" in ed.status.value
        np.testing.assert_array_equal(image.rgba, _reference(store, ed.model.transfer_function(), ed.camera()).rgba)
        # the histogram: the coarsest level's values
        assert ed.model._values.size == np.prod(volume.store.levels[-1].shape)
        ed.close()
        slow_loader(volume, 0.01)
        live = TransferFunctionEditor(volume, size=SIZE, live=True, precision="float32")
        live.azimuth.value = 30.0  # a view whose chunks are not all resident
        end = time.monotonic() + 120
        seen = []
        while time.monotonic() < end:
            frame = live.renderer.last_frame
            if frame is not None and frame.generation == 2:  # the first request was the widget's own
                if not seen or seen[-1] != frame.level:
                    seen.append(frame.level)
                if frame.level == "full":
                    break
            time.sleep(0.005)
        live.close()
        assert seen[0] == "coarse" and seen[-1] == "full", seen
        assert live.renderer.last_frame.image.metadata["converged"]
