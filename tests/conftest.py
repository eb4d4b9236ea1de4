"""Shared pytest fixtures.

This file is imported by every test run, including the core run under Debian's
``/usr/bin/python3`` (numpy 1.24, numba 0.56, no pyvista/vtk/OpenEXR): it must import
only the standard library and pytest, and it must not change numba's settings.
See docs/development.md for the test conventions (the ``core`` marker).
"""
import os
import pathlib

import pytest

#: tests/paraview/ runs inside ParaView's pvbatch (tests/paraview/run.py sets
#: PV_HDRVOL_IN_PARAVIEW); the main suite runs it from tests/test_paraview.py instead.
collect_ignore = [] if os.environ.get("PV_HDRVOL_IN_PARAVIEW") else ["paraview"]

#: Root of the repository (the folder holding pyproject.toml).
REPO_ROOT = pathlib.Path(__file__).resolve().parent.parent

#: The project's shared datasets: ``../shared/data`` beside the repository.
SHARED_DATA = REPO_ROOT.parent / "shared" / "data"


def require(ok, message):
    """Skip the test with ``message`` unless ``ok``; under CI, fail it instead (CI
    installs every tool the suite needs)."""
    if not ok:
        if in_ci():
            pytest.fail(message + " (CI is set: .ci/run installs it)", pytrace=False)
        pytest.skip(message)


def in_ci():
    """Whether the ``CI`` environment variable is set to a true value (CI runs do)."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


@pytest.fixture(scope="session")
def shared_data():
    """Path of ``../shared/data`` relative to the repository root.

    When the folder is missing the test is skipped, except under CI (``CI`` set),
    where it fails: a CI run must never pass by skipping its real-data tests.

    Example::

        def test_engine(shared_data):
            path = shared_data / "structured" / "engine_256x256x128_uint8.vti"
    """
    if not SHARED_DATA.is_dir():
        message = f"shared data folder {SHARED_DATA} is missing"
        if in_ci():
            pytest.fail(message + " (CI is set: tests that need it fail instead of skipping)", pytrace=False)
        pytest.skip(message)
    return SHARED_DATA
