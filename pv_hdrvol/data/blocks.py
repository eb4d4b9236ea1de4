"""Composite datasets (multiblock, partitioned) -> the flat arrays of one scene.

What ParaView's readers of simulation codes give (PLOT3D, Exodus, CGNS, ``.vtm`` and
multi-piece files) is a tree of datasets: ``vtkMultiBlockDataSet``
(``pyvista.MultiBlock``), ``vtkPartitionedDataSetCollection`` and
``vtkPartitionedDataSet``, nested in any order. This module

- flattens the tree into its leaves, each with a readable path (``"Block-00/piece 2"``:
  a block's ``NAME`` metadata where it has one, else ``"block i"``/``"piece i"``),
  dropping ``None`` and empty leaves (no points or no cells: readers give them for
  pieces and element blocks that are empty on this time step or rank; they hold
  nothing to render, so they are listed, not warned about);
- chooses the scalars over all leaves (:func:`choose_block_scalars`, the rules of
  :func:`~pv_hdrvol.data.grid.choose_scalars`), skipping leaves without them with a
  warning that names them;
- gathers image leaves on one lattice into one :class:`~pv_hdrvol.GridVolume` over
  their union box (:func:`gather_images`; NaN, i.e. empty space, where no leaf has
  points), and merges mesh leaves (unstructured and curvilinear) into one
  :class:`~pv_hdrvol.TetMesh` (:func:`merge_meshes`), whose exact duplicate points
  are merged so that faces shared by two leaves are interior and nothing is counted
  twice.

Pure data: what renders them is :mod:`pv_hdrvol.raycast.blocks`.
"""
from __future__ import annotations

import dataclasses
import warnings
from typing import NamedTuple

import numpy as np

from .grid import (DatasetCache, ScalarsError, _arrays, image_array, _kernel_dtype, choose_scalars, content_digest,
                   volume_from_array)

#: VTK classes of uniform image leaves (gathered onto one lattice)
IMAGE_CLASSES = ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid")
#: VTK classes of leaves the tetrahedral ray caster renders
MESH_CLASSES = ("vtkUnstructuredGrid", "vtkStructuredGrid")
#: leaves with no volume: skipped with a warning
SURFACE_CLASSES = ("vtkPolyData",)
#: relative difference of spacings that still counts as one lattice
SPACING_RTOL = 1e-9
#: distance (in spacings) from the first leaf's lattice that still counts as on it
LATTICE_ATOL = 1e-6
#: the union box may hold at most this many times the leaves' points before the leaves
#: are rendered one by one instead of gathered (the NaN filling costs memory and time)
MAX_UNION_RATIO = 4.0


class Leaf(NamedTuple):
    """One dataset of a composite dataset and its path in the tree."""

    path: str
    dataset: object

    @property
    def class_name(self):
        return self.dataset.GetClassName()


def is_composite(data):
    """True for a composite VTK dataset: ``pyvista.MultiBlock``, ``vtkMultiBlockDataSet``,
    ``vtkPartitionedDataSet(Collection)``, ``vtkMultiPieceDataSet`` and the like."""
    return hasattr(data, "IsA") and hasattr(data, "GetClassName") and bool(data.IsA("vtkCompositeDataSet"))


def flatten(data):
    """``(leaves, empty)``: the non-empty leaves of a composite dataset as :class:`Leaf`
    (depth first, in block order) and the paths of the empty ones (no points or no
    cells). ``None`` blocks are left out of both.

    Raises
    ------
    TypeError
        ``data`` is not a composite dataset, or holds one of a kind that is not a tree
        of blocks (AMR datasets).
    """
    if not is_composite(data):
        raise TypeError(f"expected a composite dataset (pyvista.MultiBlock, vtkMultiBlockDataSet, "
                        f"vtkPartitionedDataSet(Collection)); got {type(data).__name__}")
    leaves, empty = [], []
    _walk(data, "", leaves, empty)
    return leaves, empty


def _children(node):
    """``(label, child)`` of each child of a composite node: its NAME metadata if set,
    else ``"block i"`` (multiblock, collection) or ``"piece i"`` (partitioned)."""
    from vtkmodules.vtkCommonDataModel import vtkCompositeDataSet

    if node.IsA("vtkUniformGridAMR"):  # a vtkPartitionedDataSetCollection from VTK 9.5 on
        raise TypeError(f"composite datasets of class {node.GetClassName()} are not supported: the levels of an AMR "
                        f"dataset overlap (refined boxes cover coarse ones), and pv_hdrvol renders blocks that tile "
                        f"a domain (multiblock and partitioned datasets)")
    if node.IsA("vtkPartitionedDataSetCollection"):
        count, get, word = node.GetNumberOfPartitionedDataSets(), node.GetPartitionedDataSet, "block"
    elif node.IsA("vtkPartitionedDataSet"):  # vtkMultiPieceDataSet too
        count, get, word = node.GetNumberOfPartitions(), node.GetPartitionAsDataObject, "piece"
    elif node.IsA("vtkMultiBlockDataSet"):
        count, get, word = node.GetNumberOfBlocks(), node.GetBlock, "block"
    else:
        raise TypeError(f"composite datasets of class {node.GetClassName()} are not supported; pv_hdrvol renders "
                        f"multiblock and partitioned datasets (vtkMultiBlockDataSet, vtkPartitionedDataSet, "
                        f"vtkPartitionedDataSetCollection)")
    out = []
    for i in range(count):
        name = None
        if node.HasMetaData(i):
            info = node.GetMetaData(i)
            if info.Has(vtkCompositeDataSet.NAME()):
                name = info.Get(vtkCompositeDataSet.NAME())
        out.append((name or f"{word} {i}", get(i)))
    return out


def _walk(node, prefix, leaves, empty):
    for label, child in _children(node):
        path = f"{prefix}/{label}" if prefix else label
        if child is None:
            continue
        if is_composite(child):
            _walk(child, path, leaves, empty)
        elif child.IsA("vtkDataSet") and (child.GetNumberOfPoints() == 0 or child.GetNumberOfCells() == 0):
            empty.append(path)
        else:
            leaves.append(Leaf(path, child))


def _names(ds):
    return list(_arrays(ds.GetPointData())), list(_arrays(ds.GetCellData()))


def choose_block_scalars(leaves, scalars=None, preference="point"):
    """``(name, use_cell, kept, missing)``: the array to render over all ``leaves``, its
    association, the leaves that have it and the paths of those that do not.

    ``scalars`` if given, else the active scalars of the leaves (one name among all
    leaves that set any), else the only array name of all leaves. The association is
    that of :func:`~pv_hdrvol.data.grid.choose_scalars` (cell data when the name is
    only a cell array or ``preference == "cell"``), and must be the same in every
    leaf. Leaves without the array are *not* warned about here
    (:func:`warn_missing`).

    Raises
    ------
    ScalarsError
        No leaf has the array (the message lists the arrays there are), or it must be
        given (several arrays, no common active one).
    ValueError
        The array is point data in some leaves and cell data in others.
    """
    names = [_names(leaf.dataset) for leaf in leaves]
    if scalars is None:
        active = []
        for leaf in leaves:
            a = leaf.dataset.GetPointData().GetScalars() or leaf.dataset.GetCellData().GetScalars()
            if a is not None and a.GetName() and a.GetName() not in active:
                active.append(a.GetName())
        every = sorted({n for p, c in names for n in p + c})
        if len(active) == 1:
            scalars = active[0]
        elif not active and len(every) == 1:
            scalars = every[0]
        else:
            why = f"the blocks' active scalars differ ({active})" if active else \
                f"the blocks have {'no arrays' if not every else 'several arrays'} and no active scalars"
            raise ScalarsError(f"scalars must be given: {why}; arrays of the blocks: {_listing(names)}")
    if not isinstance(scalars, str):
        raise TypeError(f"scalars must be an array name (str); got {scalars!r}")
    kept, missing, cell_paths, point_paths = [], [], [], []
    for leaf, (p, c) in zip(leaves, names):
        if scalars not in p and scalars not in c:
            missing.append(leaf.path)
            continue
        _, use_cell = choose_scalars(leaf.dataset, scalars, preference, "block")
        (cell_paths if use_cell else point_paths).append(leaf.path)
        kept.append(leaf)
    if not kept:
        raise ScalarsError(f"scalars {scalars!r} not found in any block; arrays of the blocks: {_listing(names)}")
    if cell_paths and point_paths:
        raise ValueError(f"scalars {scalars!r} are point data in blocks {_paths(point_paths)} and cell data in "
                         f"blocks {_paths(cell_paths)}: render one association (preference='cell' where every block "
                         f"has cell data {scalars!r}, or convert with point_data_to_cell_data / "
                         f"cell_data_to_point_data)")
    return scalars, bool(cell_paths), kept, missing


def _listing(names):
    points = sorted({n for p, _ in names for n in p})
    cells = sorted({n for _, c in names for n in c})
    return f"point: {points}, cell: {cells}"


def _paths(paths, most=8):
    """Block paths for a message: quoted, at most ``most`` and a count of the rest."""
    shown = ", ".join(repr(p) for p in paths[:most])
    return shown + (f" and {len(paths) - most} more" if len(paths) > most else "")


def warn_missing(missing, scalars, stacklevel=3):
    """Warn that the blocks ``missing`` (paths) lack ``scalars`` and are not rendered."""
    if missing:
        warnings.warn(f"{len(missing)} block{'s' if len(missing) > 1 else ''} without scalars {scalars!r} "
                      f"{'are' if len(missing) > 1 else 'is'} not rendered: {_paths(missing)}", stacklevel=stacklevel)


def classify(leaves):
    """``{"image": [...], "rectilinear": [...], "mesh": [...], "surface": [...]}``: the
    leaves by the ray caster that renders them (surfaces: none).

    Raises
    ------
    TypeError
        A leaf of another class (a table, a hyper-tree grid...), naming it.
    """
    out = {"image": [], "rectilinear": [], "mesh": [], "surface": []}
    for leaf in leaves:
        name = leaf.class_name
        if name in IMAGE_CLASSES:
            out["image"].append(leaf)
        elif name == "vtkRectilinearGrid":
            out["rectilinear"].append(leaf)
        elif name in MESH_CLASSES:
            out["mesh"].append(leaf)
        elif name in SURFACE_CLASSES:
            out["surface"].append(leaf)
        else:
            raise TypeError(f"block {leaf.path!r} is a {name}: blocks must be image data, unstructured or structured "
                            f"grids (vtkImageData, vtkUnstructuredGrid, vtkStructuredGrid)")
    return out


class ImageBlock(NamedTuple):
    """One grid leaf's array: ``values`` (z, y, x) view, first point ``origin`` and
    ``spacing`` (x, y, z); a rectilinear leaf's point coordinates ``axes`` (x, y, z),
    ``None`` for image data."""

    path: str
    values: np.ndarray
    origin: np.ndarray
    spacing: np.ndarray
    axes: tuple = None

    def coordinates(self):
        """The point coordinates along x, y and z."""
        if self.axes is not None:
            return self.axes
        return tuple(self.origin[a] + np.arange(n) * self.spacing[a] for a, n in enumerate(self.values.shape[::-1]))

    def volume(self, name=""):
        """The block as a :class:`~pv_hdrvol.GridVolume` (its own array where no
        conversion is needed)."""
        if self.axes is None:
            return volume_from_array(self.values, self.spacing, self.origin, name=name)
        return _rectilinear()[0](self.values, *self.axes, name=name)


def _rectilinear():
    """``(volume_from_rectilinear, _rectilinear_array)`` of :mod:`pv_hdrvol.data.grid`,
    or a ``ValueError`` where this version has no rectilinear grids."""
    try:
        from .grid import _rectilinear_array, volume_from_rectilinear
    except ImportError:
        raise ValueError("rectilinear blocks need rectilinear grid support (pv_hdrvol.data.grid."
                         "volume_from_rectilinear), which this version lacks: resample them onto image data "
                         "(pyvista.ImageData(...).sample(block))") from None
    return volume_from_rectilinear, _rectilinear_array


def image_blocks(leaves, scalars, use_cell):
    """:class:`ImageBlock` of each image or rectilinear leaf (cell data at the cell
    centres); an error of one leaf names it."""
    preference = "cell" if use_cell else "point"
    out = []
    for leaf in leaves:
        try:
            if leaf.class_name == "vtkRectilinearGrid":
                values, axes, _ = _rectilinear()[1](leaf.dataset, scalars, preference)
                out.append(ImageBlock(leaf.path, values, np.array([a[0] for a in axes]),
                                      np.array([(a[-1] - a[0]) / (a.size - 1) for a in axes]), tuple(axes)))
                continue
            values, spacing, origin, _ = image_array(leaf.dataset, scalars, preference)
        except (TypeError, ValueError) as e:
            raise type(e)(f"block {leaf.path!r}: {e}") from e
        out.append(ImageBlock(leaf.path, values, origin, spacing))
    return out


def lattice_offsets(blocks):
    """``(offsets, reason)``: each block's first point as integer indices (x, y, z) on
    the first block's lattice, or ``(None, why not)`` when the blocks are not on one
    lattice (spacings differ by more than :data:`SPACING_RTOL` relative, or a first
    point lies more than :data:`LATTICE_ATOL` spacings off it)."""
    spacing, origin = blocks[0].spacing, blocks[0].origin
    offsets = np.zeros((len(blocks), 3), dtype=np.int64)
    for i, b in enumerate(blocks[1:], 1):
        if np.any(np.abs(b.spacing - spacing) > SPACING_RTOL * spacing):
            return None, (f"spacings differ: {tuple(spacing.tolist())} in {blocks[0].path!r}, "
                          f"{tuple(b.spacing.tolist())} in {b.path!r}")
        k = (b.origin - origin) / spacing
        offsets[i] = np.round(k)
        if np.any(np.abs(k - offsets[i]) > LATTICE_ATOL):
            return None, (f"the first point of {b.path!r}, {tuple(b.origin.tolist())}, is off the lattice of "
                          f"{blocks[0].path!r} (origin {tuple(origin.tolist())}, spacing {tuple(spacing.tolist())})")
    return offsets, None


def gather_images(blocks, name=""):
    """``(volume, reason)``: the grid blocks as one :class:`~pv_hdrvol.GridVolume` over
    their union box, or ``(None, why not)``.

    Image blocks must be on one lattice (:func:`lattice_offsets`); with rectilinear
    blocks, every block's coordinates must be a contiguous run of the union's
    (:func:`union_axes`). The union box may hold at most :data:`MAX_UNION_RATIO` times
    the blocks' points. Points no block has are
    NaN (empty space for the kernels: a sample whose stencil touches one contributes
    nothing, so a gap's faces are placed to within a step, first order in the step,
    where blocks rendered one by one end their segments exactly). Points shared by
    several blocks (the faces of a split volume, ghost layers) take the later block's
    value; where the values differ a warning names the two blocks. Blocks that tile a
    volume give its values, origin and spacing exactly, hence its render bit for bit.
    """
    if len(blocks) == 1:  # no copy: the block's own array, as a single dataset renders
        return blocks[0].volume(name), None
    if any(b.axes is not None for b in blocks):
        axes, offsets, reason = union_axes(blocks)
    else:
        offsets, reason = lattice_offsets(blocks)
    if offsets is None:
        return None, reason
    filled = _fill(blocks, offsets)
    if isinstance(filled, str):
        return None, filled
    values, integer = filled
    if any(b.axes is not None for b in blocks):
        volume = _rectilinear()[0](values, *axes, name=name)
    else:
        # the union's first point: a block's own first point where it starts the union (exact)
        origin = np.array([blocks[int(np.argmin(offsets[:, a]))].origin[a] for a in range(3)])
        volume = volume_from_array(values, blocks[0].spacing, origin, name=name)
    if integer and not volume.integer:
        volume = dataclasses.replace(volume, integer=True)  # integer data with NaN holes: still CT-like
    return volume, None


def union_axes(blocks):
    """``(axes, offsets, reason)``: the union of the blocks' point coordinates on each
    axis (coordinates closer than :data:`LATTICE_ATOL` of the narrowest cell merged)
    and each block's first point as indices into them, or ``(None, None, why not)``
    when a block's coordinates are not a contiguous run of the union's (its points
    interleave another block's)."""
    coords = [b.coordinates() for b in blocks]
    axes = []
    offsets = np.zeros((len(blocks), 3), dtype=np.int64)
    for a in range(3):
        tol = LATTICE_ATOL * min(float(np.diff(c[a]).min()) for c in coords)
        u = np.unique(np.concatenate([c[a] for c in coords]))
        u = u[np.concatenate([[True], np.diff(u) > tol])]
        for i, c in enumerate(coords):
            k = int(np.searchsorted(u, c[a][0] - tol))
            run = u[k:k + c[a].size]
            if run.size != c[a].size or np.abs(run - c[a]).max() > tol:
                return None, None, (f"the {'xyz'[a]} coordinates of {blocks[i].path!r} are not a contiguous run of "
                                    f"the blocks' union (its points interleave another block's)")
            offsets[i, a] = k
        axes.append(u)
    return tuple(axes), offsets, None


def _fill(blocks, offsets):
    """``(values, integer)``: the blocks' values placed at ``offsets`` (x, y, z
    indices) in one array over their union, NaN where none is; or the reason not to
    (the union too large)."""
    shapes = np.array([b.values.shape[::-1] for b in blocks], dtype=np.int64)  # (x, y, z)
    lo = offsets.min(axis=0)
    dims = (offsets + shapes).max(axis=0) - lo
    union = int(np.prod(dims))
    held = int(shapes.prod(axis=1).sum())
    if union > MAX_UNION_RATIO * held:
        return (f"the blocks' union box holds {union} points, over {MAX_UNION_RATIO:g} times the "
                f"{held} points of the blocks")
    # 1 + the index of the block that wrote a point (one byte a point below 255 blocks)
    written = np.zeros(dims[::-1], dtype=np.min_scalar_type(len(blocks)))
    spans = []
    for off, shape in zip(offsets - lo, shapes):
        s = tuple(slice(int(o), int(o + n)) for o, n in zip(off[::-1], shape[::-1]))
        spans.append(s)
        written[s] = 1
    full = bool(written.all())
    written[...] = 0
    dtype = np.result_type(*[b.values.dtype for b in blocks])
    integer = bool(np.issubdtype(dtype, np.integer))
    if not full and not np.issubdtype(dtype, np.floating):
        # the holes are NaN: a float type that holds every value exactly
        dtype = _kernel_dtype(np.concatenate([np.array([b.values.min(), b.values.max()]) for b in blocks]))
    values = np.full(dims[::-1], np.nan if not full else 0, dtype=dtype)
    for i, (b, s) in enumerate(zip(blocks, spans)):
        before = written[s]
        shared = before > 0
        if shared.any():
            old, new = values[s][shared], b.values[shared]
            same = old == new
            if old.dtype.kind == "f":
                same |= np.isnan(old) & np.isnan(new)
            differ = ~same
            if differ.any():
                other = blocks[int(before[shared][np.argmax(differ)]) - 1].path
                warnings.warn(f"blocks {other!r} and {b.path!r} share {int(shared.sum())} points and differ at "
                              f"{int(differ.sum())} of them; the later block's values are rendered there",
                              stacklevel=5)
        values[s] = b.values
        written[s] = i + 1
    return values, integer


def merge_meshes(leaves, scalars, use_cell):
    """One :class:`~pv_hdrvol.TetMesh` of the mesh leaves (unstructured grids, their
    non-tetrahedral cells split with a warning; curvilinear grids split 5 tets a
    hexahedron).

    Points, tetrahedra and scalars are concatenated; :func:`~pv_hdrvol.tetmesh_from_arrays`
    then merges exactly coincident points, so a face that two leaves share through
    duplicated points joins their cells as neighbours: rays cross it as an interior
    face, and nothing is counted twice. Point values stay per corner (a field that
    jumps across the face keeps its jump).
    """
    from .structured import collapsed_tets
    from .tets import tetmesh_from_arrays

    points, tets, values = [], [], []
    n = 0
    for leaf in leaves:
        try:
            p, t, v = _mesh_arrays(leaf.dataset, scalars, use_cell)
        except (TypeError, ValueError) as e:
            raise type(e)(f"block {leaf.path!r}: {e}") from e
        points.append(p)
        tets.append(t + n)
        values.append(v)
        n += len(p)
    points, tets, values = np.concatenate(points), np.concatenate(tets), np.concatenate(values)
    # tetrahedra with two equal corners (collapsed grid lines) would claim a face thrice
    # and leave a false boundary inside (see collapsed_tets); the tets that remain conform
    collapsed = collapsed_tets(points, tets)
    if collapsed.all():
        raise ValueError("every tetrahedron of the mesh blocks has two equal corners (collapsed); nothing to render")
    if collapsed.any():
        tets = tets[~collapsed]
        if use_cell:
            values = values[~collapsed]
    return tetmesh_from_arrays(points, tets, values, association="cell" if use_cell else "point", name=scalars)


def _mesh_arrays(ds, scalars, use_cell):
    """``(points (m, 3), tets (n, 4) int64, values)`` of one unstructured or structured
    grid (values per point, or per tetrahedron for cell data)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from .tets import VTK_TETRA, _cell_types, _tetrahedralize, mesh_scalars

    if ds.GetClassName() == "vtkStructuredGrid":
        from .structured import TETS_PER_CELL, _check_dims, grid_dims, grid_start, structured_tets, visible_cells

        dims = _check_dims(grid_dims(ds))
        points = vtk_to_numpy(ds.GetPoints().GetData())
        visible = visible_cells(ds)
        tets = structured_tets(points, dims, visible, grid_start(ds))
        arr = mesh_scalars(ds, scalars, use_cell)
        if use_cell:
            arr = np.repeat(arr if visible is None else arr[visible], TETS_PER_CELL)
        return points, tets, arr
    types = _cell_types(ds)
    ug = ds if np.all(types == VTK_TETRA) else _tetrahedralize(ds, types)
    conn = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).astype(np.int64)
    offsets = vtk_to_numpy(ug.GetCells().GetOffsetsArray()).astype(np.int64)
    if conn.size != 4 * ug.GetNumberOfCells() or not np.all(np.diff(offsets) == 4):
        raise ValueError("the mesh's tetrahedra are malformed (a cell without 4 points)")
    return vtk_to_numpy(ug.GetPoints().GetData()), conn.reshape(-1, 4), mesh_scalars(ug, scalars, use_cell)


class BlockScene(NamedTuple):
    """What a composite dataset renders as (:func:`prepare_blocks`).

    ``kind``: ``"grid"`` (``volume`` holds the gathered GridVolume), ``"grid blocks"``
    (``blocks`` holds one :class:`ImageBlock` per leaf: not on one lattice, or too
    sparse; ``reason`` says which), ``"mesh"`` (``mesh`` holds the merged TetMesh) or
    ``"mixed"`` (grid leaves in ``blocks``, mesh leaves merged in ``mesh``).
    ``paths``: the leaves rendered; ``missing``: those without the scalars;
    ``empty``: those without points or cells; ``surfaces``: those without volume.
    """

    kind: str
    scalars: str
    association: str
    volume: object
    blocks: list
    mesh: object
    reason: str
    paths: list
    missing: list
    empty: list
    surfaces: list

    def describe(self):
        """A dict for an image's metadata."""
        out = {"kind": self.kind, "rendered": list(self.paths)}
        for key in ("missing", "empty", "surfaces"):
            if getattr(self, key):
                out[key] = list(getattr(self, key))
        if self.reason:
            out["not gathered"] = self.reason
        return out


def prepare_blocks(data, scalars=None, preference="point"):
    """The :class:`BlockScene` of a composite dataset: its leaves flattened, the scalars
    chosen, image leaves gathered or listed, mesh leaves merged; cached per dataset
    while no leaf's structure, points or scalars change (an in-place numpy edit is
    seen, as for single datasets). Warns about leaves without the scalars and about
    surfaces, every time.

    Raises
    ------
    ValueError
        No leaf to render; errors of one leaf name it.
    ScalarsError, TypeError
        As :func:`choose_block_scalars` and :func:`classify`.
    """
    from .._validate import as_choice

    as_choice("preference", preference, ("point", "cell"))
    leaves, empty = flatten(data)
    if not leaves:
        raise ValueError(f"the dataset has no block with points and cells to render"
                         f"{f' (empty blocks: {_paths(empty)})' if empty else ''}")
    kinds = classify(leaves)
    if kinds["surface"]:
        warnings.warn(f"{len(kinds['surface'])} surface block{'s' if len(kinds['surface']) > 1 else ''} "
                      f"(vtkPolyData) {'have' if len(kinds['surface']) > 1 else 'has'} no volume and "
                      f"{'are' if len(kinds['surface']) > 1 else 'is'} not rendered: "
                      f"{_paths([leaf.path for leaf in kinds['surface']])}", stacklevel=3)
    volumetric = [leaf for leaf in leaves if leaf.class_name not in SURFACE_CLASSES]
    if not volumetric:
        raise ValueError(f"the dataset has only surface blocks, which have no volume to render: "
                         f"{_paths([leaf.path for leaf in leaves])}")
    name, use_cell, kept, missing = choose_block_scalars(volumetric, scalars, preference)
    warn_missing(missing, name, stacklevel=3)
    kinds = classify(kept)
    surfaces = [leaf.path for leaf in leaves if leaf.class_name in SURFACE_CLASSES]
    grids = kinds["image"] + kinds["rectilinear"]
    association = "cell" if use_cell else "point"
    key = (name, association, tuple((leaf.path, _address(leaf.dataset), int(leaf.dataset.GetMTime())) for leaf in kept),
           content_digest(*_content(kept, name, use_cell)))
    common = dict(scalars=name, association=association, paths=[leaf.path for leaf in kept], missing=missing,
                  empty=empty, surfaces=surfaces)
    cached = _SCENE_CACHE.lookup(data, key)
    if cached is not None:
        return cached._replace(**common)
    if kinds["mesh"] and grids:
        # grids and meshes: rendered as one scene, the mesh cut between the grids' boxes
        # along each ray (raycast.blocks.render_mixed_blocks); the grids' own boxes, as
        # their gathered box may hold the mesh
        scene = BlockScene("mixed", volume=None, blocks=image_blocks(grids, name, use_cell),
                           mesh=merge_meshes(kinds["mesh"], name, use_cell), reason="", **common)
    elif kinds["mesh"]:
        scene = BlockScene("mesh", volume=None, blocks=[], mesh=merge_meshes(kept, name, use_cell), reason="",
                           **common)
    else:
        blocks = image_blocks(kept, name, use_cell)
        volume, reason = gather_images(blocks, name)
        scene = BlockScene("grid" if volume is not None else "grid blocks", volume=volume,
                           blocks=[] if volume is not None else blocks, mesh=None, reason=reason or "", **common)
    return _SCENE_CACHE.store(data, key, scene)


def _address(ds):
    """The C++ object behind a VTK wrapper (a wrapper may be made anew by each GetBlock)."""
    return getattr(ds, "__this__", None) or id(ds)


def _content(leaves, scalars, use_cell):
    """The arrays a render reads: each leaf's scalars, and a mesh leaf's points."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    out = []
    for leaf in leaves:
        ds = leaf.dataset
        out.append(_arrays(ds.GetCellData() if use_cell else ds.GetPointData())[scalars]())
        if leaf.class_name in MESH_CLASSES and ds.GetPoints() is not None:
            out.append(vtk_to_numpy(ds.GetPoints().GetData()))
        elif leaf.class_name in IMAGE_CLASSES:
            out.append(np.array(ds.GetOrigin() + ds.GetSpacing() + ds.GetExtent(), dtype=np.float64))
        elif leaf.class_name == "vtkRectilinearGrid":
            out.extend(vtk_to_numpy(c) for c in (ds.GetXCoordinates(), ds.GetYCoordinates(), ds.GetZCoordinates()))
    return out


_SCENE_CACHE = DatasetCache(4)
