"""Every front end takes every kind of dataset (issue 33, part 6): the classification
(:mod:`pv_hdrvol.data.kinds`), files of each kind, the accessor, the command line, the
editor's model and the viewer's progressive renderer, each against ``hv.render`` of the
same data in memory."""
import re

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.data.kinds import BLOCKS, GRID, MESH, SUPPORTED, as_renderable, data_kind
from pv_hdrvol.integrations.cli import main
from pv_hdrvol.data.files import read_volume

SIZE = (14, 12)
OPTS = dict(precision="float64")


def _image():
    grid = pv.ImageData(dimensions=(9, 7, 6), spacing=(0.5, 0.4, 0.6), origin=(1.0, -1.0, 0.5))
    x, y, z = grid.points.T
    grid["f"] = 0.2 + 0.3 * x + 0.2 * y + 0.1 * z
    return grid


def _curvilinear():
    """A warped box: a curvilinear grid with a smooth field."""
    i, j, k = np.meshgrid(np.linspace(0, 1, 6), np.linspace(0, 1, 5), np.linspace(0, 1, 4), indexing="ij")
    x = i + 0.15 * np.sin(2.0 * j)
    y = j + 0.1 * i * k
    z = k + 0.05 * i
    grid = pv.StructuredGrid(x, y, z)
    grid["f"] = np.sin(grid.points[:, 0]) + grid.points[:, 1] ** 2
    return grid


def _halves(image):
    return pv.MultiBlock([image.extract_subset((0, 4, 0, 6, 0, 5)), image.extract_subset((4, 8, 0, 6, 0, 5))])


def _tf():
    return hv.TransferFunction.ramp(0.0, 1.6, cmap="viridis", opacity=(0.05, 0.5))


def test_each_kind_is_classified_and_other_data_named():
    assert data_kind(_image()) == GRID and data_kind(np.zeros((2, 2, 2))) == GRID
    assert data_kind(_curvilinear()) == MESH and data_kind(_image().triangulate()) == MESH
    assert data_kind(_halves(_image())) == BLOCKS
    assert data_kind(pv.RectilinearGrid(np.arange(3.0), np.arange(3.0), np.arange(3.0))) == GRID
    with pytest.raises(TypeError) as info:
        data_kind([1, 2, 3])
    assert str(info.value) == f"pv_hdrvol renders {SUPPORTED}; got list"


def test_files_of_each_kind_read_as_one_volume_or_mesh(tmp_path):
    from vtkmodules.vtkCommonDataModel import vtkPartitionedDataSetCollection
    from vtkmodules.vtkIOParallelXML import vtkXMLPartitionedDataSetCollectionWriter

    image, curvi = _image(), _curvilinear()
    curvi.save(tmp_path / "c.vts")
    mesh = read_volume(tmp_path / "c.vts")
    assert isinstance(mesh, hv.TetMesh) and mesh.n_cells == 5 * curvi.n_cells
    _halves(image).save(tmp_path / "halves.vtm")
    gathered = read_volume(tmp_path / "halves.vtm")
    assert isinstance(gathered, hv.GridVolume) and gathered.dims == (9, 7, 6)
    np.testing.assert_array_equal(gathered.values.ravel(), image["f"])
    collection = vtkPartitionedDataSetCollection()
    for n, half in enumerate(_halves(image)):
        collection.SetPartition(n, 0, half)
    writer = vtkXMLPartitionedDataSetCollectionWriter()
    writer.SetFileName(str(tmp_path / "halves.vtpc"))
    writer.SetInputData(collection)
    assert writer.Write() == 1
    again = read_volume(tmp_path / "halves.vtpc")
    np.testing.assert_array_equal(again.values, gathered.values)
    (tmp_path / "broken.vtpc").write_text("<VTKFile nothing")
    with pytest.raises(ValueError, match=re.escape(f"cannot read '{tmp_path / 'broken.vtpc'}'")):
        read_volume(tmp_path / "broken.vtpc")


def test_blocks_that_do_not_gather_are_named_where_one_volume_is_needed():
    image = _image()
    fine = pv.ImageData(dimensions=(5, 7, 6), spacing=(0.25, 0.4, 0.6), origin=(1.0 + 8 * 0.5, -1.0, 0.5))
    fine["f"] = np.ones(fine.n_points)
    blocks = pv.MultiBlock([image, fine])
    with pytest.raises(ValueError, match=r"^the image blocks of this dataset are rendered one by one \(.+\): "
                                         r"pv_hdrvol.render\(dataset\) renders them; the viewer"):
        as_renderable(blocks)
    assert hv.render(blocks, _tf(), "iso", SIZE, **OPTS).metadata["blocks"]["kind"] == "grid blocks"


@pytest.mark.parametrize("make", [_curvilinear, lambda: _halves(_image())], ids=["curvilinear", "multiblock"])
def test_accessor_renders_as_render(make):
    data = make()
    ref = hv.render(data, _tf(), "iso", SIZE, **OPTS)
    np.testing.assert_array_equal(data.hdrvol.render(tf=_tf(), size=SIZE, **OPTS).rgba, ref.rgba)
    assert ref.peak_luminance > 0
    with pytest.raises(ValueError, match=r"^lens= is not supported for "):
        data.hdrvol.render(tf=_tf(), size=SIZE, lens=hv.Fisheye())


def test_accessor_names_blocks_in_its_repr():
    assert repr(_halves(_image()).hdrvol) == ("<hdrvol accessor of MultiBlock with 2 blocks; call .render(scalars=, "
                                              "tf=, camera=, size=, **options)>")


@pytest.mark.parametrize("name", ["c.vts", "halves.vtm"])
def test_command_line_renders_each_kind_as_the_library(tmp_path, name, capsys):
    data = _curvilinear() if name.endswith(".vts") else _halves(_image())
    data.save(tmp_path / name)
    out = tmp_path / "out.exr"
    assert main(["render", str(tmp_path / name), "-o", str(out), "--size", *map(str, SIZE), "--precision", "float64",
                 "--no-progress"]) == 0
    ref = hv.render(read_volume(tmp_path / name), None, hv.Camera.fit(data.bounds, "iso"), SIZE, **OPTS)
    np.testing.assert_array_equal(hv.load(out).rgba, ref.rgba.astype(np.float32))  # EXR keeps float32
    assert f"{name} (f, " in capsys.readouterr().out


def test_editor_model_and_progressive_renderer_take_blocks():
    from pv_hdrvol.editor.model import TransferFunctionModel
    from pv_hdrvol.viewer.progressive import ProgressiveRenderer

    image = _image()
    blocks = _halves(image)
    model = TransferFunctionModel.for_data(blocks)
    assert model.transfer_function().to_dict() == TransferFunctionModel.for_data(image).transfer_function().to_dict()
    frames = list(ProgressiveRenderer(blocks, _tf(), precision="float64").frames("iso", SIZE))
    full = ProgressiveRenderer(image, _tf(), precision="float64")
    np.testing.assert_array_equal(frames[-1].image.rgba, list(full.frames("iso", SIZE))[-1].image.rgba)


@pytest.mark.parametrize("make", [_curvilinear, lambda: pv.MultiBlock([_curvilinear()])],
                         ids=["curvilinear", "multiblock"])
def test_vtk_algorithm_renders_as_render(make):
    from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer

    data = make()
    alg = HDRVolumeRenderer()
    alg.SetInputDataObject(data)
    alg.SetImageSize(*SIZE)
    alg.SetCamera("iso")
    alg.SetOptions(hv.RenderOptions(precision="float64"))
    assert alg.Update(), alg.GetLastError()
    ref = hv.render(data, None, hv.Camera.fit(_curvilinear().bounds, "iso"), SIZE, **OPTS)
    np.testing.assert_array_equal(hv.HDRImage.from_pyvista(alg.GetOutput()).rgba, ref.rgba)
    alg.SetLens(hv.Fisheye())
    assert not alg.Update()
    assert alg.GetLastError() == ("ValueError: SetLens, SetLabels and SetCull apply to image data only, not to a "
                                  f"{data.GetClassName()}")


def test_the_data_types_page_prints_what_it_says(tmp_path, monkeypatch):
    from conftest import REPO_ROOT
    from docblocks import python_blocks, run_blocks

    page = REPO_ROOT / "docs" / "data_types.md"
    blocks, _ = python_blocks(page)
    expected = re.search(r"^prints\n\n```text\n(.*?)^```", page.read_text(), re.S | re.M).group(1)
    assert run_blocks(blocks, tmp_path, monkeypatch) == expected
