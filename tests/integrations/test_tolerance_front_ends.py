"""``tolerance=`` in every front end (issue 32, part 1): the PyVista accessor, the VTK
algorithm and the command line render a small volume with a tolerance into the pixels
of ``hv.render(..., tolerance=)``, bit for bit, and hand on the knobs it chose (the
image's metadata, the VTK output's field data, ``pv-hdrvol info``). The ParaView
property is checked in real ParaView (tests/paraview/pv_render.py)."""
import json

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.integrations.cli import main
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer

TOL = 1e-3
SIZE = (16, 16)
#: what the record holds besides the time the pilot took
KNOBS = ("tolerance", "estimated_error", "step", "termination", "table_size", "precision", "rungs", "differences",
         "order", "peak", "knob_bias", "pilot_pixels")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """A 16^3 Gaussian blob (ImageData and its .vti), its default camera, and the
    reference: hv.render with the tolerance."""
    grid = pv.ImageData(dimensions=(16, 16, 16))
    x, y, z = grid.points.T
    grid["density"] = np.exp(-((x - 7.5) ** 2 + (y - 6.5) ** 2 + (z - 8.0) ** 2) / 18.0)
    path = tmp_path_factory.mktemp("tol") / "blob.vti"
    grid.save(path)
    camera = hv.Camera.fit(grid.bounds, "iso")
    reference = hv.render(grid, None, camera, SIZE, tolerance=TOL, progress_bar=False)
    record = reference.metadata["tolerance"]
    # the renderer chose: not the defaults (0.5 voxel, float32, 1e-6)
    assert record["precision"] == "float64" and record["step"] != 0.5 and record["termination"] != 1e-6
    assert 0 < record["estimated_error"] <= TOL
    return grid, path, camera, reference


def _knobs(record):
    return {key: record[key] for key in KNOBS}


def test_accessor_renders_the_pixels_of_hv_render(scene):
    grid, _, camera, reference = scene
    image = grid.hdrvol.render(camera=camera, size=SIZE, tolerance=TOL, progress_bar=False)
    assert image.rgba.dtype == np.float64
    np.testing.assert_array_equal(image.rgba, reference.rgba)
    np.testing.assert_array_equal(image.depth, reference.depth)
    assert _knobs(image.metadata["tolerance"]) == _knobs(reference.metadata["tolerance"])
    assert image.settings().options.tolerance == TOL  # replayed, it chooses again
    with pytest.raises(ValueError, match=r"^tolerance= chooses step, termination, precision: leave them at their "
                                         r"defaults or drop tolerance; got step=0\.3$"):
        grid.hdrvol.render(camera=camera, size=SIZE, tolerance=TOL, step=0.3)


def test_vtk_algorithm_renders_the_pixels_and_hands_on_the_knobs(scene):
    grid, _, camera, reference = scene
    alg = HDRVolumeRenderer()
    alg.SetInputDataObject(0, grid)
    alg.SetImageSize(*SIZE)
    alg.SetCamera(camera)
    alg.SetTolerance(TOL)
    assert alg.GetTolerance() == TOL and alg.GetLastTolerance() is None
    assert alg.Update()
    output = alg.GetOutput()
    image = hv.HDRImage.from_pyvista(pv.wrap(output))
    np.testing.assert_array_equal(image.rgba, reference.rgba)
    expected = _knobs(reference.metadata["tolerance"])
    # the knobs are in the output's field data, as the rest of the image's metadata
    stored = json.loads(output.GetFieldData().GetAbstractArray("hdrvol_metadata").GetValue(0))
    assert _knobs(stored["tolerance"]) == expected
    assert stored["step_voxels"] == expected["step"] and stored["precision"] == "float64"
    assert _knobs(alg.GetLastTolerance()) == expected

    # off again: the knobs as set, float32 and no record
    alg.SetTolerance(0)
    assert alg.GetTolerance() == 0.0 and alg.GetOptions().tolerance is None
    assert alg.Update()
    plain = hv.HDRImage.from_pyvista(pv.wrap(alg.GetOutput()))
    assert "tolerance" not in plain.metadata and alg.GetLastTolerance() is None
    np.testing.assert_array_equal(plain.rgba, hv.render(grid, None, camera, SIZE, progress_bar=False).rgba)


def test_cli_renders_the_pixels_and_info_prints_the_knobs(scene, tmp_path, capsys):
    grid, path, _, reference = scene
    record = reference.metadata["tolerance"]
    npy, exr = tmp_path / "t.npy", tmp_path / "t.exr"
    # the command line's camera is the iso view of the data's bounds, as the fixture's
    assert main(["render", str(path), "-o", str(npy), "--size", "16", "--tolerance", "1e-3", "--no-progress"]) == 0
    rendered = capsys.readouterr().out
    np.testing.assert_array_equal(hv.load(npy).rgba, reference.rgba)  # .npy: bit for bit, float64
    assert f"  step:               {record['step']:.6g} voxels" in rendered
    pytest.importorskip("OpenEXR")
    assert main(["render", str(path), "-o", str(exr), "--size", "16", "--tolerance", "1e-3", "--no-progress"]) == 0
    capsys.readouterr()
    image = hv.load(exr)
    np.testing.assert_array_equal(image.rgba, reference.rgba.astype(np.float32))  # what float32 EXR holds
    assert _knobs(image.metadata["tolerance"]) == _knobs(record)
    assert main(["info", str(exr)]) == 0
    info = capsys.readouterr().out
    for line in ["tolerance 0.001, the knobs the renderer chose:",
                 f"  step:               {record['step']:.6g} voxels",
                 f"  termination:        {record['termination']:.6g}",
                 f"  table size:         {record['table_size']}",
                 "  precision:          float64",
                 f"  estimated error:    {record['estimated_error']:.6g} of the peak (RMS)"]:
        assert line in info.splitlines(), (line, info)
    assert "tolerance=0.001" in info  # the options of the settings, which choose again
    assert "  tolerance: {" not in info  # printed readably, not as a raw dict under metadata:


def test_vtk_algorithm_on_pieces_renders_the_whole_on_piece_zero(scene):
    """Under MPI a tolerance's knobs are chosen on a pilot of the whole image, so piece
    0 reads the whole extent and renders alone (as for the default transfer function);
    a piece rendered as its own volume would be refused by GridPlan."""
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    from thread_comm import run_spmd

    grid, path, camera, _ = scene
    tf = hv.TransferFunction.ramp(0.05, 1.0, cmap="gray", opacity=(0.0, 0.3))
    expected = hv.render(grid, tf, camera, SIZE, tolerance=TOL, progress_bar=False)

    def process(comm):
        reader = vtkXMLImageDataReader()
        reader.SetFileName(str(path))
        renderer = HDRVolumeRenderer()
        renderer.SetInputConnection(reader.GetOutputPort())
        renderer.SetCommunicator(comm)
        renderer.SetImageSize(*SIZE)
        renderer.SetCamera(camera)
        renderer.SetTransferFunction(tf)  # with a function set, pieces would render where they live
        renderer.SetTolerance(TOL)
        ok = renderer.UpdatePiece(comm.rank, comm.size, 0)
        out = renderer.GetOutput()
        return ok, renderer.GetLastError(), reader.GetOutput().GetExtent(), (
            hv.HDRImage.from_pyvista(out) if out.GetNumberOfPoints() else None)

    results, errors = run_spmd(2, process)
    assert errors == [None, None] and [r[:2] for r in results] == [(True, None), (True, None)], results
    (_, _, extent, image), (_, _, _, other) = results
    assert extent == (0, 15, 0, 15, 0, 15) and other is None
    np.testing.assert_array_equal(image.rgba, expected.rgba)
    assert _knobs(image.metadata["tolerance"]) == _knobs(expected.metadata["tolerance"])


def test_a_tetrahedral_mesh_in_every_front_end(tmp_path, capsys):
    """Meshes choose tau_max instead of a step: the same pixels from the accessor, the
    VTK algorithm and the command line, and info prints tau_max."""
    mesh = pv.ImageData(dimensions=(6, 6, 6)).triangulate()
    x, y, z = mesh.points.T
    mesh["s"] = np.exp(-((x - 2.5) ** 2 + (y - 2.0) ** 2 + (z - 3.0) ** 2) / 4.0)
    camera = hv.Camera.fit(mesh.bounds, "iso")
    reference = hv.render(mesh, None, camera, SIZE, tolerance=TOL, progress_bar=False)
    record = reference.metadata["tolerance"]
    assert "tau_max" in record and "step" not in record and record["precision"] == "float64"
    mesh_knobs = [k if k != "step" else "tau_max" for k in KNOBS]

    image = mesh.hdrvol.render(camera=camera, size=SIZE, tolerance=TOL, progress_bar=False)
    np.testing.assert_array_equal(image.rgba, reference.rgba)
    alg = HDRVolumeRenderer()
    alg.SetInputDataObject(0, mesh)
    alg.SetImageSize(*SIZE)
    alg.SetCamera(camera)
    alg.SetTolerance(TOL)
    assert alg.Update()
    np.testing.assert_array_equal(hv.HDRImage.from_pyvista(pv.wrap(alg.GetOutput())).rgba, reference.rgba)
    assert {k: alg.GetLastTolerance()[k] for k in mesh_knobs} == {k: record[k] for k in mesh_knobs}

    mesh.save(tmp_path / "m.vtu")
    out = tmp_path / "m.npy"
    assert main(["render", str(tmp_path / "m.vtu"), "-o", str(out), "--size", "16", "--tolerance", "1e-3",
                 "--no-progress"]) == 0
    np.testing.assert_array_equal(hv.load(out).rgba, reference.rgba)
    printed = capsys.readouterr().out.splitlines()
    assert f"  tau_max:            {record['tau_max']:.6g}" in printed and not any("step:" in p for p in printed)
