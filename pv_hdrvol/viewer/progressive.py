"""Progressive refinement: a coarse frame at once, the full frame when input stops.

While the camera or the transfer function changes, each request renders a coarse
frame (the image at a fraction of its size, upsampled bilinearly) and then starts the
full render. A newer request cancels the render in flight at the end of the chunk of
rows of 8-pixel tiles running (``raycast.frame.run_in_chunks``; chunks of about
:data:`CHUNK_SECONDS`, at least one row of tiles), so a window never waits for a frame
nobody will see. The full frame is
the plan's own render: equal, bit for bit, to :func:`pv_hdrvol.render` of the same
scene.

The coarse factor follows a time budget (methods.md C.4 pitfall 10: a fixed level is a
GPU-era choice): after each coarse frame, the next uses the smallest factor whose
predicted time (pixels scale as ``1 / factor**2``) fits ``coarse_seconds``.

:class:`ProgressiveRenderer` runs renders on a worker thread (numba's kernels release
the GIL, so a GUI stays responsive) and hands each :class:`Frame` to ``on_frame`` on
that thread; :meth:`ProgressiveRenderer.frames` is the same sequence, synchronous, for
scripts and tests.

A volume larger than memory (:class:`~pv_hdrvol.MultiscaleVolume`, a multiresolution
store) refines by level of detail as well as by pixels (HDR VolVis, section 6.3: a coarse
level while the user interacts, finer levels when the camera rests). Every frame renders
with ``wait=False`` (:meth:`MultiscalePlan.execute
<pv_hdrvol.outofcore.render.MultiscalePlan.execute>`): what is resident, coarser
ancestors where chunks have not arrived, never a hole. The coarse frame is rendered at
``1 / factor`` of the size, so its ``screen_error`` in full-size pixels is ``factor``
times the renderer's: the time budget that picks the factor picks the coarser level too.
When the camera rests, ``"refining"`` frames at full size follow as chunks arrive (a new
one when the loader's ``pending`` count drops, but not more often than the last frame
took to render, and at least every :data:`REFINE_SECONDS` while reads are pending),
until one is ``converged``: that last frame is ``"full"`` and equals, bit for bit,
:func:`pv_hdrvol.render` with ``wait=True``. A newer request cancels the refinement.
"""
from __future__ import annotations

import dataclasses
import threading
import time
import traceback
import warnings
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .._validate import as_real, as_size
from ..data.tets import is_unstructured
from ..image.hdr import HDRImage
from ..image.upsample import upsample
from ..outofcore.render import MultiscaleVolume
from ..raycast.grid import EmptyRenderWarning, GridPlan, collected_warnings
from ..data.kinds import as_renderable
from ..raycast.tets import TetPlan
from ..rays.camera import data_bounds, fit_camera

#: Coarse factors tried, smallest first (full-size pixels per coarse pixel, per axis).
FACTORS = (2, 3, 4, 6, 8, 12, 16)
#: The coarse frame's time budget: 12.5 frames per second, so that frames whose time
#: the policy predicted a little short still come at 10 per second or more.
COARSE_SECONDS = 0.08
#: A render checks for a newer request after chunks of rows of tiles of about this
#: long (at least one row of 8-pixel tiles): the latency of cancellation.
CHUNK_SECONDS = 0.03
#: Out of core: while chunks are pending, a refining frame at least this often (seconds).
REFINE_SECONDS = 0.2


class Cancelled(Exception):
    """A render stopped because a newer request came (or the renderer closed)."""


@dataclass(frozen=True)
class Frame:
    """One frame of a progressive sequence.

    Attributes
    ----------
    image : HDRImage
        At the requested size: a coarse frame upsampled, or the full render.
    level : {"coarse", "refining", "full"}
        ``"refining"``: out of core only, a full-size frame rendered before every chunk it
        asks for has arrived (coarser levels there); ``image.metadata["levels"]`` says
        how many blocks each level drew.
    factor : int
        Full-size pixels per rendered pixel, per axis (1 for the full frame).
    generation : int
        The request this frame answers (:meth:`ProgressiveRenderer.request`'s return).
    seconds : float
        Wall time of the frame's render (and upsampling).
    unoccluded : HDRImage or None
        With ``unoccluded=True`` and a ``far`` that stops some rays: the same render with
        no ray stopped (the pixels ``far`` cuts rendered again, the others shared), for
        statistics that geometry in front must not change (a scene's tone mapping).
        ``None`` otherwise: then it equals ``image``.
    warnings : tuple of Warning
        What the renderer warned while making the frame (an
        :class:`~pv_hdrvol.EmptyRenderWarning` saying why the image is empty). The
        worker thread hands them over here instead of warning (:mod:`warnings` is
        process-wide: they would surface in whatever the main thread runs next); the
        owner shows them with the image. :meth:`ProgressiveRenderer.frames` warns them
        too, in its caller's thread.
    """

    image: HDRImage
    level: str
    factor: int
    generation: int
    seconds: float
    unoccluded: Optional[HDRImage] = None
    warnings: tuple = ()


class ProgressiveRenderer:
    """Renders one scene (data, transfer function, options) progressively, for any
    camera and image size.

    Parameters
    ----------
    data : pyvista.ImageData, vtkImageData, ndarray, GridVolume, MultiscaleVolume, or a tetrahedral mesh
        As :func:`pv_hdrvol.render`; converted once. A :class:`~pv_hdrvol.MultiscaleVolume`
        refines by level of detail too (see the module).
    tf : TransferFunction, optional
        The default is the renderer's default for the data.
    options : RenderOptions, optional
        And ``**option_kwargs``: as :func:`pv_hdrvol.render`: RenderOptions fields, and
        ``cmap``, ``clim``, ``opacity``, ``scale`` shaping the default transfer function
        (:func:`~pv_hdrvol.raycast.grid.resolve_render_options`, as every front end).
    scalars, preference
        Which array of a dataset, as :func:`pv_hdrvol.render`.
    coarse_seconds : float
        The coarse frame's time budget (default :data:`COARSE_SECONDS`).
    factor : int
        The first coarse frame's factor (default 4); later ones follow the budget.
    on_frame : callable, optional
        ``on_frame(frame)``, called on the worker thread for every frame of the latest
        request (frames of superseded requests are dropped). Needed for
        :meth:`request`; not for :meth:`frames`.
    on_error : callable, optional
        ``on_error(exception)`` on the worker thread when a render fails (default: the
        traceback is printed); the worker goes on with the next request.
    screen_error : float, optional
        Out of core only: the largest projected voxel, in pixels, of the converged frame
        (default 1; as :meth:`MultiscalePlan.execute
        <pv_hdrvol.outofcore.render.MultiscalePlan.execute>`).

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> from pv_hdrvol.viewer.progressive import ProgressiveRenderer
    >>> renderer = ProgressiveRenderer(np.random.default_rng(0).random((16, 16, 16)), precision="float64")
    >>> [(f.level, f.factor, f.image.shape) for f in renderer.frames("iso", (32, 32))]
    [('coarse', 4, (32, 32)), ('full', 1, (32, 32))]
    """

    def __init__(self, data, tf=None, options=None, *, coarse_seconds=COARSE_SECONDS, factor=4, on_frame=None,
                 on_error=None, scalars=None, preference="point", screen_error=None, **option_kwargs):
        #: whether the data is a MultiscaleVolume (rendered out of core, refined by level)
        self.multiscale = isinstance(data, MultiscaleVolume)
        if self.multiscale:
            if scalars is not None:
                raise ValueError("scalars= picks an array of a dataset; a multiresolution store holds one: "
                                 f"got {scalars!r}")
            self.data = data
        else:
            if screen_error is not None:
                raise ValueError("screen_error= is the level of detail of an out-of-core volume (MultiscaleVolume); "
                                 f"this is a {type(data).__name__}")
            self.data = as_renderable(data, scalars=scalars, preference=preference)
        #: what a view name frames: the bounds of the data given (:func:`~pv_hdrvol.rays.camera.data_bounds`;
        #: a dataset's cell corners, where the volume made of cell data spans the cell centres)
        self.bounds = data_bounds(data, scalars, preference)
        self.screen_error = 1.0 if screen_error is None else as_real("screen_error", screen_error, low=0.0,
                                                                        low_open=True)
        self.tets = not self.multiscale and is_unstructured(self.data)
        self.coarse_seconds = as_real("coarse_seconds", coarse_seconds, low=0.0, low_open=True)
        if factor not in FACTORS:
            raise ValueError(f"factor must be one of {FACTORS}; got {factor!r}")
        self.factor = factor
        for name, f in (("on_frame", on_frame), ("on_error", on_error)):
            if f is not None and not callable(f):
                raise TypeError(f"{name} must be callable; got {type(f).__name__}")
        self.on_frame, self.on_error = on_frame, on_error
        self._lock = threading.Condition()
        # the plan resolves tf, the transfer function's words and the options (resolve_render_options)
        self._plan = self._make_plan(tf, options, **option_kwargs)
        self.options = self._plan.options
        self._generation = 0
        self._pending = None  # (generation, camera, size, lens, plan, far, unoccluded) of the latest request
        self._thread = None
        self._closed = False
        #: the last frame delivered by the worker (None before the first)
        self.last_frame: Optional[Frame] = None

    def _make_plan(self, tf, options, **option_kwargs):
        return (TetPlan if self.tets else GridPlan)(self.data, tf, options, **option_kwargs)

    @property
    def tf(self):
        """The transfer function of the scene (the plan's)."""
        return self._plan.tf

    def set_scene(self, tf=None, **option_changes):
        """Change the transfer function and/or options (``global_alpha=``, ``step=``,
        ...; validated now) for the next requests. Renders in flight keep theirs."""
        options = self.options.replace(**option_changes) if option_changes else self.options
        if tf is None and option_changes and set(option_changes) <= {"clip_planes", "crop_box"}:
            # a clip changes only each ray's interval: the plan's tables and arrays stay
            plan = self._plan.with_clip(options.clip_planes, options.crop_box)
        else:
            plan = self._make_plan(self._plan.tf if tf is None else tf, options)
        with self._lock:
            self.options, self._plan = options, plan

    # -- synchronous ------------------------------------------------------------------
    def frames(self, camera, size, *, lens=None, coarse=True, far=None, unoccluded=False, refine=True):
        """The frames of one request, rendered here: the coarse frame (unless
        ``coarse=False``), then the full one. A list of :class:`Frame`. ``far``: where
        opaque geometry stops each ray (as :meth:`GridPlan.execute
        <pv_hdrvol.raycast.grid.GridPlan.execute>`; the coarse frame takes the value
        of the full-size pixel at each coarse pixel's centre). ``unoccluded=True``:
        each frame also carries the render without ``far`` (:attr:`Frame.unoccluded`).
        Out of core, ``"refining"`` frames come before the full one as chunks arrive
        (see the module); ``refine=False`` renders the full frame waiting for its chunks
        instead (one frame)."""
        size = as_size(size)
        self._check_lens(lens)
        camera = fit_camera(self.bounds, camera)
        with self._lock:
            plan = self._plan
        out = list(self._sequence(plan, camera, size, lens, 0, lambda: False, far, unoccluded, coarse, refine))
        for message in dict.fromkeys(w for frame in out for w in map(str, frame.warnings)):
            warnings.warn(message, EmptyRenderWarning, stacklevel=2)  # rendered here: the caller's warnings
        return out

    def _check_lens(self, lens):
        if lens is not None and self.multiscale:
            raise ValueError("lenses are not supported for out-of-core volumes (MultiscaleVolume) yet")

    def _sequence(self, plan, camera, size, lens, generation, stale, far, unoccluded, coarse=True, refine=True):
        """The frames of one request, one by one (each rendered when the caller asks for
        it, so a consumer that stops early renders no more)."""
        if coarse and _coarse_lens(lens, 0.5) is not _NO_COARSE:
            yield _collecting(self._coarse, plan, camera, size, lens, generation, stale, far, unoccluded)
        if self.multiscale and refine:
            yield from self._refine(plan, camera, size, lens, generation, stale, far, unoccluded)
        else:
            yield _collecting(self._full, plan, camera, size, lens, generation, stale, far, unoccluded)

    def _refine(self, plan, camera, size, lens, generation, stale, far, unoccluded):
        """Out of core: full-size frames of what is resident, a new one as chunks arrive,
        until one is converged (``"full"``)."""
        cache = plan.volume.cache(plan.dtype)
        idle = 0
        while True:
            frame = _collecting(self._full, plan, camera, size, lens, generation, stale, far, unoccluded, False)
            meta = frame.image.metadata
            # pending 0 twice without converging: nothing more will arrive (reads the cache
            # refused); the frame stands as the full one rather than polling for ever
            done = meta["converged"] or (meta["pending"] == 0 and idle >= 1)
            if done:
                yield frame
                return
            yield dataclasses.replace(frame, level="refining")
            idle = idle + 1 if meta["pending"] == 0 else 0
            _await_chunks(cache, meta["pending"], frame.seconds, stale)
            if stale():
                return

    def _coarse(self, plan, camera, size, lens, generation, stale, far=None, unoccluded=False):
        width, height = size
        f = self.factor
        small = (max(1, -(-width // f)), max(1, -(-height // f)))
        if far is not None:
            far = np.asarray(far)
            rows = np.minimum(((np.arange(small[1]) + 0.5) * height / small[1]).astype(int), height - 1)
            cols = np.minimum(((np.arange(small[0]) + 0.5) * width / small[0]).astype(int), width - 1)
            far = far[rows[:, None], cols[None, :]]
        t0 = time.perf_counter()
        small_lens = _coarse_lens(lens, small[0] / width)
        image = self._execute(plan, camera, small, small_lens, stale, far, wait=False)
        rendered = time.perf_counter() - t0
        opened = self._unoccluded(plan, camera, small, small_lens, stale, far, image, False) if unoccluded else None
        image = _resize(image, size)
        opened = None if opened is None else _resize(opened, size)
        seconds = time.perf_counter() - t0
        self.factor = _next_factor(f, rendered, self.coarse_seconds)
        return Frame(image, "coarse", f, generation, seconds, opened)

    def _full(self, plan, camera, size, lens, generation, stale, far=None, unoccluded=False, wait=True):
        t0 = time.perf_counter()
        image = self._execute(plan, camera, size, lens, stale, far, wait=wait)
        opened = self._unoccluded(plan, camera, size, lens, stale, far, image, wait) if unoccluded else None
        return Frame(image, "full", 1, generation, time.perf_counter() - t0, opened)

    def _unoccluded(self, plan, camera, size, lens, stale, far, image, wait=True):
        """``image`` (rendered with ``far``) as it would be without ``far``, or None
        when ``far`` stopped no ray: the smallest window holding every stopped ray is
        rendered again without it (a window is pixel for pixel the full render's;
        meshes have no windows and render whole)."""
        if far is None:
            return None
        stopped = np.isfinite(np.asarray(far))
        if not stopped.any():
            return None
        if self.tets:
            return self._execute(plan, camera, size, lens, stale)
        rows = np.nonzero(stopped.any(axis=1))[0]
        cols = np.nonzero(stopped.any(axis=0))[0]
        window = (int(cols[0]), int(rows[0]), int(cols[-1] - cols[0] + 1), int(rows[-1] - rows[0] + 1))
        part = self._execute(plan, camera, size, lens, stale, window=window, wait=wait)
        rgba = np.array(image.rgba)
        rgba[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1] = part.rgba
        return HDRImage(rgba, image.depth)  # depth is not the point: statistics read the colour

    def _execute(self, plan, camera, size, lens, stale, far=None, window=None, wait=True):
        seen = []

        def progress(_fraction):
            if stale():
                seen.append(True)
                return False
            return True

        try:
            if self.tets:
                if lens is not None:
                    raise ValueError("lenses are not supported for tetrahedral meshes")
                return plan.execute(camera, size, progress=progress, progress_bar=False,
                                    chunk_seconds=CHUNK_SECONDS, far=far)
            if self.multiscale:
                # wait=False: what is resident (never a hole); wait=True only where a caller
                # asked for the converged frame at once (refine=False)
                return plan.execute(camera, size, screen_error=self.screen_error, wait=wait, progress=progress,
                                    progress_bar=False, chunk_seconds=CHUNK_SECONDS, far=far, window=window)
            return plan.execute(camera, size, lens=lens, progress=progress, progress_bar=False,
                                chunk_seconds=CHUNK_SECONDS, far=far, window=window)
        except RuntimeError as error:
            if seen and str(error) == "render aborted":
                raise Cancelled() from None
            raise

    # -- asynchronous -----------------------------------------------------------------
    def request(self, camera, size, *, lens=None, far=None, unoccluded=False):
        """Render ``camera`` at ``size`` on the worker thread: a coarse frame, then the
        full one, each handed to ``on_frame``. Cancels the render in flight. Returns the
        request's generation number (frames carry it). ``far`` and ``unoccluded``: as
        :meth:`frames`."""
        if self.on_frame is None:
            raise ValueError("request() needs on_frame= (the frames go there); frames() renders synchronously")
        size = as_size(size)
        self._check_lens(lens)
        camera = fit_camera(self.bounds, camera)
        with self._lock:
            if self._closed:
                raise RuntimeError("the renderer is closed")
            self._generation += 1
            self._pending = (self._generation, camera, size, lens, self._plan, far, bool(unoccluded))
            if self._thread is None:
                self._thread = threading.Thread(target=self._work, name="pv_hdrvol progressive", daemon=True)
                self._thread.start()
            self._lock.notify_all()
            return self._generation

    def _work(self):
        while True:
            with self._lock:
                while self._pending is None and not self._closed:
                    self._lock.wait()
                if self._closed:
                    return
                generation, camera, size, lens, plan, far, unoccluded = self._pending
                self._pending = None

            def stale(generation=generation):
                return self._closed or self._generation != generation

            try:
                for frame in self._sequence(plan, camera, size, lens, generation, stale, far, unoccluded):
                    if stale():
                        break
                    self.last_frame = frame
                    self.on_frame(frame)
            except Cancelled:
                continue
            except Exception as error:  # noqa: BLE001 - handed to the owner, the thread goes on
                if self.on_error is None:
                    traceback.print_exc()  # and the worker stays for the next request
                else:
                    self.on_error(error)

    def close(self):
        """Stop the worker (a render in flight is cancelled at its next row of tiles)."""
        with self._lock:
            self._closed = True
            self._lock.notify_all()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


_NO_COARSE = object()


def _collecting(render, *args):
    """``render(*args)``'s frame, carrying the warnings the renderer gave meanwhile
    (:attr:`Frame.warnings`) instead of warning them."""
    with collected_warnings() as said:
        frame = render(*args)
    return dataclasses.replace(frame, warnings=tuple(said)) if said else frame


def level_text(image, level=None):
    """What an out-of-core frame drew, in a line for a status bar: the blocks per level of
    detail (0 the finest) and whether the frame is converged or how many chunks are still
    loading; ``level`` (a :attr:`Frame.level`) leads it. ``""`` for an image without
    levels (an in-core render).

    Examples
    --------
    >>> from pv_hdrvol import HDRImage
    >>> import numpy as np
    >>> image = HDRImage(np.zeros((1, 1, 4)), metadata={"levels": [3, 0, 5], "converged": False, "pending": 7})
    >>> level_text(image, "refining")
    'refining: level 0: 3 blocks, level 2: 5 blocks; loading 7 chunks'
    """
    meta = getattr(image, "metadata", None) or {}
    if "levels" not in meta:
        return ""
    drawn = ", ".join(f"level {L}: {n} block{'s' if n != 1 else ''}" for L, n in enumerate(meta["levels"]) if n)
    state = "converged" if meta.get("converged") else f"loading {meta.get('pending', 0)} chunks"
    if level == "coarse":  # converged at the coarse frame's own (coarser) level of detail only
        state = "moving" if meta.get("converged") else state
    return f"{level + ': ' if level else ''}{drawn or 'nothing visible'}; {state}"


def _await_chunks(cache, pending, seconds, stale):
    """Wait until fewer than ``pending`` chunks are loading in ``cache`` (and at least
    ``seconds``, the last frame's render time, so that refining frames take at most about
    half the time), or :data:`REFINE_SECONDS` have passed, or the request is stale."""
    start = time.monotonic()
    while not stale():
        waited = time.monotonic() - start
        if waited >= REFINE_SECONDS or (waited >= seconds and cache.pending < pending):
            return
        time.sleep(0.005)


def _coarse_lens(lens, scale):
    """``lens`` for an image ``scale`` times the size: a magnifier's (or sampling-rate
    lens's) circle or square shrinks with it; a fisheye has no pixel sizes. Other lenses
    (masks, polygons, feature lenses) give ``_NO_COARSE``: their requests render the
    full frame only."""
    import dataclasses

    if lens is None or type(lens).__name__ == "Fisheye":
        return lens
    names = {f.name for f in dataclasses.fields(lens)} if dataclasses.is_dataclass(lens) else set()
    if {"center", "radius"} <= names and isinstance(getattr(lens, "shape", "circle"), str) \
            and lens.center is not None and lens.radius is not None:
        changes = {"center": (lens.center[0] * scale, lens.center[1] * scale), "radius": lens.radius * scale}
        if getattr(lens, "transition", None) is not None:
            changes["transition"] = lens.transition * scale
        return dataclasses.replace(lens, **changes)
    return _NO_COARSE


def _next_factor(factor, seconds, budget):
    """The smallest factor whose predicted time fits ``budget``, from a frame at
    ``factor`` that took ``seconds`` (time scales as 1 / factor**2)."""
    for f in FACTORS:
        if seconds * (factor / f) ** 2 <= budget:
            return f
    return FACTORS[-1]


def _resize(image, size):
    """A coarse image at ``size``: premultiplied RGBA bilinear (``image.upsample``'s
    kernel, pixel centres aligned, cut to ``size``), depth nearest."""
    width, height = size
    h, w = image.shape
    if (w, h) == (width, height):
        return image
    factor = width / w if abs(width / w - height / h) < 1e-12 else None
    if factor is not None and round(h * factor) >= height and round(w * factor) >= width:
        rgba = upsample(image.rgba, factor=factor, method="bilinear")[:height, :width]
    else:
        rgba = _bilinear(image.rgba, height, width)
    rows = np.minimum((np.arange(height) * h) // height, h - 1)
    cols = np.minimum((np.arange(width) * w) // width, w - 1)
    depth = image.depth[rows[:, None], cols[None, :]]
    meta = dict(image.metadata, coarse_size=[w, h])
    return HDRImage(rgba.astype(image.rgba.dtype, copy=False), depth, metadata=meta)


def _bilinear(a, height, width):
    """``a`` (h, w, c) resampled to (height, width), pixel centres aligned."""
    h, w = a.shape[:2]
    y = np.clip((np.arange(height) + 0.5) * h / height - 0.5, 0, h - 1)
    x = np.clip((np.arange(width) + 0.5) * w / width - 0.5, 0, w - 1)
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    y1, x1 = np.minimum(y0 + 1, h - 1), np.minimum(x0 + 1, w - 1)
    fy, fx = (y - y0)[:, None, None], (x - x0)[None, :, None]
    top = a[y0][:, x0] * (1 - fx) + a[y0][:, x1] * fx
    bottom = a[y1][:, x0] * (1 - fx) + a[y1][:, x1] * fx
    return top * (1 - fy) + bottom * fy
