"""Reading and writing image files: the errors Python users expect, naming the path."""
import re

import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv


@pytest.fixture
def image():
    rgba = np.zeros((3, 5, 4), np.float32)
    rgba[1, 2] = (0.5, 0.25, 0.125, 0.5)
    return hv.HDRImage(rgba)


@pytest.mark.parametrize("ext", [".exr", ".npy", ".hdr"])
def test_load_missing_file_raises_file_not_found_naming_it(tmp_path, ext):
    path = tmp_path / f"missing{ext}"
    with pytest.raises(FileNotFoundError, match=re.escape(f"No such file or directory: '{path}'")):
        hv.load(path)


def test_load_a_folder_raises_is_a_directory(tmp_path):
    (tmp_path / "folder.exr").mkdir()
    with pytest.raises(IsADirectoryError, match=re.escape(f"'{tmp_path / 'folder.exr'}'")):
        hv.HDRImage.load(tmp_path / "folder.exr")


@pytest.mark.parametrize("content", [b"", b"not an exr", b"P6\n2 2\n255\n" + bytes(12)])
def test_load_a_file_that_is_not_exr(tmp_path, content):
    path = tmp_path / "fake.exr"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=re.escape(f"'{path}' is not a readable OpenEXR image: it does not start "
                                                   f"with the OpenEXR magic number")):
        hv.load(path)


def test_load_a_truncated_exr(image, tmp_path):
    image.save(tmp_path / "whole.exr")
    data = (tmp_path / "whole.exr").read_bytes()
    assert hv.load(tmp_path / "whole.exr").rgba.tolist() == image.rgba.tolist()
    for n in (8, 200, len(data) - 20):  # in the header, in the offset table, in the pixels
        path = tmp_path / f"cut{n}.exr"
        path.write_bytes(data[:n])
        with pytest.raises(ValueError, match=re.escape(f"'{path}' is not a readable OpenEXR image (truncated or "
                                                       f"corrupt): ")):
            hv.load(path)


@pytest.mark.parametrize("content", [b"", b"not a numpy file"])
def test_load_a_file_that_is_not_npy(tmp_path, content):
    path = tmp_path / "fake.npy"
    path.write_bytes(content)
    with pytest.raises(ValueError, match=re.escape(f"'{path}' is not a readable .npy image: ")):
        hv.load(path)


@pytest.mark.parametrize("ext", [".exr", ".npy", ".hdr", ".png"])
def test_save_into_a_missing_folder_names_the_folder(image, tmp_path, ext):
    path = tmp_path / "no" / "such" / f"out{ext}"
    with pytest.raises(FileNotFoundError, match=re.escape(f"cannot write '{path}': no such folder: "
                                                          f"'{tmp_path / 'no' / 'such'}'")):
        image.save(path)
    assert not (tmp_path / "no").exists()


def test_save_below_a_file_or_over_a_folder(image, tmp_path):
    (tmp_path / "plain").write_text("a file")
    with pytest.raises(NotADirectoryError, match=re.escape(f"not a folder: '{tmp_path / 'plain'}'")):
        image.save(tmp_path / "plain" / "out.exr")
    (tmp_path / "taken.exr").mkdir()
    with pytest.raises(IsADirectoryError, match=re.escape(f"cannot write an image over a folder: "
                                                          f"'{tmp_path / 'taken.exr'}'")):
        image.save(tmp_path / "taken.exr")


def test_save_unknown_extension_is_a_value_error_before_any_file_check(image, tmp_path):
    with pytest.raises(ValueError, match=re.escape("unknown image extension '.jpg'; use .exr, .hdr, .npy or .png")):
        image.save(tmp_path / "missing" / "out.jpg")


@pytest.mark.parametrize("make", [
    lambda: pv.UnstructuredGrid(),
    lambda: pv.UnstructuredGrid(np.empty(0, np.int64), np.empty(0, np.uint8), np.ones((5, 3))),  # points only
])
def test_empty_unstructured_grid_has_no_cells_on_every_path(make):
    mesh = make()
    message = re.escape(f"the mesh has no cells to render ({mesh.n_points} points, 0 cells)")
    with pytest.raises(ValueError, match=message):
        mesh.hdrvol.render(size=8)
    with pytest.raises(ValueError, match=message):
        hv.render(mesh, None, hv.Camera(), 8)
    with pytest.raises(ValueError, match=message):
        hv.tetmesh_from_dataset(mesh)


# -- other files the package reads: every parsing error names the file (issue 31, part 6) --------------------------
def test_a_truncated_pof_file_names_itself_and_the_fix(tmp_path):
    from pv_hdrvol.culling.pof import PlenopticOpacity

    values = np.zeros((9, 9, 9))
    values[2:7, 2:7, 2:7] = 1.0
    tf = hv.TransferFunction([0.0, 1.0], [[1.0, 1.0, 1.0]] * 2, [0.0, 0.5])
    whole = tmp_path / "whole.pof.npz"
    PlenopticOpacity.compute(values, [tf], block_size=4, threads=1).save(whole)
    data = whole.read_bytes()
    for n in (0, 10, len(data) // 2, len(data) - 10):  # empty, in the first header, in the data, in the directory
        path = tmp_path / f"cut{n}.pof.npz"
        path.write_bytes(data[:n])
        with pytest.raises(ValueError, match=re.escape(f"{str(path)!r} is not a readable POF file (truncated or "
                                                       f"corrupt: write it again with PlenopticOpacity.save or "
                                                       f"python -m pv_hdrvol.parallel pof): ")):
            PlenopticOpacity.load(path)
    with pytest.raises(FileNotFoundError, match=re.escape(f"{str(tmp_path / 'missing.pof.npz')!r}")):
        PlenopticOpacity.load(tmp_path / "missing.pof.npz")


@pytest.mark.parametrize("cut", [0, 1, 2])  # empty, in the first line, halfway
def test_a_truncated_editor_file_names_itself_and_the_fix(tmp_path, cut):
    from pv_hdrvol.editor.model import TransferFunctionModel

    whole = tmp_path / "whole.json"
    TransferFunctionModel(hv.TransferFunction.ramp(0.0, 1.0, cmap="gray")).save(whole)
    text = whole.read_text()
    path = tmp_path / "cut.json"
    path.write_text(text[:(0, 3, len(text) // 2)[cut]])
    with pytest.raises(ValueError, match=re.escape(f"{str(path)!r} is not valid JSON (truncated or not a transfer "
                                                   f"function file: save it again): ")):
        TransferFunctionModel.load(path)
