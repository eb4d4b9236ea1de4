"""Test helper: the mpiexec that goes with this Python's mpi4py, and the environment
its ranks run in (tests/parallel/test_parallel.py, tests/outofcore/test_ooc_parallel.py)."""
import os
import sys

import pytest

from conftest import REPO_ROOT, in_ci


def mpiexec():
    """The mpiexec beside this Python: the mpich wheel's for pip's mpi4py, Debian's Open
    MPI one (/usr/bin) for Debian's python3-mpi4py; never a mismatched pair from PATH."""
    try:
        import mpi4py  # noqa: F401 (only whether it is there)
    except ImportError:
        if in_ci():
            pytest.fail("mpi4py is missing (pip install -e '.[test]' installs mpi4py and mpich)", pytrace=False)
        pytest.skip("mpi4py is not installed")
    path = os.path.join(os.path.dirname(sys.executable), "mpiexec")
    if not os.access(path, os.X_OK):
        if in_ci():
            pytest.fail(f"no mpiexec beside {sys.executable} (the mpich wheel installs one)", pytrace=False)
        pytest.skip(f"no mpiexec beside {sys.executable}")
    return path


def mpi_env(**extra):
    # Open MPI (Debian's Python uses /usr/bin/mpiexec) refuses root, and more ranks than
    # cores, without these; MPICH ignores them
    env = dict(os.environ, PYTHONPATH=str(REPO_ROOT), OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", **extra)
    return env
