"""Lets ParaView 5.11's Python plugins load on Python 3.11 and later, and zarr 3 import
on Debian bookworm's numpy 1.24.

ParaView 5.11's ``paraview/detail/pythonalgorithm.py`` imports ``inspect.getargspec``,
which Python 3.11 removed, so no Python plugin loads as shipped (Debian bookworm's
ParaView 5.11 with Python 3.11). ParaView imports that module before it runs a plugin
file, so the fix must come first, from the environment: Python imports this
``sitecustomize`` at start-up when this folder is on ``PYTHONPATH`` (in ParaView's GUI,
pvpython, pvbatch and every MPI rank). It only adds the missing name: on ParaView 5.12
and later, or Python 3.10 and earlier, it changes nothing.

zarr 3 (multiresolution stores, ``*.ome.zarr``) reads ``numpy.dtypes``, new in numpy
1.25; bookworm's ParaView runs on numpy 1.24. When numpy is imported, and only if it
lacks it, the module is added as numpy 1.25 makes it: the dtype classes numpy 1.24 has
already (``type(np.dtype("f4"))`` is 1.25's ``numpy.dtypes.Float32DType``), under 1.25's
names. (Done at numpy's import, not zarr's: zarr is a pytest plugin, which pytest
imports through its own import hook.) It can go with numpy 1.24 (Debian trixie has 2.2).

``pv-hdrvol paraview`` prints the environment that puts this folder on PYTHONPATH.
"""
import inspect
import sys

if not hasattr(inspect, "getargspec"):
    # pythonalgorithm uses only ``getargspec(f).args``, which getfullargspec has too
    inspect.getargspec = inspect.getfullargspec

#: numpy 1.25's ``numpy.dtypes`` names and a type code of each
_NUMPY_DTYPES = (("Bool", "?"), ("Int8", "b"), ("UInt8", "B"), ("Int16", "h"), ("UInt16", "H"), ("Int32", "i"),
                 ("UInt32", "I"), ("Int64", "l"), ("UInt64", "L"), ("LongLong", "q"), ("ULongLong", "Q"),
                 ("Float16", "e"), ("Float32", "f"), ("Float64", "d"), ("LongDouble", "g"), ("Complex64", "F"),
                 ("Complex128", "D"), ("CLongDouble", "G"), ("Object", "O"), ("Bytes", "S"), ("Str", "U"),
                 ("Void", "V"), ("DateTime64", "M8"), ("TimeDelta64", "m8"))


def _add_numpy_dtypes(numpy):
    import types

    if hasattr(numpy, "dtypes"):
        return
    module = types.ModuleType("numpy.dtypes", "DType classes (numpy 1.25's numpy.dtypes, added for zarr 3).")
    for name, code in _NUMPY_DTYPES:
        setattr(module, f"{name}DType", type(numpy.dtype(code)))
    numpy.dtypes = module
    sys.modules["numpy.dtypes"] = module


class _AfterNumpy:
    """A meta-path finder for numpy only: it finds numpy as Python would
    (``PathFinder``) and adds ``numpy.dtypes`` once numpy has run; then it leaves
    ``sys.meta_path``. It imports nothing itself."""

    @classmethod
    def find_spec(cls, name, path=None, target=None):
        if name != "numpy":
            return None
        sys.meta_path.remove(cls)
        from importlib.machinery import PathFinder

        spec = PathFinder.find_spec(name, path)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        exec_module = spec.loader.exec_module

        def exec_then_add(module):
            exec_module(module)
            try:
                _add_numpy_dtypes(module)
            except Exception:  # noqa: BLE001 - never break numpy's import; zarr's says what is missing
                pass

        spec.loader.exec_module = exec_then_add
        return spec


if "numpy" not in sys.modules:
    sys.meta_path.insert(0, _AfterNumpy)
