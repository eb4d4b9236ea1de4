"""pv_hdrvol for ParaView: HDR volume rendering as filters, and OpenEXR/Radiance files.

Load it once: Tools > Manage Plugins > Load New (this file), ``LoadPlugin(path,
ns=globals())`` in pvpython/pvbatch, or put this folder on ``PV_PLUGIN_PATH``. ParaView
5.11 on Python 3.11 (Debian bookworm) needs the ``getargspec`` shim of ``shim/``
on ``PYTHONPATH`` first: ``pv-hdrvol paraview`` prints the environment to use
(docs/paraview.md).

Filters: **HDR Volume Render** (image data or a tetrahedral unstructured grid -> a 2-D
image with the HDR ``rgba``, ``depth`` and a tone-mapped ``tonemapped`` array),
**HDR Tone Map**, **HDR Upsample**; a reader and writers for ``.exr`` and ``.hdr``.

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
    from pv_hdrvol.integrations import vtk_image
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
TONEMAP_OPERATORS = ("reinhard", "drago", "linear", "gamma", "durand", "fattal")
SCALES = ("auto", "linear", "log", "symlog")
LENSES = ("none", "magnifier", "fisheye")
#: The render view's camera properties, which HDR Volume Render has under the same names.
CAMERA_PROPERTIES = ("CameraPosition", "CameraFocalPoint", "CameraViewUp", "CameraViewAngle",
                     "CameraParallelProjection", "CameraParallelScale")


def _string_list(values, name="list"):
    strings = "".join(f'<String value="{v}"/>' for v in values)
    return f'<StringListDomain name="{name}">{strings}</StringListDomain>'


def _parse_parameters(text):
    """``"key=0.18, white=4, local=true"`` -> ``{"key": 0.18, "white": 4.0, "local": True}``."""
    parameters = {}
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


def _documentation(text):
    return f"<Documentation>{text}</Documentation>"


if HDRVolumeRenderer is not None:

    @smproxy.filter(name="HDRVolumeRender", label="HDR Volume Render", support_reload=False)
    @smhint.xml('<ShowInMenu category="pv_hdrvol"/>')
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData", "vtkUnstructuredGrid"], composite_data_supported=False)
    @smdomain.xml('<InputArrayDomain name="input_array" attribute_type="any" number_of_components="1"/>')
    class HDRVolumeRender(HDRVolumeRenderer):
        """Volume render image data or a tetrahedral mesh into an HDR image (pv_hdrvol)."""

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
            self._cmap = self._scale = None  # the default transfer function's keywords
            self._lut = None
            self._opacity_function = None
            self._pof_file, self._pof_weights = "", ""
            self._pof = None  # (path, modification time, PlenopticOpacity)
            self._display = vtk_image.HDRToneMapper()
            self._display_operator = "reinhard"
            self._push_camera()
            _install_client_hook()

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
            super().SetImageSize(width, height)
            self._push_lens()  # its centre and radius are fractions of the image

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

        @smproperty.doublevector(name="LensCenter", label="Lens Center", default_values=[0.5, 0.5])
        @smdomain.xml(_documentation("The magnifier's centre as fractions of the image width and height "
                                     "(0, 0: top left)."))
        def SetLensCenter(self, x, y):
            self._lens_settings["center"] = (x, y)
            self._push_lens()

        @smproperty.doublevector(name="LensRadius", label="Lens Radius", default_values=0.25)
        @smdomain.doublerange(min=0.01, max=1.0)
        def SetLensRadius(self, value):
            self._lens_settings["radius"] = value
            self._push_lens()

        @smproperty.doublevector(name="LensMagnification", label="Lens Magnification", default_values=2.0)
        @smdomain.doublerange(min=0.1, max=16.0)
        def SetLensMagnification(self, value):
            self._lens_settings["factor"] = value
            self._push_lens()

        @smproperty.doublevector(name="FisheyeFieldOfView", label="Fisheye Field Of View", default_values=180.0)
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
        @smproperty.stringvector(name="Precision", default_values="float32", number_of_elements=1)
        @smdomain.xml(_string_list(PRECISIONS))
        def SetPrecision(self, value):
            super().SetPrecision(value)

        @smproperty.doublevector(name="Step", default_values=0.5)
        @smdomain.doublerange(min=0.01, max=4.0)
        def SetStep(self, value):
            super().SetStep(value)

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

        @smproperty.intvector(name="Shade", default_values=0)
        @smdomain.xml('<BooleanDomain name="bool"/>')
        def SetShade(self, value):
            super().SetShade(value)

        @smproperty.doublevector(name="Ambient", default_values=0.1)
        @smdomain.doublerange(min=0.0, max=1.0)
        def SetAmbient(self, value):
            super().SetAmbient(value)

        @smproperty.doublevector(name="Diffuse", default_values=0.7)
        @smdomain.doublerange(min=0.0, max=1.0)
        def SetDiffuse(self, value):
            super().SetDiffuse(value)

        @smproperty.doublevector(name="Specular", default_values=0.2)
        @smdomain.doublerange(min=0.0, max=1.0)
        def SetSpecular(self, value):
            super().SetSpecular(value)

        @smproperty.doublevector(name="SpecularPower", label="Specular Power", default_values=10.0)
        @smdomain.doublerange(min=1.0, max=128.0)
        def SetSpecularPower(self, value):
            super().SetSpecularPower(value)

        # -- the transfer function ------------------------------------------------
        @smproperty.stringvector(name="TransferFunction", label="Transfer Function",
                                 default_values=TRANSFER_FUNCTIONS[0], number_of_elements=1)
        @smdomain.xml(_string_list(TRANSFER_FUNCTIONS) + _documentation(
            "Color Map Editor: the colour map and opacity ParaView has for the array (its log scale "
            "too), followed when edited. pv_hdrvol default: chosen from the data, shaped by Cmap and Scale."))
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

        @smproperty.stringvector(name="Cmap", default_values="", number_of_elements=1)
        @smdomain.xml(_documentation("pv_hdrvol default only: a matplotlib colormap name (empty: magma)."))
        def SetCmapName(self, value):
            self._cmap = value or None
            self._push_transfer_function()

        @smproperty.stringvector(name="Scale", default_values="auto", number_of_elements=1)
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
        @smproperty.stringvector(name="POFFile", label="POF File", default_values="", number_of_elements=1)
        @smdomain.filelist()
        @smhint.filechooser(extensions="npz", file_description="plenoptic opacity functions")
        @smdomain.xml(_documentation(
            "Plenoptic opacity functions of the input (python -m pv_hdrvol.parallel pof): render the family "
            "of their bases, weighted by Family Weights, and skip the blocks they show hidden. Image data "
            "and a parallel projection only; the colour map is not used. Empty: no culling."))
        def SetPOFFile(self, value):
            self._pof_file = value or ""
            self._push_culling()

        @smproperty.stringvector(name="FamilyWeights", label="Family Weights", default_values="",
                                 number_of_elements=1)
        @smdomain.xml(_documentation("The weight k_i >= 0 of each basis of the POF File, comma-separated "
                                     "(empty: all 1)."))
        def SetFamilyWeights(self, value):
            self._pof_weights = value or ""
            self._push_culling()

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
            "Render View: the camera properties below, which the plugin links to the active render view "
            "(Follow View); a view name frames the input."))
        def SetCameraMode(self, value):
            if value not in CAMERA_MODES:
                raise ValueError(f"Camera must be one of {list(CAMERA_MODES)}; got {value!r}")
            self._camera_mode = value
            self._push_camera()

        @smproperty.intvector(name="FollowView", label="Follow View", default_values=1)
        @smdomain.xml('<BooleanDomain name="bool"/>' + _documentation(
            "Keep the camera properties linked to the active render view (the one active when the filter "
            "was made, or when this is switched on): rotating the view re-renders. Off: the camera stays "
            "where it is."))
        def SetFollowView(self, value):
            pass  # nothing for the filter: the client side (this plugin's hook) links and unlinks

        @smproperty.doublevector(name="CameraPosition", label="Camera Position", default_values=[0.0, 0.0, 0.0])
        def SetCameraPosition(self, x, y, z):
            self._set_view_camera("position", (x, y, z))

        @smproperty.doublevector(name="CameraFocalPoint", label="Camera Focal Point",
                                 default_values=[0.0, 0.0, 0.0])
        def SetCameraFocalPoint(self, x, y, z):
            self._set_view_camera("focal_point", (x, y, z))

        @smproperty.doublevector(name="CameraViewUp", label="Camera View Up", default_values=[0.0, 0.0, 1.0])
        def SetCameraViewUp(self, x, y, z):
            self._set_view_camera("view_up", (x, y, z))

        @smproperty.doublevector(name="CameraViewAngle", label="Camera View Angle", default_values=30.0)
        def SetCameraViewAngle(self, value):
            self._set_view_camera("view_angle", value)

        @smproperty.intvector(name="CameraParallelProjection", label="Camera Parallel Projection",
                              default_values=0)
        @smdomain.xml('<BooleanDomain name="bool"/>')
        def SetCameraParallelProjection(self, value):
            self._set_view_camera("parallel_projection", bool(value))

        @smproperty.doublevector(name="CameraParallelScale", label="Camera Parallel Scale", default_values=1.0)
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

        # -- display ----------------------------------------------------------------
        @smproperty.stringvector(name="DisplayToneMap", label="Display Tone Map", default_values="reinhard",
                                 number_of_elements=1)
        @smdomain.xml(_string_list(TONEMAP_OPERATORS) + _documentation(
            "The operator of the 'tonemapped' array shown on screen (the HDR 'rgba' array is unchanged; "
            "HDR Tone Map gives every parameter)."))
        def SetDisplayToneMap(self, value):
            self._display.SetOperator(value)  # validates the name
            if value != self._display_operator:
                self._display_operator = value
                self.Modified()

        def RequestData(self, request, inInfo, outInfo):
            status = super().RequestData(request, inInfo, outInfo)
            from vtkmodules.vtkCommonDataModel import vtkImageData

            out = vtkImageData.GetData(outInfo)
            if status and out.GetNumberOfPoints():
                self._display.SetInputDataObject(0, out)
                self._display.Update()
                out.ShallowCopy(self._display.GetOutputDataObject(0))
                self._display.SetInputDataObject(0, None)
            return status

    # ------------------------------------------------------------------------------
    # The client side: fill a new HDR Volume Render's camera and colour map from the
    # active view and the array's colour map, as ParaView's own representations do.
    # ------------------------------------------------------------------------------
    def _link_camera(proxy, view):
        """Keep ``proxy``'s camera properties equal to ``view``'s (one link per pair)."""
        from paraview import servermanager

        pxm = servermanager.ProxyManager()
        for name in CAMERA_PROPERTIES:
            link = servermanager.vtkSMPropertyLink()
            link.AddLinkedProperty(view.SMProxy, name, 1)   # vtkSMLink::INPUT
            link.AddLinkedProperty(proxy.SMProxy, name, 2)  # vtkSMLink::OUTPUT
            pxm.RegisterLink(f"pv_hdrvol:{proxy.GetGlobalIDAsString()}:{name}", link)
            proxy.SMProxy.GetProperty(name).Copy(view.SMProxy.GetProperty(name))
        proxy.SMProxy.UpdateVTKObjects()

    def _unlink_camera(proxy):
        from paraview import servermanager

        pxm = servermanager.ProxyManager()
        for name in CAMERA_PROPERTIES:
            pxm.UnRegisterLink(f"pv_hdrvol:{proxy.GetGlobalIDAsString()}:{name}")

    def follow_view(proxy, view=None):
        """Link an HDR Volume Render's camera to ``view`` (default the active render view)
        and use the colour map of its array; what the plugin does for each new filter."""
        from paraview import simple

        view = view or simple.GetActiveView()
        if view is not None and view.GetXMLName() == "RenderView":
            _unlink_camera(proxy)
            _link_camera(proxy, view)
        _use_array_color_map(proxy)

    def _use_array_color_map(proxy):
        from paraview import simple

        if proxy.LookupTable is not None:
            return
        scalars = proxy.Scalars
        name = scalars[1] if len(scalars) > 1 else ""
        if not name:
            return
        lut = simple.GetColorTransferFunction(name)
        if not lut.ScalarRangeInitialized:  # a new colour map: span the data, as ParaView does
            info = proxy.Input.GetDataInformation().DataInformation
            array_info = (info.GetPointDataInformation() if scalars[0] == "POINTS"
                          else info.GetCellDataInformation()).GetArrayInformation(name)
            if array_info is not None:
                lo, hi = array_info.GetComponentRange(0)
                lut.RescaleTransferFunction(lo, hi)
                simple.GetOpacityTransferFunction(name).RescaleTransferFunction(lo, hi)
        proxy.LookupTable = lut
        proxy.ScalarOpacityFunction = simple.GetOpacityTransferFunction(name)

    _seen = set()

    def _on_register(*_):
        """A proxy was registered: set up each new HDR Volume Render once."""
        try:
            from paraview import simple
        except ImportError:  # a server process without the client's modules
            return
        for proxy in list(simple.GetSources().values()):
            if proxy.GetXMLName() != "HDRVolumeRender" or proxy.GetGlobalIDAsString() in _seen:
                continue
            _seen.add(proxy.GetGlobalIDAsString())
            try:
                camera_set = list(proxy.CameraPosition) != list(proxy.CameraFocalPoint)
                view = simple.GetActiveView()
                if not camera_set and proxy.FollowView and view is not None and view.GetXMLName() == "RenderView":
                    _link_camera(proxy, view)
                _use_array_color_map(proxy)
                # by its ID, not the proxy itself: an observer on the proxy's own property that
                # held it would keep the deleted filter (and its render plan) alive
                proxy.SMProxy.GetProperty("FollowView").AddObserver(
                    "ModifiedEvent", lambda *_, gid=proxy.GetGlobalIDAsString(): _follow_changed(gid))
            except Exception as exc:  # an observer must not break ParaView: say it, go on
                from vtkmodules.vtkCommonCore import vtkOutputWindow

                vtkOutputWindow.GetInstance().DisplayWarningText(
                    f"pv_hdrvol plugin: could not link HDR Volume Render to the view and the colour map "
                    f"({type(exc).__name__}: {exc}); set its Camera and Lookup Table by hand\n")

    def _follow_changed(gid):
        from paraview import simple

        proxy = next((p for p in simple.GetSources().values() if p.GetGlobalIDAsString() == gid), None)
        if proxy is None:
            return
        _unlink_camera(proxy)
        view = simple.GetActiveView()
        if proxy.FollowView and view is not None and view.GetXMLName() == "RenderView":
            _link_camera(proxy, view)

    _hooked = set()

    def _install_client_hook():
        """Observe proxy registrations of the active session, once per session. Called when
        the plugin loads and when a filter is made: a plugin on PV_PLUGIN_PATH loads
        before pvpython/pvbatch has a session."""
        try:
            from paraview import servermanager
        except ImportError:
            return
        pxm = servermanager.vtkSMProxyManager.GetProxyManager()
        session_pxm = pxm.GetActiveSessionProxyManager() if pxm is not None else None
        if session_pxm is not None and session_pxm.GetAddressAsString("vtkObject") not in _hooked:
            _hooked.add(session_pxm.GetAddressAsString("vtkObject"))
            session_pxm.AddObserver("RegisterEvent", _on_register)

    _install_client_hook()

    # --------------------------------------------------------------------------------
    @smproxy.filter(name="HDRToneMap", label="HDR Tone Map", support_reload=False)
    @smhint.xml('<ShowInMenu category="pv_hdrvol"/>')
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData"], composite_data_supported=False)
    class HDRToneMap(vtk_image.HDRToneMapper):
        """Tone map an HDR image (its ``rgba`` array) into a ``tonemapped`` uint8 RGB array."""

        @smproperty.stringvector(name="Operator", default_values="reinhard", number_of_elements=1)
        @smdomain.xml(_string_list(TONEMAP_OPERATORS))
        def SetOperator(self, value):
            super().SetOperator(value)

        @smproperty.stringvector(name="Encoding", default_values="srgb", number_of_elements=1)
        @smdomain.xml(_documentation("srgb, linear, or a display gamma such as 2.2"))
        def SetEncodingText(self, value):
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
            self.SetParameters(_parse_parameters(text))

    @smproxy.filter(name="HDRUpsample", label="HDR Upsample", support_reload=False)
    @smhint.xml('<ShowInMenu category="pv_hdrvol"/>')
    @smproperty.input(name="Dataset", port_index=1)
    @smdomain.datatype(dataTypes=["vtkImageData", "vtkUnstructuredGrid"], composite_data_supported=False)
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

    @smproxy.writer(extensions="exr", file_description="OpenEXR HDR image (pv_hdrvol)", support_reload=False)
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

    @smproxy.writer(extensions="hdr", file_description="Radiance HDR image (pv_hdrvol)", support_reload=False)
    @smproperty.input(name="Input", port_index=0)
    @smdomain.datatype(dataTypes=["vtkImageData"], composite_data_supported=False)
    class HDRRadianceWriter(vtk_image.HDRImageWriter):
        """The HDR ``rgba`` array of a 2-D image as Radiance RGBE (.hdr)."""

        @smproperty.stringvector(name="FileName", panel_visibility="never")
        @smdomain.filelist()
        def SetFileName(self, name):
            if name and name != "None":  # ParaView 5.11 pushes "None" while it makes the proxy
                super().SetFileName(name)
