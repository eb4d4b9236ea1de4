"""VTK pipeline algorithms for HDR images: tone map, read, write, upsample.

Pure VTK + numpy + pv_hdrvol (no ParaView, no PyVista import), so that a ParaView
plugin can wrap them with decorators only and they run under ParaView's own Python.
The numerics stay in :mod:`pv_hdrvol.image`; these are thin adapters.

Images are the 2-D ``vtkImageData`` of :meth:`HDRImage.to_vtk
<pv_hdrvol.HDRImage.to_vtk>`: point arrays ``"rgba"`` (4 components, linear
premultiplied), ``"depth"`` and optionally ``"value"``, the metadata as JSON in field
data, VTK row order (row 0 at the bottom; :meth:`HDRImage.from_pyvista
<pv_hdrvol.HDRImage.from_pyvista>` flips the rows back).

The conventions are :class:`~pv_hdrvol.integrations.vtk_algorithm.HDRVolumeRenderer`'s:
VTK-style ``Set``/``Get`` methods validate what can be validated alone at once and call
``Modified()`` only when the value changes; what must be validated together is
validated in ``RequestData``, whose errors fail the update, are written to the VTK
output window in VTK's format and are kept for ``GetLastError()``.
"""
from __future__ import annotations

import numbers
import os

import numpy as np
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.vtkCommonCore import VTK_UNSIGNED_CHAR
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkDataSet, vtkImageData
from vtkmodules.vtkCommonExecutionModel import vtkAlgorithm, vtkStreamingDemandDrivenPipeline

from .._validate import as_choice, as_int, as_real
from ..image.hdr import HDRImage
from ..image.io import EXR_MAGIC, EXR_TYPES
from ..image.tonemap import OPERATORS, display_encoding, make_operator, tonemap
from ..image.upsample import GUIDES, METHODS, SPATIAL, upsample
from .vtk_base import ReportingAlgorithm, request_whole_extent

_SDDP = vtkStreamingDemandDrivenPipeline

#: File name extensions :class:`HDRImageReader` reads (those of :func:`pv_hdrvol.load`).
READ_EXTENSIONS = (".exr", ".hdr", ".npy")
#: File name extensions :class:`HDRImageWriter` writes (those of :meth:`HDRImage.save`).
WRITE_EXTENSIONS = (".exr", ".hdr", ".npy", ".png")

#: OpenEXR channels :func:`pv_hdrvol.load` returns (as ``rgba``, ``depth``, ``value``).
_LOADED_CHANNELS = frozenset("RGBAZV")
#: The first bytes of each format :class:`HDRImageReader` reads.
_MAGICS = {".exr": (EXR_MAGIC,), ".hdr": (b"#?RADIANCE", b"#?RGBE"), ".npy": (b"\x93NUMPY",)}


class _ImageOutput:
    """``GetOutput()`` as image algorithms have it."""

    def GetOutput(self, port=0):
        """The output ``vtkImageData`` (``GetOutputDataObject(port)``)."""
        return self.GetOutputDataObject(port)


def _set_whole_extent(info, cols, rows):
    info.Set(_SDDP.WHOLE_EXTENT(), 0, cols - 1, 0, rows - 1, 0, 0)
    info.Set(vtkDataObject.SPACING(), 1.0, 1.0, 1.0)
    info.Set(vtkDataObject.ORIGIN(), 0.0, 0.0, 0.0)


def _empty_on_another_rank(inInfo, port):
    """Whether input ``port`` is empty on an MPI rank other than 0: where HDR Volume
    Render puts no image (rank 0 holds the whole one), the filters after it output an
    empty image and the writers write nothing, as VTK's parallel pipelines do."""
    image = vtkDataObject.GetData(inInfo[port])
    if image is not None and image.GetNumberOfPoints():
        return False
    from vtkmodules.vtkParallelCore import vtkMultiProcessController

    controller = vtkMultiProcessController.GetGlobalController()
    return controller is not None and controller.GetNumberOfProcesses() > 1 and controller.GetLocalProcessId() != 0


def _image_on(inInfo, port, who):
    """The 2-D, non-empty ``vtkImageData`` on input ``port``; ``(image, cols, rows)``."""
    image = vtkImageData.GetData(inInfo[port])
    if image is None or image.GetNumberOfPoints() == 0:
        raise ValueError(f"{who} needs a non-empty vtkImageData on input port {port}; got "
                         f"{'nothing' if image is None else 'an empty ' + image.GetClassName()}")
    cols, rows, depth = image.GetDimensions()
    if depth != 1:
        raise ValueError(f"{who} needs a 2-D image (z dimension 1) on input port {port}; got dimensions "
                         f"{image.GetDimensions()}")
    return image, cols, rows


def _point_array_names(image):
    pd = image.GetPointData()
    return [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())]


def _same(a, b):
    """Equal values of the same type (1 and 1.0 or True and 1 differ: an operator may
    validate them differently)."""
    if type(a) is not type(b):
        return False
    try:
        return bool(a == b)
    except ValueError:  # arrays: compared element-wise, without one truth value
        return False


def _check_file_name(path):
    if path is None:
        return None
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"the file name must be a str or os.PathLike, or None; got {type(path).__name__}")
    return os.fspath(path)


# -- tone mapping ----------------------------------------------------------------------------------
class HDRToneMapper(_ImageOutput, ReportingAlgorithm):
    """Tone map a 2-D HDR ``vtkImageData`` into 8-bit display colours.

    Input port 0: a 2-D ``vtkImageData`` (the layout of :meth:`HDRImage.to_vtk
    <pv_hdrvol.HDRImage.to_vtk>`, e.g. :class:`HDRVolumeRenderer
    <pv_hdrvol.integrations.vtk_algorithm.HDRVolumeRenderer>`'s output). Output: a
    shallow copy of the input (every array kept) plus the uint8 3-component point array
    ``"tonemapped"``, the active scalars, so that ParaView (with *Map Scalars* off)
    shows it as colours and ``vtkPNGWriter`` saves it. It is
    ``pv_hdrvol.tonemap(image, operator, encoding=encoding, **parameters).rgb8`` of the
    input, rows in VTK order, bit for bit.

    Properties: :meth:`SetOperator` (default ``"reinhard"``), :meth:`SetEncoding`
    (``None``: the operator's own, sRGB for most), :meth:`SetParameter` / :meth:`SetParameters` (the operator's
    parameters, none by default), :meth:`SetRGBAArray` (``None``: ``"rgba"`` if the
    input has it, else the active scalars). The parameters are checked against the
    operator in ``RequestData`` (by :func:`~pv_hdrvol.image.tonemap.make_operator`),
    since either may change first.

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> image = hv.HDRImage(np.full((2, 3, 4), 0.25, np.float32)).to_vtk()
    >>> mapper = HDRToneMapper()
    >>> mapper.SetInputDataObject(image)
    >>> mapper.SetOperator("linear")
    >>> mapper.SetParameter("exposure_stops", 1.0)
    >>> mapper.SetEncoding("linear")
    >>> mapper.Update()
    True
    >>> out = mapper.GetOutput().GetPointData().GetScalars()
    >>> out.GetName(), out.GetNumberOfComponents(), out.GetTuple3(0)
    ('tonemapped', 3, (128.0, 128.0, 128.0))
    """

    def __init__(self):
        super().__init__(nInputPorts=1, inputType="vtkImageData", nOutputPorts=1, outputType="vtkImageData")
        self._operator = "reinhard"
        self._encoding = None
        self._parameters = {}
        self._rgba_array = None

    def SetOperator(self, name):
        """The tone-mapping operator: a name of :data:`pv_hdrvol.image.tonemap.OPERATORS`
        (``"linear"``, ``"gamma"``, ``"knee"``, ``"reinhard"``, ``"drago"``, ``"durand"``, ``"fattal"``)."""
        if not isinstance(name, str) or name not in OPERATORS:
            raise ValueError(f"operator must be one of {sorted(OPERATORS)}; got {name!r}")
        if name != self._operator:
            self._operator = name
            self.Modified()

    def GetOperator(self):
        """The operator's name."""
        return self._operator

    def SetEncoding(self, encoding):
        """Display encoding: ``"srgb"``, ``"linear"``, a gamma > 0 (``x**(1/gamma)``), or
        ``None``, the operator's own (:func:`~pv_hdrvol.image.tonemap.default_encoding`:
        sRGB, the ``"gamma"`` operator's gamma, linear for ``"knee"``), as
        :func:`pv_hdrvol.tonemap` does."""
        if encoding is not None and (isinstance(encoding, bool) or not isinstance(encoding, (str, numbers.Real))):
            raise TypeError(f"encoding must be 'srgb', 'linear', a gamma > 0 or None; got {encoding!r}")
        if encoding is not None:
            display_encoding(encoding)  # the one validation, tonemap's
        if encoding is not None and not isinstance(encoding, str):
            encoding = float(encoding)
        if not _same(encoding, self._encoding):
            self._encoding = encoding
            self.Modified()

    def GetEncoding(self):
        """``"srgb"``, ``"linear"``, the gamma (float), or ``None`` (the operator's own)."""
        return self._encoding

    def SetParameter(self, name, value):
        """Set one parameter of the operator (``exposure_stops``, ``key``, ``bias``,
        ``saturation``...); ``value=None`` removes it (the operator's default). Checked
        against the operator at the next execution."""
        if not isinstance(name, str) or not name.isidentifier():
            raise TypeError(f"a parameter name must be a str (an identifier); got {name!r}")
        parameters = dict(self._parameters)
        if value is None:
            parameters.pop(name, None)
        else:
            parameters[name] = value
        self._replace_parameters(parameters)

    def SetParameters(self, parameters):
        """Replace all parameters by the dict ``parameters`` (entries ``None`` are left out)."""
        if not isinstance(parameters, dict):
            raise TypeError(f"parameters must be a dict {{name: value}}; got {type(parameters).__name__}")
        for name in parameters:
            if not isinstance(name, str) or not name.isidentifier():
                raise TypeError(f"a parameter name must be a str (an identifier); got {name!r}")
        self._replace_parameters({k: v for k, v in parameters.items() if v is not None})

    def _replace_parameters(self, parameters):
        if parameters.keys() != self._parameters.keys() or not all(
                _same(v, self._parameters[k]) for k, v in parameters.items()):
            self._parameters = parameters
            self.Modified()

    def GetParameters(self):
        """A copy of the parameters, ``{name: value}``."""
        return dict(self._parameters)

    def SetRGBAArray(self, name):
        """The point array to tone map (3 or 4 float components, linear, premultiplied
        if 4); ``None``: ``"rgba"`` if the input has it, else the active scalars."""
        if name is not None and not isinstance(name, str):
            raise TypeError(f"the RGBA array must be a point array name (str) or None; got {name!r}")
        if name != self._rgba_array:
            self._rgba_array = name
            self.Modified()

    def GetRGBAArray(self):
        """The array name set with :meth:`SetRGBAArray`, or ``None``."""
        return self._rgba_array

    def _pixels(self, image, cols, rows):
        """The array to tone map, (rows, cols, 3 or 4), row 0 at the top (a view)."""
        pd = image.GetPointData()
        name = self._rgba_array
        if name is None:
            if pd.GetArray("rgba") is not None:
                name = "rgba"
            elif pd.GetScalars() is not None and pd.GetScalars().GetName():
                name = pd.GetScalars().GetName()
            else:
                raise ValueError(f"the image has no point array 'rgba' and no active scalars; its point arrays: "
                                 f"{_point_array_names(image)} (choose one with SetRGBAArray)")
        arr = pd.GetArray(name)
        if arr is None:
            raise ValueError(f"the image has no point array {name!r}; its point arrays: {_point_array_names(image)}")
        n = arr.GetNumberOfComponents()
        if n not in (3, 4):
            raise ValueError(f"point array {name!r} has {n} component{'s' if n != 1 else ''}; tone mapping needs 3 "
                             f"(RGB) or 4 (RGBA)")
        values = vtk_to_numpy(arr)
        if not np.issubdtype(values.dtype, np.floating):
            raise TypeError(f"point array {name!r} holds {values.dtype}; tone mapping needs linear floats")
        return values.reshape(rows, cols, n)[::-1]

    def _execute(self, inInfo, outInfo):
        if _empty_on_another_rank(inInfo, 0):
            vtkImageData.GetData(outInfo).Initialize()
            return 1
        image, cols, rows = _image_on(inInfo, 0, "HDRToneMapper")
        pixels = self._pixels(image, cols, rows)
        operator = make_operator(self._operator, **self._parameters)  # the parameters meet the operator here
        self.UpdateProgress(0.0)
        rgb8 = tonemap(pixels, operator, encoding=self._encoding).rgb8
        colours = numpy_to_vtk(np.ascontiguousarray(rgb8[::-1].reshape(-1, 3)), deep=True)
        colours.SetName("tonemapped")
        out = vtkImageData.GetData(outInfo)
        out.ShallowCopy(image)  # the output's point data is its own: the input keeps its arrays
        out.GetPointData().AddArray(colours)
        out.GetPointData().SetActiveScalars("tonemapped")
        self.UpdateProgress(1.0)
        return 1


# -- files -----------------------------------------------------------------------------------------
class HDRImageReader(_ImageOutput, ReportingAlgorithm):
    """Read an HDR image file (``.exr``, ``.hdr``, ``.npy``) as a 2-D ``vtkImageData``.

    Reads as :func:`pv_hdrvol.load` does, and outputs :meth:`HDRImage.to_vtk
    <pv_hdrvol.HDRImage.to_vtk>`'s arrays (``"rgba"``, ``"depth"``, ``"value"`` where
    the file has it; the metadata in field data). An OpenEXR file's other channels,
    those :func:`pv_hdrvol.load` does not return (anything but ``R``, ``G``, ``B``,
    ``A``, ``Z``, ``V``), are added as point arrays named after the channel: float32
    (half channels widened), or uint32 for ``UINT`` channels (kept exact).

    The file is read once, in ``RequestInformation`` (which sets the whole extent), and
    kept while its path, modification time and size are unchanged, so ``RequestData``
    and later updates do not read it again.

    Examples
    --------
    >>> import os, tempfile, numpy as np, pv_hdrvol as hv
    >>> path = os.path.join(tempfile.mkdtemp(), "image.npy")
    >>> _ = hv.HDRImage(np.full((2, 3, 4), 0.5, np.float32)).save(path)
    >>> reader = HDRImageReader()
    >>> reader.CanReadFile(path)
    1
    >>> reader.SetFileName(path)
    >>> reader.Update()
    True
    >>> reader.GetOutput().GetDimensions()
    (3, 2, 1)
    """

    def __init__(self):
        super().__init__(nInputPorts=0, nOutputPorts=1, outputType="vtkImageData")
        self._file_name = None
        self._cache_key = None
        self._cache = None  # the vtkImageData of the file read last

    def SetFileName(self, path):
        """The file to read (``str`` or ``os.PathLike``; ``None``: none)."""
        path = _check_file_name(path)
        if path != self._file_name:
            self._file_name = path
            self.Modified()

    def GetFileName(self):
        """The file name set last, or ``None``."""
        return self._file_name

    def CanReadFile(self, path):
        """1 if ``path`` has an extension of :data:`READ_EXTENSIONS` and starts as a file
        of that format does, else 0 (never raises)."""
        try:
            path = os.fspath(path)
            magics = _MAGICS.get(os.path.splitext(path)[1].lower())
            if magics is None:
                return 0
            with open(path, "rb") as f:
                head = f.read(max(len(m) for m in magics))
        except (OSError, TypeError, ValueError):
            return 0
        return int(any(head.startswith(m) for m in magics))

    def RequestInformation(self, request, inInfo, outInfo):
        self._last_error = None
        return self._reporting(self._information, outInfo)

    def _information(self, outInfo):
        image = self._read()
        cols, rows, _ = image.GetDimensions()
        _set_whole_extent(outInfo.GetInformationObject(0), cols, rows)
        return 1

    def _read(self):
        """The cached ``vtkImageData`` of the file, read again only when it changed."""
        path = self._file_name
        if path is None:
            raise ValueError("HDRImageReader has no file to read: call SetFileName(path)")
        try:
            st = os.stat(path)
        except OSError:
            st = None
        if st is None:
            HDRImage.load(path)  # raises pv_hdrvol.load's own error for this path
            st = os.stat(path)
        key = (path, st.st_mtime_ns, st.st_size)
        if key != self._cache_key:
            self._cache, self._cache_key = None, None
            image = HDRImage.load(path).to_vtk()
            if os.path.splitext(path)[1].lower() == ".exr":
                _add_exr_channels(image, path)
            self._cache, self._cache_key = image, key
        return self._cache

    def _execute(self, inInfo, outInfo):
        vtkImageData.GetData(outInfo).ShallowCopy(self._read())
        return 1


def _add_exr_channels(image, path):
    """Add the EXR channels :func:`pv_hdrvol.load` does not return to ``image`` (a
    ``vtkImageData`` of :meth:`HDRImage.to_vtk`) as point arrays, rows flipped."""
    try:
        import OpenEXR
    except ImportError:  # pragma: no cover - pv_hdrvol.load has read the file with it
        return
    cols, rows, _ = image.GetDimensions()
    with OpenEXR.File(path, header_only=True) as f:
        names = [c.name for c in f.header()["channels"] if c.name not in _LOADED_CHANNELS]
    if not names:
        return
    with OpenEXR.File(path, separate_channels=True) as f:
        channels = f.channels()
        for name in names:
            pixels = np.asarray(channels[name].pixels)
            if pixels.shape != (rows, cols):
                raise ValueError(f"{path!r}: channel {name!r} has {pixels.shape[1]}x{pixels.shape[0]} pixels, the "
                                 f"image {cols}x{rows} (subsampled channels are not read)")
            dtype = np.uint32 if pixels.dtype == np.uint32 else np.float32
            arr = numpy_to_vtk(np.ascontiguousarray(pixels[::-1].reshape(-1), dtype=dtype), deep=True)
            arr.SetName(name)
            image.GetPointData().AddArray(arr)


class HDRImageWriter(ReportingAlgorithm):
    """Write a 2-D HDR ``vtkImageData`` to ``.exr``, ``.hdr``, ``.npy`` or ``.png``.

    Input port 0: the layout of :meth:`HDRImage.to_vtk <pv_hdrvol.HDRImage.to_vtk>`
    (a 4-component point array ``"rgba"``; ``"depth"``, ``"value"`` and the metadata
    where present). :meth:`Write` updates the input and writes
    ``HDRImage.from_pyvista(input).save(file_name, pixel_type)``: the extension picks
    the format (see :meth:`HDRImage.save <pv_hdrvol.HDRImage.save>`: ``.exr`` keeps
    everything, float32 bit for bit, with the metadata in its header; ``.hdr`` keeps
    RGB over black in 8-bit mantissas and the metadata; ``.npy`` keeps RGBA and depth
    in RGBA's type, no metadata; ``.png`` the input's ``"tonemapped"`` colours where it
    has them -- what ParaView shows, :class:`HDRToneMapper`'s or HDR Volume Render's
    Display Tone Map --, else the default 8-bit display mapping).

    Examples
    --------
    >>> import os, tempfile, numpy as np, pv_hdrvol as hv
    >>> path = os.path.join(tempfile.mkdtemp(), "image.npy")
    >>> writer = HDRImageWriter()
    >>> writer.SetInputDataObject(hv.HDRImage(np.full((2, 3, 4), 0.5, np.float32)).to_vtk())
    >>> writer.SetFileName(path)
    >>> writer.Write()
    1
    >>> float(hv.load(path).rgba[1, 2, 0])
    0.5
    """

    def __init__(self):
        super().__init__(nInputPorts=1, inputType="vtkImageData", nOutputPorts=0)
        self._file_name = None
        self._pixel_type = "float32"
        self._wrote = False

    def SetFileName(self, path):
        """The file to write (``str`` or ``os.PathLike``); its extension picks the format."""
        path = _check_file_name(path)
        if path is not None:
            ext = os.path.splitext(path)[1].lower()
            if ext not in WRITE_EXTENSIONS:
                raise ValueError(f"unknown image extension {ext!r}; use .exr, .hdr, .npy or .png")
        if path != self._file_name:
            self._file_name = path
            self.Modified()

    def GetFileName(self):
        """The file name set last, or ``None``."""
        return self._file_name

    def SetPixelType(self, pixel_type):
        """OpenEXR RGBA pixels: ``"float32"`` (default, exact) or ``"float16"`` (half);
        other formats ignore it."""
        as_choice("pixel_type", pixel_type, EXR_TYPES)
        if pixel_type != self._pixel_type:
            self._pixel_type = pixel_type
            self.Modified()

    def GetPixelType(self):
        """``"float32"`` or ``"float16"``."""
        return self._pixel_type

    def RequestUpdateExtent(self, request, inInfo, outInfo):
        # A writer has no output to carry a piece request: under MPI each process asks
        # for its own piece, as VTK's parallel writers do, so that HDR Volume Render
        # renders the pieces where they live and only piece 0 holds (and writes) the
        # image. Left at "piece 0 of 1", every process rendered the whole volume and
        # wrote the same file.
        from vtkmodules.vtkParallelCore import vtkMultiProcessController

        controller = vtkMultiProcessController.GetGlobalController()
        if controller is not None and controller.GetNumberOfProcesses() > 1:
            info = inInfo[0].GetInformationObject(0)
            info.Set(_SDDP.UPDATE_PIECE_NUMBER(), controller.GetLocalProcessId())
            info.Set(_SDDP.UPDATE_NUMBER_OF_PIECES(), controller.GetNumberOfProcesses())
        return 1

    def Write(self):
        """Update the input and write the file; 1 on success, 0 on failure (as VTK writers)."""
        self._wrote = False
        self.Modified()  # a writer writes at each call, as VTK's do
        self.Update()
        return 1 if self._wrote else 0

    def _execute(self, inInfo, outInfo):
        if self._file_name is None:
            raise ValueError("HDRImageWriter has no file to write: call SetFileName(path)")
        if _empty_on_another_rank(inInfo, 0):  # rank 0 writes the image
            return 1
        image, cols, rows = _image_on(inInfo, 0, "HDRImageWriter")
        self.UpdateProgress(0.0)
        shown = image.GetPointData().GetArray("tonemapped")
        if self._file_name.lower().endswith(".png") and shown is not None and shown.GetNumberOfComponents() == 3 \
                and shown.GetDataType() == VTK_UNSIGNED_CHAR:
            from ..image.io import write_png

            write_png(self._file_name, vtk_to_numpy(shown).reshape(rows, cols, 3)[::-1])  # rows top first
        else:
            HDRImage.from_pyvista(image).save(self._file_name, pixel_type=self._pixel_type)
        self._wrote = True
        self.UpdateProgress(1.0)
        return 1


# -- upsampling ------------------------------------------------------------------------------------
class HDRUpsampler(_ImageOutput, ReportingAlgorithm):
    """Upsample a low-resolution render, guided by the rendered dataset at full resolution.

    Input port 0: a render's image (the layout of :meth:`HDRImage.to_vtk
    <pv_hdrvol.HDRImage.to_vtk>`, from :class:`HDRVolumeRenderer
    <pv_hdrvol.integrations.vtk_algorithm.HDRVolumeRenderer>`, ``pv_hdrvol.render`` or
    a file they saved), whose metadata hold the render's settings (camera, transfer
    function, options). Input port 1: the dataset that was rendered, a tetrahedral
    ``vtkUnstructuredGrid`` or a ``vtkImageData``; optional for ``"bilinear"`` and
    ``"nearest"``, which need no guide. Output: the image ``factor`` times larger.

    ``RequestData`` computes, with the render's ``settings`` (:meth:`HDRImage.settings
    <pv_hdrvol.HDRImage.settings>`) and ``metadata``::

        layers = pv_hdrvol.depth_layers(dataset, settings.camera, (w * factor, h * factor),
                                        scalars=metadata["scalars"],
                                        preference=metadata.get("association", "point"),
                                        **extra)
        pv_hdrvol.upsample(image, layers, factor, method=..., guide=..., spatial=...,
                           support=..., sigma_range=...).to_vtk()

    where ``extra`` is empty for a mesh (the guide is its boundary) and, for an image
    volume, ``tf=settings.tf, options=settings.options``: the reference depth is where
    the render's own opacity first reaches 0.05. ``"bilinear"`` and ``"nearest"``
    compute no layers (they would not change the result).

    Properties: :meth:`SetFactor` (default 4), :meth:`SetMethod` (``"joint_bilateral"``)
    and ``upsample``'s :meth:`SetGuide`, :meth:`SetSpatial`, :meth:`SetSupport`,
    :meth:`SetSigmaRange` (each ``None`` by default: ``upsample``'s own default).
    """

    def __init__(self):
        super().__init__(nInputPorts=2, nOutputPorts=1, outputType="vtkImageData")
        self._factor = 4
        self._method = "joint_bilateral"
        self._guide = None
        self._spatial = None
        self._support = None
        self._sigma_range = None

    def FillInputPortInformation(self, port, info):
        info.Set(vtkAlgorithm.INPUT_REQUIRED_DATA_TYPE(), "vtkImageData" if port == 0 else "vtkDataSet")
        if port == 1:
            info.Set(vtkAlgorithm.INPUT_IS_OPTIONAL(), 1)
        return 1

    def _set(self, attribute, value):
        if not _same(value, getattr(self, attribute)):
            setattr(self, attribute, value)
            self.Modified()

    def SetFactor(self, factor):
        """Output pixels per input pixel along each axis: an integer >= 1 (default 4)."""
        self._set("_factor", as_int("factor", factor, low=1))

    def GetFactor(self):
        """The upsampling factor (int)."""
        return self._factor

    def SetMethod(self, method):
        """``"joint_bilateral"`` (default), ``"bilinear"`` or ``"nearest"``."""
        self._set("_method", as_choice("method", method, METHODS))

    def GetMethod(self):
        """``"joint_bilateral"``, ``"bilinear"`` or ``"nearest"``."""
        return self._method

    def SetGuide(self, guide):
        """What the range term compares: ``"thickness"`` (a mesh's default), ``"layers"``
        (an image volume's), or ``None`` (``upsample``'s default)."""
        self._set("_guide", None if guide is None else as_choice("guide", guide, GUIDES))

    def GetGuide(self):
        """``"thickness"``, ``"layers"`` or ``None``."""
        return self._guide

    def SetSpatial(self, spatial):
        """Spatial weights: ``"bilinear"``, ``"gaussian"``, or ``None`` (``upsample``'s default)."""
        self._set("_spatial", None if spatial is None else as_choice("spatial", spatial, SPATIAL))

    def GetSpatial(self):
        """``"bilinear"``, ``"gaussian"`` or ``None``."""
        return self._spatial

    def SetSupport(self, support):
        """``spatial="gaussian"``: its support in output pixels (> 0), or ``None`` (the factor, at least 2)."""
        self._set("_support", None if support is None else as_real("support", support, low=0.0, low_open=True))

    def GetSupport(self):
        """The Gaussian's support in output pixels (float), or ``None``."""
        return self._support

    def SetSigmaRange(self, sigma_range):
        """Sigma of the range Gaussian in the guide's units (> 0), or ``None`` (``upsample``'s default)."""
        self._set("_sigma_range",
                  None if sigma_range is None else as_real("sigma_range", sigma_range, low=0.0, low_open=True))

    def GetSigmaRange(self):
        """The range sigma (float), or ``None``."""
        return self._sigma_range

    def RequestInformation(self, request, inInfo, outInfo):
        self._last_error = None
        return self._reporting(self._information, inInfo, outInfo)

    def _information(self, inInfo, outInfo):
        x0, x1, y0, y1, _, _ = inInfo[0].GetInformationObject(0).Get(_SDDP.WHOLE_EXTENT())
        f = self._factor
        _set_whole_extent(outInfo.GetInformationObject(0), (x1 - x0 + 1) * f, (y1 - y0 + 1) * f)
        return 1

    def RequestUpdateExtent(self, request, inInfo, outInfo):
        for port in (0, 1):
            if inInfo[port].GetNumberOfInformationObjects():
                request_whole_extent(inInfo[port].GetInformationObject(0))
        return 1

    def _execute(self, inInfo, outInfo):
        from ..raycast.layers import depth_layers

        if _empty_on_another_rank(inInfo, 0):
            vtkImageData.GetData(outInfo).Initialize()
            return 1
        vtk_image, cols, rows = _image_on(inInfo, 0, "HDRUpsampler")
        image = HDRImage.from_pyvista(vtk_image)
        dataset = vtkDataSet.GetData(inInfo[1]) if inInfo[1].GetNumberOfInformationObjects() else None
        layers = None
        self.UpdateProgress(0.0)
        if self._method == "joint_bilateral":
            settings = _render_settings(image)
            if dataset is None:
                raise ValueError("joint bilateral upsampling needs the rendered dataset on input port 1 (or "
                                 "SetMethod('bilinear') or 'nearest', which need no guide)")
            kind = dataset.GetClassName()
            if kind not in ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid", "vtkUnstructuredGrid"):
                raise ValueError(f"HDRUpsampler needs the rendered vtkUnstructuredGrid or vtkImageData on input "
                                 f"port 1; got {kind}")
            extra = {} if kind == "vtkUnstructuredGrid" else {"tf": settings.tf, "options": settings.options}
            layers = depth_layers(dataset, settings.camera, (cols * self._factor, rows * self._factor),
                                  scalars=image.metadata.get("scalars"),
                                  preference=image.metadata.get("association", "point"), **extra)
            self.UpdateProgress(0.5)
        out = upsample(image, layers, self._factor, method=self._method, guide=self._guide, spatial=self._spatial,
                       support=self._support, sigma_range=self._sigma_range)
        vtkImageData.GetData(outInfo).ShallowCopy(out.to_vtk())
        self.UpdateProgress(1.0)
        return 1


def _render_settings(image):
    """The :class:`~pv_hdrvol.RenderSettings` of a render's image, or a ``ValueError``
    saying where such an image comes from."""
    stored = image.metadata.get("settings")
    if not isinstance(stored, dict) or stored.get("camera") is None:
        raise ValueError("the image on input port 0 holds no camera in its metadata: it must come from HDR Volume "
                         "Render (HDRVolumeRenderer) or pv_hdrvol.render, or a .exr/.hdr file they saved")
    try:
        return image.settings()
    except ValueError as exc:  # rendered with a lens, or already resized: the camera's rays are not the pixels
        raise ValueError(f"the image on input port 0 is not a plain render: {exc}") from None


__all__ = ["HDRImageReader", "HDRImageWriter", "HDRToneMapper", "HDRUpsampler", "READ_EXTENSIONS",
           "WRITE_EXTENSIONS"]
