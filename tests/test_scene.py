"""HDR volumes in PyVista scenes (issue 21, part 4), off screen: the volume drawn is
our render from the plotter's camera bit for bit, composited as ``T(C) + (1 - a)
scene``; a mesh in front of the volume hides it exactly; a mesh inside stops the rays
at its surface (the depth buffer read back as ray distances, checked on a plane)."""
import numpy as np
import pytest

from offscreen import require_offscreen_vtk

pytestmark = pytest.mark.vtk_render

require_offscreen_vtk()

import pyvista as pv  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.raycast.grid import GridPlan  # noqa: E402
from pv_hdrvol.viewer.scene import HDRVolumeActor, add_hdr_volume  # noqa: E402

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


def _view(pl):
    pl.camera.position = (0.5, 0.5, 4.0)
    pl.camera.focal_point = (0.5, 0.5, 0.5)
    pl.camera.up = (0.0, 1.0, 0.0)


def test_the_volume_is_our_render_from_the_plotters_camera_composited_over_the_scene():
    pl = _plotter()
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64", tonemap="linear")
    assert isinstance(actor, HDRVolumeActor) and pl.hdrvol.actors == (actor,)
    _view(pl)
    shot = pl.screenshot(return_img=True)
    camera = hv.Camera.from_pyvista(pl.camera)
    direct = hv.render(_volume(), _tf(), camera, SIZE, precision="float64")
    np.testing.assert_array_equal(actor.hdr.rgba, direct.rgba)  # nothing in front: no ray stopped
    mapped = hv.tonemap(direct, "linear").rgb
    a = direct.rgba[..., 3:4]
    expected = np.round(np.clip(mapped + (1 - a) * (51 / 255), 0, 1) * 255).astype(np.uint8)
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
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64")
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
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64")
    _view(pl)
    pl.screenshot(return_img=True)
    hdr = actor.hdr
    actor.set_tonemap("linear", exposure_stops=2.0)
    shot = pl.screenshot(return_img=True)
    assert actor.hdr is hdr  # the kept render
    mapped = hv.tonemap(hdr, "linear", exposure_stops=2.0).rgb
    expected = np.round(np.clip(mapped + (1 - hdr.rgba[..., 3:4]) * (51 / 255), 0, 1) * 255)
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
    actor = pl.hdrvol.add_volume(_volume(), _tf(), precision="float64")
    _view(pl)
    picture = np.asarray(pl.show(jupyter_backend="static", return_viewer=True))[..., :3]
    assert actor.level == "full"
    # the picture is our render from the plotter's camera, tone mapped (the default,
    # reinhard) and composited over the background, computed here, not read from the actor
    direct = hv.render(_volume(), _tf(), hv.Camera.from_pyvista(pl.camera), SIZE, precision="float64")
    a = direct.rgba[..., 3:4]
    assert (a > 0.2).sum() > 500
    expected = np.round(np.clip(hv.tonemap(direct, "reinhard").rgb + (1 - a) * (51 / 255), 0, 1) * 255)
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
