"""HDRToneMapper, HDRImageReader, HDRImageWriter and HDRUpsampler in plain VTK pipelines."""
import doctest
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkCommonDataModel import vtkImageData
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as SDDP
from vtkmodules.vtkFiltersGeneral import vtkDataSetTriangleFilter

import pv_hdrvol as hv
from pv_hdrvol.integrations import vtk_image
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer
from pv_hdrvol.integrations.vtk_image import (READ_EXTENSIONS, HDRImageReader, HDRImageWriter, HDRToneMapper,
                                              HDRUpsampler)
from vtk_capture import CapturedErrors

W, H = 8, 6  # low-resolution renders; upsampled 4x to 32x24
CAMERA = hv.Camera((9.0, -7.0, 5.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=30.0)


def _volume():
    """A plain vtkImageData (no PyVista): a Gaussian blob and a second array."""
    n = 9
    z, y, x = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    img = vtkImageData()
    img.SetDimensions(n, n, n)
    img.SetSpacing(0.5, 0.5, 0.5)
    img.SetOrigin(-2.0, -2.0, -2.0)
    arr = numpy_to_vtk(np.exp(-3.0 * (x**2 + y**2 + z**2)).reshape(-1), deep=True)
    arr.SetName("density")
    img.GetPointData().AddArray(arr)
    img.GetPointData().SetActiveScalars("density")
    other = numpy_to_vtk(np.arange(n**3, dtype=np.float64), deep=True)
    other.SetName("index")
    img.GetPointData().AddArray(other)
    return img


def _mesh():
    """The blob as a vtkUnstructuredGrid of tetrahedra."""
    tri = vtkDataSetTriangleFilter()
    tri.SetInputData(_volume())
    tri.Update()
    return tri.GetOutput()


TF = hv.TransferFunction.ramp(0.0, 1.0, cmap="viridis", opacity=(0.0, 0.8))


@pytest.fixture(scope="module")
def volume_render():
    """``(volume, HDRImage)``: a float32 render of the blob image, 8x6, not at the default step."""
    volume = _volume()
    return volume, hv.render(volume, TF, CAMERA, (W, H), step=0.7)


@pytest.fixture(scope="module")
def mesh_render():
    """``(mesh, HDRImage)``: a float32 render of the blob mesh, 8x6."""
    mesh = _mesh()
    return mesh, hv.render(mesh, TF, CAMERA, (W, H))


def _arrays(image):
    """``{name: numpy copy}`` of an image's point arrays."""
    pd = image.GetPointData()
    return {pd.GetArrayName(i): np.array(vtk_to_numpy(pd.GetArray(i))) for i in range(pd.GetNumberOfArrays())}


def _metadata(image):
    meta = image.GetFieldData().GetAbstractArray("hdrvol_metadata")
    return None if meta is None else json.loads(meta.GetValue(0))


def _assert_same_image(out, ref):
    """Same dimensions, point arrays (names, types, values bit for bit) and metadata."""
    assert out.GetDimensions() == ref.GetDimensions()
    got, want = _arrays(out), _arrays(ref)
    assert list(got) == list(want)
    for name in want:
        assert got[name].dtype == want[name].dtype, name
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    assert _metadata(out) == _metadata(ref)


def _fails_with(alg, message, update=None):
    """``alg`` fails its update: ``GetLastError() == message``, written to the output window."""
    with CapturedErrors() as captured:
        ok = (update or alg.Update)()
    assert ok in (False, 0)
    assert alg.GetLastError() == message
    assert f"{type(alg).__name__} (0x" in captured.text and message in captured.text


# -- HDRToneMapper ---------------------------------------------------------------------------------
def _mapper(image):
    alg = HDRToneMapper()
    alg.SetInputDataObject(image)
    return alg


@pytest.mark.parametrize(("operator", "parameters", "encoding"), [
    ("reinhard", {}, "srgb"),
    ("linear", {"exposure_stops": 3.0}, "linear"),
    ("drago", {"bias": 0.7, "saturation": 0.8}, 2.2),
    ("gamma", {"gamma": 1.8}, "srgb"),
    ("reinhard", {"local": True}, "srgb"),
])
def test_tone_mapper_equals_tonemap_bit_for_bit(volume_render, operator, parameters, encoding):
    _, image = volume_render
    source = image.to_vtk()
    alg = _mapper(source)
    alg.SetOperator(operator)
    alg.SetEncoding(encoding)
    alg.SetParameters(parameters)
    assert alg.Update() is True and alg.GetLastError() is None
    out = alg.GetOutput()
    scalars = out.GetPointData().GetScalars()
    assert scalars.GetName() == "tonemapped" and scalars.GetNumberOfComponents() == 3
    assert scalars.GetDataTypeAsString() == "unsigned char"
    ref = hv.tonemap(hv.HDRImage.from_pyvista(source), operator, encoding=encoding, **parameters).rgb8
    got = vtk_to_numpy(scalars)
    np.testing.assert_array_equal(got, ref[::-1].reshape(-1, 3))
    assert len(np.unique(got)) > 3  # a picture, not a constant
    # every input array is kept, unchanged, with the metadata
    arrays = _arrays(out)
    assert list(arrays) == ["rgba", "depth", "tonemapped"]
    for name, values in _arrays(source).items():
        np.testing.assert_array_equal(arrays[name], values)
    assert _metadata(out) == _metadata(source) and _metadata(out)["settings"]["size"] == [W, H]


def test_tone_mapper_leaves_its_input_alone(volume_render):
    source = volume_render[1].to_vtk()
    mtime = source.GetMTime()
    before = _arrays(source)
    alg = _mapper(source)
    assert alg.Update() is True
    assert source.GetMTime() == mtime
    assert source.GetPointData().GetScalars().GetName() == "rgba"
    after = _arrays(source)
    assert list(after) == list(before) == ["rgba", "depth"]
    for name in before:
        np.testing.assert_array_equal(after[name], before[name])


def test_tone_mapper_rgb_array_and_active_scalars():
    """A 3-component float array (no "rgba"): the active scalars by default, or named."""
    rng = np.random.default_rng(3)
    colour = rng.random((5, 7, 3)) * 10.0 ** rng.uniform(-3, 2, (5, 7, 1))
    img = vtkImageData()
    img.SetDimensions(7, 5, 1)
    for name, values in (("other", colour[..., ::-1] * 2.0), ("colour", colour)):
        arr = numpy_to_vtk(np.ascontiguousarray(values[::-1].reshape(-1, 3)), deep=True)
        arr.SetName(name)
        img.GetPointData().AddArray(arr)
    img.GetPointData().SetActiveScalars("colour")
    alg = _mapper(img)
    assert alg.Update() is True
    got = vtk_to_numpy(alg.GetOutput().GetPointData().GetArray("tonemapped"))
    np.testing.assert_array_equal(got, hv.tonemap(colour).rgb8[::-1].reshape(-1, 3))
    alg.SetRGBAArray("other")
    assert alg.GetRGBAArray() == "other"
    assert alg.Update() is True
    got = vtk_to_numpy(alg.GetOutput().GetPointData().GetArray("tonemapped"))
    np.testing.assert_array_equal(got, hv.tonemap(colour[..., ::-1] * 2.0).rgb8[::-1].reshape(-1, 3))


def test_tone_mapper_setters_validate_and_modify_only_on_change(volume_render):
    alg = _mapper(volume_render[1].to_vtk())
    assert (alg.GetOperator(), alg.GetEncoding(), alg.GetParameters(), alg.GetRGBAArray()) == \
        ("reinhard", None, {}, None)
    alg.SetOperator("linear")
    alg.SetParameter("exposure_stops", 1.0)
    assert alg.Update() is True
    first = vtk_to_numpy(alg.GetOutput().GetPointData().GetScalars()).copy()
    t0 = alg.GetMTime()
    # equal values: no Modified()
    alg.SetOperator("linear")
    alg.SetParameter("exposure_stops", 1.0)
    alg.SetParameters({"exposure_stops": 1.0, "percentile": None})
    alg.SetEncoding(None)
    alg.SetRGBAArray(None)
    alg.SetParameter("key", None)  # removing what is not there
    assert alg.GetMTime() == t0
    params = alg.GetParameters()
    params["exposure_stops"] = 5.0  # a copy
    assert alg.GetParameters() == {"exposure_stops": 1.0} and alg.GetMTime() == t0
    # a change re-executes and changes the picture
    alg.SetParameter("exposure_stops", 2.0)
    assert alg.GetMTime() > t0
    assert alg.Update() is True
    second = vtk_to_numpy(alg.GetOutput().GetPointData().GetScalars())
    assert np.all(second >= first) and np.any(second > first)
    t1 = alg.GetMTime()
    alg.SetEncoding(2.2)
    t2 = alg.GetMTime()
    assert t2 > t1 and alg.GetEncoding() == 2.2
    alg.SetEncoding(2.2)
    assert alg.GetMTime() == t2
    alg.SetParameter("exposure_stops", None)
    assert alg.GetParameters() == {} and alg.GetMTime() > t2

    with pytest.raises(ValueError, match=r"operator must be one of \['drago', 'durand', 'fattal', 'gamma', "
                                         r"'knee', 'linear', 'reinhard'\]; got 'aces'"):
        alg.SetOperator("aces")
    with pytest.raises(ValueError, match=r"encoding must be 'srgb', 'linear' or a gamma > 0; got 'rec709'"):
        alg.SetEncoding("rec709")
    with pytest.raises(ValueError, match=r"encoding gamma must be finite and > 0; got -1"):
        alg.SetEncoding(-1)
    with pytest.raises(TypeError, match=r"encoding must be 'srgb', 'linear', a gamma > 0 or None; got True"):
        alg.SetEncoding(True)
    with pytest.raises(TypeError, match=r"a parameter name must be a str \(an identifier\); got 3"):
        alg.SetParameter(3, 1.0)
    with pytest.raises(TypeError, match=r"parameters must be a dict \{name: value\}; got list"):
        alg.SetParameters([("key", 0.2)])
    with pytest.raises(TypeError, match=r"the RGBA array must be a point array name \(str\) or None; got 4"):
        alg.SetRGBAArray(4)
    assert (alg.GetOperator(), alg.GetEncoding()) == ("linear", 2.2)  # failed setters change nothing


@pytest.mark.parametrize(("setup", "message"), [
    (lambda a: (a.SetOperator("linear"), a.SetParameter("key", 0.2)),
     "TypeError: linear takes parameters ['exposure_stops', 'percentile', 'saturation']; got unknown ['key']"),
    (lambda a: (a.SetOperator("drago"), a.SetParameter("bias", 2.0)), "ValueError: bias must be in (0, 1); got 2.0"),
    (lambda a: a.SetRGBAArray("colour"), "ValueError: the image has no point array 'colour'; its point arrays: "
                                         "['rgba', 'depth']"),
    (lambda a: a.SetRGBAArray("depth"), "ValueError: point array 'depth' has 1 component; tone mapping needs 3 "
                                        "(RGB) or 4 (RGBA)"),
])
def test_tone_mapper_errors_fail_the_update(volume_render, setup, message):
    alg = _mapper(volume_render[1].to_vtk())
    assert alg.Update() is True
    setup(alg)
    events = []
    alg.AddObserver(vtkCommand.ErrorEvent, lambda obj, event: events.append(event))
    _fails_with(alg, message)
    assert events == ["ErrorEvent"]
    assert alg.GetOutput().GetNumberOfPoints() == 0
    alg.SetOperator("reinhard")
    alg.SetParameters({})
    alg.SetRGBAArray(None)
    with CapturedErrors() as captured:
        assert alg.Update() is True
    assert alg.GetLastError() is None and captured.text == ""


def test_tone_mapper_needs_an_image_with_colours():
    img = vtkImageData()
    img.SetDimensions(3, 2, 1)
    depth = numpy_to_vtk(np.zeros(6), deep=True)
    depth.SetName("depth")
    img.GetPointData().AddArray(depth)
    _fails_with(_mapper(img), "ValueError: the image has no point array 'rgba' and no active scalars; its point "
                              "arrays: ['depth'] (choose one with SetRGBAArray)")
    img.SetDimensions(3, 2, 2)
    _fails_with(_mapper(img), "ValueError: HDRToneMapper needs a 2-D image (z dimension 1) on input port 0; got "
                              "dimensions (3, 2, 2)")


# -- HDRImageReader --------------------------------------------------------------------------------
def _reader(path):
    alg = HDRImageReader()
    alg.SetFileName(path)
    return alg


@pytest.mark.parametrize("ext", [".npy", ".hdr", ".exr"])
def test_reader_outputs_what_load_reads(volume_render, tmp_path, ext):
    if ext == ".exr":
        pytest.importorskip("OpenEXR")
    path = tmp_path / f"image{ext}"
    volume_render[1].save(path)
    alg = _reader(path)
    assert alg.GetFileName() == str(path)
    alg.UpdateInformation()
    assert alg.GetOutputInformation(0).Get(SDDP.WHOLE_EXTENT()) == (0, W - 1, 0, H - 1, 0, 0)
    assert alg.Update() is True
    _assert_same_image(alg.GetOutput(), hv.load(path).to_vtk())
    if ext != ".npy":  # .npy keeps no metadata
        assert _metadata(alg.GetOutput())["settings"] == volume_render[1].metadata["settings"]


def test_reader_adds_the_other_exr_channels(tmp_path):
    """An EXR written by another tool: RGB without alpha or depth, and channels of its own."""
    OpenEXR = pytest.importorskip("OpenEXR")
    rng = np.random.default_rng(7)
    rows, cols = 4, 6
    channels = {
        "RGB": rng.random((rows, cols, 3)).astype(np.float32),
        "mask": rng.random((rows, cols)).astype(np.float16),
        "id": np.arange(rows * cols, dtype=np.uint32).reshape(rows, cols) + np.uint32(2**30 + 1),
        "N.x": rng.standard_normal((rows, cols)).astype(np.float32),
    }
    path = str(tmp_path / "other.exr")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, dict(channels)) as f:  # (OpenEXR replaces the dict's arrays by Channels)
        f.write(path)
    alg = _reader(path)
    assert alg.Update() is True
    got = _arrays(alg.GetOutput())
    assert sorted(got) == ["N.x", "depth", "id", "mask", "rgba"]
    ref = hv.load(path)
    np.testing.assert_array_equal(got["rgba"].reshape(rows, cols, 4)[::-1], ref.rgba)
    np.testing.assert_array_equal(got["rgba"].reshape(rows, cols, 4)[::-1][..., :3], channels["RGB"])
    assert np.all(got["rgba"][:, 3] == 1.0) and np.all(np.isinf(got["depth"]))
    assert got["mask"].dtype == np.float32 and got["N.x"].dtype == np.float32 and got["id"].dtype == np.uint32
    for name in ("mask", "id", "N.x"):  # VTK row order: row 0 at the bottom
        np.testing.assert_array_equal(got[name].reshape(rows, cols)[::-1], channels[name].astype(got[name].dtype))


def test_reader_reads_a_file_once(volume_render, tmp_path, monkeypatch):
    path = tmp_path / "image.npy"
    volume_render[1].save(path)
    calls = []
    load = hv.HDRImage.load
    monkeypatch.setattr(hv.HDRImage, "load", lambda p: (calls.append(p), load(p))[1])
    alg = _reader(path)
    alg.UpdateInformation()
    assert alg.Update() is True and len(calls) == 1
    t0 = alg.GetMTime()
    alg.SetFileName(str(path))  # the same name: no Modified()
    assert alg.GetMTime() == t0
    alg.Modified()
    assert alg.Update() is True and len(calls) == 1  # re-executed from the cache
    assert alg.GetOutput().GetDimensions() == (W, H, 1)
    hv.HDRImage(np.ones((3, 5, 4), np.float32)).save(path)  # another file under the same name
    alg.Modified()
    assert alg.Update() is True and len(calls) == 2
    assert alg.GetOutput().GetDimensions() == (5, 3, 1)


def test_reader_errors_are_those_of_load(tmp_path):
    missing = tmp_path / "missing.npy"
    with pytest.raises(FileNotFoundError) as expected:
        hv.load(missing)
    _fails_with(_reader(missing), f"FileNotFoundError: {expected.value}")
    (tmp_path / "text.npy").write_text("not an array")
    with pytest.raises(ValueError) as expected:
        hv.load(tmp_path / "text.npy")
    _fails_with(_reader(tmp_path / "text.npy"), f"ValueError: {expected.value}")
    _fails_with(_reader(tmp_path / "image.png"), "ValueError: unknown image extension '.png'; use .exr, .hdr or .npy")
    _fails_with(HDRImageReader(), "ValueError: HDRImageReader has no file to read: call SetFileName(path)")
    with pytest.raises(TypeError, match=r"the file name must be a str or os.PathLike, or None; got int"):
        HDRImageReader().SetFileName(3)


def test_can_read_file(volume_render, tmp_path):
    assert READ_EXTENSIONS == (".exr", ".hdr", ".npy") == vtk_image.READ_EXTENSIONS
    reader = HDRImageReader()
    for ext in (".npy", ".hdr"):
        volume_render[1].save(tmp_path / f"image{ext}")
        assert reader.CanReadFile(str(tmp_path / f"image{ext}")) == 1
    os.replace(tmp_path / "image.npy", tmp_path / "IMAGE.NPY")
    assert reader.CanReadFile(tmp_path / "IMAGE.NPY") == 1
    os.replace(tmp_path / "image.hdr", tmp_path / "image.exr")  # a Radiance file by another name
    assert reader.CanReadFile(tmp_path / "image.exr") == 0
    (tmp_path / "image.txt").write_bytes(b"\x93NUMPY")
    assert reader.CanReadFile(tmp_path / "image.txt") == 0
    assert reader.CanReadFile(tmp_path / "missing.npy") == 0
    (tmp_path / "folder.npy").mkdir()
    assert reader.CanReadFile(tmp_path / "folder.npy") == 0
    assert reader.CanReadFile(None) == 0


# -- HDRImageWriter --------------------------------------------------------------------------------
def _writer(image, path):
    alg = HDRImageWriter()
    alg.SetInputDataObject(image)
    alg.SetFileName(path)
    return alg


def test_writer_npy_round_trip_is_exact(tmp_path):
    image = hv.render(_volume(), TF, CAMERA, (W, H), precision="float64")
    source = image.to_vtk()
    path = tmp_path / "image.npy"
    alg = _writer(source, path)
    assert alg.Write() == 1 and alg.GetLastError() is None
    back = hv.load(path)
    assert back.rgba.dtype == np.float64
    np.testing.assert_array_equal(back.rgba, image.rgba)
    np.testing.assert_array_equal(back.depth, image.depth)
    # each Write() writes, also when nothing changed
    os.remove(path)
    assert alg.Write() == 1 and path.exists()


@pytest.mark.parametrize("pixel_type", ["float32", "float16"])
def test_writer_exr_round_trip(volume_render, tmp_path, pixel_type):
    pytest.importorskip("OpenEXR")
    _, image = volume_render
    source = image.to_vtk()
    path = tmp_path / "image.exr"
    alg = _writer(source, str(path))
    alg.SetPixelType(pixel_type)
    assert alg.GetPixelType() == pixel_type
    assert alg.Write() == 1
    back = hv.load(path)
    expected = image.rgba if pixel_type == "float32" else image.rgba.astype(np.float16).astype(np.float32)
    np.testing.assert_array_equal(back.rgba, expected)
    np.testing.assert_array_equal(back.depth, image.depth.astype(np.float32))  # EXR depth is float32
    assert back.metadata == hv.HDRImage.from_pyvista(source).metadata
    assert back.settings().camera == CAMERA


@pytest.mark.parametrize("ext", [".hdr", ".png"])
def test_writer_writes_what_save_writes(volume_render, tmp_path, ext):
    _, image = volume_render
    ours, theirs = tmp_path / f"ours{ext}", tmp_path / f"theirs{ext}"
    assert _writer(image.to_vtk(), ours).Write() == 1
    hv.HDRImage.from_pyvista(image.to_vtk()).save(theirs)
    assert ours.read_bytes() == theirs.read_bytes()
    if ext == ".hdr":
        assert hv.load(ours).metadata == hv.HDRImage.from_pyvista(image.to_vtk()).metadata


def test_writer_png_writes_the_tonemapped_colours_the_input_carries(volume_render, tmp_path):
    """What the view shows (HDR Tone Map's or the ParaView filter's 'tonemapped' array),
    not the default display mapping (Drago's operator differs from it)."""
    _, image = volume_render
    mapper = HDRToneMapper()
    mapper.SetInputDataObject(image.to_vtk())
    mapper.SetOperator("drago")
    path = tmp_path / "shown.png"
    writer = HDRImageWriter()
    writer.SetInputConnection(mapper.GetOutputPort())
    writer.SetFileName(path)
    assert writer.Write() == 1
    from vtkmodules.vtkIOImage import vtkPNGReader

    reader = vtkPNGReader()
    reader.SetFileName(str(path))
    reader.Update()
    shown = vtk_to_numpy(mapper.GetOutput().GetPointData().GetArray("tonemapped"))
    np.testing.assert_array_equal(vtk_to_numpy(reader.GetOutput().GetPointData().GetScalars()), shown)
    default = tmp_path / "default.png"
    image.save(default)
    assert path.read_bytes() != default.read_bytes()


def test_writer_errors(volume_render, tmp_path):
    source = volume_render[1].to_vtk()
    mtime = source.GetMTime()
    alg = _writer(source, None)
    _fails_with(alg, "ValueError: HDRImageWriter has no file to write: call SetFileName(path)", alg.Write)
    alg.SetFileName(tmp_path / "no" / "image.npy")
    _fails_with(alg, f"FileNotFoundError: [Errno 2] cannot write '{tmp_path / 'no' / 'image.npy'}': no such folder: "
                     f"'{tmp_path / 'no'}'", alg.Write)
    assert source.GetMTime() == mtime
    with pytest.raises(ValueError, match=r"unknown image extension '.tif'; use .exr, .hdr, .npy or .png"):
        alg.SetFileName("image.tif")
    with pytest.raises(ValueError, match=r"pixel_type must be one of \['float32', 'float16'\]; got 'float64'"):
        alg.SetPixelType("float64")
    t0 = alg.GetMTime()
    alg.SetPixelType("float32")
    alg.SetFileName(tmp_path / "no" / "image.npy")
    assert alg.GetMTime() == t0
    no_rgba = vtkImageData()
    no_rgba.SetDimensions(2, 2, 1)
    values = numpy_to_vtk(np.zeros(4), deep=True)
    values.SetName("depth")
    no_rgba.GetPointData().AddArray(values)
    alg = _writer(no_rgba, tmp_path / "image.npy")
    _fails_with(alg, "ValueError: the image has no 4-component point array 'rgba'", alg.Write)


# -- HDRUpsampler ----------------------------------------------------------------------------------
def _upsampler(image, dataset=None, factor=4):
    alg = HDRUpsampler()
    if isinstance(image, vtkImageData):
        alg.SetInputDataObject(0, image)
    else:
        alg.SetInputConnection(0, image.GetOutputPort())
    if dataset is not None:
        alg.SetInputDataObject(1, dataset)
    alg.SetFactor(factor)
    return alg


def test_upsampler_mesh_equals_python_bit_for_bit(mesh_render):
    mesh, low = mesh_render
    alg = _upsampler(low.to_vtk(), mesh)
    alg.UpdateInformation()
    assert alg.GetOutputInformation(0).Get(SDDP.WHOLE_EXTENT()) == (0, 4 * W - 1, 0, 4 * H - 1, 0, 0)
    assert alg.Update() is True
    layers = hv.depth_layers(mesh, low.settings().camera, (4 * W, 4 * H), scalars=low.metadata["scalars"],
                             preference=low.metadata["association"])
    ref = hv.upsample(low, layers, 4)
    assert ref.metadata["upsampled"]["guide"] == "thickness"
    _assert_same_image(alg.GetOutput(), ref.to_vtk())
    # the guide matters: not what bilinear interpolation gives
    bilinear = hv.upsample(low, factor=4, method="bilinear")
    assert not np.array_equal(hv.HDRImage.from_pyvista(alg.GetOutput()).rgba, bilinear.rgba)
    # a property change re-executes
    alg.SetSigmaRange(0.05)
    assert alg.Update() is True
    _assert_same_image(alg.GetOutput(), hv.upsample(low, layers, 4, sigma_range=0.05).to_vtk())
    alg.SetFactor(2)
    assert alg.Update() is True and alg.GetOutput().GetDimensions() == (2 * W, 2 * H, 1)


def test_upsampler_after_the_renderer_in_a_pipeline(mesh_render):
    """HDRVolumeRenderer -> HDRUpsampler; the renderer's image holds its camera."""
    mesh, low = mesh_render
    renderer = HDRVolumeRenderer()
    renderer.SetInputDataObject(mesh)
    renderer.SetTransferFunction(TF)
    renderer.SetCamera(CAMERA)
    renderer.SetImageSize(W, H)
    alg = _upsampler(renderer, mesh, factor=2)
    assert alg.Update() is True
    rendered = hv.HDRImage.from_pyvista(renderer.GetOutput())
    np.testing.assert_array_equal(rendered.rgba, low.rgba)
    layers = hv.depth_layers(mesh, CAMERA, (2 * W, 2 * H), scalars="density", preference="point")
    _assert_same_image(alg.GetOutput(), hv.upsample(rendered, layers, 2).to_vtk())


def test_upsampler_image_volume_equals_python_bit_for_bit(volume_render):
    volume, low = volume_render
    alg = _upsampler(low.to_vtk(), volume)
    alg.SetGuide("layers")
    alg.SetSpatial("gaussian")
    alg.SetSupport(3.0)
    assert alg.Update() is True
    settings = low.settings()
    layers = hv.depth_layers(volume, settings.camera, (4 * W, 4 * H), scalars="density", tf=settings.tf,
                             options=settings.options)
    assert np.isfinite(layers.depth).any() and np.isinf(layers.depth).any()  # an outline to follow
    ref = hv.upsample(low, layers, 4, guide="layers", spatial="gaussian", support=3.0)
    _assert_same_image(alg.GetOutput(), ref.to_vtk())
    # options upsample checks together fail the update with its message
    alg.SetGuide("thickness")
    _fails_with(alg, "ValueError: guide='thickness' needs the boundary layers of a mesh; these layers have no "
                     f"thickness (they are the {layers.source})")


@pytest.mark.parametrize("method", ["bilinear", "nearest"])
def test_upsampler_without_guide(volume_render, method):
    _, low = volume_render
    alg = _upsampler(low.to_vtk(), None, factor=3)
    alg.SetMethod(method)
    assert alg.Update() is True
    _assert_same_image(alg.GetOutput(), hv.upsample(low, factor=3, method=method).to_vtk())


def test_upsampler_errors(volume_render):
    volume, low = volume_render
    plain = hv.HDRImage(low.rgba, low.depth).to_vtk()
    _fails_with(_upsampler(plain, volume),
                "ValueError: the image on input port 0 holds no camera in its metadata: it must come from HDR Volume "
                "Render (HDRVolumeRenderer) or pv_hdrvol.render, or a .exr/.hdr file they saved")
    _fails_with(_upsampler(low.to_vtk()),
                "ValueError: joint bilateral upsampling needs the rendered dataset on input port 1 (or "
                "SetMethod('bilinear') or 'nearest', which need no guide)")
    twice = hv.upsample(low, factor=2, method="nearest").to_vtk()
    _fails_with(_upsampler(twice, volume),
                f"ValueError: the image on input port 0 is not a plain render: the settings are those of a {W}x{H} "
                f"render; this image is {2 * W}x{2 * H} (changed after the render, e.g. by pv_hdrvol.upsample); "
                "settings(partial=True) returns them anyway")


def test_upsampler_setters_validate_and_modify_only_on_change():
    alg = HDRUpsampler()
    assert (alg.GetFactor(), alg.GetMethod(), alg.GetGuide(), alg.GetSpatial(), alg.GetSupport(),
            alg.GetSigmaRange()) == (4, "joint_bilateral", None, None, None, None)
    t0 = alg.GetMTime()
    alg.SetFactor(4)
    alg.SetMethod("joint_bilateral")
    alg.SetGuide(None)
    alg.SetSigmaRange(None)
    assert alg.GetMTime() == t0
    alg.SetSupport(3)
    t1 = alg.GetMTime()
    assert t1 > t0 and alg.GetSupport() == 3.0
    alg.SetSupport(3.0)
    assert alg.GetMTime() == t1
    with pytest.raises(ValueError, match=r"factor must be >= 1; got 0"):
        alg.SetFactor(0)
    with pytest.raises(TypeError, match=r"factor must be an integer; got 2.5 \(float\)"):
        alg.SetFactor(2.5)
    with pytest.raises(ValueError, match=r"method must be one of \['joint_bilateral', 'bilinear', 'nearest'\]; "
                                         r"got 'cubic'"):
        alg.SetMethod("cubic")
    with pytest.raises(ValueError, match=r"guide must be one of \['thickness', 'layers'\]; got 'depth'"):
        alg.SetGuide("depth")
    with pytest.raises(ValueError, match=r"spatial must be one of \['bilinear', 'gaussian'\]; got 'box'"):
        alg.SetSpatial("box")
    with pytest.raises(ValueError, match=r"support must be > 0.0; got 0"):
        alg.SetSupport(0)
    with pytest.raises(ValueError, match=r"sigma_range must be > 0.0; got -1"):
        alg.SetSigmaRange(-1)
    assert alg.GetMTime() == t1 and alg.GetFactor() == 4


# -- the module ------------------------------------------------------------------------------------
def test_module_imports_neither_pyvista_nor_paraview():
    code = ("import sys; import pv_hdrvol.integrations.vtk_image as m; "
            "print(sorted(n for n in ('pyvista', 'paraview') if n in sys.modules), sorted(m.__all__))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == ("[] ['HDRImageReader', 'HDRImageWriter', 'HDRToneMapper', 'HDRUpsampler', "
                                  "'READ_EXTENSIONS', 'WRITE_EXTENSIONS']")


def test_docstring_examples():
    result = doctest.testmod(vtk_image, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
