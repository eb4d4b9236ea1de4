"""Communicators: what pv_hdrvol's SPMD functions take as ``comm``.

mpi4py's communicators, ``"world"`` (``MPI.COMM_WORLD``), ``None`` (one process) or a
:class:`PointToPointComm` made of sends and receives (VTK's processes).
"""
from __future__ import annotations

import os
import socket

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


def as_communicator(comm):
    """``comm`` as a communicator: ``None`` a serial one (one process), ``"world"``
    mpi4py's ``COMM_WORLD``, else an mpi4py communicator as given (checked by the methods
    the renderers call)."""
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


def node_size(comm):
    """How many processes of ``comm`` run on this node, this one included (collective:
    every process of ``comm`` calls it).

    mpi4py communicators split by shared memory (``Split_type(COMM_TYPE_SHARED)``);
    others (VTK's processes, ``comm=None``) compare host names (``allgather``).
    """
    comm = as_communicator(comm)
    if comm.size == 1:
        return 1
    if hasattr(comm, "Split_type"):
        from mpi4py import MPI

        local = comm.Split_type(MPI.COMM_TYPE_SHARED, key=comm.rank)
        try:
            return int(local.Get_size())
        finally:
            local.Free()
    names = comm.allgather(socket.gethostname())
    return names.count(names[comm.rank])


def threads_for(cores, node_cores, local, pool):
    """``(threads, reason)``: numba threads for one of ``local`` processes on a node of
    ``node_cores`` cores, this process allowed on ``cores`` of them (its CPU affinity),
    numba's pool ``pool`` threads: ``max(1, cores // local)``, so that the node runs one
    thread per core; a process the launcher bound to fewer cores than the node has keeps
    them all (they are its share already). Never more than ``pool``.

    Examples
    --------
    >>> threads_for(16, 16, 4, 16)
    (4, '16 cores, 4 processes on this node')
    >>> threads_for(2, 2, 3, 2)[0], threads_for(4, 16, 4, 16)[0]
    (1, 4)
    """
    if cores < node_cores:
        threads, how = cores, f"bound to {cores} of the node's {node_cores} cores"
    else:
        threads, how = max(1, cores // local), f"{cores} cores, {local} process{'es' if local > 1 else ''} on this node"
    return min(threads, pool), how


def rank_threads(comm, environ=None):
    """``(threads, reason)``: the numba threads this process of ``comm`` should run so
    that the processes on its node together run one thread per core (collective).

    ``NUMBA_NUM_THREADS`` in the environment is the user's choice: numba's current count
    is kept. Otherwise :func:`threads_for` of this process's CPU affinity and
    :func:`node_size`.
    """
    import numba

    environ = os.environ if environ is None else environ
    local = node_size(comm)  # first, on every process alike: it is collective
    if "NUMBA_NUM_THREADS" in environ:
        return numba.get_num_threads(), f"NUMBA_NUM_THREADS={environ['NUMBA_NUM_THREADS']}"
    node = os.cpu_count() or 1
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = node
    return threads_for(cores, node, local, numba.config.NUMBA_NUM_THREADS)


def use_rank_threads(comm, threads=None):
    """Set this thread's numba thread count to ``threads``, or by :func:`rank_threads`
    for ``None`` (collective then), and return ``(threads, reason, previous)``.
    ``numba.set_num_threads`` acts on the calling thread only and cannot exceed numba's
    pool (``NUMBA_NUM_THREADS``, by default the machine's cores)."""
    import numba

    previous = numba.get_num_threads()
    if threads is None:
        threads, reason = rank_threads(comm)
    else:
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ValueError(f"threads must be a positive int or None; got {threads!r}")
        if threads > numba.config.NUMBA_NUM_THREADS:
            raise ValueError(f"threads ({threads}) exceeds numba's pool of {numba.config.NUMBA_NUM_THREADS} "
                             f"(NUMBA_NUM_THREADS)")
        reason = f"threads={threads}"
    numba.set_num_threads(threads)
    return threads, reason, previous
