"""The Examples in docstrings state checkable facts: run them."""
import doctest
import importlib

import pytest

MODULES = [
    "pv_hdrvol.data.transfer",
    "pv_hdrvol.rays.camera",
    "pv_hdrvol.rays.lenses",
    "pv_hdrvol.raycast.grid",
    "pv_hdrvol.raycast.blocks",
    "pv_hdrvol.culling.bound",
    "pv_hdrvol.data.grid",
    "pv_hdrvol.image.hdr",
    "pv_hdrvol.image.tonemap",
    "pv_hdrvol.image.detail",
    "pv_hdrvol.image.views",
    "pv_hdrvol.image.sequence",
    "pv_hdrvol.image.upsample",
    "pv_hdrvol.image.colorbar",
    "pv_hdrvol.settings",
    "pv_hdrvol.datasets",
    "pv_hdrvol.editor.axis",
    "pv_hdrvol.editor.model",
    "pv_hdrvol.viewer.progressive",
    "pv_hdrvol.proxy.generate",
    "pv_hdrvol.proxy.model",
    "pv_hdrvol.proxy.lighting",
    "pv_hdrvol.proxy.proxies",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0
