"""Communicators: what pv_hdrvol's SPMD functions take as ``comm``.

mpi4py's communicators, ``"world"`` (``MPI.COMM_WORLD``), ``None`` (one process) or a
:class:`PointToPointComm` made of sends and receives (VTK's processes).
"""
from __future__ import annotations

WORLD = "world"


class _Serial:
    """The one-rank communicator of ``comm=None``: collectives are identities."""

    rank = 0
    size = 1

    def allgather(self, value):
        return [value]

    def alltoall(self, items):
        return list(items)

    def gather(self, value, root=0):
        return [value]

    def bcast(self, value, root=0):
        return value

    def Get_size(self):
        return 1


class PointToPointComm:
    """mpi4py's collectives of Python objects (``gather``, ``bcast``, ``allgather``,
    ``alltoall``) made of a subclass's ``_send(value, dest)`` and ``_receive(source)``
    in rank order, for processes that can only send and receive (VTK's
    ``vtkMultiProcessController``: ``integrations.vtk_algorithm.ControllerComm``).
    Subclasses set ``rank`` and ``size``."""

    rank = 0
    size = 1

    def gather(self, value, root=0):
        if self.rank != root:
            self._send(value, root)
            return None
        return [value if r == root else self._receive(r) for r in range(self.size)]

    def bcast(self, value, root=0):
        if self.rank != root:
            return self._receive(root)
        for r in range(self.size):
            if r != root:
                self._send(value, r)
        return value

    def allgather(self, value):
        return self.bcast(self.gather(value, 0), 0)

    def alltoall(self, values):
        table = self.gather(list(values), 0)
        if self.rank != 0:
            return self._receive(0)
        for r in range(1, self.size):
            self._send([row[r] for row in table], r)
        return [row[0] for row in table]


def _communicator(comm):
    if comm is None:
        return _Serial()
    if isinstance(comm, str) and comm == WORLD:
        try:
            from mpi4py import MPI
        except ImportError:
            raise ImportError("render_parallel(comm='world') needs mpi4py (pip install mpi4py mpich); "
                              "comm=None renders serially") from None
        return MPI.COMM_WORLD
    if not all(hasattr(comm, name) for name in ("rank", "size", "allgather", "alltoall", "gather", "bcast")):
        raise TypeError(f"comm must be an mpi4py communicator, 'world' or None; got {type(comm).__name__}")
    return comm
