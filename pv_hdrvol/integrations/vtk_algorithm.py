"""``HDRVolumeRenderer``: the ray caster as a VTK pipeline algorithm.

Pure VTK + pv_hdrvol (no ParaView import), so that a ParaView plugin can wrap it with
decorators only.
"""
from __future__ import annotations

import dataclasses
import numbers
import time
import weakref
from typing import NamedTuple

from vtkmodules.vtkCommonCore import vtkOutputWindow
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkImageData
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

from .._validate import as_choice, as_size
from ..data.kinds import BLOCKS, IMAGE_CLASSES, MESH, SUPPORTED, as_renderable, data_kind
from ..parallel.comm import PointToPointComm
from ..data.transfer import TF_KEYWORDS, TransferFunction, default_transfer_function_keyword
from ..params import RenderOptions, as_clip_planes
from ..rays.camera import Camera, Rays, as_camera, fit_camera
from . import VolumeCache, _content_key
from .vtk_base import ReportingAlgorithm, request_whole_extent

_SDDP = vtkStreamingDemandDrivenPipeline


def _option_methods(field, meaning):
    """``Set<Field>``/``Get<Field>`` for one :class:`RenderOptions` field."""

    def setter(self, value):
        self._set_options(**{field: value})

    def getter(self):
        return getattr(self._options, field)

    setter.__doc__ = (f"Set ``RenderOptions.{field}``: {meaning} Validated by "
                      ":class:`~pv_hdrvol.RenderOptions`; calls ``Modified()`` when it changes.")
    getter.__doc__ = f"``RenderOptions.{field}``: {meaning}"
    return setter, getter


def _bool_option_methods(field, meaning):
    """``Set<Field>``/``Get<Field>``/``<Field>On``/``<Field>Off`` for a bool field;
    the setter also takes VTK-style 0 and 1."""
    set_bool, getter = _option_methods(field, meaning)

    def setter(self, value):
        if isinstance(value, numbers.Integral) and not isinstance(value, bool) and value in (0, 1):
            value = bool(value)
        set_bool(self, value)

    def on(self):
        setter(self, True)

    def off(self):
        setter(self, False)

    setter.__doc__ = set_bool.__doc__.replace("Validated", "A bool (VTK-style 0/1 are accepted). Validated")
    on.__doc__ = f"Set ``RenderOptions.{field}`` to True."
    off.__doc__ = f"Set ``RenderOptions.{field}`` to False."
    return setter, getter, on, off


class HDRVolumeRenderer(ReportingAlgorithm):
    """Volume render a ``vtkImageData``, a ``vtkRectilinearGrid``, a curvilinear
    ``vtkStructuredGrid``, a tetrahedral ``vtkUnstructuredGrid`` or a composite dataset of
    those into a 2-D float RGBA ``vtkImageData``.

    Input port 0: ``vtkImageData`` (the whole extent is requested), ``vtkRectilinearGrid``,
    ``vtkStructuredGrid`` (each hexahedron split into five tetrahedra) or
    ``vtkUnstructuredGrid`` (tetrahedra; other 3-D cells are split, see
    :func:`~pv_hdrvol.render_tets`), or a ``vtkMultiBlockDataSet`` /
    ``vtkPartitionedDataSet(Collection)`` whose blocks gather onto one volume or merge into
    one mesh (:func:`pv_hdrvol.data.kinds.as_renderable`); lenses, labels and culling are
    for image data only. Distributed over processes, image data and meshes are rendered
    where they live; the other kinds are rendered whole by piece 0. Output: a
    ``width x height x 1`` ``vtkImageData`` with point arrays ``"rgba"`` (4 components,
    linear premultiplied RGBA, float32 or float64 as the precision) and ``"depth"``,
    VTK row order (row 0 at the bottom), as :meth:`HDRImage.to_vtk
    <pv_hdrvol.HDRImage.to_vtk>`; :meth:`HDRImage.from_pyvista
    <pv_hdrvol.HDRImage.from_pyvista>` turns it back into an image with row 0 at the
    top.

    Properties are set VTK-style (``SetStep(0.25)``, ``GetStep()``); every render
    option is one field of a single :class:`~pv_hdrvol.RenderOptions`, replaced (and
    so validated) by each setter, which then calls ``Modified()`` if the value
    changed.

    Say the accuracy instead of the knobs: ``SetTolerance(1e-3)`` (the RMS error of the
    image relative to its peak, ``RenderOptions.tolerance``) lets the renderer choose
    step, termination, table size and precision at each execution; ``SetTolerance(0)``
    switches it off. Step, termination and precision must then stay at their defaults
    (setting one is the ``ValueError`` of :class:`~pv_hdrvol.RenderOptions`). The
    choices and the estimated error reach the output with the rest of the image's
    metadata (the field-data string ``"hdrvol_metadata"``, JSON: its ``"tolerance"``
    entry; :meth:`HDRImage.from_pyvista <pv_hdrvol.HDRImage.from_pyvista>` reads it
    back) and :meth:`GetLastTolerance`.

    Pieces (MPI: ``pvbatch --mpi``, ``pvserver`` on several ranks): data with a transfer
    function (set, or a lookup table) is rendered where it lives. For an image each
    process asks its input for its own piece of the extent (VTK's extent translator,
    plus one ghost layer for shading and gradient opacity); a tetrahedral mesh's cells
    are moved to one box per process (VTK's processes only). Each renders what it owns,
    and piece 0 composites the partial images in depth order into the whole image
    (:mod:`pv_hdrvol.parallel.pieces`; equal to the serial render to rounding); the
    other pieces output empty images. Otherwise (the default transfer function -- it
    reads every value --, a cell array, a lens, labels, culling or a tolerance -- its
    knobs are chosen on a pilot of the whole image) piece 0 asks for all of the data
    (the whole extent of an image, piece 0 of 1 of a mesh) and renders it alone; no
    process renders its piece as if it were the whole.

    Multiresolution stores: the output of
    :class:`~pv_hdrvol.integrations.vtk_multiscale.MultiscaleReader` (one level of a
    ``*.ome.zarr`` store, naming the store in field data) renders as the whole store
    out of core (:func:`pv_hdrvol.open_multiscale`, one per path kept between
    executions; :meth:`SetScreenError`, :meth:`SetCacheBytes`; :meth:`SetOutOfCore`
    ``(False)`` renders the level in memory), with the transfer function and camera
    any input gets; view names frame the store's bounds.

    Scalars: ``SetScalars(name)``, or the standard
    ``SetInputArrayToProcess(0, 0, 0, association, name)``; by default the active
    scalars. Progress is reported through ``UpdateProgress`` (``ProgressEvent``).
    Setting ``AbortExecute`` during a render stops it and leaves the output empty;
    the flag stays set until you reset it (``SetAbortExecute(0)``).

    Errors (missing scalars, a bad camera, ...) are raised in ``RequestData``: VTK
    then reports a failure (``Update()`` returns ``False``, an ``ErrorEvent`` fires,
    the output is empty). VTK drops the Python traceback when any Python observer
    sees the error (PyVista installs one on import), so the exception is also
    written to the VTK output window (as VTK formats errors, ending in
    ``"HDRVolumeRenderer (0x...): <Type>: <message>"``) and kept for
    :meth:`GetLastError`.

    Examples
    --------
    >>> from vtkmodules.vtkImagingCore import vtkRTAnalyticSource
    >>> source = vtkRTAnalyticSource()
    >>> renderer = HDRVolumeRenderer()
    >>> renderer.SetInputConnection(source.GetOutputPort())
    >>> renderer.SetImageSize(32, 24)
    >>> renderer.SetStep(1.0)
    >>> renderer.Update()
    True
    >>> renderer.GetOutput().GetDimensions()
    (32, 24, 1)
    """

    REPORT_NAME = "HDRVolumeRenderer"  # also for subclasses (the ParaView filter)
    #: whether data is rendered where it lives under MPI (``_distribution``)
    DISTRIBUTED = True

    def __init__(self):
        # vtkDataObject, not vtkDataSet: VTK would run a data-set filter once per block of
        # a multiblock input, rendering each block as if it were the whole volume
        super().__init__(nInputPorts=1, inputType="vtkDataObject", nOutputPorts=1, outputType="vtkImageData")
        self._options = RenderOptions()
        self._size = (512, 512)
        self._scalars = None
        self._preference = "point"
        self._tf = None
        self._tf_keywords = dict.fromkeys(TF_KEYWORDS)
        self._vtk_tf = {"colors": None, "opacity": None}  # ParaView's colour map: [function, observer id]
        self._vtk_tf_made = None  # (key, the TransferFunction made from the colour map)
        self._plan = None  # (key, GridPlan or TetPlan): kept while data, tf and options are unchanged
        self._default_tf = None  # (data, keywords, the data's default transfer function)
        self._camera = None
        self._last_camera = None
        self._last_tolerance = None
        self._lens = None
        self._cull = None
        self._labels = None
        self._label_styles = None
        self._comm = None
        self._last_piece = None
        self._shared_tf = None  # (dict, TransferFunction): piece 0's, as last received
        self._moved = None  # a mesh piece: (key, summary, (box, the cells moved to it, points) or None)
        self._tet_piece = None  # a curvilinear piece: (key, its tetrahedra as a vtkUnstructuredGrid)
        # bricks survive re-executions for a new camera or TF; keyed by the arrays, not
        # by the input object, which ParaView hands over as a new shallow copy each time
        self._volumes = VolumeCache(dataset_mtime=False)
        # a level of a multiresolution store (MultiscaleReader): the store, out of core
        self._out_of_core = True
        self._screen_error = 1.0
        self._cache_bytes = None  # None: open_multiscale's default
        self._multiscale = {}  # store path -> MultiscaleVolume (its chunk cache stays between renders)
        self._multiscale_plan = None  # (key, MultiscalePlan)

    # -- render options: one RenderOptions, replaced by every setter ------------------
    def _set_options(self, **changes):
        new = dataclasses.replace(self._options, **changes)
        if new != self._options:
            self._options = new
            self.Modified()

    def SetOptions(self, options):
        """Replace all render options at once (a :class:`~pv_hdrvol.RenderOptions`)."""
        if not isinstance(options, RenderOptions):
            raise TypeError(f"options must be a RenderOptions; got {type(options).__name__}")
        if options != self._options:
            self._options = options
            self.Modified()

    def GetOptions(self):
        """The current :class:`~pv_hdrvol.RenderOptions` (immutable)."""
        return self._options

    SetStep, GetStep = _option_methods("step", "sample distance in voxels of the smallest spacing (> 0).")
    SetPrecision, GetPrecision = _option_methods(
        "precision", "compositing arithmetic, 'float32', 'float64', 'float16' or 'uint8'.")
    SetGlobalAlpha, GetGlobalAlpha = _option_methods(
        "global_alpha", "multiplier in (0, 1] of every transfer-function opacity.")
    SetOpacityUnitDistance, GetOpacityUnitDistance = _option_methods(
        "opacity_unit_distance", "world length over which a TF opacity is reached (None: smallest spacing).")
    SetTermination, GetTermination = _option_methods(
        "termination", "transmittance below which a ray stops, in [0, 1) (0: never).")
    SetDepthThreshold, GetDepthThreshold = _option_methods(
        "depth_threshold", "accumulated opacity at which depth is recorded, in (0, 1].")
    SetBlockSize, GetBlockSize = _option_methods(
        "block_size", "edge in cells of the empty-space-skipping blocks (a power of two).")
    SetBlending, GetBlending = _option_methods(
        "blending", "'composite', 'maximum', 'minimum', 'average' or 'additive' (PyVista's names).")
    SetGradientOpacity, GetGradientOpacity = _option_methods(
        "gradient_opacity", "None, or (low, high): extinction times a ramp of the gradient magnitude.")
    SetSkipEmpty, GetSkipEmpty, SkipEmptyOn, SkipEmptyOff = _bool_option_methods(
        "skip_empty", "skip blocks that map to zero opacity (same result, less time).")
    SetShade, GetShade, ShadeOn, ShadeOff = _bool_option_methods(
        "shade", "Blinn-Phong shading by the gradient (composite blending only).")
    SetAmbient, GetAmbient = _option_methods("ambient", "Blinn-Phong ambient weight (>= 0).")
    SetDiffuse, GetDiffuse = _option_methods("diffuse", "Blinn-Phong diffuse weight (>= 0).")
    SetSpecular, GetSpecular = _option_methods("specular", "Blinn-Phong specular weight (>= 0).")
    SetSpecularPower, GetSpecularPower = _option_methods("specular_power", "Blinn-Phong exponent (>= 1).")
    SetLights, GetLights = _option_methods(
        "lights", "None (a headlight), a Light, a direction towards the light, or a sequence of them.")
    SetShadeGradient, GetShadeGradient = _option_methods(
        "shade_gradient", "'sampled' (central differences at each sample) or 'interpolated'.")
    SetShadeThreshold, GetShadeThreshold = _option_methods(
        "shade_threshold", "fraction of the TF axis per voxel at which shading is at full strength (>= 0).")
    SetDevice, GetDevice = _option_methods(
        "device", "'cpu' (default) or 'cuda': image volumes on an NVIDIA GPU through numba-cuda (docs/gpu.md).")

    # -- clipping: vtkVolumeMapper's clipping-plane methods, and a crop box -------------
    def AddClippingPlane(self, plane):
        """Cut the volume with ``plane`` (a ``vtkPlane``, or ``(origin, normal)``), keeping
        the side its normal points to, as ``vtkVolumeMapper.AddClippingPlane``: a copy of
        its origin and normal now (call it again after changing the plane; the Qt
        viewer's and ParaView's widgets do)."""
        self._set_options(clip_planes=self._options.clip_planes + as_clip_planes(plane))

    def RemoveAllClippingPlanes(self):
        """Remove every clipping plane."""
        self._set_options(clip_planes=())

    def SetClippingPlanes(self, planes):
        """Replace the clipping planes: a ``vtkPlaneCollection``, ``vtkPlanes``, a
        sequence of planes, or ``None`` (``RenderOptions.clip_planes``)."""
        self._set_options(clip_planes=planes)

    def GetClippingPlanes(self):
        """The clipping planes, as a new ``vtkPlaneCollection`` of new ``vtkPlane``\\ s."""
        from vtkmodules.vtkCommonDataModel import vtkPlane, vtkPlaneCollection

        out = vtkPlaneCollection()
        for p in self._options.clip_planes:
            plane = vtkPlane()
            plane.SetOrigin(*p.origin)
            plane.SetNormal(*p.normal)
            out.AddItem(plane)
        return out

    def SetCropBox(self, *bounds):
        """Keep only this world box: ``(xmin, xmax, ymin, ymax, zmin, zmax)`` as 6 numbers
        or one sequence (VTK's bounds order, as ``SetCroppingRegionPlanes``); ``None``:
        no crop (``RenderOptions.crop_box``)."""
        value = bounds[0] if len(bounds) == 1 else bounds
        self._set_options(crop_box=value)

    def GetCropBox(self):
        """``RenderOptions.crop_box``: the 6 bounds, or ``None``."""
        return self._options.crop_box

    def SetTolerance(self, tolerance):
        """Set ``RenderOptions.tolerance``: the RMS error of the linear, premultiplied RGB
        image against the converged render, relative to its peak, in (0, 0.5]; the
        renderer then chooses step, termination, table size and precision. ``0`` or
        ``None``: off (the knobs as set). Step, termination and precision must be at
        their defaults while it is on. Validated by :class:`~pv_hdrvol.RenderOptions`;
        calls ``Modified()`` when it changes."""
        # 0 is "off" as in a VTK (ParaView) number property; RenderOptions says None
        if isinstance(tolerance, numbers.Real) and not isinstance(tolerance, bool) and tolerance == 0:
            tolerance = None
        self._set_options(tolerance=tolerance)

    def GetTolerance(self):
        """``RenderOptions.tolerance`` as a VTK number: ``0.0`` when off (the field is
        then ``None``: ``GetOptions().tolerance``)."""
        return 0.0 if self._options.tolerance is None else self._options.tolerance

    def GetLastTolerance(self):
        """What the last execution chose for its tolerance, else ``None``: the image's
        ``metadata["tolerance"]`` (``step`` or, for a mesh, ``tau_max``,
        ``termination``, ``table_size``, ``precision``, ``estimated_error``, ...; see
        :mod:`pv_hdrvol.raycast.tolerance`), a copy."""
        return None if self._last_tolerance is None else dict(self._last_tolerance)

    # -- other properties --------------------------------------------------------------
    def SetImageSize(self, width, height=None):
        """Output size: ``SetImageSize(w, h)``, ``SetImageSize((w, h))`` or ``SetImageSize(n)`` (square)."""
        size = as_size(width if height is None else (width, height))
        if size != self._size:
            self._size = size
            self.Modified()

    def GetImageSize(self):
        """``(width, height)`` in pixels."""
        return self._size

    def SetScalars(self, name):
        """Name of the input array to render; ``None``: the active scalars (or the array to process)."""
        if name is not None and not isinstance(name, str):
            raise TypeError(f"scalars must be an array name (str) or None; got {name!r}")
        if name != self._scalars:
            self._scalars = name
            self.Modified()

    def GetScalars(self):
        """The array name set with :meth:`SetScalars` (``None``: active scalars)."""
        return self._scalars

    def SetPreference(self, preference):
        """``"point"`` or ``"cell"``: which array wins when both have the scalars' name."""
        as_choice("preference", preference, ("point", "cell"))
        if preference != self._preference:
            self._preference = preference
            self.Modified()

    def GetPreference(self):
        """``"point"`` or ``"cell"``."""
        return self._preference

    def SetTransferFunction(self, tf):
        """A :class:`~pv_hdrvol.TransferFunction`, or ``None`` for the data-driven default."""
        if tf is not None and not isinstance(tf, TransferFunction):
            raise TypeError(f"the transfer function must be a pv_hdrvol TransferFunction or None; "
                            f"got {type(tf).__name__}")
        if tf is not self._tf:
            self._tf = tf
            self.Modified()

    def GetTransferFunction(self):
        """The :class:`~pv_hdrvol.TransferFunction` set last, or ``None``."""
        return self._tf

    # -- VTK's (ParaView's) colour map as the transfer function -------------------------
    def _set_vtk_function(self, slot, function):
        old = self._vtk_tf[slot]
        if (old[0] if old else None) is function:
            return
        if old is not None:
            old[0].RemoveObserver(old[1])
        # editing the colour map in place (ParaView's Color Map Editor) re-executes; the
        # observer holds this algorithm weakly, or a long-lived colour map would keep it
        # (and its plan's arrays) alive after the pipeline drops it
        this = weakref.ref(self)

        def modified(*_):
            algorithm = this()
            if algorithm is not None:
                algorithm.Modified()

        self._vtk_tf[slot] = None if function is None else [function, function.AddObserver("ModifiedEvent", modified)]
        self.Modified()

    def SetLookupTable(self, colors):
        """A ``vtkColorTransferFunction`` (ParaView's lookup table for the array) as the
        transfer function's colours, its range and its log scale; ``None``: not used.
        Editing it re-executes. See
        :func:`~pv_hdrvol.integrations.vtk_transfer.transfer_function_from_vtk`."""
        from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

        if colors is not None and not isinstance(colors, vtkColorTransferFunction):
            raise TypeError(f"the lookup table must be a vtkColorTransferFunction or None; "
                            f"got {type(colors).__name__}")
        self._set_vtk_function("colors", colors)

    def GetLookupTable(self):
        """The ``vtkColorTransferFunction`` set with :meth:`SetLookupTable`, or ``None``."""
        return self._vtk_tf["colors"][0] if self._vtk_tf["colors"] else None

    def SetScalarOpacityFunction(self, opacity):
        """A ``vtkPiecewiseFunction`` (ParaView's opacity function for the array) as the
        opacities of :meth:`SetLookupTable`'s transfer function; ``None``: opacity 1."""
        from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction

        if opacity is not None and not isinstance(opacity, vtkPiecewiseFunction):
            raise TypeError(f"the scalar opacity function must be a vtkPiecewiseFunction or None; "
                            f"got {type(opacity).__name__}")
        self._set_vtk_function("opacity", opacity)

    def GetScalarOpacityFunction(self):
        """The ``vtkPiecewiseFunction`` set with :meth:`SetScalarOpacityFunction`, or ``None``."""
        return self._vtk_tf["opacity"][0] if self._vtk_tf["opacity"] else None

    def _transfer_function(self):
        """The transfer function set, else the lookup table's (kept while the table and
        the opacity function are unchanged, so that its tables are built once), else
        ``None`` (the default)."""
        colors, opacity = self.GetLookupTable(), self.GetScalarOpacityFunction()
        if self._tf is not None or colors is None:
            if self._tf is None and opacity is not None:
                raise ValueError("a scalar opacity function needs a lookup table (SetLookupTable) for the colours")
            return self._tf
        given = [name + "=" for name, value in self._tf_keywords.items() if value is not None]
        if given:
            raise TypeError(f"pass either a lookup table or {', '.join(given)}, not both: the lookup table sets "
                            "colour, opacity, range and axis already")
        key = (colors, colors.GetMTime(), opacity, None if opacity is None else opacity.GetMTime())
        if self._vtk_tf_made is None or key != self._vtk_tf_made[0]:  # VTK objects compare by identity
            from .vtk_transfer import transfer_function_from_vtk

            self._vtk_tf_made = (key, transfer_function_from_vtk(colors, opacity))
        return self._vtk_tf_made[1]

    # -- the default transfer function's keywords: hv.render's cmap=, clim=, opacity=, scale=
    def _set_tf_keyword(self, name, value):
        # validated now, not at the next Update(); compared by meaning (an opacity may be an array)
        meaning = None if value is None else default_transfer_function_keyword(name, value)
        old = self._tf_keywords[name]
        if meaning == (None if old is None else default_transfer_function_keyword(name, old)):
            return
        self._tf_keywords[name] = value
        self.Modified()

    def SetCmap(self, cmap):
        """``cmap=`` of ``hv.render``: a matplotlib colormap name for the default
        transfer function (``None``: its own). Not with :meth:`SetTransferFunction`."""
        self._set_tf_keyword("cmap", cmap)

    def GetCmap(self):
        """The colormap set with :meth:`SetCmap`, or ``None``."""
        return self._tf_keywords["cmap"]

    def SetClim(self, low, high=None):
        """``clim=`` of ``hv.render``: ``SetClim(low, high)``, ``SetClim((low, high))``
        (either end ``None``: the default's), ``SetClim(c)`` for ``(-c, c)``, or
        ``SetClim(None)``: the range the default transfer function's colours and
        opacity span."""
        self._set_tf_keyword("clim", low if high is None else (low, high))

    def GetClim(self):
        """The range set with :meth:`SetClim`, or ``None``."""
        return self._tf_keywords["clim"]

    def SetOpacity(self, opacity):
        """``opacity=`` of ``hv.render``: a PyVista opacity curve name, one number, or
        opacities spread over the range (``None``: the default's)."""
        self._set_tf_keyword("opacity", opacity)

    def GetOpacity(self):
        """The opacity set with :meth:`SetOpacity`, or ``None``."""
        return self._tf_keywords["opacity"]

    def SetScale(self, scale):
        """``scale=`` of ``hv.render``: the default transfer function's axis,
        ``"linear"``, ``"log"`` or ``"symlog"`` (``None``: chosen from the data)."""
        self._set_tf_keyword("scale", scale)

    def GetScale(self):
        """The axis set with :meth:`SetScale`, or ``None``."""
        return self._tf_keywords["scale"]

    def SetCamera(self, camera):
        """The view: a :class:`~pv_hdrvol.Camera`, a ``vtkCamera`` or a view name.

        A ``vtkCamera`` (or ``pyvista.Plotter``) is copied now: later changes to it do
        not re-execute the pipeline; set it again. A view name (``"iso"``, ``"xy"``,
        ...) or ``None`` (``"iso"``) frames the input's bounds at each execution.

        A ``dict`` of :class:`~pv_hdrvol.Camera`'s fields (``position``,
        ``focal_point``, ``view_up``, ``view_angle``, ``parallel_projection``,
        ``parallel_scale``) is made into a camera at each execution, so that fields set
        one at a time (ParaView's camera properties) are checked together then.
        """
        if isinstance(camera, dict):
            fields = {f.name for f in dataclasses.fields(Camera)}
            unknown = sorted(set(camera) - fields)
            if unknown:
                raise ValueError(f"camera fields must be among {sorted(fields)}; got {unknown}")
            camera = dict(camera)
        elif isinstance(camera, str):
            Camera.fit((0, 1, 0, 1, 0, 1), camera)  # validates the view name now
        elif isinstance(camera, Rays):
            raise TypeError("SetCamera takes a Camera, a vtkCamera or a view name, not Rays: the image size "
                            "comes from SetImageSize")
        elif camera is not None and not isinstance(camera, Camera):
            camera = as_camera(camera, None)
        if camera != self._camera:
            self._camera = camera
            self.Modified()

    def GetCamera(self):
        """The :class:`~pv_hdrvol.Camera`, view name, fields (a copy) or ``None`` set last."""
        return dict(self._camera) if isinstance(self._camera, dict) else self._camera

    def SetLens(self, lens):
        """A lens (:class:`~pv_hdrvol.Magnifier`, ...) applied to the camera, or ``None``."""
        if lens is not None and not callable(getattr(lens, "rays", None)):
            raise TypeError(f"the lens must have a rays(camera, size) method, or be None; got {type(lens).__name__}")
        if lens is not self._lens:
            self._lens = lens
            self.Modified()

    def GetLastCamera(self):
        """The :class:`~pv_hdrvol.Camera` of the last render (a view name or fields
        resolved), or ``None`` before the first."""
        return self._last_camera

    def GetLens(self):
        """The lens set last, or ``None``."""
        return self._lens

    def SetCommunicator(self, comm):
        """The processes that render the pieces of distributed data together: ``None``
        (default: those of VTK's global ``vtkMultiProcessController``, ParaView's MPI
        ranks) or an mpi4py-style communicator (``rank``, ``size``, ``gather``,
        ``allgather``, ``alltoall``, ``bcast``; e.g. ``MPI.COMM_WORLD``) whose
        ``rank`` is the piece this algorithm is asked for and ``size`` the number of
        pieces (a mesh is moved between VTK's processes only: with another communicator
        piece 0 renders all of it)."""
        if comm is not None and not all(hasattr(comm, name) for name in ("rank", "size", "gather", "allgather",
                                                                          "alltoall", "bcast")):
            raise TypeError(f"the communicator must have rank, size, gather, allgather, alltoall and bcast (as "
                            f"mpi4py's), or be None; got {type(comm).__name__}")
        if comm is not self._comm:
            self._comm = comm
            self.Modified()

    def GetCommunicator(self):
        """The communicator set with :meth:`SetCommunicator`, or ``None``."""
        return self._comm

    def SetCull(self, cull):
        """Visibility culling of image data: a :class:`~pv_hdrvol.culling.pof.PlenopticOpacity`
        of the input (or a ``Culling`` with its threshold), or ``None``. The transfer
        function must then be a family of its bases (``SetTransferFunction(
        TransferFunction.family(pof.bases, k))``) and the camera orthographic; the
        output's metadata hold the culling's counts (docs/culling.md)."""
        if cull is not None and not callable(getattr(cull, "mask_for", None)):
            raise TypeError(f"cull must be a PlenopticOpacity or Culling, or None; got {type(cull).__name__}")
        if cull is not self._cull:
            self._cull = cull
            self.Modified()

    def GetCull(self):
        """The culling set last, or ``None``."""
        return self._cull

    def SetLabels(self, name, styles=None):
        """Two-level rendering: the input's array ``name`` (same association as the
        scalars) labels the voxels and ``styles`` (``{label: tf | blending | (tf,
        blending)}``) styles them; ``None`` switches it off."""
        if name is not None and not isinstance(name, str):
            raise TypeError(f"labels must be the name of an input array, or None; got {type(name).__name__}")
        if styles is not None and not isinstance(styles, dict):
            raise TypeError(f"label styles must be a dict {{label: style}}; got {type(styles).__name__}")
        if (name, styles) != (self._labels, self._label_styles):
            self._labels, self._label_styles = name, styles
            self.Modified()

    def GetLabels(self):
        """``(array name, styles)`` set last."""
        return self._labels, self._label_styles

    # -- multiresolution stores: a MultiscaleReader's level renders its store out of core
    def SetOutOfCore(self, on):
        """Whether a level of a multiresolution store (the output of
        :class:`~pv_hdrvol.integrations.vtk_multiscale.MultiscaleReader`, which names its
        store in field data) renders the whole store out of core (default ``True``:
        :func:`pv_hdrvol.open_multiscale`, finer levels where the camera needs them,
        chunks read on demand) rather than the level in memory."""
        on = bool(on)
        if on != self._out_of_core:
            self._out_of_core = on
            self.Modified()

    def GetOutOfCore(self):
        return self._out_of_core

    def SetScreenError(self, pixels):
        """Out of core: the largest projected voxel, in pixels, a block may show
        (default 1; :meth:`MultiscalePlan.execute <pv_hdrvol.outofcore.render.MultiscalePlan.execute>`)."""
        from .._validate import as_real

        pixels = as_real("screen_error", pixels, low=0.0, low_open=True)
        if pixels != self._screen_error:
            self._screen_error = pixels
            self.Modified()

    def GetScreenError(self):
        return self._screen_error

    def SetCacheBytes(self, n):
        """Out of core: the most bytes of chunks kept in memory per store (``None``: the
        default of :func:`pv_hdrvol.open_multiscale`, 2 GiB). A new size reopens the stores."""
        from .._validate import as_int

        n = None if n is None else as_int("cache_bytes", n, low=1)
        if n != self._cache_bytes:
            self._cache_bytes = n
            self._close_multiscale()
            self.Modified()

    def GetCacheBytes(self):
        return self._cache_bytes

    def _close_multiscale(self):
        self._multiscale_plan = None
        for volume in self._multiscale.values():
            volume.close()
        self._multiscale.clear()

    def _store_input(self, inp, scalars, preference):
        """``(MultiscaleVolume, level)`` when ``inp`` is a MultiscaleReader's level that
        is still that level (its array chosen, its geometry), else ``None``: data changed
        on its way (another array, a cut) renders in memory as any other."""
        if not self._out_of_core or inp is None or inp.GetClassName() not in IMAGE_CLASSES:
            return None
        from .vtk_multiscale import store_of

        found = store_of(inp)
        if found is None:
            return None
        path, level, name = found
        active = inp.GetPointData().GetScalars()
        chosen = scalars if scalars is not None else (None if active is None else active.GetName())
        if chosen != name or (scalars is not None and preference == "cell"):
            return None
        volume = self._multiscale.get(path)
        if volume is None:
            from ..outofcore.render import open_multiscale

            kwargs = {} if self._cache_bytes is None else {"cache_bytes": self._cache_bytes}
            volume = self._multiscale[path] = open_multiscale(path, **kwargs)
        store = volume.store
        if not 0 <= level < store.n_levels:
            return None
        import numpy as np

        spacing, origin = store.level_geometry(level)
        if tuple(inp.GetDimensions()) != tuple(store.levels[level].dims) \
                or not np.allclose(inp.GetSpacing(), spacing, rtol=1e-9, atol=0) \
                or not np.allclose(inp.GetOrigin(), origin, rtol=1e-9, atol=1e-12 * float(np.abs(spacing).max())):
            return None
        return volume, level

    def _execute_multiscale(self, volume, out):
        """Render the store out of core (:class:`~pv_hdrvol.outofcore.render.MultiscalePlan`),
        with the transfer function and options the in-memory render would use."""
        if self._labels is not None or self._cull is not None:
            raise ValueError("SetLabels and SetCull are not supported for a multiresolution store rendered out "
                             "of core; SetOutOfCore(False) renders the level in memory")
        from ..outofcore.render import MultiscalePlan

        tf = self._transfer_function()
        keywords = tuple((name, None if value is None else default_transfer_function_keyword(name, value))
                         for name, value in self._tf_keywords.items())
        key = (volume, tf, self._options, keywords)
        old = None if self._multiscale_plan is None else self._multiscale_plan[0]
        # the volume and the transfer function by identity, the rest by value
        if old is None or old[0] is not volume or old[1] is not tf or old[2:] != key[2:]:
            self._multiscale_plan = None
            given = {} if tf is not None else {k: v for k, v in self._tf_keywords.items()}
            self._multiscale_plan = (key, MultiscalePlan(volume, tf, self._options, **given))
        plan = self._multiscale_plan[1]
        camera = fit_camera(volume, Camera(**self._camera) if isinstance(self._camera, dict) else self._camera)
        self._last_camera = camera
        self._last_tolerance = None

        def progress(fraction):
            self.UpdateProgress(fraction)
            return not self._should_abort()

        try:
            image = plan.execute(camera, self._size, screen_error=self._screen_error, wait=True, lens=self._lens,
                                 progress=progress, progress_bar=False)
        except RuntimeError:
            if self._should_abort():
                out.Initialize()
                return 1
            raise
        out.ShallowCopy(image.to_vtk())
        return 1

    def GetOutput(self, port=0):
        """The output ``vtkImageData`` (``GetOutputDataObject(port)``, as image algorithms have)."""
        return self.GetOutputDataObject(port)

    # -- pipeline ---------------------------------------------------------------------
    def RequestInformation(self, request, inInfo, outInfo):
        w, h = self._size
        info = outInfo.GetInformationObject(0)
        info.Set(_SDDP.WHOLE_EXTENT(), 0, w - 1, 0, h - 1, 0, 0)
        info.Set(vtkDataObject.SPACING(), 1.0, 1.0, 1.0)
        info.Set(vtkDataObject.ORIGIN(), 0.0, 0.0, 0.0)
        return 1

    def RequestUpdateExtent(self, request, inInfo, outInfo):
        # Distributed (_distribution): each process asks for its piece of the extent.
        # Otherwise a ray may cross any part of the volume: piece 0 asks for all of it
        # (the whole extent of an image; piece 0 of 1 of a mesh) and renders alone, the
        # other pieces leave the request as it is and output an empty image.
        info = inInfo[0].GetInformationObject(0)
        plan = self._distribution(inInfo, outInfo)
        if plan is not None and plan.whole is None:
            if info.Has(_SDDP.WHOLE_EXTENT()):  # a curvilinear grid: its piece of the extent, as an image's
                whole = tuple(info.Get(_SDDP.WHOLE_EXTENT()))
                info.Set(_SDDP.UPDATE_EXTENT(), _piece_extent(whole, _output_piece(outInfo), plan.comm.size, 0), 6)
                info.Set(_SDDP.UPDATE_PIECE_NUMBER(), 0)
                info.Set(_SDDP.UPDATE_NUMBER_OF_PIECES(), 1)
                info.Set(_SDDP.UPDATE_NUMBER_OF_GHOST_LEVELS(), 0)
            return 1  # a mesh: each process takes the piece its reader gives
        if plan is not None:
            # the extent itself, ghost points included, as "piece 0 of 1": XML image
            # readers cut their own pieces from the piece number and a ghost level, with
            # another split than the extent translator's (ParaView 5.11, 3 processes)
            info.Set(_SDDP.UPDATE_EXTENT(), plan.extent, 6)
            info.Set(_SDDP.UPDATE_PIECE_NUMBER(), 0)
            info.Set(_SDDP.UPDATE_NUMBER_OF_PIECES(), 1)
            info.Set(_SDDP.UPDATE_NUMBER_OF_GHOST_LEVELS(), 0)
            return 1
        if _output_piece(outInfo) != 0:
            return 1
        request_whole_extent(info)
        info.Set(_SDDP.UPDATE_PIECE_NUMBER(), 0)
        info.Set(_SDDP.UPDATE_NUMBER_OF_PIECES(), 1)
        return 1

    def _scalars_to_render(self):
        if self._scalars is not None:
            return self._scalars, self._preference
        info = self.GetInputArrayInformation(0)
        if info.Has(vtkDataObject.FIELD_NAME()):
            assoc = info.Get(vtkDataObject.FIELD_ASSOCIATION()) if info.Has(vtkDataObject.FIELD_ASSOCIATION()) else 0
            if assoc not in (vtkDataObject.FIELD_ASSOCIATION_POINTS, vtkDataObject.FIELD_ASSOCIATION_CELLS):
                raise ValueError(f"the array to process must be a point or cell array; got association {assoc}")
            return info.Get(vtkDataObject.FIELD_NAME()), (
                "cell" if assoc == vtkDataObject.FIELD_ASSOCIATION_CELLS else "point")
        return None, self._preference

    def _should_abort(self):
        check = getattr(self, "CheckAbort", None)  # VTK >= 9.4 also sees upstream aborts
        return bool(check()) if check is not None else bool(self.GetAbortExecute())

    def _distribution(self, inInfo, outInfo):
        """The :class:`_Distribution` of this execution when the image volume is
        rendered where it lives, else ``None`` (piece 0 renders all of it). Decided from
        the pipeline's information and the filter's settings only, never from a piece's
        data, so that every process decides alike (they then exchange images)."""
        info = outInfo.GetInformationObject(0)
        n = info.Get(_SDDP.UPDATE_NUMBER_OF_PIECES()) if info.Has(_SDDP.UPDATE_NUMBER_OF_PIECES()) else 1
        in_info = inInfo[0].GetInformationObject(0)
        data = in_info.Get(vtkDataObject.DATA_OBJECT()) if in_info.Has(vtkDataObject.DATA_OBJECT()) else None
        # image data and rectilinear grids: each process renders its piece of the extent
        structured = in_info.Has(_SDDP.WHOLE_EXTENT()) and (
            data is None or data.GetClassName() in IMAGE_CLASSES + ("vtkRectilinearGrid",))
        # a curvilinear grid's pieces are rendered as the tetrahedra a whole grid's render
        # makes of them, through the mesh path (_execute_mesh_piece)
        mesh = not structured and data is not None and data.GetClassName() in ("vtkUnstructuredGrid",
                                                                                "vtkStructuredGrid")
        if self._out_of_core and data is not None \
                and data.GetFieldData().GetAbstractArray("pv_hdrvol_store") is not None:
            return None  # a store's level: piece 0 renders the store out of core
        if n < 2 or not self.DISTRIBUTED or not (structured or mesh) or self._lens is not None \
                or self._labels is not None or self._cull is not None or self._options.tolerance is not None:
            return None  # a tolerance's knobs are chosen on a pilot of the whole image
        try:
            if self._scalars_to_render()[1] == "cell" or self._transfer_function() is None:
                return None  # a cell array; the default function reads every value of the whole volume
        except (TypeError, ValueError):
            return None  # piece 0 reports it
        comm = self._comm if self._comm is not None else ControllerComm.world()
        piece = _output_piece(outInfo)
        if comm is None or comm.size != n or comm.rank != piece:
            return None
        if mesh:  # the pieces the reader gives; cut into boxes and exchanged in _execute_mesh_piece
            if not isinstance(comm, ControllerComm):
                return None  # vtkRedistributeDataSetFilter needs VTK's processes
            return _Distribution(comm, None, None, None, 0)
        whole = tuple(in_info.Get(_SDDP.WHOLE_EXTENT()))
        ghosts = 1 if (self._options.shade or self._options.gradient_opacity is not None) else 0
        return _Distribution(comm, whole, _piece_extent(whole, piece, n, 0), _piece_extent(whole, piece, n, ghosts),
                             ghosts)

    def _execute(self, inInfo, outInfo):
        inp = vtkDataObject.GetData(inInfo[0])
        out = vtkImageData.GetData(outInfo)
        distribution = self._distribution(inInfo, outInfo)
        if distribution is not None and distribution.whole is None:
            return self._execute_mesh_piece(inp, out, distribution)
        if distribution is not None:
            return self._execute_piece(inp, out, distribution)
        if _output_piece(outInfo) != 0:  # piece 0 renders the whole image (RequestUpdateExtent)
            out.Initialize()
            return 1
        kind = inp.GetClassName() if inp is not None else None
        try:
            what = None if inp is None else data_kind(inp)
        except TypeError:
            what = None
        if what is None or inp.GetNumberOfPoints() == 0:
            raise ValueError(f"HDRVolumeRenderer needs a non-empty volume on input port 0 ({SUPPORTED}); got "
                             f"{'nothing' if inp is None else kind}")
        if kind not in IMAGE_CLASSES and (self._lens is not None or self._labels is not None
                                          or self._cull is not None):
            raise ValueError(f"SetLens, SetLabels and SetCull apply to image data only, not to a {kind}")
        scalars, preference = self._scalars_to_render()
        store = self._store_input(inp, scalars, preference)
        if store is not None:
            return self._execute_multiscale(store[0], out)
        # a view name frames the input's bounds (its rendered blocks'), as hv.render frames it
        camera = fit_camera(inp, Camera(**self._camera) if isinstance(self._camera, dict) else self._camera,
                            scalars=scalars, preference=preference)
        self._last_camera = camera
        tf = self._transfer_function()
        self._last_tolerance = None

        mesh = what == MESH or (what == BLOCKS and _blocks_are_meshes(inp))
        first = _first_use(mesh, _compiled_precision(self._options))
        if first:  # numba compiles (or loads from its cache) the kernels now: say so
            self.SetProgressText("compiling the ray caster (first render)")
            _display_text(f"pv_hdrvol: first {first} render in this process: compiling the ray caster, or loading "
                          f"it from numba's cache ({_numba_cache_dir()}); the first time this takes about a minute")
        started = time.perf_counter()

        def progress(fraction):
            if first and fraction > 0:
                self.SetProgressText("rendering")
            self.UpdateProgress(fraction)
            return not self._should_abort()

        try:
            # a plan (validated options, tables, skip structures) is made once and
            # executed for each camera and size: rotating the view re-renders only
            plan = self._plan_for(inp, kind, scalars, preference, tf)
            if mesh:
                image = plan.execute(camera, self._size, progress=progress, progress_bar=False)
            else:
                # progress goes to VTK's ProgressEvent (PyVista's and ParaView's bars), not tqdm
                image = plan.execute(camera, self._size, lens=self._lens, cull=self._cull, progress=progress,
                                     progress_bar=False)
        except RuntimeError:
            if self._should_abort():
                out.Initialize()  # an aborted render leaves no output
                return 1
            raise
        finally:
            if first:
                _display_text(f"pv_hdrvol: first {first} render took {time.perf_counter() - started:.1f} s")
        self._last_tolerance = image.metadata.get("tolerance")
        out.ShallowCopy(image.to_vtk())
        return 1

    def _execute_piece(self, inp, out, distribution):
        """Render this process's piece of the image and composite on piece 0
        (:func:`pv_hdrvol.parallel.pieces.gather_pieces`: if any process fails, all
        raise, the others naming it)."""
        from ..parallel.pieces import gather_pieces
        from ..raycast.grid import VolumePiece

        import numpy as np

        image = piece = spacing = rays = error = None
        owned = distribution.owned
        tf = self._shared_transfer_function(distribution.comm)
        _share_cores(distribution.comm)
        whole_axes = _whole_axes(inp, distribution)  # collective; None for image data
        try:
            if owned[1] <= owned[0] or owned[3] <= owned[2] or owned[5] <= owned[4]:
                raise ValueError(f"the image of extent {distribution.whole} has too few cells for "
                                 f"{distribution.comm.size} processes: process {distribution.comm.rank} owns "
                                 f"{owned}; render it on fewer processes")
            if isinstance(whole_axes, Exception):
                raise whole_axes
            kind = inp.GetClassName() if inp is not None else None
            if kind not in ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid", "vtkRectilinearGrid"):
                raise ValueError(f"HDRVolumeRenderer renders a distributed vtkImageData or vtkRectilinearGrid; "
                                 f"process {distribution.comm.rank} got {'nothing' if inp is None else kind}")
            scalars, preference = self._scalars_to_render()
            data = self._volumes.get(inp, scalars, preference)
            if data.values.shape[::-1] != tuple(e[1] - e[0] + 1 for e in np.reshape(inp.GetExtent(), (3, 2))):
                raise ValueError(f"a distributed volume is rendered from a point array; "
                                 f"{data.name or 'the active scalars'!r} is a cell array (apply Cell Data to Point "
                                 f"Data, or render it on one process)")
            spacing = data.spacing
            options = None
            if whole_axes is not None:  # a rectilinear piece samples the whole grid's lattice
                start = np.asarray(inp.GetExtent()[0::2]) - np.asarray(distribution.whole[0::2])
                local = tuple(a[o:o + n] for a, o, n in zip(whole_axes, start, data.values.shape[::-1]))
                if data.axes is None:  # even within the piece, uneven in the whole
                    data = dataclasses.replace(data, axes=local, cache={})
                piece = VolumePiece.from_rectilinear(whole_axes, start, np.asarray(owned[0::2]) -
                                                     np.asarray(distribution.whole[0::2]),
                                                     np.asarray(owned[1::2]) - np.asarray(distribution.whole[0::2]))
                options = piece.options_for(self._options, data)
            else:
                piece = VolumePiece.from_extents(inp.GetOrigin(), inp.GetSpacing(), distribution.whole,
                                                 inp.GetExtent(), owned)
            bounds = piece.bounds(spacing)
            camera = as_camera(Camera(**self._camera) if isinstance(self._camera, dict) else self._camera, bounds)
            self._last_camera = camera
            rays = camera.rays(self._size)
            plan = self._plan_for(inp, "vtkImageData", scalars, preference, tf, data=data if options else None,
                                  options=options)

            def progress(fraction):
                self.UpdateProgress(fraction)
                return not self._should_abort()

            first = _first_use(False, _compiled_precision(self._options))
            if first:
                _display_text(f"pv_hdrvol: first {first} render in this process (its piece): compiling the ray "
                              f"caster, or loading it from numba's cache ({_numba_cache_dir()})")
            image = plan.execute(camera, self._size, piece=piece, progress=progress, progress_bar=False)
        except Exception as e:  # every process learns of it in gather_pieces; none waits forever
            error = e
        self._last_piece = inp
        whole = gather_pieces(image, piece, spacing, rays, comm=distribution.comm, root=0, error=error)
        if whole is None:
            out.Initialize()
        else:
            out.ShallowCopy(whole.to_vtk())
        return 1

    def _shared_transfer_function(self, comm):
        """Piece 0's transfer function, on every process (collective). In a symmetric
        batch run each process has its own colour map, which ParaView rescales to the
        data it sees: a process that holds no data kept [0, 1] and rendered its piece
        with it (seen with 2 ranks). Piece 0's is the one a script or the GUI shows. The
        same function received again is the same object, so plans are kept."""
        local = None
        if comm.rank == 0:
            try:
                local = self._transfer_function()
            except (TypeError, ValueError) as e:  # every process raises it
                local = e
        received = comm.bcast(None if local is None else (local if isinstance(local, Exception)
                                                          else local.to_dict()), root=0)
        if isinstance(received, Exception):
            raise received
        if self._shared_tf is None or self._shared_tf[0] != received:
            self._shared_tf = (received, TransferFunction.from_dict(received))
        return self._shared_tf[1]

    def _execute_mesh_piece(self, inp, out, distribution):
        """A tetrahedral mesh spread over processes: cut its bounds into one box per
        process (k-d, at quantiles of the cell centres: about equal cells each), move to
        each process every cell that meets its box (``vtkRedistributeDataSetFilter``
        with these cuts; cells on a cut go to both sides), render the span of each ray
        in the box (``TetPlan.execute(piece=...)``), and composite on piece 0."""
        import numpy as np

        from ..parallel.pieces import allgather_or_raise, gather_boxes, split_bounds
        from ..raycast.tets import MeshPiece, TetPlan

        comm = distribution.comm
        scalars, preference = self._scalars_to_render()
        summary = error = None
        try:
            if inp is not None and inp.GetClassName() == "vtkStructuredGrid":
                key = (_content_key(inp), tuple(inp.GetExtent()))
                if self._tet_piece is None or self._tet_piece[0] != key:
                    self._tet_piece = (key, _tet_grid_of_structured(inp))
                inp = self._tet_piece[1]
            kind = inp.GetClassName() if inp is not None else None
            if kind != "vtkUnstructuredGrid":
                raise ValueError(f"HDRVolumeRenderer renders a distributed vtkUnstructuredGrid; process {comm.rank} "
                                 f"got {'nothing' if inp is None else kind}")
            if scalars is None and inp.GetNumberOfCells():
                active = inp.GetPointData().GetScalars()
                scalars = active.GetName() if active is not None else None
            key = (scalars, _content_key(inp))
            if self._moved is None or self._moved[0] != key:
                self._moved = (key, _mesh_summary(inp, scalars), None)
            summary = dict(self._moved[1], changed=self._moved[2] is None)
        except Exception as e:  # said to every process before the collective redistribution
            error = e
        everyone = allgather_or_raise(comm, summary, error)
        held = [s for s in everyone if s["cells"]]
        if not held:
            raise ValueError("HDRVolumeRenderer needs a non-empty vtkUnstructuredGrid: no process holds a cell")
        names = [s["scalars"] for s in held if s["scalars"]]
        scalars = scalars if scalars is not None else (names[0] if names else None)
        lo = np.min([s["bounds"][0::2] for s in held], axis=0)
        hi = np.max([s["bounds"][1::2] for s in held], axis=0)
        bounds = tuple(float(v) for pair in zip(lo, hi) for v in pair)
        # each process's sample stands for its cells: a k-d split of equal cells
        boxes = split_bounds(bounds, comm.size, np.concatenate([s["centres"] for s in held]),
                             np.concatenate([np.full(len(s["centres"]), s["cells"] / len(s["centres"])) for s in held]))
        tf = self._shared_transfer_function(comm)
        _share_cores(comm)
        mine = MeshPiece(tuple(boxes[comm.rank][0]), tuple(boxes[comm.rank][1]), tuple(lo), tuple(hi))
        if any(s["changed"] for s in everyone) or self._moved[2] is None or self._moved[2][0] != mine:
            # no process's piece changed (a new camera, size or colour map): keep the
            # moved cells, whose TetMesh is then kept too
            part = _redistribute(inp, boxes, comm)
            # the whole mesh's distinct points, each counted by the one box that owns it
            points = sum(comm.allgather(_points_owned(part, mine)))
            self._moved = (self._moved[0], self._moved[1], (mine, part, points))
        _, part, points = self._moved[2]

        image = piece = rays = error = None
        try:
            piece = mine
            camera = as_camera(Camera(**self._camera) if isinstance(self._camera, dict) else self._camera,
                               piece.bounds())
            self._last_camera = camera
            rays = camera.rays(self._size)
            options = self._options
            if options.opacity_unit_distance is None:
                # the whole mesh's (TetMesh.default_unit_distance), not this piece's
                diagonal = float(np.linalg.norm(hi - lo))
                options = dataclasses.replace(options, opacity_unit_distance=diagonal / points ** (1.0 / 3.0)
                                              if diagonal > 0 else 1.0)
            if part.GetNumberOfCells():
                data = self._volumes.get(part, scalars, preference)
                key = (data, tf, options)  # kept while the piece, the function and the options are unchanged
                if self._plan is None or self._plan[0][:2] != (data, tf) or self._plan[0][2] != options:
                    self._plan = None
                    self._plan = (key, TetPlan(data, tf, options))
                plan = self._plan[1]

                def progress(fraction):
                    self.UpdateProgress(fraction)
                    return not self._should_abort()

                image = plan.execute(camera, self._size, piece=piece, progress=progress, progress_bar=False)
            else:  # nothing of the mesh in this box
                from ..image.hdr import HDRImage

                w, h = self._size
                dtype = np.float64 if options.precision == "float64" else np.float32
                image = HDRImage(np.zeros((h, w, 4), dtype=dtype), np.full((h, w), np.inf))
        except Exception as e:  # every process learns of it in gather_boxes; none waits forever
            error = e
        whole = gather_boxes(image, None if piece is None else piece.world_box(), rays, comm=comm, root=0,
                             error=error)
        if whole is None:
            out.Initialize()
        else:
            whole.metadata["cells_per_process"] = [s["cells"] for s in everyone]
            out.ShallowCopy(whole.to_vtk())
        self._last_piece = part
        return 1

    def GetLastPiece(self):
        """The data this process rendered last when the input was spread over processes
        (its extent of an image, with ghosts; its cells of a mesh after they were moved
        to its box), else ``None``: what each process holds (``GetActualMemorySize()``)."""
        return self._last_piece

    def _plan_for(self, inp, kind, scalars, preference, tf, data=None, options=None):
        """The :class:`GridPlan` or :class:`TetPlan` of this input, transfer function and
        options, made again only when one of them changed; the default transfer function
        of the data is kept while the data and its keywords are unchanged (it reads every
        value: 0.6 s for engine). The same pixels as ``render_volume``/``render_tets``,
        which resolve the transfer function, make a plan and execute it once."""
        from ..data.tets import TetMesh
        from ..raycast.grid import resolve_render_options

        opts = self._options if options is None else options
        if data is not None:  # prepared by the caller (a rectilinear piece)
            pass
        elif inp.IsA("vtkCompositeDataSet"):  # gathered onto one volume or merged into one mesh, cached
            data = as_renderable(inp, scalars=scalars, preference=preference)
        else:
            data = self._volumes.get(inp, scalars, preference)
        keywords = tuple((name, None if value is None else default_transfer_function_keyword(name, value))
                         for name, value in self._tf_keywords.items())
        made = self._default_tf
        if tf is None and made is not None and made[0] is data and made[1] == keywords:
            tf = made[2]  # the data's default function, kept
        else:  # as every front end: a transfer function and a keyword are the same TypeError
            given = tf
            tf, opts = resolve_render_options(data, tf, opts, **self._tf_keywords)
            if given is None:
                self._default_tf = (data, keywords, tf)
        labels = None if self._labels is None else (self._labels, id(self._label_styles))
        if self._plan is not None:
            old = self._plan[0]  # the data and the transfer function by identity, the rest by value
            if old[0] is data and old[1] is tf and old[2:] == (opts, labels):
                return self._plan[1]
            unclipped = opts.replace(clip_planes=(), crop_box=None)
            if old[0] is data and old[1] is tf and old[3] == labels \
                    and old[2].replace(clip_planes=(), crop_box=None) == unclipped:
                # only the clip changed (a plane dragged): the plan's tables and arrays stay
                plan = self._plan[1].with_clip(opts.clip_planes, opts.crop_box)
                self._plan = ((data, tf, opts, labels), plan)
                return plan
        self._plan = None  # drop the old plan (and its arrays) before making the new one
        if isinstance(data, TetMesh):
            from ..raycast.tets import TetPlan

            plan = TetPlan(data, tf, opts)
        else:
            from ..data.grid import labels_from_dataset
            from ..raycast.grid import GridPlan

            label_array = None if self._labels is None else labels_from_dataset(inp, self._labels, preference)
            plan = GridPlan(data, tf, opts, labels=label_array, label_styles=self._label_styles)
        self._plan = ((data, tf, opts, labels), plan)
        return plan


def _blocks_are_meshes(data):
    """Whether the volumetric blocks of a composite dataset are meshes (rendered by the
    tetrahedral ray caster), not grids."""
    from ..data.blocks import classify, flatten

    kinds = classify(flatten(data)[0])
    return bool(kinds["mesh"]) and not (kinds["image"] or kinds["rectilinear"])


class HDRProxyWriter(HDRVolumeRenderer):
    """Write the proxy folder of a ``vtkImageData`` (:func:`~pv_hdrvol.make_proxies`,
    docs/proxy.md) from a pipeline: in situ, where the volume is, for exploration later
    without it. The output is the reference render (as :class:`HDRVolumeRenderer`'s).

    Set what :class:`HDRVolumeRenderer` takes (image size, scalars, transfer function
    or its keywords, a camera -- which must be a parallel projection; a view name frames
    one -- ``step``, ``opacity_unit_distance``), and :meth:`SetFileName` (the folder),
    :meth:`SetIntervals`, :meth:`SetLayers`, :meth:`SetMultiPerspective`,
    :meth:`SetTraining`, :meth:`SetClusters`. Every execution writes the folder.

    Examples
    --------
    >>> import tempfile, os
    >>> from vtkmodules.vtkImagingCore import vtkRTAnalyticSource
    >>> source = vtkRTAnalyticSource()
    >>> writer = HDRProxyWriter()
    >>> writer.SetInputConnection(source.GetOutputPort())
    >>> writer.SetImageSize(16, 16); writer.SetTraining(0)
    >>> writer.SetFileName(os.path.join(tempfile.mkdtemp(), "wavelet.proxy"))
    >>> writer.Update()
    True
    >>> sorted(os.listdir(writer.GetFileName()))
    ['data.csv', 'preview.png', 'proxies.exr', 'proxies.json']
    """

    REPORT_NAME = "HDRProxyWriter"
    DISTRIBUTED = False  # the proxies of the whole volume: piece 0 reads all of it

    def __init__(self):
        super().__init__()
        self._file_name = None
        self._proxy_options = {"intervals": 16, "layers": None, "multi_perspective": False, "training": 3,
                               "clusters": 24}
        #: the ProxySet written by the last execution
        self.proxies = None

    def _set_proxy(self, name, value):
        if self._proxy_options[name] != value:
            self._proxy_options[name] = value
            self.Modified()

    def SetFileName(self, name):
        """The proxy folder to write (created; its proxy files are replaced)."""
        if name is not None and not isinstance(name, str):
            raise TypeError(f"the file name must be a str; got {type(name).__name__}")
        if name != self._file_name:
            self._file_name = name
            self.Modified()

    def GetFileName(self):
        return self._file_name

    def SetIntervals(self, n):
        """``L``, intensity intervals (2..64; default 16)."""
        from .._validate import as_int

        self._set_proxy("intervals", as_int("intervals", n, low=2, high=64))

    def SetLayers(self, layers):
        """Isovalues of depth layers (a sequence), a count of opacity peaks (an int) or ``None``."""
        if layers is not None and not isinstance(layers, numbers.Integral):
            layers = tuple(float(v) for v in layers)
        self._set_proxy("layers", layers)

    def SetMultiPerspective(self, on):
        self._set_proxy("multi_perspective", bool(on))

    def SetTraining(self, n):
        """Training renders of the colour model (0: none; default 3)."""
        from .._validate import as_int

        self._set_proxy("training", as_int("training", n, low=0))

    def SetClusters(self, k):
        from .._validate import as_int

        self._set_proxy("clusters", as_int("clusters", k, low=1))

    def GetProxyOptions(self):
        """The proxy settings as a dict (a copy)."""
        return dict(self._proxy_options)

    def _execute(self, inInfo, outInfo):
        from ..image.hdr import HDRImage
        from ..proxy.generate import as_proxy_camera, make_proxies

        inp = vtkDataObject.GetData(inInfo[0])
        out = vtkImageData.GetData(outInfo)
        if _output_piece(outInfo) != 0:
            out.Initialize()
            return 1
        kind = inp.GetClassName() if inp is not None else None
        if kind not in ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid") or inp.GetNumberOfPoints() == 0:
            raise ValueError(f"HDRProxyWriter needs a non-empty vtkImageData on input port 0; got "
                             f"{'nothing' if inp is None else kind}")
        if not self._file_name:
            raise ValueError("HDRProxyWriter has no file name: SetFileName(folder) first")
        if self._options.tolerance is not None:  # make_proxies casts at one step
            raise ValueError(f"HDRProxyWriter casts its proxies at SetStep's step; SetTolerance chooses the knobs of "
                             f"a render, not of proxies: SetTolerance(0); got tolerance={self._options.tolerance!r}")
        scalars, preference = self._scalars_to_render()
        data = self._volumes.get(inp, scalars, preference)
        camera = Camera(**self._camera) if isinstance(self._camera, dict) else self._camera
        camera = as_proxy_camera(camera, inp.GetBounds())
        from ..raycast.grid import resolve_render_options

        tf = resolve_render_options(data, self._transfer_function(), **self._tf_keywords)[0]
        self.SetProgressText("casting proxies")
        proxies = make_proxies(data, camera, self._size, tf, step=self._options.step,
                               opacity_unit_distance=self._options.opacity_unit_distance, progress_bar=False,
                               **self._proxy_options)
        proxies.save(self._file_name)
        self.proxies = proxies
        self.UpdateProgress(1.0)
        out.ShallowCopy(HDRImage(proxies.rgba).to_vtk())
        return 1


class _Distribution(NamedTuple):
    """How this process renders its piece: the communicator, the whole extent, the
    extent it owns and the one it asks for (owned plus ``ghosts`` layers)."""

    comm: "ControllerComm"
    whole: tuple
    owned: tuple
    extent: tuple
    ghosts: int


def _whole_axes(inp, distribution):
    """The whole rectilinear grid's coordinates (x, y, z arrays) from every process's
    piece (collective: each sends its extent and coordinates), an exception to raise if
    they do not fit, or ``None`` when the input is not a rectilinear grid (on any
    process: all decide alike, from piece 0's class name)."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy

    mine = None
    if inp is not None and inp.GetClassName() == "vtkRectilinearGrid" and inp.GetNumberOfPoints():
        mine = (tuple(inp.GetExtent()), [vtk_to_numpy(c).astype(np.float64) for c in
                                         (inp.GetXCoordinates(), inp.GetYCoordinates(), inp.GetZCoordinates())])
    pieces = distribution.comm.allgather(mine)
    if all(p is None for p in pieces):
        return None
    whole = np.reshape(distribution.whole, (3, 2))
    axes = [np.full(int(hi - lo + 1), np.nan) for lo, hi in whole]
    for p in pieces:
        if p is None:
            continue
        for axis in range(3):
            lo = int(p[0][2 * axis] - whole[axis][0])
            axes[axis][lo:lo + p[1][axis].size] = p[1][axis]
    if any(np.isnan(a).any() for a in axes):
        return ValueError("the rectilinear grid's pieces do not cover its whole extent: render it on one process")
    return tuple(axes)


def _tet_grid_of_structured(grid):
    """A curvilinear grid (a piece of one) as the ``vtkUnstructuredGrid`` of the
    tetrahedra a render of the whole grid splits it into (:func:`~pv_hdrvol.data.
    structured.structured_tets`: the lattice alone decides the split, so pieces that
    share a face cut it alike; blanked cells, ghost cells (DUPLICATECELL: another
    piece's) and collapsed tetrahedra left out), with
    its points and point data as they are and its cell data repeated per tetrahedron."""
    import numpy as np
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy
    from vtkmodules.vtkCommonDataModel import VTK_TETRA, vtkCellArray, vtkUnstructuredGrid

    from ..data.structured import TETS_PER_CELL, collapsed_tets, grid_dims, grid_start, structured_tets, visible_cells

    out = vtkUnstructuredGrid()
    if grid.GetNumberOfPoints() == 0 or grid.GetNumberOfCells() == 0:
        return out
    points = vtk_to_numpy(grid.GetPoints().GetData())
    visible = visible_cells(grid)
    ghosts = grid.GetCellGhostArray()
    if ghosts is not None:  # a ghost layer's cells are another piece's: DUPLICATECELL
        owned = (vtk_to_numpy(ghosts).astype(np.uint8) & 1) == 0
        if not owned.all():
            visible = owned if visible is None else visible & owned
    cells = np.arange(grid.GetNumberOfCells()) if visible is None else np.flatnonzero(visible)
    tets = structured_tets(points, grid_dims(grid), visible, grid_start(grid))
    of_cell = np.repeat(cells, TETS_PER_CELL)
    keep = ~collapsed_tets(points, tets)
    tets, of_cell = tets[keep], of_cell[keep]
    out.SetPoints(grid.GetPoints())
    out.GetPointData().ShallowCopy(grid.GetPointData())
    connectivity = vtkCellArray()
    connectivity.SetData(numpy_to_vtkIdTypeArray(np.arange(0, 4 * len(tets) + 1, 4, dtype=np.int64), deep=True),
                         numpy_to_vtkIdTypeArray(np.ascontiguousarray(tets.ravel(), dtype=np.int64), deep=True))
    out.SetCells(VTK_TETRA, connectivity)
    data = grid.GetCellData()
    for i in range(data.GetNumberOfArrays()):
        array = data.GetArray(i)
        if array is None or array.GetName() == "vtkGhostType":
            continue
        values = numpy_to_vtk(np.ascontiguousarray(vtk_to_numpy(array)[of_cell]), deep=True)
        values.SetName(array.GetName())
        out.GetCellData().AddArray(values)
    return out


def _mesh_summary(mesh, scalars, sample=4096):
    """What the processes tell each other about their pieces of a mesh before it is cut
    into boxes: counts, bounds, the scalars' name and a strided sample of cell centres."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkFiltersCore import vtkCellCenters

    n = mesh.GetNumberOfCells()
    centres = np.empty((0, 3))
    points, bounds = 0, None
    if n:
        finder = vtkCellCenters()
        finder.SetInputData(mesh)
        finder.VertexCellsOff()
        finder.Update()
        centres = vtk_to_numpy(finder.GetOutput().GetPoints().GetData())[:: max(1, n // sample)].astype(float)
        used = _used_points(mesh)  # the bounds a TetMesh of the whole mesh has
        bounds = tuple(float(v) for pair in zip(used.min(axis=0), used.max(axis=0)) for v in pair)
    return {"cells": n, "bounds": bounds, "scalars": scalars, "centres": centres}


def _used_points(mesh):
    """The distinct points (``(m, 3)`` float64) the cells of ``mesh`` use, as a TetMesh
    keeps them."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy

    if not mesh.GetNumberOfCells():
        return np.empty((0, 3))
    xyz = vtk_to_numpy(mesh.GetPoints().GetData()).astype(np.float64)
    return np.unique(xyz[np.unique(vtk_to_numpy(mesh.GetCells().GetConnectivityArray()))], axis=0)


def _points_owned(mesh, piece):
    """How many distinct points of ``mesh`` lie in ``piece``'s box (half open: a point on
    a face two boxes share belongs to the box above it), so that the counts of all
    processes add up to the whole mesh's distinct points (its default unit distance)."""
    import numpy as np

    used = _used_points(mesh)
    lo, hi = piece.world_box()
    inside = (used >= lo) & ((used < hi) | (piece.closed() & (used <= hi)))
    return int(np.count_nonzero(inside.all(axis=1)))


def _share_cores(comm):
    """Give this process its share of its node's cores for the render (collective):
    ``max(1, cores // processes on the node)`` numba threads, unless ``NUMBA_NUM_THREADS``
    is set (:func:`pv_hdrvol.parallel.comm.rank_threads`). Every pvbatch rank would
    otherwise start one thread per core of the machine."""
    from ..parallel.comm import use_rank_threads

    use_rank_threads(comm)


def _redistribute(mesh, boxes, comm):
    """This process's cells of ``mesh`` after moving every cell to each process whose box
    it meets (``boxes[rank]``; collective). Box ``i`` goes to process ``i``."""
    from vtkmodules.vtkCommonDataModel import vtkUnstructuredGrid
    from vtkmodules.vtkFiltersParallelDIY2 import vtkRedistributeDataSetFilter

    d3 = vtkRedistributeDataSetFilter()
    d3.SetController(comm.controller)
    d3.SetInputData(mesh)
    d3.SetBoundaryModeToAssignToAllIntersectingRegions()
    d3.UseExplicitCutsOn()
    d3.ExpandExplicitCutsOff()
    for lo, hi in boxes:
        d3.AddExplicitCut([lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]])
    d3.Update()
    part = vtkUnstructuredGrid()
    part.ShallowCopy(d3.GetOutputDataObject(0))
    return part


def _piece_extent(whole, piece, n, ghosts):
    """VTK's extent of ``piece`` of ``n`` of the ``whole`` extent (the extent
    translator's block split, which readers and the pipeline use) with ``ghosts``
    layers, clipped to the whole extent."""
    from vtkmodules.vtkCommonExecutionModel import vtkExtentTranslator

    translator = vtkExtentTranslator()
    translator.SetWholeExtent(*whole)
    translator.SetPiece(piece)
    translator.SetNumberOfPieces(n)
    translator.SetGhostLevel(ghosts)
    translator.PieceToExtent()
    return tuple(translator.GetExtent())


class ControllerComm(PointToPointComm):
    """A ``vtkMultiProcessController`` (ParaView's MPI processes) as the mpi4py-style
    communicator :mod:`pv_hdrvol.parallel` takes: ``rank``, ``size`` and collectives of
    Python objects, pickled and sent as bytes with ``Send``/``Receive``."""

    TAG = 87113

    def __init__(self, controller):
        self.controller = controller
        self.rank = controller.GetLocalProcessId()
        self.size = controller.GetNumberOfProcesses()

    @classmethod
    def world(cls):
        """The global controller's communicator, or ``None`` without one."""
        from vtkmodules.vtkParallelCore import vtkMultiProcessController

        controller = vtkMultiProcessController.GetGlobalController()
        return None if controller is None else cls(controller)

    def _send(self, value, dest):
        import pickle

        import numpy as np
        from vtkmodules.util.numpy_support import numpy_to_vtk
        from vtkmodules.vtkCommonCore import VTK_UNSIGNED_CHAR

        payload = np.frombuffer(pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL), dtype=np.uint8)
        self.controller.Send(numpy_to_vtk(payload, deep=1, array_type=VTK_UNSIGNED_CHAR), dest, self.TAG)

    def _receive(self, source):
        import pickle

        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

        payload = vtkUnsignedCharArray()
        self.controller.Receive(payload, source, self.TAG)
        return pickle.loads(vtk_to_numpy(payload).tobytes())


def _output_piece(outInfo):
    """The piece of the output the pipeline asks for (0 without pieces)."""
    info = outInfo.GetInformationObject(0)
    return info.Get(_SDDP.UPDATE_PIECE_NUMBER()) if info.Has(_SDDP.UPDATE_PIECE_NUMBER()) else 0


#: (mesh?, precision) of the renders done in this process
_RENDERED = set()


def _first_use(mesh, precision):
    """``"<precision> image volume"`` or ``"... mesh"`` the first time a process renders
    it (when numba compiles or loads its kernels), else ``""``."""
    key = (mesh, precision)
    if key in _RENDERED:
        return ""
    _RENDERED.add(key)
    return f"{precision} {'tetrahedral mesh' if mesh else 'image volume'}"


def _compiled_precision(options):
    """The precision whose kernels a render with ``options`` runs: a tolerance's is
    chosen (float64, :mod:`pv_hdrvol.raycast.tolerance`), not the option's default."""
    return "float64" if options.tolerance is not None else options.precision


def _numba_cache_dir():
    from numba.core import config

    return config.CACHE_DIR or "__pycache__ beside pv_hdrvol's source"


def _display_text(text):
    vtkOutputWindow.GetInstance().DisplayText(text + "\n")


__all__ = ["ControllerComm", "HDRVolumeRenderer"]
