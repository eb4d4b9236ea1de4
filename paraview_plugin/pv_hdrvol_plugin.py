"""pv_hdrvol for ParaView: HDR volume rendering as filters, and OpenEXR/Radiance files.

Load it once: Tools > Manage Plugins > Load New (this file), ``LoadPlugin(path,
ns=globals())`` in pvpython/pvbatch, or put this folder on ``PV_PLUGIN_PATH``. ParaView
5.11 on Python 3.11 (Debian bookworm) needs the ``getargspec`` shim of ``shim/``
on ``PYTHONPATH`` first: ``pv-hdrvol paraview`` prints the environment to use
(docs/paraview.md).

Filters: **HDR Volume Render** (image data or a tetrahedral unstructured grid -> a 2-D
image with the HDR ``rgba``, ``depth`` and a tone-mapped ``tonemapped`` array, and the
'In View' surface that the render view shows: the image facing the camera at the
volume's depth, docs/paraview.md),
**HDR Tone Map**, **HDR Upsample**; a reader and writers for ``.exr`` and ``.hdr``; a
reader of multiresolution stores (``*.ome.zarr`` directories: one level, which HDR
Volume Render turns back into the whole store, rendered out of core).

This file is only the ParaView layer: decorated classes that call the VTK algorithms of
``pv_hdrvol.integrations``; every property means what the same name means in
``pv_hdrvol.RenderOptions`` and ``hv.tonemap``.
"""
import os
import sys

paraview_plugin_name = "pv_hdrvol"
paraview_plugin_version = "0.1.0"


def _prepare():
    """Make ``import pv_hdrvol`` work from this checkout, and give numba a persistent
    cache folder of its own version (before numba is imported) unless the user chose one."""
    import importlib.util

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    if importlib.util.find_spec("pv_hdrvol") is None and os.path.isfile(os.path.join(root, "pv_hdrvol", "__init__.py")):
        sys.path.insert(0, root)
    if not os.environ.get("NUMBA_CACHE_DIR"):
        try:
            from importlib.metadata import version

            numba_version = version("numba")
        except Exception:  # no numba: the import below says so
            numba_version = "unknown"
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        folder = os.path.join(base, "pv_hdrvol", f"numba-{numba_version}-py{sys.version_info[0]}{sys.version_info[1]}")
        os.environ["NUMBA_CACHE_DIR"] = folder
        if "numba" in sys.modules:  # another plugin imported numba already
            sys.modules["numba"].config.CACHE_DIR = folder


_prepare()

from paraview.util.vtkAlgorithm import smdomain, smhint, smproperty, smproxy  # noqa: E402

try:
    import pv_hdrvol  # noqa: F401  (numba, numpy)
    from pv_hdrvol.integrations import vtk_image, vtk_multiscale
    from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer
except ImportError as exc:  # never break ParaView: say what is missing, register nothing
    from vtkmodules.vtkCommonCore import vtkOutputWindow

    vtkOutputWindow.GetInstance().DisplayErrorText(
        f"pv_hdrvol plugin: not loaded, {exc}. ParaView's Python ({sys.executable}, Python "
        f"{sys.version.split()[0]}) needs numpy and numba (Debian: apt-get install python3-numba), and "
        f"pv_hdrvol on its PYTHONPATH (see docs/paraview.md, or run `pv-hdrvol paraview`).\n")
    HDRVolumeRenderer = None

#: The camera modes of HDR Volume Render: the render view's camera, or a view name
#: framing the input (as hv.Camera.fit).
CAMERA_MODES = ("Render View", "iso", "xy", "yx", "xz", "zx", "yz", "zy")
#: Where HDR Volume Render's transfer function comes from.
TRANSFER_FUNCTIONS = ("Color Map Editor", "pv_hdrvol default")
PRECISIONS = ("float32", "float64", "float16", "uint8")
BLENDINGS = ("composite", "maximum", "minimum", "average", "additive")
DEVICES = ("cpu", "cuda")
TONEMAP_OPERATORS = ("knee", "reinhard", "drago", "linear", "gamma", "durand", "fattal")
SCALES = ("auto", "linear", "log", "symlog")
LENSES = ("none", "magnifier", "fisheye")
#: The render view's camera properties, which HDR Volume Render has under the same names.
CAMERA_PROPERTIES = ("CameraPosition", "CameraFocalPoint", "CameraViewUp", "CameraViewAngle",
                     "CameraParallelProjection", "CameraParallelScale")


#: The Properties panel's groups of HDR Volume Render, in the order a user goes through
#: them (the rare properties of each behind the gear)
PANEL_GROUPS = (
    ("Output", ("ImageSize", "DisplayToneMap")),
    ("Transfer Function", ("TransferFunction", "Cmap", "Scale", "GlobalAlpha", "OpacityUnitDistance", "Blending")),
    ("Sampling and Accuracy", ("Tolerance", "Step", "Precision", "Device")),
    ("Shading", ("Shade", "Ambient", "Diffuse", "Specular", "SpecularPower")),
    ("Camera", ("Camera", "FollowView") + CAMERA_PROPERTIES),
    ("Lens", ("Lens", "LensCenter", "LensRadius", "LensMagnification", "FisheyeFieldOfView")),
    ("Culling", ("POFFile", "FamilyWeights")),
    ("Out Of Core", ("OutOfCore", "ScreenError", "CacheSize")),
)
_GROUPS = "".join(f'<PropertyGroup label="{label}">' + "".join(f'<Property name="{n}"/>' for n in names)
                  + "</PropertyGroup>" for label, names in PANEL_GROUPS)


#: The hint that shows a property in the panel only for a store's input
_FOR_STORES = '<PropertyWidgetDecorator type="GenericDecorator" mode="visibility" property="InputIsStore" value="1"/>'


def _string_list(values, name="list"):
    strings = "".join(f'<String value="{v}"/>' for v in values)
    return f'<StringListDomain name="{name}">{strings}</StringListDomain>'


def _parse_parameters(text):
    """``"key=0.18, white=4, local=true"`` -> ``{"key": 0.18, "white": 4.0, "local": True}``;
    ``""`` or ``None`` (what ParaView 5.11 pushes for an empty string property) -> ``{}``."""
    parameters = {}
    text = text or ""
    for item in filter(None, (part.strip() for part in text.replace(";", ",").split(","))):
        name, sep, value = (piece.strip() for piece in item.partition("="))
        if not sep or not name.isidentifier() or not value:
            raise ValueError(f"tone-map parameters are name=value pairs separated by commas; got {item!r}")
        low = value.lower()
        if low in ("true", "false"):
            parameters[name] = low == "true"
        elif low == "none":
            parameters[name] = None
        else:
            try:
                parameters[name] = int(value) if value.lstrip("+-").isdigit() else float(value)
            except ValueError:
                raise ValueError(f"tone-map parameter {name} must be a number, true, false or none; "
                                 f"got {value!r}") from None
    return parameters


def _surface_of(image, camera):
    """HDR Volume Render's 'In View' output: the tone-mapped image as a surface facing
    ``camera`` at the volume's depth (VTK rows, bottom first, to pv_hdrvol's)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from pv_hdrvol.integrations.vtk_surface import view_surface

    cols, rows, _ = image.GetDimensions()
    data = image.GetPointData()
    alpha = vtk_to_numpy(data.GetArray("rgba"))[:, 3].reshape(rows, cols)[::-1]
    depth = vtk_to_numpy(data.GetArray("depth")).reshape(rows, cols)[::-1]
    colors = vtk_to_numpy(data.GetArray("tonemapped"))[:, :3].reshape(rows, cols, 3)[::-1]
    return view_surface(alpha, depth, colors, camera)


def _setting(algorithm, name, apply):
    """Run a property setter's work. A value it refuses raises (ParaView reports it) and
    stays the filter's error until a valid value is set: the next execution fails with
    it (GetLastError says it) instead of rendering with the previous value."""
    refused = algorithm.__dict__.setdefault("_refused", {})
    try:
        apply()
    except Exception as exc:
        refused[name] = f"{type(exc).__name__}: {exc}"
        algorithm.Modified()
        raise
    if refused.pop(name, None) is not None:
        algorithm.Modified()


def _raise_refused(algorithm):
    refused = algorithm.__dict__.get("_refused")
    if refused:
        raise ValueError("; ".join(f"{name} was refused ({why})" for name, why in refused.items())
                         + ": set a valid value; nothing is rendered with the previous one")


def _say_once(algorithm, text):
    """A warning in ParaView's Output Messages, once per filter and text."""
    said = algorithm.__dict__.setdefault("_said", set())
    if text not in said:
        said.add(text)
        from vtkmodules.vtkCommonCore import vtkOutputWindow

        vtkOutputWindow.GetInstance().DisplayWarningText(text + "\n")


def _documentation(text):
    return f"<Documentation>{text}</Documentation>"


if HDRVolumeRenderer is not None:

    @smproxy.filter(name="HDRVolumeRender", label="HDR Volume Render", support_reload=False)
    # port 0, the HDR image, is data (save it, tone map it, upsample it) and is not shown
    # by Apply: drawn flat in the 3-D view whose camera made it, it would turn with the
    # view like a plane. Port 1, the image as a surface facing the camera at the
    # volume's depth, is what the render view shows (pv_hdrvol.integrations.vtk_surface).
    @smhint.xml('<ShowInMenu category="pv_hdrvol"/>'
                '<View type="None" port="0"/><Visibility replace_input="2"/>'
                '<RepresentationType view="RenderView" type="Surface" port="1"/>')
    @smproperty.xml('<OutputPort name="HDR Image" index="0"/>')
    @smproperty.xml('<OutputPort name="In View" index="1"/>')
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData", "vtkRectilinearGrid", "vtkStructuredGrid", "vtkUnstructuredGrid"],
                       composite_data_supported=True)
    @smdomain.xml('<InputArrayDomain name="input_array" attribute_type="any" number_of_components="1"/>')
    class HDRVolumeRender(HDRVolumeRenderer):
        """Volume render image data, a rectilinear, curvilinear or tetrahedral grid, or blocks of
        those, into an HDR image (pv_hdrvol)."""

        def __init__(self):
            self._lens_settings = {"name": "none", "center": (0.5, 0.5), "radius": 0.25, "factor": 2.0,
                                   "fov_degrees": 180.0}
            super().__init__()
            self._camera_mode = "Render View"
            # ParaView's camera, property by property; position == focal point: never set
            self._view_camera = {"position": (0.0, 0.0, 0.0), "focal_point": (0.0, 0.0, 0.0),
                                 "view_up": (0.0, 0.0, 1.0), "view_angle": 30.0,
                                 "parallel_projection": False, "parallel_scale": 1.0}
            self._tf_source = TRANSFER_FUNCTIONS[0]
            # Clip / Crop as the panel holds them (the renderer gets them only while switched on)
            self._clip = {"on": False, "origin": (0.0, 0.0, 0.0), "normal": (1.0, 0.0, 0.0)}
            self._crop = {"on": False, "origin": (0.0, 0.0, 0.0), "length": (1.0, 1.0, 1.0)}
            self._cmap = self._scale = None  # the default transfer function's keywords
            self._lut = None
            self._opacity_function = None
            self._pof_file, self._pof_weights = "", ""
            self._pof = None  # (path, modification time, PlenopticOpacity)
            # the display: knee (colour-map colours as ParaView's Volume representation
            # shows them, hue kept above the knee), unencoded as its own default
            self._display = vtk_image.HDRToneMapper()
            self._display.SetOperator("knee")
            self._display_operator = "knee"
            # Step and Precision as the panel holds them: passed on while Tolerance is 0,
            # kept aside while it is on (the renderer chooses them then)
            defaults = pv_hdrvol.RenderOptions()
            self._knobs = {"step": defaults.step, "precision": defaults.precision}
            self._tolerance = 0.0
            self._push_camera()
            self.SetNumberOfOutputPorts(2)
            _install_client_hook()

        def FillOutputPortInformation(self, port, info):
            from vtkmodules.vtkCommonDataModel import vtkDataObject

            info.Set(vtkDataObject.DATA_TYPE_NAME(), "vtkImageData" if port == 0 else "vtkPolyData")
            return 1

        # -- the array, the size ---------------------------------------------------
        @smproperty.xml("""
          <StringVectorProperty name="SelectInputScalars" label="Scalars" command="SetInputArrayToProcess"
                                number_of_elements="5" element_types="0 0 0 0 2" animateable="0">
            <ArrayListDomain name="array_list" attribute_type="Scalars" input_domain_name="input_array">
              <RequiredProperties><Property name="Input" function="Input"/></RequiredProperties>
            </ArrayListDomain>
            <Documentation>The point or cell array to render.</Documentation>
          </StringVectorProperty>""")
        def SetInputArrayToProcess(self, idx, port, connection, field, name):
            return super().SetInputArrayToProcess(idx, port, connection, field, name)

        @smproperty.intvector(name="ImageSize", label="Image Size", default_values=[512, 512])
        @smdomain.intrange(min=1, max=8192)
        def SetImageSize(self, width, height):
            def apply():
                HDRVolumeRenderer.SetImageSize(self, width, height)
                self._push_lens()  # its centre and radius are fractions of the image

            _setting(self, "Image Size", apply)

        # -- the lens (image data) ------------------------------------------------------
        @smproperty.stringvector(name="Lens", default_values="none", number_of_elements=1)
        @smdomain.xml(_string_list(LENSES) + _documentation(
            "A magic lens (image data only): magnifier (Lens Center, Lens Radius, Lens Magnification) or "
            "fisheye (Fisheye Field Of View), as pv_hdrvol.Magnifier and pv_hdrvol.Fisheye."))
        def SetLensName(self, value):
            if value not in LENSES:
                raise ValueError(f"Lens must be one of {list(LENSES)}; got {value!r}")
            self._lens_settings["name"] = value
            self._push_lens()

        @smproperty.doublevector(name="LensCenter", label="Lens Center", default_values=[0.5, 0.5],
                                 panel_visibility="advanced")
        @smdomain.xml(_documentation("The magnifier's centre as fractions of the image width and height "
                                     "(0, 0: top left)."))
        def SetLensCenter(self, x, y):
            self._lens_settings["center"] = (x, y)
            self._push_lens()

        @smproperty.doublevector(name="LensRadius", label="Lens Radius", default_values=0.25,
                                 panel_visibility="advanced")
        @smdomain.doublerange(min=0.01, max=1.0)
        def SetLensRadius(self, value):
            self._lens_settings["radius"] = value
            self._push_lens()

        @smproperty.doublevector(name="LensMagnification", label="Lens Magnification", default_values=2.0,
                                 panel_visibility="advanced")
        @smdomain.doublerange(min=0.1, max=16.0)
        def SetLensMagnification(self, value):
            self._lens_settings["factor"] = value
            self._push_lens()

        @smproperty.doublevector(name="FisheyeFieldOfView", label="Fisheye Field Of View", default_values=180.0,
                                 panel_visibility="advanced")
        @smdomain.doublerange(min=1.0, max=360.0)
        def SetFisheyeFieldOfView(self, value):
            self._lens_settings["fov_degrees"] = value
            self._push_lens()

        def _push_lens(self):
            lens = self._lens_settings
            if lens["name"] == "none":
                HDRVolumeRenderer.SetLens(self, None)
                return
            if lens["name"] == "fisheye":
                made = pv_hdrvol.Fisheye(fov_degrees=lens["fov_degrees"])
            else:
                width, height = self.GetImageSize()
                made = pv_hdrvol.Magnifier(center=(lens["center"][0] * width, lens["center"][1] * height),
                                           radius=lens["radius"] * min(width, height), factor=lens["factor"])
            if made != self.GetLens():  # lenses compare by their fields: re-execute only for a new one
                HDRVolumeRenderer.SetLens(self, made)

        # -- render options (RenderOptions' names) ---------------------------------
        @smproperty.doublevector(name="Tolerance", default_values=0.0)
        @smdomain.doublerange(min=0.0, max=0.5)
        @smdomain.xml(_documentation(
            "Say the accuracy instead of Step and Precision. 0 (default): off, Step and Precision render as set. "
            "A positive value, e.g. 0.001: the RMS error you accept, relative to the image's peak (at most 0.5); "
            "the renderer chooses the step, early termination, table size and precision that meet it, and Step "
            "and Precision are not used (kept for when Tolerance is 0 again). The choices and the estimated error "
            "are in the output's field data (hdrvol_metadata, its 'tolerance' entry)."))
        def SetTolerance(self, value):
            def apply():
                if value:  # a negative or too large tolerance is refused, not taken for "off"
                    pv_hdrvol.RenderOptions(tolerance=value)
                self._tolerance = value
                self._push_knobs()

            _setting(self, "Tolerance", apply)

        @smproperty.stringvector(name="Precision", default_values="float32", number_of_elements=1)
        @smdomain.xml(_string_list(PRECISIONS) + _documentation(
            "Compositing arithmetic. Not used while Tolerance is on (the renderer chooses it)."))
        def SetPrecision(self, value):
            pv_hdrvol.RenderOptions(precision=value)  # refused now, whether Tolerance is on or not
            self._knobs["precision"] = value
            self._push_knobs()

        @smproperty.doublevector(name="Step", default_values=0.5)
        @smdomain.doublerange(min=0.01, max=4.0)
        @smdomain.xml(_documentation(
            "Distance between samples, in voxels of the smallest spacing. Not used while Tolerance is on (the "
            "renderer chooses it)."))
        def SetStep(self, value):
            pv_hdrvol.RenderOptions(step=value)  # refused now, whether Tolerance is on or not
            self._knobs["step"] = value
            self._push_knobs()

        def _push_knobs(self):
            """Step and Precision, or only Tolerance (the knobs at their defaults): one
            RenderOptions, so that the two never conflict whatever order ParaView pushes
            them in."""
            from pv_hdrvol.params import TOLERANCE_KNOBS

            if self._tolerance > 0:
                defaults = pv_hdrvol.RenderOptions()
                knobs = {name: getattr(defaults, name) for name in TOLERANCE_KNOBS}
                knobs["tolerance"] = self._tolerance
            else:
                knobs = dict(self._knobs, tolerance=None)
            HDRVolumeRenderer.SetOptions(self, self.GetOptions().replace(**knobs))

        @smproperty.doublevector(name="GlobalAlpha", label="Global Alpha", default_values=1.0)
        @smdomain.doublerange(min=0.0, max=1.0)
        def SetGlobalAlpha(self, value):
            super().SetGlobalAlpha(value)

        @smproperty.doublevector(name="OpacityUnitDistance", label="Opacity Unit Distance", default_values=0.0)
        @smdomain.xml(_documentation("World length over which a transfer-function opacity is reached; "
                                     "0: the smallest grid spacing (mean edge length of a mesh)."))
        def SetOpacityUnitDistance(self, value):
            super().SetOpacityUnitDistance(None if value <= 0 else value)

        @smproperty.stringvector(name="Blending", default_values="composite", number_of_elements=1)
        @smdomain.xml(_string_list(BLENDINGS))
        def SetBlending(self, value):
            super().SetBlending(value)

        @smproperty.stringvector(name="Device", default_values="cpu", number_of_elements=1, panel_visibility="advanced")
        @smdomain.xml(_string_list(DEVICES) + _documentation(
            "Where an image volume renders: cpu (default), or cuda: the same kernels on an NVIDIA GPU through "
            "numba-cuda (pip install 'pv_hdrvol[gpu]' into ParaView's Python). float32/float64, no labels, uniform "
            "grids in memory; a machine without a GPU says what is missing."))
        def SetDevice(self, value):
            super().SetDevice(value)

        @smproperty.intvector(name="Shade", default_values=0)
        @smdomain.xml('<BooleanDomain name="bool"/>')
        def SetShade(self, value):
            super().SetShade(value)

        @smproperty.doublevector(name="Ambient", default_values=0.1, panel_visibility="advanced")
        @smdomain.doublerange(min=0.0, max=1.0)
        def SetAmbient(self, value):
            super().SetAmbient(value)

        @smproperty.doublevector(name="Diffuse", default_values=0.7, panel_visibility="advanced")
        @smdomain.doublerange(min=0.0, max=1.0)
        def SetDiffuse(self, value):
            super().SetDiffuse(value)

        @smproperty.doublevector(name="Specular", default_values=0.2, panel_visibility="advanced")
        @smdomain.doublerange(min=0.0, max=1.0)
        def SetSpecular(self, value):
            super().SetSpecular(value)

        @smproperty.doublevector(name="SpecularPower", label="Specular Power", default_values=10.0,
                                 panel_visibility="advanced")
        @smdomain.doublerange(min=1.0, max=128.0)
        def SetSpecularPower(self, value):
            super().SetSpecularPower(value)

        # -- the transfer function ------------------------------------------------
        # The panel's groups: a PropertyGroup must follow the properties it names, and the
        # decorators write properties in the order of their methods' names, so the groups
        # are in the XML of the last method (SetTransferFunctionSource)
        @smproperty.xml(f"""
          <StringVectorProperty name="TransferFunction" label="Transfer Function"
                                command="SetTransferFunctionSource" number_of_elements="1"
                                default_values="{TRANSFER_FUNCTIONS[0]}" panel_visibility="advanced">
            {_string_list(TRANSFER_FUNCTIONS)}
            {_documentation("Color Map Editor: the colour map and opacity ParaView has for the array (its log "
                            "scale too), followed when edited. pv_hdrvol default: chosen from the data, shaped "
                            "by Cmap and Scale.")}
          </StringVectorProperty>
          {_GROUPS}""")
        def SetTransferFunctionSource(self, value):
            if value not in TRANSFER_FUNCTIONS:
                raise ValueError(f"Transfer Function must be one of {list(TRANSFER_FUNCTIONS)}; got {value!r}")
            self._tf_source = value
            self._push_transfer_function()

        @smproperty.xml("""
          <ProxyProperty name="LookupTable" label="Lookup Table" command="SetLookupTableProxy"
                         number_of_elements="1" panel_visibility="never">
            <ProxyGroupDomain name="groups"><Group name="lookup_tables"/></ProxyGroupDomain>
            <Documentation>ParaView's colour map (set by the plugin from the array's).</Documentation>
          </ProxyProperty>""")
        def SetLookupTableProxy(self, lut):
            self._lut = lut
            self._push_transfer_function()

        @smproperty.xml("""
          <ProxyProperty name="ScalarOpacityFunction" label="Scalar Opacity Function"
                         command="SetScalarOpacityFunctionProxy" number_of_elements="1" panel_visibility="never">
            <ProxyGroupDomain name="groups"><Group name="piecewise_functions"/></ProxyGroupDomain>
            <Documentation>ParaView's opacity function (set by the plugin from the array's).</Documentation>
          </ProxyProperty>""")
        def SetScalarOpacityFunctionProxy(self, function):
            self._opacity_function = function
            self._push_transfer_function()

        @smproperty.stringvector(name="Cmap", default_values="", number_of_elements=1, panel_visibility="advanced")
        @smdomain.xml(_documentation("pv_hdrvol default only: a matplotlib colormap name (empty: magma)."))
        def SetCmapName(self, value):
            self._cmap = value or None
            self._push_transfer_function()

        @smproperty.stringvector(name="Scale", default_values="auto", number_of_elements=1, panel_visibility="advanced")
        @smdomain.xml(_string_list(SCALES) + _documentation("pv_hdrvol default only: the axis of the "
                                                            "transfer function (auto: chosen from the data)."))
        def SetScaleName(self, value):
            self._scale = None if value == "auto" else value
            self._push_transfer_function()

        def _push_transfer_function(self):
            default = self._tf_source == TRANSFER_FUNCTIONS[1]
            lut = None if default else self._lut
            HDRVolumeRenderer.SetLookupTable(self, lut)
            HDRVolumeRenderer.SetScalarOpacityFunction(self, None if lut is None else self._opacity_function)
            HDRVolumeRenderer.SetCmap(self, self._cmap if default else None)
            HDRVolumeRenderer.SetScale(self, self._scale if default else None)

        # -- visibility culling -----------------------------------------------------
        @smproperty.stringvector(name="POFFile", label="POF File", default_values="", number_of_elements=1,
                                 panel_visibility="advanced")
        @smdomain.filelist()
        @smhint.filechooser(extensions="npz", file_description="plenoptic opacity functions")
        @smdomain.xml(_documentation(
            "Plenoptic opacity functions of the input (python -m pv_hdrvol.parallel pof): render the family "
            "of their bases, weighted by Family Weights, and skip the blocks they show hidden. Image data "
            "and a parallel projection only; the colour map is not used. Empty: no culling."))
        def SetPOFFile(self, value):
            self._pof_file = value or ""
            _setting(self, "POF File", self._push_culling)

        @smproperty.stringvector(name="FamilyWeights", label="Family Weights", default_values="",
                                 number_of_elements=1, panel_visibility="advanced")
        @smdomain.xml(_documentation("The weight k_i >= 0 of each basis of the POF File, comma-separated "
                                     "(empty: all 1)."))
        def SetFamilyWeights(self, value):
            self._pof_weights = value or ""
            _setting(self, "Family Weights", self._push_culling)

        def _push_culling(self):
            if not self._pof_file:
                HDRVolumeRenderer.SetCull(self, None)
                HDRVolumeRenderer.SetTransferFunction(self, None)
                return
            from pv_hdrvol import TransferFunction
            from pv_hdrvol.culling.pof import PlenopticOpacity

            if not os.path.isfile(self._pof_file):
                raise ValueError(f"POF File {self._pof_file!r} is not a file (python -m pv_hdrvol.parallel pof "
                                 f"writes one)")
            stamp = os.path.getmtime(self._pof_file)
            if self._pof is None or self._pof[:2] != (self._pof_file, stamp):
                self._pof = (self._pof_file, stamp, PlenopticOpacity.load(self._pof_file))
            pof = self._pof[2]
            text = self._pof_weights.replace(";", ",")
            weights = [float(x) for x in text.split(",") if x.strip()] or None
            HDRVolumeRenderer.SetTransferFunction(self, TransferFunction.family(pof.bases, weights))
            HDRVolumeRenderer.SetCull(self, pof)

        # -- the camera -------------------------------------------------------------
        @smproperty.stringvector(name="Camera", default_values="Render View", number_of_elements=1)
        @smdomain.xml(_string_list(CAMERA_MODES) + _documentation(
            "Render View: the camera properties below, which follow the active render view "
            "(Follow View); a view name frames the input."))
        def SetCameraMode(self, value):
            if value not in CAMERA_MODES:
                raise ValueError(f"Camera must be one of {list(CAMERA_MODES)}; got {value!r}")
            self._camera_mode = value
            self._push_camera()

        @smproperty.intvector(name="FollowView", label="Follow View", default_values=1, panel_visibility="advanced")
        @smdomain.xml('<BooleanDomain name="bool"/>' + _documentation(
            "Keep the camera properties equal to the active render view's (the one active when the filter "
            "was made, or when this is switched on): each render of the view renders its camera. Off: the "
            "camera stays where it is."))
        def SetFollowView(self, value):
            pass  # nothing for the filter: the client side (this plugin's hook) links and unlinks

        @smproperty.xml("""
          <IntVectorProperty name="ImageSizeFollowsView" command="SetImageSizeFollowsView" number_of_elements="1"
                             default_values="0" panel_visibility="never">
            <BooleanDomain name="bool"/>
            <Documentation>Set by the plugin when Image Size follows the view's size (kept in state files, so
            that a loaded state follows it again).</Documentation>
          </IntVectorProperty>""")
        def SetImageSizeFollowsView(self, value):
            pass  # nothing for the filter: the client side (this plugin's hook) links the size

        @smproperty.doublevector(name="CameraPosition", label="Camera Position", default_values=[0.0, 0.0, 0.0],
                                 panel_visibility="advanced")
        def SetCameraPosition(self, x, y, z):
            self._set_view_camera("position", (x, y, z))

        @smproperty.doublevector(name="CameraFocalPoint", label="Camera Focal Point",
                                 default_values=[0.0, 0.0, 0.0], panel_visibility="advanced")
        def SetCameraFocalPoint(self, x, y, z):
            self._set_view_camera("focal_point", (x, y, z))

        @smproperty.doublevector(name="CameraViewUp", label="Camera View Up", default_values=[0.0, 0.0, 1.0],
                                 panel_visibility="advanced")
        def SetCameraViewUp(self, x, y, z):
            self._set_view_camera("view_up", (x, y, z))

        @smproperty.doublevector(name="CameraViewAngle", label="Camera View Angle", default_values=30.0,
                                 panel_visibility="advanced")
        def SetCameraViewAngle(self, value):
            self._set_view_camera("view_angle", value)

        @smproperty.intvector(name="CameraParallelProjection", label="Camera Parallel Projection",
                              default_values=0, panel_visibility="advanced")
        @smdomain.xml('<BooleanDomain name="bool"/>')
        def SetCameraParallelProjection(self, value):
            self._set_view_camera("parallel_projection", bool(value))

        @smproperty.doublevector(name="CameraParallelScale", label="Camera Parallel Scale", default_values=1.0,
                                 panel_visibility="advanced")
        def SetCameraParallelScale(self, value):
            self._set_view_camera("parallel_scale", value)

        def _set_view_camera(self, field, value):
            self._view_camera[field] = value
            self._push_camera()

        def _push_camera(self):
            unset = self._view_camera["position"] == self._view_camera["focal_point"]
            if self._camera_mode != "Render View":
                HDRVolumeRenderer.SetCamera(self, self._camera_mode)
            elif unset:  # not linked to a view (yet): frame the input
                HDRVolumeRenderer.SetCamera(self, "iso")
            else:  # validated together when the filter executes
                HDRVolumeRenderer.SetCamera(self, dict(self._view_camera))

        # -- clipping: one plane and a crop box ------------------------------------
        # ParaView's own widgets: the implicit plane of Clip/Slice (InteractivePlane: Origin,
        # Normal, Input for the bounds) and the box of the volume representation's cropping
        # (InteractiveBox: Position and Scale; without Input in its group ParaView's box is
        # the unit box moved by Position and scaled by Scale, i.e. the world box from Crop
        # Origin to Crop Origin + Crop Length; with Input it would be relative to the
        # input's bounds, as the volume representation's cropping). A
        # PropertyGroup must follow the properties it names, and the decorators order
        # properties by method name: each group is in the XML of its group's last method.
        @smproperty.xml("""
          <IntVectorProperty name="Clip" command="SetClip" number_of_elements="1" default_values="0">
            <BooleanDomain name="bool"/>
            <Documentation>Cut the volume with the plane of Clip Origin and Clip Normal (the render view shows
            it as ParaView's interactive plane: drag it, or its normal arrow): the side the normal points to is
            kept, as in VTK's volume mappers (AddClippingPlane) and pv_hdrvol.RenderOptions(clip_planes=).
            Moving the plane re-renders without preparing the volume again.</Documentation>
          </IntVectorProperty>""")
        def SetClip(self, value):
            self._clip["on"] = bool(value)
            _setting(self, "Clip", self._push_clip)

        @smproperty.xml("""
          <DoubleVectorProperty name="ClipNormal" label="Clip Normal" command="SetClipNormal" number_of_elements="3"
                                default_values="1.0 0.0 0.0">
            <DoubleRangeDomain name="range"/>
            <Documentation>The clipping plane's normal (any length but 0): the side it points to is kept.
            Default +x.</Documentation>
          </DoubleVectorProperty>""")
        def SetClipNormal(self, x, y, z):
            self._clip["normal"] = (x, y, z)
            _setting(self, "Clip", self._push_clip)

        @smproperty.xml("""
          <DoubleVectorProperty name="ClipOrigin" label="Clip Origin" command="SetClipOrigin" number_of_elements="3"
                                default_values="0.0 0.0 0.0">
            <BoundsDomain name="range" mode="normal" default_mode="mid">
              <RequiredProperties><Property name="Input" function="Input"/></RequiredProperties>
            </BoundsDomain>
            <Documentation>A point of the clipping plane, in world coordinates. Default: the centre of the
            input's bounds.</Documentation>
          </DoubleVectorProperty>
          <PropertyGroup label="Clip Plane" panel_widget="InteractivePlane">
            <Property function="Origin" name="ClipOrigin"/>
            <Property function="Normal" name="ClipNormal"/>
            <Property function="Input" name="Input"/>
            <Hints>
              <PropertyWidgetDecorator type="GenericDecorator" mode="visibility" property="Clip" value="1"/>
            </Hints>
          </PropertyGroup>""")
        def SetClipOrigin(self, x, y, z):
            self._clip["origin"] = (x, y, z)
            _setting(self, "Clip", self._push_clip)

        def _push_clip(self):
            clip = self._clip
            # the plane's own checks (a zero normal is refused) only while Clip is on
            HDRVolumeRenderer.SetClippingPlanes(self, [(clip["origin"], clip["normal"])] if clip["on"] else None)

        @smproperty.xml("""
          <IntVectorProperty name="Crop" command="SetCrop" number_of_elements="1" default_values="0">
            <BooleanDomain name="bool"/>
            <Documentation>Keep only the axis-aligned box from Crop Origin to Crop Origin + Crop Length (the
            render view shows it as ParaView's interactive box: drag its faces), as
            pv_hdrvol.RenderOptions(crop_box=(xmin, xmax, ymin, ymax, zmin, zmax)).</Documentation>
          </IntVectorProperty>""")
        def SetCrop(self, value):
            self._crop["on"] = bool(value)
            _setting(self, "Crop", self._push_crop)

        @smproperty.xml("""
          <DoubleVectorProperty name="CropLength" label="Crop Length" command="SetCropLength" number_of_elements="3"
                                default_values="1.0 1.0 1.0">
            <BoundsDomain name="range" mode="component_magnitude" default_mode="max">
              <RequiredProperties><Property name="Input" function="Input"/></RequiredProperties>
            </BoundsDomain>
            <Documentation>The crop box's side lengths along x, y and z (each above 0). Default: the input's
            size, so that switching Crop on keeps everything until the box is moved.</Documentation>
          </DoubleVectorProperty>""")
        def SetCropLength(self, x, y, z):
            self._crop["length"] = (x, y, z)
            _setting(self, "Crop", self._push_crop)

        @smproperty.xml("""
          <DoubleVectorProperty name="CropOrigin" label="Crop Origin" command="SetCropOrigin" number_of_elements="3"
                                default_values="0.0 0.0 0.0">
            <BoundsDomain name="range" mode="normal" default_mode="min">
              <RequiredProperties><Property name="Input" function="Input"/></RequiredProperties>
            </BoundsDomain>
            <Documentation>The crop box's corner of least x, y and z, in world coordinates. Default: the input's
            lower bounds.</Documentation>
          </DoubleVectorProperty>
          <PropertyGroup label="Crop Box" panel_widget="InteractiveBox">
            <Property function="Position" name="CropOrigin"/>
            <Property function="Scale" name="CropLength"/>
            <Hints>
              <PropertyWidgetDecorator type="GenericDecorator" mode="visibility" property="Crop" value="1"/>
            </Hints>
          </PropertyGroup>""")
        def SetCropOrigin(self, x, y, z):
            self._crop["origin"] = (x, y, z)
            _setting(self, "Crop", self._push_crop)

        def _push_crop(self):
            crop = self._crop
            box = None
            if crop["on"]:
                (x, y, z), (lx, ly, lz) = crop["origin"], crop["length"]
                box = (x, x + lx, y, y + ly, z, z + lz)
            HDRVolumeRenderer.SetCropBox(self, box)

        # -- multiresolution stores (the store reader's output) -------------------------
        # shown only for a store (InputIsStore, set by the plugin when the filter is made)
        @smproperty.intvector(name="OutOfCore", label="Out Of Core", default_values=1)
        @smhint.xml(_FOR_STORES)
        @smdomain.xml('<BooleanDomain name="bool"/>' + _documentation(
            "For a level of a multiresolution store (*.ome.zarr, opened with pv_hdrvol's store reader): render "
            "the whole store out of core (pv_hdrvol.open_multiscale), with finer levels where the camera needs "
            "them and chunks read on demand, instead of the level in memory. Other inputs are not affected."))
        def SetOutOfCore(self, value):
            super().SetOutOfCore(bool(value))

        @smproperty.doublevector(name="ScreenError", label="Screen Error", default_values=1.0,
                                 panel_visibility="advanced")
        @smhint.xml(_FOR_STORES)
        @smdomain.doublerange(min=0.25, max=16.0)
        @smdomain.xml(_documentation("Out of core: the largest projected voxel, in pixels, a block of the "
                                     "store may show (smaller: finer levels, more reading)."))
        def SetScreenError(self, value):
            _setting(self, "Screen Error", lambda: HDRVolumeRenderer.SetScreenError(self, value))

        @smproperty.intvector(name="CacheSize", label="Cache Size", default_values=2048, panel_visibility="advanced")
        @smhint.xml(_FOR_STORES)
        @smdomain.intrange(min=64, max=262144)
        @smdomain.xml(_documentation("Out of core: the most memory, in MiB, for the store's chunks."))
        def SetCacheSize(self, mib):
            _setting(self, "Cache Size", lambda: HDRVolumeRenderer.SetCacheBytes(self, int(mib) * 2 ** 20))

        @smproperty.xml("""
          <IntVectorProperty name="InputIsStore" command="SetInputIsStore" number_of_elements="1"
                             default_values="0" panel_visibility="never">
            <BooleanDomain name="bool"/>
            <Documentation>Set by the plugin: the input is a multiresolution store's level (the
            out-of-core properties are shown only then).</Documentation>
          </IntVectorProperty>""")
        def SetInputIsStore(self, value):
            pass  # nothing for the filter: the store is found from the input when it executes

        # -- display ----------------------------------------------------------------
        @smproperty.stringvector(name="DisplayToneMap", label="Display Tone Map", default_values="knee",
                                 number_of_elements=1)
        @smdomain.xml(_string_list(TONEMAP_OPERATORS) + _documentation(
            "The operator of the 'tonemapped' array shown on screen (the HDR 'rgba' array is unchanged; "
            "HDR Tone Map gives every parameter). knee (default): the colour map's colours as ParaView's "
            "Volume representation shows them, compressed keeping their hue only above 0.8; reinhard, drago...: "
            "photographic mappings of the whole range, sRGB-encoded."))
        def SetDisplayToneMap(self, value):
            self._display.SetOperator(value)  # validates the name
            if value != self._display_operator:
                self._display_operator = value
                self.Modified()

        def _execute(self, inInfo, outInfo):
            _raise_refused(self)
            return super()._execute(inInfo, outInfo)

        def RequestData(self, request, inInfo, outInfo):
            from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPolyData

            if self._tf_source == TRANSFER_FUNCTIONS[0] and self._lut is None and not self._pof_file:
                _say_once(self, "HDR Volume Render: Transfer Function is 'Color Map Editor' but its Lookup Table "
                                "is not set (no colour map was found for the array when the filter was made), so "
                                "pv_hdrvol's default transfer function renders. Set LookupTable = "
                                "GetColorTransferFunction(array) and ScalarOpacityFunction = "
                                "GetOpacityTransferFunction(array), or Transfer Function = 'pv_hdrvol default'.")
            status = super().RequestData(request, inInfo, outInfo)

            out = vtkImageData.GetData(outInfo, 0)
            surface = vtkPolyData.GetData(outInfo, 1)
            surface.Initialize()
            if status and out.GetNumberOfPoints():
                self._display.SetInputDataObject(0, out)
                self._display.Update()
                out.ShallowCopy(self._display.GetOutputDataObject(0))
                self._display.SetInputDataObject(0, None)
                surface.ShallowCopy(_surface_of(out, self.GetLastCamera()))
            return status

    # ------------------------------------------------------------------------------
    # The client side: fill a new HDR Volume Render's camera and colour map from the
    # active view and the array's colour map, as ParaView's own representations do.
    #
    # Only the server manager's C++ objects are used here, on the session that
    # registered the filter; never ``paraview.simple`` or ``paraview.servermanager``.
    # servermanager takes the active session once, when first imported: imported by a
    # plugin that ParaView's GUI loads before its builtin session exists, it keeps no
    # session, and ``paraview.simple`` (the Python Shell's first line, or an observer
    # of ours) then runs ``Connect()``, making a second builtin session. Links made
    # there between proxies of the first crashed the GUI (Filters > pv_hdrvol > HDR
    # Volume Render, SIGSEGV in pqCore), and the Python Shell saw none of the pipeline.
    # ------------------------------------------------------------------------------
    # The views' own wrapping, before this plugin hands any view to Python: VTK wraps an
    # object once, as the most derived class its loaded modules know, and a render view
    # first met through a base-class pointer (the active-view selection, an iterator)
    # with this module not yet imported would stay a plain vtkSMProxy, also for the
    # Python Shell's paraview.simple (GetDisplayProperties: no FindRepresentation).
    from paraview.modules.vtkRemotingViews import vtkPVRenderView

    #: Filter (its _key) -> how it follows a view: {"view": the view's _key,
    #: "size": whether Image Size follows the view's size, "kept": the view's camera
    #: (and size) when a filter with a camera of its own was linked: that camera is kept
    #: until the view's moves away from it}. Not registered with the proxy manager (no
    #: Link Manager entry, nothing saved in state files: the plugin links again on load).
    _FOLLOWERS = {}
    #: View (its _key) -> {"interacting": a mouse interaction is under way}
    _VIEWS = {}
    #: Filter (its _key) -> the lookup table the plugin chose for it (followed when the
    #: filter's Scalars change); a table set by the user is never replaced.
    _AUTO_LUT = {}
    _seen = set()

    def _key(proxy):
        """What the plugin's bookkeeping knows a proxy by: its global ID and its address.
        The ID alone is not enough: a new session (Reset Session, then Load State)
        numbers its proxies from the start again, and a view or filter of it would be
        taken for the old one of the same ID (never observed, never followed). None for
        no proxy (an empty proxy property)."""
        if proxy is None:
            return None
        return f"{proxy.GetGlobalIDAsString()}@{proxy.GetAddressAsString('vtkObject')}"

    def _sm(proxy):
        """The vtkSMProxy of a ``servermanager`` proxy wrapper, or the proxy itself."""
        return getattr(proxy, "SMProxy", proxy)

    def _property(proxy, name):
        """The value of a vector property as a list, or a proxy property's first proxy."""
        prop = proxy.GetProperty(name)
        if prop is None:
            return None
        if prop.IsA("vtkSMProxyProperty"):
            return prop.GetProxy(0) if prop.GetNumberOfProxies() else None
        return [prop.GetElement(i) for i in range(prop.GetNumberOfElements())]

    def _set_proxy_property(proxy, name, value):
        prop = proxy.GetProperty(name)
        prop.RemoveAllProxies()
        if value is not None:
            prop.AddProxy(value)

    def _active_render_view(pxm):
        """The session's active view (what the GUI and paraview.simple call active), if a render view."""
        model = pxm.GetSelectionModel("ActiveView")
        view = model.GetCurrentProxy() if model is not None else None
        return view if view is not None and view.GetXMLName() == "RenderView" else None

    class _Bookkeeping:
        """Property changes the plugin makes for the user (a camera copied from the view,
        a colour map chosen) are not the user's: the GUI's undo stack does not record
        them (an "Undo Changed ..." entry after loading a state, or after each rotation,
        would undo the plugin's choice, not the user's)."""

        def __enter__(self):
            from paraview.modules.vtkRemotingServerManager import vtkSMProxyManager

            manager = vtkSMProxyManager.GetProxyManager()
            self.builder = manager.GetUndoStackBuilder() if manager is not None else None
            if self.builder is not None:
                self.before = self.builder.GetIgnoreAllChanges()
                self.builder.SetIgnoreAllChanges(True)
            return self

        def __exit__(self, *exc):
            if self.builder is not None:
                self.builder.SetIgnoreAllChanges(self.before)
            return False

    def _render_view(view):
        """The vtkPVRenderView of a render view proxy (its camera, its interactor). Not
        the proxy's own GetActiveCamera: a proxy first seen by Python through a base-class
        pointer (a selection model, an iterator) is wrapped as a plain vtkSMProxy."""
        return vtkPVRenderView.SafeDownCast(view.GetClientSideObject())

    def _view_camera(view):
        """The camera ``view`` renders with now, as HDR Volume Render's properties: the
        VTK camera itself, which ParaView's buttons (view direction, Reset Camera) and
        scripts (``GetActiveCamera().Azimuth(30)``) change before the view's camera
        properties catch up, after the render."""
        camera = _render_view(view).GetActiveCamera()
        return {"CameraPosition": list(camera.GetPosition()), "CameraFocalPoint": list(camera.GetFocalPoint()),
                "CameraViewUp": list(camera.GetViewUp()), "CameraViewAngle": [camera.GetViewAngle()],
                "CameraParallelProjection": [int(camera.GetParallelProjection())],
                "CameraParallelScale": [camera.GetParallelScale()]}

    def _copy_from_view(proxy, view, values, follow):
        """Set the filter's camera (and Image Size, if it follows) to ``values`` of
        ``view``; only properties that differ, so that an unchanged camera re-renders
        nothing. Whether anything changed."""
        size = _property(view, "ViewSize")
        if follow["size"] and min(size) >= 1:  # not a hidden view's 0 x 0
            values = dict(values, ImageSize=size)
        changed = False
        with _Bookkeeping():
            for name, value in values.items():
                if _property(proxy, name) != value:
                    prop = proxy.GetProperty(name)
                    for i, v in enumerate(value):
                        prop.SetElement(i, v)
                    changed = True
            if changed:
                proxy.UpdateVTKObjects()
        return changed

    def _before_render(pxm, view_gid):
        """A render of the view starts: give each filter that follows it the camera it
        renders with now, so that the picture is the final camera's (a view-direction
        button, Reset Camera, undo, a linked camera, an animation track, a loaded state
        all end in such a render). Not while the mouse moves the camera: the 'In View'
        surface, the picture at the volume's depth, turns with the view then, and the
        still render that ends the interaction renders the volume again."""
        if _VIEWS.get(view_gid, {}).get("interacting"):
            return
        views = _registered(pxm, "views")
        view = next((v for v in views if _key(v) == view_gid), None)
        if view is None:
            return
        alive = {_key(v) for v in views}
        if any(follow["view"] not in alive for follow in _FOLLOWERS.values()):
            _link_followers(pxm)  # filters whose view is gone follow the active one
        values = None
        for proxy in _filters(pxm):
            follow = _FOLLOWERS.get(_key(proxy))
            if follow is None or follow["view"] != view_gid:
                continue
            values = values or _view_camera(view)
            if follow["kept"] is not None:
                if follow["kept"] == (values, _property(view, "ViewSize")):
                    continue  # the filter's own camera (and size) until the view moves
                follow["kept"] = None
            try:
                _copy_from_view(proxy, view, values, follow)
            except Exception as exc:  # an observer must not break ParaView: say it, go on
                _say(f"could not give HDR Volume Render the view's camera ({type(exc).__name__}: {exc})")
        try:
            with _Bookkeeping():
                _data_legends(pxm, view)
        except Exception as exc:  # an observer must not break ParaView: say it, go on
            _say(f"could not show the data's colour legend ({type(exc).__name__}: {exc})")

    #: 'In View' representations whose pixel legend was replaced by the data's
    _LEGENDS = set()

    def _data_legends(pxm, view):
        """The legend of an 'In View' output would describe its pixels' colours (the
        'colors' array, 0-255), not data: where ParaView shows it in ``view`` (its "show
        color legend" setting, or the legend button), hide it and show the legend of the
        colour map the render follows, titled by the data array's name. Once per
        representation: what the user does with the legends afterwards stands."""
        from paraview.modules.vtkRemotingViews import vtkSMTransferFunctionManager

        in_view = view.GetProperty("Representations")
        members = {_key(in_view.GetProxy(i)) for i in range(in_view.GetNumberOfProxies())} if in_view else set()
        bars = [b for b in _registered(pxm, "scalar_bars") if _key(b) in members and _property(b, "Visibility")[0]]
        for representation in _registered(pxm, "representations"):
            gid = _key(representation)
            if gid not in _shown or gid in _LEGENDS or gid not in members:
                continue
            pixels = _key(_property(representation, "LookupTable"))
            shown = [b for b in bars if _key(_property(b, "LookupTable")) == pixels]
            source = representation.GetProperty("Input").GetProxy(0)
            data_lut = _property(source, "LookupTable")
            if not shown or pixels is None or data_lut is None:
                continue
            _LEGENDS.add(gid)
            for bar in shown:
                bar.GetProperty("Visibility").SetElement(0, 0)
                bar.UpdateVTKObjects()
            bar = vtkSMTransferFunctionManager().GetScalarBarRepresentation(data_lut, view)
            if bar is not None:
                bar.GetProperty("Title").SetElement(0, _array_of(source)[1])
                bar.GetProperty("ComponentTitle").SetElement(0, "")
                bar.GetProperty("Visibility").SetElement(0, 1)
                bar.UpdateVTKObjects()

    def _interaction(view_gid, interacting):
        _VIEWS.setdefault(view_gid, {})["interacting"] = interacting

    def _watch_view(pxm, view):
        """Observe ``view``'s renders and its mouse interactions, once per view."""
        gid = _key(view)
        if gid in _VIEWS:
            return
        _VIEWS[gid] = {"interacting": False}
        view.AddObserver("StartEvent", lambda *_: _before_render(pxm, gid))
        interactor = _render_view(view).GetInteractor()
        if interactor is not None:
            # before ParaView's own observer, whose still render ends the interaction
            interactor.AddObserver("StartInteractionEvent", lambda *_: _interaction(gid, True), 10.0)
            interactor.AddObserver("EndInteractionEvent", lambda *_: _interaction(gid, False), 10.0)

    def _link_camera(proxy, view, copy=True):
        """Make ``proxy``'s camera follow ``view``'s: from now (``copy``), or from the
        view's next move away from the camera it has now (a filter with a camera of its
        own: a state file's, a script's)."""
        gid = _key(proxy)
        # the image size follows the view's, so that each pixel of the view is one ray,
        # unless the user chose a size (not the default) when the filter was made; a
        # filter whose size followed (a state file's) follows again
        follow_size = bool(proxy.GetProperty("ImageSize").IsValueDefault()
                           or _property(proxy, "ImageSizeFollowsView")[0])
        with _Bookkeeping():
            proxy.GetProperty("ImageSizeFollowsView").SetElement(0, int(follow_size))
        _watch_view(proxy.GetSessionProxyManager(), view)
        follow = {"view": _key(view), "size": follow_size, "kept": None}
        _FOLLOWERS[gid] = follow
        if copy:
            _copy_from_view(proxy, view, _view_camera(view), follow)
        else:
            follow["kept"] = (_view_camera(view), _property(view, "ViewSize"))

    def _unlink_camera(proxy):
        _FOLLOWERS.pop(_key(_sm(proxy)), None)

    def follow_view(proxy, view=None):
        """Make an HDR Volume Render's camera follow ``view``'s (default the session's active
        render view) and use the colour map of its array; what the plugin does for each
        new filter. ``proxy`` and ``view``: ``paraview.simple`` proxies or vtkSMProxy."""
        proxy = _sm(proxy)
        view = _sm(view) if view is not None else _active_render_view(proxy.GetSessionProxyManager())
        if view is not None and view.GetXMLName() == "RenderView":
            _link_camera(proxy, view)
        _use_array_color_map(proxy)

    def _array_range(proxy, association, name):
        """The data range of the input's array ``name``, or None where not known."""
        inputs = proxy.GetProperty("Input")
        if inputs is None or not inputs.GetNumberOfProxies():
            return None
        info = inputs.GetProxy(0).GetDataInformation(inputs.GetOutputPortForConnection(0))
        attributes = info.GetCellDataInformation() if association == "1" else info.GetPointDataInformation()
        array = attributes.GetArrayInformation(name) if attributes is not None else None
        return None if array is None else array.GetComponentRange(0)

    def _array_of(proxy):
        """``(association, name)`` of the filter's Scalars ("0" points, "1" cells; "" no array)."""
        scalars = _property(proxy, "SelectInputScalars") or []
        return (scalars[3], scalars[4]) if len(scalars) == 5 else ("0", "")

    def _camera_unset(proxy):
        """Whether the filter's camera properties were never set (position == focal point)."""
        return _property(proxy, "CameraPosition") == _property(proxy, "CameraFocalPoint")

    def _use_array_color_map(proxy):
        """Set Lookup Table and Scalar Opacity Function to ParaView's for the filter's
        array (spanning the data if ParaView had no range yet), unless the user set them
        (not recorded on the undo stack: the plugin's choice, not the user's)."""
        with _Bookkeeping():
            _choose_array_color_map(proxy)

    def _choose_array_color_map(proxy):
        from paraview.modules.vtkRemotingViews import vtkSMTransferFunctionManager, vtkSMTransferFunctionProxy

        gid = _key(proxy)
        current = _property(proxy, "LookupTable")
        if current is not None and current is not _AUTO_LUT.get(gid):
            return  # the user's table
        association, name = _array_of(proxy)
        inputs = proxy.GetProperty("Input")
        if not name and inputs is not None and inputs.GetNumberOfProxies():
            # a script's input that has not run yet lists no arrays, so Scalars got no
            # default: run it (the render needs it anyway) and take the domain's default
            inputs.GetProxy(0).UpdatePipeline()
            proxy.UpdatePropertyInformation()
            selection = proxy.GetProperty("SelectInputScalars")
            domain = selection.GetDomain("array_list")
            if domain is not None:
                domain.Update(None)
            selection.ResetToDomainDefaults()
            proxy.UpdateVTKObjects()
            association, name = _array_of(proxy)
        if not name:
            return
        pxm = proxy.GetSessionProxyManager()
        manager = vtkSMTransferFunctionManager()
        lut = manager.GetColorTransferFunction(name, pxm)
        opacity = manager.GetOpacityTransferFunction(name, pxm)
        if lut is None or opacity is None:
            return
        if not _property(lut, "ScalarRangeInitialized")[0]:  # a new colour map: span the data, as ParaView does
            span = _array_range(proxy, association, name)
            if span is not None and span[0] <= span[1]:
                for function in (lut, opacity):
                    vtkSMTransferFunctionProxy.RescaleTransferFunction(function, span[0], span[1], False)
                lut.GetProperty("ScalarRangeInitialized").SetElement(0, 1)
                lut.UpdateVTKObjects()
        _set_proxy_property(proxy, "LookupTable", lut)
        _set_proxy_property(proxy, "ScalarOpacityFunction", opacity)
        _AUTO_LUT[gid] = lut
        proxy.UpdateVTKObjects()

    def _mark_store_input(proxy):
        """InputIsStore: whether the filter's input is pv_hdrvol's store reader (its
        out-of-core properties are shown then)."""
        inputs = proxy.GetProperty("Input")
        source = inputs.GetProxy(0) if inputs is not None and inputs.GetNumberOfProxies() else None
        store = int(source is not None and source.GetXMLName() == "MultiscaleStoreReader")
        if _property(proxy, "InputIsStore") != [store]:
            with _Bookkeeping():
                proxy.GetProperty("InputIsStore").SetElement(0, store)
                proxy.UpdateVTKObjects()

    def _say(text):
        from vtkmodules.vtkCommonCore import vtkOutputWindow

        vtkOutputWindow.GetInstance().DisplayWarningText(f"pv_hdrvol plugin: {text}\n")

    def _registered(pxm, group):
        """The proxies registered in ``pxm``'s session under ``group`` (a list: callers
        may register or unregister proxies while they go through it)."""
        from paraview.modules.vtkRemotingServerManager import vtkSMProxyIterator

        found = []
        iterator = vtkSMProxyIterator()
        iterator.SetSessionProxyManager(pxm)
        iterator.SetModeToOneGroup()
        iterator.Begin(group)
        while not iterator.IsAtEnd():
            if iterator.GetProxy() is not None:
                found.append(iterator.GetProxy())
            iterator.Next()
        return found

    def _filters(pxm):
        """The HDR Volume Render proxies registered in ``pxm``'s session."""
        return [proxy for proxy in _registered(pxm, "sources") if proxy.GetXMLName() == "HDRVolumeRender"]

    def _on_register(pxm, _event):
        """A proxy was registered in ``pxm``'s session: set up each new HDR Volume Render
        once, and each new representation of its 'In View' output."""
        try:
            _show_colors(pxm)
        except Exception as exc:  # an observer must not break ParaView: say it, go on
            _say(f"could not show HDR Volume Render's colours ({type(exc).__name__}: {exc}); colour its "
                 f"'In View' output by 'colors' with Map Scalars off")
        for proxy in _filters(pxm):
            gid = _key(proxy)
            if gid in _seen:
                continue
            _seen.add(gid)
            try:
                _mark_store_input(proxy)
                _use_array_color_map(proxy)
                # by the ID and the session, not the proxy itself: an observer on the proxy's
                # own property that held it would keep the deleted filter (and its plan) alive
                for name, react in (("FollowView", _follow_changed), ("SelectInputScalars", _scalars_changed)):
                    proxy.GetProperty(name).AddObserver(
                        "ModifiedEvent", lambda *_, g=gid, m=pxm, f=react: f(m, g))
            except Exception as exc:  # an observer must not break ParaView: say it, go on
                _say(f"could not give HDR Volume Render the colour map of its array "
                     f"({type(exc).__name__}: {exc}); set its Lookup Table by hand")
        _link_followers(pxm)  # the new filters' cameras follow the active render view

    def _link_followers(pxm, *_):
        """Link each filter that follows the view but has no view (just made; made
        before any render view; loaded from a state file before its view became active;
        its view deleted, as Load State replaces the views) to the session's active
        render view; a camera given when it was made is kept until the view moves."""
        _watch_active_view(pxm)
        view = _active_render_view(pxm)
        if view is None:
            return
        views = {_key(v) for v in _registered(pxm, "views")}
        for proxy in _filters(pxm):
            gid = _key(proxy)
            follow = _FOLLOWERS.get(gid)
            if gid in _seen and (follow is None or follow["view"] not in views) and _property(proxy, "FollowView")[0]:
                try:
                    _link_camera(proxy, view, copy=_camera_unset(proxy))
                except Exception as exc:  # an observer must not break ParaView
                    _say(f"could not link HDR Volume Render to the view ({type(exc).__name__}: {exc}); set its "
                         f"Camera by hand")

    def _watch_active_view(pxm):
        """Observe the session's active-view selection once it exists (the GUI and
        paraview.simple make it): a view made active later links waiting filters."""
        model = pxm.GetSelectionModel("ActiveView")
        key = ("active view", pxm.GetAddressAsString("vtkObject"))
        if model is not None and key not in _hooked:
            _hooked.add(key)
            model.AddObserver("CurrentChangedEvent", lambda *_: _link_followers(pxm))

    _shown = set()

    def _show_colors(pxm):
        """Representations of an 'In View' output draw its RGBA colours as they are (Map
        Scalars off, unlit): the image's own pixels, not a colour map or a shading of them."""
        for representation in _registered(pxm, "representations"):
            if not representation.IsA("vtkSMPVRepresentationProxy"):
                continue
            inputs = representation.GetProperty("Input")
            if inputs is None or not inputs.GetNumberOfProxies() or representation.GetProperty("MapScalars") is None:
                continue
            source = inputs.GetProxy(0)
            gid = _key(representation)
            if gid in _shown or source is None or source.GetXMLName() != "HDRVolumeRender" \
                    or inputs.GetOutputPortForConnection(0) != 1:
                continue
            _shown.add(gid)
            # the pixels' own colours (no colour map), unlit: ambient 1, diffuse 0, so that
            # the view's light kit does not shade the picture of a volume
            for name, value in (("MapScalars", 0), ("Ambient", 1.0), ("Diffuse", 0.0), ("Specular", 0.0)):
                representation.GetProperty(name).SetElement(0, value)
            representation.UpdateVTKObjects()

    def _on_unregister(pxm, _event):
        """Forget filters and views that are no longer registered."""
        alive = {_key(proxy) for proxy in _filters(pxm)}
        for gid in [g for g in _FOLLOWERS if g not in alive]:
            del _FOLLOWERS[gid]
        for gid in [g for g in _AUTO_LUT if g not in alive]:
            del _AUTO_LUT[gid]
        # a view's observers went with it: a new view at its address is observed again
        views = {_key(view) for view in _registered(pxm, "views")}
        for key in [k for k in _VIEWS if k not in views]:
            del _VIEWS[key]

    def _find(pxm, gid):
        return next((p for p in _filters(pxm) if _key(p) == gid), None)

    def _follow_changed(pxm, gid):
        proxy = _find(pxm, gid)
        if proxy is None:
            return
        _unlink_camera(proxy)
        view = _active_render_view(pxm)
        if _property(proxy, "FollowView")[0] and view is not None:
            _link_camera(proxy, view)

    def _scalars_changed(pxm, gid):
        proxy = _find(pxm, gid)
        if proxy is not None:
            _use_array_color_map(proxy)

    _hooked = set()

    def _install_client_hook(*_):
        """Observe proxy registrations of the active session, once per session: when the
        plugin loads, when the active session changes (pvpython's Connect(), a GUI
        connecting to a server) and when a filter is made."""
        try:  # not paraview.servermanager: see the note above
            from paraview.modules.vtkRemotingServerManager import vtkSMProxyManager
        except ImportError:
            return
        manager = vtkSMProxyManager.GetProxyManager()
        if manager is None:
            return
        if "manager" not in _hooked:
            _hooked.add("manager")
            manager.AddObserver(manager.ActiveSessionChanged, _install_client_hook)
        pxm = manager.GetActiveSessionProxyManager()
        if pxm is not None and pxm.GetAddressAsString("vtkObject") not in _hooked:
            _hooked.add(pxm.GetAddressAsString("vtkObject"))
            pxm.AddObserver("RegisterEvent", _on_register)
            pxm.AddObserver("UnRegisterEvent", _on_unregister)

    _install_client_hook()

    def _check_mpi_launch():
        """Say so when an mpiexec started several processes but ParaView runs as one: an
        mpiexec of another MPI than ParaView's (the MPICH of pip's mpi4py first on PATH,
        where Debian's ParaView uses Open MPI) starts independent serial processes, each
        rendering everything and writing the same files."""
        launched = next((int(os.environ[name]) for name in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE",
                                                            "MPI_LOCALNRANKS")
                         if os.environ.get(name, "").isdigit()), 1)
        if launched < 2:
            return
        from vtkmodules.vtkParallelCore import vtkMultiProcessController

        controller = vtkMultiProcessController.GetGlobalController()
        if controller is None or controller.GetNumberOfProcesses() == 1:
            _say(f"this process was started by an mpiexec of {launched} processes, but ParaView runs as one: that "
                 f"mpiexec is not the one of the MPI ParaView was built with (Debian's ParaView: Open MPI's "
                 f"/usr/bin/mpiexec; check `mpiexec --version`), or pvbatch lacks --mpi. Each process renders "
                 f"all of the data and they write the same files.")

    _check_mpi_launch()

    def _warm_in_background():
        """Compile the common variants (Shade, Tolerance, tetrahedra...) in a background
        process of ParaView's Python when numba's cache lacks them, so that their first
        use in the GUI loads them in about a second instead of compiling for half a
        minute (pv_hdrvol.integrations.warm; its log in the cache folder).
        ``PV_HDRVOL_WARM=0`` turns it off; one MPI rank starts it."""
        if os.environ.get("PV_HDRVOL_WARM", "1") == "0" or not os.environ.get("NUMBA_CACHE_DIR"):
            return
        rank = next((os.environ[n] for n in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK") if n in os.environ), "0")
        if rank != "0":
            return
        import shutil

        from pv_hdrvol.integrations.warm import start_in_background

        # ParaView runs Python embedded (sys.executable is vtkpython or paraview itself):
        # the interpreter of the same version beside it has the same numba
        version = f"python{sys.version_info[0]}.{sys.version_info[1]}"
        python = os.path.join(sys.base_prefix, "bin", version)
        python = python if os.access(python, os.X_OK) else shutil.which(version)
        if python is None:
            return
        try:
            start_in_background(os.environ["NUMBA_CACHE_DIR"], python=python)
        except OSError as exc:
            _say(f"could not start compiling the common variants in the background ({exc}); their first use "
                 f"compiles them")

    _warm_in_background()

    # --------------------------------------------------------------------------------
    @smproxy.filter(name="HDRToneMap", label="HDR Tone Map", support_reload=False)
    @smhint.xml('<ShowInMenu category="pv_hdrvol"/>')
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData"], composite_data_supported=False)
    class HDRToneMap(vtk_image.HDRToneMapper):
        """Tone map an HDR image (its ``rgba`` array) into a ``tonemapped`` uint8 RGB array."""

        @smproperty.stringvector(name="Operator", default_values="reinhard", number_of_elements=1)
        @smdomain.xml(_string_list(TONEMAP_OPERATORS))
        def SetOperatorName(self, value):
            _setting(self, "Operator", lambda: vtk_image.HDRToneMapper.SetOperator(self, value))

        @smproperty.stringvector(name="Encoding", default_values="auto", number_of_elements=1)
        @smdomain.xml(_documentation("auto (the operator's own: srgb, the gamma operator's gamma, linear for "
                                     "knee), srgb, linear, or a display gamma such as 2.2"))
        def SetEncodingText(self, value):
            if value in (None, "", "auto"):  # 5.11 pushes None for an empty string
                value = None
            else:
                try:
                    value = float(value)
                except ValueError:
                    pass
            self.SetEncoding(value)

        @smproperty.stringvector(name="Parameters", default_values="", number_of_elements=1)
        @smdomain.xml(_documentation(
            "The operator's parameters as name=value pairs separated by commas, as in hv.tonemap: "
            "exposure_stops=1, key=0.18, white=4, bias=0.85, saturation=0.8, sigma_range=0.4, ..."))
        def SetParameterText(self, text):
            _setting(self, "Parameters", lambda: self.SetParameters(_parse_parameters(text)))

        def _execute(self, inInfo, outInfo):
            _raise_refused(self)
            return super()._execute(inInfo, outInfo)

    @smproxy.filter(name="HDRUpsample", label="HDR Upsample", support_reload=False)
    @smhint.xml('<ShowInMenu category="pv_hdrvol"/>')
    @smproperty.input(name="Dataset", port_index=1)
    @smdomain.datatype(dataTypes=["vtkImageData", "vtkRectilinearGrid", "vtkStructuredGrid", "vtkUnstructuredGrid"],
                       composite_data_supported=True)
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData"], composite_data_supported=False)
    class HDRUpsample(vtk_image.HDRUpsampler):
        """Joint bilateral upsampling of a low-resolution HDR Volume Render output, guided by
        the depth layers of the dataset it rendered (port 1) at full resolution."""

        @smproperty.intvector(name="Factor", default_values=4)
        @smdomain.intrange(min=1, max=16)
        def SetFactor(self, value):
            super().SetFactor(value)

        @smproperty.stringvector(name="Method", default_values="joint_bilateral", number_of_elements=1)
        @smdomain.xml(_string_list(("joint_bilateral", "bilinear", "nearest")))
        def SetMethod(self, value):
            super().SetMethod(value)

    # --------------------------------------------------------------------------------
    @smproxy.reader(name="HDRImageReader", label="pv_hdrvol HDR image reader", extensions="exr hdr",
                    file_description="HDR images (OpenEXR, Radiance)", support_reload=False)
    class HDRImageReader(vtk_image.HDRImageReader):
        """An OpenEXR or Radiance image: its channels as point arrays."""

        @smproperty.stringvector(name="FileName")
        @smdomain.filelist()
        @smhint.filechooser(extensions="exr hdr", file_description="HDR images (OpenEXR, Radiance)")
        def SetFileName(self, name):
            if name and name != "None":  # ParaView 5.11 pushes "None" while it makes the proxy
                super().SetFileName(name)

    # A store is a directory: is_directory lets ParaView (5.10 and later) open a directory
    # named *.ome.zarr as one file (File > Open: select it and press OK, as Return
    # navigates into it; OpenDataFile). No UseDirectoryName hint: that would pass the
    # folder above the selection. The
    # reader's FileName may also name the store's zarr.json (it reads the folder), but
    # File > Open of a zarr.json does not offer this reader (a factory entry is either
    # for directories or for files).
    @smproxy.reader(name="MultiscaleStoreReader", label="pv_hdrvol multiresolution store reader",
                    extensions="ome.zarr", is_directory=True,
                    file_description="Multiresolution volumes (pv_hdrvol OME-Zarr)", support_reload=False)
    class MultiscaleStoreReader(vtk_multiscale.MultiscaleReader):
        """One level of a multiresolution store (*.ome.zarr) as image data; HDR Volume
        Render renders the whole store from it, out of core."""

        @smproperty.xml("""
          <StringVectorProperty name="FileName" command="SetFileName" number_of_elements="1"
                                panel_visibility="never">
            <FileListDomain name="files"/>
            <Documentation>The store: a directory *.ome.zarr (or its zarr.json).</Documentation>
          </StringVectorProperty>""")
        def SetFileName(self, name):
            if name and name != "None":  # ParaView 5.11 pushes "None" while it makes the proxy
                super().SetFileName(name)

        @smproperty.intvector(name="Level", default_values=-1)
        @smdomain.intrange(min=-1, max=30)
        @smdomain.xml(_documentation(
            "The level to load, 0 the finest (each next one halves every axis). -1 (default): the finest level "
            "with at most Max Points, so that opening never loads the whole volume. HDR Volume Render renders "
            "the whole store out of core whatever level is loaded."))
        def SetLevelNumber(self, level):
            _setting(self, "Level", lambda: vtk_multiscale.MultiscaleReader.SetLevel(self, None if level < 0 else level))

        @smproperty.intvector(name="MaxPoints", label="Max Points", default_values=64)
        @smdomain.intrange(min=1, max=4096)
        @smdomain.xml(_documentation("With Level -1: the most points, in Mi (2^20), of the level loaded."))
        def SetMaxMegaPoints(self, mega):
            _setting(self, "Max Points",
                     lambda: vtk_multiscale.MultiscaleReader.SetMaxPoints(self, int(mega) * 2 ** 20))

        def _execute(self, inInfo, outInfo):
            _raise_refused(self)
            return super()._execute(inInfo, outInfo)

    # supports_parallel: ParaView offers only such writers under MPI; rank 0 writes the
    # image (the others hold none)
    @smproxy.writer(extensions="exr", file_description="OpenEXR HDR image (pv_hdrvol)", support_reload=False,
                    supports_parallel="1")
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData"], composite_data_supported=False)
    class HDRExrWriter(vtk_image.HDRImageWriter):
        """The HDR ``rgba`` (and ``depth``, ``value``) arrays of a 2-D image as OpenEXR."""

        @smproperty.stringvector(name="FileName", panel_visibility="never")
        @smdomain.filelist()
        def SetFileName(self, name):
            if name and name != "None":  # ParaView 5.11 pushes "None" while it makes the proxy
                super().SetFileName(name)

        @smproperty.stringvector(name="PixelType", label="Pixel Type", default_values="float32",
                                 number_of_elements=1)
        @smdomain.xml(_string_list(("float32", "float16")))
        def SetPixelType(self, value):
            super().SetPixelType(value)

    # ParaView 5.11's own PNG writer is not parallel, so under MPI SaveData("x.png") found
    # no writer; this one writes the shown (tone-mapped) colours from rank 0
    @smproxy.writer(extensions="png", file_description="PNG of the shown tone map (pv_hdrvol)",
                    support_reload=False, supports_parallel="1")
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData"], composite_data_supported=False)
    class HDRPngWriter(vtk_image.HDRImageWriter):
        """The ``tonemapped`` colours of a 2-D image (HDR Volume Render's Display Tone
        Map, HDR Tone Map's output) as an 8-bit PNG; without them, the default display
        mapping of ``rgba``."""

        @smproperty.stringvector(name="FileName", panel_visibility="never")
        @smdomain.filelist()
        def SetFileName(self, name):
            if name and name != "None":  # ParaView 5.11 pushes "None" while it makes the proxy
                super().SetFileName(name)

    @smproxy.writer(extensions="hdr", file_description="Radiance HDR image (pv_hdrvol)", support_reload=False,
                    supports_parallel="1")
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData"], composite_data_supported=False)
    class HDRRadianceWriter(vtk_image.HDRImageWriter):
        """The HDR ``rgba`` array of a 2-D image as Radiance RGBE (.hdr)."""

        @smproperty.stringvector(name="FileName", panel_visibility="never")
        @smdomain.filelist()
        def SetFileName(self, name):
            if name and name != "None":  # ParaView 5.11 pushes "None" while it makes the proxy
                super().SetFileName(name)
