"""Data spread over processes, as VTK's pipeline hands it out: which piece of an extent
a process asks for, the whole rectilinear grid's axes from its pieces, a curvilinear
piece as tetrahedra, a mesh's pieces summarised, cut into boxes and moved
(``vtkRedistributeDataSetFilter``), and :class:`ControllerComm`, VTK's processes as an
mpi4py-style communicator. :mod:`~pv_hdrvol.integrations.vtk_execute` renders the
pieces with these; nothing here renders.
"""
from __future__ import annotations

from typing import NamedTuple

from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

from ..parallel.comm import PointToPointComm

_SDDP = vtkStreamingDemandDrivenPipeline


class Distribution(NamedTuple):
    """How this process renders its piece: the communicator, the whole extent, the
    extent it owns and the one it asks for (owned plus ``ghosts`` layers)."""

    comm: "ControllerComm"
    whole: tuple
    owned: tuple
    extent: tuple
    ghosts: int


def whole_axes(inp, distribution):
    """The whole rectilinear grid's coordinates (x, y, z arrays) from every process's
    piece (collective: each sends its extent and coordinates), an exception to raise if
    they do not fit, or ``None`` when the input is not a rectilinear grid (on any
    process: all decide alike, from piece 0's class name)."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy

    mine = None
    if inp is not None and inp.GetClassName() == "vtkRectilinearGrid" and inp.GetNumberOfPoints():
        mine = (tuple(inp.GetExtent()), [vtk_to_numpy(c).astype(np.float64) for c in
                                         (inp.GetXCoordinates(), inp.GetYCoordinates(), inp.GetZCoordinates())])
    pieces = distribution.comm.allgather(mine)
    if all(p is None for p in pieces):
        return None
    whole = np.reshape(distribution.whole, (3, 2))
    axes = [np.full(int(hi - lo + 1), np.nan) for lo, hi in whole]
    for p in pieces:
        if p is None:
            continue
        for axis in range(3):
            lo = int(p[0][2 * axis] - whole[axis][0])
            axes[axis][lo:lo + p[1][axis].size] = p[1][axis]
    if any(np.isnan(a).any() for a in axes):
        return ValueError("the rectilinear grid's pieces do not cover its whole extent: render it on one process")
    return tuple(axes)


def tet_grid_of_structured(grid):
    """A curvilinear grid (a piece of one) as the ``vtkUnstructuredGrid`` of the
    tetrahedra a render of the whole grid splits it into (:func:`~pv_hdrvol.data.
    structured.structured_tets`: the lattice alone decides the split, so pieces that
    share a face cut it alike; blanked cells, ghost cells (DUPLICATECELL: another
    piece's) and collapsed tetrahedra left out), with
    its points and point data as they are and its cell data repeated per tetrahedron."""
    import numpy as np
    from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy
    from vtkmodules.vtkCommonDataModel import VTK_TETRA, vtkCellArray, vtkUnstructuredGrid

    from ..data.structured import TETS_PER_CELL, collapsed_tets, grid_dims, grid_start, structured_tets, visible_cells

    out = vtkUnstructuredGrid()
    if grid.GetNumberOfPoints() == 0 or grid.GetNumberOfCells() == 0:
        return out
    points = vtk_to_numpy(grid.GetPoints().GetData())
    visible = visible_cells(grid)
    ghosts = grid.GetCellGhostArray()
    if ghosts is not None:  # a ghost layer's cells are another piece's: DUPLICATECELL
        owned = (vtk_to_numpy(ghosts).astype(np.uint8) & 1) == 0
        if not owned.all():
            visible = owned if visible is None else visible & owned
    cells = np.arange(grid.GetNumberOfCells()) if visible is None else np.flatnonzero(visible)
    tets = structured_tets(points, grid_dims(grid), visible, grid_start(grid))
    of_cell = np.repeat(cells, TETS_PER_CELL)
    keep = ~collapsed_tets(points, tets)
    tets, of_cell = tets[keep], of_cell[keep]
    out.SetPoints(grid.GetPoints())
    out.GetPointData().ShallowCopy(grid.GetPointData())
    connectivity = vtkCellArray()
    connectivity.SetData(numpy_to_vtkIdTypeArray(np.arange(0, 4 * len(tets) + 1, 4, dtype=np.int64), deep=True),
                         numpy_to_vtkIdTypeArray(np.ascontiguousarray(tets.ravel(), dtype=np.int64), deep=True))
    out.SetCells(VTK_TETRA, connectivity)
    data = grid.GetCellData()
    for i in range(data.GetNumberOfArrays()):
        array = data.GetArray(i)
        if array is None or array.GetName() == "vtkGhostType":
            continue
        values = numpy_to_vtk(np.ascontiguousarray(vtk_to_numpy(array)[of_cell]), deep=True)
        values.SetName(array.GetName())
        out.GetCellData().AddArray(values)
    return out


def mesh_summary(mesh, scalars, sample=4096):
    """What the processes tell each other about their pieces of a mesh before it is cut
    into boxes: counts, bounds, the scalars' name and a strided sample of cell centres."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkFiltersCore import vtkCellCenters

    n = mesh.GetNumberOfCells()
    centres = np.empty((0, 3))
    bounds = None
    if n:
        finder = vtkCellCenters()
        finder.SetInputData(mesh)
        finder.VertexCellsOff()
        finder.Update()
        centres = vtk_to_numpy(finder.GetOutput().GetPoints().GetData())[:: max(1, n // sample)].astype(float)
        used = used_points(mesh)  # the bounds a TetMesh of the whole mesh has
        bounds = tuple(float(v) for pair in zip(used.min(axis=0), used.max(axis=0)) for v in pair)
    return {"cells": n, "bounds": bounds, "scalars": scalars, "centres": centres}


def used_points(mesh):
    """The distinct points (``(m, 3)`` float64) the cells of ``mesh`` use, as a TetMesh
    keeps them."""
    import numpy as np
    from vtkmodules.util.numpy_support import vtk_to_numpy

    if not mesh.GetNumberOfCells():
        return np.empty((0, 3))
    xyz = vtk_to_numpy(mesh.GetPoints().GetData()).astype(np.float64)
    return np.unique(xyz[np.unique(vtk_to_numpy(mesh.GetCells().GetConnectivityArray()))], axis=0)


def points_owned(mesh, piece):
    """How many distinct points of ``mesh`` lie in ``piece``'s box (half open: a point on
    a face two boxes share belongs to the box above it), so that the counts of all
    processes add up to the whole mesh's distinct points (its default unit distance)."""
    import numpy as np

    used = used_points(mesh)
    lo, hi = piece.world_box()
    inside = (used >= lo) & ((used < hi) | (piece.closed() & (used <= hi)))
    return int(np.count_nonzero(inside.all(axis=1)))


def share_cores(comm):
    """Give this process its share of its node's cores for the render (collective):
    ``max(1, cores // processes on the node)`` numba threads, unless ``NUMBA_NUM_THREADS``
    is set (:func:`pv_hdrvol.parallel.comm.rank_threads`). Every pvbatch rank would
    otherwise start one thread per core of the machine."""
    from ..parallel.comm import use_rank_threads

    use_rank_threads(comm)


def redistribute(mesh, boxes, comm):
    """This process's cells of ``mesh`` after moving every cell to each process whose box
    it meets (``boxes[rank]``; collective). Box ``i`` goes to process ``i``."""
    from vtkmodules.vtkCommonDataModel import vtkUnstructuredGrid
    from vtkmodules.vtkFiltersParallelDIY2 import vtkRedistributeDataSetFilter

    d3 = vtkRedistributeDataSetFilter()
    d3.SetController(comm.controller)
    d3.SetInputData(mesh)
    d3.SetBoundaryModeToAssignToAllIntersectingRegions()
    d3.UseExplicitCutsOn()
    d3.ExpandExplicitCutsOff()
    for lo, hi in boxes:
        d3.AddExplicitCut([lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]])
    d3.Update()
    part = vtkUnstructuredGrid()
    part.ShallowCopy(d3.GetOutputDataObject(0))
    return part


def piece_extent(whole, piece, n, ghosts):
    """VTK's extent of ``piece`` of ``n`` of the ``whole`` extent (the extent
    translator's block split, which readers and the pipeline use) with ``ghosts``
    layers, clipped to the whole extent."""
    from vtkmodules.vtkCommonExecutionModel import vtkExtentTranslator

    translator = vtkExtentTranslator()
    translator.SetWholeExtent(*whole)
    translator.SetPiece(piece)
    translator.SetNumberOfPieces(n)
    translator.SetGhostLevel(ghosts)
    translator.PieceToExtent()
    return tuple(translator.GetExtent())


class ControllerComm(PointToPointComm):
    """A ``vtkMultiProcessController`` (ParaView's MPI processes) as the mpi4py-style
    communicator :mod:`pv_hdrvol.parallel` takes: ``rank``, ``size`` and collectives of
    Python objects, pickled and sent as bytes with ``Send``/``Receive``."""

    TAG = 87113

    def __init__(self, controller):
        self.controller = controller
        self.rank = controller.GetLocalProcessId()
        self.size = controller.GetNumberOfProcesses()

    @classmethod
    def world(cls):
        """The global controller's communicator, or ``None`` without one."""
        from vtkmodules.vtkParallelCore import vtkMultiProcessController

        controller = vtkMultiProcessController.GetGlobalController()
        return None if controller is None else cls(controller)

    def _send(self, value, dest):
        import pickle

        import numpy as np
        from vtkmodules.util.numpy_support import numpy_to_vtk
        from vtkmodules.vtkCommonCore import VTK_UNSIGNED_CHAR

        payload = np.frombuffer(pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL), dtype=np.uint8)
        self.controller.Send(numpy_to_vtk(payload, deep=1, array_type=VTK_UNSIGNED_CHAR), dest, self.TAG)

    def _receive(self, source):
        import pickle

        from vtkmodules.util.numpy_support import vtk_to_numpy
        from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

        payload = vtkUnsignedCharArray()
        self.controller.Receive(payload, source, self.TAG)
        return pickle.loads(vtk_to_numpy(payload).tobytes())


def output_piece(outInfo):
    """The piece of the output the pipeline asks for (0 without pieces)."""
    info = outInfo.GetInformationObject(0)
    return info.Get(_SDDP.UPDATE_PIECE_NUMBER()) if info.Has(_SDDP.UPDATE_PIECE_NUMBER()) else 0


__all__ = ["ControllerComm", "Distribution", "mesh_summary", "output_piece", "piece_extent", "points_owned",
           "redistribute", "share_cores", "tet_grid_of_structured", "used_points", "whole_axes"]
