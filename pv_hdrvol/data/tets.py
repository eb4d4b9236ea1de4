"""Tetrahedral meshes -> flat arrays for the tet ray caster: cells, scalars, adjacency, boundary.

A :class:`TetMesh` holds what ``raycast/_tet_kernels.py`` marches through:

- ``points`` (m, 3) float64, translated and scaled so the mesh fits the unit ball
  (``world = points * scale + center``): the Plücker products of rays and edges are
  then formed on numbers of order 1 whatever the mesh's units (1e-9 m or 1e9 m);
- ``tets`` (n, 4) int64 point indices after exact duplicate points are merged (so two
  cells that share a face through duplicated points are still neighbours);
- ``values`` (n, 4) float64: each cell's scalar at its four corners (point data: the
  original point's value, so a field that jumps across duplicated points keeps its
  jump; cell data: the cell value four times);
- ``neighbors`` (n, 4): the cell across face ``i`` (the face opposite corner ``i``),
  -1 on the boundary, and ``neighbor_faces``: which face of that cell it is;
- ``boundary`` (b, 3) point indices of the boundary faces, wound so their normal
  points out of the mesh, with the cell and local face each belongs to.

Zero-volume and inverted cells are kept: the marching needs no volume (a flat cell is
crossed in zero length). A face shared by more than two cells (non-manifold) links the
first two; the others are boundary.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from .grid import DatasetCache, ScalarsError, _arrays, choose_scalars, content_digest
from .._validate import as_choice
from .structured import structured_tet_arrays

#: VTK cell type of a linear tetrahedron
VTK_TETRA = 10
#: corners of face i (the face opposite corner i), in cyclic order
FACE_CORNERS = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]], dtype=np.int64)


@dataclass(eq=False)
class TetMesh:
    """A tetrahedral mesh prepared for ray casting (see the module docstring).

    Build one with :func:`tetmesh_from_dataset`; the PyVista accessor and ``hv.render``
    cache it on the dataset, so only the first render pays for it.
    """

    points: np.ndarray
    tets: np.ndarray
    values: np.ndarray
    neighbors: np.ndarray
    neighbor_faces: np.ndarray
    boundary: np.ndarray
    boundary_cell: np.ndarray
    boundary_face: np.ndarray
    center: np.ndarray
    scale: float
    value_range: tuple
    name: str = ""
    association: str = "point"
    cache: dict = field(default_factory=dict, repr=False)

    @property
    def n_cells(self):
        return int(self.tets.shape[0])

    @property
    def bounds(self):
        """``(xmin, xmax, ymin, ymax, zmin, zmax)`` in world units."""
        w = self.points * self.scale + self.center
        lo, hi = w.min(axis=0), w.max(axis=0)
        return tuple(float(v) for pair in zip(lo, hi) for v in pair)

    def world_points(self):
        """The (merged) points in world coordinates."""
        return self.points * self.scale + self.center

    def cell_volumes(self):
        """Signed volumes of the cells in world units (negative: inverted corner order)."""
        p = self.world_points()
        a, b, c, d = (p[self.tets[:, i]] for i in range(4))
        return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0

    def default_unit_distance(self):
        """A typical cell size: the bounding-box diagonal over the cube root of the
        number of points (PyVista's default for unstructured volumes)."""
        b = np.asarray(self.bounds)
        diag = float(np.linalg.norm(b[1::2] - b[0::2]))
        n = max(len(self.points), 1)
        return diag / n ** (1.0 / 3.0) if diag > 0 else 1.0

    def __repr__(self):
        return (f"TetMesh({self.n_cells} tets, {len(self.points)} points, {len(self.boundary)} boundary faces, "
                f"scalars={self.name!r} ({self.association}), range=[{self.value_range[0]:.6g}, "
                f"{self.value_range[1]:.6g}])")


def is_unstructured(data):
    """True for data rendered by the tet path: a :class:`TetMesh`, a vtkUnstructuredGrid
    (pyvista.UnstructuredGrid) or a curvilinear vtkStructuredGrid (pyvista.StructuredGrid,
    split into tetrahedra by :func:`tetmesh_from_structured`)."""
    if isinstance(data, TetMesh):
        return True
    return hasattr(data, "GetClassName") and data.GetClassName() in ("vtkUnstructuredGrid", "vtkStructuredGrid")


def as_tetmesh(data, scalars=None, preference="point"):
    """A :class:`TetMesh` from a TetMesh, an unstructured grid or a structured
    (curvilinear) grid, cached per grid.

    A structured grid's hexahedra are split into five tetrahedra each
    (:func:`tetmesh_from_structured`).
    The cache key holds the grid's modification time, the array and its association,
    and a SHA-1 of the point coordinates, the scalars and (structured grids) the
    dimensions and blanking: changing the mesh or its scalars rebuilds it, also by an
    in-place numpy edit that did not call ``Modified()``.
    The cache holds the grid weakly and at most four prepared meshes (``DatasetCache``).
    """
    if isinstance(data, TetMesh):
        if scalars is not None:
            raise ValueError("scalars names an array of a dataset; a TetMesh has its scalars already")
        return data
    if not is_unstructured(data):
        raise TypeError(f"expected an unstructured grid (pyvista.UnstructuredGrid / vtkUnstructuredGrid), a "
                        f"structured grid (pyvista.StructuredGrid / vtkStructuredGrid) or a TetMesh; got "
                        f"{type(data).__name__}")
    key = (int(data.GetMTime()), scalars, preference, _content_digest(data, scalars, preference))
    mesh = _MESH_CACHE.lookup(data, key)
    if mesh is None:
        mesh = _MESH_CACHE.store(data, key, tetmesh_from_dataset(data, scalars, preference))
    return mesh


_MESH_CACHE = DatasetCache(4)  # a few meshes at most: they can be large


def _content_digest(dataset, scalars, preference):
    """:func:`~pv_hdrvol.data.grid.content_digest` of a grid's point coordinates and of the
    scalars a render would use (an in-place numpy edit changes no modification time).
    Scalars that cannot be chosen are left out: building the mesh then raises the clear
    error."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    arrays = []
    points = dataset.GetPoints()
    if points is not None:
        arrays.append(vtk_to_numpy(points.GetData()))
    if dataset.GetClassName() == "vtkStructuredGrid":
        # the lattice and its blanking (ghost arrays) decide the cells
        arrays.append(np.asarray(dataset.GetExtent(), dtype=np.int64))
        for ghosts in (dataset.GetPointGhostArray(), dataset.GetCellGhostArray()):
            arrays.append(vtk_to_numpy(ghosts) if ghosts is not None else np.empty(0, dtype=np.uint8))
    try:
        name, use_cell = choose_scalars(dataset, scalars, preference, "mesh")
        field_data = dataset.GetCellData() if use_cell else dataset.GetPointData()
        arrays.append(_arrays(field_data)[name]())
    except (ScalarsError, KeyError):
        pass
    return content_digest(*arrays)


def check_has_cells(dataset):
    """Raise ``ValueError("the mesh has no cells to render (...)")`` for an unstructured
    grid without points or cells: its bounds are VTK's "unset" (1, -1, ...), which would
    otherwise surface as a puzzling message about bounds when a camera is fitted."""
    n_points = int(dataset.GetNumberOfPoints())
    n_cells = int(dataset.GetNumberOfCells())
    if n_points == 0 or n_cells == 0:
        raise ValueError(f"the mesh has no cells to render ({n_points} points, {n_cells} cells)")


def tetmesh_from_dataset(dataset, scalars=None, preference="point"):
    """Prepare an unstructured grid for ray casting; the dataset itself is not modified.

    Parameters
    ----------
    dataset : pyvista.UnstructuredGrid, vtkUnstructuredGrid, pyvista.StructuredGrid or vtkStructuredGrid
        Linear tetrahedra are used as they are. Other 3-D cells (hexahedra, wedges,
        pyramids, quadratic cells...) are split into tetrahedra with
        ``vtkDataSetTriangleFilter``, with a warning; 0-D to 2-D cells are dropped.
        A structured (curvilinear) grid's hexahedra are split into five tetrahedra
        each, without a warning
        (:func:`tetmesh_from_structured`).
    scalars : str, optional
        Array to render; default the active scalars, else the only array.
    preference : {"point", "cell"}
        Association to use when the name exists as point and as cell data.

    Raises
    ------
    ValueError
        No 3-D cell, non-finite point coordinates, a scalar array of the wrong length
        or with more than one component.
    """
    as_choice("preference", preference, ("point", "cell"))
    if not is_unstructured(dataset) or isinstance(dataset, TetMesh):
        raise TypeError(f"expected a pyvista.UnstructuredGrid / vtkUnstructuredGrid or a pyvista.StructuredGrid / "
                        f"vtkStructuredGrid; got {type(dataset).__name__}")
    if dataset.GetClassName() == "vtkStructuredGrid":
        return tetmesh_from_structured(dataset, scalars, preference)
    from vtkmodules.util.numpy_support import vtk_to_numpy

    check_has_cells(dataset)
    name, use_cell = choose_scalars(dataset, scalars, preference, "mesh")
    ug = dataset
    types = _cell_types(ug)
    if not np.all(types == VTK_TETRA):
        ug = _tetrahedralize(dataset, types)
        types = _cell_types(ug)
    conn = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).astype(np.int64)
    offsets = vtk_to_numpy(ug.GetCells().GetOffsetsArray()).astype(np.int64)
    if conn.size != 4 * types.size or not np.all(np.diff(offsets) == 4):
        raise ValueError("the mesh's tetrahedra are malformed (a cell without 4 points)")
    tets_orig = conn.reshape(-1, 4)
    points = vtk_to_numpy(ug.GetPoints().GetData())
    arr = mesh_scalars(ug, name, use_cell)
    return tetmesh_from_arrays(points, tets_orig, arr, association="cell" if use_cell else "point", name=name)


def mesh_scalars(ds, name, use_cell):
    """The one-component array ``name`` of a (tetrahedralised) mesh's cell or point data."""
    arrays = _arrays(ds.GetCellData() if use_cell else ds.GetPointData())
    if name not in arrays:  # the tetrahedralize filter keeps arrays; this guards odd inputs
        raise ScalarsError(f"scalars {name!r} were lost when splitting cells into tetrahedra")
    arr = np.asarray(arrays[name]())
    if arr.ndim != 1:
        raise ScalarsError(f"scalars {name!r} must have one component; got shape {arr.shape}")
    return arr


def tetmesh_from_arrays(points, tets, values, *, association="point", name=""):
    """Prepare a tetrahedral mesh given as numpy arrays (no VTK needed).

    Parameters
    ----------
    points : array (m, 3)
        Coordinates (any real dtype; copied to float64).
    tets : int array (n, 4)
        Point indices of each tetrahedron (any corner order: inverted cells are fine).
    values : array (m,) or (n,)
        Scalars per point (``association="point"``) or per cell (``"cell"``).
        Non-finite values make their cells empty.
    """
    as_choice("association", association, ("point", "cell"))
    points = np.asarray(points)
    tets = np.asarray(tets)
    values = np.asarray(values)
    if points.ndim != 2 or points.shape[1] != 3 or not np.issubdtype(points.dtype, np.number):
        raise ValueError(f"points must be a real array of shape (m, 3); got shape {points.shape}, dtype {points.dtype}")
    if tets.ndim != 2 or tets.shape[1] != 4 or not np.issubdtype(tets.dtype, np.integer):
        raise ValueError(f"tets must be an integer array of shape (n, 4); got shape {tets.shape}, dtype {tets.dtype}")
    if tets.shape[0] == 0:
        raise ValueError("the mesh has no tetrahedra")
    if tets.min() < 0 or tets.max() >= points.shape[0]:
        raise ValueError(f"tets index points 0..{points.shape[0] - 1}; got indices {int(tets.min())}..{int(tets.max())}")
    if values.ndim != 1 or not (np.issubdtype(values.dtype, np.number) or values.dtype == np.bool_):
        raise ValueError(f"values must be a real 1-D array; got shape {values.shape}, dtype {values.dtype}")
    expected = tets.shape[0] if association == "cell" else points.shape[0]
    if values.shape[0] != expected:
        raise ValueError(f"scalars {name!r} has {values.shape[0]} values; the mesh has {expected} "
                         f"{'cells' if association == 'cell' else 'points'}")
    tets_orig = tets.astype(np.int64)
    points = np.asarray(points, dtype=np.float64)
    used = np.zeros(len(points), dtype=bool)
    used[tets_orig.ravel()] = True
    bad = ~np.all(np.isfinite(points), axis=1) & used
    if np.any(bad):
        raise ValueError(f"{int(np.count_nonzero(bad))} points of the tetrahedra have non-finite coordinates "
                         f"(NaN or inf); remove those cells first")
    arr = np.asarray(values, dtype=np.float64)  # a copy whenever the dtype differs; never written
    per_corner = np.repeat(arr[:, None], 4, axis=1) if association == "cell" else arr[tets_orig]
    finite = np.isfinite(per_corner)
    value_range = (float(per_corner[finite].min()), float(per_corner[finite].max())) if finite.any() else (0.0, 0.0)

    # merge exactly coincident points (topology only; values stay per corner)
    sub = np.flatnonzero(used)
    uniq, inverse = np.unique(points[sub], axis=0, return_inverse=True)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[sub] = np.asarray(inverse).reshape(-1)
    merged = remap[tets_orig]
    lo, hi = uniq.min(axis=0), uniq.max(axis=0)
    center = 0.5 * (lo + hi)
    scale = 0.5 * float(np.linalg.norm(hi - lo))
    if not scale > 0:
        scale = 1.0
    unit = (uniq - center) / scale
    neighbors, neighbor_faces = _adjacency(merged)
    bcell, bface = np.nonzero(neighbors < 0)
    boundary = _outward_faces(unit, merged, bcell, bface)
    return TetMesh(unit, np.ascontiguousarray(merged), np.ascontiguousarray(per_corner), neighbors, neighbor_faces,
                   boundary, bcell.astype(np.int64), bface.astype(np.int64), center, scale, value_range, name,
                   association)


def tetmesh_from_structured(dataset, scalars=None, preference="point"):
    """Prepare a curvilinear grid (``pyvista.StructuredGrid``, ``vtkStructuredGrid``) for
    the tet ray caster: each hexahedron split into 5 tetrahedra, blanked cells left out,
    collapsed ones dropped (:func:`~pv_hdrvol.data.structured.structured_tet_arrays`
    gives the parameters, the errors and the notes); the dataset is not modified.

    Returns
    -------
    TetMesh
    """
    points, tets, values, association, name = structured_tet_arrays(dataset, scalars, preference)
    return tetmesh_from_arrays(points, tets, values, association=association, name=name)


def _cell_types(ug):
    """The cell type of every cell (uint8 array): ``GetCellTypes()`` from VTK 9.6 on,
    ``GetCellTypesArray()`` before (ParaView 5.11 has VTK 9.2)."""
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonCore import vtkVersion

    new = (vtkVersion.GetVTKMajorVersion(), vtkVersion.GetVTKMinorVersion()) >= (9, 6)
    arr = ug.GetCellTypes() if new else ug.GetCellTypesArray()
    return vtk_to_numpy(arr) if arr is not None else np.empty(0, dtype=np.uint8)


def _tetrahedralize(dataset, types):
    """Split every 3-D cell into tetrahedra (``vtkDataSetTriangleFilter``), with a warning."""
    from vtkmodules.vtkCommonDataModel import vtkCellTypes, vtkUnstructuredGrid
    from vtkmodules.vtkFiltersGeneral import vtkDataSetTriangleFilter

    kinds = sorted({vtkCellTypes.GetClassNameFromTypeId(int(t)) for t in np.unique(types) if t != VTK_TETRA})
    copy = vtkUnstructuredGrid()
    copy.ShallowCopy(dataset)  # the filter never writes to the caller's mesh
    f = vtkDataSetTriangleFilter()
    f.TetrahedraOnlyOn()
    f.SetInputData(copy)
    f.Update()
    out = f.GetOutput()
    n = out.GetNumberOfCells()
    out_types = _cell_types(out) if n else np.empty(0)
    if n == 0 or not np.all(out_types == VTK_TETRA):
        raise ValueError(f"the mesh has no 3-D cells to render (cell types: {', '.join(kinds) or 'none'})")
    warnings.warn(f"split {int(np.count_nonzero(types != VTK_TETRA))} non-tetrahedral cells ({', '.join(kinds)}) "
                  f"into {n} tetrahedra; 0-D to 2-D cells are dropped", stacklevel=4)
    return out


def _adjacency(tets):
    """``(neighbors, neighbor_faces)``, each (n, 4) int64: the cell across each face and
    that face's index there; -1 on the boundary."""
    n = tets.shape[0]
    faces = np.sort(tets[:, FACE_CORNERS].reshape(-1, 3), axis=1)  # row 4 c + i: face i of cell c
    order = np.lexsort((faces[:, 2], faces[:, 1], faces[:, 0]))
    f = faces[order]
    same = np.all(f[1:] == f[:-1], axis=1)
    # a pair (k, k+1) whose k is not itself the second of a pair: the first two cells of a face
    first = np.flatnonzero(same)
    if first.size:
        keep = np.ones(first.size, dtype=bool)
        keep[1:] = first[1:] != first[:-1] + 1
        first = first[keep]
    nb = np.full(4 * n, -1, dtype=np.int64)
    a, b = order[first], order[first + 1]
    nb[a], nb[b] = b // 4, a // 4
    nf = np.full(4 * n, -1, dtype=np.int64)
    nf[a], nf[b] = b % 4, a % 4
    return nb.reshape(n, 4), nf.reshape(n, 4)


def _outward_faces(points, tets, cells, faces):
    """Corner indices of boundary faces wound so that ``(b - a) x (c - a)`` points away
    from the cell's fourth corner (out of the mesh)."""
    tri = tets[cells[:, None], FACE_CORNERS[faces]]  # (b, 3)
    opp = tets[cells, faces]
    a, b, c = (points[tri[:, i]] for i in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), points[opp] - a) > 0
    tri[inward] = tri[inward][:, [0, 2, 1]]
    return np.ascontiguousarray(tri)
