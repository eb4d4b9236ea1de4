"""device="cuda" (pv_hdrvol.gpu) without a GPU: the CUDA kernels under numba-cuda's
simulator equal the CPU renders (float64 to 1e-6 relative, as the issue asks; float32
to the same bound, measured at 2e-8), a camera orbit uploads nothing again, every
kernel variant compiles to PTX for an H100/H200 (compute capability 9.0), and a
machine without numba-cuda or a GPU gets an error naming what is missing.

The simulator and the PTX compiler each need a process of their own (the simulator is
chosen when numba.cuda is first imported; the PTX check replaces numba-cuda's device
query), so they run as scripts in tests/gpu/.
"""
import json
import math
import os
import pathlib
import runpy
import subprocess
import sys

import numba
import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.params import RenderOptions
from pv_hdrvol.raycast.grid import GridPlan

HERE = pathlib.Path(__file__).resolve().parent
SIM = HERE / "sim_renders.py"
PTX = HERE / "compile_ptx.py"
#: relative to the CPU image's peak: the issue's bound for float64; float32 measured 1.8e-8
TOLERANCE = {"float64": 1e-6, "float32": 1e-6}


def _env(**extra):
    env = dict(os.environ)
    env.pop("NUMBA_ENABLE_CUDASIM", None)
    env["PYTHONPATH"] = os.pathsep.join([str(HERE.parents[1])] + [p for p in [env.get("PYTHONPATH")] if p])
    env.update(extra)
    return env


def _run(args, env, timeout=600):
    return subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True, timeout=timeout)


# -- options: refused by name before anything of CUDA is imported -------------------------
@pytest.mark.core
def test_device_option_is_validated():
    assert RenderOptions().device == "cpu"
    assert RenderOptions(device="cuda").device == "cuda"
    with pytest.raises(ValueError, match=r"device must be one of \['cpu', 'cuda'\]; got 'gpu'"):
        RenderOptions(device="gpu")
    with pytest.raises(TypeError, match="device must be a string"):
        RenderOptions(device=0)
    with pytest.raises(ValueError, match="device='cuda' composites in float32 or float64; got precision='uint8'"):
        RenderOptions(device="cuda", precision="uint8")


@pytest.mark.core
def test_what_the_gpu_does_not_take_is_refused_by_name():
    vol = np.random.default_rng(0).random((6, 6, 6))
    with pytest.raises(ValueError, match=r"device='cuda' renders uniform grids without labels and gradient opacity; "
                                         r"got gradient_opacity=: render it with device='cpu'"):
        GridPlan(vol, device="cuda", gradient_opacity=(0.0, 1.0))
    with pytest.raises(ValueError, match="got labels="):
        GridPlan(vol, device="cuda", labels=(vol > 0.5).astype(np.uint8))
    grid = hv.volume_from_rectilinear(vol, np.arange(6.0), np.arange(6.0) ** 1.5, np.arange(6.0))
    with pytest.raises(ValueError, match=r"got a rectilinear grid \(axes\)"):
        GridPlan(grid, device="cuda")


def test_an_out_of_core_volume_is_refused_on_the_gpu(tmp_path):
    pytest.importorskip("zarr")
    hv.write_multiscale(np.random.default_rng(0).random((8, 8, 8)).astype(np.float32), tmp_path / "s.ome.zarr")
    volume = hv.open_multiscale(tmp_path / "s.ome.zarr")
    with pytest.raises(ValueError, match=r"device='cuda' is not supported for it yet"):
        hv.render(volume, size=(8, 8), device="cuda")


# -- no numba-cuda, no GPU: a clear error -----------------------------------------------------
@pytest.mark.core
def test_without_numba_cuda_the_error_names_it():
    code = ("import sys; sys.modules['numba_cuda'] = None\n"
            "import numpy as np, pv_hdrvol as hv\n"
            "try:\n    hv.render(np.ones((4, 4, 4)), size=(4, 4), device='cuda')\n"
            "except hv.DeviceUnavailableError as e:\n    print('ERROR', e)\n")
    out = _run(["-c", code], _env())
    assert out.returncode == 0, out.stderr
    assert "ERROR device='cuda' needs numba-cuda, which is not installed" in out.stdout
    assert "pip install 'pv_hdrvol[gpu]'" in out.stdout


def test_without_a_gpu_the_error_names_the_driver():
    pytest.importorskip("numba_cuda")
    code = ("import numpy as np, pv_hdrvol as hv\n"
            "try:\n    hv.render(np.ones((4, 4, 4)), size=(4, 4), device='cuda')\n"
            "except hv.DeviceUnavailableError as e:\n    print('ERROR', e)\n")
    out = _run(["-c", code], _env(CUDA_VISIBLE_DEVICES=""))
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("ERROR device='cuda' found no CUDA GPU: "), out.stdout
    assert "Render with device='cpu' (the default)" in out.stdout


@pytest.mark.core
def test_a_cpu_render_imports_nothing_of_cuda():
    # (numba-cuda's .pth file imports its small _numba_cuda_redirector at start-up)
    code = ("import sys, numpy as np, pv_hdrvol as hv\n"
            "hv.render(np.random.default_rng(0).random((6, 6, 6)), size=(4, 4))\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numba_cuda', 'cuda')\n"
            "             or m.startswith('numba.cuda')))\n")
    out = _run(["-c", code], _env())
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


# -- the simulator against the CPU ---------------------------------------------------------------
@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    pytest.importorskip("numba_cuda")
    out = str(tmp_path_factory.mktemp("gpu") / "sim.npz")
    run = _run([str(SIM), out, "--front-ends"], _env(NUMBA_ENABLE_CUDASIM="1"))
    assert run.returncode == 0, run.stderr[-4000:]
    with open(out + ".json") as f:
        return np.load(out), json.load(f)


CASES = runpy.run_path(str(SIM))["cases"]()


@pytest.mark.parametrize("index, name", list(enumerate(CASES)))
def test_simulator_equals_cpu(simulated, index, name):
    arrays, meta = simulated
    sim = runpy.run_path(str(SIM))
    plan_kw, exec_kw = CASES[name]
    cpu = sim["render"](plan_kw, exec_kw, "cpu")
    gpu_rgba, gpu_depth = arrays[f"{index}_rgba"], arrays[f"{index}_depth"]
    assert gpu_rgba.dtype == cpu.rgba.dtype
    peak = np.abs(cpu.rgba).max()
    assert peak > 0
    err = np.abs(gpu_rgba.astype(np.float64) - cpu.rgba).max() / peak
    assert err <= TOLERANCE[plan_kw.get("precision", "float32")], f"{name}: {err:.3g}"
    assert int(arrays[f"{index}_samples"]) == sim["count"](cpu)
    np.testing.assert_array_equal(np.isfinite(gpu_depth), np.isfinite(cpu.depth))
    np.testing.assert_allclose(gpu_depth[np.isfinite(gpu_depth)], cpu.depth[np.isfinite(cpu.depth)], rtol=1e-12)
    if cpu.value is not None:
        np.testing.assert_allclose(arrays[f"{index}_value"], cpu.value, rtol=1e-12, equal_nan=True)
    assert meta[name]["gpu"] == "numba-cuda simulator"


def test_front_ends_render_on_the_gpu(simulated):
    _, meta = simulated
    fronts = meta["front ends"]
    for name in ("accessor", "vtk", "progressive", "progressive mesh", "cli"):
        assert fronts[name] <= TOLERANCE["float32"], (name, fronts[name])
    assert fronts["cli_device"] == "numba-cuda simulator"


def test_shading_changes_the_simulated_image(simulated):
    arrays, _ = simulated
    names = list(CASES)
    plain, shaded = arrays[f"{names.index('float32')}_rgba"], arrays[f"{names.index('float32 shaded')}_rgba"]
    assert np.abs(plain - shaded).max() > 0.05 * np.abs(plain).max()


def test_a_camera_orbit_uploads_no_volume_again(simulated):
    _, meta = simulated
    first, *orbit = meta["orbit"]
    bricks = 3 * 3 * 3 * 9 ** 3 * 4  # the float32 bricks of 16^3 points: 3^3 bricks of 9^3
    assert first > bricks
    # the camera (21 floats), the rows of tiles and a few bytes of lighting placeholders
    assert all(b < 1024 for b in orbit), orbit


# -- real CUDA lowering, without a GPU ------------------------------------------------------------
def test_every_kernel_variant_compiles_to_ptx_for_compute_capability_9():
    pytest.importorskip("numba_cuda")
    run = _run([str(PTX)], _env())
    assert run.returncode == 0, run.stderr[-4000:]
    lines = dict(line.split(": ") for line in run.stdout.strip().splitlines())
    assert sorted(lines) == sorted(["composite float32", "composite float64", "composite float32 shaded",
                                    "composite float64 shaded", "projection float32", "projection float64",
                                    "tets float32", "tets float64"])
    for name, result in lines.items():
        size, seconds = result.split()
        assert int(size) > 10_000, name


def test_the_stubs_the_gpu_resolves_are_every_stub_of_the_cpu_kernels():
    """A stub (a plain function numba compiles through an overload) is marked
    ``compiled_only`` and declared with ``stub_overload``; the GPU's variants resolve
    every one of them from that list, none typed by hand. Read with ast: every function
    of a kernel module whose body only raises is marked."""
    import ast

    from pv_hdrvol import _jit
    from pv_hdrvol.gpu import _kernels as G
    from pv_hdrvol.raycast import _composite_kernels as C, _kernels as K

    raising = set()
    for path in (pathlib.Path(K.__file__).parent).glob("_*kernels*.py"):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.FunctionDef):
                body = [s for s in node.body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant))]
                if len(body) == 1 and isinstance(body[0], ast.Raise):
                    raising.add(node.name)
                    assert any(getattr(d, "id", None) == "compiled_only" for d in node.decorator_list), node.name
    assert {stub.__name__ for stub in _jit.STUBS} == raising and len(_jit.STUBS) == len(raising) == 19
    markers = [G.marker("float32"), G.marker("float64"), C.projection_marker(C.MAXIMUM, 1.0, 2.0),
               C.projection_marker(C.ADDITIVE, 1.0, math.inf)]
    for marker in markers:
        for shaded in (False, True):
            resolved = G._resolve(numba.typeof(marker), shaded)
            assert set(resolved) == set(_jit.STUBS) | {G._make_light}
            assert all(callable(f) and not getattr(f, "compiled_only", False) for f in resolved.values())
    with pytest.raises(TypeError, match="is not marked compiled_only"):
        _jit.stub_overload(lambda x: x)
