"""Shared pytest fixtures.

This file is imported by every test run, including the core run under Debian's
``/usr/bin/python3`` (numpy 1.24, numba 0.56, no pyvista/vtk/OpenEXR): it must import
only the standard library and pytest, and it must not change numba's settings.
See docs/development.md for the test conventions (the ``core`` marker).
"""
import os
import pathlib
import re

import pytest

#: tests/paraview/ runs inside ParaView's pvbatch (tests/paraview/run.py sets
#: PV_HDRVOL_IN_PARAVIEW); the main suite runs it from tests/integrations/test_paraview.py instead.
collect_ignore = [] if os.environ.get("PV_HDRVOL_IN_PARAVIEW") else ["paraview"]

#: Root of the repository (the folder holding pyproject.toml).
REPO_ROOT = pathlib.Path(__file__).resolve().parent.parent

#: The project's shared datasets: ``../shared/data`` beside the repository.
SHARED_DATA = REPO_ROOT.parent / "shared" / "data"


#: Top-level modules that this run lacks on purpose, separated by spaces (.ci/run sets
#: it for the core run under Debian's /usr/bin/python3: pyvista, OpenEXR...). Under CI a
#: skip is a failure unless the test declares it expected (``expected_skip``) or it is an
#: ``importorskip`` of one of these.
ABSENT_MODULES_VARIABLE = "PV_HDRVOL_ABSENT_MODULES"

#: The reason ``pytest.importorskip`` gives: "could not import 'scipy.special': ..."
_IMPORTORSKIP = re.compile(r"could not import '([^'.]+)")


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "expected_skip(reason): a skip of this test (or of every test of the module or class) is "
                   "expected under CI; any other skip fails when CI is set (tests/conftest.py)")


def _absent_modules():
    return set(os.environ.get(ABSENT_MODULES_VARIABLE, "").split())


def _skip_reason(report):
    longrepr = report.longrepr
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        return str(longrepr[2]).replace("Skipped: ", "", 1)
    return str(longrepr)


def _unexpected_skip(node, report):
    """Why ``report``'s skip must fail this CI run, or None when it may skip: not
    under CI, an xfail, a test marked ``expected_skip`` (with a reason), or an
    ``importorskip`` of a module this run lacks on purpose."""
    if not in_ci() or not report.skipped or hasattr(report, "wasxfail"):
        return None
    reason = _skip_reason(report)
    marker = node.get_closest_marker("expected_skip")
    if marker is not None:
        if not (marker.kwargs.get("reason") or marker.args):
            return f"{reason} (expected_skip needs a reason=)"
        return None
    found = _IMPORTORSKIP.search(reason)
    if found and found.group(1) in _absent_modules():
        return None
    return (f"skipped under CI: {reason} (CI installs everything the suite needs: a skip there is a failure "
            f"unless the test is marked expected_skip(reason=...), or an importorskip of a module named in "
            f"{ABSENT_MODULES_VARIABLE}; see docs/development.md)")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    message = _unexpected_skip(item, report)
    if message is not None:
        report.outcome, report.longrepr = "failed", message


class _SkippedModule(pytest.Item):
    """Stands for a module that skipped itself while imported (a module-level
    ``importorskip``) under CI: it fails, and the session goes on."""

    def __init__(self, *, message, **kwargs):
        super().__init__(**kwargs)
        self.message = message

    def runtest(self):
        pytest.fail(self.message, pytrace=False)

    def reportinfo(self):
        return self.fspath, None, self.name


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    report = outcome.get_result()
    message = _unexpected_skip(collector, report)
    if message is not None:
        report.outcome, report.longrepr = "passed", None
        report.result = [_SkippedModule.from_parent(collector, name="skipped-module", message=message)]


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
