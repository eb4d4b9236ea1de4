"""Progressive refinement and cancellation (issue 21, part 1): the full frame is the
direct render bit for bit, a newer request cancels the render in flight at its next row
of tiles and its frames are never shown, the coarse factor follows the time budget."""
import threading
import time

import numpy as np
import pytest

import pv_hdrvol as hv
from meshes import box_mesh
from pv_hdrvol.viewer import progressive as P
from pv_hdrvol.viewer.progressive import Frame, ProgressiveRenderer

pytestmark = pytest.mark.core


def _volume():
    z, y, x = np.mgrid[0:24, 0:20, 0:16].astype(np.float64)
    values = np.exp(-((x - 8) ** 2 + (y - 10) ** 2 + (z - 12) ** 2) / 30.0) * 1e4 + 1e-3
    return hv.volume_from_array(values, spacing=(1.0, 1.5, 0.75))


def _tf():
    return hv.TransferFunction.ramp(1e-3, 1e4, scale="log", cmap="gray", opacity=(0.0, 0.3))


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_the_full_frame_equals_a_direct_render_bit_for_bit(precision):
    volume, tf = _volume(), _tf()
    camera = hv.Camera.fit(volume.bounds, "iso")
    frames = ProgressiveRenderer(volume, tf, precision=precision).frames(camera, (40, 30))
    direct = hv.render(volume, tf, camera, (40, 30), precision=precision)
    assert [f.level for f in frames] == ["coarse", "full"]
    np.testing.assert_array_equal(frames[-1].image.rgba, direct.rgba)
    np.testing.assert_array_equal(frames[-1].image.depth, direct.depth)
    coarse = frames[0]
    assert coarse.image.shape == (30, 40) and coarse.factor == 4
    assert coarse.image.metadata["coarse_size"] == [10, 8]


def test_a_tetrahedral_mesh_refines_to_its_direct_render():
    points, tets, values = box_mesh((3, 3, 3), field=lambda p: 1.0 + p[:, 0] * p[:, 1])
    mesh = hv.tetmesh_from_arrays(points, tets, values)
    tf = hv.TransferFunction.ramp(1.0, 10.0, cmap="gray", opacity=(0.1, 0.6))
    camera = hv.Camera.fit(mesh.bounds, "iso")
    frames = ProgressiveRenderer(mesh, tf, precision="float64").frames(camera, (24, 24))
    direct = hv.render(mesh, tf, camera, (24, 24), precision="float64")
    np.testing.assert_array_equal(frames[-1].image.rgba, direct.rgba)


@pytest.mark.parametrize("mesh", [False, True], ids=["grid", "tets"])
def test_unoccluded_frames_equal_the_render_without_far(mesh):
    """unoccluded=True: each frame also carries the render with no ray stopped (a window
    over the stopped rays rendered again; a mesh renders whole), bit for bit the frame
    of the same request without far; None when far stops nothing."""
    if mesh:
        points, tets, values = box_mesh((3, 3, 3), field=lambda p: 1.0 + p[:, 0] * p[:, 1])
        data, tf = hv.tetmesh_from_arrays(points, tets, values), hv.TransferFunction.ramp(1.0, 10.0, cmap="gray",
                                                                                         opacity=(0.1, 0.6))
    else:
        data, tf = _volume(), _tf()
    camera = hv.Camera.fit(data.bounds, "iso")
    far = np.full((30, 40), np.inf)
    far[5:12, 20:31] = 1e-3  # a mesh just in front of the camera over part of the picture
    renderer = ProgressiveRenderer(data, tf, precision="float64", factor=2)
    cut = renderer.frames(camera, (40, 30), far=far, unoccluded=True)
    renderer.factor = 2
    open_ = renderer.frames(camera, (40, 30))
    for a, b in zip(cut, open_):
        assert a.level == b.level and not np.array_equal(a.image.rgba, b.image.rgba)
        np.testing.assert_array_equal(a.unoccluded.rgba, b.image.rgba)
    renderer.factor = 2
    assert [f.unoccluded for f in renderer.frames(camera, (40, 30), far=np.full((30, 40), np.inf),
                                                  unoccluded=True)] == [None, None]


def test_the_coarse_frame_is_the_small_render_upsampled():
    volume, tf = _volume(), _tf()
    camera = hv.Camera.fit(volume.bounds, "xy")
    renderer = ProgressiveRenderer(volume, tf, precision="float64", factor=2)
    coarse = renderer.frames(camera, (32, 32))[0]
    small = hv.render(volume, tf, camera, (16, 16), precision="float64")
    # pixel centres of the coarse image fall between full-size pixels 2i and 2i + 1:
    # their mean is the coarse pixel, exactly, away from the border
    pairs = 0.5 * (coarse.image.rgba[1:-1:2] + coarse.image.rgba[2::2])
    quads = 0.5 * (pairs[:, 1:-1:2] + pairs[:, 2::2])
    inner = 0.25 * (small.rgba[:-1, :-1] + small.rgba[1:, :-1] + small.rgba[:-1, 1:] + small.rgba[1:, 1:])
    np.testing.assert_allclose(quads, inner, rtol=0, atol=1e-12)


def test_the_factor_follows_the_time_budget():
    assert P._next_factor(4, 0.05, 0.1) == 3  # 0.05 * (4/3)^2 = 0.089 fits; 0.05 * 4 = 0.2 does not
    assert P._next_factor(4, 0.4, 0.1) == 8
    assert P._next_factor(2, 100.0, 0.1) == P.FACTORS[-1]
    assert P._next_factor(16, 1e-4, 0.1) == 2


def test_cancellation_comes_at_the_next_row_of_tiles():
    """The render checks between chunks of rows of tiles: once a newer request exists,
    the very next check stops it (no further chunk is rendered)."""
    volume, tf = _volume(), _tf()
    renderer = ProgressiveRenderer(volume, tf, precision="float64")
    checks = []

    def stale():
        checks.append(len(checks))
        return len(checks) >= 3  # a newer request arrived during the second chunk

    with pytest.raises(P.Cancelled):
        renderer._full(renderer._plan, "iso", (64, 200), None, 1, stale)
    assert len(checks) == 3  # the third report saw it and stopped: the chunks after it never ran


def test_a_newer_request_cancels_the_one_in_flight_and_its_frames_never_arrive():
    """The second request comes while the first one's full render is running (its
    coarse frame shown, a row of tiles of the full one rendered): that render stops at
    its next check, and only the second request's frames follow."""
    volume, tf = _volume(), _tf()
    seen, outcomes = [], []
    arrived, in_flight, requested = threading.Event(), threading.Event(), threading.Event()

    def on_frame(frame):
        seen.append(frame)
        if frame.level == "full":
            arrived.set()

    with ProgressiveRenderer(volume, tf, precision="float64", on_frame=on_frame) as renderer:
        full = renderer._full

        def watched_full(plan, camera, size, lens, generation, stale, far=None, unoccluded=False):
            def check():  # called between chunks of rows of tiles
                if generation == 1 and not in_flight.is_set():
                    in_flight.set()  # the first full render has rendered its first rows
                    assert requested.wait(60)  # hold it there until the newer request exists
                return stale()

            try:
                frame = full(plan, camera, size, lens, generation, check, far, unoccluded)
            except P.Cancelled:
                outcomes.append((generation, "cancelled"))
                raise
            outcomes.append((generation, "done"))
            return frame

        renderer._full = watched_full
        first = renderer.request("iso", (200, 200))
        assert in_flight.wait(60)
        second = renderer.request("xy", (48, 40))
        requested.set()
        assert arrived.wait(60)
    assert (first, second) == (1, 2)
    assert outcomes == [(first, "cancelled"), (second, "done")]
    assert all(isinstance(f, Frame) for f in seen)
    assert [(f.level, f.generation) for f in seen] == [("coarse", first), ("coarse", second), ("full", second)]
    np.testing.assert_array_equal(seen[-1].image.rgba, hv.render(volume, tf, "xy", (48, 40),
                                                                 precision="float64").rgba)


def test_a_new_transfer_function_is_used_by_the_next_request():
    volume, tf = _volume(), _tf()
    renderer = ProgressiveRenderer(volume, tf, precision="float64")
    other = hv.TransferFunction.ramp(1e-3, 1e4, scale="log", cmap="gray", opacity=(0.0, 0.9))
    renderer.set_scene(other, global_alpha=0.5)
    full = renderer.frames("iso", (16, 16), coarse=False)[0]
    np.testing.assert_array_equal(full.image.rgba, hv.render(volume, other, "iso", (16, 16), precision="float64",
                                                             global_alpha=0.5).rgba)
    with pytest.raises(ValueError, match="global_alpha"):
        renderer.set_scene(global_alpha=2.0)


def test_errors_reach_on_error_and_bad_arguments_are_named():
    volume = _volume()
    with pytest.raises(ValueError, match=r"factor must be one of \(2, 3, 4, 6, 8, 12, 16\); got 5"):
        ProgressiveRenderer(volume, factor=5)
    with pytest.raises(TypeError, match="on_frame must be callable; got int"):
        ProgressiveRenderer(volume, on_frame=1)
    with pytest.raises(ValueError, match=r"request\(\) needs on_frame="):
        ProgressiveRenderer(volume).request("iso", (8, 8))
    errors, done = [], threading.Event()

    def on_error(error):
        errors.append(error)
        done.set()

    frames = []
    with ProgressiveRenderer(volume, on_frame=frames.append, on_error=on_error) as renderer:
        renderer.request("iso", (8, 8), lens="not a lens")
        assert done.wait(30)
    assert isinstance(errors[0], TypeError) and "lens must have a rays(camera, size) method" in str(errors[0])
    assert len(errors) == 1 and frames == []  # a lens that is not one renders no coarse frame either


def test_a_failed_render_does_not_stop_the_worker(capsys):
    """Without on_error the traceback is printed and the next request still renders."""
    volume, tf = _volume(), _tf()
    done = threading.Event()
    seen = []

    def on_frame(frame):
        seen.append(frame)
        if frame.level == "full":
            done.set()

    with ProgressiveRenderer(volume, tf, precision="float64", on_frame=on_frame) as renderer:
        renderer.request("iso", (8, 8), lens="not a lens")
        end, printed = time.monotonic() + 30, ""
        while "lens must have a rays" not in printed and time.monotonic() < end:
            time.sleep(0.02)
            printed += capsys.readouterr().err
        assert "TypeError: lens must have a rays(camera, size) method; got str" in printed
        renderer.request("iso", (8, 8))
        assert done.wait(60)
    assert [f.level for f in seen] == ["coarse", "full"] and seen[-1].generation == 2
    direct = hv.render(volume, tf, "iso", (8, 8), precision="float64")
    np.testing.assert_array_equal(seen[-1].image.rgba, direct.rgba)
    np.testing.assert_array_equal(seen[-1].image.depth, direct.depth)
