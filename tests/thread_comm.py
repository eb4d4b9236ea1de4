"""Processes as threads for the SPMD tests: ``run_spmd(n, fn)`` calls ``fn(comm)`` in
``n`` threads, each with a :class:`ThreadComm` (mpi4py's collectives through
``pv_hdrvol.parallel.comm.PointToPointComm``; every message pickled, as between
processes), and returns ``(results, errors)``, one of each per rank."""
import pickle
import queue
import threading

from pv_hdrvol.parallel.comm import PointToPointComm

TIMEOUT = 600


class ThreadComm(PointToPointComm):
    def __init__(self, boxes, rank, size):
        self._boxes, self.rank, self.size = boxes, rank, size

    def _send(self, value, dest):
        self._boxes[(self.rank, dest)].put(pickle.dumps(value))

    def _receive(self, source):
        return pickle.loads(self._boxes[(source, self.rank)].get(timeout=TIMEOUT))


def run_spmd(n, fn):
    boxes = {(s, d): queue.Queue() for s in range(n) for d in range(n)}
    results, errors = [None] * n, [None] * n

    def one(rank):
        try:
            results[rank] = fn(ThreadComm(boxes, rank, n))
        except BaseException as e:  # noqa: B902 -- handed to the caller
            errors[rank] = e

    threads = [threading.Thread(target=one, args=(r,)) for r in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(TIMEOUT)
    assert not any(t.is_alive() for t in threads), "an SPMD thread hangs"
    return results, errors
