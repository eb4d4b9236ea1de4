"""The numba decorators every kernel module uses: one compilation policy for the package.

nogil (threads of the caller can run kernels in parallel), an on-disk cache (start-up
stays fast), numpy's error model (division by zero gives inf/NaN, never raises).
"""
from __future__ import annotations

import numba
import numpy as np

#: Options of every kernel (also for ``numba.extending.overload(jit_options=...)``).
JIT_OPTIONS = {"nogil": True, "cache": True, "error_model": "numpy"}


def kernel(fn):
    """The decorator of every serial kernel."""
    return numba.njit(**JIT_OPTIONS)(fn)


def inline_kernel(fn):
    """For small per-sample helpers: inlined at numba IR level into their caller."""
    return numba.njit(inline="always", **JIT_OPTIONS)(fn)


def parallel_kernel(fn):
    """As :func:`kernel`, with ``numba.prange`` over pixels, rows or tiles."""
    return numba.njit(parallel=True, **JIT_OPTIONS)(fn)


@inline_kernel
def uindex(i):
    """An index known to be >= 0, as uint64: numba then emits no negative-index
    wraparound (a compare and a conditional move per load)."""
    return np.uint64(i)
