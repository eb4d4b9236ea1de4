"""One option path and one framing for every front end.

PyVista's words (``cmap``, ``clim``, ``opacity``, ``scale``, ``scalars``) mean the same
in every front end: ``hv.render``, the PyVista accessor, ``plotter.hdrvol.add_volume``
(its HDR render, off screen), the progressive renderer that the viewers draw (without a
display), the notebook editor, the VTK algorithm, ``pv-hdrvol render`` (its ``main``,
writing ``.npy`` and ``.exr``) and ``python -m pv_hdrvol.parallel render`` on one rank,
in process: each makes the picture ``hv.render`` makes with the same words. The
transfer function and options come from ``resolve_render_options``, the view from
``fit_camera``, which every front end calls.

And every front end frames a CTH-like rectilinear grid with cell data alike: on the
dataset's bounds (the cells' corners, as PyVista and ParaView frame it; a volume of its
cell data spans the cell centres only), cameras equal within 1e-6, images equal. The
parallel command line renders image data only, so it frames an image of cell data.

The Qt viewer needs a display: tests/qt/qt_viewer.py checks it with the same words and
grid under Xvfb (tests/viewer/test_viewer_qt.py).
"""
import dataclasses
import re

import numpy as np
import pytest

from meshes import cth_like_grid
from offscreen import require_offscreen_vtk

try:  # before pyvista imports VTK's rendering: the scene's cases need an offscreen window
    require_offscreen_vtk()
    OFFSCREEN = None
except pytest.skip.Exception as skipped:  # under CI require_offscreen_vtk fails instead
    OFFSCREEN = str(skipped)

import pyvista as pv  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.editor.model import TransferFunctionModel  # noqa: E402
from pv_hdrvol.integrations.cli import main as cli_main  # noqa: E402
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer  # noqa: E402
from pv_hdrvol.parallel.__main__ import main as parallel_main  # noqa: E402
from pv_hdrvol.raycast.grid import resolve_render_options  # noqa: E402
from pv_hdrvol.rays.camera import fit_camera  # noqa: E402
from pv_hdrvol.viewer.progressive import ProgressiveRenderer  # noqa: E402

SIZE = (32, 24)
#: the parallel command line composites its ranks' pieces one after another, with early
#: ray termination per piece: its image equals the single pass's to this fraction of the
#: brightest value (tests/parallel/test_parallel.py; on one rank, as here, bit for bit)
PARALLEL_TOLERANCE = 2e-6

#: PyVista's words, alone and together (scalars: the grid's second array)
WORDS = [
    dict(cmap="bone"),
    dict(clim=(-0.4, 0.9)),
    dict(clim=0.8),
    dict(opacity="sigmoid"),
    dict(opacity=[0.0, 0.4, 0.1]),
    dict(scale="symlog"),
    dict(scalars="other"),
    dict(cmap="bone", clim=(None, 1.0), opacity="geom_r", scale="linear", scalars="other"),
]


def _words_id(words):
    return "-".join(f"{k}={v!r}" for k, v in words.items()).replace(" ", "")


def _grid():
    """A 20x18x16 image with two point arrays of both signs; ``density`` active."""
    g = pv.ImageData(dimensions=(20, 18, 16), spacing=(0.5, 0.55, 0.6), origin=(-1.0, 0.5, 2.0))
    x, y, z = (g.points - np.asarray(g.center)).T
    g.point_data["other"] = np.cos(0.9 * x) * np.sin(0.7 * y) + 0.1 * z
    g.point_data["density"] = np.exp(-0.12 * (x * x + 1.3 * y * y + 0.7 * z * z)) - 0.3 * np.sin(x) * np.cos(y)
    g.set_active_scalars("density")
    return g


def _cell_image():
    """An image with cell data, for the parallel command line (image data only)."""
    g = pv.ImageData(dimensions=(17, 15, 13), spacing=(0.5, 0.4, 0.3), origin=(1.0, -2.0, 0.5))
    c = g.cell_centers().points - np.asarray(g.center)
    g.cell_data["density"] = np.exp(-0.3 * (c * c).sum(axis=1))
    return g


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("option_path")
    grid, cth, cells = _grid(), cth_like_grid(), _cell_image()
    grid.save(folder / "grid.vti")
    cth.save(folder / "cth.vtr")
    cells.save(folder / "cells.vti")
    return {"grid": (grid, folder / "grid.vti"), "cth": (cth, folder / "cth.vtr"),
            "cells": (cells, folder / "cells.vti")}


# -- the front ends: (dataset, file, words, folder) -> (HDRImage, Camera) ------------------------------------------------
def _hv_render(data, path, words, folder):
    image = hv.render(data, None, None, SIZE, **words)
    return image, image.settings().camera


def _accessor(data, path, words, folder):
    image = data.hdrvol.render(size=SIZE, **words)
    return image, image.settings().camera


def _scene(data, path, words, folder):
    if OFFSCREEN is not None:
        pytest.skip(OFFSCREEN)
    pl = pv.Plotter(off_screen=True, window_size=SIZE)
    try:
        actor = pl.hdrvol.add_volume(data, show_scalar_bar=False, **words)
        pl.view_isometric()  # PyVista's reset_camera on the volume's box
        pl.screenshot(return_img=True)
        assert actor.up_to_date and actor.hdr.shape == SIZE[::-1]
        return actor.hdr, hv.Camera.from_pyvista(pl.camera)
    finally:
        pl.close()


def _progressive(data, path, words, folder):
    with ProgressiveRenderer(data, **words) as renderer:
        (frame,) = renderer.frames(None, SIZE, coarse=False)
    return frame.image, frame.image.settings().camera


def _vtk_algorithm(data, path, words, folder):
    alg = HDRVolumeRenderer()
    alg.SetInputDataObject(0, data)
    alg.SetImageSize(*SIZE)
    setters = {"cmap": alg.SetCmap, "clim": alg.SetClim, "opacity": alg.SetOpacity, "scale": alg.SetScale,
               "scalars": alg.SetScalars}
    for word, value in words.items():
        setters[word](value)
    assert alg.Update(), alg.GetLastError()
    return hv.HDRImage.from_pyvista(pv.wrap(alg.GetOutput())), alg.GetLastCamera()


def _cli_arguments(words):
    out = []
    for word, value in words.items():
        if word == "clim":
            lo, hi = (-value, value) if np.isscalar(value) else value
            out += ["--clim", "auto" if lo is None else repr(lo), "auto" if hi is None else repr(hi)]
        elif word == "opacity" and not isinstance(value, str):
            out += ["--opacity", *map(repr, np.atleast_1d(value).tolist())]
        else:
            out += [f"--{word}", str(value)]
    return out


def _cli(suffix):
    def run(data, path, words, folder):
        out = folder / f"cli_{path.stem}{suffix}"
        assert cli_main(["render", str(path), "-o", str(out), "--size", *map(str, SIZE), "--no-progress",
                         *_cli_arguments(words)]) == 0
        image = hv.load(out)
        return image, image.settings().camera if suffix == ".exr" else None  # .npy keeps no settings

    return run


def _parallel_cli(data, path, words, folder):
    out = folder / f"parallel_{path.stem}.exr"
    assert parallel_main(["render", str(path), "--serial", "--size", *map(str, SIZE), "-o", str(out),
                          *_cli_arguments(words)]) == 0
    image = hv.load(out)
    return image, image.settings().camera


FRONT_ENDS = {
    "accessor": _accessor,
    "add_volume": _scene,
    "progressive": _progressive,
    "vtk_algorithm": _vtk_algorithm,
    "cli_npy": _cli(".npy"),
    "cli_exr": _cli(".exr"),
}


@pytest.mark.parametrize("words", WORDS, ids=_words_id)
@pytest.mark.parametrize("front_end", list(FRONT_ENDS))
def test_every_front_end_makes_hv_renders_picture_from_pyvistas_words(files, tmp_path, front_end, words):
    grid, path = files["grid"]
    reference = hv.render(grid, None, None, SIZE, **words)
    image, camera = FRONT_ENDS[front_end](grid, path, words, tmp_path)
    assert camera in (None, reference.settings().camera)  # None: a .npy, which keeps no camera
    assert image.rgba.dtype == reference.rgba.dtype
    assert np.array_equal(image.rgba, reference.rgba)
    assert reference.rgba[..., 3].max() > 0.05  # something to compare


@pytest.mark.parametrize("words", WORDS, ids=_words_id)
def test_the_parallel_command_line_makes_hv_renders_picture_from_pyvistas_words(files, tmp_path, words, capsys):
    grid, path = files["grid"]
    reference = hv.render(grid, None, None, SIZE, **words)
    image, camera = _parallel_cli(grid, path, words, tmp_path)
    capsys.readouterr()
    assert camera == reference.settings().camera
    assert image.settings().tf.to_dict() == reference.settings().tf.to_dict()  # the same function
    scale = float(np.abs(reference.rgba).max())
    assert np.abs(image.rgba.astype(np.float64) - reference.rgba).max() <= PARALLEL_TOLERANCE * scale


@pytest.mark.parametrize("words", WORDS, ids=_words_id)
def test_the_notebook_editor_starts_from_the_function_of_the_words(files, words):
    pytest.importorskip("ipywidgets")
    from pv_hdrvol.viewer.notebook import TransferFunctionEditor

    grid, _ = files["grid"]
    reference = hv.render(grid, None, None, SIZE, **words)
    tf_words = {k: v for k, v in words.items() if k != "scalars"}
    tf, _ = resolve_render_options(hv.volume_from_dataset(grid, words.get("scalars")), **tf_words)
    assert tf.to_dict() == reference.settings().tf.to_dict()  # hv.render's function (its table's size aside)
    editor = TransferFunctionEditor(grid, size=SIZE, live=False, **words)
    try:
        # the editor holds the words' function (as its model keeps any function) and renders it
        assert editor.model.to_dict() == TransferFunctionModel(tf).to_dict()
        image = editor.refresh()
        assert editor._base == reference.settings().camera  # the sliders turn this view
        _assert_cameras_close(editor.camera(), editor._base)
        direct = hv.render(grid, editor.model.transfer_function(), None, SIZE, scalars=words.get("scalars"))
        assert np.array_equal(image.rgba, direct.rgba)
    finally:
        editor.close()


def test_the_words_and_options_resolve_once_for_every_front_end():
    volume = hv.volume_from_dataset(_grid())
    tf, options = resolve_render_options(volume, None, None, cmap="bone", clim=(-0.4, 0.9), opacity="sigmoid",
                                         scale="linear", step=0.25, global_alpha=0.5)
    assert (tf.vmin, tf.vmax, tf.scale, options.step, options.global_alpha) == (-0.4, 0.9, "linear", 0.25, 0.5)
    given = hv.RenderOptions(precision="float64")
    same_tf, same = resolve_render_options(volume, tf, given)
    assert same_tf is tf and same is given  # validated once: handed on as they are
    assert resolve_render_options(volume, tf, given, step=0.3)[1] == dataclasses.replace(given, step=0.3)


@pytest.mark.parametrize("keywords,error,message", [
    (dict(cmapp="bone"), TypeError, "unknown render option(s) ['cmapp']; allowed: "),
    (dict(tf=hv.TransferFunction.ramp(0.0, 1.0), cmap="bone"), TypeError,
     "pass either tf= or cmap=, not both: a TransferFunction sets colour, opacity, range and axis already"),
    (dict(tf="bone"), TypeError, "tf must be a TransferFunction; got str"),
    (dict(options=dict(step=1.0)), TypeError, "options must be a RenderOptions; got dict"),
    (dict(clim=(1.0, 0.0)), ValueError, "clim must be finite with high > low; got (1.0, 0.0)"),
    (dict(opacity="sigmod"), ValueError, "opacity='sigmod' is not a PyVista opacity transfer function"),
    (dict(scale="loglog"), ValueError, "scale must be one of ['linear', 'log', 'symlog']; got 'loglog'"),
    (dict(step=0.0), ValueError, "step must be > 0; got 0.0"),
])
def test_bad_words_are_named_with_what_is_allowed(keywords, error, message):
    volume = hv.volume_from_dataset(_grid())
    with pytest.raises(error, match="^" + re.escape(message)):
        resolve_render_options(volume, **keywords)
    if "options" not in keywords:  # the same message from a front end
        with pytest.raises(error, match="^" + re.escape(message)):
            hv.render(_grid(), size=(8, 6), **keywords)


def test_unknown_words_name_the_transfer_functions_words_as_allowed():
    with pytest.raises(TypeError, match=r"allowed: \[.*'step'.*\] and the transfer function's cmap, clim, opacity, "
                                        r"scale$"):
        resolve_render_options(hv.volume_from_dataset(_grid()), colormap="bone")


# -- framing ------------------------------------------------------------------------------------------------------------
def _assert_cameras_close(camera, expected):
    for name in ("position", "focal_point", "view_up"):
        np.testing.assert_allclose(getattr(camera, name), getattr(expected, name), rtol=0, atol=1e-6, err_msg=name)
    assert camera.view_angle == pytest.approx(expected.view_angle, rel=0, abs=1e-6)
    assert camera.parallel_projection == expected.parallel_projection
    if expected.parallel_projection:  # a perspective view does not read it (the notebook's keeps 1.0)
        assert camera.parallel_scale == pytest.approx(expected.parallel_scale, rel=0, abs=1e-6)


FRAMING = {"hv.render": _hv_render, **FRONT_ENDS}


@pytest.mark.parametrize("front_end", list(FRAMING))
def test_every_front_end_frames_a_rectilinear_cell_data_grid_on_its_bounds(files, tmp_path, front_end):
    cth, path = files["cth"]
    expected = fit_camera(cth, "iso")
    b = np.asarray(cth.bounds)
    # the corners of the cells, not their centres (where the values of cell data sit)
    assert np.allclose(expected.focal_point, 0.5 * (b[0::2] + b[1::2]))
    assert expected.parallel_scale == pytest.approx(0.5 * np.linalg.norm(b[1::2] - b[0::2]), rel=1e-15)
    reference = hv.render(cth, None, expected, SIZE)
    image, camera = FRAMING[front_end](cth, path, {}, tmp_path)
    if camera is not None:  # None: a .npy, which keeps no camera (the image says it all the same)
        _assert_cameras_close(camera, expected)
    assert np.array_equal(image.rgba, reference.rgba)
    assert reference.rgba[..., 3].max() > 0.05


def test_the_notebook_editor_frames_a_rectilinear_cell_data_grid_on_its_bounds(files):
    pytest.importorskip("ipywidgets")
    from pv_hdrvol.viewer.notebook import TransferFunctionEditor

    cth, _ = files["cth"]
    editor = TransferFunctionEditor(cth, size=SIZE, live=False)
    try:
        _assert_cameras_close(editor.camera(), fit_camera(cth, "iso"))
    finally:
        editor.close()


def test_the_parallel_command_line_frames_an_image_of_cell_data_on_its_bounds(files, tmp_path, capsys):
    cells, path = files["cells"]
    expected = fit_camera(cells, "iso")
    image, camera = _parallel_cli(cells, path, {}, tmp_path)
    capsys.readouterr()
    _assert_cameras_close(camera, expected)
    reference = hv.render(cells, None, None, SIZE)
    assert reference.settings().camera == expected
    scale = float(np.abs(reference.rgba).max())
    assert scale > 0.05
    assert np.abs(image.rgba.astype(np.float64) - reference.rgba).max() <= PARALLEL_TOLERANCE * scale


def test_a_volume_of_cell_data_keeps_its_datasets_bounds_for_the_view():
    cth = cth_like_grid()
    volume = hv.volume_from_dataset(cth)
    assert volume.dataset_bounds == tuple(cth.bounds)
    assert volume.bounds[0] > cth.bounds[0]  # the values sit at the cell centres
    assert fit_camera(volume, "xz") == fit_camera(cth, "xz") == hv.Camera.fit(cth.bounds, "xz")
    # the render of the volume frames as the render of the dataset
    assert hv.render(volume, None, None, SIZE).settings().camera == fit_camera(cth)
    point = hv.volume_from_dataset(_grid())
    assert point.dataset_bounds is None and fit_camera(point) == hv.Camera.fit(point.bounds)
