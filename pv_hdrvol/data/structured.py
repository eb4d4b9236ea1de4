"""Curvilinear (structured) grids -> tetrahedral meshes for the exact tet ray caster.

A ``vtkStructuredGrid`` (``pyvista.StructuredGrid``; a PLOT3D grid) holds hexahedra on a
logical i-j-k lattice: point ``(i, j, k)`` is number ``i + nx * (j + ny * k)`` (VTK
order, i fastest) and cell ``(i, j, k)`` has the corners ``(i..i+1, j..j+1, k..k+1)``.
Each hexahedron is split into five tetrahedra, as VTK's ``vtkDataSetTriangleFilter``
splits a structured grid: a central tetrahedron on four pairwise non-adjacent corners
and the four corner tetrahedra cut off around it (each the remaining corner with its
three neighbours). The central tetrahedron takes the corners ``{0, 3, 5, 6}`` (corner
bits 1: +i, 2: +j, 4: +k) in the cells with ``i + j + k`` even and ``{1, 2, 4, 7}`` in
the odd ones, so each face of the cell is cut along the diagonal between the two
central corners on it, and the neighbour across it, of the other parity, cuts it along
the same diagonal: the split is conforming (no cracks, no T-junctions) without looking
at the coordinates, and the scalar is continuous across the cells.

The field inside a cell is then piecewise linear (linear in each tetrahedron), where
VTK's hexahedron is trilinear: the two agree at the corners and for every field that
is linear in the coordinates of a grid whose cells are parallelepipeds; on curved cells
they differ by O(h^2). The five-tetrahedron split is the closer of the two conforming
lattice splits measured (``benchmarks/bench_curvilinear.py``, docs/data_types.md): on
the Blunt Fin and LOX post at native resolution it is 3.9e-4 and 1.7e-5 RMS of the
image's peak from the trilinear field, 2.3x and 5.8x closer than the six-tetrahedron
Kuhn split around the diagonal ``(i, j, k) -> (i+1, j+1, k+1)`` used before (9.0e-4 and
9.9e-5), with 5/6 of the tetrahedra at the same render time.
"""
from __future__ import annotations

import numpy as np

from .._validate import as_choice
from .grid import ScalarsError, _arrays, choose_scalars

#: the five tetrahedra of the unit cube for the two cell parities (``(i + j + k) % 2``),
#: as corner bits (1: +i, 2: +j, 4: +k): four corner tetrahedra (a corner and its three
#: neighbours along the cell's edges), then the central one on the other four corners;
#: the split of an even cell mirrored in i is that of an odd one. _oriented swaps the
#: middle corners where needed, so that every tetrahedron of a right-handed cell has a
#: positive volume
_FIVE_BITS = np.array([
    [[1, 0, 3, 5], [2, 0, 3, 6], [4, 0, 5, 6], [7, 3, 5, 6], [0, 3, 5, 6]],  # even: central {0, 3, 5, 6}
    [[0, 1, 2, 4], [3, 1, 2, 7], [5, 1, 4, 7], [6, 2, 4, 7], [1, 2, 4, 7]],  # odd: central {1, 2, 4, 7}
], dtype=np.int64)
#: tetrahedra per hexahedron
TETS_PER_CELL = 5


def _oriented(bits):
    """``bits`` with the middle corners of negatively oriented tetrahedra swapped."""
    corners = np.stack([(bits >> 0) & 1, (bits >> 1) & 1, (bits >> 2) & 1], axis=-1).astype(np.float64)
    e = corners[:, 1:] - corners[:, :1]
    out = bits.copy()
    negative = np.linalg.det(e) < 0
    out[negative] = out[negative][:, [0, 2, 1, 3]]
    return out


_FIVE_BITS = np.stack([_oriented(b) for b in _FIVE_BITS])
#: vtkDataSetAttributes ghost bits that hide a cell of a structured grid, as
#: vtkStructuredGrid::IsCellVisible reads them: HIDDENCELL | REFINEDCELL in the cell
#: ghosts, HIDDENPOINT in the ghosts of any of its points
_HIDDEN_CELL_BITS = 32 | 8
_HIDDEN_POINT_BITS = 2


def structured_tets(points, dims, visible=None, start=(0, 0, 0)):
    """The alternating five-tetrahedron split of a structured grid's hexahedra (as VTK's
    ``vtkDataSetTriangleFilter`` splits them).

    Each cell gives four corner tetrahedra and a central one; the central tetrahedron's
    corners alternate with the parity of ``i + j + k`` (module docstring), so that two
    cells sharing a face cut it along the same diagonal. Chosen over the six-tetrahedron
    Kuhn split for its accuracy: 2.3x (Blunt Fin) and 5.8x (LOX post) closer to the
    trilinear field of the hexahedra at native resolution, with 5/6 of the tetrahedra
    (``benchmarks/bench_curvilinear.py``, docs/data_types.md).

    Parameters
    ----------
    points : array (nx * ny * nz, 3)
        The grid's points in VTK order (index ``i + nx * (j + ny * k)``). Only their
        number is checked: the split depends on the lattice alone.
    dims : (nx, ny, nz) ints, each >= 2
        Points along i, j, k.
    visible : bool array ((nx-1) * (ny-1) * (nz-1),), optional
        Cells to split (VTK cell order, i fastest); default all. Hidden cells give no
        tetrahedra (and do not change the parity of the others).
    start : (i0, j0, k0) ints, optional
        The lattice index of point 0 (the start of the grid's extent,
        :func:`grid_start`). The parity is that of the global ``i0 + i + j0 + j + k0 +
        k``, so the pieces of one grid (a partitioned grid, ``extract_subset``) cut the
        faces they share the same way. VTK's filter counts from each piece's first
        cell instead: the two agree where ``i0 + j0 + k0`` is even.

    Returns
    -------
    tets : int64 array (5 * n_visible, 4)
        Point indices; rows ``5 c .. 5 c + 4`` are the tetrahedra of the ``c``-th
        visible cell, in cell order (``np.repeat(cell_values[visible], 5)`` gives their
        cell data; :data:`TETS_PER_CELL` is 5). The split is conforming: two cells
        sharing a face cut it along the same diagonal. In a right-handed cell
        (``(P_i x P_j) . P_k > 0`` for the edge vectors from corner ``(i, j, k)``), each
        tetrahedron has a positive volume.

    Raises
    ------
    ValueError
        ``dims`` not three integers >= 2 (a 2-D grid has no volume), ``points`` not
        of shape ``(nx * ny * nz, 3)``, ``visible`` of the wrong length.

    Examples
    --------
    >>> structured_tets(np.zeros((8, 3)), (2, 2, 2)).shape
    (5, 4)
    """
    dims = _check_dims(dims)
    nx, ny, nz = dims
    points = np.asarray(points)
    if points.shape != (nx * ny * nz, 3):
        raise ValueError(f"points must have shape ({nx * ny * nz}, 3) for dims {dims}; got {points.shape}")
    i = np.arange(nx - 1, dtype=np.int64)
    j = np.arange(ny - 1, dtype=np.int64)[:, None]
    k = np.arange(nz - 1, dtype=np.int64)[:, None, None]
    # cell order, i fastest: (k, j, i) arrays raveled
    base = (i + nx * (j + ny * k)).ravel()
    try:
        shift = sum(int(v) for v in start) if len(start) == 3 else None
    except (TypeError, ValueError):
        shift = None
    if shift is None:
        raise ValueError(f"start must be three integers (i0, j0, k0); got {start!r}")
    odd = ((i + j + k + shift) & 1).astype(bool).ravel()
    if visible is not None:
        visible = np.asarray(visible, dtype=bool).ravel()
        if visible.shape != base.shape:
            raise ValueError(f"visible must have one entry per cell ({base.size}); got {visible.size}")
        base, odd = base[visible], odd[visible]
    bits = _FIVE_BITS
    offset = (bits & 1) + nx * (((bits >> 1) & 1) + ny * ((bits >> 2) & 1))  # (2, 5, 4)
    out = np.empty((base.size, TETS_PER_CELL, 4), dtype=np.int64)
    base = base[:, None, None]
    np.add(base, offset[0], out=out, where=~odd[:, None, None])
    np.add(base, offset[1], out=out, where=odd[:, None, None])
    return out.reshape(-1, 4)


def collapsed_tets(points, tets):
    """Bool array (n,): the tetrahedra two of whose corners are the same point (equal
    coordinates), as a collapsed grid line or face makes them.

    Such a tetrahedron has no volume and no ray crosses any length of it, but it has
    two copies of one real face, so the face is claimed by three cells and the mesh's
    adjacency links the wrong two, leaving a false boundary face inside the mesh
    (a 270-degree shell sector with a collapsed axis then fails with "the camera is
    inside the mesh", split by VTK's vtkDataSetTriangleFilter as by
    :func:`structured_tets`). :func:`structured_tet_arrays` drops them; the split
    stays conforming without them (each collapsed quad face keeps its one real
    triangle in both cells).
    """
    points = np.asarray(points)
    tets = np.asarray(tets)
    out = np.zeros(len(tets), dtype=bool)
    for a in range(4):
        pa = points[tets[:, a]]
        for b in range(a + 1, 4):
            out |= np.all(pa == points[tets[:, b]], axis=1)
    return out


def _check_dims(dims):
    try:
        d = tuple(int(v) for v in dims)
    except (TypeError, ValueError):
        raise ValueError(f"dims must be three integers (nx, ny, nz); got {dims!r}") from None
    if len(d) != 3:
        raise ValueError(f"dims must be three integers (nx, ny, nz); got {dims!r}")
    if min(d) < 2:
        raise ValueError(f"a structured grid must be 3-D, with at least 2 points along every axis; got dimensions "
                         f"{d}: a 2-D grid or a single point has no volume to render")
    return d


def is_structured_grid(data):
    """True for a ``vtkStructuredGrid`` (``pyvista.StructuredGrid``)."""
    return hasattr(data, "GetClassName") and data.GetClassName() == "vtkStructuredGrid"


def grid_dims(dataset):
    """``(nx, ny, nz)`` points along i, j, k of a vtkStructuredGrid, from its extent
    (``GetDimensions()`` takes an output argument in VTK 9.7, none before)."""
    e = dataset.GetExtent()
    return tuple(int(e[2 * a + 1]) - int(e[2 * a]) + 1 for a in range(3))


def grid_start(dataset):
    """``(i0, j0, k0)``: the lattice index of a vtkStructuredGrid's first point (its
    extent's start; not 0 for a piece of a larger grid)."""
    e = dataset.GetExtent()
    return tuple(int(e[2 * a]) for a in range(3))


def visible_cells(dataset):
    """Bool array, one per cell (VTK order): the cells ``IsCellVisible`` reports visible
    (no HIDDENCELL or REFINEDCELL ghost bit, no corner point with HIDDENPOINT), or
    None when every cell is."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    nx, ny, nz = grid_dims(dataset)
    hidden = None
    cg = dataset.GetCellGhostArray()
    if cg is not None:
        hidden = (vtk_to_numpy(cg).astype(np.uint8) & _HIDDEN_CELL_BITS) != 0
    pg = dataset.GetPointGhostArray()
    if pg is not None:
        hp = ((vtk_to_numpy(pg).astype(np.uint8) & _HIDDEN_POINT_BITS) != 0).reshape(nz, ny, nx)
        if hp.any():
            # a cell is hidden when any of its 8 corners is
            hc = np.zeros((nz - 1, ny - 1, nx - 1), dtype=bool)
            for dk in (0, 1):
                for dj in (0, 1):
                    for di in (0, 1):
                        hc |= hp[dk:nz - 1 + dk, dj:ny - 1 + dj, di:nx - 1 + di]
            hidden = hc.ravel() if hidden is None else hidden | hc.ravel()
    if hidden is None or not hidden.any():
        return None
    return ~hidden


def structured_tet_arrays(dataset, scalars=None, preference="point"):
    """A curvilinear grid split into tetrahedra, as the arguments of
    :func:`~pv_hdrvol.data.tets.tetmesh_from_arrays`; the dataset is not modified.
    :func:`~pv_hdrvol.data.tets.tetmesh_from_structured` makes the mesh of them.

    Parameters
    ----------
    dataset : pyvista.StructuredGrid or vtkStructuredGrid
        Hexahedra on an i-j-k lattice, each split into 5 tetrahedra
        (:func:`structured_tets`). Blanked cells (``vtkStructuredGrid::BlankCell``,
        ``BlankPoint``: the ghost array's hidden bits) give no tetrahedra.
    scalars : str, optional
        Array to render; default the active scalars, else the only array.
    preference : {"point", "cell"}
        Association to use when the name exists as point and as cell data. Cell data
        is constant on each cell's five tetrahedra.

    Returns
    -------
    points : ndarray, shape (n, 3)
    tets : ndarray of int64, shape (m, 4)
    values : ndarray, shape (n,) or (m,)
    association : {"point", "cell"}
    name : str
        The array's name.

    Raises
    ------
    ValueError
        A grid with a dimension of 1 (2-D), every cell hidden, non-finite point
        coordinates (the message gives how many and the first point's index and
        (i, j, k)), scalars missing, ambiguous or with more than one component
        (:class:`~pv_hdrvol.ScalarsError`).
    TypeError
        ``dataset`` is not a structured grid.

    Notes
    -----
    Collapsed cells (a grid line that degenerates to a point, as at the nose of the
    Blunt Fin) give tetrahedra with two equal corners: they are dropped
    (:func:`collapsed_tets` says why). Flat cells with distinct corners give
    zero-volume tetrahedra and folded cells inverted ones: the tet caster crosses both
    (a flat cell in zero length).
    """
    as_choice("preference", preference, ("point", "cell"))
    if not is_structured_grid(dataset):
        raise TypeError(f"expected a pyvista.StructuredGrid / vtkStructuredGrid; got {type(dataset).__name__}")
    from vtkmodules.util.numpy_support import vtk_to_numpy

    dims = grid_dims(dataset)
    if min(dims) < 1 or dataset.GetPoints() is None:
        raise ValueError(f"the structured grid has no points (dimensions {dims})")
    _check_dims(dims)
    name, use_cell = choose_scalars(dataset, scalars, preference, "grid")
    values = np.asarray(_arrays(dataset.GetCellData() if use_cell else dataset.GetPointData())[name]())
    if values.ndim != 1:
        raise ScalarsError(f"scalars {name!r} must have one component; got shape {values.shape}")
    nx, ny, nz = dims
    n_cells = (nx - 1) * (ny - 1) * (nz - 1)
    expected = n_cells if use_cell else nx * ny * nz
    if values.shape[0] != expected:
        raise ScalarsError(f"scalars {name!r} has {values.shape[0]} values; the grid has {expected} "
                           f"{'cells' if use_cell else 'points'}")
    points = vtk_to_numpy(dataset.GetPoints().GetData())
    visible = visible_cells(dataset)
    if visible is not None and not visible.any():
        raise ValueError(f"every cell of the structured grid is hidden (blanked); nothing to render "
                         f"(dimensions {dims})")
    tets = structured_tets(points, dims, visible, grid_start(dataset))
    if use_cell:
        values = np.repeat(values if visible is None else values[visible], TETS_PER_CELL)
    # only the points of visible cells must be finite: blanked regions may hold garbage
    used = np.zeros(len(points), dtype=bool)
    used[tets.ravel()] = True
    finite = np.all(np.isfinite(points), axis=1) | ~used
    if not finite.all():
        bad = np.flatnonzero(~finite)
        first = int(bad[0])
        ijk = (first % nx, (first // nx) % ny, first // (nx * ny))
        raise ValueError(f"{bad.size} points of the structured grid have non-finite coordinates (NaN or inf), "
                         f"the first is point {first} (i, j, k) = {ijk}; blank those cells "
                         f"(BlankPoint) or remove them first")
    collapsed = collapsed_tets(points, tets)
    if collapsed.all():
        raise ValueError(f"every tetrahedron of the structured grid has two equal corners (the grid is "
                         f"collapsed); nothing to render (dimensions {dims})")
    if collapsed.any():
        tets = tets[~collapsed]
        if use_cell:
            values = values[~collapsed]
    return points, tets, values, "cell" if use_cell else "point", name
