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
1.25; bookworm's ParaView runs on numpy 1.24. When zarr is first imported, and only if
numpy lacks it, the module is added as numpy 1.25 makes it: the dtype classes numpy
1.24 has already (``type(np.dtype("f4"))`` is 1.25's ``numpy.dtypes.Float32DType``),
under 1.25's names. It can go with numpy 1.24 (Debian trixie has 2.2).

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


def _add_numpy_dtypes():
    import types

    import numpy

    if hasattr(numpy, "dtypes"):
        return
    module = types.ModuleType("numpy.dtypes", "DType classes (numpy 1.25's numpy.dtypes, added for zarr 3).")
    for name, code in _NUMPY_DTYPES:
        setattr(module, f"{name}DType", type(numpy.dtype(code)))
    numpy.dtypes = module
    sys.modules["numpy.dtypes"] = module


class _BeforeZarr:
    """A meta-path finder that finds nothing: it adds ``numpy.dtypes`` when zarr is
    first imported (so a process that never reads a store never imports numpy here),
    then leaves ``sys.meta_path``."""

    @classmethod
    def find_spec(cls, name, path=None, target=None):
        if name == "zarr":
            sys.meta_path.remove(cls)
            try:
                _add_numpy_dtypes()
            except ImportError:  # no numpy: zarr's own import says so
                pass
        return None


sys.meta_path.insert(0, _BeforeZarr)
