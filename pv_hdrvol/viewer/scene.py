"""HDR volumes inside PyVista scenes: ``plotter.hdrvol.add_volume(data, ...)``.

PyVista lets plugins extend its plotters with namespaced components (0.48+,
``pyvista.plotter_components``); this module registers ``hdrvol`` on every plotter,
``pyvistaqt.BackgroundPlotter`` included. :func:`add_hdr_volume` is the same as a
function of the plotter.

How it draws, each time VTK renders the scene (the renderer's ``EndEvent``):

1. read the opaque scene's colour and depth buffers (VTK's own drawing of the meshes);
2. turn the depth into the distance along each pixel's ray (:func:`ray_distances`):
   rays stop there, as VTK's volume mappers stop at the depth buffer, so meshes in
   front of or inside the volume hide what lies behind them;
3. when the camera, the window size or the depth changed, render the volume: at once
   (full quality) on an off-screen plotter (scripts, screenshots, notebooks' static
   backend); on a window, progressively on a worker thread (a coarse frame within
   about 0.1 s, the full frame when the camera rests; a newer view cancels the old);
4. tone-map it with the statistics of the volume alone (the rays the meshes stopped
   are rendered again without them, :attr:`Frame.unoccluded
   <pv_hdrvol.viewer.progressive.Frame.unoccluded>`): a mesh in front changes only the
   pixels it covers (for the global operators; a local one, ``durand`` or ``fattal``,
   also maps each pixel by its neighbours);
5. composite the tone-mapped volume ``T(C)`` over the scene as premultiplied colour
   with coverage ``max(alpha, max(T(C)))`` (:func:`over_scene`), into an opaque image
   drawn by an overlay renderer on the layer above the scene's; the scene's 2-D
   annotations (text, scalar bars) are drawn there too, above the volume, and widgets'
   renderers (the orientation axes) stay above it.

The coverage is the least one for which the tone-mapped colour is a valid premultiplied
colour: the tone mapper brightens faint emission far beyond its opacity, and adding
that light over a white background saturated it (PyVista's default theme: the volume
vanished); with the coverage the volume hides as much of the background as it shows
colour. Over black it changes nothing (``T(C)`` as before). docs/interactive.md
measures the volume's visibility on white, grey and black against PyVista's
``add_volume`` on the same data.

The HDR render is kept (:attr:`HDRVolumeActor.hdr`): changing the tone mapping only
re-maps it. Noticed and left as is: the volume follows the camera a frame late while it
renders.
"""
from __future__ import annotations

import threading
import warnings
import zlib

import numpy as np

from .._validate import as_real
from ..image.tonemap import OPERATORS, fit
from ..image.tonemap import tonemap as _tonemap
from ..raycast.grid import EmptyRenderWarning
from ..rays.camera import Camera
from .progressive import COARSE_SECONDS, ProgressiveRenderer, level_text

#: Interval of the timer that shows frames finished on the worker thread (ms).
POLL_MS = 30


def ray_distances(camera, depth, vtk_camera=None):
    """The world distance along each pixel's ray to the opaque surface of ``depth``.

    Parameters
    ----------
    camera : Camera
        The camera of the render (its rays: :meth:`Camera.rays`).
    depth : ndarray (rows, cols)
        VTK's depth buffer in [0, 1] (OpenGL window depth; row 0 at the top, as
        :class:`~pv_hdrvol.HDRImage`); 1 is the background.
    vtk_camera : vtkCamera, optional
        The camera whose projection made ``depth`` (default ``camera.to_vtk()``).

    Returns
    -------
    ndarray (rows, cols), float64
        ``inf`` where nothing opaque was drawn.
    """
    depth = np.asarray(depth, dtype=np.float64)
    rows, cols = depth.shape
    vtk_camera = camera.to_vtk() if vtk_camera is None else vtk_camera
    m = vtk_camera.GetCompositeProjectionTransformMatrix(cols / rows, -1.0, 1.0)
    matrix = np.array([[m.GetElement(i, j) for j in range(4)] for i in range(4)])
    inverse = np.linalg.inv(matrix)
    x = (np.arange(cols) + 0.5) / cols * 2.0 - 1.0
    y = 1.0 - (np.arange(rows) + 0.5) / rows * 2.0  # row 0 at the top
    ndc = np.empty((rows, cols, 4))
    ndc[..., 0] = x[None, :]
    ndc[..., 1] = y[:, None]
    ndc[..., 2] = 2.0 * depth - 1.0
    ndc[..., 3] = 1.0
    world = ndc @ inverse.T
    world = world[..., :3] / world[..., 3:]
    rays = camera.rays((cols, rows))
    t = np.einsum("ij,ij->i", world.reshape(-1, 3) - rays.origins, rays.directions).reshape(rows, cols)
    return np.where(depth < 1.0, np.maximum(t, 0.0), np.inf)


def over_scene(rgb, alpha, scene):
    """The tone-mapped volume over the scene: ``rgb + (1 - coverage) scene`` with
    ``coverage = max(alpha, max(rgb))`` per pixel, clipped to [0, 1].

    ``rgb`` (rows, cols, 3) display colour of the premultiplied render, ``alpha`` (rows,
    cols) its opacity, ``scene`` (rows, cols, 3) the display colour behind, all in
    [0, 1]. The coverage is the least that makes ``rgb`` a valid premultiplied colour
    (``rgb <= coverage``), and never less than the volume's opacity: over black the
    result is ``rgb``; over any background a pixel stays within [0, 1] before clipping.
    """
    rgb = np.asarray(rgb, dtype=np.float32)
    coverage = np.maximum(np.asarray(alpha, dtype=np.float32), rgb.max(axis=-1))
    return np.clip(rgb + (1.0 - np.minimum(coverage, 1.0))[..., None] * scene, 0.0, 1.0)


def _widget_lists(plotter):
    """The plotter's lists of plane and box widgets (``plotter.widgets`` from PyVista
    0.47 on, the plotter itself before)."""
    owner = getattr(plotter, "widgets", None)
    if owner is None or not hasattr(owner, "plane_widgets"):
        owner = plotter
    return [getattr(owner, name) for name in ("plane_widgets", "box_widgets") if isinstance(getattr(owner, name, None),
                                                                                           list)]


class HDRVolumeActor:
    """One HDR volume in a PyVista plotter (made by :func:`add_hdr_volume`).

    Attributes
    ----------
    hdr : HDRImage or None
        The last volume render shown (coarse, refining or full), at the renderer's size.
    level : {"coarse", "refining", "full", None}
        Which it was (``"refining"``: an out-of-core volume's frame before all its chunks
        arrived; see :mod:`pv_hdrvol.viewer.progressive`).
    renderer : ProgressiveRenderer
        The scene's renderer (transfer function, options).
    scalar_bar : vtkScalarBarActor or None
        The transfer function's colour bar (``show_scalar_bar=True``).
    """

    def __init__(self, plotter, data, tf=None, *, tonemap="reinhard", tonemap_params=None, progressive=None,
                 coarse_seconds=COARSE_SECONDS, scalars=None, preference="point", show_scalar_bar=True,
                 scalar_bar_args=None, **render_kwargs):
        from vtkmodules.vtkCommonDataModel import vtkImageData
        from vtkmodules.vtkRenderingCore import vtkImageActor, vtkRenderer

        if isinstance(tonemap, str) and tonemap not in OPERATORS:
            raise ValueError(f"tonemap must be one of {sorted(OPERATORS)} or a callable; got {tonemap!r}")
        if scalar_bar_args is not None and not hasattr(scalar_bar_args, "keys"):
            raise TypeError(f"scalar_bar_args must be a dict of pyvista's add_scalar_bar arguments; got "
                            f"{type(scalar_bar_args).__name__}")
        self.plotter = plotter
        self.scene = plotter.renderer
        self.tonemap_operator = tonemap
        self.tonemap_params = dict(tonemap_params or {})
        self._lock = threading.Lock()
        self._arrived = None  # a frame finished on the worker, waiting for the GUI thread
        self.progressive = (not getattr(plotter, "off_screen", False) and getattr(plotter, "iren", None) is not None) \
            if progressive is None else bool(progressive)
        self.renderer = ProgressiveRenderer(data, tf, coarse_seconds=coarse_seconds, scalars=scalars,
                                            preference=preference, on_frame=self._on_frame,
                                            on_error=self._on_error, **render_kwargs)
        self.hdr, self.level, self.error, self.far = None, None, None, None
        #: what the renderer warned about the full frame shown (an EmptyRenderWarning's reason)
        self.warnings = ()
        self._unoccluded = None  # self.hdr without the scene's meshes (None: the same), for the statistics
        self._display = None  # (tone-mapped rgb float32 (rows, cols, 3), alpha (rows, cols)) of self.hdr
        self._key = None
        self._requested = self._shown = 0  # generations: of the last request, of the full frame shown
        self._busy = False
        self.lens = None
        self._clip_widgets = []
        #: the Camera of the last render requested
        self.renderer_camera = None
        # the overlay: an opaque image of the composite, on the layer above the scene's,
        # drawn before the other renderers there (widgets' own renderers stay on top)
        window = plotter.render_window
        self._overlay = vtkRenderer()
        self._overlay.SetLayer(self.scene.GetLayer() + 1)
        window.SetNumberOfLayers(max(window.GetNumberOfLayers(), self.scene.GetLayer() + 2))
        self._overlay.InteractiveOff()
        self._overlay.SetViewport(self.scene.GetViewport())
        self._image = vtkImageData()
        self._actor = vtkImageActor()
        self._actor.InterpolateOff()
        self._actor.GetMapper().SetInputData(self._image)
        self._actor.GetMapper().BorderOn()  # pixels to the image's edge, not from centre to centre
        self._actor.VisibilityOff()
        self._overlay.AddActor(self._actor)
        self._overlay.GetActiveCamera().ParallelProjectionOn()
        window.AddRenderer(self._overlay)
        _first_of_its_layer(window, self._overlay)
        self._annotations = []  # the scene's 2-D props, hidden while it renders, drawn on the overlay
        # the volume's box, invisible, so that reset_camera() and the clipping range see it: the
        # dataset's bounds, which hv.render's view names frame too (fit_camera)
        self._box = _bounds_actor(self.renderer.bounds)
        self.scene.AddActor(self._box)
        self._start_observer = self.scene.AddObserver("StartEvent", self._scene_starts)
        self._observer = self.scene.AddObserver("EndEvent", self._scene_rendered)
        self.scalar_bar = None
        if show_scalar_bar:
            self.scalar_bar = add_scalar_bar(plotter, self.renderer.tf, _scalars_name(data, scalars),
                                             **dict(scalar_bar_args or {}))
        self._timer = None
        if self.progressive and getattr(plotter, "iren", None) is not None:
            # a window's timer shows the frames the worker finished (off screen: wait() does)
            interactor = plotter.iren.interactor
            self._timer_observer = interactor.AddObserver("TimerEvent", self._poll)
            self._timer = interactor.CreateRepeatingTimer(POLL_MS)

    # -- what users change ------------------------------------------------------------
    def set_transfer_function(self, tf=None, **options):
        """A new transfer function and/or render options (``global_alpha=``...): the
        volume renders again at the next scene render (which this requests)."""
        self.renderer.set_scene(tf, **options)
        if tf is not None and self.scalar_bar is not None:
            self.scalar_bar.SetLookupTable(_lookup_table(self.renderer.tf))
        self._key = None
        self._render_window()

    def set_lens(self, lens):
        """Render through ``lens`` (a :class:`~pv_hdrvol.Magnifier` or other lens of
        image volumes; ``None``: none). A lens's rays are not the camera's, so they are
        not stopped by the scene's depth: use lenses on volumes without meshes in front."""
        if lens is not None and self.renderer.tets:
            raise ValueError("lenses are not supported for tetrahedral meshes")
        self.renderer._check_lens(lens)  # nor, yet, out of core
        self.lens = lens
        self._key = None
        self._render_window()

    def set_clip(self, clip_planes=None, crop_box=None):
        """Cut the volume with ``clip_planes`` and/or a ``crop_box`` (as
        :class:`~pv_hdrvol.RenderOptions`'; ``None``: none), keeping the rest of the
        scene; it renders again at the next scene render (which this requests)."""
        self.renderer.set_scene(clip_planes=clip_planes, crop_box=crop_box)
        self._key = None
        self._render_window()

    def add_clip_plane_widget(self, normal="x", origin=None, *, invert=False, **widget_kwargs):
        """An interactive plane (PyVista's ``add_plane_widget``, a
        ``vtkImplicitPlaneWidget``) that clips the volume as it is dragged or turned:
        the side its normal points to is kept (VTK's convention; ``invert=True`` keeps
        the other). ``normal``: ``"x"``, ``"y"``, ``"z"``, ``"-x"``... or a vector;
        ``origin``: default the volume's centre; ``widget_kwargs`` go to
        ``add_plane_widget``. The crop box stays. Returns the widget
        (:meth:`clear_clip_widgets` removes it and the cut)."""
        bounds = self.renderer.data.bounds
        if origin is None:
            origin = tuple(0.5 * (bounds[2 * i] + bounds[2 * i + 1]) for i in range(3))
        sign = -1.0 if invert else 1.0
        widget_kwargs.setdefault("interaction_event", "always")  # cut while dragging (coarse frames)

        def moved(normal, origin):
            self.set_clip(((tuple(origin), tuple(sign * float(x) for x in normal)),),
                          self.renderer.options.crop_box)

        widget = self.plotter.add_plane_widget(moved, normal=normal, origin=origin, bounds=bounds,
                                               **widget_kwargs)
        self._clip_widgets.append(widget)
        return widget

    def add_crop_box_widget(self, **widget_kwargs):
        """An interactive box (PyVista's ``add_box_widget``) that crops the volume to it
        as its faces are dragged; ``widget_kwargs`` go to ``add_box_widget``. Returns
        the widget (:meth:`clear_clip_widgets` removes it and the crop)."""
        def moved(box):
            self.set_clip(self.renderer.options.clip_planes, box.bounds)

        widget_kwargs.setdefault("interaction_event", "always")
        widget_kwargs.setdefault("factor", 1.0)  # start at the volume's bounds: nothing cut yet
        widget = self.plotter.add_box_widget(moved, bounds=self.renderer.data.bounds, rotation_enabled=False,
                                             **widget_kwargs)
        self._clip_widgets.append(widget)
        return widget

    def remove_clip_widget(self, widget):
        """Remove one widget of :meth:`add_clip_plane_widget` or
        :meth:`add_crop_box_widget`, and its cut (the plane, or the crop box)."""
        if widget not in self._clip_widgets:
            raise ValueError("remove_clip_widget takes a widget that add_clip_plane_widget or add_crop_box_widget "
                             "of this volume returned")
        widget.Off()
        for store in _widget_lists(self.plotter):
            if widget in store:
                store.remove(widget)
        self._clip_widgets.remove(widget)
        box = widget.GetClassName() == "vtkBoxWidget"
        options = self.renderer.options
        self.set_clip(options.clip_planes if box else None, None if box else options.crop_box)

    def clear_clip_widgets(self):
        """Remove the clip and crop widgets of this volume, and their cut."""
        for widget in list(self._clip_widgets):
            self.remove_clip_widget(widget)

    def probe(self, col, row):
        """What the shown render holds at pixel ``(col, row)`` (row 0 at the top): a dict
        of ``rgba`` (linear, premultiplied), ``depth`` (world distance along the ray
        where the opacity first reached the render's depth threshold; inf if never),
        ``point`` (that world point, or None) and ``value`` (the data there, trilinear on
        a grid; None on a mesh, where no cell is searched, or without a point), ``level``."""
        if self.hdr is None:
            return None
        rows, cols = self.hdr.shape
        if not (0 <= col < cols and 0 <= row < rows):
            return None
        depth = float(self.hdr.depth[row, col])
        point = value = None
        if np.isfinite(depth) and self.lens is None:
            rays = self.renderer_camera.rays((cols, rows), (col, row, 1, 1))
            point = rays.origins[0] + depth * rays.directions[0]
            value = _value_at(self.renderer.data, point)
        return {"rgba": np.array(self.hdr.rgba[row, col], dtype=np.float64), "depth": depth, "point": point,
                "value": value, "level": self.level}

    def set_tonemap(self, operator=None, **params):
        """Re-map the kept HDR render with another operator or parameters (no new render)."""
        if operator is not None:
            self.tonemap_operator = operator
        self.tonemap_params.update(params)
        if self.hdr is not None:
            self._display = self._mapped(self.hdr, self._unoccluded)
        self._render_window()

    def remove(self):
        """Take the volume out of the plotter."""
        self.close()
        self.scene.RemoveObserver(self._observer)
        self.scene.RemoveObserver(self._start_observer)
        self._restore_annotations()
        self.scene.RemoveActor(self._box)
        if self.scalar_bar is not None:
            self.plotter.remove_scalar_bar(self.scalar_bar.GetTitle(), render=False)
        self.plotter.render_window.RemoveRenderer(self._overlay)
        actors = self.plotter.hdrvol._actors
        if self in actors:
            actors.remove(self)
        self._render_window()

    def close(self):
        """Stop the worker thread and the timer, and release the clip widgets (the
        plotter's close does this)."""
        for widget in self._clip_widgets:
            # their observers hold callbacks that hold this actor: a cycle through VTK
            widget.Off()
            widget.RemoveAllObservers()
            for store in _widget_lists(self.plotter):
                if widget in store:
                    store.remove(widget)
        self._clip_widgets = []
        if self._timer is not None and getattr(self.plotter, "iren", None) is not None:
            interactor = self.plotter.iren.interactor
            interactor.DestroyTimer(self._timer)
            interactor.RemoveObserver(self._timer_observer)
            self._timer = None
        self.renderer.close()

    # -- the drawing ----------------------------------------------------------------------
    def _mapped(self, image, unoccluded=None):
        """``(rgb, alpha)`` of ``image``, tone-mapped with the statistics of ``unoccluded``
        (the volume alone; None: ``image`` is)."""
        fitted = fit(image if unoccluded is None else unoccluded, self.tonemap_operator, **self.tonemap_params)
        out = _tonemap(image, self.tonemap_operator, fitted=fitted, **self.tonemap_params)
        alpha = np.clip(np.asarray(image.rgba[..., 3], dtype=np.float32), 0.0, 1.0)
        return out.rgb, alpha

    def _on_frame(self, frame):  # worker thread
        display = self._mapped(frame.image, frame.unoccluded)
        with self._lock:
            self._arrived = (frame, display)

    def _on_error(self, error):  # worker thread
        with self._lock:
            self.error = error

    def _poll(self, *_):  # GUI thread, timer
        with self._lock:
            arrived, self._arrived = self._arrived, None
        if arrived is not None:
            frame, display = arrived
            if frame.generation != self._requested:
                return  # a frame of a view already left (the worker drops most of them)
            self.hdr, self.level, self._display = frame.image, frame.level, display
            self._unoccluded = frame.unoccluded
            if frame.level == "full":
                self._shown = frame.generation
                self.warnings = frame.warnings
                for message in dict.fromkeys(map(str, frame.warnings)):
                    # the worker hands its warnings over (warnings is process-wide): said here, on
                    # the thread that shows the frame, once per full frame
                    warnings.warn(message, EmptyRenderWarning, stacklevel=2)
            self._render_window()

    def _render_window(self):
        # the plotter's render(): nothing before the plotter is first shown, as PyVista's add_* do
        if not self._busy and getattr(self.plotter, "render_window", None) is not None:
            self.plotter.render()

    def wait(self, timeout=30.0):
        """Block until the full frame of the present view is shown (progressive mode:
        runs the poll that a window's timer runs, so a script can wait for it). Returns
        whether it is; a render's error is raised here."""
        import time

        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self._poll()
            if self.up_to_date:
                return True
            if self.error is not None:
                raise self.error
            time.sleep(0.01)
        return False

    @property
    def status(self):
        """A line on the frame shown: out of core, its levels of detail and whether it is
        converged (:func:`~pv_hdrvol.viewer.progressive.level_text`); in core, ``""``."""
        return "" if self.hdr is None else level_text(self.hdr, self.level)

    @property
    def up_to_date(self):
        """Whether the full render of the present view and function is shown."""
        return self._key is not None and self.level == "full" and self._shown == self._requested

    def _scene_starts(self, *_):
        """Hide the scene's 2-D annotations while it renders (the composite must not
        hold them): the overlay draws them, above the volume."""
        if self._busy:
            return
        self._restore_annotations()
        props = self.scene.GetViewProps()
        props.InitTraversal()
        for _ in range(props.GetNumberOfItems()):
            prop = props.GetNextProp()
            if prop.IsA("vtkActor2D") and prop.GetVisibility():
                self._annotations.append(prop)
        for prop in self._annotations:
            prop.VisibilityOff()

    def _restore_annotations(self):
        for prop in self._annotations:
            prop.VisibilityOn()
        self._annotations = []

    def _scene_rendered(self, *_):
        if self._busy:
            return
        self._busy = True
        try:
            self._draw()
        finally:
            self._busy = False
            # the overlay draws the annotations, after the composite image
            annotations = self._annotations
            self._restore_annotations()
            props = self._overlay.GetViewProps()
            shown = [props.GetItemAsObject(i) for i in range(props.GetNumberOfItems())]
            for prop in shown:
                if prop is not self._actor and prop not in annotations:
                    self._overlay.RemoveViewProp(prop)
            for prop in annotations:
                if prop not in shown:
                    self._overlay.AddViewProp(prop)

    def _draw(self):
        from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkFloatArray, vtkUnsignedCharArray

        window = self.plotter.render_window
        cols, rows = self.scene.GetSize()
        x0, y0 = self.scene.GetOrigin()
        if cols < 1 or rows < 1:
            return
        z = vtkFloatArray()
        window.GetZbufferData(x0, y0, x0 + cols - 1, y0 + rows - 1, z)
        depth = vtk_to_numpy(z).reshape(rows, cols)[::-1]
        c = vtkUnsignedCharArray()
        window.GetRGBACharPixelData(x0, y0, x0 + cols - 1, y0 + rows - 1, 0, c)
        scene_rgb = vtk_to_numpy(c).reshape(rows, cols, 4)[::-1, :, :3]
        vtk_camera = self.scene.GetActiveCamera()
        camera = Camera.from_pyvista(vtk_camera)
        key = (camera, cols, rows, zlib.crc32(np.ascontiguousarray(depth).tobytes()))
        if key != self._key:
            self._key = key
            far = ray_distances(camera, depth, vtk_camera)
            #: world distance along each pixel's ray to the scene's opaque surfaces (inf: none), row 0 at the top
            self.far = far
            self.renderer_camera = camera
            if self.lens is not None:
                far = None  # a lens's rays are not the camera's (see set_lens)
            if self.progressive:
                self._requested = self.renderer.request(camera, (cols, rows), far=far, lens=self.lens,
                                                        unoccluded=True)
            else:
                (frame,) = self.renderer.frames(camera, (cols, rows), coarse=False, refine=False, far=far,
                                                lens=self.lens, unoccluded=True)
                self.hdr, self.level, self._unoccluded = frame.image, frame.level, frame.unoccluded
                self.warnings = frame.warnings  # frames() warned them already, here
                self._display = self._mapped(frame.image, frame.unoccluded)
                self._requested += 1
                self._shown = self._requested
        composite = scene_rgb.astype(np.float32) / 255.0
        if self._display is not None and self._display[0].shape[:2] == (rows, cols):
            composite = over_scene(*self._display, composite)
        pixels = np.round(np.clip(composite, 0.0, 1.0) * 255.0).astype(np.uint8)[::-1]
        self._image.SetDimensions(cols, rows, 1)
        self._image.GetPointData().SetScalars(numpy_to_vtk(pixels.reshape(-1, 3), deep=True))
        self._image.Modified()
        self._actor.VisibilityOn()
        cam = self._overlay.GetActiveCamera()
        cam.SetFocalPoint((cols - 1) / 2.0, (rows - 1) / 2.0, 0.0)
        cam.SetPosition((cols - 1) / 2.0, (rows - 1) / 2.0, 1.0)
        cam.SetViewUp(0.0, 1.0, 0.0)
        cam.SetParallelScale(rows / 2.0)
        self._overlay.ResetCameraClippingRange()
        #: the composite shown, (rows, cols, 3) uint8, row 0 at the top
        self.composite = pixels[::-1]


def _first_of_its_layer(window, renderer):
    """Move ``renderer`` before the other renderers of its layer in ``window``'s list
    (VTK draws a layer's renderers in list order): the orientation axes' and other
    widgets' renderers on that layer draw over it."""
    items = window.GetRenderers()
    order = [items.GetItemAsObject(i) for i in range(items.GetNumberOfItems())]
    order.remove(renderer)
    at = next((i for i, r in enumerate(order) if r.GetLayer() == renderer.GetLayer()), len(order))
    order.insert(at, renderer)
    for i, r in enumerate(order):
        items.ReplaceItem(i, r)


def _scalars_name(data, scalars):
    """The scalar bar's title: the rendered array's name, as PyVista's add_volume's."""
    if isinstance(scalars, str):
        return scalars
    from ..outofcore.render import MultiscaleVolume

    if isinstance(data, MultiscaleVolume):  # a store: its array's name
        return data.name or "hdrvol"
    try:
        name = data.active_scalars_name
    except AttributeError:
        name = None
    return name or "hdrvol"


def _lookup_table(tf, n=256):
    """A ``pyvista.LookupTable`` of ``tf``'s colours (``n`` entries evenly spaced on its
    axis; HDR colours divided by the brightest, as a screen shows them): log axes as
    VTK's log scale; a symlog axis, which VTK has none of, spans the axis itself and
    is labelled in data values by annotations (:func:`_symlog_ticks`)."""
    import pyvista as pv

    from ..data.transfer import scale_inverse, scale_forward

    a0, a1 = scale_forward([tf.values[0], tf.values[-1]], tf.scale, tf.linthresh)
    values = scale_inverse(np.linspace(a0, a1, n), tf.scale, tf.linthresh)
    rgb = tf.color_at(values)
    rgb = rgb / max(float(np.max(tf.colors)), 1e-300)
    lut = pv.LookupTable()
    lut.values = np.column_stack([np.round(np.clip(rgb, 0.0, 1.0) * 255.0), np.full(n, 255.0)]).astype(np.uint8)
    if tf.scale == "symlog":
        lut.scalar_range = (float(a0), float(a1))
        ticks = _symlog_ticks(float(tf.values[0]), float(tf.values[-1]), tf.linthresh)
        lut.annotations = {float(scale_forward(t, "symlog", tf.linthresh)): f"{t:.3g}" for t in ticks}
    else:
        lut.scalar_range = (float(tf.values[0]), float(tf.values[-1]))
        lut.log_scale = tf.scale == "log"
    return lut


def _symlog_ticks(lo, hi, linthresh, most=7):
    """Data values to label a symlog axis from ``lo`` to ``hi``: its ends, 0 when inside,
    and powers of ten of either sign (every k-th, at most ``most`` in all)."""
    ticks = {lo, hi}
    if lo < 0.0 < hi:
        ticks.add(0.0)
    powers = []
    top = max(abs(lo), abs(hi))
    if top > 0:
        for k in range(int(np.floor(np.log10(max(linthresh, 1e-300)))), int(np.floor(np.log10(top))) + 1):
            for sign in (-1.0, 1.0):
                v = sign * 10.0 ** k
                if lo < v < hi:
                    powers.append(v)
    step = max(1, -(-len(powers) // max(1, most - len(ticks))))
    by_size = sorted(powers, key=lambda v: (abs(v), v))[::-1]
    keep = set()
    for sign in (-1.0, 1.0):
        keep.update([v for v in by_size if np.sign(v) == sign][::step])
    return sorted(ticks | keep)


def add_scalar_bar(plotter, tf, title="hdrvol", **scalar_bar_args):
    """Add ``tf``'s colour bar to ``plotter`` (``plotter.add_scalar_bar`` with
    :func:`_lookup_table`; ``scalar_bar_args`` as PyVista's). Returns the
    ``vtkScalarBarActor``."""
    lut = _lookup_table(tf)
    args = dict(scalar_bar_args)
    if tf.scale == "symlog":
        args.setdefault("n_labels", 0)  # the annotations label it, in data values
    args.setdefault("title", title)
    args.setdefault("use_opacity", False)
    return plotter.add_scalar_bar(lookup_table=lut, **args)


def _value_at(data, point):
    """The data at world ``point``: trilinear on a grid (None outside), None on a mesh
    (a cell search is not done for a probe)."""
    from ..data.grid import GridVolume

    if not isinstance(data, GridVolume):
        return None
    axes = getattr(data, "axes", None)
    if axes is None:
        f = (np.asarray(point) - data.origin) / data.spacing  # (x, y, z) in voxels
    else:  # a rectilinear grid: the cell and the fraction in it, per axis
        f = np.array([np.interp(c, a, np.arange(a.size, dtype=np.float64), left=-1.0, right=a.size)
                      for c, a in zip(np.asarray(point, dtype=np.float64), axes)])
    dims = np.array(data.dims)  # (nx, ny, nz)
    if np.any(f < 0) or np.any(f > dims - 1):
        return None
    i0 = np.minimum(np.floor(f).astype(int), dims - 2)
    w = f - i0
    values = data.values  # (z, y, x)
    total = 0.0
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                weight = (w[0] if dx else 1 - w[0]) * (w[1] if dy else 1 - w[1]) * (w[2] if dz else 1 - w[2])
                total += weight * float(values[i0[2] + dz, i0[1] + dy, i0[0] + dx])
    return total


def _bounds_actor(bounds):
    """An actor over ``bounds`` that draws nothing (opacity 0, no depth) but counts in
    the renderer's bounds: ``reset_camera`` frames the volume, the clipping range keeps it."""
    from vtkmodules.vtkCommonExecutionModel import vtkAlgorithm
    from vtkmodules.vtkFiltersSources import vtkOutlineSource
    from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper

    source = vtkOutlineSource()
    source.SetBounds(*bounds)
    source.SetOutputPointsPrecision(vtkAlgorithm.DOUBLE_PRECISION)  # float32 corners framed 1e-7 off
    mapper = vtkPolyDataMapper()
    mapper.SetInputConnection(source.GetOutputPort())
    actor = vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetOpacity(0.0)
    actor.PickableOff()
    return actor


def add_hdr_volume(plotter, data, tf=None, *, tonemap="reinhard", tonemap_params=None, progressive=None,
                   coarse_seconds=COARSE_SECONDS, scalars=None, preference="point", show_scalar_bar=True,
                   scalar_bar_args=None, **render_kwargs):
    """Draw ``data`` (an image volume or tetrahedral mesh) as an HDR volume in
    ``plotter``'s scene, from its camera, occluded by its opaque meshes.

    Parameters
    ----------
    plotter : pyvista.Plotter or pyvistaqt.BackgroundPlotter
    data, tf, scalars, preference, **render_kwargs
        As :func:`pv_hdrvol.render`: RenderOptions fields (``precision=``,
        ``global_alpha=``, ``step=``...) and PyVista's ``cmap=``, ``clim=``,
        ``opacity=`` (a name such as ``"sigmoid"``, a number or opacities) and the axis
        ``scale=``, which shape the default transfer function with the same meaning as
        in ``hv.render`` (:func:`~pv_hdrvol.raycast.grid.resolve_render_options`). The
        volume's box, which ``reset_camera`` and the view names frame, is the dataset's
        bounds, as ``hv.render`` frames it. A :class:`~pv_hdrvol.MultiscaleVolume` (a
        store larger than memory) renders out of core: with a window, coarse levels
        while the camera moves and finer ones as chunks arrive; off screen, converged
        at once (``screen_error=`` sets its level of detail).
    tonemap : str or callable
        The operator that maps the HDR render to the screen (:func:`pv_hdrvol.tonemap`),
        with ``tonemap_params``.
    progressive : bool, optional
        Coarse frames while the camera moves and a worker thread (default: on for a
        plotter with a window; off-screen plotters render at full quality at once).
    coarse_seconds : float
        The coarse frame's time budget.
    show_scalar_bar : bool
        Add the transfer function's colour bar (its log axis where it has one), as
        PyVista's ``add_volume`` does (default True).
    scalar_bar_args : dict, optional
        Arguments of PyVista's ``add_scalar_bar`` (``title``, ``n_labels``, ``vertical``...).

    Returns
    -------
    HDRVolumeActor
    """
    import pyvista as pv

    if not isinstance(plotter, pv.BasePlotter):
        kind = type(plotter).__name__
        got = repr(plotter) if isinstance(plotter, str) else f"{'an' if kind[0] in 'AEIOU' else 'a'} {kind}"
        raise TypeError(f"plotter must be a pyvista.Plotter (or a pyvistaqt BackgroundPlotter or QtInteractor); got "
                        f"{got}: pass the plotter first, add_hdr_volume(plotter, data, tf)")
    as_real("coarse_seconds", coarse_seconds, low=0.0, low_open=True)
    actor = HDRVolumeActor(plotter, data, tf, tonemap=tonemap, tonemap_params=tonemap_params,
                           progressive=progressive, coarse_seconds=coarse_seconds, scalars=scalars,
                           preference=preference, show_scalar_bar=show_scalar_bar,
                           scalar_bar_args=scalar_bar_args, **render_kwargs)
    plotter.hdrvol._actors.append(actor)
    actor._render_window()
    return actor


def _register():
    import pyvista as pv

    if "hdrvol" in {r.name for r in pv.registered_plotter_components()}:
        return

    @pv.register_plotter_component("hdrvol")
    class HDRVolumeComponent:
        """``plotter.hdrvol``: HDR volumes in this plotter's scene."""

        def __init__(self, plotter):
            self._plotter = plotter
            self._actors = []

        def add_volume(self, data, tf=None, **kwargs):
            """:func:`pv_hdrvol.viewer.scene.add_hdr_volume` on this plotter."""
            return add_hdr_volume(self._plotter, data, tf, **kwargs)

        @property
        def actors(self):
            return tuple(self._actors)

        def __plotter_close__(self):
            for actor in self._actors:
                actor.close()


_register()
