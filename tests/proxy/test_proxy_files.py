"""Proxy folders on disk and the front ends that make and read them: the Python API,
the PyVista accessor, ``pv-hdrvol proxy`` and the VTK algorithm."""
import csv
import json
import re

import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.data.files import IMAGE_FORMATS
from pv_hdrvol.integrations.cli import main

pytest.importorskip("OpenEXR")
pv = pytest.importorskip("pyvista")


def blob_grid(n=24):
    grid = pv.ImageData(dimensions=(n, n, n), spacing=(0.5, 0.5, 0.5), origin=(-3, -3, -3))
    x, y, z = grid.points.T
    grid["density"] = np.exp(-((x - 0.5) ** 2 + y ** 2 / 2 + z ** 2 / 3) / 2)
    return grid


@pytest.fixture(scope="module")
def proxies():
    return hv.make_proxies(blob_grid(), "iso", 32, intervals=8, layers=[0.3, 0.6], multi_perspective=True,
                           training=2, clusters=4)


def test_a_folder_round_trips(proxies, tmp_path):
    folder = proxies.save(tmp_path / "blob.proxy")
    assert sorted(p.name for p in folder.iterdir()) == ["data.csv", "preview.png", "proxies.exr", "proxies.json"]
    q = hv.load_proxies(folder)
    assert repr(q) == repr(proxies)
    for name, a in proxies.arrays.items():
        np.testing.assert_array_equal(q.arrays[name], a.astype(np.float32).astype(np.float64), err_msg=name)
    np.testing.assert_array_equal(q.model.lut(), proxies.model.lut())  # JSON keeps float64 exactly
    assert q.camera == proxies.camera and q.size == proxies.size
    np.testing.assert_array_equal(q.edges, proxies.edges)
    assert q.tf.to_dict() == proxies.tf.to_dict()
    # a synthesis from the folder equals one from memory, to the float32 of the channels
    a, b = q.synthesize({3: 0.5}, rotate=(20, 0)), proxies.synthesize({3: 0.5}, rotate=(20, 0))
    np.testing.assert_allclose(a.rgba, b.rgba, atol=1e-5)
    with open(folder / "data.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows[0]["FILE"] == "preview.png" and rows[0]["FILE_proxies"] == "proxies.exr"
    assert int(rows[0]["intervals"]) == 8 and int(rows[0]["layers"]) == 2


def test_broken_folders_say_what_is_wrong(proxies, tmp_path):
    import OpenEXR

    folder = proxies.save(tmp_path / "p")
    with pytest.raises(FileNotFoundError, match="no proxy folder at"):
        hv.load_proxies(tmp_path / "missing")
    meta = json.loads((folder / "proxies.json").read_text())

    bad = dict(meta, size=[16, 16])
    (folder / "proxies.json").write_text(json.dumps(bad))
    with pytest.raises(hv.ProxyFormatError, match="the images are 32x32; proxies.json says 16x16"):
        hv.load_proxies(folder)
    (folder / "proxies.json").write_text(json.dumps(dict(meta, version=99)))
    with pytest.raises(hv.ProxyFormatError, match="has version 99; this pv_hdrvol reads version 1"):
        hv.load_proxies(folder)
    (folder / "proxies.json").write_text(json.dumps(meta))

    with OpenEXR.File(str(folder / "proxies.exr")) as f:
        channels = {k: np.array(v.pixels) for k, v in f.channels().items()}
    channels.pop("iop.I05", None) if "iop.I05" in channels else channels.pop("own.I05")
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(str(folder / "proxies.exr"))
    with pytest.raises(hv.ProxyFormatError, match=r"lacks channel 'own.I05' \(own of interval 5\)"):
        hv.load_proxies(folder)
    (folder / "proxies.json").unlink()
    with pytest.raises(FileNotFoundError, match="proxies.json is missing"):
        hv.load_proxies(folder)
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="exists and is not a folder"):
        proxies.save(tmp_path / "file")


def test_accessor_makes_the_same_proxies_as_the_function():
    grid = blob_grid(16)
    a = grid.hdrvol.make_proxies("xy", 16, intervals=4, training=0)
    b = hv.make_proxies(grid, "xy", 16, intervals=4, training=0)
    for name in a.arrays:
        np.testing.assert_array_equal(a.arrays[name], b.arrays[name])
    with pytest.raises(TypeError, match="proxies are made of image data"):
        pv.Sphere().delaunay_3d().hdrvol.make_proxies()


def test_cli_makes_a_folder_and_synthesises_from_it(tmp_path, capsys):
    vti = tmp_path / "blob.vti"
    blob_grid(20).save(vti)
    out = tmp_path / "blob.proxy"
    assert main(["proxy", "make", str(vti), str(out), "--size", "24", "--intervals", "8", "--layers", "0.5",
                 "--multi-perspective", "--training", "2", "--clusters", "3"]) == 0
    assert "wrote" in capsys.readouterr().out
    p = hv.load_proxies(out)
    assert (p.size, p.intervals, p.n_layers, p.multi_perspective) == ((24, 24), 8, 1, True)
    exr = tmp_path / "syn.exr"
    assert main(["proxy", "view", str(out), "-o", str(exr), "--opacity", "2=0.5", "5=0", "--rotate", "15", "0",
                 "--headlight", "--enhance", "0.3"]) == 0
    img = hv.load(exr)
    ref = p.synthesize({2: 0.5, 5: 0.0}, rotate=(15, 0), light=hv.Light(), enhance=0.3)
    np.testing.assert_allclose(img.rgba, ref.rgba, atol=1e-6)
    png = tmp_path / "layers.png"
    assert main(["proxy", "view", str(out), "-o", str(png), "--layer", "0", "1", "0.5", "0.2", "1",
                 "--ambient-occlusion", "1"]) == 0
    # the PNG holds the layer picture's display mapping, pixel for pixel
    layered = p.synthesize(layers={0: ((1.0, 0.5, 0.2), 1.0)}, ambient_occlusion=1.0)
    plain = p.synthesize()
    shown = _read_png(png)
    np.testing.assert_array_equal(shown, layered.to_display())
    assert np.abs(shown.astype(int) - plain.to_display().astype(int)).max() > 32  # a layer, not the volume
    with pytest.raises(SystemExit):
        main(["proxy", "view", str(out), "-o", str(exr), "--opacity", "9=0.5"])
    assert "interval 9 is out of range; these proxies have intervals 0..7" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["proxy", "view", str(out), "-o", str(exr), "--opacity", "2:0.5"])
    assert "--opacity takes I=K" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["proxy", "view", str(tmp_path / "nothing"), "-o", str(exr)])
    assert "no proxy folder at" in capsys.readouterr().err


def _read_png(path):
    """(rows, cols, channels) uint8, row 0 at the top, as VTK's PNG reader reads it."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader

    reader = vtkPNGReader()
    reader.SetFileName(str(path))
    reader.Update()
    out = reader.GetOutput()
    cols, rows, _ = out.GetDimensions()
    pixels = vtk_to_numpy(out.GetPointData().GetScalars())
    return pixels.reshape(rows, cols, -1)[::-1]


def test_vtk_algorithm_writes_the_folder(tmp_path):
    from pv_hdrvol.integrations.vtk_algorithm import HDRProxyWriter

    grid = blob_grid(16)
    writer = HDRProxyWriter()
    writer.SetInputDataObject(grid)
    writer.SetImageSize(20, 16)
    writer.SetIntervals(4)
    writer.SetTraining(0)
    writer.SetCamera("xy")
    assert not writer.Update()
    assert writer.GetLastError() == "ValueError: HDRProxyWriter has no file name: SetFileName(folder) first"
    writer.SetFileName(str(tmp_path / "w.proxy"))
    assert writer.Update(), writer.GetLastError()
    out = hv.HDRImage.from_pyvista(pv.wrap(writer.GetOutput()))
    p = hv.load_proxies(tmp_path / "w.proxy")
    np.testing.assert_allclose(out.rgba, p.rgba, atol=1e-7)
    direct = hv.make_proxies(grid, "xy", (20, 16), intervals=4, training=0)
    np.testing.assert_array_equal(writer.proxies.atten, direct.atten)
    writer.SetCamera(hv.Camera.fit(grid, "xy"))  # perspective
    assert not writer.Update()
    assert "proxies need a parallel-projection camera" in writer.GetLastError()


# -- one answer per question (issue 31, part 6) ----------------------------------------------------------------------
def _tets():
    mesh = pv.ImageData(dimensions=(4, 4, 4)).triangulate()
    mesh["s"] = np.arange(mesh.n_points, dtype=float)
    return mesh


def test_proxies_are_refused_for_meshes_with_one_message(tmp_path, capsys):
    # the proxy pass marches voxels; the tet renderer keeps no per-interval attenuation: meshes are refused
    for mesh in (_tets(), hv.tetmesh_from_dataset(_tets())):
        with pytest.raises(TypeError, match=f"proxies are made of image data \\(ImageData\\); got a tetrahedral mesh "
                                            f"\\({type(mesh).__name__}\\): resample it onto an image first"):
            hv.make_proxies(mesh, "iso", 8, training=0)
    _tets().save(tmp_path / "tets.vtu")
    with pytest.raises(SystemExit) as exit_info:
        main(["proxy", "make", str(tmp_path / "tets.vtu"), str(tmp_path / "out")])
    assert exit_info.value.code == 2
    assert (f"pv-hdrvol proxy make: error: '{tmp_path / 'tets.vtu'}' is a mesh file; proxies are made of image "
            f"volumes (the proxy pass marches voxels): use one of {', '.join(IMAGE_FORMATS)}, or "
            f"render the mesh with pv-hdrvol render") in capsys.readouterr().err
    _tets().save(tmp_path / "tets.vtk")  # .vtk holds either kind: refused once read
    with pytest.raises(SystemExit):
        main(["proxy", "make", str(tmp_path / "tets.vtk"), str(tmp_path / "out")])
    assert (f"error: '{tmp_path / 'tets.vtk'}' holds a tetrahedral mesh; proxies are made of image volumes"
            in capsys.readouterr().err)
    assert not (tmp_path / "out").exists()
    with pytest.raises(SystemExit):
        main(["proxy", "make", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert f"image volume, one of {', '.join(IMAGE_FORMATS)} (proxies are made of image data" \
        in help_text and ".vtu" not in help_text  # was: listed, then refused
    assert IMAGE_FORMATS[:2] == (".vti", ".pvti") and ".vtr" not in IMAGE_FORMATS and ".vtm" not in IMAGE_FORMATS


def test_layers_outside_the_data_are_refused_not_left_empty():
    grid = blob_grid(12)
    lo, hi = float(grid["density"].min()), float(grid["density"].max())
    with pytest.raises(ValueError, match=re.escape(f"layers 1e+09 outside the data range [{lo:g}, {hi:g}] would be "
                                                   f"empty depth layers (no ray crosses them); choose isovalues "
                                                   f"inside the range, or layers=k for k layers at the opacity's "
                                                   f"peaks")):
        hv.make_proxies(grid, "iso", 8, intervals=4, layers=[0.5, 1e9], training=0)
    with pytest.raises(ValueError, match=re.escape("layers -1, 2 outside the data range")):
        hv.make_proxies(grid, "iso", 8, intervals=4, layers=[-1.0, 2.0], training=0)
    p = hv.make_proxies(grid, "iso", 8, intervals=4, layers=[lo, hi], training=0)  # the ends are inside
    assert p.n_layers == 2
