"""One way of saying each thing (issue 18, part 4): the same bad input gets the same
error from hv.render, the PyVista accessor, the VTK algorithm and the CLI."""
import re

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.integrations.cli import main
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer
from pv_hdrvol.data.kinds import SUPPORTED
from pv_hdrvol.data.files import READABLE

CASES = [
    # (keyword, value, CLI arguments, message)
    ("step", -1.0, ["--step", "-1"], "step must be > 0; got -1.0"),
    ("precision", "float8", ["--precision", "float8"], None),  # argparse's choices: checked below
    ("camera", "top", ["--view", "top"], "view must be one of ['iso', 'xy', 'yx', 'xz', 'zx', 'yz', 'zy']; got 'top'"),
    ("specular_power", 0.5, ["--specular-power", "0.5"], "specular_power must be >= 1; got 0.5"),
    ("global_alpha", 2.0, ["--global-alpha", "2"], "global_alpha must be <= 1; got 2.0"),
    # the default transfer function's keywords
    ("clim", (4.0, 1.0), ["--clim", "4", "1"], "clim must be finite with high > low; got (4.0, 1.0)"),
    ("opacity", 1.5, ["--opacity", "1.5"], "opacity values must lie in [0, 1]; got 1.5"),
    ("opacity", "sigmod", ["--opacity", "sigmod"],
     "opacity='sigmod' is not a PyVista opacity transfer function: Opacity transfer function (sigmod) unknown. "
     "Valid options: ['linear', 'geom', 'geom_r', 'sigmoid', 'sigmoid_1', 'sigmoid_2', 'sigmoid_3', 'sigmoid_4', "
     "'sigmoid_5', 'sigmoid_6', 'sigmoid_7', 'sigmoid_8', 'sigmoid_9', 'sigmoid_10', 'sigmoid_15', 'sigmoid_20', "
     "'foreground', 'linear_r', 'sigmoid_r', 'sigmoid_3_r', 'sigmoid_4_r', 'sigmoid_5_r', 'sigmoid_6_r', "
     "'sigmoid_7_r', 'sigmoid_8_r', 'sigmoid_9_r', 'sigmoid_10_r']"),
    ("cmap", "nope", ["--cmap", "nope"], "cmap 'nope' is not a matplotlib colormap name"),
]


@pytest.fixture(scope="module")
def grid(tmp_path_factory):
    g = pv.ImageData(dimensions=(6, 6, 6))
    g["v"] = np.linspace(0.0, 1.0, g.n_points)
    path = tmp_path_factory.mktemp("fe") / "g.vti"
    g.save(path)
    return g, path


def _vtk_set(alg, keyword, value):
    if keyword == "camera":
        alg.SetCamera(value)
    else:
        name = "Set" + "".join(part.capitalize() for part in keyword.split("_"))
        getattr(alg, name)(value)


@pytest.mark.parametrize("keyword,value,cli,message", [c for c in CASES if c[3] is not None])
def test_the_same_bad_input_gets_the_same_message_everywhere(grid, tmp_path, capsys, keyword, value, cli, message):
    g, path = grid
    pattern = "^" + re.escape(message) + "$"
    with pytest.raises(ValueError, match=pattern):
        hv.render(g, None, size=(8, 8), **{keyword: value})
    with pytest.raises(ValueError, match=pattern):
        g.hdrvol.render(size=(8, 8), **{keyword: value})
    alg = HDRVolumeRenderer()
    with pytest.raises(ValueError, match=pattern):
        _vtk_set(alg, keyword, value)
    with pytest.raises(SystemExit) as exit_:
        main(["render", str(path), "-o", str(tmp_path / "x.exr"), "--size", "8", "--no-progress", *cli])
    assert exit_.value.code == 2
    assert capsys.readouterr().err.strip().endswith("error: " + message)


def test_choices_name_the_allowed_values_everywhere(grid, tmp_path, capsys):
    g, path = grid
    message = "precision must be one of ['float64', 'float32', 'float16', 'uint8']; got 'float8'"
    with pytest.raises(ValueError, match=re.escape(message)):
        hv.render(g, None, size=(8, 8), precision="float8")
    with pytest.raises(ValueError, match=re.escape(message)):
        g.hdrvol.render(size=(8, 8), precision="float8")
    with pytest.raises(ValueError, match=re.escape(message)):
        HDRVolumeRenderer().SetPrecision("float8")
    with pytest.raises(SystemExit):  # argparse lists the choices itself
        main(["render", str(path), "--precision", "float8"])
    assert "invalid choice: 'float8' (choose from" in capsys.readouterr().err


@pytest.mark.parametrize("keywords,cli", [
    (dict(cmap="viridis"), ["--cmap", "viridis"]),
    (dict(clim=(0.2, None), opacity="sigmoid"), ["--clim", "0.2", "auto", "--opacity", "sigmoid"]),
    (dict(opacity=[0.0, 0.3, 0.1], scale="symlog"), ["--opacity", "0", "0.3", "0.1", "--scale", "symlog"]),
    (dict(opacity=0.05, clim=0.8), ["--opacity", "0.05", "--clim", "-0.8", "0.8"]),
])
def test_the_transfer_function_keywords_give_the_same_pixels_everywhere(grid, tmp_path, keywords, cli):
    """cmap=, clim=, opacity=, scale=: hv.render, the accessor, the VTK algorithm's
    setters and the CLI's options make the same function, the one that
    default_transfer_function makes from them."""
    from pv_hdrvol.raycast.grid import default_transfer_function

    g, path = grid
    cam = hv.Camera.fit(g.bounds, "iso")
    tf = default_transfer_function(hv.volume_from_dataset(g), **keywords)
    ref = hv.render(g, tf, cam, (8, 8)).rgba
    np.testing.assert_array_equal(hv.render(g, None, cam, (8, 8), **keywords).rgba, ref)
    np.testing.assert_array_equal(g.hdrvol.render(camera=cam, size=(8, 8), **keywords).rgba, ref)
    alg = HDRVolumeRenderer()
    alg.SetInputDataObject(0, g)
    alg.SetImageSize(8, 8)
    alg.SetCamera(cam)
    for keyword, value in keywords.items():
        _vtk_set(alg, keyword, value)
    assert alg.Update()
    np.testing.assert_array_equal(hv.HDRImage.from_pyvista(pv.wrap(alg.GetOutput())).rgba, ref)
    out = tmp_path / "k.exr"
    assert main(["render", str(path), "-o", str(out), "--size", "8", "--no-progress", *cli]) == 0
    np.testing.assert_array_equal(hv.load(out).rgba, ref)


def test_a_transfer_function_and_its_keywords_are_refused_together_everywhere(grid):
    g, _ = grid
    tf = hv.TransferFunction.ramp(0.0, 1.0)
    message = ("pass either tf= or cmap=, not both: a TransferFunction sets colour, opacity, range and axis "
               "already")
    with pytest.raises(TypeError, match="^" + re.escape(message) + "$"):
        hv.render(g, tf, size=(8, 8), cmap="gray")
    with pytest.raises(TypeError, match="^" + re.escape(message) + "$"):
        g.hdrvol.render(tf=tf, size=(8, 8), cmap="gray")
    alg = HDRVolumeRenderer()
    alg.SetInputDataObject(0, g)
    alg.SetTransferFunction(tf)
    alg.SetCmap("gray")
    assert not alg.Update()
    assert alg.GetLastError() == "TypeError: " + message
    alg.SetCmap(None)
    assert alg.Update()


def test_the_vtk_keyword_setters_are_modified_only_by_a_new_meaning():
    alg = HDRVolumeRenderer()
    alg.SetOpacity([0.0, 0.5])
    t = alg.GetMTime()
    alg.SetOpacity(np.array([0.0, 0.5]))  # the same opacities: no re-execution
    alg.SetClim(0.0, 1.0)
    t2 = alg.GetMTime()
    alg.SetClim((0, 1))
    assert alg.GetMTime() == t2 > t
    assert (alg.GetOpacity(), alg.GetClim()) == ([0.0, 0.5], (0.0, 1.0))
    alg.SetClim(None)
    assert alg.GetClim() is None and alg.GetMTime() > t2


def test_a_render_made_with_the_keywords_renders_again_from_its_settings(grid):
    """The settings keep the function the keywords made (not the keywords), so
    ``settings().render`` gives the same pixels without them."""
    g, _ = grid
    img = hv.render(g, None, "iso", (8, 8), cmap="viridis", clim=(0.1, None), opacity="sigmoid")
    settings = img.settings()
    assert settings.keywords == {} and settings.tf.vmin == 0.1
    np.testing.assert_array_equal(settings.render(g).rgba, img.rgba)


# -- one answer per question (issue 31, part 6) ----------------------------------------------------------------------
@pytest.fixture
def opened(monkeypatch):
    """What hv.view and pv-hdrvol view hand to the Qt viewers: [(which, data, tf, keywords)]."""
    pytest.importorskip("pyvistaqt")
    import pv_hdrvol.proxy.qt
    import pv_hdrvol.viewer.qt

    calls = []
    monkeypatch.setattr(pv_hdrvol.viewer.qt, "view", lambda data, tf=None, **kw: calls.append(("volume", data, tf, kw)))
    monkeypatch.setattr(pv_hdrvol.proxy.qt, "view", lambda data, **kw: calls.append(("proxies", data, None, kw)))
    return calls


def _mesh():
    mesh = pv.ImageData(dimensions=(4, 4, 4)).triangulate()
    mesh["s"] = np.arange(mesh.n_points, dtype=float)
    return mesh


def test_view_opens_every_file_the_cli_opens_as_the_cli_reads_it(grid, tmp_path, opened):
    _mesh().save(tmp_path / "tets.vtu")
    for path in (grid[1], tmp_path / "tets.vtu"):
        hv.view(str(path))
        main(["view", str(path)])
        (_, mine, tf, kw), (_, cli, cli_tf, cli_kw) = opened[-2:]
        assert type(mine) is type(cli) and type(mine).__name__ in ("GridVolume", "TetMesh")  # was: "got str"
        np.testing.assert_array_equal(mine.values, cli.values)
        assert tf is cli_tf is None and kw["title"] == cli_kw["title"] == f"pv_hdrvol: {path.name}"
    hv.view(grid[1], scalars="v")  # a pathlib.Path, and the array by name
    assert opened[-1][1].name == "v"


def test_view_reads_a_transfer_function_file_as_the_cli_does(grid, tmp_path, opened):
    from pv_hdrvol.editor.model import TransferFunctionModel

    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray", opacity=(0.0, 0.3))
    TransferFunctionModel(tf).save(tmp_path / "tf.json")
    hv.view(str(grid[1]), tf=str(tmp_path / "tf.json"))
    main(["view", str(grid[1]), "--tf", str(tmp_path / "tf.json")])
    assert opened[-2][2].to_dict() == opened[-1][2].to_dict() == TransferFunctionModel(tf).transfer_function().to_dict()


def test_view_names_a_file_it_cannot_open(tmp_path, opened):
    missing = tmp_path / "missing.vti"
    with pytest.raises(FileNotFoundError, match=re.escape(f"No such file or directory: '{missing}'")):
        hv.view(str(missing))
    (tmp_path / "notes.txt").write_text("not a volume")
    with pytest.raises(ValueError, match=re.escape(f"cannot read '{tmp_path / 'notes.txt'}': unknown extension '.txt'; "
                                                   f"use one of {', '.join(READABLE)}")):
        hv.view(tmp_path / "notes.txt")
    pv.Sphere().save(tmp_path / "sphere.vtk")
    with pytest.raises(ValueError, match=re.escape(f"'{tmp_path / 'sphere.vtk'}' holds a PolyData; pv_hdrvol renders "
                                                   f"{SUPPORTED}")):
        hv.view(tmp_path / "sphere.vtk")
    (tmp_path / "empty.proxy").mkdir()
    with pytest.raises(FileNotFoundError, match=re.escape(f"'{tmp_path / 'empty.proxy'}' is not a complete proxy "
                                                          f"folder: proxies.json is missing")):
        hv.view(tmp_path / "empty.proxy")
    assert opened == []


def test_view_opens_a_store_out_of_core_as_the_cli_does(tmp_path, opened, capsys):
    """A folder with a zarr.json is a multiresolution store: hv.view and pv-hdrvol view
    open it with open_multiscale (not as a proxy folder); --tf lands on its coarsest
    level's range in both; what does not apply, or a Zarr store pv_hdrvol did not write,
    is named."""
    pytest.importorskip("zarr")
    import zarr

    from pv_hdrvol.editor.model import TransferFunctionModel
    from stores import write_store

    path = write_store(tmp_path / "smooth.ome.zarr", n=40)
    hv.view(str(path))
    main(["view", str(path)])
    hv.view(path, tf=str(_saved_tf(tmp_path)))
    main(["view", str(path) + "/", "--tf", str(tmp_path / "tf.json"), "--precision", "float64"])
    for which, data, tf, kw in opened:
        assert which == "volume" and isinstance(data, hv.MultiscaleVolume)
        assert data.store.path == hv.MultiscaleStore(path).path and kw["title"] == "pv_hdrvol: smooth.ome.zarr"
        data.close()
    assert opened[0][2] is opened[1][2] is None and opened[3][3]["precision"] == "float64"
    expected = TransferFunctionModel.load(tmp_path / "tf.json", _path_values(path)).transfer_function().to_dict()
    assert opened[2][2].to_dict() == opened[3][2].to_dict() == expected
    del opened[:]
    with pytest.raises(SystemExit) as exit_info:
        main(["view", str(path), "--scalars", "v"])
    assert exit_info.value.code == 2
    assert f"pv-hdrvol view: error: --scalars picks an array of a dataset; the store '{path}' holds one" in \
        capsys.readouterr().err
    with pytest.raises(ValueError, match="scalars= picks an array of a dataset; a multiresolution store holds one"):
        hv.view(str(path), scalars="v")
    zarr.open_group(str(tmp_path / "plain.zarr"), mode="w").create_array("a", shape=(4, 4, 4), dtype="f4")
    message = "plain.zarr is not a pv_hdrvol multiresolution store"
    with pytest.raises(ValueError, match=message):
        hv.view(tmp_path / "plain.zarr")
    with pytest.raises(SystemExit):
        main(["view", str(tmp_path / "plain.zarr")])
    err = capsys.readouterr().err
    assert "pv-hdrvol view: error: " in err and message in err and "Traceback" not in err
    assert opened == []


def _saved_tf(tmp_path):
    from pv_hdrvol.editor.model import TransferFunctionModel

    TransferFunctionModel(hv.TransferFunction.ramp(0.0, 1.0, cmap="gray", opacity=(0.0, 0.3))).save(
        tmp_path / "tf.json")
    return tmp_path / "tf.json"


def _path_values(path):
    """The coarsest level of the store at ``path`` (what the editor and --tf see of it)."""
    from pv_hdrvol.editor.model import coarsest_values

    with hv.open_multiscale(path) as volume:
        return coarsest_values(volume)


def test_add_hdr_volume_names_a_plotter_that_is_not_one(grid):
    with pytest.raises(TypeError, match=re.escape("plotter must be a pyvista.Plotter (or a pyvistaqt BackgroundPlotter "
                                                  "or QtInteractor); got 'not a plotter': pass the plotter first, "
                                                  "add_hdr_volume(plotter, data, tf)")):  # was AttributeError
        hv.add_hdr_volume("not a plotter", grid[0])
    with pytest.raises(TypeError, match=re.escape("got an ImageData: pass the plotter first")):
        hv.add_hdr_volume(grid[0], grid[0])
