"""Compiling the ray caster's variants ahead of their first use
(pv_hdrvol.integrations.warm): a warmed numba cache serves a later process's render
of other data with the same variant without compiling anything."""
import json
import os
import subprocess
import sys

import pytest

from conftest import REPO_ROOT

pytest.importorskip("vtkmodules")

_RENDER = """
import json, sys
import numpy as np
from numba.core.registry import CPUDispatcher
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonDataModel import vtkImageData
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer
image = vtkImageData()
image.SetDimensions(20, 17, 9)
image.SetSpacing(0.5, 1.0, 2.0)
values = numpy_to_vtk((np.arange(20 * 17 * 9) % 251).astype(np.uint8), deep=True)
values.SetName("v")
image.GetPointData().SetScalars(values)
renderer = HDRVolumeRenderer()
renderer.SetInputDataObject(0, image)
renderer.SetImageSize(31, 17)
renderer.SetCamera("xz")
renderer.SetShade(True)
renderer.Update()
stats = [v.stats for m in list(sys.modules.values()) if m.__name__.startswith("pv_hdrvol")
         for v in vars(m).values() if isinstance(v, CPUDispatcher)]
print(json.dumps({"error": renderer.GetLastError(), "hits": sum(sum(s.cache_hits.values()) for s in stats),
                  "misses": sum(sum(s.cache_misses.values()) for s in stats)}))
"""


def _python(code_or_module, cache, *args):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(REPO_ROOT))
    command = [sys.executable, "-m", code_or_module, *args] if not code_or_module.startswith("\n") else \
        [sys.executable, "-c", code_or_module]
    done = subprocess.run(command, env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=900)
    assert done.returncode == 0, done.stdout[-3000:]
    return done.stdout


def test_a_warmed_cache_serves_a_later_render_without_compiling(tmp_path):
    from pv_hdrvol.integrations.warm import stamp_path, start_in_background

    cache = tmp_path / "numba"
    out = _python("pv_hdrvol.integrations.warm", cache, "--variants", "shaded-grid", "--stamp")
    assert "pv_hdrvol warm: shaded-grid in" in out
    assert os.path.exists(stamp_path(str(cache)))
    # another process, other data (shape, spacing, size, camera), the same variant: all from the cache
    facts = json.loads(_python(_RENDER, cache).strip().splitlines()[-1])
    assert facts["error"] is None and facts["hits"] > 0 and facts["misses"] == 0, facts
    # stamped: nothing to start
    assert start_in_background(str(cache)) is None


def test_unknown_variants_are_refused():
    from pv_hdrvol.integrations.warm import warm

    with pytest.raises(ValueError, match=r"unknown variant 'shaded'; the variants are \['float-grid', 'grid', "
                                         r"'shaded-grid', 'shaded-tets', 'tets', 'tolerance-grid'\]"):
        warm(["shaded"])


@pytest.mark.parametrize("name", ["grid", "float-grid", "tets"])
def test_each_kind_of_warming_data_is_what_the_renderer_takes(name):
    """The data each variant renders (without rendering it: compiling takes a minute)."""
    from vtkmodules.vtkCommonDataModel import VTK_TETRA

    from pv_hdrvol.data.kinds import data_kind
    from pv_hdrvol.integrations.warm import _data

    data = _data(name)
    assert data_kind(data) is not None and data.GetNumberOfPoints() == 216
    values = data.GetPointData().GetScalars()
    assert values.GetName() == "values" and values.GetRange() == (0.0, 250.0)
    assert values.GetDataTypeAsString() == ("unsigned char" if name == "grid" else "float")
    if name == "tets":
        assert data.GetNumberOfCells() > 0 and {data.GetCellType(i) for i in range(data.GetNumberOfCells())} == {
            VTK_TETRA}
