"""The pv-hdrvol command, in-process and once as a real subprocess."""
import json
import os
import shutil
import struct
import subprocess
import sys

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.data.kinds import SUPPORTED
from pv_hdrvol.datasets import hydrogen_orbital, hydrogen_orbital_array
from pv_hdrvol.integrations.cli import main
from pv_hdrvol.raycast.grid import default_transfer_function


def _png_size(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])  # IHDR width, height


def _stat_line(out, label):
    line = next(line for line in out.splitlines() if line.strip().startswith(label))
    return line.split(":", 1)[1].strip()


@pytest.fixture(scope="module")
def volume_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("vol") / "orbital.vti"
    grid = hydrogen_orbital(size=20)
    grid["twice"] = 2 * grid["probability_density"]
    grid.set_active_scalars("probability_density")
    grid.save(path)
    return path


def test_demo_in_process(tmp_path, capsys):
    assert main(["demo", "-o", str(tmp_path / "out"), "--size", "20", "16", "--grid", "20", "--no-progress"]) == 0
    out = capsys.readouterr().out
    exr, png = tmp_path / "out" / "demo.exr", tmp_path / "out" / "demo.png"
    assert exr.is_file() and _png_size(png) == (20, 16)
    image = hv.load(exr)
    assert image.shape == (16, 20)
    # the printed statistics are those of the written image
    assert _stat_line(out, "peak luminance") == f"{image.peak_luminance:.6g}"
    assert _stat_line(out, "min non-zero luminance") == f"{image.min_nonzero_luminance:.6g}"
    assert _stat_line(out, "dynamic range") == f"{image.dynamic_range_decades:.2f} decades"
    assert image.dynamic_range_decades > 4
    assert image.metadata["source"] == "pv_hdrvol.datasets.hydrogen_orbital(n=3, l=2, m=0, size=20)"


def test_render_matches_library(volume_file, tmp_path, capsys):
    out_exr, out_png = tmp_path / "r.exr", tmp_path / "r.png"
    args = ["render", str(volume_file), "-o", str(out_exr), "--png", str(out_png), "--size", "20", "16",
            "--step", "0.7", "--clim", "1e-12", "1e-3", "--scale", "log", "--cmap", "gray",
            "--opacity", "0", "0.2", "--view", "xz", "--scalars", "twice", "--no-progress"]
    assert main(args) == 0
    assert f"wrote {out_exr}" in capsys.readouterr().out
    grid = pv.read(volume_file)
    tf = hv.TransferFunction.ramp(1e-12, 1e-3, scale="log", cmap="gray", opacity=(0.0, 0.2))
    ref = hv.render(grid, tf, hv.Camera.fit(grid.bounds, "xz"), (20, 16), scalars="twice", step=0.7)
    image = hv.load(out_exr)
    np.testing.assert_array_equal(image.rgba, ref.rgba)  # float32 EXR round trip is exact
    assert image.metadata["source_file"] == str(volume_file) and image.metadata["scalars"] == "twice"
    assert _png_size(out_png) == (20, 16)


def test_render_clipped_matches_library(volume_file, tmp_path):
    out = tmp_path / "c.exr"
    assert main(["render", str(volume_file), "-o", str(out), "--size", "18", "14", "--no-progress",
                 "--clip-plane", "0", "0", "0.1", "0.2", "0", "-1", "--clip-plane", "0", "0", "0", "1", "0", "0",
                 "--crop-box", "-40", "40", "-40", "40", "-30", "40"]) == 0
    grid = pv.read(volume_file)
    clip = {"clip_planes": [((0, 0, 0.1), (0.2, 0, -1)), ((0, 0, 0), (1, 0, 0))], "crop_box": (-40, 40, -40, 40, -30, 40)}
    ref = hv.render(grid, None, hv.Camera.fit(grid.bounds, "iso"), (18, 14), **clip)
    image = hv.load(out)
    np.testing.assert_array_equal(image.rgba, ref.rgba)
    assert image.settings().options == hv.RenderOptions(**clip)
    assert np.abs(image.rgba - hv.render(grid, None, hv.Camera.fit(grid.bounds, "iso"), (18, 14)).rgba).max() > 0.01


def test_render_shaded_matches_library(volume_file, tmp_path):
    out_exr = tmp_path / "s.exr"
    args = ["render", str(volume_file), "-o", str(out_exr), "--size", "18", "--shade", "--specular", "0.6",
            "--specular-power", "20", "--ambient", "0.05", "--diffuse", "0.9", "--light", "0", "0", "1",
            "--light", "1", "1", "0", "--no-progress"]
    assert main(args) == 0
    grid = pv.read(volume_file)
    ref = hv.render(grid, None, hv.Camera.fit(grid.bounds, "iso"), (18, 18), shade=True, specular=0.6,
                    specular_power=20.0, ambient=0.05, diffuse=0.9, lights=[(0, 0, 1), (1, 1, 0)])
    image = hv.load(out_exr)
    np.testing.assert_array_equal(image.rgba, ref.rgba)
    assert image.settings().options.lights == (hv.Light((0, 0, 1)), hv.Light((1, 1, 0)))


@pytest.mark.parametrize("args,lens", [
    (["--magnifier", "9", "7", "6", "2.5"], hv.Magnifier((9.0, 7.0), radius=6.0, factor=2.5)),
    (["--fisheye", "120"], hv.Fisheye(120.0)),
])
def test_render_with_a_lens_matches_library(volume_file, tmp_path, args, lens):
    out = tmp_path / "l.exr"
    assert main(["render", str(volume_file), "-o", str(out), "--size", "18", "14", "--no-progress", *args]) == 0
    grid = pv.read(volume_file)
    ref = hv.render(grid, None, hv.Camera.fit(grid.bounds, "iso"), (18, 14), lens=lens)
    np.testing.assert_array_equal(hv.load(out).rgba, ref.rgba)


def test_render_maximum_projection_keeps_the_value(volume_file, tmp_path, capsys):
    out_exr = tmp_path / "mip.exr"
    args = ["render", str(volume_file), "-o", str(out_exr), "--size", "12", "--blending", "maximum",
            "--scalars", "twice", "--no-progress"]
    assert main(args) == 0
    grid = pv.read(volume_file)
    image = hv.load(out_exr)
    # the projected value does not depend on the transfer function (every finite block is sampled)
    tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray")
    ref = hv.render(grid, tf, hv.Camera.fit(grid.bounds, "iso"), 12, scalars="twice", blending="maximum")
    assert image.metadata["blending"] == "maximum"
    np.testing.assert_array_equal(image.value, ref.value.astype(np.float32))


def test_render_defaults_legacy_vtk(volume_file, tmp_path, monkeypatch):
    legacy = tmp_path / "orbital.vtk"
    pv.read(volume_file).save(legacy)
    monkeypatch.chdir(tmp_path)
    assert main(["render", str(legacy), "--size", "12", "--no-progress"]) == 0
    image = hv.load(tmp_path / "orbital.exr")  # default output: FILE's stem + .exr in the current directory
    grid = pv.read(legacy)  # legacy files round spacing and origin: compare with what was read
    ref = hv.render(grid, None, hv.Camera.fit(grid.bounds, "iso"), (12, 12))
    np.testing.assert_array_equal(image.rgba, ref.rgba)


def test_render_tetrahedral_mesh(tmp_path, capsys):
    mesh = pv.ImageData(dimensions=(4, 5, 3), spacing=(0.5, 0.25, 1.0)).triangulate()
    mesh["pressure"] = np.linspace(1.0, 2.0, mesh.n_points)
    path = tmp_path / "part.vtu"
    mesh.save(path)
    out = tmp_path / "part.exr"
    assert main(["render", str(path), "-o", str(out), "--size", "14", "12", "--opacity", "0", "0.4",
                 "--no-progress"]) == 0
    assert f"part.vtu (pressure, {mesh.n_cells} tets): 14x12 float32" in capsys.readouterr().out
    # the default transfer function of the mesh, with the opacity given
    tf = default_transfer_function(hv.tetmesh_from_dataset(mesh), opacity=(0.0, 0.4))
    assert tf.opacities[0] == 0.0 and tf.opacities[-1] == 0.4
    ref = hv.render(mesh, tf, hv.Camera.fit(mesh.bounds, "iso"), (14, 12))
    np.testing.assert_array_equal(hv.load(out).rgba, ref.rgba)


def test_render_nrrd(tmp_path):
    values, spacing, _ = hydrogen_orbital_array(size=12)
    header = (f"NRRD0004\ntype: double\ndimension: 3\nsizes: 12 12 12\nspacings: {spacing[0]!r} {spacing[1]!r} "
              f"{spacing[2]!r}\nencoding: raw\nendian: little\n\n")
    nrrd = tmp_path / "orbital.nrrd"
    nrrd.write_bytes(header.encode() + values.astype("<f8").tobytes())
    assert main(["render", str(nrrd), "-o", str(tmp_path / "n.exr"), "--size", "10", "--no-progress"]) == 0
    grid = pv.read(nrrd)
    np.testing.assert_array_equal(grid.active_scalars, values.reshape(-1))
    ref = hv.render(grid, None, hv.Camera.fit(grid.bounds, "iso"), (10, 10))
    np.testing.assert_array_equal(hv.load(tmp_path / "n.exr").rgba, ref.rgba)


def test_info(volume_file, tmp_path, capsys):
    exr = tmp_path / "i.exr"
    assert main(["render", str(volume_file), "-o", str(exr), "--size", "8", "--precision", "float64",
                 "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["info", str(exr)]) == 0
    out = capsys.readouterr().out
    image = hv.load(exr)
    assert out.startswith("i.exr: 8x8 float32\n")  # EXR stores float32
    assert _stat_line(out, "peak luminance") == f"{image.peak_luminance:.6g}"
    assert "  precision: float64\n" in out and f"  source_file: {volume_file}\n" in out
    # the render settings, readably; all of them with --json
    settings = image.settings()
    assert "render settings (pv_hdrvol.load(FILE).settings()):\n  size:               8x8\n" in out
    tf = settings.tf
    assert (f"  transfer function:  {tf.values.size} control points over [{tf.vmin!r}, {tf.vmax!r}], scale "
            f"{tf.scale}, colours in rgb, opacity 0 to {tf.opacities.max():.6g}, table of 65536 entries\n") in out
    assert "  options:            step=0.5, precision='float64', global_alpha=1.0, " in out
    assert "  settings: " not in out  # not repeated as a raw dict
    assert "the knobs the renderer chose" not in out  # no tolerance=, no record of one
    assert main(["info", str(exr), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == image.metadata


@pytest.mark.parametrize(("args", "message"), [
    (["render", "{tmp}/missing.vti"], "pv-hdrvol render: error: file not found: '{tmp}/missing.vti'"),
    (["render", "{vol}", "--scalars", "nope"],
     "pv-hdrvol render: error: scalars 'nope' not found; point arrays: ['probability_density', 'twice'], "
     "cell arrays: []"),
    (["render", "{vol}", "--size", "1", "2", "3"], "pv-hdrvol render: error: --size takes N or W H; got 3 numbers"),
    (["render", "{vol}", "--step", "-1"], "pv-hdrvol render: error: step must be > 0; got -1.0"),
    (["render", "{vol}", "--view", "top"], "pv-hdrvol render: error: view must be one of ['iso', 'xy', 'yx', "
                                           "'xz', 'zx', 'yz', 'zy']; got 'top'"),
    (["render", "{vol}", "--clim", "-1", "auto", "--scale", "log"],
     "pv-hdrvol render: error: scale='log' needs a positive low end of clim; got -1.0"),
    (["render", "{vol}", "--clim", "0", "one"], "pv-hdrvol render: error: --clim: 'one' is not a number"),
    (["render", "{vol}", "--opacity", "0", "half"], "pv-hdrvol render: error: --opacity: 'half' is not a number"),
    (["render", "{vol}", "--magnifier", "5", "5", "4", "2", "--fisheye", "90"],
     "pv-hdrvol render: error: --magnifier and --fisheye are two lenses; give one"),
    (["render", "{vol}", "--shade", "--blending", "maximum"],
     "pv-hdrvol render: error: shade applies to blending='composite' only; got blending='maximum'"),
    (["render", "{vol}", "-o", "{tmp}/x.png"],
     "pv-hdrvol render: error: output '{tmp}/x.png' must end in .exr or .npy"),
    (["render", "{vol}", "--png", "{tmp}/x.jpg"], "pv-hdrvol render: error: --png '{tmp}/x.jpg' must end in .png"),
    (["render", "{tmp}/notes.txt"], "pv-hdrvol render: error: cannot read '{tmp}/notes.txt': unknown extension "
                                    "'.txt'"),
    (["render", "{tmp}/sphere.vtk"], "pv-hdrvol render: error: '{tmp}/sphere.vtk' holds a PolyData; pv_hdrvol "
                                     "renders " + SUPPORTED),
    (["render", "{tmp}/tets.vtk", "--blending", "maximum"],
     "pv-hdrvol render: error: tetrahedral meshes support blending='composite' only; got 'maximum'"),
    (["demo", "--orbital", "2", "2", "0"], "pv-hdrvol demo: error: l must satisfy 0 <= l < n = 2; got l=2"),
    (["info", "{tmp}/missing.exr"], "pv-hdrvol info: error: file not found: '{tmp}/missing.exr'"),
    (["info", "{tmp}/notes.txt"], "pv-hdrvol info: error: unknown image extension '.txt'; use .exr, .hdr or .npy"),
    (["info", "{tmp}/fake.exr"], "pv-hdrvol info: error: '{tmp}/fake.exr' is not a readable OpenEXR image: it "
                                 "does not start with the OpenEXR magic number"),
    (["render", "{vol}", "-o", "{tmp}/nodir/x.exr"],
     "pv-hdrvol render: error: -o/--output: cannot write '{tmp}/nodir/x.exr': no such folder: '{tmp}/nodir'"),
    (["render", "{vol}", "-o", "{tmp}/x.exr", "--png", "{tmp}/notes.txt/x.png"],
     "pv-hdrvol render: error: --png: cannot write '{tmp}/notes.txt/x.png': not a folder: '{tmp}/notes.txt'"),
    (["demo", "-o", "{tmp}/out", "--size", "8"], "pv-hdrvol demo: error: --output-dir: cannot write an image over a "
                                                 "folder: '{tmp}/out/demo.png'"),
    (["paint"], "pv-hdrvol: error: argument COMMAND: invalid choice: 'paint'"),
    # --tolerance chooses what --step and --precision set: refused together, as argparse refuses
    # exclusive options, before the file is read
    (["render", "{tmp}/missing.vti", "--tolerance", "1e-3", "--step", "1"],
     "pv-hdrvol render: error: argument --tolerance: not allowed with argument --step"),
    (["render", "{vol}", "--precision", "float64", "--tolerance", "1e-3"],
     "pv-hdrvol render: error: argument --tolerance: not allowed with argument --precision"),
    (["demo", "--tolerance", "1e-2", "--step", "1", "--precision", "float32"],
     "pv-hdrvol demo: error: argument --tolerance: not allowed with argument --step"),
    (["render", "{vol}", "--tolerance", "0.7"], "pv-hdrvol render: error: tolerance must be <= 0.5; got 0.7"),
    (["render", "{vol}", "--tolerance", "0"], "pv-hdrvol render: error: tolerance must be > 0; got 0.0"),
    (["render", "{vol}", "--clip-plane", "0", "0", "0", "0", "0", "0"],
     "pv-hdrvol render: error: a clip plane's normal must not be the zero vector; got (0.0, 0.0, 0.0)"),
    (["render", "{vol}", "--crop-box", "0", "1", "0", "1", "2", "1"],
     "pv-hdrvol render: error: crop_box needs min < max on every axis (infinite ends allowed); got (0.0, 1.0, 0.0, "
     "1.0, 2.0, 1.0)"),
])
def test_user_errors_exit_2_without_traceback(args, message, volume_file, tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("not a volume")
    (tmp_path / "out" / "demo.png").mkdir(parents=True)
    (tmp_path / "fake.exr").write_bytes(b"not an exr")
    pv.Sphere().save(tmp_path / "sphere.vtk")
    tets = pv.ImageData(dimensions=(3, 3, 3)).triangulate()
    tets["s"] = np.arange(tets.n_points, dtype=float)
    tets.save(tmp_path / "tets.vtk")
    args = [a.format(tmp=tmp_path, vol=volume_file) for a in args]
    with pytest.raises(SystemExit) as exit_info:
        main(args + (["--no-progress"] if args[0] in ("render", "demo") else []))
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert message.format(tmp=tmp_path) in err
    assert "Traceback" not in err


def test_console_script_demo(tmp_path):
    script = shutil.which("pv-hdrvol")
    command = [script] if script else [sys.executable, "-m", "pv_hdrvol.integrations.cli"]
    result = subprocess.run(command + ["demo", "-o", str(tmp_path), "--size", "16", "--grid", "16"],
                            capture_output=True, text=True, timeout=300, env={**os.environ, "PYTHONWARNINGS": ""})
    assert result.returncode == 0, result.stderr
    assert "dynamic range:" in result.stdout and "decades" in result.stdout
    assert _png_size(tmp_path / "demo.png") == (16, 16)
    assert hv.load(tmp_path / "demo.exr").shape == (16, 16)


def test_transfer_function_options_on_a_constant_volume(tmp_path):
    # the data range is empty: the ramp takes the default's range [v, v + 1] instead of failing
    path = tmp_path / "const.vti"
    grid = pv.ImageData(dimensions=(6, 6, 6))
    grid["v"] = np.full(grid.n_points, 2.0)
    grid.save(path)
    out = tmp_path / "c.exr"
    args = ["render", str(path), "--cmap", "gray", "--opacity", "0.5", "0.5", "-o", str(out), "--size", "8",
            "--no-progress"]
    assert main(args) == 0
    assert hv.load(out).rgba[..., 3].max() > 0


def test_output_folders_are_checked_before_reading_and_rendering(volume_file, tmp_path, monkeypatch, capsys):
    def must_not_run(*args, **kwargs):
        raise AssertionError("rendered although the output cannot be written")

    monkeypatch.setattr(pv, "read", must_not_run)
    monkeypatch.setattr(hv, "render", must_not_run)
    for args in (["-o", str(tmp_path / "missing" / "x.exr")], ["--png", str(tmp_path / "missing" / "x.png")]):
        with pytest.raises(SystemExit) as exit_info:
            main(["render", str(volume_file), "--no-progress", *args])
        assert exit_info.value.code == 2
        assert f"no such folder: '{tmp_path / 'missing'}'" in capsys.readouterr().err


def test_render_help_lists_every_readable_extension(capsys):
    from pv_hdrvol.integrations.cli import READABLE

    with pytest.raises(SystemExit) as exit_info:
        main(["render", "--help"])
    assert exit_info.value.code == 0
    help_text = " ".join(capsys.readouterr().out.split())  # argparse wraps lines
    assert (f"one of {', '.join(READABLE)} (meshes: .vtu, .pvtu, .vts, .vtk; blocks, rendered as one scene: .vtm, "
            f".vtpc, .vtpd)") in help_text
    assert {".vtu", ".cube", ".vtr", ".vts", ".vtm", ".vtpc"} <= set(READABLE)


@pytest.mark.data
def test_render_gaussian_cube_as_pyvista_reads_it(shared_data, tmp_path, capsys):
    cube = shared_data / "hdr" / "m4_TotalDensity.cube"
    out = tmp_path / "cube.exr"
    assert main(["render", str(cube), "-o", str(out), "--size", "16", "12", "--no-progress"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ("pv-hdrvol render: note: m4_TotalDensity.cube is rendered as pyvista.read gives it, in "
                            "grid index units (spacing 1, origin 0, axis-aligned); the cube's origin, step (steps "
                            "0.566918, 0.566917, 0.566918) and axis directions are not applied\n")
    assert "m4_TotalDensity.cube (SCF Total Density, 25x22x31): 16x12 float32" in captured.out
    # the same image as pyvista.read + the accessor give
    ref = pv.read(cube).hdrvol.render(size=(16, 12), camera="iso")
    np.testing.assert_array_equal(hv.load(out).rgba, ref.rgba)
    assert ref.peak_luminance > 0  # not an empty picture


def _png_pixels(path):
    """RGB pixels of a PNG written by pv_hdrvol's own writer (8-bit RGB, filter 0 on every row)."""
    import zlib

    data = path.read_bytes()
    width, height = _png_size(path)
    pos, idat = 8, b""
    while pos < len(data):
        length, tag = struct.unpack(">I4s", data[pos:pos + 8])
        if tag == b"IDAT":
            idat += data[pos + 8:pos + 8 + length]
        pos += 12 + length
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(height, 1 + 3 * width)
    assert np.all(raw[:, 0] == 0)
    return raw[:, 1:].reshape(height, width, 3)


@pytest.mark.parametrize("tonemap", [None, "drago", "linear"])
def test_png_preview_tonemap(volume_file, tmp_path, tonemap):
    out_exr, out_png = tmp_path / "t.exr", tmp_path / "t.png"
    args = ["render", str(volume_file), "-o", str(out_exr), "--png", str(out_png), "--size", "20", "16",
            "--no-progress"] + (["--tonemap", tonemap] if tonemap else [])
    assert main(args) == 0
    image = hv.load(out_exr)  # float32 both in the render and in the file
    expected = image.to_display() if tonemap is None else image.tonemap(tonemap).rgb8
    np.testing.assert_array_equal(_png_pixels(out_png), expected)
    if tonemap == "drago":
        assert not np.array_equal(expected, image.to_display())  # the option changes the picture


def test_png_preview_with_colorbar(volume_file, tmp_path):
    import matplotlib.image

    out_exr, out_png = tmp_path / "c.exr", tmp_path / "c.png"
    args = ["render", str(volume_file), "-o", str(out_exr), "--png", str(out_png), "--size", "20", "16",
            "--clim", "1e-9", "1e-3", "--scale", "log", "--colorbar", "--no-progress"]
    assert main(args) == 0
    preview = hv.load(out_exr).to_display()
    figure = np.round(matplotlib.image.imread(out_png)[..., :3] * 255).astype(np.uint8)
    assert figure.shape[1] > 20 + 60 and figure.shape[0] >= 16  # room for the bar and its labels
    # the preview sits pixel for pixel at the left edge
    rows = [r for r in range(figure.shape[0] - 15) if np.array_equal(figure[r:r + 16, :20], preview)]
    assert len(rows) == 1, rows


@pytest.mark.parametrize(("args", "message"), [
    (["--colorbar"], "pv-hdrvol render: error: --colorbar styles the PNG preview; add --png OUT.png"),
    (["--tonemap", "drago"], "pv-hdrvol render: error: --tonemap styles the PNG preview; add --png OUT.png"),
    # (argparse quotes the choices from Python 3.12.8 on: the list is not pinned)
    (["--png", "{tmp}/x.png", "--tonemap", "aces"],
     "pv-hdrvol render: error: argument --tonemap: invalid choice: 'aces' (choose from "),
])
def test_preview_option_errors(args, message, volume_file, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["render", str(volume_file), "-o", str(tmp_path / "x.exr"), "--no-progress",
              *[a.format(tmp=tmp_path) for a in args]])
    assert exit_info.value.code == 2
    assert message.format(tmp=tmp_path) in capsys.readouterr().err


def test_matplotlib_stays_out_of_a_render_without_colorbar(volume_file, tmp_path):
    # pyvista itself imports parts of matplotlib (colors); the figure machinery stays out
    code = ("import sys; from pv_hdrvol.integrations.cli import main; "
            f"main(['render', {str(volume_file)!r}, '-o', {str(tmp_path / 'g.exr')!r}, '--png', "
            f"{str(tmp_path / 'g.png')!r}, '--cmap', 'gray', '--size', '8', '--no-progress']); "
            "print(sorted(m for m in ('pv_hdrvol.image.colorbar', 'matplotlib.figure', 'matplotlib.pyplot') "
            "if m in sys.modules))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, env=env)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == "[]"


def test_render_with_pof_culls_and_matches_library(tmp_path, capsys):
    from pv_hdrvol.culling.pof import PlenopticOpacity

    rng = np.random.default_rng(11)
    grid = pv.ImageData(dimensions=(45, 37, 40))
    grid.point_data["v"] = 0.6 + 0.4 * rng.random(grid.n_points)
    path = tmp_path / "opaque.vti"
    grid.save(path)
    tf = hv.TransferFunction([0.0, 0.5, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1], [1, 1, 1]], [0.0, 0.9, 0.99])
    pof = PlenopticOpacity.compute(grid, [tf], block_size=8)
    pof.save(tmp_path / "opaque.pof.npz")
    out_exr = tmp_path / "c.exr"
    assert main(["render", str(path), "--pof", str(tmp_path / "opaque.pof.npz"), "--k", "1.5", "--size", "40", "32",
                 "-o", str(out_exr), "--no-progress"]) == 0
    out = capsys.readouterr().out
    family = hv.TransferFunction.family([tf], [1.5])
    ref = hv.render(grid, family, hv.Camera.fit(grid.bounds, "iso", parallel_projection=True), (40, 32), cull=pof)
    image = hv.load(out_exr)
    np.testing.assert_array_equal(image.rgba, ref.rgba)
    stats = ref.metadata["culling"]
    assert stats["culled"] > 0
    assert _stat_line(out, "culled blocks").startswith(f"{stats['culled']} of {stats['nonempty']} non-empty")
    for extra, message in ((["--cmap", "gray"], "--pof renders the family of its bases"),
                           (["--k", "1", "2"], "k must have one weight per basis")):
        with pytest.raises(SystemExit):
            main(["render", str(path), "--pof", str(tmp_path / "opaque.pof.npz"), "-o", str(out_exr), *extra])
        assert message in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["render", str(path), "--k", "1", "-o", str(out_exr)])
    assert "--k weighs the bases of --pof; give --pof FILE.npz" in capsys.readouterr().err
