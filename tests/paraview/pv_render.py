"""HDR Volume Render in real ParaView (pvbatch): the plugin loads, the image equals
``pv_hdrvol.render`` of the same data, camera and transfer function, the transfer
function is ParaView's colour map, properties re-execute, bad input is refused clearly.

Run by tests/paraview/run.py inside pvbatch (see there); not collected by the main suite.
"""
import numpy as np
import pytest
from paraview import servermanager, simple

import pv_hdrvol as hv
from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

ENGINE = ("structured", "engine_256x256x128_uint8.vti", "ImageFile")
BLUNTFIN = ("unstructured", "bluntfin_187395tets.vtu", "Density")


def _reader(shared_data, case):
    folder, name, array = case
    reader = simple.OpenDataFile(str(shared_data / folder / name))
    assert reader is not None
    reader.UpdatePipeline()
    return reader, array


def _image(proxy):
    proxy.UpdatePipeline()
    return hv.HDRImage.from_pyvista(servermanager.Fetch(proxy))


def _set_color_map(array, lo, hi, log):
    """A colour map in RGB space with four colours and a three-point opacity, as a user sets it."""
    lut = simple.GetColorTransferFunction(array)
    pwf = simple.GetOpacityTransferFunction(array)
    mid1, mid2 = (lo * (hi / lo) ** (1 / 3), lo * (hi / lo) ** (2 / 3)) if log else (
        lo + (hi - lo) / 3, lo + 2 * (hi - lo) / 3)
    lut.ColorSpace = "RGB"
    lut.RGBPoints = [lo, 0.1, 0.0, 0.3, mid1, 0.8, 0.2, 0.1, mid2, 1.0, 0.8, 0.0, hi, 1.0, 1.0, 1.0]
    lut.UseLogScale = int(log)
    pwf.Points = [lo, 0.0, 0.5, 0.0, mid1, 0.02, 0.5, 0.0, hi, 0.3, 0.5, 0.0]
    pwf.UseLogScale = int(log)
    values = np.array([lo, mid1, mid2, hi])
    colors = np.array([[0.1, 0.0, 0.3], [0.8, 0.2, 0.1], [1.0, 0.8, 0.0], [1.0, 1.0, 1.0]])
    # the opacity at mid2 is the interpolation between mid1 and hi on the same axis
    f = (np.log(mid2 / mid1) / np.log(hi / mid1)) if log else (mid2 - mid1) / (hi - mid1)
    opacities = np.array([0.0, 0.02, 0.02 + f * (0.3 - 0.02), 0.3])
    return lut, pwf, hv.TransferFunction(values, colors, opacities, scale="log" if log else "linear")


@pytest.mark.parametrize("case", [ENGINE, BLUNTFIN], ids=["engine", "bluntfin"])
def test_render_equals_python_api(plugin, shared_data, case):
    reader, array = _reader(shared_data, case)
    lo, hi = (20.0, 255.0) if case is ENGINE else (0.2, 5.0)
    lut, pwf, expected_tf = _set_color_map(array, lo, hi, log=case is BLUNTFIN)
    camera = hv.Camera.fit(reader.GetDataInformation().GetBounds(), "iso")
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[48, 40], Camera="iso", LookupTable=lut,
                                       ScalarOpacityFunction=pwf)
    render.Scalars = ["POINTS", array]
    image = _image(render)

    # the transfer function the filter renders with is the colour map the user set
    tf = transfer_function_from_vtk(lut.GetClientSideObject(), pwf.GetClientSideObject())
    assert tf.scale == expected_tf.scale
    np.testing.assert_allclose(tf.values, expected_tf.values, rtol=1e-12)
    np.testing.assert_allclose(tf.colors, expected_tf.colors, atol=1e-12)
    np.testing.assert_allclose(tf.opacities, expected_tf.opacities, atol=1e-12)

    data = servermanager.Fetch(reader)
    direct = hv.render(data, expected_tf, camera, (48, 40), scalars=array, progress_bar=False)
    assert image.rgba.dtype == np.float32 and image.shape == (40, 48)
    assert image.rgba[..., 3].max() > 0.05
    np.testing.assert_allclose(image.rgba, direct.rgba, rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(image.depth, direct.depth)

    # a display array for the screen: uint8 RGB, the active scalars
    out = servermanager.Fetch(render)
    shown = out.GetPointData().GetScalars()
    assert shown.GetName() == "tonemapped" and shown.GetNumberOfComponents() == 3
    assert shown.GetDataTypeAsString() == "unsigned char"
    simple.Delete(render)


def test_clip_plane_and_crop_box_equal_python_api(plugin, shared_data):
    """Clip (Clip Origin, Clip Normal: the implicit-plane widget's properties) and Crop
    (Crop Origin, Crop Length: the box widget's) render what hv.render renders with
    clip_planes=/crop_box= (the kept side is where the normal points, VTK's), to the
    tolerance of test_render_equals_python_api; their defaults come from the input's
    bounds; moving the plane keeps the plan; a zero normal is refused; both off render
    the whole volume again."""
    reader, array = _reader(shared_data, ENGINE)
    lut, pwf, tf = _set_color_map(array, 20.0, 255.0, log=False)
    bounds = reader.GetDataInformation().GetBounds()
    camera = hv.Camera.fit(bounds, "iso")
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[48, 40], Camera="iso", LookupTable=lut,
                                       ScalarOpacityFunction=pwf)
    render.Scalars = ["POINTS", array]
    # off by default; the plane through the input's centre facing +x, the box the input's bounds
    assert (render.Clip, render.Crop) == (0, 0)
    np.testing.assert_allclose(render.ClipOrigin, [(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2,
                                                   (bounds[4] + bounds[5]) / 2])
    assert list(render.ClipNormal) == [1.0, 0.0, 0.0]
    np.testing.assert_allclose(render.CropOrigin, bounds[::2])
    np.testing.assert_allclose(render.CropLength, np.subtract(bounds[1::2], bounds[::2]))
    whole = _image(render).rgba.copy()
    data = servermanager.Fetch(reader)

    def direct(**clip):
        return hv.render(data, tf, camera, (48, 40), scalars=array, progress_bar=False, **clip)

    render.Clip = 1
    render.ClipOrigin = [120.0, 100.0, 60.0]
    render.ClipNormal = [0.3, 0.0, -1.0]
    render.Crop = 1
    render.CropOrigin = [20.0, 10.0, 0.0]
    render.CropLength = [200.0, 180.0, 127.0]
    crop_box = (20.0, 220.0, 10.0, 190.0, 0.0, 127.0)
    image = _image(render)
    expected = direct(clip_planes=((120.0, 100.0, 60.0), (0.3, 0.0, -1.0)), crop_box=crop_box)
    assert image.rgba[..., 3].max() > 0.05
    assert np.abs(expected.rgba - whole).max() > 0.05  # the cut shows
    np.testing.assert_allclose(image.rgba, expected.rgba, rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(image.depth, expected.depth)
    algorithm = render.GetClientSideObject()
    assert algorithm.GetCropBox() == crop_box

    # the widget dragged: a new plane re-renders with the same plan (no re-preparation)
    kept = algorithm._state.plan[1]
    render.ClipNormal = [0.0, -1.0, 0.0]
    image = _image(render)
    assert algorithm._state.plan[1].table is kept.table
    expected = direct(clip_planes=((120.0, 100.0, 60.0), (0.0, -1.0, 0.0)), crop_box=crop_box)
    np.testing.assert_allclose(image.rgba, expected.rgba, rtol=1e-6, atol=1e-7)

    # a zero normal is refused until fixed (not rendered with the previous plane)
    render.ClipNormal = [0.0, 0.0, 0.0]
    text = _error_text(render)
    assert text is not None and text.startswith("ValueError: Clip was refused"), text
    render.Clip = 0  # off: the plane is not used, nothing to refuse
    render.Crop = 0
    assert _error_text(render) is None
    np.testing.assert_array_equal(_image(render).rgba, whole)
    simple.Delete(render)


def test_properties_and_color_map_edits_re_execute(plugin, shared_data):
    reader, array = _reader(shared_data, ENGINE)
    lut, pwf, _ = _set_color_map(array, 20.0, 255.0, log=False)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[32, 32], Camera="iso", LookupTable=lut,
                                       ScalarOpacityFunction=pwf)
    render.Scalars = ["POINTS", array]
    first = _image(render).rgba.copy()
    render.GlobalAlpha = 0.5
    second = _image(render).rgba.copy()
    assert not np.array_equal(first, second)
    # editing the colour map in place (what the Color Map Editor does) re-executes too
    pwf.Points = [20.0, 0.0, 0.5, 0.0, 255.0, 0.9, 0.5, 0.0]
    third = _image(render).rgba.copy()
    assert not np.array_equal(second, third)
    render.Camera = "xy"
    fourth = _image(render).rgba.copy()
    assert not np.array_equal(third, fourth)
    simple.Delete(render)


def test_camera_follows_the_render_view(plugin, shared_data):
    reader, array = _reader(shared_data, ENGINE)
    view = simple.CreateView("RenderView")
    simple.SetActiveView(view)
    simple.Show(reader, view)
    simple.ResetCamera(view)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[24, 24])
    assert list(render.CameraPosition) == list(view.CameraPosition)
    assert render.InputIsStore == 0  # no out-of-core properties in the panel for a plain image
    # the filter took the array's colour map, as ParaView shows it
    assert render.LookupTable is not None and render.LookupTable == simple.GetColorTransferFunction(array)
    before = _image(render).rgba.copy()
    view.GetActiveCamera().Azimuth(30)
    simple.Render(view)
    assert list(render.CameraPosition) == list(view.CameraPosition)
    after = _image(render)
    assert not np.array_equal(before, after.rgba)
    camera = after.settings().camera
    np.testing.assert_allclose(camera.position, view.CameraPosition, rtol=1e-12)
    # what a view-direction button does (a direction, then Reset Camera, then one
    # render): that one render is the final camera's, not the one before the reset
    simple.Show(simple.OutputPort(render, 1), view)
    for direction in ("PositiveX", "NegativeY", "PositiveZ"):
        getattr(view.SMProxy, f"ResetActiveCameraTo{direction}")()
        view.SMProxy.ResetCamera()
        simple.Render(view)
        final = view.GetActiveCamera()
        # the image the view's render made (no update after it: Fetch would run the
        # filter again with whatever camera it has by then)
        shown = hv.HDRImage.from_pyvista(render.GetClientSideObject().GetOutputDataObject(0))
        np.testing.assert_array_equal(shown.settings().camera.position, final.GetPosition())
        np.testing.assert_array_equal(render.CameraFocalPoint, final.GetFocalPoint())
        assert (shown.rgba[..., 3] > 0.01).mean() > 0.05, direction  # the volume, not a speck
    # Follow View off: the camera stays
    render.FollowView = 0
    view.GetActiveCamera().Azimuth(30)
    simple.Render(view)
    assert list(render.CameraPosition) != list(view.CameraPosition)
    simple.Delete(render)
    simple.Delete(view)


def _error_text(proxy):
    """Update ``proxy`` and return what its algorithm reported."""
    proxy.UpdatePipeline()
    return proxy.GetClientSideObject().GetLastError()


def test_bad_input_gives_the_clear_message(plugin, shared_data):
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[8, 8], Camera="iso")
    render.Scalars = ["POINTS", "no_such_array"]
    text = _error_text(render)
    assert text is not None and "no_such_array" in text
    simple.Delete(render)
    # a polydata input: ParaView's input domain lists the filter for volumes only, and
    # a script that forces one gets the algorithm's message
    render = plugin["HDRVolumeRender"](Input=simple.Sphere(), ImageSize=[8, 8], Camera="iso")
    text = _error_text(render)
    from pv_hdrvol.data.kinds import SUPPORTED

    assert text == f"ValueError: HDRVolumeRenderer needs a non-empty volume on input port 0 ({SUPPORTED}); got vtkPolyData"
    simple.Delete(render)
    # size 0 is refused where it is set
    render = plugin["HDRVolumeRender"](Input=reader, Camera="iso")
    with pytest.raises(ValueError, match="size"):
        render.GetClientSideObject().SetImageSize(0, 10)
    simple.Delete(render)


def test_device_cuda_without_numba_cuda_says_what_is_missing(plugin, shared_data):
    """ParaView's Python (Debian's) has no numba-cuda: Device=cuda fails the render with
    the message naming it, and Device=cpu renders again."""
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[8, 8], Camera="iso", Device="cuda")
    text = _error_text(render)
    assert text is not None and text.startswith("DeviceUnavailableError: device='cuda' needs numba-cuda, which is "
                                                "not installed"), text
    assert "pip install 'pv_hdrvol[gpu]'" in text
    render.Device = "cpu"
    assert _error_text(render) is None
    simple.Delete(render)


def test_progress_reaches_paraview_and_abort_is_honoured(plugin, shared_data):
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[64, 48], Camera="iso",
                                       TransferFunction="pv_hdrvol default")
    render.Scalars = ["POINTS", array]
    algorithm = render.GetClientSideObject()
    seen = []
    tag = algorithm.AddObserver("ProgressEvent", lambda obj, _: seen.append(obj.GetProgress()))
    render.UpdatePipeline()
    assert len(seen) >= 3 and seen[-1] == 1.0 and seen == sorted(seen)
    algorithm.RemoveObserver(tag)
    # ParaView's abort button sets AbortExecute: the render stops and leaves no image
    tag = algorithm.AddObserver("ProgressEvent", lambda obj, _: obj.SetAbortExecute(1))
    render.GlobalAlpha = 0.7
    render.UpdatePipeline()
    assert algorithm.GetOutputDataObject(0).GetNumberOfPoints() == 0
    algorithm.RemoveObserver(tag)
    algorithm.SetAbortExecute(0)
    render.GlobalAlpha = 0.6
    assert _image(render).shape == (48, 64)
    simple.Delete(render)


def test_magnifier_lens_equals_python_api(plugin, shared_data):
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[40, 30], Camera="xy",
                                       TransferFunction="pv_hdrvol default", Lens="magnifier",
                                       LensCenter=[0.4, 0.5], LensRadius=0.3, LensMagnification=3.0)
    render.Scalars = ["POINTS", array]
    image = _image(render)
    data = servermanager.Fetch(reader)
    lens = hv.Magnifier(center=(16.0, 15.0), radius=9.0, factor=3.0)
    tf = image.settings(partial=True).tf  # the lens is not part of the settings
    direct = hv.render(data, tf, hv.Camera.fit(data.GetBounds(), "xy"), (40, 30), lens=lens, scalars=array,
                       progress_bar=False)
    np.testing.assert_array_equal(image.rgba, direct.rgba)
    render.Lens = "none"
    assert not np.array_equal(_image(render).rgba, image.rgba)
    simple.Delete(render)


def test_a_deleted_filter_is_freed(plugin, shared_data):
    import gc
    import weakref

    reader, array = _reader(shared_data, ENGINE)
    view = simple.CreateView("RenderView")
    simple.SetActiveView(view)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[16, 16])  # linked to the view, its colour map
    render.UpdatePipeline()
    render.FollowView = 0
    render.FollowView = 1  # relinks through the plugin's observer
    assert list(render.CameraPosition) == list(view.CameraPosition)
    algorithm = weakref.ref(render.GetClientSideObject())
    simple.Delete(render)
    del render
    gc.collect()
    assert algorithm() is None  # no observer keeps it (and its render plan) alive
    simple.Delete(view)


def test_pof_file_culls_with_the_family_of_its_bases(plugin, tmp_path):
    """POF File + Family Weights: the family of the POF's bases, culled, as hv.render(cull=)."""
    from pv_hdrvol.culling.pof import PlenopticOpacity

    wavelet = simple.Wavelet(WholeExtent=[0, 32, 0, 32, 0, 32])  # 4^3 blocks of 8^3
    wavelet.UpdatePipeline()
    data = servermanager.Fetch(wavelet)
    tf = hv.TransferFunction([30.0, 100.0, 280.0], [[1, 0.5, 0.2], [1, 0.8, 0.5], [1, 1, 1]], [0.9, 0.95, 0.99])
    pof = PlenopticOpacity.compute(data, [tf], block_size=8, threads=1)
    path = tmp_path / "wavelet.pof.npz"
    pof.save(path)
    view = simple.CreateView("RenderView")
    view.CameraParallelProjection = 1
    simple.SetActiveView(view)
    simple.Show(wavelet, view)
    simple.ResetCamera(view)
    render = plugin["HDRVolumeRender"](Input=wavelet, ImageSize=[40, 32])
    render.POFFile = str(path)
    render.FamilyWeights = "1.5"
    image = _image(render)
    culling = image.metadata["culling"]
    assert culling["culled"] > 0, culling
    camera = image.settings(partial=True).camera  # the POF itself is not a setting
    assert camera.parallel_projection and list(camera.position) == list(view.CameraPosition)
    family = hv.TransferFunction.family([tf], [1.5])
    direct = hv.render(data, family, camera, (40, 32), scalars="RTData", cull=pof, progress_bar=False)
    np.testing.assert_array_equal(image.rgba, direct.rgba)
    assert direct.metadata["culling"]["culled"] == culling["culled"]
    render.POFFile = ""  # off: the colour map again, no culling
    assert "culling" not in _image(render).metadata
    simple.Delete(render)
    simple.Delete(view)


def test_tolerance_chooses_the_knobs_and_step_waits_for_it(plugin):
    """Tolerance > 0: the renderer chooses step, termination, table and precision (the
    pixels of hv.render(..., tolerance=), bit for bit; the knobs in the output's
    metadata) while the panel's Step and Precision wait, without conflicting; 0: Step
    and Precision render again. The one tolerance render of these checks (a 16^3
    wavelet, 16^2 pixels: its float64 kernels compile on a cold numba 0.56 cache)."""
    wavelet = simple.Wavelet(WholeExtent=[0, 15, 0, 15, 0, 15])
    wavelet.UpdatePipeline()
    render = plugin["HDRVolumeRender"](Input=wavelet, ImageSize=[16, 16], Camera="iso",
                                       TransferFunction="pv_hdrvol default", Step=0.25, Precision="float64",
                                       Tolerance=1e-3)
    render.Scalars = ["POINTS", "RTData"]
    image = _image(render)
    record = image.metadata["tolerance"]
    assert record["tolerance"] == 1e-3 and record["precision"] == "float64" and record["step"] != 0.25
    assert image.settings().options == hv.RenderOptions(tolerance=1e-3)  # only the tolerance was passed
    data = servermanager.Fetch(wavelet)
    camera = hv.Camera.fit(data.GetBounds(), "iso")
    direct = hv.render(data, image.settings().tf, camera, (16, 16), scalars="RTData", tolerance=1e-3,
                       progress_bar=False)
    np.testing.assert_array_equal(image.rgba, direct.rgba)
    expected = dict(direct.metadata["tolerance"], pilot_seconds=None)
    assert dict(record, pilot_seconds=None) == expected
    assert render.GetClientSideObject().GetLastTolerance()["step"] == record["step"]

    render.Tolerance = 0.0  # off: the panel's Step and Precision, kept meanwhile
    plain = _image(render)
    assert "tolerance" not in plain.metadata
    assert plain.settings().options == hv.RenderOptions(step=0.25, precision="float64")
    _warnings(lambda: setattr(render, "Tolerance", -1.0))  # refused, not taken for "off"
    text = _error_text(render)
    assert text.startswith("ValueError: Tolerance was refused (ValueError: tolerance must be > 0; got -1.0)"), text
    render.Tolerance = 0.0
    assert _error_text(render) is None
    simple.Delete(render)
    simple.Delete(wavelet)


def _warnings(action):
    """What ``action()`` writes to VTK's output window."""
    from vtkmodules.vtkCommonCore import vtkOutputWindow, vtkStringOutputWindow

    window, previous = vtkStringOutputWindow(), vtkOutputWindow.GetInstance()
    vtkOutputWindow.SetInstance(window)
    try:
        action()
    finally:
        vtkOutputWindow.SetInstance(previous)
    return window.GetOutput()


def test_in_view_output_is_the_image_at_its_depth(plugin, shared_data):
    """Port 1: one quad per visible pixel with its colours, seen from the render's camera
    at the pixel's depth (the unit test checks the geometry; here, that ParaView gets it)."""
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[40, 30], Camera="iso",
                                       TransferFunction="pv_hdrvol default")
    image = _image(render)
    surface = render.GetClientSideObject().GetOutputDataObject(1)
    assert surface.GetClassName() == "vtkPolyData"
    visible = (image.rgba[..., 3] >= 0.5 / 255).sum()
    assert visible > 100 and surface.GetNumberOfCells() == visible
    colors = surface.GetCellData().GetArray("colors")
    assert colors.GetNumberOfComponents() == 4 and colors.GetDataTypeAsString() == "unsigned char"
    simple.Delete(render)


def test_a_refused_value_fails_the_render_until_fixed(plugin, shared_data):
    """A value a setter refuses is not silently replaced by the previous one: the next
    update fails with it (GetLastError), a valid value renders again."""
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[16, 12], Camera="iso",
                                       TransferFunction="pv_hdrvol default")
    assert _error_text(render) is None
    # through the proxy, as the Properties panel and scripts set it: the setter's
    # exception is printed by ParaView, the property holds the refused value
    said = _warnings(lambda: setattr(render, "ImageSize", [0, 10]))
    text = _error_text(render)
    assert text.startswith("ValueError: Image Size was refused (ValueError: ") and "set a valid value" in text, text
    render.ImageSize = [20, 10]
    assert _error_text(render) is None and _image(render).rgba.shape == (10, 20, 4)
    render.POFFile = "/no/such.pof.npz"
    assert _error_text(render).startswith("ValueError: POF File was refused (ValueError: POF File "
                                          "'/no/such.pof.npz' is not a file")
    render.POFFile = ""
    assert _error_text(render) is None
    tone = plugin["HDRToneMap"](Input=render)  # no Parameters: no traceback (ParaView pushes None)
    said = _warnings(tone.UpdatePipeline)
    assert tone.GetClientSideObject().GetLastError() is None and "Traceback" not in said, said
    tone.Parameters = "key"
    tone.UpdatePipeline()
    assert tone.GetClientSideObject().GetLastError().startswith("ValueError: Parameters was refused")
    simple.Delete(tone)
    simple.Delete(render)


def test_color_map_editor_without_a_lookup_table_says_so(plugin, shared_data):
    reader, array = _reader(shared_data, ENGINE)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[16, 12], Camera="iso")
    assert render.LookupTable == simple.GetColorTransferFunction(array)
    render.LookupTable = None
    render.ScalarOpacityFunction = None
    said = _warnings(render.UpdatePipeline)
    assert "Transfer Function is 'Color Map Editor' but its Lookup Table is not set" in said, said
    assert "LookupTable = GetColorTransferFunction(array)" in said
    render.TransferFunction = "pv_hdrvol default"
    assert "Lookup Table" not in _warnings(render.UpdatePipeline)
    simple.Delete(render)


def test_lookup_table_follows_scalars_set_after_the_filter(plugin):
    """A script sets Scalars after making the filter: the plugin's lookup table follows
    the new array; one the user set is kept."""
    source = simple.Wavelet()
    calculator = simple.Calculator(Input=source, ResultArrayName="doubled", Function="2*RTData")
    calculator.UpdatePipeline()
    render = plugin["HDRVolumeRender"](Input=calculator, ImageSize=[8, 8], Camera="iso")
    render.Scalars = ["POINTS", "RTData"]
    assert render.LookupTable == simple.GetColorTransferFunction("RTData")
    render.Scalars = ["POINTS", "doubled"]
    assert render.LookupTable == simple.GetColorTransferFunction("doubled")
    assert render.ScalarOpacityFunction == simple.GetOpacityTransferFunction("doubled")
    mine = simple.GetColorTransferFunction("mine")
    render.LookupTable = mine
    render.Scalars = ["POINTS", "RTData"]
    assert render.LookupTable == mine
    simple.Delete(render)


def test_meshes_in_front_hide_the_volume_and_behind_are_hidden(plugin, shared_data, tmp_path):
    """The In View surface lies at the volume's depth: an opaque sphere between the camera
    and the volume covers it, the same sphere behind the volume is covered where the
    volume is opaque."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader

    reader, array = _reader(shared_data, ENGINE)
    view = simple.CreateView("RenderView")
    view.ViewSize = [160, 120]
    view.OrientationAxesVisibility = 0
    view.Background = [0.0, 0.0, 0.0]
    view.UseColorPaletteForBackground = 0
    simple.SetActiveView(view)
    simple.ResetCamera(view)  # no input shown: frame the volume by hand
    bounds = reader.GetDataInformation().GetBounds()
    centre = [(bounds[0] + bounds[1]) / 2, (bounds[2] + bounds[3]) / 2, (bounds[4] + bounds[5]) / 2]
    view.CameraFocalPoint = centre
    view.CameraPosition = [centre[0], centre[1], centre[2] + 800.0]
    view.CameraViewUp = [0.0, 1.0, 0.0]
    # a colour map of its own (other tests edit the array's), opaque above 60
    lut, pwf = simple.GetColorTransferFunction("occlusion"), simple.GetOpacityTransferFunction("occlusion")
    lut.RGBPoints = [0.0, 1.0, 0.3, 0.3, 255.0, 1.0, 0.9, 0.8]
    pwf.Points = [0.0, 0.0, 0.5, 0.0, 60.0, 0.0, 0.5, 0.0, 90.0, 1.0, 0.5, 0.0, 255.0, 1.0, 0.5, 0.0]
    render = plugin["HDRVolumeRender"](Input=reader, LookupTable=lut, ScalarOpacityFunction=pwf)
    assert list(render.ImageSize) == [160, 120]
    shown = simple.Show(simple.OutputPort(render, 1), view)
    assert shown.MapScalars == 0 and shown.Ambient == 1.0 and shown.Diffuse == 0.0
    image = _image(render)
    opaque = image.rgba[..., 3] >= 0.999

    def screenshot(name):
        path = str(tmp_path / name)
        simple.SaveScreenshot(path, view, ImageResolution=[160, 120])
        png = vtkPNGReader()
        png.SetFileName(path)
        png.Update()
        return vtk_to_numpy(png.GetOutput().GetPointData().GetScalars()).reshape(120, 160, -1)[::-1, :, :3]

    sphere = simple.Sphere(Center=centre, Radius=20.0, ThetaResolution=32, PhiResolution=32)
    simple.Show(sphere, view)
    sphere_shown = simple.GetDisplayProperties(sphere, view)
    sphere_shown.AmbientColor = sphere_shown.DiffuseColor = [0.0, 1.0, 0.0]
    sphere_shown.Ambient, sphere_shown.Diffuse = 1.0, 0.0  # flat green, whatever the lights

    def green(shot):
        shot = shot.astype(int)
        return (shot[..., 1] > 200) & (shot[..., 0] < 60) & (shot[..., 2] < 60)

    sphere.Center = [centre[0], centre[1], bounds[5] + 100.0]  # between the camera and the volume
    front = green(screenshot("front.png"))
    assert front[57:63, 77:83].all()  # the sphere covers the middle of the view
    covered = front & opaque  # where the sphere hides opaque volume
    assert covered.sum() > 100, covered.sum()
    sphere.Center = [centre[0], centre[1], bounds[4] - 100.0]  # behind the volume
    behind = screenshot("behind.png").astype(int)
    simple.Hide(sphere, view)
    alone = screenshot("alone.png").astype(int)
    # where the volume is opaque the sphere behind it changes nothing
    # (one of 139 such pixels differed in a full run, by 19 levels; none run alone)
    diff = np.abs(behind - alone).max(axis=2)
    bad = covered & (diff > 1)
    assert bad.sum() <= covered.sum() // 50, (bad.sum(), covered.sum(), np.argwhere(bad)[:5], diff[bad][:5])
    simple.Delete(sphere)
    simple.Delete(render)
    simple.Delete(view)


def test_a_plot3d_reader_renders_its_curvilinear_block(plugin, shared_data):
    """What a user of a CFD code does: open a PLOT3D grid and solution with ParaView's
    reader (a multiblock of one curvilinear vtkStructuredGrid) and apply HDR Volume
    Render: each hexahedron is split into five tetrahedra, as hv.render splits it."""
    folder = shared_data / "unstructured" / "plot3d_original"
    reader = simple.PLOT3DReader(FileName=str(folder / "bluntfinxyz.bin"), QFileName=[str(folder / "bluntfinq.bin")])
    reader.UpdatePipeline()
    data = servermanager.Fetch(reader)
    assert data.GetClassName() == "vtkMultiBlockDataSet" and data.GetBlock(0).GetClassName() == "vtkStructuredGrid"
    lut, pwf = simple.GetColorTransferFunction("Density"), simple.GetOpacityTransferFunction("Density")
    lut.ApplyPreset("Inferno (matplotlib)", True)
    render = plugin["HDRVolumeRender"](Input=reader, ImageSize=[40, 32], Camera="iso", LookupTable=lut,
                                       ScalarOpacityFunction=pwf)
    render.Scalars = ["POINTS", "Density"]
    image = _image(render)
    tf = transfer_function_from_vtk(lut.GetClientSideObject(), pwf.GetClientSideObject())
    camera = hv.Camera.fit(reader.GetDataInformation().GetBounds(), "iso")
    direct = hv.render(data, tf, camera, (40, 32), scalars="Density", progress_bar=False)
    assert direct.metadata["blocks"]["kind"] == "mesh" and image.rgba[..., 3].max() > 0.01
    np.testing.assert_allclose(image.rgba, direct.rgba, rtol=1e-6, atol=1e-7)
    simple.Delete(render)
