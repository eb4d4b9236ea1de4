"""The frame: what every plan's render shares between its camera and its image.

A frame turns a camera (or a lens's or the caller's rays), a size, a window and a far
image into the kernels' ray inputs, runs the kernel over rows of tiles on the CPU in
chunks (progress, Ctrl-C, a progress bar) or on a registered device runner, and hands
back the pixels. :class:`~pv_hdrvol.raycast.grid.GridPlan`,
:class:`~pv_hdrvol.raycast.tets.TetPlan` and the out-of-core plan call these; later
stages (``outofcore``, ``gpu``, ``viewer``) import only the public names here.
"""
from __future__ import annotations

import sys
import time

import numpy as np

from .._validate import as_real, as_size
from ..image.hdr import HDRImage
from ..rays.camera import Camera, Rays, check_window

# Rays are cast in square tiles of this many pixels a side (cache locality).
TILE = 8
# Renders expected to take longer than this (seconds) run in chunks of about
# CHUNK_SECONDS, so that Ctrl-C stops them soon; progress_bar=None then shows a bar on a
# terminal or in a notebook.
AUTO_BAR_SECONDS = 1.0
CHUNK_SECONDS = 0.25
# the clock that times the first chunk (tests replace it)
_clock = time.perf_counter

#: The compositing marker of each precision: its type picks the one loop a kernel compiles.
MARKERS = {"float64": np.float64(0.0), "float32": np.float32(0.0), "float16": np.int64(0), "uint8": np.int64(0)}


def check_far(far, width, height, name="far"):
    """``far`` (or another per-pixel distance, ``name``) as a flat float64 array (empty
    for ``None``), checked."""
    if far is None:
        return np.empty(0)
    a = np.asarray(far)
    if a.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be a numeric array; got dtype {a.dtype}")
    if a.shape != (height, width):
        raise ValueError(f"{name} must have the image's shape (rows, cols) = {(height, width)}; got {a.shape}")
    a = np.ascontiguousarray(a, dtype=np.float64).reshape(-1)
    if np.isnan(a).any() or (a < 0).any():
        raise ValueError(f"{name} must hold distances >= 0 (inf: no limit); got NaN or negative values")
    return a


def window_rays(rays, window):
    """The rays of ``window = (col, row, width, height)``, a rectangle of ``rays``' image."""
    col, row, w, h = check_window(window, rays.width, rays.height)

    def cut(a, k):
        return np.ascontiguousarray(a.reshape(rays.height, rays.width, k)[row:row + h, col:col + w].reshape(-1, k))

    lod = None if rays.lod is None else cut(np.asarray(rays.lod), 1).reshape(-1)
    return Rays(cut(rays.origins, 3), cut(rays.directions, 3), w, h, lod)


def windowed(camera, rays, far, window, width, height):
    """``(rays, far, width, height)`` of a render of ``width x height`` cut to ``window``
    (``None``: the whole image): ``far`` checked and flat, cut to the window too; the
    window's rays (a camera makes them; given rays are cut)."""
    far = check_far(far, width, height)
    if window is not None:
        if far.size:
            col, row, w, h = check_window(window, width, height)
            far = np.ascontiguousarray(far.reshape(height, width)[row:row + h, col:col + w]).reshape(-1)
        rays = camera.rays((width, height), window) if rays is None else window_rays(rays, window)
        width, height = rays.width, rays.height
    return rays, far, width, height


def check_lod(rays):
    """The rays' level of detail as a contiguous float64 array, or None when all are 0."""
    if rays.lod is None:
        return None
    lod = np.ascontiguousarray(rays.lod, dtype=np.float64).reshape(-1)
    if lod.size != rays.width * rays.height:
        raise ValueError(f"Rays.lod must have one value per ray ({rays.width * rays.height}); got {lod.size}")
    if not np.all(np.isfinite(lod)) or lod.min() < 0:
        raise ValueError("Rays.lod must be finite and >= 0")
    return lod if lod.max() > 0 else None


def tile_lanes():
    """Lanes of the tile kernels: one per thread. Lane ``l`` of ``n`` renders tiles
    ``l, l + n, ...``, so each thread walks the image in small steps: the tile it renders
    next lies ``n`` tiles on along the row (two, 16 pixels, on two threads) and finds
    most of its bricks (or cells) still in cache, while every thread still gets an even
    share of every part of the image."""
    import numba

    return numba.get_num_threads()


def run_in_chunks(cast, height, progress=None, progress_bar=None, chunk_seconds=None):
    """Call ``cast(tile_rows)`` (which renders those rows of ``TILE``-pixel tiles and
    returns how many pixel rows it did) over all rows of tiles, with progress.

    The middle row of tiles goes first, then the others in chunks that double in size
    until an eighth of the rows is done, each limited to about ``CHUNK_SECONDS`` at
    the rate measured so far; then the rest in chunks of that limit (all of it, for a
    quick render). A kernel call cannot be interrupted, so Ctrl-C (KeyboardInterrupt)
    takes effect when the chunk running ends: within about ``CHUNK_SECONDS``,
    whatever ``progress_bar`` says. ``progress``/``progress_bar=True`` get at least as
    many reports as a quarter of the tile rows (<= 64). The rows are taken in
    bit-reversed order, so every chunk is spread over the image; tile rows are
    rendered independently, so the chunks change no pixel.

    ``progress_bar=None`` shows a tqdm bar for a slow render only on a terminal or in a
    Jupyter kernel (:func:`auto_bar_wanted`). ``progress(fraction)`` returning
    ``False`` raises ``RuntimeError("render aborted")``; any exception (KeyboardInterrupt
    too) closes the bar and propagates. ``chunk_seconds`` replaces ``CHUNK_SECONDS``
    (a chunk is never less than one row of tiles).
    """
    chunk_seconds = CHUNK_SECONDS if chunk_seconds is None else as_real("chunk_seconds", chunk_seconds, low=0.0,
                                                                         low_open=True)
    tile_count_y = -(-height // TILE)
    bar = tqdm_bar(progress_bar, height) if progress_bar else None
    done = 0

    def report(rows):
        nonlocal done
        done += rows
        if bar is not None:
            bar.update(rows)
        if progress is not None and progress(done / height) is False:
            raise RuntimeError("render aborted")

    try:
        t_start = _clock()
        middle = tile_count_y // 2
        report(cast(np.array([middle], dtype=np.int64)))
        rest = _spread_order(np.delete(np.arange(tile_count_y, dtype=np.int64), middle))
        # a watched render reports at least as often as it always did: after a quarter
        # of the tile rows (<= 64 reports)
        most = -(-rest.size // max(1, min(tile_count_y // 4, 64) - 1)) \
            if progress is not None or bar is not None else rest.size
        start, size, rows_done = 0, 1, 1
        t_first = _clock()  # the first call may have compiled the kernel: not a rate
        while start < rest.size:
            # seconds a row of tiles, so far
            rate = (t_first - t_start) if rows_done == 1 else (_clock() - t_first) / (rows_done - 1)
            if bar is None and progress_bar is None and rate * tile_count_y > AUTO_BAR_SECONDS \
                    and auto_bar_wanted():
                bar = tqdm_bar(True, height, quiet_without_tqdm=True)
                if bar is not None:
                    bar.update(done)
            fits = max(1, int(chunk_seconds / rate)) if rate > 0 else rest.size
            # double the chunks until an eighth of the rows is timed (the middle row
            # alone may be cheap), and keep each to about chunk_seconds
            size = min(fits if 8 * rows_done >= tile_count_y else 2 * size, fits, most)
            # in image order inside a chunk: neighbouring rows share bricks (cells) in cache
            part = np.sort(rest[start:start + size])
            report(cast(part))
            start += part.size
            rows_done += part.size
    finally:
        if bar is not None:
            bar.close()


def pixel_rows(tile_rows, height):
    """How many pixel rows of an image ``height`` rows high the rows of tiles
    ``tile_rows`` cover (the last row of tiles may be cut short)."""
    return int(np.minimum((tile_rows + 1) * TILE, height).sum() - (tile_rows * TILE).sum())


def _spread_order(rows):
    """``rows`` in bit-reversed (van der Corput) order of their positions: any run of
    consecutive entries is spread evenly over the image."""
    n = rows.size
    if n < 3:
        return rows
    bits = int(n - 1).bit_length()
    i = np.arange(n, dtype=np.int64)
    rev = np.zeros(n, dtype=np.int64)
    for b in range(bits):
        rev |= ((i >> b) & 1) << (bits - 1 - b)
    return rows[np.argsort(rev, kind="stable")]


def auto_bar_wanted():
    """Whether ``progress_bar=None`` may show a bar: when stderr is a terminal or the code
    runs in a Jupyter (IPython) kernel; never into a log file or a pipe, where tqdm's
    carriage-return lines would pile up."""
    try:
        if sys.stderr is not None and sys.stderr.isatty():
            return True
    except (AttributeError, ValueError, OSError):  # a replaced or closed stderr
        pass
    ipython = sys.modules.get("IPython")  # never imported here: only if already in use
    if ipython is None:
        return False
    try:
        shell = ipython.get_ipython()
    except Exception:  # noqa: BLE001 - any failure means: not in a kernel
        return False
    return shell is not None and getattr(shell, "kernel", None) is not None


def check_progress_bar(value):
    if value not in (True, False, None):
        raise TypeError(f"progress_bar must be True, False or None (after 1 s); got {value!r}")


def tqdm_bar(enabled, total, quiet_without_tqdm=False):
    """A tqdm bar over ``total`` rows when ``enabled`` (None without tqdm if ``quiet_without_tqdm``)."""
    if not enabled:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        if quiet_without_tqdm:
            return None  # the automatic bar is a convenience: no tqdm, no bar
        raise ImportError("progress_bar=True needs tqdm (pip install tqdm)") from None
    return tqdm(total=total, desc="Rendering", unit="rows")


#: Renderers on other devices than the CPU, registered by later stages: device name
#: (``RenderOptions.device``) -> a function of no arguments that returns a runner with
#: ``frame()`` (a context manager holding the runner for one frame), the frame makers
#: ``composite_frame(...)``, ``projection_frame(...)`` and ``tet_frame(...)`` (each
#: returns ``(cast, finish)``: see :func:`run_frame`), and ``describe()``, the frame's
#: ``metadata["device"]`` (``pv_hdrvol.gpu`` registers ``"cuda"`` when imported).
DEVICE_RUNNERS = {}


def device_runner(device):
    """A new runner of ``device`` from :data:`DEVICE_RUNNERS`."""
    make = DEVICE_RUNNERS.get(device)
    if make is None:
        raise ValueError(f"device={device!r} has no renderer registered: import pv_hdrvol.gpu")
    return make()


def run_frame(cast, finish, height, progress, progress_bar, chunk_seconds):
    """A device frame: one ``cast`` over every row of tiles (chunks would leave the
    device idle between launches), or :func:`run_in_chunks` when progress is watched
    (``progress``, a bar), so that it reports and can be cancelled; then ``finish()``,
    which copies the image back."""
    if progress is None and not progress_bar:
        cast(np.arange(-(-height // TILE), dtype=np.int64))
    else:
        run_in_chunks(cast, height, progress, progress_bar, chunk_seconds)
    finish()


def frame_rays(camera, size, lens=None):
    """``(rays, width, height)`` of a frame: a lens's rays for ``camera`` (checked), the
    given :class:`~pv_hdrvol.Rays`, or ``None`` when the camera's own rays are made in
    the kernel (``Camera.kernel_array``); the image size is the rays' or ``size``."""
    if lens is not None:
        if not callable(getattr(lens, "rays", None)):
            raise TypeError(f"lens must have a rays(camera, size) method; got {type(lens).__name__}")
        if not isinstance(camera, Camera):
            raise TypeError(f"a lens needs a Camera; got {type(camera).__name__}")
        rays = lens.rays(camera, size)
        if not isinstance(rays, Rays):
            raise TypeError(f"lens.rays() must return Rays; got {type(rays).__name__}")
    elif isinstance(camera, Rays):
        rays = camera
    else:
        rays = None
    width, height = (rays.width, rays.height) if rays is not None else as_size(size)
    return rays, width, height


def voxel_rays(camera, rays, width, height, origin, inv_spacing):
    """The grid kernels' ray inputs ``(cam, origins, directions)`` in voxel coordinates
    (t stays in world units): the camera array followed by ``origin`` and
    ``inv_spacing`` when the kernel makes the camera's rays (``rays`` None; empty ray
    arrays), else the rays moved and scaled (an empty camera array)."""
    if rays is None:
        cam = np.concatenate([camera.kernel_array((width, height)), origin, inv_spacing])
        origins = directions = np.empty((0, 3))
    else:
        cam = np.empty(0)
        origins = np.ascontiguousarray((rays.origins - origin) * inv_spacing)
        directions = np.ascontiguousarray(rays.directions * inv_spacing)
    return cam, origins, directions


#: The ``out_value`` a composite frame passes the grid kernels: a placeholder (they write a
#: projection's values where ``out_value`` has one per pixel).
NO_VALUE = np.empty(0)


class FrameBuffers:
    """A frame's outputs, flat (one row per pixel): ``rgba`` (premultiplied, float64 for
    ``precision="float64"``, else float32, from transparent), ``depth`` (float64, inf
    where the threshold is never met), ``counts`` (int64, the work per pixel: samples or
    cells) and, for a projection, ``value`` (float64, NaN where nothing projects)."""

    def __init__(self, width, height, precision, value=False):
        n = width * height
        self.width, self.height = width, height
        self.rgba = np.zeros((n, 4), dtype=np.float64 if precision == "float64" else np.float32)
        self.depth = np.full(n, np.inf, dtype=np.float64)
        self.counts = np.zeros(n, dtype=np.int64)
        self.value = np.full(n, np.nan) if value else None

    def image(self, metadata):
        """The :class:`~pv_hdrvol.HDRImage` of the buffers (rows, cols), row 0 at the top."""
        h, w = self.height, self.width
        value = None if self.value is None else self.value.reshape(h, w)
        return HDRImage(self.rgba.reshape(h, w, 4), self.depth.reshape(h, w), metadata=metadata, value=value)


class FramePlan:
    """What every plan shares to run its frames: the device runner it keeps (its arrays
    stay on the device between frames) and :meth:`run_frame`."""

    _runner = None

    def run_frame(self, cast, height, progress=None, progress_bar=None, chunk_seconds=None, device=None,
                  device_frame=None):
        """Render a frame: ``cast(tile_rows)`` over every row of tiles on the CPU
        (:func:`run_in_chunks`), or, for a ``device`` other than ``"cpu"`` and a
        ``device_frame(runner)`` that returns the runner's ``(cast, finish)``, on the
        plan's runner of that device (made on first use from :data:`DEVICE_RUNNERS`),
        one frame at a time on its arrays (:func:`run_frame`). Returns the runner's
        ``describe()`` or ``None`` on the CPU."""
        if device in (None, "cpu") or device_frame is None:
            run_in_chunks(cast, height, progress, progress_bar, chunk_seconds)
            return None
        if self._runner is None:
            self._runner = device_runner(device)
        with self._runner.frame() as runner:  # one frame at a time on a plan's device arrays
            on_device, finish = device_frame(runner)
            run_frame(on_device, finish, height, progress, progress_bar, chunk_seconds)
            return runner.describe()


def frame_metadata(renderer, scalars, tf, camera, options, unit, settings, seconds, **keys):
    """The metadata every frame carries, in this order: ``renderer``, ``scalars``,
    ``precision``, then ``keys`` (the plan's own, e.g. ``step_voxels``), then
    ``global_alpha``, ``opacity_unit_distance``, ``termination``, ``depth_threshold``,
    ``transfer_function``, ``camera`` (its repr, or ``"rays"``), ``settings``
    (:func:`~pv_hdrvol.settings.settings_metadata`) and ``render_seconds``."""
    meta = {"renderer": renderer, "scalars": scalars, "precision": options.precision}
    meta.update(keys)
    meta.update({
        "global_alpha": options.global_alpha,
        "opacity_unit_distance": unit,
        "termination": options.termination,
        "depth_threshold": options.depth_threshold,
        "transfer_function": repr(tf),
        "camera": camera if isinstance(camera, str) else repr(camera) if isinstance(camera, Camera) else "rays",
        "settings": settings,
        "render_seconds": seconds,
    })
    return meta


__all__ = ["AUTO_BAR_SECONDS", "CHUNK_SECONDS", "DEVICE_RUNNERS", "MARKERS", "TILE", "FrameBuffers", "FramePlan",
           "frame_metadata", "frame_rays", "voxel_rays", "auto_bar_wanted", "check_far",
           "check_lod", "check_progress_bar", "device_runner", "pixel_rows", "run_frame", "run_in_chunks", "tile_lanes",
           "tqdm_bar", "window_rays", "windowed"]
