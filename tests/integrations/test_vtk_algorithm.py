"""HDRVolumeRenderer in a plain VTK pipeline."""
import re
import subprocess
import sys

import numpy as np
import pytest
from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkImageData
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as SDDP
from vtkmodules.vtkImagingCore import vtkRTAnalyticSource
from vtkmodules.vtkRenderingCore import vtkCamera

import pv_hdrvol as hv
from pv_hdrvol.datasets import demo_transfer_function, hydrogen_orbital_array
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer
from vtk_capture import CapturedErrors

W, H = 24, 64  # 64 rows: the render reports progress in more than one chunk


def _image_data():
    """A plain vtkImageData (no PyVista) holding the 2p_z orbital and a second array."""
    values, spacing, origin = hydrogen_orbital_array(2, 1, 0, size=17, extent=12.0)
    img = vtkImageData()
    img.SetDimensions(17, 17, 17)
    img.SetSpacing(spacing)
    img.SetOrigin(origin)
    arr = numpy_to_vtk(values.reshape(-1), deep=True)
    arr.SetName("probability_density")
    img.GetPointData().AddArray(arr)
    img.GetPointData().SetActiveScalars("probability_density")
    cells = numpy_to_vtk(np.linspace(0.0, 1.0, img.GetNumberOfCells()), deep=True)
    cells.SetName("ramp")
    img.GetCellData().AddArray(cells)
    vec = numpy_to_vtk(np.ones((img.GetNumberOfPoints(), 3)), deep=True)
    vec.SetName("vector")
    img.GetPointData().AddArray(vec)
    return img


def _camera():
    cam = hv.Camera((40.0, -30.0, 20.0), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0), view_angle=35.0)
    vcam = vtkCamera()
    vcam.SetPosition(cam.position)
    vcam.SetFocalPoint(cam.focal_point)
    vcam.SetViewUp(cam.view_up)
    vcam.SetViewAngle(cam.view_angle)
    return cam, vcam


def _renderer(source):
    alg = HDRVolumeRenderer()
    if isinstance(source, vtkImageData):
        alg.SetInputDataObject(source)
    else:
        alg.SetInputConnection(source.GetOutputPort())
    alg.SetImageSize(W, H)
    return alg


def _rgba(output):
    """Output arrays back in (rows, cols) order with row 0 at the top."""
    cols, rows, one = output.GetDimensions()
    assert one == 1
    rgba = vtk_to_numpy(output.GetPointData().GetArray("rgba")).reshape(rows, cols, 4)[::-1]
    depth = vtk_to_numpy(output.GetPointData().GetArray("depth")).reshape(rows, cols)[::-1]
    return rgba, depth


def test_matches_hv_render_exactly():
    data = _image_data()
    cam, vcam = _camera()
    tf = demo_transfer_function(vmax=5e-3)
    alg = _renderer(data)
    alg.SetTransferFunction(tf)
    alg.SetCamera(vcam)
    alg.SetStep(0.6)
    alg.SetPrecision("float64")
    alg.SetGlobalAlpha(0.5)
    alg.SetTermination(0.0)
    assert alg.Update() is True
    out = alg.GetOutputDataObject(0)
    assert alg.GetOutput() is out
    assert out.GetDimensions() == (W, H, 1) and out.GetExtent() == (0, W - 1, 0, H - 1, 0, 0)
    assert out.GetPointData().GetArray("rgba").GetNumberOfComponents() == 4
    rgba, depth = _rgba(out)
    ref = hv.render(data, tf, cam, (W, H), step=0.6, precision="float64", global_alpha=0.5, termination=0.0)
    assert rgba.dtype == np.float64
    np.testing.assert_array_equal(rgba, ref.rgba)
    np.testing.assert_array_equal(depth, ref.depth)
    assert ref.rgba[..., 3].max() > 0.01  # not a trivially empty picture
    np.testing.assert_array_equal(hv.HDRImage.from_pyvista(out).rgba, ref.rgba)


def test_clipping_planes_as_a_vtk_mapper_takes_them_and_a_crop_box():
    from vtkmodules.vtkCommonDataModel import vtkPlane

    data = _image_data()
    cam, vcam = _camera()
    tf = demo_transfer_function(vmax=5e-3)
    alg = _renderer(data)
    alg.SetTransferFunction(tf)
    alg.SetCamera(vcam)
    alg.SetPrecision("float64")
    plane = vtkPlane()
    plane.SetOrigin(0.0, 0.0, 0.5)
    plane.SetNormal(0.3, 0.0, -1.0)
    alg.AddClippingPlane(plane)
    alg.AddClippingPlane(((0.0, -2.0, 0.0), (0.0, 1.0, 0.0)))
    alg.SetCropBox(-8.0, 9.0, -20.0, 20.0, -20.0, 20.0)
    assert alg.Update() is True
    rgba, depth = _rgba(alg.GetOutput())
    clip = {"clip_planes": [((0.0, 0.0, 0.5), (0.3, 0.0, -1.0)), ((0.0, -2.0, 0.0), (0.0, 1.0, 0.0))],
            "crop_box": (-8.0, 9.0, -20.0, 20.0, -20.0, 20.0)}
    ref = hv.render(data, tf, cam, (W, H), precision="float64", **clip)
    np.testing.assert_array_equal(rgba, ref.rgba)
    np.testing.assert_array_equal(depth, ref.depth)
    planes = alg.GetClippingPlanes()
    assert planes.GetNumberOfItems() == 2 and planes.GetItem(1).GetOrigin() == (0.0, -2.0, 0.0)
    assert alg.GetCropBox() == (-8.0, 9.0, -20.0, 20.0, -20.0, 20.0)
    # moving the plane (a widget dragged): the plan's tables stay, the picture follows
    kept = alg._state.plan[1]
    alg.SetClippingPlanes([((0.0, 0.0, -0.5), (0.3, 0.0, -1.0))])
    assert alg.Update() is True
    assert alg._state.plan[1].table is kept.table
    ref = hv.render(data, tf, cam, (W, H), precision="float64", clip_planes=((0.0, 0.0, -0.5), (0.3, 0.0, -1.0)),
                    crop_box=clip["crop_box"])
    np.testing.assert_array_equal(_rgba(alg.GetOutput())[0], ref.rgba)
    alg.RemoveAllClippingPlanes()
    alg.SetCropBox(None)
    assert alg.Update() is True
    whole = hv.render(data, tf, cam, (W, H), precision="float64")
    np.testing.assert_array_equal(_rgba(alg.GetOutput())[0], whole.rgba)
    assert np.abs(whole.rgba - ref.rgba).max() > 1e-3
    with pytest.raises(ValueError, match="crop_box needs min < max on every axis"):
        alg.SetCropBox(0, 1, 0, 1, 1, 0)


def test_tetrahedral_mesh_input():
    """A vtkUnstructuredGrid of tets (a triangulated image) renders as hv.render renders it."""
    from vtkmodules.vtkFiltersGeneral import vtkDataSetTriangleFilter

    tri = vtkDataSetTriangleFilter()
    tri.SetInputData(_image_data())
    tri.Update()
    mesh = tri.GetOutput()
    cam, vcam = _camera()
    tf = demo_transfer_function(vmax=0.02)
    alg = _renderer(tri)
    alg.SetTransferFunction(tf)
    alg.SetCamera(vcam)
    alg.SetPrecision("float64")
    assert alg.Update()
    rgba, depth = _rgba(alg.GetOutput())
    ref = hv.render(mesh, tf, cam, (W, H), precision="float64")
    assert ref.metadata["renderer"] == "pv_hdrvol tetrahedral ray caster" and ref.rgba[..., 3].max() > 0.05
    np.testing.assert_array_equal(rgba, ref.rgba)
    np.testing.assert_array_equal(depth, ref.depth)
    alg.SetLens(hv.Fisheye())
    assert not alg.Update()
    assert alg.GetLastError() == ("ValueError: SetLens, SetLabels and SetCull apply to image data only, not to "
                                  "a vtkUnstructuredGrid")


def test_defaults_and_source_connection():
    source = vtkRTAnalyticSource()
    source.SetWholeExtent(-6, 6, -6, 6, -6, 6)
    alg = _renderer(source)
    alg.SetStep(1.0)
    assert alg.Update() is True
    # the whole input was requested and rendered with the default (iso) camera
    assert source.GetOutput().GetExtent() == (-6, 6, -6, 6, -6, 6)
    ref = hv.render(source.GetOutput(), None, hv.Camera.fit(source.GetOutput().GetBounds(), "iso"), (W, H), step=1.0)
    np.testing.assert_array_equal(_rgba(alg.GetOutputDataObject(0))[0], ref.rgba)


def test_whole_extent_from_request_information():
    alg = _renderer(_image_data())
    alg.SetImageSize(40, 30)
    alg.UpdateInformation()
    assert alg.GetOutputInformation(0).Get(SDDP.WHOLE_EXTENT()) == (0, 39, 0, 29, 0, 0)


def test_progress_events_and_abort():
    alg = _renderer(_image_data())
    seen = []
    alg.AddObserver(vtkCommand.ProgressEvent, lambda obj, event: seen.append(obj.GetProgress()))
    assert alg.Update() is True
    assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)
    assert any(0.0 < f < 1.0 for f in seen)

    aborter = HDRVolumeRenderer()
    aborter.SetInputDataObject(_image_data())
    aborter.SetImageSize(W, H)

    def stop(obj, event):
        if 0.0 < obj.GetProgress() < 1.0:
            obj.SetAbortExecute(1)

    aborter.AddObserver(vtkCommand.ProgressEvent, stop)
    assert aborter.Update() is True  # an abort is not an error
    assert aborter.GetOutputDataObject(0).GetNumberOfPoints() == 0
    assert aborter.GetAbortExecute() == 1 and aborter.GetLastError() is None


def test_input_is_not_modified():
    data = _image_data()
    mtime = data.GetMTime()
    before = {data.GetPointData().GetArrayName(i): vtk_to_numpy(data.GetPointData().GetArray(i)).copy()
              for i in range(data.GetPointData().GetNumberOfArrays())}
    alg = _renderer(data)
    alg.SetScalars("probability_density")
    assert alg.Update() is True
    assert data.GetMTime() == mtime
    assert data.GetPointData().GetNumberOfArrays() == len(before)
    assert data.GetPointData().GetScalars().GetName() == "probability_density"
    for name, values in before.items():
        np.testing.assert_array_equal(vtk_to_numpy(data.GetPointData().GetArray(name)), values)


@pytest.mark.parametrize(("scalars", "message"), [
    ("nope", "ScalarsError: scalars 'nope' not found; point arrays: "
             "['probability_density', 'vector'], cell arrays: ['ramp']"),
    ("vector", "ScalarsError: scalars 'vector' must have one component; got shape (4913, 3)"),
])
def test_errors_fail_the_update_with_the_message(scalars, message):
    alg = _renderer(_image_data())
    assert alg.Update() is True and alg.GetOutputDataObject(0).GetNumberOfPoints() == W * H
    alg.SetScalars(scalars)
    events = []
    alg.AddObserver(vtkCommand.ErrorEvent, lambda obj, event: events.append(event))
    with CapturedErrors() as captured:
        ok = alg.Update()
    assert ok is False
    assert events == ["ErrorEvent"]
    assert alg.GetLastError() == message
    assert "HDRVolumeRenderer (0x" in captured.text and message in captured.text
    assert alg.GetOutputDataObject(0).GetNumberOfPoints() == 0  # the previous picture is gone
    # fixing the cause clears the error
    alg.SetScalars("probability_density")
    with CapturedErrors() as captured:
        assert alg.Update() is True
    assert alg.GetLastError() is None and captured.text == ""


def test_input_array_to_process_selects_cell_data():
    data = _image_data()
    alg = _renderer(data)
    alg.SetStep(1.0)
    alg.SetInputArrayToProcess(0, 0, 0, vtkDataObject.FIELD_ASSOCIATION_CELLS, "ramp")
    assert alg.Update() is True
    ref = hv.render(data, None, hv.Camera.fit(data.GetBounds(), "iso"), (W, H), scalars="ramp",
                    preference="cell", step=1.0)
    np.testing.assert_array_equal(_rgba(alg.GetOutputDataObject(0))[0], ref.rgba)


def test_setters_validate_through_render_options_and_modify():
    alg = HDRVolumeRenderer()
    assert alg.GetOptions() == hv.RenderOptions()
    t0 = alg.GetMTime()
    alg.SetStep(0.25)
    t1 = alg.GetMTime()
    assert t1 > t0 and alg.GetStep() == 0.25 and alg.GetOptions() == hv.RenderOptions(step=0.25)
    alg.SetStep(0.25)  # unchanged value: no Modified()
    assert alg.GetMTime() == t1
    alg.SetSkipEmpty(0)
    assert alg.GetSkipEmpty() is False and alg.GetMTime() > t1
    alg.SkipEmptyOn()
    assert alg.GetSkipEmpty() is True
    alg.SetOpacityUnitDistance(2.0)
    alg.SetDepthThreshold(0.5)
    alg.SetBlockSize(16)
    assert alg.GetOptions() == hv.RenderOptions(step=0.25, opacity_unit_distance=2.0, depth_threshold=0.5,
                                                block_size=16)
    with pytest.raises(ValueError, match=r"step must be > 0; got 0"):
        alg.SetStep(0)
    with pytest.raises(ValueError, match=r"precision must be one of \['float64', 'float32', 'float16', 'uint8'\]; "
                                         r"got 'double'"):
        alg.SetPrecision("double")
    with pytest.raises(ValueError, match=r"global_alpha must be <= 1; got 2"):
        alg.SetGlobalAlpha(2)
    with pytest.raises(ValueError, match=r"block_size must be a power of two; got 12"):
        alg.SetBlockSize(12)
    with pytest.raises(TypeError, match=r"skip_empty must be a bool; got 'yes'"):
        alg.SetSkipEmpty("yes")
    assert alg.GetOptions().step == 0.25  # failed setters change nothing
    with pytest.raises(TypeError, match=r"options must be a RenderOptions; got dict"):
        alg.SetOptions({"step": 1.0})

    alg.SetImageSize(320, 200)
    assert alg.GetImageSize() == (320, 200)
    alg.SetImageSize((64, 48))
    assert alg.GetImageSize() == (64, 48)
    with pytest.raises(ValueError, match=r"size\[0\] \(width\) must be >= 1; got 0"):
        alg.SetImageSize(0, 10)
    with pytest.raises(TypeError, match=r"the transfer function must be a pv_hdrvol TransferFunction or None; got str"):
        alg.SetTransferFunction("magma")
    with pytest.raises(ValueError, match=r"preference must be one of \['point', 'cell'\]; got 'points'"):
        alg.SetPreference("points")
    with pytest.raises(TypeError, match=r"scalars must be an array name \(str\) or None; got 3"):
        alg.SetScalars(3)
    with pytest.raises(ValueError, match=r"view must be one of \['iso', .*\]; got 'front'"):
        alg.SetCamera("front")
    with pytest.raises(TypeError, match=r"camera must be None, a view name .*; got float"):
        alg.SetCamera(1.5)
    _, vcam = _camera()
    alg.SetCamera(vcam)
    assert isinstance(alg.GetCamera(), hv.Camera) and alg.GetCamera().view_angle == 35.0


def _option_values():
    """A value other than the default for each RenderOptions field, as its setter takes it."""
    from pv_hdrvol.params import ClipPlane

    return {"step": 0.25, "precision": "float64", "global_alpha": 0.5, "opacity_unit_distance": 2.0,
            "termination": 1e-3, "depth_threshold": 0.5, "block_size": 8, "skip_empty": False,
            "blending": "maximum", "gradient_opacity": (0.1, 0.5), "shade": True, "ambient": 0.3, "diffuse": 0.5,
            "specular": 0.1, "specular_power": 20.0, "lights": (1.0, 0.0, 0.0), "shade_gradient": "interpolated",
            "shade_threshold": 0.05, "tolerance": 1e-3, "clip_planes": [((0.0, 0.0, 0.0), (1.0, 0.0, 0.0))],
            "crop_box": (0.0, 1.0, 0.0, 1.0, 0.0, 1.0), "device": "cuda"}, ClipPlane


def test_every_render_option_has_its_generated_set_and_get():
    """Each RenderOptions field is a VTK property ``Set<Field>``/``Get<Field>`` (its name
    in CamelCase, as ParaView's properties call them), made from the field and not
    written by hand; a bool field also has ``<Field>On``/``<Field>Off``. The setter
    replaces the one field and calls Modified(); the getter reads it back."""
    import dataclasses

    from pv_hdrvol.integrations.vtk_algorithm import OPTION_PROPERTIES, option_property_name

    values, ClipPlane = _option_values()
    fields = [f for f in dataclasses.fields(hv.RenderOptions)]
    assert sorted(values) == sorted(f.name for f in fields)  # a new field gets a value here too
    assert sorted(OPTION_PROPERTIES) == sorted(values)  # ... and its meaning in the table
    assert option_property_name("opacity_unit_distance") == "OpacityUnitDistance"
    for field in fields:
        name = option_property_name(field.name)
        setter, getter = getattr(HDRVolumeRenderer, f"Set{name}"), getattr(HDRVolumeRenderer, f"Get{name}")
        assert setter.__module__ == getter.__module__ == "pv_hdrvol.integrations.vtk_algorithm"
        assert setter.__name__ == f"Set{name}" and f"RenderOptions.{field.name}" in setter.__doc__
        # made by the generator (its closures), not written in the class body
        assert setter.__code__.co_name == "setter" and getter.__code__.co_name == "getter", name
        assert (hasattr(HDRVolumeRenderer, f"{name}On") and hasattr(HDRVolumeRenderer, f"{name}Off")) \
            == (field.type in (bool, "bool")), name
        alg = HDRVolumeRenderer()
        if field.name == "tolerance":  # the knobs it chooses stay at their defaults
            alg.SetOptions(hv.RenderOptions())
        t0 = alg.GetMTime()
        getattr(alg, f"Set{name}")(values[field.name])
        assert alg.GetMTime() > t0, name
        expected = hv.RenderOptions(**{field.name: values[field.name]})
        assert alg.GetOptions() == expected, name
        got = getattr(alg, f"Get{name}")()
        assert got == getattr(expected, field.name), name
    # VTK's words: a tolerance of 0 is off, a crop box as 6 numbers, bools as 0/1
    alg = HDRVolumeRenderer()
    alg.SetTolerance(0)
    assert alg.GetTolerance() == 0.0 and alg.GetOptions().tolerance is None
    alg.SetCropBox(0, 1, 0, 1, 0, 1)
    assert alg.GetCropBox() == (0.0, 1.0, 0.0, 1.0, 0.0, 1.0)
    alg.SetShade(1)
    assert alg.GetShade() is True
    alg.ShadeOff()
    assert alg.GetShade() is False
    alg.SetClipPlanes(values["clip_planes"])
    assert alg.GetClipPlanes() == (ClipPlane((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)),)
    assert alg.GetClippingPlanes().GetNumberOfItems() == 1  # vtkVolumeMapper's name: a vtkPlaneCollection
    with pytest.raises(TypeError):
        alg.SetStep(0.25, 0.5)  # one value


def test_a_hand_written_option_method_is_refused():
    """The generated methods are the only ones: writing one by hand is an error when the
    class is made, so that a field has one meaning in every front end."""
    from pv_hdrvol.integrations.vtk_algorithm import _with_option_properties

    class Renderer(HDRVolumeRenderer):
        def SetStep(self, value):
            pass

    with pytest.raises(TypeError, match=r"Renderer.SetStep is made from RenderOptions.step"):
        _with_option_properties(Renderer)


def test_the_paraview_plugin_calls_only_methods_the_algorithm_has():
    """Every HDRVolumeRenderer method the ParaView plugin's filter calls (``super().X``,
    ``HDRVolumeRenderer.X``, ``self.X``) and every ``command`` of its XML properties
    exists (read from the plugin's source: ParaView is not needed)."""
    import ast
    import pathlib

    source = (pathlib.Path(__file__).resolve().parents[2] / "paraview_plugin" / "pv_hdrvol_plugin.py").read_text()
    tree = ast.parse(source)
    plugin = next(n for n in ast.walk(tree) if isinstance(n, ast.ClassDef) and n.name == "HDRVolumeRender")
    own = {n.name for n in plugin.body if isinstance(n, ast.FunctionDef)}
    called = set()
    for node in ast.walk(plugin):
        if isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Load) and node.attr[:1].isupper():
            target = node.value
            if (isinstance(target, ast.Call) and getattr(target.func, "id", None) == "super") \
                    or getattr(target, "id", None) in ("HDRVolumeRenderer", "self"):
                called.add(node.attr)
    called |= set(re.findall(r'command="(\w+)"', ast.get_source_segment(source, plugin)))
    assert {"SetGlobalAlpha", "SetOptions", "SetCropBox", "SetClippingPlanes", "SetInputArrayToProcess"} <= called
    missing = sorted(name for name in called if name not in own and not hasattr(HDRVolumeRenderer, name))
    assert missing == []


def test_tolerance_round_trips_as_a_vtk_number_and_conflicts_with_the_knobs_it_chooses():
    """SetTolerance/GetTolerance: a number, 0 (or None) for off; RenderOptions says None
    then. With a tolerance on, Step, Termination and Precision stay at their defaults:
    setting one is RenderOptions' ValueError, in either order, and changes nothing."""
    alg = HDRVolumeRenderer()
    assert alg.GetTolerance() == 0.0 and alg.GetOptions().tolerance is None
    t0 = alg.GetMTime()
    alg.SetTolerance(1e-3)
    t1 = alg.GetMTime()
    assert t1 > t0 and alg.GetTolerance() == 1e-3 and alg.GetOptions() == hv.RenderOptions(tolerance=1e-3)
    alg.SetTolerance(1e-3)  # unchanged: no Modified()
    assert alg.GetMTime() == t1
    knobs = "tolerance= chooses step, termination, precision: leave them at their defaults or drop tolerance; got "
    for setter, value, shown in (("SetStep", 0.25, "step=0.25"), ("SetTermination", 1e-3, "termination=0.001"),
                                 ("SetPrecision", "float64", "precision='float64'")):
        with pytest.raises(ValueError, match="^" + re.escape(knobs + shown) + "$"):
            getattr(alg, setter)(value)
    assert alg.GetOptions() == hv.RenderOptions(tolerance=1e-3) and alg.GetMTime() == t1
    alg.SetTolerance(0)
    assert alg.GetTolerance() == 0.0 and alg.GetOptions() == hv.RenderOptions() and alg.GetMTime() > t1
    t2 = alg.GetMTime()
    alg.SetTolerance(None)  # also off: unchanged
    assert alg.GetTolerance() == 0.0 and alg.GetMTime() == t2
    alg.SetStep(0.25)
    with pytest.raises(ValueError, match="^" + re.escape(knobs + "step=0.25") + "$"):
        alg.SetTolerance(1e-3)
    assert alg.GetTolerance() == 0.0 and alg.GetStep() == 0.25
    with pytest.raises(ValueError, match=r"^tolerance must be > 0; got -0\.001$"):
        alg.SetTolerance(-1e-3)
    with pytest.raises(ValueError, match=r"^tolerance must be <= 0\.5; got 0\.7$"):
        alg.SetTolerance(0.7)


def test_proxy_writer_refuses_a_tolerance(tmp_path):
    """make_proxies casts at one step: a tolerance is refused, not silently dropped."""
    from pv_hdrvol.integrations.vtk_algorithm import HDRProxyWriter

    writer = HDRProxyWriter()
    writer.SetInputDataObject(_image_data())
    writer.SetFileName(str(tmp_path / "p.proxy"))
    writer.SetTolerance(1e-3)
    with CapturedErrors():
        assert not writer.Update()
    assert writer.GetLastError() == ("ValueError: HDRProxyWriter casts its proxies at SetStep's step; SetTolerance "
                                     "chooses the knobs of a render, not of proxies: SetTolerance(0); got "
                                     "tolerance=0.001")
    assert not (tmp_path / "p.proxy").exists()


def test_module_does_not_import_pyvista():
    # ParaView's Python has VTK but not necessarily PyVista: the algorithm module must not need it
    code = "import sys; import pv_hdrvol.integrations.vtk_algorithm; print('pyvista' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == "False"


def test_rays_are_refused_as_camera():
    rays = hv.Camera().rays((4, 4))
    with pytest.raises(TypeError, match=r"SetCamera takes a Camera, a vtkCamera or a view name, not Rays"):
        HDRVolumeRenderer().SetCamera(rays)


def test_an_extent_that_does_not_start_at_zero_is_placed_where_vtk_places_it():
    # vtkRTAnalyticSource's extent starts at -6: its first point is at origin + (-6) * spacing
    source = vtkRTAnalyticSource()
    source.SetWholeExtent(-6, 6, -6, 6, -6, 6)
    source.Update()
    shifted = source.GetOutput()
    moved = vtkImageData()
    moved.DeepCopy(shifted)
    moved.SetExtent(0, 12, 0, 12, 0, 12)
    moved.SetOrigin(-6.0, -6.0, -6.0)
    assert shifted.GetBounds() == moved.GetBounds() == (-6.0, 6.0, -6.0, 6.0, -6.0, 6.0)
    assert hv.volume_from_dataset(shifted).bounds == hv.volume_from_dataset(moved).bounds
    tf = hv.TransferFunction.ramp(40.0, 280.0, cmap="gray", opacity=(0.0, 0.2))
    camera = hv.Camera.fit(shifted.GetBounds(), "xz")
    a = hv.render(shifted, tf, camera, (12, 10), progress_bar=False)
    b = hv.render(moved, tf, camera, (12, 10), progress_bar=False)
    assert a.rgba[..., 3].max() > 0.1
    np.testing.assert_array_equal(a.rgba, b.rgba)


def test_cull_with_plenoptic_opacity():
    """SetCull(pof): the same pixels and counts as hv.render(..., cull=pof)."""
    from pv_hdrvol.culling.pof import PlenopticOpacity

    rng = np.random.default_rng(11)
    img = vtkImageData()
    img.SetDimensions(33, 33, 33)
    arr = numpy_to_vtk(0.6 + 0.4 * rng.random(33**3), deep=True)
    arr.SetName("v")
    img.GetPointData().SetScalars(arr)
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1], [1, 1, 1]], [0.0, 0.9, 0.99])
    pof = PlenopticOpacity.compute(img, [tf], block_size=8)
    family = hv.TransferFunction.family([tf], [1.2])
    cam = hv.Camera.fit(img.GetBounds(), "iso", parallel_projection=True)
    alg = _renderer(img)
    alg.SetTransferFunction(family)
    alg.SetCamera({"position": cam.position, "focal_point": cam.focal_point, "view_up": cam.view_up,
                   "parallel_projection": True, "parallel_scale": cam.parallel_scale})
    alg.SetCull(pof)
    assert alg.GetCull() is pof
    alg.Update()
    ref = hv.render(img, family, cam, (W, H), cull=pof)
    assert ref.metadata["culling"]["culled"] > 0
    out = hv.HDRImage.from_pyvista(alg.GetOutput())
    np.testing.assert_array_equal(out.rgba, ref.rgba)
    assert out.metadata["culling"]["culled"] == ref.metadata["culling"]["culled"]
    with pytest.raises(TypeError, match="cull must be a PlenopticOpacity or Culling, or None; got str"):
        alg.SetCull("head.pof.npz")
