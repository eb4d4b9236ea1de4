"""Lets ParaView 5.11's Python plugins load on Python 3.11 and later.

ParaView 5.11's ``paraview/detail/pythonalgorithm.py`` imports ``inspect.getargspec``,
which Python 3.11 removed, so no Python plugin loads as shipped (Debian bookworm's
ParaView 5.11 with Python 3.11). ParaView imports that module before it runs a plugin
file, so the fix must come first, from the environment: Python imports this
``sitecustomize`` at start-up when this folder is on ``PYTHONPATH`` (in ParaView's GUI,
pvpython, pvbatch and every MPI rank). It only adds the missing name: on ParaView 5.12
and later, or Python 3.10 and earlier, it changes nothing.

``pv-hdrvol paraview`` prints the environment that puts this folder on PYTHONPATH.
"""
import inspect

if not hasattr(inspect, "getargspec"):
    # pythonalgorithm uses only ``getargspec(f).args``, which getfullargspec has too
    inspect.getargspec = inspect.getfullargspec
