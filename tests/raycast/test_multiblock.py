"""Composite datasets (multiblock, partitioned) rendered as one scene (issue 33, part 3).

A volume split into blocks as VTK splits extents (neighbours share their boundary
points) must render as the unsplit volume: the image blocks are gathered onto one
lattice, so bit for bit. Blocks on different lattices are rendered one by one and
composited in ray order; mesh blocks are merged into one tetrahedral mesh.
"""
import importlib
import warnings

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
from vtkmodules.vtkCommonDataModel import (vtkCompositeDataSet, vtkMultiBlockDataSet, vtkMultiPieceDataSet,
                                           vtkPartitionedDataSet, vtkPartitionedDataSetCollection)

import pv_hdrvol as hv
from pv_hdrvol.data.blocks import flatten, image_blocks, is_composite
from pv_hdrvol.data.grid import content_digest
from pv_hdrvol.parallel.pieces import split_boxes
from pv_hdrvol.raycast.blocks import render_blocks, render_image_blocks

SIZE = (32, 32)
DIMS = (17, 13, 11)


def _smooth_image(cell=False):
    """A float64 field on 17x13x11 points (spacing and origin not 1 and 0)."""
    img = pv.ImageData(dimensions=DIMS, spacing=(0.5, 0.7, 0.9), origin=(1.0, -2.0, 3.0))
    p = img.cell_centers().points if cell else img.points
    x, y, z = ((p - np.array(img.center)) / np.array([4.0, 4.2, 4.5])).T
    f = np.exp(-(x * x + y * y + z * z) * 2.0) + 0.3 * np.sin(3 * x) * np.cos(2 * y) ** 2
    (img.cell_data if cell else img.point_data)["f"] = f
    return img


def _pieces(img, n):
    """The image cut into ``n`` extent pieces sharing their boundary points (VTK's
    block split), each keeping its extent offset."""
    return [img.extract_subset((lo[0], hi[0], lo[1], hi[1], lo[2], hi[2])) for lo, hi in split_boxes(img.dimensions, n)]


def _container(pieces, kind, tmp_path=None):
    if kind == "multiblock":
        return pv.MultiBlock(pieces)
    if kind == "partitioned":
        pds = vtkPartitionedDataSet()
        for i, p in enumerate(pieces):
            pds.SetPartition(i, p)
        coll = vtkPartitionedDataSetCollection()
        coll.SetPartitionedDataSet(0, pds)
        return coll
    if kind == "nested":  # a multiblock of a multiblock and a multi-piece dataset (a vtkPartitionedDataSet)
        outer = vtkMultiBlockDataSet()
        inner = vtkMultiBlockDataSet()
        half = len(pieces) // 2
        for i, p in enumerate(pieces[:half]):
            inner.SetBlock(i, p)
        pds = vtkMultiPieceDataSet()
        for i, p in enumerate(pieces[half:]):
            pds.SetPartition(i, p)
        outer.SetBlock(0, inner)
        outer.SetBlock(1, pds)
        return outer
    if kind == "vtm":
        path = str(tmp_path / "split.vtm")
        pv.MultiBlock(pieces).save(path)
        return pv.read(path)
    raise AssertionError(kind)


def _tf():
    return hv.TransferFunction([-0.3, 1.2], [[1.0, 0.4, 0.1], [0.2, 0.5, 1.0]], [0.0, 0.7])


@pytest.mark.parametrize("n", [2, 8])
@pytest.mark.parametrize("kind", ["multiblock", "partitioned", "nested", "vtm"])
def test_a_split_volume_renders_as_the_unsplit_one(kind, n, tmp_path):
    img = _smooth_image()
    data = _container(_pieces(img, n), kind, tmp_path)
    assert is_composite(data) and len(flatten(data)[0]) == n
    cam = hv.Camera.fit(img.bounds, "iso")
    ref = hv.render(img, None, cam, SIZE, precision="float64")
    out = hv.render(data, None, cam, SIZE, precision="float64")
    assert ref.rgba[..., 3].max() > 0.3  # something to compare
    np.testing.assert_allclose(out.rgba, ref.rgba, rtol=1e-6, atol=1e-6 * ref.rgba.max())
    # gathered onto one lattice: the same volume, hence the same bits (default camera and tf too)
    assert np.array_equal(out.rgba, ref.rgba)
    assert np.array_equal(hv.render(data, size=SIZE, precision="float64").rgba,
                          hv.render(img, size=SIZE, precision="float64").rgba)
    assert out.metadata["blocks"]["kind"] == "grid"
    assert len(out.metadata["blocks"]["rendered"]) == n


def test_a_split_volume_of_cell_data_renders_as_the_unsplit_one():
    img = _smooth_image(cell=True)
    data = pv.MultiBlock(_pieces(img, 8))
    ref = hv.render(img, _tf(), "xz", SIZE, precision="float64")
    out = hv.render(data, _tf(), "xz", SIZE, precision="float64")
    assert ref.rgba[..., 3].max() > 0.3
    assert np.array_equal(out.rgba, ref.rgba)
    assert out.metadata["blocks"]["kind"] == "grid"


def test_composite_kinds_that_are_not_trees_of_blocks_are_refused():
    from vtkmodules.vtkCommonDataModel import vtkOverlappingAMR

    with pytest.raises(TypeError, match="composite datasets of class vtkOverlappingAMR are not supported"):
        hv.render(vtkOverlappingAMR(), size=SIZE)
    table = vtkMultiBlockDataSet()
    from vtkmodules.vtkCommonDataModel import vtkTable

    table.SetBlock(0, vtkTable())
    with pytest.raises(TypeError, match=r"block 'block 0' is a vtkTable: blocks must be image data, unstructured or "
                                        r"structured grids"):
        hv.render(table, size=SIZE)
    assert not is_composite(_smooth_image())


def test_block_paths_use_names_and_positions():
    img = _smooth_image()
    data = _container(_pieces(img, 4), "nested")
    mb = pv.MultiBlock({"left": _pieces(img, 2)[0], "right": _pieces(img, 2)[1]})
    assert [leaf.path for leaf in flatten(data)[0]] == ["block 0/block 0", "block 0/block 1", "block 1/piece 0",
                                                        "block 1/piece 1"]
    assert [leaf.path for leaf in flatten(mb)[0]] == ["left", "right"]
    named = vtkMultiBlockDataSet()
    named.SetBlock(0, data)
    named.GetMetaData(0).Set(vtkCompositeDataSet.NAME(), "fluid")
    assert flatten(named)[0][0].path == "fluid/block 0/block 0"


def test_a_block_without_the_array_is_skipped_with_a_warning_naming_it():
    img = _smooth_image()
    pieces = _pieces(img, 2)
    bare = pieces[1].copy()
    bare.point_data["g"] = bare.point_data.pop("f")
    data = pv.MultiBlock({"solid": pieces[0], "air": bare})
    with pytest.warns(UserWarning, match=r"1 block without scalars 'f' is not rendered: 'air'"):
        out = hv.render(data, _tf(), "iso", SIZE, scalars="f", precision="float64")
    alone = hv.render(pieces[0], _tf(), "iso", SIZE, precision="float64")  # a view frames the blocks rendered
    assert alone.rgba[..., 3].max() > 0.3
    assert np.array_equal(out.rgba, alone.rgba)
    assert out.metadata["blocks"]["missing"] == ["air"]


def test_no_block_with_the_array_is_a_scalars_error_listing_the_arrays():
    data = pv.MultiBlock(_pieces(_smooth_image(), 2))
    with pytest.raises(hv.ScalarsError, match=r"scalars 'rho' not found in any block; arrays of the blocks: "
                                              r"point: \['f'\], cell: \[\]"):
        hv.render(data, size=SIZE, scalars="rho")
    two = pv.MultiBlock(_pieces(_smooth_image(), 2))
    two[1].point_data["g"] = two[1].point_data["f"] * 2
    two[0].point_data.active_scalars_name = None
    two[1].point_data.active_scalars_name = None
    with pytest.raises(hv.ScalarsError, match="scalars must be given"):
        hv.render(two, size=SIZE)


def test_point_data_in_one_block_and_cell_data_in_another_are_refused():
    pieces = _pieces(_smooth_image(), 2)
    cells = pieces[1].point_data_to_cell_data()
    cells.point_data.clear()
    data = pv.MultiBlock({"p": pieces[0], "c": cells})
    with pytest.raises(ValueError, match=r"scalars 'f' are point data in blocks 'p' and cell data in blocks 'c': "
                                         r"render one association"):
        hv.render(data, size=SIZE)


def test_empty_and_none_blocks_are_left_out_silently_and_listed():
    img = _smooth_image()
    pieces = _pieces(img, 2)
    data = pv.MultiBlock({"a": pieces[0], "nothing": pv.ImageData(), "b": pieces[1], "none": None,
                          "no cells": pv.UnstructuredGrid()})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = hv.render(data, _tf(), "iso", SIZE, precision="float64")
    ref = hv.render(img, _tf(), "iso", SIZE, precision="float64")
    assert np.array_equal(out.rgba, ref.rgba)
    assert out.metadata["blocks"]["empty"] == ["nothing", "no cells"]
    with pytest.raises(ValueError, match=r"no block with points and cells to render \(empty blocks: 'e'\)"):
        hv.render(pv.MultiBlock({"e": pv.ImageData()}), size=SIZE)


def test_shared_points_that_differ_warn_naming_both_blocks():
    pieces = _pieces(_smooth_image(), 2)
    other = pieces[1].copy()
    other.point_data["f"] = other.point_data["f"] + 1.0
    with pytest.warns(UserWarning, match=r"blocks 'one' and 'two' share 143 points and differ at 143"):
        hv.render(pv.MultiBlock({"one": pieces[0], "two": other}), _tf(), "iso", (8, 8), precision="float64")


def _box(lo, hi, h, field):
    dims = np.round((np.array(hi, float) - np.array(lo, float)) / h).astype(int) + 1
    img = pv.ImageData(dimensions=dims, spacing=(h, h, h), origin=lo)
    img.point_data["f"] = field(img.points)
    return img


def test_blocks_of_different_spacings_composite_as_beer_lambert():
    # a constant field through two blocks of spacing 0.5 and 0.25 that share the face x = 4:
    # along x the ray crosses 8 units of extinction sigma, once (no double counting)
    const = lambda p: np.full(len(p), 0.5)  # noqa: E731
    data = pv.MultiBlock([_box((0, 0, 0), (4, 2, 2), 0.5, const), _box((4, 0, 0), (8, 2, 2), 0.25, const)])
    tf = hv.TransferFunction([0.0, 1.0], [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]], [0.05, 0.05])
    cam = hv.Camera((20.0, 1.0, 1.0), (4.0, 1.0, 1.0), (0.0, 0.0, 1.0), parallel_projection=True, parallel_scale=0.5)
    out = hv.render(data, tf, cam, (4, 4), precision="float64", termination=0)
    assert out.metadata["blocks"]["kind"] == "grid blocks"
    assert "spacings differ" in out.metadata["blocks"]["not gathered"]
    sigma = -np.log(1 - 0.05) / 0.25  # opacity 0.05 per unit distance, the finest spacing
    np.testing.assert_allclose(out.rgba[..., 3], 1 - np.exp(-sigma * 8.0), rtol=1e-12)


def test_blocks_of_different_spacings_render_as_the_unsplit_volume():
    # a linear field: trilinear interpolation is exact on either lattice, so the blocks differ
    # from the unsplit fine volume only where their samples lie (each block's own ray segment)
    field = lambda p: 0.1 * p[:, 0] + 0.15 * p[:, 1] - 0.05 * p[:, 2]  # noqa: E731
    whole = _box((0, 0, 0), (8, 6, 5), 0.25, field)
    data = pv.MultiBlock([_box((0, 0, 0), (4, 6, 5), 0.5, field), _box((4, 0, 0), (8, 6, 5), 0.25, field)])
    tf = hv.TransferFunction([0.0, 1.5], [[1.0, 0.3, 0.1], [0.1, 0.4, 1.0]], [0.0, 0.3])
    cam = hv.Camera.fit(whole.bounds, "iso")
    for step, limit in ((0.5, 2e-5), (0.1, 2e-6)):  # measured 7.4e-6 and 4.8e-7: converges with the step
        ref = hv.render(whole, tf, cam, SIZE, precision="float64", step=step)
        out = hv.render(data, tf, cam, SIZE, precision="float64", step=step)
        assert ref.rgba[..., 3].max() > 0.3
        assert out.metadata["blocks"]["kind"] == "grid blocks"
        assert np.abs(out.rgba - ref.rgba).max() < limit


def test_blocks_rendered_one_by_one_match_the_gathered_render():
    # the same split through both paths: compositing in ray order is exact, the samples differ
    img = _smooth_image()
    data = pv.MultiBlock(_pieces(img, 8))
    cam = hv.Camera.fit(img.bounds, "iso")
    gathered = hv.render(data, _tf(), cam, SIZE, precision="float64", step=0.1)
    blocks = image_blocks(flatten(data)[0], "f", False)
    fractions = []
    one_by_one = render_image_blocks(blocks, _tf(), cam, SIZE, name="f", precision="float64", step=0.1,
                                     progress=fractions.append)
    assert gathered.rgba[..., 3].max() > 0.3
    assert np.abs(one_by_one.rgba - gathered.rgba).max() < 5e-5  # measured 1.7e-5 (3.1e-4 at step 0.5)
    assert fractions == sorted(fractions) and fractions[-1] == pytest.approx(1.0)


def test_a_missing_piece_is_a_hole_of_empty_space():
    # 7 of 8 pieces on one lattice: gathered with NaN where the eighth was (its faces stay,
    # held by its neighbours). The 7 pieces composited one by one end each segment at the
    # hole's face; the gathered volume's samples are whole steps, each empty when its
    # stencil touches the hole: first order in the step at the hole's faces (measured
    # 0.040, 0.0079, 0.0024 at steps 0.5, 0.1, 0.02), as any volume with NaN renders
    img = _smooth_image()
    pieces = _pieces(img, 8)
    del pieces[5]
    data = pv.MultiBlock(pieces)
    cam = hv.Camera.fit(img.bounds, "iso")
    whole = hv.render(img, _tf(), cam, SIZE, precision="float64", step=0.1)
    blocks = image_blocks(flatten(data)[0], "f", False)
    errors = []
    for step in (0.5, 0.1):
        gathered = hv.render(data, _tf(), cam, SIZE, precision="float64", step=step)
        one_by_one = render_image_blocks(blocks, _tf(), cam, SIZE, name="f", precision="float64", step=step)
        errors.append(np.abs(one_by_one.rgba - gathered.rgba).max())
    assert gathered.metadata["blocks"]["kind"] == "grid"
    assert np.abs(gathered.rgba - whole.rgba).max() > 0.05  # the hole shows
    assert errors[0] < 0.06 and errors[1] < 0.012 and errors[1] < errors[0] / 3


def test_integer_blocks_with_a_hole_stay_integer_data():
    from pv_hdrvol.data.blocks import prepare_blocks

    img = pv.ImageData(dimensions=(9, 9, 9))
    img.point_data["ct"] = (np.arange(img.n_points) % 200).astype(np.uint8)
    pieces = _pieces(img, 8)
    scene = prepare_blocks(pv.MultiBlock(pieces[:7]))
    assert scene.volume.values.dtype == np.float32 and scene.volume.integer and scene.volume.has_nan
    assert np.isnan(scene.volume.values[-2, -2, -2])  # in the eighth piece, off its faces
    full = prepare_blocks(pv.MultiBlock(pieces))
    assert full.volume.values.dtype == np.uint8 and np.array_equal(full.volume.values,
                                                                    img.point_data["ct"].reshape(9, 9, 9))


def test_sparse_blocks_are_rendered_one_by_one_and_overlaps_refused(capsys):
    field = lambda p: np.exp(-((p - 2) ** 2).sum(axis=1))  # noqa: E731
    far_apart = pv.MultiBlock([_box((0, 0, 0), (2, 2, 2), 0.5, field), _box((10, 10, 10), (12, 12, 12), 0.5, field)])
    fractions = []
    out = hv.render(far_apart, _tf(), "iso", (16, 16), precision="float64", progress_bar=True,
                    progress=fractions.append)
    assert out.rgba[..., 3].max() > 0.1
    assert "Rendering" in capsys.readouterr().err  # one bar for the blocks together
    assert fractions == sorted(fractions) and fractions[-1] == pytest.approx(1.0) and fractions[0] < 0.5
    assert out.metadata["blocks"]["kind"] == "grid blocks"
    assert "over 4 times" in out.metadata["blocks"]["not gathered"]
    overlapping = pv.MultiBlock({"p": _box((0, 0, 0), (4, 2, 2), 0.5, field), "q": _box((3, 0, 0), (6, 2, 2), 0.25,
                                                                                           field)})
    with pytest.raises(ValueError, match="the boxes of image blocks 'p' and 'q' overlap"):
        hv.render(overlapping, _tf(), "iso", (8, 8))
    with pytest.raises(ValueError, match=r"shade=True needs one volume; these grid blocks are rendered one by one"):
        hv.render(far_apart, _tf(), "iso", (8, 8), shade=True)


def _tet_grid(n=(7, 6, 5)):
    img = pv.ImageData(dimensions=n)
    p = img.points
    img.point_data["f"] = np.exp(-((p - 3.0) ** 2).sum(axis=1) / 6.0)
    img.cell_data["c"] = np.linspace(0.0, 1.0, img.n_cells)
    return img.cast_to_unstructured_grid().triangulate()


@pytest.mark.parametrize("scalars, file", [("f", False), ("c", False), ("f", True)])
def test_two_mesh_blocks_sharing_a_face_render_as_the_single_mesh(scalars, file, tmp_path):
    ug = _tet_grid()
    x = ug.cell_centers().points[:, 0]
    left, right = ug.extract_cells(np.flatnonzero(x < 3)), ug.extract_cells(np.flatnonzero(x >= 3))
    assert left.n_points + right.n_points > ug.n_points  # the shared face's points are in both
    data = pv.MultiBlock({"left": left, "right": right})
    if file:
        data.save(str(tmp_path / "mesh.vtm"))
        data = pv.read(str(tmp_path / "mesh.vtm"))
    cam = hv.Camera.fit(ug.bounds, "iso")
    ref = hv.render(ug, None, cam, SIZE, scalars=scalars, precision="float64")
    out = hv.render(data, None, cam, SIZE, scalars=scalars, precision="float64")
    assert ref.rgba[..., 3].max() > 0.2
    np.testing.assert_allclose(out.rgba, ref.rgba, rtol=0, atol=1e-12)
    assert out.metadata["blocks"] == {"kind": "mesh", "rendered": ["left", "right"]}


def test_curvilinear_blocks_render_as_the_single_grid():
    img = pv.ImageData(dimensions=(7, 6, 5), spacing=(1.0, 0.8, 0.6))
    sg = img.cast_to_structured_grid()
    p = sg.points.copy()
    p[:, 2] += 0.2 * np.sin(p[:, 0])  # curvilinear: not a box
    sg.points = p
    sg.point_data["f"] = np.exp(-((p - np.array(sg.center)) ** 2).sum(axis=1) / 4.0)
    pieces = [sg.extract_subset((0, 3, 0, 5, 0, 4)), sg.extract_subset((3, 6, 0, 5, 0, 4))]
    cam = hv.Camera.fit(sg.bounds, "iso")
    ref = hv.render(sg, None, cam, SIZE, precision="float64")
    out = hv.render(pv.MultiBlock(pieces), None, cam, SIZE, precision="float64")
    assert ref.rgba[..., 3].max() > 0.2
    np.testing.assert_allclose(out.rgba, ref.rgba, rtol=0, atol=1e-12)


def _mixed_scene():
    """A linear field on [0, 6] x [0, 5] x [0, 4]: the slab 2 <= x <= 4 as an image block,
    the rest as two tetrahedral blocks; and the whole as one tetrahedral mesh."""
    img = pv.ImageData(dimensions=(13, 11, 9), spacing=(0.5, 0.5, 0.5))
    img.point_data["f"] = 0.1 + 0.12 * img.points[:, 0] + 0.05 * img.points[:, 1] + 0.08 * img.points[:, 2]
    ug = img.cast_to_unstructured_grid().triangulate()
    x = ug.cell_centers().points[:, 0]
    scene = pv.MultiBlock({"left": ug.extract_cells(np.flatnonzero(x < 2)), "grid": img.extract_subset((4, 8, 0, 10, 0, 8)),
                           "right": ug.extract_cells(np.flatnonzero(x > 4))})
    return scene, ug


@pytest.mark.parametrize("camera", ["along x", "iso"])
def test_image_and_mesh_blocks_render_as_one_scene(camera):
    """Along x each ray crosses mesh, grid, mesh: the mesh is rendered once per gap
    between the grids' boxes, cut there exactly; a linear field is exact under both
    interpolations, so the scene equals the whole mesh to the grid's sampling error."""
    scene, ug = _mixed_scene()
    tf = hv.TransferFunction([0.0, 1.2], [[1.0, 0.3, 0.1], [0.1, 0.4, 1.0]], [0.0, 0.5])
    cam = hv.Camera((-8, 2.5, 2.0), (6, 2.5, 2.0), (0, 0, 1)) if camera == "along x" else "iso"
    out = hv.render(scene, tf, cam, SIZE, precision="float64", step=0.02, termination=0)
    ref = hv.render(ug, tf, cam, SIZE, precision="float64", termination=0, opacity_unit_distance=0.5)
    assert out.metadata["blocks"] == {"kind": "mixed", "rendered": ["left", "grid", "right"]}
    assert out.metadata["mesh_passes"] == 2
    assert ref.rgba[..., 3].max() > 0.9
    assert np.abs(out.rgba - ref.rgba).max() < 3e-6  # measured 1.5e-7 along x, 1.2e-6 iso


def test_a_mesh_inside_a_grid_blocks_box_is_refused_naming_it():
    img = _smooth_image()
    inner = _tet_grid()  # points 0..6 x 0..5 x 0..4, inside the image's box
    inner.points[:] = inner.points * 0.5 + np.array(img.center) - 1.5
    with pytest.raises(ValueError, match=r"tetrahedra of the mesh blocks lie inside the box of grid block 'grid'"):
        hv.render(pv.MultiBlock({"grid": img, "mesh": inner}), size=SIZE, scalars="f")


def test_options_of_image_volumes_only_are_refused():
    data = pv.MultiBlock(_pieces(_smooth_image(), 2))
    with pytest.raises(ValueError, match="lens= is not supported for multiblock datasets"):
        hv.render(data, size=SIZE, lens=hv.Magnifier((16, 16), radius=8, transition=2, factor=2.0))
    with pytest.raises(ValueError, match="block_mask= is not supported for multiblock datasets"):
        hv.render(data, size=SIZE, block_mask=np.ones((1, 1, 1), bool))


def test_a_single_block_is_rendered_from_its_own_array():
    from pv_hdrvol.data.blocks import prepare_blocks

    img = _smooth_image()
    scene = prepare_blocks(pv.MultiBlock({"only": img}))
    assert np.shares_memory(scene.volume.values, img.point_data["f"])
    assert np.array_equal(hv.render(pv.MultiBlock({"only": img}), _tf(), "iso", SIZE, precision="float64").rgba,
                          hv.render(img, _tf(), "iso", SIZE, precision="float64").rgba)


def test_the_callers_data_is_not_modified():
    img = _smooth_image()
    pieces = _pieces(img, 8)
    pieces[3].point_data["f"][:5] = np.nan
    pieces[3].point_data["f"][5] = np.inf
    data = pv.MultiBlock(pieces + [_box((20, 20, 20), (21, 21, 21), 0.5, lambda p: p[:, 0])])  # far: one by one
    before = [content_digest(p.point_data["f"]) for p in data]
    hv.render(data, None, "iso", (8, 8), precision="float64")
    assert [content_digest(p.point_data["f"]) for p in data] == before
    assert np.isposinf(pieces[3].point_data["f"][5])


def test_a_repeated_render_reuses_the_gathered_volume_until_a_block_changes():
    img = _smooth_image()
    data = pv.MultiBlock(_pieces(img, 2))
    a = render_blocks(data, _tf(), "iso", (8, 8), precision="float64")
    b = render_blocks(data, _tf(), "iso", (8, 8), precision="float64")
    assert np.array_equal(a.rgba, b.rgba)
    data[1].point_data["f"][:] = 0.0  # in place, no Modified(): seen through the content digest
    with pytest.warns(UserWarning, match="share 143 points and differ at 143"):
        c = render_blocks(data, _tf(), "iso", (8, 8), precision="float64")
    assert not np.array_equal(a.rgba, c.rgba)


def _rectilinear(x, y, z, field):
    grid = pv.RectilinearGrid(np.asarray(x, float), np.asarray(y, float), np.asarray(z, float))
    grid.point_data["f"] = field(grid.points)
    return grid


def _rect_piece(grid, i, j, k):
    """The points i[0]..i[1], j[0]..j[1], k[0]..k[1] of a rectilinear grid (inclusive)."""
    x, y, z = (np.asarray(c) for c in (grid.x, grid.y, grid.z))
    piece = pv.RectilinearGrid(x[i[0]:i[1] + 1], y[j[0]:j[1] + 1], z[k[0]:k[1] + 1])
    values = grid.point_data["f"].reshape(len(z), len(y), len(x))
    piece.point_data["f"] = values[k[0]:k[1] + 1, j[0]:j[1] + 1, i[0]:i[1] + 1].ravel()
    return piece


_GAUSS = lambda p: np.exp(-((p - np.array([2.5, 1.5, 1.5])) ** 2).sum(axis=1) / 2.0)  # noqa: E731
_X = [0.0, 0.5, 1.2, 2.0, 2.5, 3.1, 4.0, 4.4, 5.0]


# Rectilinear grids (issue 33, part 1) are rendered where pv_hdrvol.data.grid has them;
# before, a rectilinear block is refused by its path (both branches assert)
_HAS_RECTILINEAR = hasattr(importlib.import_module("pv_hdrvol.data.grid"), "volume_from_rectilinear")


def _refused(data):
    with pytest.raises(ValueError, match=r"block 'Block-00': rectilinear blocks need rectilinear grid support"):
        hv.render(data, _tf(), "iso", SIZE, precision="float64")


def test_a_split_rectilinear_grid_renders_as_the_whole():
    whole = _rectilinear(_X, np.linspace(0, 3, 7), [0.0, 0.4, 1.0, 1.9, 2.5, 3.0], _GAUSS)
    data = pv.MultiBlock([_rect_piece(whole, (0, 4), (0, 6), (0, 5)), _rect_piece(whole, (4, 8), (0, 3), (0, 5)),
                          _rect_piece(whole, (4, 8), (3, 6), (0, 5))])
    if not _HAS_RECTILINEAR:
        return _refused(data)
    ref = hv.render(whole, _tf(), "iso", SIZE, precision="float64")
    out = hv.render(data, _tf(), "iso", SIZE, precision="float64")
    assert ref.rgba[..., 3].max() > 0.3
    assert np.array_equal(out.rgba, ref.rgba)
    assert out.metadata["blocks"]["kind"] == "grid"


def test_a_rectilinear_block_beside_an_image_block_gathers_into_one_grid():
    z = np.arange(6) * 0.5
    left = _rectilinear(_X, np.linspace(0, 3, 7), z, _GAUSS)
    right = pv.ImageData(dimensions=(5, 7, 6), spacing=(0.5, 0.5, 0.5), origin=(5.0, 0.0, 0.0))
    right.point_data["f"] = _GAUSS(right.points)
    whole = _rectilinear(np.concatenate([_X, 5.0 + 0.5 * np.arange(1, 5)]), np.linspace(0, 3, 7), z, _GAUSS)
    if not _HAS_RECTILINEAR:
        return _refused(pv.MultiBlock([left, right]))
    ref = hv.render(whole, _tf(), "iso", SIZE, precision="float64")
    out = hv.render(pv.MultiBlock([left, right]), _tf(), "iso", SIZE, precision="float64")
    assert ref.rgba[..., 3].max() > 0.3
    assert np.array_equal(out.rgba, ref.rgba)
    assert out.metadata["blocks"]["kind"] == "grid"


def test_rectilinear_blocks_whose_points_interleave_render_one_by_one():
    # a constant field along x through two blocks with different y points: Beer-Lambert
    const = lambda p: np.full(len(p), 0.5)  # noqa: E731
    a = _rectilinear([0.0, 1.0, 2.0], [0.0, 1.0], [0.0, 1.0], const)
    b = _rectilinear([2.0, 2.5, 3.5, 4.0], [0.0, 0.3, 1.0], [0.0, 0.6, 1.0], const)
    tf = hv.TransferFunction([0.0, 1.0], [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]], [0.05, 0.05])
    cam = hv.Camera((20.0, 0.5, 0.5), (2.0, 0.5, 0.5), (0.0, 0.0, 1.0), parallel_projection=True,
                    parallel_scale=0.25)
    if not _HAS_RECTILINEAR:
        return _refused(pv.MultiBlock([a, b]))
    out = hv.render(pv.MultiBlock([a, b]), tf, cam, (4, 4), precision="float64", termination=0)
    assert out.metadata["blocks"]["kind"] == "grid blocks"
    assert "not a contiguous run" in out.metadata["blocks"]["not gathered"]
    sigma = -np.log(1 - 0.05) / 0.3  # the narrowest cell of all blocks is the opacity unit
    np.testing.assert_allclose(out.rgba[..., 3], 1 - np.exp(-sigma * 4.0), rtol=1e-12)
