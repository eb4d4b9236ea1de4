"""Render settings in the image metadata: stored exactly, read back, rendered again bit for bit."""
import dataclasses
import json
import re

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.settings import RenderSettings, options_from_dict, options_to_dict


@pytest.fixture(scope="module")
def grid():
    g = pv.ImageData(dimensions=(12, 10, 9), spacing=(0.5, 0.7, 0.6), origin=(-1.0, 0.25, 3.0))
    r2 = np.sum((g.points - np.array(g.center)) ** 2, axis=1)
    g["density"] = np.exp(-3.0 * r2)  # over ten decades
    g["other"] = r2
    return g


def _awkward_tf():
    # floats that print differently from what they are (1/3, 0.1), hsv, a small table
    values = [-0.1, 1 / 3, 0.7, 1.0]
    colors = [[0.1, 0.2, 1 / 3], [1.0, 0.5, 0.0], [2.5, 1e-17, 0.3], [0.0, 0.0, 1.0]]
    return hv.TransferFunction(values, colors, [0.0, 0.1, 1 / 7, 0.9], scale="symlog", linthresh=0.01,
                               color_space="hsv", table_size=4096)


def test_transfer_function_round_trip_is_exact():
    tf = _awkward_tf()
    back = hv.TransferFunction.from_dict(json.loads(json.dumps(tf.to_dict())))
    for name in ("values", "colors", "opacities"):
        np.testing.assert_array_equal(getattr(back, name), getattr(tf, name))
    assert (back.scale, back.linthresh, back.color_space, back.table_size) == ("symlog", 0.01, "hsv", 4096)
    for a, b in zip(back.table(np.float64, 0.5, 0.3), tf.table(np.float64, 0.5, 0.3)):
        np.testing.assert_array_equal(a, b)


def test_camera_round_trip_is_exact():
    cam = hv.Camera((0.1, 1 / 3, 1e-300), (2 / 3, 0.0, 7.0), (0.0, 1.0, 0.1), view_angle=1 / 3,
                    parallel_projection=True, parallel_scale=0.1 + 0.2)
    assert hv.Camera.from_dict(json.loads(json.dumps(cam.to_dict()))) == cam


@pytest.mark.parametrize(("call", "error", "message"), [
    (lambda: hv.TransferFunction.from_dict({"values": [0, 1], "colors": [[0, 0, 0]] * 2}), ValueError,
     "TransferFunction.from_dict: missing keys ['opacities']; needs ['values', 'colors', 'opacities']"),
    (lambda: hv.TransferFunction.from_dict({"values": [0, 1], "colors": [[0, 0, 0]] * 2, "opacities": [0, 1],
                                            "cmap": "magma"}), ValueError,
     "TransferFunction.from_dict: unknown keys ['cmap']; allowed: "),
    (lambda: hv.TransferFunction.from_dict([0, 1]), TypeError, "TransferFunction.from_dict needs a dict; got list"),
    (lambda: hv.Camera.from_dict({"position": [0, 0, 1], "fov": 30}), ValueError,
     "Camera.from_dict: unknown keys ['fov']; allowed: ['position', 'focal_point', 'view_up', 'view_angle', "
     "'parallel_projection', 'parallel_scale']"),
    (lambda: options_from_dict({"step": 0.5, "shininess": 3}), ValueError,
     "unknown render options ['shininess'] (saved by a newer pv_hdrvol?); this version knows ['step', "),
    (lambda: RenderSettings.from_dict({"version": 2, "tf": {}, "size": [1, 1], "options": {}}), ValueError,
     "settings version 2 is not readable by this pv_hdrvol (reads version 1)"),
])
def test_from_dict_errors_name_the_keys(call, error, message):
    with pytest.raises(error, match=re.escape(message)):
        call()


def test_options_are_serialised_field_by_field():
    # every field travels, found by dataclasses.fields: also fields added later
    opts = hv.RenderOptions(step=0.3, precision="float64", global_alpha=1 / 3, opacity_unit_distance=0.1,
                            termination=0.0, depth_threshold=0.2, block_size=8, skip_empty=False,
                            gradient_opacity=(0.0, 0.5))
    d = json.loads(json.dumps(options_to_dict(opts)))
    assert set(d) == {f.name for f in dataclasses.fields(hv.RenderOptions)}
    assert options_from_dict(d) == opts

    @dataclasses.dataclass(frozen=True)
    class Shaded(hv.RenderOptions):
        light_direction: tuple = (0.0, 0.0, 1.0)

    assert options_to_dict(Shaded())["light_direction"] == [0.0, 0.0, 1.0]


def test_grid_render_again_from_the_exr_is_bit_identical(grid, tmp_path):
    tf = hv.TransferFunction.ramp(1e-9, 1.0, scale="log", cmap="magma", opacity=(0.0, 0.6), table_size=8192)
    camera = hv.Camera.fit(grid.bounds, "xz", zoom=1.3)
    first = hv.render(grid, tf, camera, (24, 18), scalars="density", step=0.7, global_alpha=0.8,
                      termination=0.0, block_size=8, gradient_opacity=(0.0, 2.0))
    assert first.rgba[..., 3].max() > 0.05 and first.dynamic_range_decades > 2  # a picture worth comparing
    first.save(tmp_path / "first.exr")
    loaded = hv.load(tmp_path / "first.exr")
    np.testing.assert_array_equal(loaded.rgba, first.rgba)  # float32 round trip
    settings = loaded.settings()
    assert settings.size == (24, 18) and settings.camera == camera and settings.keywords == {}
    assert settings.options == hv.RenderOptions(step=0.7, global_alpha=0.8, termination=0.0, block_size=8,
                                                gradient_opacity=(0.0, 2.0))
    again = settings.render(grid, scalars="density")
    assert again.rgba.dtype == first.rgba.dtype
    np.testing.assert_array_equal(again.rgba, first.rgba)
    np.testing.assert_array_equal(again.depth, first.depth)
    assert loaded.metadata["transfer_function"] == repr(tf)  # the old summary stays


def test_default_transfer_function_and_camera_are_stored_too(grid, tmp_path):
    first = grid.hdrvol.render(scalars="density", size=(16, 12), precision="float64", camera="iso")
    first.save(tmp_path / "d.hdr")  # Radiance headers keep the metadata as well
    settings = hv.load(tmp_path / "d.hdr").settings()
    np.testing.assert_array_equal(settings.render(grid, scalars="density").rgba, first.rgba)
    assert settings.tf.scale == "log" and settings.options.precision == "float64"


def test_tet_render_with_upsampling_again_is_bit_identical(tmp_path):
    mesh = pv.ImageData(dimensions=(5, 4, 4), spacing=(0.5, 0.25, 0.4)).triangulate()
    mesh["pressure"] = np.linspace(1.0, 2.0, mesh.n_points) ** 3
    tf = hv.TransferFunction.ramp(1.0, 8.0, cmap="viridis", opacity=(0.1, 0.7))
    camera = hv.Camera.fit(mesh.bounds, "iso")
    first = hv.render(mesh, tf, camera, (16, 12), tau_max=0.5, upsample=2, precision="float64")
    assert first.rgba[..., 3].max() > 0.05
    first.save(tmp_path / "t.exr")
    settings = hv.load(tmp_path / "t.exr").settings()
    assert settings.size == (16, 12) and settings.keywords == {"tau_max": 0.5, "upsample": 2}
    np.testing.assert_array_equal(settings.render(mesh).rgba, first.rgba)


def test_inputs_settings_cannot_hold_are_named(grid):
    cam = hv.Camera.fit(grid.bounds, "xy")
    lensed = hv.render(grid, None, cam, 8, scalars="density", lens=hv.Magnifier((4, 4), radius=3, factor=2.0))
    with pytest.raises(ValueError, match=re.escape("the render also used lens, which the settings do not hold; "
                                                   "settings(partial=True) returns the rest")):
        lensed.settings()
    assert lensed.settings(partial=True).camera == cam
    by_rays = hv.render(grid, None, cam.rays((6, 5)), scalars="density")
    assert by_rays.metadata["settings"]["not_stored"] == ["rays"]
    with pytest.raises(ValueError, match=re.escape("these settings hold no camera (the render was given rays)")):
        by_rays.settings(partial=True).render(grid)


def test_settings_of_an_image_resized_after_the_render(grid):
    low = hv.render(grid, None, hv.Camera.fit(grid.bounds, "iso"), (6, 4), scalars="density")
    big = hv.upsample(low, factor=2, method="nearest")
    with pytest.raises(ValueError, match=re.escape("the settings are those of a 6x4 render; this image is 12x8 "
                                                   "(changed after the render, e.g. by pv_hdrvol.upsample); "
                                                   "settings(partial=True) returns them anyway")):
        big.settings()
    assert big.settings(partial=True).size == (6, 4) == low.settings().size


def test_images_without_settings(tmp_path):
    img = hv.HDRImage(np.zeros((2, 2, 4), np.float32))
    img.save(tmp_path / "plain.npy")
    with pytest.raises(ValueError, match=re.escape("this image's metadata hold no render settings")):
        hv.load(tmp_path / "plain.npy").settings()


def test_shaded_render_with_lights_renders_again_bit_for_bit(grid):
    """Lights are dataclasses: they travel as dicts of their fields, directions as given
    (not normalised again, which could move a bit)."""
    lights = [hv.Light((1.0, 2.0, 2.0), (0.5, 1 / 3, 0.25)), "headlight"]
    img = grid.hdrvol.render(scalars="density", size=(11, 9), shade=True, specular=0.5, lights=lights)
    stored = json.loads(json.dumps(img.metadata))
    settings = hv.HDRImage(img.rgba, metadata=stored).settings()
    assert settings.options.lights == (hv.Light((1.0, 2.0, 2.0), (0.5, 1 / 3, 0.25)), hv.Light())
    again = settings.render(grid, scalars="density")
    np.testing.assert_array_equal(again.rgba, img.rgba)
