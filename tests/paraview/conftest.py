"""Fixtures of the ParaView plugin checks (run inside pvbatch by tests/paraview/run.py)."""
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PLUGIN = os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py")


@pytest.fixture(scope="session")
def plugin():
    """The plugin's proxies by name, loaded once per process as a user does:
    ``LoadPlugin(path, ns=...)``."""
    from paraview import simple

    # OpenGL first, as in the GUI (whose view exists before any filter runs): a render
    # view made before numba (LLVM 14) compiles anything loads Mesa's llvmpipe (LLVM 15)
    # into a clean process. A CI run once aborted creating the first view after
    # minutes of compiling ("Fatal Python error: Aborted" in CreateView), which never
    # happened locally; this keeps the checks off that path and fails at once if X or
    # OpenGL is missing. (Not reproduced here with a cold numba cache, bounds checking and
    # MALLOC_CHECK_=3; tests/integrations/test_paraview.py now prints the text before such a crash.)
    simple.Delete(simple.CreateView("RenderView"))
    ns = {"__name__": "pv_hdrvol_checks"}  # LoadPlugin fills globals() when given an empty namespace
    simple.LoadPlugin(PLUGIN, ns=ns)
    assert {"HDRVolumeRender", "HDRToneMap", "HDRUpsample"} <= set(ns), sorted(k for k in ns if "HDR" in k)
    return ns
