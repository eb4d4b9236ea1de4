"""VTK's (ParaView's) colour map as the transfer function, and the VTK algorithm's
lookup-table and camera-field inputs."""
import numpy as np
import pytest

vtk = pytest.importorskip("vtkmodules.vtkRenderingCore")
from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction  # noqa: E402
from vtkmodules.vtkImagingCore import vtkRTAnalyticSource  # noqa: E402
from vtkmodules.vtkRenderingCore import vtkColorTransferFunction  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer  # noqa: E402
from pv_hdrvol.integrations.vtk_transfer import TOLERANCE, transfer_function_from_vtk  # noqa: E402


def _colors(points, log=False, space="RGB"):
    ctf = vtkColorTransferFunction()
    for x, r, g, b in points:
        ctf.AddRGBPoint(x, r, g, b)
    ctf.SetScale(1 if log else 0)
    getattr(ctf, f"SetColorSpaceTo{space}")()
    return ctf


def _opacity(points, log=False):
    pwf = vtkPiecewiseFunction()
    for x, a in points:
        pwf.AddPoint(x, a)
    pwf.SetUseLogScale(int(log))
    return pwf


def _vtk_values(ctf, pwf, x):
    rgb = np.array([ctf.GetColor(v) for v in x])
    return rgb, np.array([pwf.GetValue(v) for v in x])


@pytest.mark.parametrize("log", [False, True])
def test_rgb_colour_map_is_taken_exactly(log):
    ctf = _colors([(1.0, 0, 0, 0), (10.0, 1, 0, 0), (1000.0, 1, 1, 1)], log=log)
    pwf = _opacity([(1.0, 0.0), (100.0, 0.2), (1000.0, 1.0)], log=log)
    tf = transfer_function_from_vtk(ctf, pwf)
    assert tf.scale == ("log" if log else "linear")
    np.testing.assert_array_equal(tf.values, [1.0, 10.0, 100.0, 1000.0])  # every control point, no more
    x = np.geomspace(1.0, 1000.0, 2001)
    rgb, alpha = _vtk_values(ctf, pwf, x)
    np.testing.assert_allclose(tf.color_at(x), rgb, atol=1e-12)
    np.testing.assert_allclose(tf.opacity_at(x), alpha, atol=1e-12)


# largest colour errors measured over the 20,001 values below: Diverging 1.11e-4,
# Lab 1.10e-4, HSV 1.56e-4; opacity 9.90e-5 in each (docs/paraview.md), held to about 10 %
@pytest.mark.parametrize("space, colour_error", [("Diverging", 1.22e-4), ("Lab", 1.21e-4), ("HSV", 1.72e-4)])
def test_other_colour_spaces_and_mixed_axes_are_within_the_tolerance(space, colour_error):
    ctf = _colors([(0.1, 0.23, 0.30, 0.75), (5.0, 0.87, 0.87, 0.87), (50.0, 0.71, 0.02, 0.15)], log=True,
                  space=space)
    pwf = _opacity([(0.1, 0.0), (50.0, 0.8)], log=False)  # linear opacity on a log colour map
    tf = transfer_function_from_vtk(ctf, pwf)
    x = np.geomspace(0.1, 50.0, 20001)
    rgb, alpha = _vtk_values(ctf, pwf, x)
    # bisection checks segment midpoints (TOLERANCE, 1e-4): elsewhere the error may be larger
    assert np.abs(tf.color_at(x) - rgb).max() < colour_error
    assert np.abs(tf.opacity_at(x) - alpha).max() < 1.1 * TOLERANCE
    assert tf.values.size < 200  # 113 to 145 points


def test_discretized_paraview_style_table_is_read_as_the_continuous_function():
    from vtkmodules.vtkRenderingCore import vtkDiscretizableColorTransferFunction

    ctf = vtkDiscretizableColorTransferFunction()
    ctf.AddRGBPoint(0.0, 0.0, 0.0, 0.0)
    ctf.AddRGBPoint(1.0, 1.0, 1.0, 1.0)
    ctf.SetColorSpaceToRGB()
    ctf.DiscretizeOn()
    ctf.SetNumberOfValues(4)
    ctf.Build()
    tf = transfer_function_from_vtk(ctf)
    np.testing.assert_allclose(tf.color_at(np.array([0.3])), [[0.3, 0.3, 0.3]], atol=1e-12)
    np.testing.assert_array_equal(tf.opacities, [1.0, 1.0])  # no opacity function: opaque


def test_bad_colour_maps_are_refused_with_the_reason():
    with pytest.raises(TypeError, match="colors must be a vtkColorTransferFunction"):
        transfer_function_from_vtk(_opacity([(0, 0), (1, 1)]))
    with pytest.raises(TypeError, match="opacity must be a vtkPiecewiseFunction or None; got str"):
        transfer_function_from_vtk(_colors([(0, 0, 0, 0), (1, 1, 1, 1)]), "ramp")
    with pytest.raises(ValueError, match="at least 2 control points; it has 1"):
        transfer_function_from_vtk(_colors([(0, 0, 0, 0)]))
    with pytest.raises(ValueError, match=r"log scale but its range \[-1.0, 1.0\] is not positive"):
        transfer_function_from_vtk(_colors([(-1, 0, 0, 0), (1, 1, 1, 1)], log=True))
    indexed = _colors([(0, 0, 0, 0), (1, 1, 1, 1)])
    indexed.IndexedLookupOn()
    with pytest.raises(ValueError, match="categorical"):
        transfer_function_from_vtk(indexed)


def _renderer():
    source = vtkRTAnalyticSource()
    source.SetWholeExtent(-6, 6, -6, 6, -6, 6)
    alg = HDRVolumeRenderer()
    alg.SetInputConnection(source.GetOutputPort())
    alg.SetImageSize(16, 12)
    alg.SetCamera("iso")
    return source, alg


def _rgba(alg):
    alg.Update()
    return hv.HDRImage.from_pyvista(alg.GetOutput()).rgba.copy()


def test_lookup_table_renders_as_the_transfer_function_and_edits_re_execute():
    source, alg = _renderer()
    ctf = _colors([(40.0, 0.1, 0.1, 0.4), (280.0, 1.0, 0.9, 0.2)])
    pwf = _opacity([(40.0, 0.0), (280.0, 0.3)])
    alg.SetLookupTable(ctf)
    alg.SetScalarOpacityFunction(pwf)
    first = _rgba(alg)
    source.Update()
    direct = hv.render(source.GetOutput(), transfer_function_from_vtk(ctf, pwf), "iso", (16, 12),
                       progress_bar=False)
    np.testing.assert_array_equal(first, direct.rgba)
    mtime = alg.GetMTime()
    alg.SetLookupTable(ctf)  # the same table again: nothing to do
    assert alg.GetMTime() == mtime
    pwf.AddPoint(160.0, 0.9)  # an edit in place (ParaView's Color Map Editor) re-executes
    assert alg.GetMTime() > mtime
    assert not np.array_equal(_rgba(alg), first)
    alg.SetLookupTable(None)
    assert ctf.HasObserver("ModifiedEvent") == 0  # no observer left behind


def test_lookup_table_with_default_keywords_is_a_clear_error():
    _, alg = _renderer()
    alg.SetLookupTable(_colors([(40.0, 0, 0, 0), (280.0, 1, 1, 1)]))
    alg.SetCmap("viridis")
    assert not alg.Update() or alg.GetLastError() is not None
    assert alg.GetLastError() == ("TypeError: pass either a lookup table or cmap=, not both: the lookup table "
                                  "sets colour, opacity, range and axis already")
    _, alg = _renderer()
    alg.SetScalarOpacityFunction(_opacity([(40.0, 0.0), (280.0, 0.3)]))
    alg.Update()
    assert alg.GetLastError() == ("ValueError: a scalar opacity function needs a lookup table (SetLookupTable) "
                                  "for the colours")
    with pytest.raises(TypeError, match="lookup table must be a vtkColorTransferFunction or None; got str"):
        alg.SetLookupTable("viridis")


def test_camera_fields_are_checked_together_when_the_filter_runs():
    _, alg = _renderer()
    cam = hv.Camera.fit((-6, 6, -6, 6, -6, 6), "xz")
    fields = {"position": cam.position, "focal_point": cam.focal_point, "view_up": cam.view_up,
              "view_angle": cam.view_angle}
    alg.SetCamera(fields)
    from_fields = _rgba(alg)
    alg.SetCamera(cam)
    np.testing.assert_array_equal(_rgba(alg), from_fields)
    alg.SetCamera(dict(fields, position=cam.focal_point))  # a half-updated camera: refused at execution
    alg.Update()
    assert alg.GetLastError() is not None and alg.GetLastError().startswith("ValueError")
    with pytest.raises(ValueError, match=r"camera fields must be among .*; got \['zoom'\]"):
        alg.SetCamera({"zoom": 2.0})


def test_a_multiblock_input_renders_as_one_scene():
    """Two halves of an image as a vtkMultiBlockDataSet render as the image (gathered
    onto its lattice: bit for bit), and the blocks' default transfer function is the
    image's; blocks that do not gather are named."""
    import pyvista as pv
    from vtkmodules.vtkCommonDataModel import vtkMultiBlockDataSet

    source = vtkRTAnalyticSource()
    source.SetWholeExtent(0, 8, 0, 6, 0, 5)
    source.Update()
    image = pv.wrap(source.GetOutput())
    blocks = vtkMultiBlockDataSet()
    blocks.SetBlock(0, image.extract_subset((0, 4, 0, 6, 0, 5)))
    blocks.SetBlock(1, image.extract_subset((4, 8, 0, 6, 0, 5)))
    images = []
    for data in (blocks, image):
        alg = HDRVolumeRenderer()
        alg.SetInputDataObject(data)
        alg.SetImageSize(12, 10)
        alg.SetCamera("iso")
        alg.SetOptions(hv.RenderOptions(precision="float64"))
        assert alg.Update(), alg.GetLastError()
        images.append(hv.HDRImage.from_pyvista(alg.GetOutput()).rgba.copy())
    np.testing.assert_array_equal(images[0], images[1])
    assert images[0][..., 3].max() > 0.05
    fine = pv.ImageData(dimensions=(3, 7, 6), spacing=(0.5, 1.0, 1.0), origin=(8.0, 0.0, 0.0))
    fine["RTData"] = np.ones(fine.n_points, dtype=np.float32)
    blocks.SetBlock(1, fine)
    alg = HDRVolumeRenderer()
    alg.SetInputDataObject(blocks)
    alg.SetImageSize(8, 8)
    assert not alg.Update()
    assert alg.GetLastError().startswith("ValueError: the image blocks of this dataset are rendered one by one (")
    assert alg.GetOutput().GetNumberOfPoints() == 0


def test_only_piece_zero_renders_and_asks_for_the_whole_input():
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline as SDDP

    source, alg = _renderer()
    alg.UpdatePiece(1, 2, 0)  # what a second MPI rank asks for
    assert alg.GetOutput().GetNumberOfPoints() == 0
    alg.UpdatePiece(0, 2, 0)
    assert alg.GetOutput().GetDimensions() == (16, 12, 1)
    requested = source.GetOutputInformation(0).Get(SDDP.UPDATE_EXTENT())
    assert tuple(requested) == (-6, 6, -6, 6, -6, 6)  # the whole extent, not half of it


def test_a_new_camera_reuses_the_plan_and_renders_as_the_python_api():
    source, alg = _renderer()
    alg.Update()
    plan = alg._state.plan[1]
    alg.SetCamera("xz")
    rgba = _rgba(alg)
    assert alg._state.plan[1] is plan  # only the camera changed: tables and skip structures are kept
    source.Update()
    direct = hv.render(source.GetOutput(), None, "xz", (16, 12), progress_bar=False)
    np.testing.assert_array_equal(rgba, direct.rgba)
    alg.SetStep(0.25)
    alg.Update()
    assert alg._state.plan[1] is not plan
    alg.SetCmap("viridis")
    alg.Update()
    assert alg._state.plan[1].tf.colors[0].tolist() != plan.tf.colors[0].tolist()


def test_a_colour_map_does_not_keep_a_dropped_algorithm_alive():
    import gc
    import weakref

    ctf = _colors([(40.0, 0, 0, 0), (280.0, 1, 1, 1)])  # outlives the algorithm, as ParaView's does
    _, alg = _renderer()
    alg.SetLookupTable(ctf)
    alg.Update()
    ref = weakref.ref(alg)
    del alg
    gc.collect()
    assert ref() is None
    ctf.AddRGBPoint(100.0, 0.5, 0.5, 0.5)  # its observer outlives the algorithm harmlessly


# -- edges: the range ends, beyond them, 0 and negative values, mixed axes --------------
def _edge_points(ctf, pwf):
    """The colour map's and the opacity function's ends, 1e-9 (relative) and 1 beside
    each, 0, negative values, far beyond, and 2001 points between (on both axes)."""
    ends = [ctf.GetRange()[0], ctf.GetRange()[1], pwf.GetRange()[0], pwf.GetRange()[1]]
    x = [0.0, -1.0, -1e-6, -1e3, 1e-6, 1e6]
    for e in ends:
        x += [e, e - 1e-9 * max(abs(e), 1.0), e + 1e-9 * max(abs(e), 1.0), e - 1.0, e + 1.0]
    lo, hi = min(ends), max(ends)
    between = np.linspace(lo, hi, 2001)
    return np.concatenate([x, between, np.geomspace(max(lo, 1e-3), hi, 2001)])


def _errors(tf, ctf, pwf, x):
    rgb, alpha = _vtk_values(ctf, pwf, x)
    return np.abs(tf.color_at(x) - rgb).max(), np.abs(tf.opacity_at(x) - alpha).max()


_COLOUR_POINTS = [(1.0, 0.2, 0.3, 0.4), (100.0, 1.0, 0.5, 0.0), (255.0, 1.0, 0.9, 0.8)]
#: (colour map log, opacity points, opacity log, the axis, the tolerance): linear on the
#: same axis is exact; mixed axes within TOLERANCE
_EDGE_CASES = {
    "linear/linear": (False, [(-50.0, 0.2), (0.0, 0.0), (128.0, 0.3), (300.0, 1.0)], False, "linear", 1e-12),
    "log/linear": (True, [(0.0, 0.0), (128.0, 0.3), (255.0, 1.0)], False, "symlog", TOLERANCE),
    "linear/log": (False, [(0.5, 0.1), (10.0, 0.3), (255.0, 1.0)], True, "linear", TOLERANCE),
    "log/log": (True, [(0.5, 0.1), (10.0, 0.3), (400.0, 1.0)], True, "log", 1e-12),
}


@pytest.mark.parametrize("clamping", [True, False])
@pytest.mark.parametrize("case", list(_EDGE_CASES))
def test_vtk_is_followed_at_and_beyond_the_range_ends(case, clamping):
    colour_log, opacity_points, opacity_log, scale, tolerance = _EDGE_CASES[case]
    ctf = _colors(_COLOUR_POINTS, log=colour_log)
    pwf = _opacity(opacity_points, log=opacity_log)
    ctf.SetClamping(int(clamping))  # off: black beyond the colour map's ends
    pwf.SetClamping(int(clamping))  # off: opacity 0 beyond the opacity function's ends (and at its last point)
    tf = transfer_function_from_vtk(ctf, pwf)
    assert tf.scale == scale
    colour_error, opacity_error = _errors(tf, ctf, pwf, _edge_points(ctf, pwf))
    assert colour_error <= tolerance
    assert opacity_error <= tolerance
    assert tf.values.size < 500


def test_reported_log_colour_map_with_a_linear_opacity_from_zero():
    # A log lookup table over [1, 255] and a linear opacity function over [0, 255]
    # gave zero voxels the opacity at 1 (1/255): on a log axis every value <= 0
    # takes the first entry. A symlog axis (linthresh: the colour map's start) gives
    # 0 and negative values their own.
    ctf = _colors([(1.0, 0.0, 0.0, 0.0), (255.0, 1.0, 1.0, 1.0)], log=True)
    pwf = _opacity([(0.0, 0.0), (255.0, 1.0)])
    assert pwf.GetValue(0.0) == 0.0
    tf = transfer_function_from_vtk(ctf, pwf)
    assert (tf.scale, tf.linthresh, tf.vmin, tf.vmax) == ("symlog", 1.0, 0.0, 255.0)
    assert float(tf.opacity_at(0.0)) == 0.0
    x = np.array([-100.0, -1.0, 0.0, 0.25, 0.5, 1.0, 2.0, 10.0, 100.0, 254.0, 255.0, 1000.0])
    rgb, alpha = _vtk_values(ctf, pwf, x)
    np.testing.assert_allclose(tf.opacity_at(x), alpha, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(tf.color_at(x), rgb, rtol=0, atol=TOLERANCE)
    np.testing.assert_array_equal(tf.opacity_at(np.array([-100.0, -1.0, 0.0, 255.0, 1000.0])),
                                  [0.0, 0.0, 0.0, 1.0, 1.0])


def test_log_colour_map_keeps_its_log_axis_where_vtk_is_constant_up_to_it():
    # opacity 0 from -10 to 10 covers the colour map's start (1): a log axis, whose
    # first entry every value <= 0 takes, is then exact
    ctf = _colors(_COLOUR_POINTS, log=True)
    pwf = _opacity([(-10.0, 0.0), (0.0, 0.0), (10.0, 0.0), (255.0, 1.0)])
    tf = transfer_function_from_vtk(ctf, pwf)
    assert tf.scale == "log"
    assert tf.vmin == 1.0
    colour_error, opacity_error = _errors(tf, ctf, pwf, _edge_points(ctf, pwf))
    assert colour_error <= 1e-12
    assert opacity_error <= TOLERANCE  # linear opacity on the log axis: halved segments


def test_below_and_above_range_colours_are_followed():
    # GetColor gives them beyond the range when clamping is on; DeepCopy drops them
    ctf = _colors([(1.0, 0.2, 0.3, 0.4), (255.0, 1.0, 0.9, 0.8)])
    ctf.SetUseBelowRangeColor(1)
    ctf.SetBelowRangeColor(0.1, 0.5, 0.9)
    ctf.SetUseAboveRangeColor(1)
    ctf.SetAboveRangeColor(0.7, 0.7, 0.7)
    pwf = _opacity([(0.0, 0.0), (300.0, 1.0)])
    tf = transfer_function_from_vtk(ctf, pwf)
    x = np.array([-5.0, 0.0, np.nextafter(1.0, 0.0), 1.0, 2.0, 255.0, np.nextafter(255.0, 300.0), 300.0, 400.0])
    rgb, alpha = _vtk_values(ctf, pwf, x)
    assert rgb[0].tolist() == [0.1, 0.5, 0.9] and rgb[-1].tolist() == [0.7, 0.7, 0.7]
    np.testing.assert_allclose(tf.color_at(x), rgb, rtol=0, atol=1e-12)
    np.testing.assert_allclose(tf.opacity_at(x), alpha, rtol=0, atol=1e-12)


def test_log_opacity_function_through_zero_is_a_clear_error():
    ctf = _colors(_COLOUR_POINTS, log=True)
    pwf = _opacity([(0.0, 0.0), (255.0, 1.0)], log=True)
    assert np.isnan(pwf.GetValue(10.0))  # VTK's own value: log10 of the point at 0
    with pytest.raises(ValueError) as info:
        transfer_function_from_vtk(ctf, pwf)
    assert str(info.value) == (
        "the opacity function uses a log scale but its range [0.0, 255.0] is not positive (VTK evaluates it as "
        "NaN there): move its points above 0 or turn its log scale off (SetUseLogScale(0); ParaView: the "
        "opacity function's UseLogScale = 0)")
    with pytest.raises(ValueError) as info:
        transfer_function_from_vtk(_colors([(-1.0, 0, 0, 0), (1.0, 1, 1, 1)], log=True))
    assert str(info.value) == (
        "the colour map uses a log scale but its range [-1.0, 1.0] is not positive (VTK then interpolates it "
        "linearly): turn its log scale off (SetScale(0); ParaView: UseLogScale = 0) or move its first point "
        "above 0")


def test_too_many_control_points_is_a_clear_error(monkeypatch):
    from pv_hdrvol.integrations import vtk_transfer

    monkeypatch.setattr(vtk_transfer, "MAX_POINTS", 8)
    ctf = _colors(_COLOUR_POINTS, log=True)
    with pytest.raises(ValueError, match=r"^following VTK's colour map and opacity function within 0.0001 needs "
                                         r"more than 8 control points \(still .* off between .* on a symlog "
                                         r"axis\): put the opacity function on the colour map's axis"):
        transfer_function_from_vtk(ctf, _opacity([(0.0, 0.0), (255.0, 1.0)]))
