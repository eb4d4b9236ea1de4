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

    ns = {"__name__": "pv_hdrvol_checks"}  # LoadPlugin fills globals() when given an empty namespace
    simple.LoadPlugin(PLUGIN, ns=ns)
    assert {"HDRVolumeRender", "HDRToneMap", "HDRUpsample"} <= set(ns), sorted(k for k in ns if "HDR" in k)
    return ns
