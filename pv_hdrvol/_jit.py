"""The numba decorators every kernel module uses: one compilation policy for the package.

nogil (threads of the caller can run kernels in parallel), an on-disk cache (start-up
stays fast), numpy's error model (division by zero gives inf/NaN, never raises).
"""
from __future__ import annotations

import numba
import numpy as np

#: Options of every kernel (also for ``numba.extending.overload(jit_options=...)``).
JIT_OPTIONS = {"nogil": True, "cache": True, "error_model": "numpy", "fastmath": False}
#: The fast-math flags of :func:`fused_kernel`.
FUSED = ("contract",)
#: :data:`JIT_OPTIONS` of a fused kernel (also for ``overload(jit_options=...)``).
FUSED_JIT_OPTIONS = dict(JIT_OPTIONS, fastmath=set(FUSED))


def kernel(fn):
    """The decorator of every serial kernel."""
    return numba.njit(**JIT_OPTIONS)(fn)


def inline_kernel(fn):
    """For small per-sample helpers: inlined at numba IR level into their caller."""
    return numba.njit(inline="always", **JIT_OPTIONS)(fn)


#: Whether :func:`helper_kernel` inlines at numba IR level: numba before 0.57 (Debian
#: bookworm's 0.56, ParaView 5.11's Python) compiles nested IR-level inlining very
#: slowly: the boundary rasteriser's ``_plucker_hit`` took 83.7 s to compile, 1.7 s as
#: plain calls; a first Blunt Fin render 230 s, 25 s; the tone mapper 12.7 s, 3.1 s
#: (docs/performance.md).
IR_INLINE_HELPERS = tuple(int(x) for x in numba.__version__.split(".")[:2]) >= (0, 57)


def helper_kernel(fn):
    """For the per-sample helpers of kernels that are not fused (tetrahedra, boundary
    rasteriser, tone mapping): as :func:`inline_kernel` on numba >= 0.57, a plain kernel
    on older numba (LLVM inlines the call; the same arithmetic, as the callers are not
    fused). The grid kernels' helpers stay :func:`inline_kernel`: inside a
    :func:`fused_kernel` they take its flags, and two grid paths give the same bits."""
    if not IR_INLINE_HELPERS:
        return numba.njit(**JIT_OPTIONS)(fn)
    return numba.njit(inline="always", **JIT_OPTIONS)(fn)


def fused_kernel(fn):
    """As :func:`kernel`, with multiply-adds fused into FMA instructions (LLVM's
    ``contract``, the only fast-math flag used): one rounding instead of two, and shorter
    dependency chains in per-sample loops. Nothing is reordered or assumed finite.

    Every kernel states ``fastmath`` explicitly: numba lets a callee that does not state
    a flag inherit the caller's, so a helper called from a fused kernel would otherwise
    be compiled (and cached) fused, and give other bits when called from elsewhere.
    Code inlined at numba IR level (``inline_kernel``, inline overloads) takes the
    caller's flags."""
    return numba.njit(**FUSED_JIT_OPTIONS)(fn)


def fused_parallel_kernel(fn):
    """:func:`fused_kernel` with ``numba.prange``."""
    return numba.njit(parallel=True, **FUSED_JIT_OPTIONS)(fn)


def parallel_kernel(fn):
    """As :func:`kernel`, with ``numba.prange`` over pixels, rows or tiles."""
    return numba.njit(parallel=True, **JIT_OPTIONS)(fn)


@inline_kernel
def uindex(i):
    """An index known to be >= 0, as uint64: numba then emits no negative-index
    wraparound (a compare and a conditional move per load)."""
    return np.uint64(i)


#: Stubs: plain functions that stand for an implementation numba chooses by the argument
#: types when a kernel compiles (:func:`compiled_only`), each declared with
#: :func:`stub_overload`. ``pv_hdrvol.gpu`` resolves every one of them per variant from
#: this list.
STUBS = []


def compiled_only(fn):
    """Mark ``fn`` a stub (``fn.compiled_only``): its body only raises; numba compiles the
    implementation :func:`stub_overload` declares for it."""
    fn.compiled_only = True
    return fn


def stub_overload(stub, **options):
    """``numba.extending.overload(stub, **options)`` that also keeps the implementation's
    generator on the stub (``stub.implementation``) and the stub in :data:`STUBS`."""
    from numba.extending import overload

    if not getattr(stub, "compiled_only", False):
        raise TypeError(f"{stub.__qualname__} is not marked compiled_only")

    def register(generator):
        stub.implementation = generator
        STUBS.append(stub)
        return overload(stub, **options)(generator)

    return register
