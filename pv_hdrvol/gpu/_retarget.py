"""The CPU kernels' own source, compiled for CUDA.

A kernel of ``raycast/`` is a numba CPU dispatcher whose Python function refers to
other dispatchers and to *stubs* (plain functions marked ``compiled_only``), which
numba's ``@overload`` resolves at compile time by the argument types. The CUDA target
cannot take all of them as they are: numba-cuda's typing fails on overloads declared
``inline="always"`` (the stencil, the warp, the lighting), and the CUDA simulator
(``NUMBA_ENABLE_CUDASIM=1``), which runs device code as Python, can call neither a stub
nor a CPU dispatcher given device arrays.

:class:`Retarget` therefore rebuilds a function with the same code object and a copy of
its globals in which every dispatcher it calls is retargeted in turn and every stub is
replaced by the implementation the caller chose for this variant (precision, shading):
the overload's own implementation, taken from its generator. The result is decorated by
``decorate`` (``numba.cuda.jit(device=True)``). Nothing is copied by hand: the samples,
their order and the arithmetic are the CPU loop's, so a GPU render equals the CPU's to
rounding (fused multiply-adds may differ).
"""
from __future__ import annotations

import types

from numba.core.dispatcher import Dispatcher


class Retarget:
    """Retarget functions for one kernel variant.

    Parameters
    ----------
    decorate : callable
        Turns a Python function into a device function (``cuda.jit(device=True)``).
    resolve : dict
        Stub function -> the Python implementation to use in its place.
    inject : dict
        Names to add to every rebuilt function's globals (``cuda``, constants).
    """

    def __init__(self, decorate, resolve, inject=None):
        self._decorate = decorate
        self._resolve = dict(resolve)
        self._inject = dict(inject or {})
        self._done = {}

    def source(self, fn):
        """``fn`` rebuilt with retargeted globals, not decorated (for kernels)."""
        fn = getattr(fn, "py_func", fn)
        glob = dict(fn.__globals__)
        glob.update(self._inject)
        for name in fn.__code__.co_names:
            obj = glob.get(name)
            if obj is None or isinstance(obj, (int, float, str, bool, types.ModuleType)):
                continue
            try:
                stub = obj in self._resolve
            except TypeError:  # unhashable: not a function
                continue
            if stub:
                glob[name] = self(self._resolve[obj])
            elif isinstance(obj, Dispatcher):
                glob[name] = self(obj.py_func)
            elif getattr(obj, "compiled_only", False):
                raise TypeError(f"{fn.__qualname__} calls the overloaded {obj.__qualname__}, which this variant "
                                "does not resolve")
        closure = fn.__closure__
        return types.FunctionType(fn.__code__, glob, fn.__name__, fn.__defaults__, closure)

    def __call__(self, fn):
        """The device function of ``fn`` (a dispatcher or a Python function)."""
        fn = getattr(fn, "py_func", fn)
        device = self._done.get(fn)
        if device is None:
            device = self._decorate(self.source(fn))
            self._done[fn] = device
        return device
