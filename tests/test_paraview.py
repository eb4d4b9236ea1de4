"""The ParaView plugin in real ParaView: tests/paraview/pv_*.py run inside pvbatch.

ParaView's Python is another interpreter (Debian's /usr/bin/python3 with numba 0.56 for
ParaView 5.11), so the checks run in a pvbatch subprocess under xvfb-run (Debian's
ParaView renders only under X) with the environment ``pv-hdrvol paraview`` prints:
the getargspec shim and this source tree on PYTHONPATH, nothing else of this
interpreter's. Without pvbatch the test is skipped, except under CI, where it fails.

``PV_HDRVOL_PARAVIEW_SITE``: a folder of extra packages for ParaView's Python (OpenEXR,
installed with ``/usr/bin/python3 -m pip install --no-deps --target DIR OpenEXR``).
``PV_HDRVOL_PARAVIEW_NUMBA_CACHE``: numba's cache folder there (default: the plugin's,
one per numba version); never the folder of this interpreter's numba.
"""
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import REPO_ROOT, in_ci


def _tool(name):
    path = shutil.which(name)
    if path is None:
        message = f"{name} is not installed (apt-get install paraview python3-paraview xvfb xauth)"
        if in_ci():
            pytest.fail(message + " (CI is set: .ci/run installs it)", pytrace=False)
        pytest.skip(message)
    return path


def _paraview_environment():
    """This process's environment with ParaView's Python paths instead of ours."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "NUMBA_CACHE_DIR",
                                                                "PV_PLUGIN_PATH")}
    path = [str(REPO_ROOT / "paraview_plugin" / "shim"), str(REPO_ROOT)]
    if os.environ.get("PV_HDRVOL_PARAVIEW_SITE"):
        path.append(os.environ["PV_HDRVOL_PARAVIEW_SITE"])
    env["PYTHONPATH"] = os.pathsep.join(path)
    env["PYTHONNOUSERSITE"] = "1"
    if os.environ.get("PV_HDRVOL_PARAVIEW_NUMBA_CACHE"):
        env["NUMBA_CACHE_DIR"] = os.environ["PV_HDRVOL_PARAVIEW_NUMBA_CACHE"]
    return env


def _failure_text(output, tail=6000):
    """The end of ``output``, and where it crashed: what was printed before Python's
    "Fatal Python error" (the library's own message: X, OpenGL, LLVM) and the frames
    nearest the crash, which a plain tail cuts off."""
    text = output[-tail:]
    crash = output.find("Fatal Python error")
    if crash >= 0 and crash < len(output) - tail:
        text = f"{output[max(0, crash - 3000):crash + 3000]}\n[...]\n{text}"
    return text


def test_plugin_checks_pass_in_pvbatch(shared_data):
    pvbatch = _tool("pvbatch")
    xvfb_run = _tool("xvfb-run")
    env = _paraview_environment()
    command = [xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", pvbatch,
               str(REPO_ROOT / "tests" / "paraview" / "run.py")]
    done = subprocess.run(command, env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=1800)
    sys.stdout.write(done.stdout[-6000:])
    assert done.returncode == 0, f"pvbatch checks failed (exit {done.returncode}):\n{_failure_text(done.stdout)}"
    summary = done.stdout.strip().splitlines()[-1]
    assert " passed" in summary, summary
    if in_ci():  # a skipped check (no OpenEXR in ParaView's Python) must not pass CI
        assert "skipped" not in summary, summary


def test_one_rank_renders_the_whole_volume_under_mpi(shared_data):
    """``mpiexec -n 2 pvbatch --mpi --symmetric``: each rank's reader holds a piece; rank 0
    renders the whole volume (equal to hv.render), rank 1 outputs an empty image."""
    pvbatch = _tool("pvbatch")
    xvfb_run = _tool("xvfb-run")
    # Debian's mpiexec (Open MPI, which ParaView is built with), not the MPICH one of the
    # mpich wheel that pip's mpi4py uses (first on PATH where pyenv's shims are)
    mpiexec = "/usr/bin/mpiexec" if os.access("/usr/bin/mpiexec", os.X_OK) else _tool("mpiexec")
    env = _paraview_environment()
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", PV_HDRVOL_DATA=str(shared_data))
    command = [xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", mpiexec, "-n", "2", pvbatch, "--mpi", "--symmetric",
               str(REPO_ROOT / "tests" / "paraview" / "mpi_render.py")]
    done = subprocess.run(command, env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=900)
    sys.stdout.write(done.stdout[-4000:])
    assert done.returncode == 0, f"the MPI run failed (exit {done.returncode}):\n{_failure_text(done.stdout, 4000)}"
    for line in ("rank 1: structured/engine_256x256x128_uint8.vti: a piece of",
                 "rank 0: structured/engine_256x256x128_uint8.vti: a piece of",
                 "rank 0: unstructured/bluntfin_187395tets.vtu: a piece of"):
        assert line in done.stdout, line


def test_gui_loads_the_plugin_and_shows_the_image(shared_data, tmp_path):
    """``paraview --script`` under Xvfb with PV_PLUGIN_PATH: the plugin auto-loads, the
    filter runs on the GUI's view camera, and a screenshot shows the tone-mapped image."""
    paraview = _tool("paraview")
    xvfb_run = _tool("xvfb-run")
    env = _paraview_environment()
    shot = tmp_path / "gui.png"
    env.update(PV_PLUGIN_PATH=str(REPO_ROOT / "paraview_plugin"), PV_HDRVOL_DATA=str(shared_data),
               PV_HDRVOL_SCREENSHOT=str(shot))
    # --dr: no saved settings (no first-start dialog waiting for a click)
    command = [xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", paraview, "--dr",
               "--script=" + str(REPO_ROOT / "tests" / "paraview" / "gui_smoke.py")]
    done = subprocess.run(command, env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=600)
    assert done.returncode == 0, f"the GUI script failed (exit {done.returncode}):\n{done.stdout[-4000:]}"
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader

    png = vtkPNGReader()
    png.SetFileName(str(shot))
    png.Update()
    assert png.GetOutput().GetDimensions()[:2] == (400, 300)
    pixels = vtk_to_numpy(png.GetOutput().GetPointData().GetScalars())[:, :3].astype(int)
    # the image (not the view's grey-blue background, not black) covers part of the shot
    warm = (pixels[:, 0] > pixels[:, 2] + 40).mean()  # 0.028 seen: the engine's dense parts
    assert warm > 0.01, f"no rendered volume in the screenshot ({warm:.3f} of the pixels)"
    assert len(np.unique(pixels, axis=0)) > 200  # a picture, not a few flat colours


def test_without_numba_the_plugin_says_so_and_paraview_goes_on(tmp_path):
    pvbatch = _tool("pvbatch")
    fake = tmp_path / "numba"
    fake.mkdir()
    (fake / "__init__.py").write_text("raise ImportError(\"No module named 'numba'\")\n")
    env = _paraview_environment()
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), env["PYTHONPATH"]])
    env.pop("NUMBA_CACHE_DIR", None)
    done = subprocess.run([pvbatch, str(REPO_ROOT / "tests" / "paraview" / "no_numba.py")], env=env,
                          cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-4000:]
    assert "ParaView works on" in done.stdout
    assert "pv_hdrvol plugin: not loaded, No module named 'numba'." in done.stdout
    assert "needs numpy and numba (Debian: apt-get install python3-numba)" in done.stdout
