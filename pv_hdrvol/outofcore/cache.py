"""Chunks of a store in memory: a fixed pool of slots, filled by loader threads, least
recently used chunks evicted first, never more than ``cache_bytes``.

A slot holds a chunk's points and an apron around them: points ``64 c - 1`` to
``64 c + 65`` of its level on each axis (``SLOT_EDGE`` = 67), so that every sample of a
block reads one slot (``raycast._kernels.stencil``). The loader fills the chunk's own
points; :meth:`ChunkCache.fill_aprons` copies the apron from the neighbouring chunks of
the same level once they are resident too (a chunk's values never change, so an apron
once filled stays valid while the slot holds that chunk).

The pool is one array of ``cache_bytes // chunk_bytes`` slots, allocated once (the
operating system commits its pages as they are first written, so a large budget costs
nothing until it is used). A chunk is *requested* (a slot taken, a read queued on the
loader threads), then *ready* (its values in the slot); the render thread reads ready
slots only. Only the render thread takes and frees slots, and never frees one a render
is using (``pinned``) or that is still being read.
"""
from __future__ import annotations

import collections
import concurrent.futures
import threading

import numpy as np

from ..raycast._kernels import PAGE_SHIFT, SLOT_EDGE

CHUNK = 1 << PAGE_SHIFT
SLOT_VALUES = SLOT_EDGE ** 3
#: The 26 neighbours of a chunk (z, y, x offsets).
_NEIGHBOURS = [(dz, dy, dx) for dz in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dz, dy, dx) != (0, 0, 0)]


def _apron_span(d):
    """Along one axis, for a neighbour at offset ``d``: the slot's points it fills and
    where they are in the neighbour's own slot (both as slices of slot indices). Along an
    axis where it is not offset, the chunk's own points only: each apron point comes
    from the one neighbour that holds it, never from another's apron."""
    if d < 0:
        return slice(0, 1), slice(CHUNK, CHUNK + 1)  # point 64 c - 1: the neighbour's last
    if d > 0:
        return slice(CHUNK + 1, SLOT_EDGE), slice(1, 3)  # points 64 c + 64, + 65: its first two
    return slice(1, CHUNK + 1), slice(1, CHUNK + 1)


class ChunkCache:
    """The resident chunks of a :class:`~pv_hdrvol.outofcore.store.MultiscaleStore`.

    Parameters
    ----------
    store : MultiscaleStore
    cache_bytes : int
        The pool's size; at least enough for the coarsest level, which stays resident.
    dtype : numpy dtype
        What the kernels read (float32, or float64 for float64 renders of float64 data).
    threads : int
        Loader threads.
    """

    def __init__(self, store, cache_bytes, dtype, threads=2):
        if store.chunk != CHUNK:
            raise ValueError(f"the renderer reads chunks of {CHUNK} points a side; the store has {store.chunk}")
        self.store = store
        self.dtype = np.dtype(dtype)
        slot_bytes = SLOT_VALUES * self.dtype.itemsize
        self.n_slots = int(cache_bytes) // slot_bytes
        coarsest = int(np.prod(store.levels[-1].chunks))
        if self.n_slots < coarsest + 8:
            need = (coarsest + 8) * slot_bytes
            raise ValueError(f"cache_bytes={int(cache_bytes)} holds {self.n_slots} chunks of {slot_bytes} bytes; the "
                             f"coarsest level ({coarsest} chunks) and one block's 8 need at least {need} bytes")
        self.cache_bytes = int(cache_bytes)
        self.pool = np.empty(self.n_slots * SLOT_VALUES, dtype=self.dtype)
        # chunk tables: per level, the slot of each chunk (-1: not ready), flat (z, y, x)
        self.bases = np.cumsum([0] + [int(np.prod(lv.chunks)) for lv in store.levels])
        self.slots = np.full(int(self.bases[-1]), -1, dtype=np.int64)
        self._slot_of = {}  # key -> slot, requested or ready
        self._lru = collections.OrderedDict()  # ready keys, least recently used first
        self._loading = {}  # key -> future
        self._free = list(range(self.n_slots - 1, -1, -1))
        self._lock = threading.Lock()
        self._errors = []
        self._apron = {}  # slot -> neighbour offsets whose apron part is filled
        self.bytes_read = [0] * store.n_levels
        self.chunks_read = [0] * store.n_levels
        # +-inf read as the largest/smallest finite value, as an in-memory GridVolume's
        self._finite = store.value_range if np.issubdtype(store.dtype, np.floating) else None
        self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=max(1, int(threads)),
                                                           thread_name_prefix="pv_hdrvol-loader")
        # the coarsest level: read now, never evicted (every block can fall back on it)
        self.permanent = set()
        keys = [(store.n_levels - 1,) + tuple(int(v) for v in idx) for idx in np.ndindex(*store.levels[-1].chunks)]
        self.request(keys)
        self.wait(keys)
        self.permanent.update(keys)

    # -- state ----------------------------------------------------------------------------
    def index(self, key):
        """Position of chunk ``key = (level, cz, cy, cx)`` in :attr:`slots`."""
        level, cz, cy, cx = key
        _, ny, nx = self.store.levels[level].chunks
        return int(self.bases[level]) + (cz * ny + cy) * nx + cx

    def is_ready(self, key):
        return self.slots[self.index(key)] >= 0

    @property
    def resident_bytes(self):
        """Bytes of the pool holding ready chunks."""
        return len(self._lru) * SLOT_VALUES * self.dtype.itemsize

    @property
    def pending(self):
        with self._lock:
            return len(self._loading)

    def raise_errors(self):
        """Raise the first read error of the loader threads (a damaged chunk)."""
        with self._lock:
            if self._errors:
                raise self._errors[0]

    # -- requests -------------------------------------------------------------------------
    def touch(self, keys):
        """Mark ready ``keys`` as just used (the last to be evicted)."""
        with self._lock:
            for key in keys:
                if key in self._lru:
                    self._lru.move_to_end(key)

    def request(self, keys, pinned=()):
        """Queue reads of the ``keys`` not yet requested, in order, while slots last:
        a free slot, else the least recently used ready chunk not in ``pinned`` (nor
        permanent). Reads still queued (not started) for chunks not in ``keys`` are
        dropped first, their slots freed: a view the user has left does not delay the
        one at rest. Returns the number of keys that got no slot (the budget is spent)."""
        self.raise_errors()
        pinned = set(pinned)
        wanted = set(keys)
        with self._lock:
            for key, future in list(self._loading.items()):
                if key not in wanted and future.cancel():
                    del self._loading[key]
                    self._free.append(self._slot_of.pop(key))
        refused = 0
        for key in keys:
            if key in self._slot_of:
                continue
            while True:
                with self._lock:
                    slot = self._take_slot(pinned)
                    loading = list(self._loading.values())
                if slot is not None or not loading:
                    break
                # the slots are held by reads still under way (an earlier frame's): once one
                # is done its chunk may be evicted
                concurrent.futures.wait(loading, return_when=concurrent.futures.FIRST_COMPLETED)
                self.raise_errors()
            if slot is None:
                refused += 1
                continue
            self._slot_of[key] = slot
            with self._lock:
                self._loading[key] = self._pool.submit(self._load, key, slot)
        return refused

    def _take_slot(self, pinned):
        # under the lock: loader threads add to the LRU list
        if self._free:
            return self._free.pop()
        for key in self._lru:
            if key not in pinned and key not in self.permanent:
                del self._lru[key]
                slot = self._slot_of.pop(key)
                self.slots[self.index(key)] = -1
                self._apron.pop(slot, None)
                return slot
        return None

    def _load(self, key, slot):
        level, cz, cy, cx = key
        try:
            block = self.store.read_chunk(level, (cz, cy, cx))
            if self._finite is not None and np.isinf(block).any():
                block = np.where(np.isposinf(block), self._finite[1], np.where(np.isneginf(block), self._finite[0],
                                                                                block))
            view = self.slot_view(slot)
            view[1:1 + block.shape[0], 1:1 + block.shape[1], 1:1 + block.shape[2]] = block
        except BaseException as e:  # noqa: BLE001 - handed to the render thread
            with self._lock:
                self._errors.append(e)
                self._loading.pop(key, None)
            raise
        with self._lock:
            self.bytes_read[level] += block.nbytes
            self.chunks_read[level] += 1
            self._loading.pop(key, None)
            self._lru[key] = None
            self.slots[self.index(key)] = slot  # last: the render thread may use it now

    def slot_view(self, slot):
        """Slot ``slot`` of the pool as a (67, 67, 67) array (z, y, x)."""
        start = slot * SLOT_VALUES
        return self.pool[start:start + SLOT_VALUES].reshape(SLOT_EDGE, SLOT_EDGE, SLOT_EDGE)

    def fill_aprons(self, keys):
        """Copy into the slots of the ready ``keys`` the apron points of each neighbour
        chunk (same level) that is ready too and not yet copied. Render thread only."""
        for key in keys:
            level, cz, cy, cx = key
            slot = int(self.slots[self.index(key)])
            if slot < 0:
                continue
            done = self._apron.setdefault(slot, set())
            if len(done) == len(_NEIGHBOURS):
                continue
            chunks = self.store.levels[level].chunks
            view = None
            for d in _NEIGHBOURS:
                if d in done:
                    continue
                n = (cz + d[0], cy + d[1], cx + d[2])
                if not all(0 <= i < m for i, m in zip(n, chunks)):
                    done.add(d)  # past the volume's edge: the stencil clamps there
                    continue
                other = int(self.slots[self.index((level,) + n)])
                if other < 0:
                    continue
                view = self.slot_view(slot) if view is None else view
                spans = [_apron_span(v) for v in d]
                view[tuple(s[0] for s in spans)] = self.slot_view(other)[tuple(s[1] for s in spans)]
                done.add(d)

    def wait(self, keys=None, timeout=None):
        """Wait until ``keys`` (default: every request) are ready; raise a read error."""
        wanted = None if keys is None else set(keys)
        with self._lock:
            futures = [f for k, f in self._loading.items() if wanted is None or k in wanted]
        concurrent.futures.wait(futures, timeout=timeout)
        self.raise_errors()

    def close(self):
        """Stop the loader threads (queued reads are dropped); the cache is not used after."""
        self._pool.shutdown(wait=True, cancel_futures=True)
        with self._lock:
            for key in list(self._loading):
                self._free.append(self._slot_of.pop(key))
            self._loading.clear()


__all__ = ["CHUNK", "ChunkCache", "SLOT_EDGE", "SLOT_VALUES"]
