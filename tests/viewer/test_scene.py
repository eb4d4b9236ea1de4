"""HDR volumes in PyVista scenes (issue 21, part 4), off screen: the volume drawn is
our render from the plotter's camera bit for bit, composited as ``T(C) + (1 - max(a,
max T(C))) scene``; a mesh in front of the volume hides it exactly; a mesh inside stops the rays
at its surface (the depth buffer read back as ray distances, checked on a plane)."""
import numpy as np
import pytest

from offscreen import require_offscreen_vtk

pytestmark = pytest.mark.vtk_render

require_offscreen_vtk()

import pyvista as pv  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.raycast.grid import GridPlan  # noqa: E402
from pv_hdrvol.viewer.scene import HDRVolumeActor, _widget_lists, add_hdr_volume  # noqa: E402

SIZE = (96, 72)


def _volume():
    z, y, x = np.mgrid[0:24, 0:24, 0:24].astype(np.float64)
    values = np.exp(-((x - 12) ** 2 + (y - 12) ** 2 + (z - 12) ** 2) / 40.0)
    return hv.volume_from_array(values, spacing=(1 / 23,) * 3)  # the unit cube


def _tf():
    return hv.TransferFunction.ramp(0.0, 1.0, cmap="viridis", opacity=(0.0, 0.6))


def _plotter():
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    pl.background_color = (0.2, 0.2, 0.2)
    return pl


def _over(mapped, alpha, background):
    """The expected 8-bit composite: premultiplied ``mapped`` over ``background`` (a
    grey level in [0, 1]) with coverage max(alpha, brightest channel)."""
    coverage = np.maximum(alpha, mapped.max(axis=-1))[..., None]
    return np.round(np.clip(mapped + (1 - coverage) * background, 0, 1) * 255)


def _view(pl):
    pl.camera.position = (0.5, 0.5, 4.0)
    pl.camera.focal_point = (0.5, 0.5, 0.5)
    pl.camera.up = (0.0, 1.0, 0.0)


def test_the_volume_is_our_render_from_the_plotters_camera_composited_over_the_scene():
    pl = _plotter()
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64", tonemap="linear", show_scalar_bar=False)
    assert isinstance(actor, HDRVolumeActor) and pl.hdrvol.actors == (actor,)
    _view(pl)
    shot = pl.screenshot(return_img=True)
    camera = hv.Camera.from_pyvista(pl.camera)
    direct = hv.render(_volume(), _tf(), camera, SIZE, precision="float64")
    np.testing.assert_array_equal(actor.hdr.rgba, direct.rgba)  # nothing in front: no ray stopped
    mapped = hv.tonemap(direct, "linear").rgb
    # premultiplied colour over the background with coverage max(alpha, brightest channel)
    coverage = np.maximum(direct.rgba[..., 3], mapped.max(axis=-1))[..., None]
    expected = np.round(np.clip(mapped + (1 - coverage) * (51 / 255), 0, 1) * 255).astype(np.uint8)
    a = direct.rgba[..., 3:4]
    assert np.abs(shot.astype(int) - expected).max() <= 1  # 8-bit rounding of the background
    assert (a > 0.2).sum() > 500
    pl.close()


def test_a_mesh_in_front_of_the_volume_hides_it_and_only_there():
    pl = _plotter()
    pl.add_mesh(pv.Plane(center=(0.3, 0.5, 2.0), direction=(0, 0, 1), i_size=0.3, j_size=0.3), color="red",
                lighting=False)
    _view(pl)
    plain = pl.screenshot(return_img=True)
    red = np.all(plain == [255, 0, 0], axis=-1)
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64", show_scalar_bar=False)
    shot = pl.screenshot(return_img=True)
    assert red.sum() > 100
    np.testing.assert_array_equal(shot[red], plain[red])  # hidden: the mesh's own colour, exactly
    assert np.all(actor.hdr.rgba[red] == 0)  # those rays stopped before the volume
    behind = actor.hdr.rgba[..., 3] > 0.05
    assert np.any(shot[behind & ~red] != plain[behind & ~red])  # elsewhere the volume shows
    pl.close()


def test_a_mesh_inside_the_volume_stops_the_rays_at_its_surface():
    """A plane across the middle of the volume (z = 0.5) seen from z = 4: the depth
    buffer gives the distance 3.5 along the axis ray, and the volume's render equals a
    direct render stopped at the analytic distances (to the depth buffer's precision)."""
    pl = _plotter()
    pl.add_mesh(pv.Plane(center=(0.5, 0.5, 0.5), direction=(0, 0, 1), i_size=3, j_size=3), color="white",
                lighting=False)
    _view(pl)
    actor = add_hdr_volume(pl, _volume(), _tf(), precision="float64")
    pl.screenshot(return_img=True)
    camera = hv.Camera.from_pyvista(pl.camera)
    rays = camera.rays(SIZE)
    analytic = ((0.5 - rays.origins[:, 2]) / rays.directions[:, 2]).reshape(SIZE[1], SIZE[0])
    np.testing.assert_allclose(actor.far, analytic, rtol=1e-5)
    direct = GridPlan(_volume(), _tf(), precision="float64").execute(camera, SIZE, far=analytic)
    np.testing.assert_allclose(actor.hdr.rgba, direct.rgba, rtol=0, atol=1e-4)
    full = hv.render(_volume(), _tf(), camera, SIZE, precision="float64")
    # the half behind the plane is hidden: less light and opacity than the whole volume
    assert actor.hdr.rgba[..., 3].sum() < 0.9 * full.rgba[..., 3].sum()
    assert actor.hdr.rgba[..., :3].sum() < 0.9 * full.rgba[..., :3].sum()
    pl.close()


def test_changing_the_tone_mapping_re_maps_without_rendering():
    pl = _plotter()
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64", show_scalar_bar=False)
    _view(pl)
    pl.screenshot(return_img=True)
    hdr = actor.hdr
    actor.set_tonemap("linear", exposure_stops=2.0)
    shot = pl.screenshot(return_img=True)
    assert actor.hdr is hdr  # the kept render
    mapped = hv.tonemap(hdr, "linear", exposure_stops=2.0).rgb
    expected = _over(mapped, hdr.rgba[..., 3], 51 / 255)
    assert np.abs(shot.astype(int) - expected).max() <= 1
    actor.set_transfer_function(global_alpha=0.1)
    pl.screenshot(return_img=True)
    assert actor.hdr is not hdr and actor.hdr.rgba[..., 3].max() < hdr.rgba[..., 3].max()
    pl.close()


def test_plotters_find_the_component_through_the_entry_point():
    """A fresh interpreter that never imports pv_hdrvol gets ``plotter.hdrvol`` from the
    ``pyvista.plotter_components`` entry point (pip install -e . registers it)."""
    import os
    import subprocess
    import sys

    code = ("import sys, pyvista as pv; pl = pv.Plotter(off_screen=True); "
            "print(type(pl.hdrvol).__name__, 'pv_hdrvol' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "VTK_DEFAULT_OPENGL_WINDOW": os.environ["VTK_DEFAULT_OPENGL_WINDOW"]})
    assert done.stdout.split() == ["HDRVolumeComponent", "True"], done.stderr[-2000:]


def test_a_progressive_volume_shows_the_coarse_then_the_full_frame():
    """progressive=True on an off-screen plotter: the worker's frames arrive through
    wait() (a window's timer runs the same poll); the full one is the direct render."""
    pl = _plotter()
    _view(pl)
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64", progressive=True)
    pl.screenshot(return_img=True)  # the scene's first render requests the volume
    assert actor.wait(120) and actor.up_to_date and actor.level == "full"
    camera = hv.Camera.from_pyvista(pl.camera)
    np.testing.assert_array_equal(actor.hdr.rgba, hv.render(_volume(), _tf(), camera, SIZE,
                                                            precision="float64").rgba)
    actor.set_transfer_function(global_alpha=0.3)
    assert not actor.up_to_date
    assert actor.wait(120)
    np.testing.assert_array_equal(actor.hdr.rgba, hv.render(_volume(), _tf(), camera, SIZE, precision="float64",
                                                            global_alpha=0.3).rgba)
    pl.close()


def test_a_notebook_plot_with_the_static_backend_shows_the_volume():
    """``pl.show()`` in a notebook with PyVista's static backend renders off screen: the
    picture it returns is the composite with the volume at full quality."""
    pytest.importorskip("IPython")
    pl = pv.Plotter(notebook=True, off_screen=True, window_size=SIZE)
    pl.background_color = (0.2, 0.2, 0.2)
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64", show_scalar_bar=False)
    _view(pl)
    picture = np.asarray(pl.show(jupyter_backend="static", return_viewer=True))[..., :3]
    assert actor.level == "full"
    # the picture is our render from the plotter's camera, tone mapped (the default,
    # reinhard) and composited over the background, computed here, not read from the actor
    direct = hv.render(_volume(), _tf(), hv.Camera.from_pyvista(pl.camera), SIZE, precision="float64")
    a = direct.rgba[..., 3:4]
    assert (a > 0.2).sum() > 500
    expected = _over(hv.tonemap(direct, "reinhard").rgb, direct.rgba[..., 3], 51 / 255)
    assert picture.shape == expected.shape
    assert np.abs(picture.astype(int) - expected).max() <= 1  # 8-bit rounding of the background


def test_removing_the_volume_leaves_the_scene_and_bad_operators_are_named():
    pl = _plotter()
    pl.add_mesh(pv.Sphere(radius=0.2, center=(0.5, 0.5, 0.5)), color="red", lighting=False)
    _view(pl)
    plain = pl.screenshot(return_img=True)
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64")
    assert not np.array_equal(pl.screenshot(return_img=True), plain)
    actor.remove()
    assert pl.hdrvol.actors == ()
    np.testing.assert_array_equal(pl.screenshot(return_img=True), plain)
    with pytest.raises(ValueError, match="tonemap must be one of .* or a callable; got 'nope'"):
        pl.hdrvol.add_volume(_volume(), _tf(), tonemap="nope")
    pl.close()


# -- issue 31: any background, brightness that occluders do not change, annotations on top --
def _bright_tf():
    """Emission far above the opacity (HDR colours, faint opacity): the case that added
    light saturated on a white background."""
    return hv.TransferFunction([0.0, 0.5, 1.0], [[0.2, 0.1, 2.0], [2.0, 0.5, 0.2], [4.0, 3.0, 0.5]],
                               [0.0, 0.05, 0.1])


@pytest.mark.parametrize("grey", [1.0, 0.5, 0.0], ids=["white", "grey", "black"])
def test_the_volume_reads_on_any_background(grey):
    """Composited as premultiplied colour with coverage max(alpha, max T(C)): over white
    the volume darkens what it covers (the sum T(C) + (1 - alpha) saturated at 255 and
    the volume vanished); over black the picture is T(C) as it was."""
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    pl.background_color = (grey,) * 3
    actor = pl.hdrvol.add_volume(_volume(), _bright_tf(), precision="float64", show_scalar_bar=False)
    _view(pl)
    shot = pl.screenshot(return_img=True).astype(int)
    mapped = hv.tonemap(actor.hdr, "reinhard").rgb
    background = round(grey * 255) / 255
    assert np.abs(shot - _over(mapped, actor.hdr.rgba[..., 3], background)).max() <= 1
    covered = actor.hdr.rgba[..., 3] > 0.02
    assert covered.sum() > 300
    # the mean distance from the background over the volume's footprint, 8-bit levels
    visibility = np.abs(shot[covered] - round(grey * 255)).mean()
    assert visibility > 40, visibility
    if grey == 0.0:
        np.testing.assert_array_equal(shot, np.round(mapped * 255))
    pl.close()


def test_a_mesh_in_front_changes_only_the_pixels_it_covers():
    """The tone mapping's statistics come from the volume alone (the rays a mesh stops
    are rendered again without it): with the default Reinhard operator, a sphere in
    front of the volume leaves every pixel it does not cover as it was, bit for bit
    (they changed by up to 0.05 when the log-average was taken over the occluded
    render)."""
    pl = _plotter()
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64", show_scalar_bar=False)
    _view(pl)
    alone = pl.screenshot(return_img=True)
    hdr_alone = actor.hdr
    pl.add_mesh(pv.Sphere(radius=0.15, center=(0.45, 0.5, 1.2)), color="red", lighting=False)
    with_sphere = pl.screenshot(return_img=True)
    stopped = np.isfinite(actor.far)
    assert 100 < stopped.sum() < stopped.size / 2
    assert actor._unoccluded is not None
    np.testing.assert_array_equal(actor._unoccluded.rgba, hdr_alone.rgba)  # the volume alone, exactly
    np.testing.assert_array_equal(with_sphere[~stopped], alone[~stopped])
    assert np.any(with_sphere[stopped] != alone[stopped])
    pl.close()


def test_annotations_and_the_orientation_axes_stay_above_the_volume():
    """Text and the orientation widget drawn where the volume is opaque: their pixels
    are those of the scene without the volume (the overlay hid the axes and covered
    the text)."""
    def shot(with_volume, with_axes=True):
        pl = _plotter()
        pl.add_text("HDR", position=(30, 22), font_size=18, color=(1.0, 0.0, 0.0))
        if with_axes:
            pl.add_axes(viewport=(0.5, 0.0, 0.9, 0.5))  # lower right, over the volume
        actor = None
        if with_volume:
            actor = pl.hdrvol.add_volume(_volume(), hv.TransferFunction.ramp(0.0, 1.0, cmap="gray",
                                                                             opacity=(1.0, 1.0)),
                                         precision="float64", show_scalar_bar=False)
        _view(pl)
        pl.camera.zoom(1.6)
        picture = pl.screenshot(return_img=True).astype(int)
        opaque = None if actor is None else actor.hdr.rgba[..., 3] > 0.99
        pl.close()
        return picture, opaque

    (plain, _), (full, opaque), (no_axes, _) = shot(False), shot(True), shot(True, with_axes=False)
    text = np.all(plain == [255, 0, 0], axis=-1) & opaque
    assert text.sum() > 20
    np.testing.assert_array_equal(full[text], plain[text])
    # the axes' lines: far from the background in the plain picture; with the volume they
    # match the plain picture but at antialiased edges, which blend with what lies under
    region = np.zeros(plain.shape[:2], bool)
    region[SIZE[1] // 2:, SIZE[0] // 2:] = True
    lines = region & (np.abs(plain - 51).sum(-1) > 150) & opaque
    assert lines.sum() > 10
    shown = np.abs(full[lines] - plain[lines]).mean()
    hidden = np.abs(no_axes[lines] - plain[lines]).mean()  # what a covered axis would show
    assert shown < 0.2 * hidden, (shown, hidden)


@pytest.mark.parametrize("scale", ["linear", "log", "symlog"])
def test_the_scalar_bar_shows_the_transfer_functions_colours_on_its_axis(scale):
    """As PyVista's add_volume: a scalar bar (show_scalar_bar=True by default, titled by
    the array, scalar_bar_args passed on), with the function's colours; VTK's log scale
    for a log axis; a symlog axis labelled by annotations in data values."""
    from vtkmodules.vtkCommonCore import VTK_SCALE_LINEAR, VTK_SCALE_LOG10

    grid = pv.ImageData(dimensions=(8, 8, 8))
    grid["density"] = np.geomspace(1e-3, 1e3, grid.n_points) * (1 if scale != "symlog" else
                                                                np.resize([1, -1], grid.n_points))
    lo = 1e-3 if scale == "log" else -1e3 if scale == "symlog" else 0.0
    tf = hv.TransferFunction.ramp(lo, 1e3, scale=scale, cmap="viridis", linthresh=1e-2)
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    actor = pl.hdrvol.add_volume(grid, tf, scalar_bar_args={"vertical": True})
    bar = actor.scalar_bar
    assert bar is not None and bar.GetTitle() == "density" and bar.GetOrientation() == 1  # vertical
    assert "density" in pl.scalar_bars
    lut = bar.GetLookupTable()
    assert lut.GetScale() == (VTK_SCALE_LOG10 if scale == "log" else VTK_SCALE_LINEAR)
    peak = tf.colors.max()
    for v in (lo, 1e-2 if scale != "linear" else 250.0, 1e3):
        axis_v = hv.data.transfer.scale_forward(v, "symlog", 1e-2) if scale == "symlog" else v
        rgb = np.zeros(3)
        lut.GetColor(float(axis_v), rgb)
        np.testing.assert_allclose(rgb, tf.color_at(v) / peak, atol=2.5 / 255)  # 256 entries, 8 bits
    if scale == "symlog":
        labels = {lut.GetAnnotation(i) for i in range(lut.GetNumberOfAnnotatedValues())}
        assert {"-1e+03", "0", "1e+03"} <= labels, labels
    pl.close()


def test_a_plotter_that_is_not_one_is_named():
    """The module's add_hdr_volume checks its plotter (an AttributeError on .renderer
    before), as pv_hdrvol.add_hdr_volume does, with the same message."""
    message = (r"plotter must be a pyvista.Plotter \(or a pyvistaqt BackgroundPlotter or QtInteractor\); got "
               r"'not a plotter': pass the plotter first, add_hdr_volume\(plotter, data, tf\)")
    with pytest.raises(TypeError, match=message):
        add_hdr_volume("not a plotter", _volume())
    with pytest.raises(TypeError, match=message):
        hv.add_hdr_volume("not a plotter", _volume())


@pytest.mark.parametrize("progressive", [False, True], ids=["at once", "progressive"])
def test_an_empty_volume_says_why_in_the_thread_that_shows_it(progressive):
    """A transfer function with no opacity over the data: the EmptyRenderWarning comes
    once, where the frame is shown (the worker hands it over: warnings is process-wide),
    and stays on the actor."""
    pl = _plotter()
    _view(pl)
    clear = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray", opacity=(0.0, 0.0))
    with pytest.warns(hv.EmptyRenderWarning) as said:
        actor = pl.hdrvol.add_volume(_volume(), clear, precision="float64", progressive=progressive,
                                     show_scalar_bar=False)
        pl.screenshot(return_img=True)
        assert actor.wait(120)
    messages = [str(w.message) for w in said if issubclass(w.category, hv.EmptyRenderWarning)]
    assert len(messages) == 1 and "opacity" in messages[0], messages
    assert [str(w) for w in actor.warnings] == messages
    pl.close()


def test_a_clip_plane_widget_cuts_the_volume_as_it_is_dragged():
    """The plane widget's interaction (as a mouse drag ends each step) sets the cut, and
    the volume drawn is the clipped render bit for bit; the box widget crops; clearing
    them gives the whole volume back."""
    from vtkmodules.vtkCommonCore import vtkCommand

    pl = _plotter()
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64", tonemap="linear", show_scalar_bar=False,
                                 progressive=False)
    _view(pl)
    widget = actor.add_clip_plane_widget("z")
    assert actor.renderer.options.clip_planes == (hv.ClipPlane((0.5, 0.5, 0.5), (0, 0, 1)),)  # the centre, +z kept
    widget.SetOrigin(0.5, 0.5, 0.3)
    widget.SetNormal(0.0, 0.6, -0.8)
    widget.InvokeEvent(vtkCommand.InteractionEvent)
    plane = actor.renderer.options.clip_planes[0]
    np.testing.assert_allclose(plane.origin, (0.5, 0.5, 0.3), atol=1e-12)
    np.testing.assert_allclose(plane.normal, (0.0, 0.6, -0.8), atol=1e-12)
    widget.Off()  # its handles and outline are opaque scene geometry: they stop the rays they cover
    pl.screenshot(return_img=True)
    camera = hv.Camera.from_pyvista(pl.camera)
    expected = hv.render(_volume(), _tf(), camera, SIZE, precision="float64", clip_planes=(plane.origin, plane.normal))
    np.testing.assert_array_equal(actor.hdr.rgba, expected.rgba)
    whole = hv.render(_volume(), _tf(), camera, SIZE, precision="float64")
    assert np.abs(whole.rgba - expected.rgba).max() > 0.05
    box = actor.add_crop_box_widget()
    assert actor.renderer.options.crop_box == pytest.approx(_volume().bounds)
    box.Off()
    actor.set_clip(actor.renderer.options.clip_planes, (0.1, 0.9, 0.0, 1.0, 0.0, 1.0))
    pl.screenshot(return_img=True)
    cropped = hv.render(_volume(), _tf(), camera, SIZE, precision="float64", clip_planes=(plane.origin, plane.normal),
                        crop_box=(0.1, 0.9, 0.0, 1.0, 0.0, 1.0))
    np.testing.assert_array_equal(actor.hdr.rgba, cropped.rgba)
    widgets = _widget_lists(pl)
    assert box in widgets[1] and widget in widgets[0]
    actor.clear_clip_widgets()
    assert actor.renderer.options.clip_planes == () and actor.renderer.options.crop_box is None
    assert box not in widgets[1] and widget not in widgets[0]
    pl.screenshot(return_img=True)
    np.testing.assert_array_equal(actor.hdr.rgba, whole.rgba)
    pl.close()


def test_a_store_larger_than_memory_renders_converged_off_screen_and_refines_progressively(tmp_path):
    """A MultiscaleVolume in a scene: off screen, the converged render at once (wait=True,
    bit for bit hv.render's); progressive, coarse and refining frames (a slow loader)
    until the converged one, the status line saying which levels each frame drew."""
    pytest.importorskip("zarr")
    import time

    from stores import slow_loader, write_store

    path = write_store(tmp_path / "smooth.ome.zarr", n=80)
    with hv.open_multiscale(path, cache_bytes=2 ** 28) as volume:
        pl = _plotter()
        actor = pl.hdrvol.add_volume(volume, precision="float32", screen_error=0.5)
        pl.screenshot(return_img=True)
        assert actor.level == "full" and actor.hdr.metadata["converged"] and actor.status.endswith("converged")
        assert actor.scalar_bar is not None
        camera = hv.Camera.from_pyvista(pl.camera)
        tf = actor.renderer.tf
        np.testing.assert_array_equal(actor.hdr.rgba, hv.render(volume, tf, camera, SIZE, screen_error=0.5,
                                                                 precision="float32").rgba)
        with pytest.raises(ValueError, match="lenses are not supported for out-of-core volumes"):
            actor.set_lens(hv.Magnifier(center=(40, 30), radius=10, factor=2))
        pl.close()
    with hv.open_multiscale(path, cache_bytes=2 ** 28) as volume:
        slow_loader(volume, 0.02)
        pl = _plotter()
        actor = pl.hdrvol.add_volume(volume, tf, precision="float32", screen_error=0.5, progressive=True)
        pl.screenshot(return_img=True)
        seen, end = [], time.monotonic() + 120
        while time.monotonic() < end and not actor.up_to_date:
            actor._poll()
            assert actor.error is None, actor.error
            if actor.level is not None and (not seen or seen[-1][0] != actor.level):
                seen.append((actor.level, actor.status))
            time.sleep(0.005)
        assert actor.up_to_date and actor.hdr.metadata["converged"]
        assert seen[0][0] == "coarse" and "refining" in [level for level, _ in seen], seen
        assert any("loading" in status for _, status in seen), seen
        np.testing.assert_array_equal(actor.hdr.rgba, hv.render(volume, tf, camera, SIZE, screen_error=0.5,
                                                                 precision="float32").rgba)
        pl.close()
