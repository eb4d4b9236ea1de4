"""Rendering an image volume where its pieces live (pv_hdrvol.parallel.pieces): every
sample of the whole render has exactly one owner, the pieces' images composited in
depth order are the whole render, and processes that fail say so to the others."""
import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.parallel.pieces import (check_tiling, composite_pieces, render_pieces, split_boxes,
                                       split_volume, volume_piece)
from pv_hdrvol.raycast.grid import GridPlan, VolumePiece, resolve_transfer_function
from thread_comm import run_spmd

pytestmark = pytest.mark.core

SIZE = (33, 29)


def _volume(spacing=(1.0, 0.5, 1.25)):
    z, y, x = np.mgrid[0:12, 0:18, 0:23].astype(float)
    blob = np.exp(-((x - 12) ** 2 + (y - 8) ** 2 + (z - 6) ** 2) / 40.0)
    values = blob + 0.2 * np.random.default_rng(3).random(blob.shape)
    return hv.volume_from_array(values, spacing=spacing)


def _render_in_pieces(volume, tf, camera, n, ghosts=1, **options):
    parts = split_volume(volume, n, ghosts)
    images = [GridPlan(p, tf, **options).execute(camera, SIZE, piece=pc, progress_bar=False) for p, pc in parts]
    return composite_pieces(images, [pc.world_box(volume.spacing) for _, pc in parts], camera.rays(SIZE)), images


@pytest.mark.parametrize("dims, n", [((5, 6, 7), 1), ((5, 6, 7), 2), ((5, 6, 7), 3), ((5, 6, 7), 7),
                                     ((64, 64, 93), 8), ((2, 2, 9), 8), ((256, 256, 128), 3)])
def test_split_boxes_tile_the_volume(dims, n):
    boxes = split_boxes(dims, n)
    assert len(boxes) == n
    check_tiling([VolumePiece((0.0, 0.0, 0.0), dims, (0, 0, 0), lo, hi) for lo, hi in boxes])
    assert all(h > l for lo, hi in boxes for l, h in zip(lo, hi))


def test_split_boxes_are_vtks_block_split_for_three_pieces():
    # the extent translator's pieces of engine's whole extent (as ParaView reads it with 3 ranks)
    assert split_boxes((256, 256, 128), 3) == [((0, 0, 0), (255, 85, 127)), ((0, 85, 0), (127, 255, 127)),
                                                ((127, 85, 0), (255, 255, 127))]


def test_check_tiling_names_overlaps_and_gaps():
    whole = ((0.0, 0.0, 0.0), (5, 5, 5), (0, 0, 0))
    with pytest.raises(ValueError, match=r"the owned boxes of pieces 0 and 1 overlap: \(0, 0, 0\)..\(4, 4, 2\) and "
                                         r"\(0, 0, 1\)..\(4, 4, 3\)"):
        check_tiling([VolumePiece(*whole, (0, 0, 0), (4, 4, 2)), VolumePiece(*whole, (0, 0, 1), (4, 4, 3))])
    with pytest.raises(ValueError, match="do not tile the whole volume"):
        check_tiling([VolumePiece(*whole, (0, 0, 0), (4, 4, 2))])


def test_every_sample_has_one_owner_also_for_rays_in_the_shared_planes():
    """Without empty-space skipping and early termination a ray's sample count is fixed:
    the pieces' counts add up to the whole render's exactly. The parallel camera looks
    along z with a pixel column and row in the planes where the pieces meet (x = 11,
    y = 4): those rays lie in two pieces' closed boxes, and each of their samples must
    still be taken once."""
    volume = _volume()
    tf = resolve_transfer_function(volume)
    boxes = split_boxes(volume.dims, 4)
    assert sorted({lo[0] for lo, _ in boxes}) == [0, 11] and sorted({lo[1] for lo, _ in boxes}) == [0, 8]
    cx, cy = 11.0 * volume.spacing[0], 8.0 * volume.spacing[1]
    camera = hv.Camera(position=(cx, cy, 60.0), focal_point=(cx, cy, 10.0), parallel_projection=True,
                       parallel_scale=14.5 * volume.spacing[1] * 2)
    rays = camera.rays(SIZE)
    centre = rays.origins.reshape(SIZE[1], SIZE[0], 3)[SIZE[1] // 2, SIZE[0] // 2]
    assert centre[0] == cx and centre[1] == cy  # the middle rays lie in the planes
    options = dict(precision="float64", skip_empty=False, termination=0.0)
    whole = GridPlan(volume, tf, **options).execute(camera, SIZE, progress_bar=False)
    for n in (2, 4, 8):
        image, parts = _render_in_pieces(volume, tf, camera, n, **options)
        assert sum(p.metadata["samples"] for p in parts) == whole.metadata["samples"], n
        np.testing.assert_allclose(image.rgba, whole.rgba, rtol=0, atol=1e-13)


@pytest.mark.parametrize("options, atol", [
    (dict(precision="float64"), 1e-12),
    (dict(precision="float32"), 1e-6),
    (dict(precision="float64", shade=True), 1e-12),
    (dict(precision="float32", shade=True, gradient_opacity=(0.0, 0.05)), 1e-6),
])
def test_pieces_composited_in_depth_order_are_the_whole_render(options, atol):
    volume = _volume()
    tf = resolve_transfer_function(volume)
    camera = hv.Camera.fit(volume.bounds, "iso")  # perspective: the depth order differs per pixel
    whole = GridPlan(volume, tf, **options).execute(camera, SIZE, progress_bar=False)
    assert whole.rgba[..., 3].max() > 0.3
    for n in (2, 3, 8):
        image, _ = _render_in_pieces(volume, tf, camera, n, **options)
        assert image.rgba.dtype == whole.rgba.dtype
        np.testing.assert_allclose(image.rgba, whole.rgba, rtol=0, atol=atol, err_msg=f"{n} pieces")
        hit = np.isfinite(whole.depth)
        assert np.array_equal(np.isfinite(image.depth), hit)
        # the depth where the first piece with opacity crosses the threshold alone: exact
        assert np.mean(image.depth[hit] == whole.depth[hit]) > 0.7


def test_one_piece_made_alone_is_that_piece_of_the_split():
    """A process that holds the whole volume makes only its own piece (volume_piece),
    equal to the split's, uniform and rectilinear."""
    uniform = _volume()
    axes = (np.cumsum(np.r_[0.0, np.linspace(0.5, 1.5, uniform.dims[0] - 1)]),
            np.linspace(0.0, 3.0, uniform.dims[1]), np.linspace(-1.0, 1.0, uniform.dims[2]))
    rectilinear = hv.volume_from_rectilinear(uniform.values, *axes)
    for volume in (uniform, rectilinear):
        for ghosts in (0, 1):
            whole = split_volume(volume, 3, ghosts)
            for index, (part, piece) in enumerate(whole):
                alone, alone_piece = volume_piece(volume, 3, index, ghosts)
                for field in piece._fields:
                    a, b = getattr(alone_piece, field), getattr(piece, field)
                    if isinstance(b, tuple) and b and isinstance(b[0], np.ndarray):  # a rectilinear whole's axes
                        assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b)), field
                    else:
                        assert np.array_equal(np.asarray(a, dtype=object), np.asarray(b, dtype=object)), field
                np.testing.assert_array_equal(alone.values, part.values)
                np.testing.assert_array_equal(alone.origin, part.origin)
                assert (alone.axes is None) == (part.axes is None)
                if part.axes is not None:
                    for a, b in zip(alone.axes, part.axes):
                        np.testing.assert_array_equal(a, b)


def test_opaque_geometry_stops_every_piece_where_it_stops_the_whole():
    volume = _volume()
    tf = resolve_transfer_function(volume)
    camera = hv.Camera.fit(volume.bounds, "xy")
    far = np.full((SIZE[1], SIZE[0]), np.inf)
    far[:, : SIZE[0] // 2] = np.linalg.norm(np.subtract(camera.position, camera.focal_point))  # mid-volume
    parts = split_volume(volume, 3, 0)
    images = [GridPlan(p, tf, precision="float64").execute(camera, SIZE, piece=pc, far=far, progress_bar=False)
              for p, pc in parts]
    image = composite_pieces(images, [pc.world_box(volume.spacing) for _, pc in parts], camera.rays(SIZE))
    whole = GridPlan(volume, tf, precision="float64").execute(camera, SIZE, far=far, progress_bar=False)
    np.testing.assert_allclose(image.rgba, whole.rgba, rtol=0, atol=1e-12)
    unstopped = GridPlan(volume, tf, precision="float64").execute(camera, SIZE, progress_bar=False)
    assert (unstopped.rgba[:, : SIZE[0] // 2, 3] - whole.rgba[:, : SIZE[0] // 2, 3]).max() > 0.1


def test_faint_sixteen_decade_data_in_eight_float32_pieces():
    """Rule 2: values over 16 decades on a log axis, opacities near 1e-7 per sample: the
    float32 pieces keep the whole float64 render's faint alpha to 1e-5 relative."""
    z, y, x = np.mgrid[0:24, 0:24, 0:24].astype(float)
    values = 10.0 ** (-8 + 16 * (x + y + z) / 69.0)
    volume = hv.volume_from_array(values)
    tf = hv.TransferFunction.ramp(1e-8, 1e8, scale="log", cmap="gray", opacity=(0.1, 1))
    options = dict(global_alpha=1e-7, termination=0.0)
    camera = hv.Camera.fit(volume.bounds, "iso")
    exact = GridPlan(volume, tf, precision="float64", **options).execute(camera, SIZE, progress_bar=False)
    image, _ = _render_in_pieces(volume, tf, camera, 8, ghosts=0, precision="float32", **options)
    alpha, ref = image.rgba[..., 3].astype(float), exact.rgba[..., 3]
    assert ref[ref > 0].min() < 1e-8 and ref.max() < 1e-4  # faint everywhere
    np.testing.assert_allclose(alpha[ref > 0], ref[ref > 0], rtol=1e-5)
    assert np.array_equal(alpha > 0, ref > 0)


def test_one_piece_without_mpi_is_the_plain_render_bit_for_bit():
    volume = _volume()
    tf = resolve_transfer_function(volume)
    (data, piece), = split_volume(volume, 1)
    image = render_pieces(data, piece, tf, "iso", SIZE, comm=None)
    expected = hv.render(volume, tf, "iso", SIZE, progress_bar=False)
    np.testing.assert_array_equal(image.rgba, expected.rgba)
    np.testing.assert_array_equal(image.depth, expected.depth)


def test_processes_render_their_pieces_and_root_composites():
    volume = _volume()
    tf = resolve_transfer_function(volume)
    parts = split_volume(volume, 3, ghosts=1)
    expected = hv.render(volume, tf, "iso", SIZE, progress_bar=False, shade=True)
    results, errors = run_spmd(3, lambda comm: render_pieces(*parts[comm.rank], tf, "iso", SIZE, comm=comm,
                                                             shade=True))
    assert errors == [None] * 3 and results[1] is None and results[2] is None
    np.testing.assert_allclose(results[0].rgba, expected.rgba, rtol=0, atol=1e-6)
    assert results[0].metadata["pieces"] == 3
    results, errors = run_spmd(3, lambda comm: render_pieces(*parts[comm.rank], tf, "iso", SIZE, comm=comm, root=None))
    assert errors == [None] * 3
    assert all(np.array_equal(r.rgba, results[0].rgba) for r in results)


def test_a_process_that_fails_stops_all_of_them_with_its_reason():
    """Process 1 holds no ghost layer but shades: it raises its ValueError, the others a
    RuntimeError naming it, and nobody waits for an image that will not come."""
    volume = _volume()
    tf = resolve_transfer_function(volume)
    with_ghosts, without = split_volume(volume, 3, ghosts=1), split_volume(volume, 3, ghosts=0)
    parts = [with_ghosts[0], without[1], with_ghosts[2]]
    results, errors = run_spmd(3, lambda comm: render_pieces(*parts[comm.rank], tf, "iso", SIZE, comm=comm,
                                                             shade=True))
    lo, hi = parts[1][1].owned_lo, parts[1][1].owned_hi
    message = (f"the piece's points {lo}..{hi} must cover its owned box {lo}..{hi} with 1 ghost layer(s) inside "
               f"the volume (shading and gradient opacity read them)")
    assert isinstance(errors[1], ValueError) and str(errors[1]) == message
    for rank in (0, 2):
        assert isinstance(errors[rank], RuntimeError)
        assert str(errors[rank]) == f"process 1 could not render its piece: ValueError: {message}"


def test_what_a_piece_cannot_render_is_refused_by_name():
    volume = _volume()
    tf = resolve_transfer_function(volume)
    data, piece = split_volume(volume, 2)[0]
    plan = GridPlan(data, tf, blending="maximum")
    with pytest.raises(ValueError, match=r"blending='composite' only; got 'maximum'"):
        plan.execute("iso", SIZE, piece=piece)
    with pytest.raises(TypeError, match="piece must be a VolumePiece; got tuple"):
        GridPlan(data, tf).execute("iso", SIZE, piece=tuple(piece))
    with pytest.raises(TypeError, match="render_pieces needs tf, a TransferFunction"):
        render_pieces(data, piece, None, "iso", SIZE, comm=None)
    moved = hv.volume_from_array(data.values, spacing=data.spacing, origin=data.origin + 0.5)
    with pytest.raises(ValueError, match="is not the whole volume's origin plus offset x spacing"):
        GridPlan(moved, tf).execute("iso", SIZE, piece=piece)


# -- rectilinear grids: pieces sample the whole grid's lattice through their own axes -------
def _graded():
    """A rectilinear grid graded along every axis: x geometric, y cubic, z even then
    geometric (its narrowest cell where two of three pieces meet, so one piece lacks it)."""
    x = np.cumsum(np.r_[0.0, 0.2 * 1.12 ** np.arange(22)]) - 1.0
    y = np.linspace(-1, 1, 17) ** 3 * 1.5 + np.linspace(-1, 1, 17)
    z = np.r_[np.linspace(0, 1, 8), 1 + np.geomspace(0.05, 1.5, 12)]
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    values = np.exp(-((xx - 2) ** 2 + yy ** 2 + (zz - 1) ** 2) / 2.0) + 0.3 * np.random.default_rng(3).random(xx.shape)
    return hv.volume_from_rectilinear(values, x, y, z, name="v")


def _rectilinear_in_pieces(volume, tf, camera, n, ghosts=0, **options):
    from pv_hdrvol.params import RenderOptions

    parts = split_volume(volume, n, ghosts)
    images = [GridPlan(p, tf, pc.options_for(RenderOptions(**options), p)).execute(camera, SIZE, piece=pc,
                                                                                   progress_bar=False)
              for p, pc in parts]
    return composite_pieces(images, [pc.world_box(None) for _, pc in parts], camera.rays(SIZE)), images, parts


@pytest.mark.parametrize("n, view, shade", [(2, "iso", False), (3, "iso", True), (3, "zy", False)])
def test_rectilinear_pieces_composited_are_the_whole_render(n, view, shade):
    """split_volume keeps a rectilinear grid's pieces rectilinear (it made them uniform at
    the nominal spacing before); composited they are the serial render (measured 1.2e-15)."""
    volume = _graded()
    tf = resolve_transfer_function(volume)
    camera = hv.Camera.fit(volume.bounds, view)
    whole = GridPlan(volume, tf, precision="float64", shade=shade).execute(camera, SIZE, progress_bar=False)
    assert whole.rgba[..., 3].max() > 0.5
    image, _, parts = _rectilinear_in_pieces(volume, tf, camera, n, ghosts=1 if shade else 0, precision="float64",
                                             shade=shade)
    assert all(p.axes is not None and pc.whole_axes is not None for p, pc in parts)
    np.testing.assert_allclose(image.rgba, whole.rgba, rtol=0, atol=1e-12)


def test_every_sample_of_a_rectilinear_grid_has_one_owner():
    """Without skipping and early termination, the pieces' sample counts add up to the
    serial render's exactly."""
    volume = _graded()
    tf = resolve_transfer_function(volume)
    options = dict(precision="float64", skip_empty=False, termination=0.0)
    camera = hv.Camera.fit(volume.bounds, "xy")
    whole = GridPlan(volume, tf, **options).execute(camera, SIZE, progress_bar=False)
    for n in (2, 5):
        image, images, _ = _rectilinear_in_pieces(volume, tf, camera, n, **options)
        assert sum(im.metadata["samples"] for im in images) == whole.metadata["samples"] == 52700, n
        np.testing.assert_allclose(image.rgba, whole.rgba, rtol=0, atol=1e-13)


def test_clipped_rectilinear_pieces_composite_to_the_clipped_whole():
    volume = _graded()
    tf = resolve_transfer_function(volume)
    camera = hv.Camera.fit(volume.bounds, "iso")
    options = dict(precision="float64", clip_planes=[hv.ClipPlane((1.0, 0.0, 1.2), (0.3, -0.5, 1.0))])
    whole = GridPlan(volume, tf, **options).execute(camera, SIZE, progress_bar=False)
    unclipped = GridPlan(volume, tf, precision="float64").execute(camera, SIZE, progress_bar=False)
    assert np.abs(whole.rgba - unclipped.rgba).max() > 0.3  # the plane cuts
    image, _, _ = _rectilinear_in_pieces(volume, tf, camera, 3, **options)
    np.testing.assert_allclose(image.rgba, whole.rgba, rtol=0, atol=1e-13)  # measured 1e-15


def test_render_pieces_steps_a_rectilinear_piece_by_the_whole_grids_narrowest_cell():
    """Three pieces, one without the whole grid's narrowest cell: render_pieces gives its
    plan the whole grid's step and unit (with its own it was 7e-2 off)."""
    volume = _graded()
    tf = resolve_transfer_function(volume)
    whole = hv.render(volume, tf, "iso", SIZE, precision="float64", progress_bar=False)
    parts = split_volume(volume, 3, ghosts=0)
    assert any(p.min_cell_width != volume.min_cell_width for p, _ in parts)

    def process(comm):
        data, piece = parts[comm.rank]
        return render_pieces(data, piece, tf, "iso", SIZE, comm=comm, precision="float64")

    results, errors = run_spmd(3, process)
    assert errors == [None] * 3
    np.testing.assert_allclose(results[0].rgba, whole.rgba, rtol=0, atol=1e-12)


# -- tetrahedral meshes: each process renders the span of each ray in its box --------------
def _u_mesh():
    """A U-shaped box of 6 x 4 x 3 cubes (a notch cut from the top middle): rays leave
    and re-enter it, and a piece's cells stick out of its box."""
    from meshes import box_mesh

    points, tets, values = box_mesh((6, 4, 3), field=lambda p: 0.2 + 0.1 * p[:, 0] + 0.05 * p[:, 1] * p[:, 2])
    centre = points[tets].mean(axis=1)
    keep = ~((centre[:, 0] > 2) & (centre[:, 0] < 4) & (centre[:, 1] > 1.5))
    return points, tets[keep], values


def _mesh_in_pieces(points, tets, values, boxes, tf, camera, **options):
    from pv_hdrvol.data.tets import tetmesh_from_arrays
    from pv_hdrvol.raycast.tets import MeshPiece, TetPlan

    whole = tetmesh_from_arrays(points, tets, values)
    options.setdefault("opacity_unit_distance", whole.default_unit_distance())
    lo, hi = np.asarray(whole.bounds[0::2]), np.asarray(whole.bounds[1::2])
    corners = points[tets]
    images = []
    for a, b in boxes:
        # every cell that meets the box, as vtkRedistributeDataSetFilter's AssignToAllIntersectingRegions
        meets = np.all(corners.max(axis=1) >= a, axis=1) & np.all(corners.min(axis=1) <= b, axis=1)
        piece = MeshPiece(tuple(a), tuple(b), tuple(lo), tuple(hi))
        part = tetmesh_from_arrays(points, tets[meets], values)
        images.append(TetPlan(part, tf, **options).execute(camera, SIZE, piece=piece, progress_bar=False))
    reference = TetPlan(whole, tf, **options).execute(camera, SIZE, progress_bar=False)
    return composite_pieces(images, boxes, camera.rays(SIZE)), reference, images


def test_split_bounds_cuts_at_the_quantiles_of_the_samples():
    from pv_hdrvol.parallel.pieces import split_bounds

    samples = np.random.default_rng(2).normal(size=(3000, 3)) * [4.0, 1.0, 1.0]
    bounds = (-20.0, 20.0, -5.0, 5.0, -5.0, 5.0)
    for n in (1, 2, 3, 7):
        boxes = split_bounds(bounds, n, samples)
        assert len(boxes) == n
        volume = sum(np.prod(b - a) for a, b in boxes)
        assert volume == pytest.approx(40.0 * 10 * 10, rel=1e-12)
        counts = [np.all((samples >= a) & (samples < b), axis=1).sum() for a, b in boxes]
        assert max(counts) - min(counts) <= 2, counts  # about equal work, though the cloud is centred
    assert [tuple(a) for a, _ in split_bounds(bounds, 2)] == [(-20.0, -5.0, -5.0), (0.0, -5.0, -5.0)]
    # a sample standing for three cells counts three times: the cut moves into its cluster
    x = np.concatenate([np.linspace(-15.0, -5.0, 100), np.linspace(5.0, 15.0, 100)])
    clusters = np.column_stack([x, np.zeros(200), np.zeros(200)])
    assert split_bounds(bounds, 2, clusters)[0][1][0] == 0.0  # between the clusters
    weighted = split_bounds(bounds, 2, clusters, np.repeat([3.0, 1.0], 100))[0][1][0]
    assert -9.0 < weighted < -8.0  # two thirds into the left cluster


@pytest.mark.parametrize("n", [2, 3, 8])
def test_mesh_pieces_composited_in_depth_order_are_the_whole_render(n):
    from pv_hdrvol.parallel.pieces import split_bounds

    points, tets, values = _u_mesh()
    tf = hv.TransferFunction([0.2, 0.6, 1.3], [[0.1, 0.3, 1.0], [1.0, 1.0, 0.2], [1.0, 0.1, 0.0]], [0.05, 0.4, 0.9])
    camera = hv.Camera(position=(14.0, 11.0, 9.0), focal_point=(3.0, 2.0, 1.5))  # perspective, through the notch
    centres = points[tets].mean(axis=1)
    boxes = split_bounds((0.0, 6.0, 0.0, 4.0, 0.0, 3.0), n, centres)
    image, whole, parts = _mesh_in_pieces(points, tets, values, boxes, tf, camera, precision="float64")
    assert whole.rgba[..., 3].max() > 0.5
    # each cell segment is integrated whole by the piece that owns its midpoint, as in the
    # whole render (cut at the boxes' faces instead, the colour moved by up to 1e-4 here)
    np.testing.assert_allclose(image.rgba, whole.rgba, rtol=0, atol=1e-12)
    assert np.array_equal(np.isfinite(image.depth), np.isfinite(whole.depth))


def test_a_ray_in_the_face_two_mesh_boxes_share_is_rendered_once():
    """A parallel camera along z with its middle pixel column in the plane x = 3 where two
    boxes meet: both closed boxes hold those rays; the half-open rule gives them to one."""
    points, tets, values = _u_mesh()
    tf = hv.TransferFunction([0.0, 2.0], [[1, 1, 1], [1, 1, 1]], [0.3, 0.3])
    camera = hv.Camera(position=(3.0, 2.0, 20.0), focal_point=(3.0, 2.0, 0.0), parallel_projection=True,
                       parallel_scale=2.5)
    assert camera.rays(SIZE).origins.reshape(SIZE[1], SIZE[0], 3)[:, SIZE[0] // 2, 0].tolist() == [3.0] * SIZE[1]
    boxes = [(np.array([0.0, 0.0, 0.0]), np.array([3.0, 4.0, 3.0])), (np.array([3.0, 0.0, 0.0]),
                                                                        np.array([6.0, 4.0, 3.0]))]
    image, whole, parts = _mesh_in_pieces(points, tets, values, boxes, tf, camera, precision="float64")
    middle = parts[0].rgba[:, SIZE[0] // 2, 3], parts[1].rgba[:, SIZE[0] // 2, 3]
    assert not middle[0].any() and middle[1].max() > 0.3  # the box above the face has them
    np.testing.assert_allclose(image.rgba, whole.rgba, rtol=0, atol=1e-12)
