"""Under CI a skip fails unless declared (tests/conftest.py, docs/development.md "Skips
under CI"): a pytest run in a scratch folder with this suite's conftest.py."""
import pathlib

import pytest

pytestmark = pytest.mark.core
pytest_plugins = ["pytester"]

CONFTEST = pathlib.Path(__file__).resolve().parents[1] / "conftest.py"

TESTS = '''
import pytest

def test_plain_skip():
    pytest.skip("no tool")

def test_importorskip_of_a_missing_module():
    pytest.importorskip("pv_hdrvol_no_such_module")

def test_importorskip_of_a_module_absent_on_purpose():
    pytest.importorskip("pv_hdrvol_absent.sub")

@pytest.mark.expected_skip(reason="a one-core machine")
def test_declared():
    pytest.skip("numba's pool has one thread")

@pytest.mark.expected_skip
def test_declared_without_a_reason():
    pytest.skip("why?")

@pytest.fixture
def skipping():
    pytest.skip("a fixture skips")

def test_skipped_by_a_fixture(skipping):
    pass

@pytest.mark.xfail(reason="known")
def test_xfail():
    assert False

def test_passes():
    pass
'''


def _run(pytester, monkeypatch, ci):
    pytester.makeconftest(CONFTEST.read_text())
    pytester.makepyfile(test_cases=TESTS, test_skipped_module="import pytest\n"
                        "pytest.importorskip('pv_hdrvol_no_such_module')\n\ndef test_never_runs():\n    pass\n")
    monkeypatch.delenv("CI", raising=False)
    if ci:
        monkeypatch.setenv("CI", "true")
    monkeypatch.setenv("PV_HDRVOL_ABSENT_MODULES", "pv_hdrvol_absent another")
    return pytester.runpytest_subprocess("-p", "no:cacheprovider", "-rA")


def test_without_ci_skips_stay_skips(pytester, monkeypatch):
    result = _run(pytester, monkeypatch, ci=False)
    result.assert_outcomes(passed=1, skipped=7, xfailed=1)


def test_under_ci_only_declared_skips_skip(pytester, monkeypatch):
    result = _run(pytester, monkeypatch, ci=True)
    result.assert_outcomes(passed=1, skipped=2, failed=4, errors=1, xfailed=1)
    text = result.stdout.str()
    # (pytest 7's summary lines name the test only: the messages are checked apart)
    for line in ("SKIPPED * test_cases.py:* could not import 'pv_hdrvol_absent.sub'*",
                 "SKIPPED * test_cases.py:* numba's pool has one thread",
                 "FAILED test_cases.py::test_plain_skip*",
                 "FAILED test_cases.py::test_importorskip_of_a_missing_module*",
                 "FAILED test_cases.py::test_declared_without_a_reason*",
                 "ERROR test_cases.py::test_skipped_by_a_fixture*",
                 "FAILED test_skipped_module.py::skipped-module*",
                 "*skipped under CI: no tool (CI installs everything the suite needs*",
                 "*skipped under CI: could not import 'pv_hdrvol_no_such_module'*",
                 "*why? (expected_skip needs a reason=)*", "*skipped under CI: a fixture skips*"):
        result.stdout.fnmatch_lines([line])
    assert "test_never_runs" not in text
