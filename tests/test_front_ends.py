"""One way of saying each thing (issue 18, part 4): the same bad input gets the same
error from hv.render, the PyVista accessor, the VTK algorithm and the CLI."""
import re

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.integrations.cli import main
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer

CASES = [
    # (keyword, value, CLI arguments, message)
    ("step", -1.0, ["--step", "-1"], "step must be > 0; got -1.0"),
    ("precision", "float8", ["--precision", "float8"], None),  # argparse's choices: checked below
    ("camera", "top", ["--view", "top"], "view must be one of ['iso', 'xy', 'yx', 'xz', 'zx', 'yz', 'zy']; got 'top'"),
    ("specular_power", 0.5, ["--specular-power", "0.5"], "specular_power must be >= 1; got 0.5"),
    ("global_alpha", 2.0, ["--global-alpha", "2"], "global_alpha must be <= 1; got 2.0"),
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
