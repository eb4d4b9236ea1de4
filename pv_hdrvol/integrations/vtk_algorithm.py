"""``HDRVolumeRenderer``: the ray caster as a VTK pipeline algorithm.

Pure VTK + pv_hdrvol (no ParaView import), so that a ParaView plugin can wrap it with
decorators only. The class holds the properties; how it executes (one path for every
kind of input) is :mod:`~pv_hdrvol.integrations.vtk_execute`, and what processes do with
VTK's pieces :mod:`~pv_hdrvol.integrations.vtk_pieces`.
"""
from __future__ import annotations

import dataclasses
import numbers
import weakref
from typing import Callable, NamedTuple, Optional

from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkImageData
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

from .._validate import as_choice, as_size
from ..data.transfer import TF_KEYWORDS, TransferFunction, default_transfer_function_keyword
from ..params import RenderOptions, as_clip_planes
from ..rays.camera import Camera, Rays, as_camera
from .vtk_base import ReportingAlgorithm
from .vtk_execute import ExecutionState, execute, request_update_extent
from .vtk_pieces import ControllerComm, output_piece

_SDDP = vtkStreamingDemandDrivenPipeline


# -- RenderOptions' fields as VTK properties ---------------------------------------------
class OptionProperty(NamedTuple):
    """How one :class:`~pv_hdrvol.RenderOptions` field shows as a VTK property."""

    #: what the field means, for the docstrings
    meaning: str
    #: what the setter's value becomes before ``RenderOptions`` validates it (VTK's words for its own)
    to_field: Optional[Callable] = None
    #: what the getter returns of the field's value
    from_field: Optional[Callable] = None
    #: the setter takes the value as several numbers too (``SetCropBox(0, 1, 0, 1, 0, 1)``)
    vector: bool = False


def _zero_is_off(tolerance):
    # 0 is "off" as in a VTK (ParaView) number property; RenderOptions says None
    if isinstance(tolerance, numbers.Real) and not isinstance(tolerance, bool) and tolerance == 0:
        return None
    return tolerance


def _off_is_zero(tolerance):
    return 0.0 if tolerance is None else tolerance


#: The meaning of each RenderOptions field as a VTK property. ``Set<Field>`` and
#: ``Get<Field>`` (``Set``/``Get`` and the field's name in CamelCase: ``SetGlobalAlpha``),
#: and ``<Field>On``/``<Field>Off`` for a bool field, are made from this table for
#: every field of RenderOptions (a field missing here still gets them, pointing to
#: RenderOptions' documentation); ParaView's properties call them.
OPTION_PROPERTIES = {
    "step": OptionProperty("sample distance in voxels of the smallest spacing (> 0)."),
    "precision": OptionProperty("compositing arithmetic, 'float32', 'float64', 'float16' or 'uint8'."),
    "global_alpha": OptionProperty("multiplier in (0, 1] of every transfer-function opacity."),
    "opacity_unit_distance": OptionProperty(
        "world length over which a TF opacity is reached (None: smallest spacing)."),
    "termination": OptionProperty("transmittance below which a ray stops, in [0, 1) (0: never)."),
    "depth_threshold": OptionProperty("accumulated opacity at which depth is recorded, in (0, 1]."),
    "block_size": OptionProperty("edge in cells of the empty-space-skipping blocks (a power of two)."),
    "skip_empty": OptionProperty("skip blocks that map to zero opacity (same result, less time)."),
    "blending": OptionProperty("'composite', 'maximum', 'minimum', 'average' or 'additive' (PyVista's names)."),
    "gradient_opacity": OptionProperty(
        "None, or (low, high): extinction times a ramp of the gradient magnitude."),
    "shade": OptionProperty("Blinn-Phong shading by the gradient (composite blending only)."),
    "ambient": OptionProperty("Blinn-Phong ambient weight (>= 0)."),
    "diffuse": OptionProperty("Blinn-Phong diffuse weight (>= 0)."),
    "specular": OptionProperty("Blinn-Phong specular weight (>= 0)."),
    "specular_power": OptionProperty("Blinn-Phong exponent (>= 1)."),
    "lights": OptionProperty("None (a headlight), a Light, a direction towards the light, or a sequence of them."),
    "shade_gradient": OptionProperty("'sampled' (central differences at each sample) or 'interpolated'."),
    "shade_threshold": OptionProperty(
        "fraction of the TF axis per voxel at which shading is at full strength (>= 0)."),
    "tolerance": OptionProperty(
        "the RMS error of the linear, premultiplied RGB image against the converged render, relative to its "
        "peak, in (0, 0.5]; the renderer then chooses step, termination, table size and precision (which must "
        "stay at their defaults: see :meth:`GetLastTolerance`). ``0`` or ``None``: off, the knobs as set; the "
        "getter then says ``0.0`` (``GetOptions().tolerance`` is ``None``).",
        to_field=_zero_is_off, from_field=_off_is_zero),
    "clip_planes": OptionProperty(
        "planes cutting the volume: a ``vtkPlaneCollection``, ``vtkPlanes``, a sequence of planes (``vtkPlane``, "
        "``(origin, normal)``, ``ClipPlane``) or ``None``; each keeps the side its normal points to "
        "(:meth:`AddClippingPlane`, :meth:`GetClippingPlanes`)."),
    "crop_box": OptionProperty(
        "keep only this world box, ``(xmin, xmax, ymin, ymax, zmin, zmax)`` as 6 numbers or one sequence "
        "(VTK's bounds order, as ``SetCroppingRegionPlanes``); ``None``: no crop.", vector=True),
    "device": OptionProperty(
        "'cpu' (default) or 'cuda': image volumes on an NVIDIA GPU through numba-cuda (docs/gpu.md)."),
}


def option_property_name(field):
    """``"global_alpha"`` -> ``"GlobalAlpha"``: the VTK property of a RenderOptions field."""
    return "".join(part.capitalize() for part in field.split("_"))


def _option_methods(field, spec):
    """``{"Set<Field>": setter, "Get<Field>": getter}`` (and ``<Field>On``/``<Field>Off``
    for a bool field, whose setter also takes VTK-style 0 and 1) for one field of
    :class:`~pv_hdrvol.RenderOptions` (a ``dataclasses.Field``)."""
    is_bool = field.type in (bool, "bool")
    name, field = option_property_name(field.name), field.name

    def set_value(self, value):
        if is_bool and isinstance(value, numbers.Integral) and not isinstance(value, bool) and value in (0, 1):
            value = bool(value)
        self._set_options(**{field: value if spec.to_field is None else spec.to_field(value)})

    if spec.vector:
        def setter(self, *values):
            set_value(self, values[0] if len(values) == 1 else values)
    else:
        def setter(self, value):
            set_value(self, value)

    def getter(self):
        value = getattr(self._options, field)
        return value if spec.from_field is None else spec.from_field(value)

    setter.__doc__ = (f"Set ``RenderOptions.{field}``: {spec.meaning} "
                      f"{'A bool (VTK-style 0/1 are accepted). ' if is_bool else ''}Validated by "
                      ":class:`~pv_hdrvol.RenderOptions`; calls ``Modified()`` when it changes.")
    getter.__doc__ = f"``RenderOptions.{field}``: {spec.meaning}"
    methods = {f"Set{name}": setter, f"Get{name}": getter}
    if is_bool:
        def on(self):
            setter(self, True)

        def off(self):
            setter(self, False)

        on.__doc__ = f"Set ``RenderOptions.{field}`` to True."
        off.__doc__ = f"Set ``RenderOptions.{field}`` to False."
        methods.update({f"{name}On": on, f"{name}Off": off})
    return methods


def _with_option_properties(cls):
    """Give ``cls`` the VTK properties of every :class:`~pv_hdrvol.RenderOptions` field
    (:data:`OPTION_PROPERTIES`)."""
    for field in dataclasses.fields(RenderOptions):
        spec = OPTION_PROPERTIES.get(field.name) or OptionProperty("see :class:`~pv_hdrvol.RenderOptions`.")
        for method_name, method in _option_methods(field, spec).items():
            if method_name in vars(cls):
                raise TypeError(f"{cls.__name__}.{method_name} is made from RenderOptions.{field.name}: "
                                f"describe it in OPTION_PROPERTIES instead of writing it")
            method.__name__ = method_name
            method.__qualname__ = f"{cls.__qualname__}.{method_name}"
            method.__module__ = cls.__module__
            setattr(cls, method_name, method)
    return cls


@_with_option_properties
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
    changed. Each field has its ``Set<Field>``/``Get<Field>`` (``global_alpha``:
    :meth:`SetGlobalAlpha`, ``GetGlobalAlpha``; a bool field also ``<Field>On`` and
    ``<Field>Off``), made from the field (:data:`OPTION_PROPERTIES`);
    :meth:`SetOptions` replaces them all at once.

    Every kind of input executes through one path
    (:func:`pv_hdrvol.integrations.vtk_execute.execute`): the kind decides what is
    shared between processes, the plan and the camera, and how pieces are composited;
    the progress and abort handling and the output are the same for all.

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
        self._camera = None
        self._lens = None
        self._cull = None
        self._labels = None
        self._label_styles = None
        self._comm = None
        # a level of a multiresolution store (MultiscaleReader): the store, out of core
        self._out_of_core = True
        self._screen_error = 1.0
        self._cache_bytes = None  # None: open_multiscale's default
        # plans, volumes, moved cells and open stores kept between executions, and what
        # the last one chose (vtk_execute)
        self._state = ExecutionState()

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
        sequence of planes, or ``None`` (``RenderOptions.clip_planes``, as
        :meth:`SetClipPlanes`)."""
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

    def GetLastTolerance(self):
        """What the last execution chose for its tolerance, else ``None``: the image's
        ``metadata["tolerance"]`` (``step`` or, for a mesh, ``tau_max``,
        ``termination``, ``table_size``, ``precision``, ``estimated_error``, ...; see
        :mod:`pv_hdrvol.raycast.tolerance`), a copy."""
        last = self._state.last_tolerance
        return None if last is None else dict(last)

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
        return self._state.last_camera

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
            self._state.close_stores()
            self.Modified()

    def GetCacheBytes(self):
        return self._cache_bytes

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
        # each process asks for its piece, or piece 0 for all of the input (vtk_execute)
        return request_update_extent(self, inInfo, outInfo)

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

    def _execute(self, inInfo, outInfo):
        # the one path for every kind of input: vtk_execute.execute
        return execute(self, inInfo, outInfo)

    def GetLastPiece(self):
        """The data this process rendered last when the input was spread over processes
        (its extent of an image, with ghosts; its cells of a mesh after they were moved
        to its box), else ``None``: what each process holds (``GetActualMemorySize()``)."""
        return self._state.last_piece


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
        if output_piece(outInfo) != 0:
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
        data = self._state.volumes.get(inp, scalars, preference)
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


__all__ = ["ControllerComm", "HDRProxyWriter", "HDRVolumeRenderer", "OPTION_PROPERTIES", "OptionProperty",
           "option_property_name"]
