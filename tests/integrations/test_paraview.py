"""The ParaView plugin in real ParaView: tests/paraview/pv_*.py run inside pvbatch.

ParaView's Python is another interpreter (Debian's /usr/bin/python3 with numba 0.56 for
ParaView 5.11), so the checks run in a pvbatch subprocess under xvfb-run (Debian's
ParaView renders only under X) with the environment ``pv-hdrvol paraview`` prints:
the getargspec shim and this source tree on PYTHONPATH, nothing else of this
interpreter's. Without pvbatch the test is skipped, except under CI, where it fails.

``PV_HDRVOL_PARAVIEW_SITE``: a folder of extra packages for ParaView's Python (OpenEXR,
installed with ``/usr/bin/python3 -m pip install --no-deps --target DIR OpenEXR``, and
zarr 3 with the dependencies Debian lacks, for multiresolution stores: .ci/run).
``PV_HDRVOL_PARAVIEW_NUMBA_CACHE``: numba's cache folder there (default: the plugin's,
one per numba version); never the folder of this interpreter's numba.
"""
import contextlib
import os
import shutil
import subprocess
import sys
import time

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
    # no compiling in the background while tests run and time things (one test turns it on)
    env["PV_HDRVOL_WARM"] = "0"
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


@pytest.mark.parametrize("ranks", [2, 3])
def test_ranks_render_their_pieces_under_mpi(shared_data, tmp_path, tmp_path_factory, ranks):
    """``mpiexec -n 2|3 pvbatch --mpi --symmetric`` (tests/paraview/mpi_render.py): with
    the array's colour map each rank reads and renders its piece of the image, or the
    cells of its box of a tetrahedral mesh (read on rank 0, or spread by
    RedistributeDataSet), and rank 0 composites the whole image (hv.render's to 1e-5);
    without a colour map rank 0 renders the whole dataset alone (hv.render's bit for
    bit); the others output empty images. A curvilinear grid is read by pieces and
    rendered as tetrahedra where it lives (hv.render's to 1e-10), a graded rectilinear
    grid on the whole grid's lattice (to 2e-6, the early termination). A multiresolution
    store's level renders as the whole store out of core on rank 0
    (``open_multiscale(...).render``'s bit for bit)."""
    pvbatch = _tool("pvbatch")
    xvfb_run = _tool("xvfb-run")
    # Debian's mpiexec (Open MPI, which ParaView is built with), not the MPICH one of the
    # mpich wheel that pip's mpi4py uses (first on PATH where pyenv's shims are)
    mpiexec = "/usr/bin/mpiexec" if os.access("/usr/bin/mpiexec", os.X_OK) else _tool("mpiexec")
    env = _paraview_environment()
    # more ranks than cores (3 on a 2-core machine): Open MPI refuses them unless told
    inputs = tmp_path_factory.mktemp("grids")
    curvilinear, rectilinear = inputs / "sector.vts", inputs / "graded.vtr"
    _curvilinear_sector().save(curvilinear)
    _graded_grid().save(rectilinear)
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1",
               PV_HDRVOL_DATA=str(shared_data), PV_HDRVOL_MPI_OUT=str(tmp_path),
               PV_HDRVOL_MPI_CURVI=str(curvilinear), PV_HDRVOL_MPI_RECT=str(rectilinear),
               PV_HDRVOL_MPI_STORE=str(inputs / "blob.ome.zarr"))
    command = [xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", mpiexec, "-n", str(ranks), pvbatch, "--mpi",
               "--symmetric",
               str(REPO_ROOT / "tests" / "paraview" / "mpi_render.py")]
    done = subprocess.run(command, env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True, timeout=900)
    sys.stdout.write(done.stdout[-4000:])
    assert done.returncode == 0, f"the MPI run failed (exit {done.returncode}):\n{_failure_text(done.stdout, 4000)}"
    lines = ["rank 1: structured/engine_256x256x128_uint8.vti: a piece of",
             "rank 0: structured/engine_256x256x128_uint8.vti: a piece of",
             "rank 0: unstructured/bluntfin_187395tets.vtu: a piece of",
             f"the whole image of {ranks} pieces, within",
             "rank 0: the array's colour map, within 1e-5 of hv.render with it; render.exr and render.png written",
             "rank 1: the array's colour map; no image, nothing written"]
    lines += [f"rank {r}: read its piece (" for r in range(1, ranks)]
    lines += [f"rank {r}: unstructured/bluntfin_187395tets.vtu from {how}: given" for r in range(ranks)
              for how in ("the reader", "RedistributeDataSet")]
    lines += [f"the whole image of {ranks} boxes, within"]
    lines += ["rank 0: a store's level in: the store out of core, open_multiscale's render bit for bit"]
    lines += [f"rank {r}: a store's level in: no image" for r in range(1, ranks)]
    lines += [f"rank {r}: {kind} piece (" for r in range(ranks) for kind in ("curvilinear", "rectilinear")]
    for line in lines:
        assert line in done.stdout, line
    assert sorted(os.listdir(tmp_path)) == ["render.exr", "render.png"]
    for bad in ("Traceback", "outside the whole extent", "is not set (no colour map"):
        assert bad not in done.stdout, f"{bad!r} in the output:\n{done.stdout[-3000:]}"


def _graded_grid():
    """A rectilinear grid graded 3x along x and 2x along y (25 x 21 x 15 points), ``f``."""
    import pyvista as pv

    def graded(n, ratio):
        s = np.linspace(-1.0, 1.0, n - 1)
        return np.concatenate([[0.0], np.cumsum(1.0 + (ratio - 1.0) * s * s)]) / n

    grid = pv.RectilinearGrid(graded(25, 3.0), graded(21, 2.0), graded(15, 1.0))
    p = grid.points
    grid["f"] = np.exp(-((p[:, 0] - 0.5) ** 2 + (p[:, 1] - 0.4) ** 2 + (p[:, 2] - 0.6) ** 2) * 8.0)
    return grid


def _curvilinear_sector():
    """A curvilinear grid (a curved, sheared annular sector, 21 x 17 x 13 points) with a
    smooth field ``f``."""
    import pyvista as pv

    i, j, k = np.meshgrid(np.linspace(0, 1, 21), np.linspace(0, 1, 17), np.linspace(0, 1, 13), indexing="ij")
    radius, angle = 1.0 + i, 1.4 * j
    grid = pv.StructuredGrid(radius * np.cos(angle), radius * np.sin(angle), 0.8 * k + 0.1 * np.sin(3 * i))
    p = grid.points
    grid["f"] = np.exp(-((p[:, 0] - 0.8) ** 2 + (p[:, 1] - 0.9) ** 2 + (p[:, 2] - 0.4) ** 2) * 3.0)
    return grid


def test_an_mpiexec_of_another_mpi_is_named():
    """MPICH's mpiexec (pip's ``mpich``, in the test extras) starts pvbatch as independent
    serial processes, since Debian's ParaView uses Open MPI: each says so at plugin load;
    under Open MPI's /usr/bin/mpiexec nothing is said."""
    import glob

    pvbatch = _tool("pvbatch")
    candidates = [path for path in glob.glob(os.path.join(os.path.dirname(sys.executable), "mpiexec*"))
                  if os.path.basename(path) in ("mpiexec", "mpiexec.hydra")]
    assert candidates, f"no MPICH mpiexec beside {sys.executable} (pip install mpich: the test extras have it)"
    env = _paraview_environment()
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    for mpiexec, named in ((candidates[0], True), ("/usr/bin/mpiexec", False)):
        done = subprocess.run([mpiexec, "-n", "2", pvbatch, "--mpi", "--symmetric",
                               str(REPO_ROOT / "tests" / "paraview" / "load_only.py")], env=env, cwd=REPO_ROOT,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=300)
        assert done.returncode == 0, (mpiexec, done.stdout[-3000:])
        assert done.stdout.count(f"loaded: True, named the mpiexec: {named}") == 2, (mpiexec, done.stdout[-3000:])


def test_client_server(shared_data):
    """``pvserver`` and ``pvpython`` connected over the loopback: the filter runs on the
    server, the plugin's client side links the view's camera and the array's colour map
    (tests/paraview/client_server.py)."""
    import socket
    import threading

    pvserver, pvpython, xvfb_run = _tool("pvserver"), _tool("pvpython"), _tool("xvfb-run")
    with socket.socket() as probe:  # a free port on the loopback
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    env = _paraview_environment()
    env.update(PV_HDRVOL_DATA=str(shared_data))
    # a process group of its own: xvfb-run, its Xvfb and pvserver are ended together
    server = subprocess.Popen([xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", pvserver, f"--server-port={port}",
                               "--timeout=10"], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              start_new_session=True)
    lines, reader = [], None
    try:
        for line in server.stdout:  # wait until it listens
            lines.append(line)
            if "Accepting connection" in line:
                break
        else:
            raise AssertionError("pvserver did not start:\n" + "".join(lines))
        # its output read on while the client runs: a full pipe would stall the server
        reader = threading.Thread(target=lambda: lines.extend(server.stdout), daemon=True)
        reader.start()
        done = subprocess.run([xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", pvpython,
                               str(REPO_ROOT / "tests" / "paraview" / "client_server.py"), str(port)], env=env,
                              cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=900)
    finally:
        import signal

        ended = server.poll()  # not None: the server ended before the client was done
        # SIGTERM first: Xvfb removes its /tmp/.X*-lock only when it ends by itself
        with contextlib.suppress(ProcessLookupError):
            os.killpg(server.pid, signal.SIGTERM)
        try:
            server.wait(10)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(server.pid, signal.SIGKILL)
            server.wait()
        if reader is not None:
            reader.join(timeout=10)
        server_output = "".join(lines)
    # a server that ended by itself (a crash) says why in its own output, not the client's
    assert done.returncode == 0, (f"the client failed (exit {done.returncode}):\n{_failure_text(done.stdout, 3000)}\n"
                                  f"the server {'exited ' + str(ended) if ended is not None else 'was running'}:\n"
                                  f"{_failure_text(server_output, 4000)}")
    assert ("client-server: the array's colour map and the view's camera; the image equals hv.render"
            in done.stdout), done.stdout[-3000:]


#: Typed into ParaView's Python Shell: what the GUI holds, for the test to read: the
#: view's camera, the array's colour map and opacity function as their points, and the
#: filter's settings, from which the test renders the reference itself (hv.render)
_EXPORT = ("import json; r = FindSource('HDRVolumeRender1'); v = GetActiveView(); "
           "SaveData('{dir}/image{n}.vti', OutputPort(r, 0)); "
           "lut = GetColorTransferFunction('ImageFile'); pwf = GetOpacityTransferFunction('ImageFile'); "
           "json.dump(dict(view_size=list(v.ViewSize), camera=list(v.CameraPosition), "
           "filter_camera=list(r.CameraPosition), image_size=list(r.ImageSize), "
           "lut=r.LookupTable.SMProxy.GetGlobalIDAsString() if r.LookupTable else None, "
           "array_lut=lut.SMProxy.GetGlobalIDAsString(), "
           "pwf=r.ScalarOpacityFunction.SMProxy.GetGlobalIDAsString() if r.ScalarOpacityFunction else None, "
           "array_pwf=pwf.SMProxy.GetGlobalIDAsString(), "
           "view_camera=[list(v.CameraPosition), list(v.CameraFocalPoint), list(v.CameraViewUp), "
           "v.CameraViewAngle, v.CameraParallelProjection, v.CameraParallelScale], "
           "filter_camera_fields=[list(r.CameraPosition), list(r.CameraFocalPoint), list(r.CameraViewUp), "
           "r.CameraViewAngle, r.CameraParallelProjection, r.CameraParallelScale], "
           "rgb_points=list(lut.RGBPoints), color_space=lut.ColorSpace, lut_log=lut.UseLogScale, "
           "opacity_points=list(pwf.Points), opacity_log=pwf.UseLogScale, "
           "settings=dict((k, r.GetPropertyValue(k)) for k in ('Precision', 'Step', 'GlobalAlpha', "
           "'OpacityUnitDistance', 'Blending', 'Shade', 'Lens', 'TransferFunction', 'DisplayToneMap', "
           "'POFFile')), scalars=list(r.Scalars), "
           "clip=[r.Clip, list(r.ClipOrigin), list(r.ClipNormal)], "
           "connections=len(servermanager.Connections), "
           "legends=sorted([b.Title, b.ComponentTitle, b.LookupTable.SMProxy.GetGlobalIDAsString()] for b in "
           "servermanager.ProxyManager().GetProxiesInGroup('scalar_bars').values() if b.Visibility)), open('{dir}/state{n}.part', 'w'), default=lambda p: p.GetData()); "
           "import os; os.replace('{dir}/state{n}.part', '{dir}/state{n}.json')")  # whole when it appears

#: The filter's settings the reference render assumes (its defaults)
_DEFAULT_SETTINGS = {"Precision": "float32", "Step": 0.5, "GlobalAlpha": 1.0, "OpacityUnitDistance": 0.0,
                     "Blending": "composite", "Shade": 0, "Lens": "none", "TransferFunction": "Color Map Editor",
                     "DisplayToneMap": "knee", "POFFile": ""}


def _exported(folder, n):
    """The HDR image (row 0 at the top) and the facts the Python Shell wrote."""
    import json

    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    reader = vtkXMLImageDataReader()
    reader.SetFileName(str(folder / f"image{n}.vti"))
    reader.Update()
    image = reader.GetOutput()
    cols, rows, _ = image.GetDimensions()
    data = image.GetPointData()
    rgba = vtk_to_numpy(data.GetArray("rgba")).reshape(rows, cols, 4)[::-1]
    shown = vtk_to_numpy(data.GetArray("tonemapped")).reshape(rows, cols, 3)[::-1]
    return rgba, shown, json.loads((folder / f"state{n}.json").read_text())


def _start_gui(args, tmp_path, **screen):
    """ParaView's GUI with the plugin on PV_PLUGIN_PATH, on a private Xvfb."""
    paraview = _tool("paraview")
    for tool in ("Xvfb", "xdotool"):
        _tool(tool)
    from paraview_gui import ParaViewGUI

    env = _paraview_environment()
    env.update(PV_PLUGIN_PATH=str(REPO_ROOT / "paraview_plugin"))
    gui = ParaViewGUI([paraview, "--dr", *args], env, tmp_path / "paraview.log", tmp_path, **screen)
    gui.wait_for_window()
    return gui


def _open_python_shell(gui):
    gui.menu(100, [])  # View > Python Shell
    gui.click(149, 386)
    time.sleep(3)


def _export(gui, folder, n, shell_input=(700, 600)):
    """Type the export line into the Python Shell (its input line at ``shell_input``,
    by default where it is in the default layout); the image and facts it wrote."""
    gui.click(*shell_input)  # the Python Shell's input (a drag leaves the focus on the view)
    gui.type_line(_EXPORT.format(dir=folder, n=n))
    gui.wait_for(f"the Python Shell's export {n}", lambda: (folder / f"state{n}.json").exists(), 400)
    return _exported(folder, n)


def _functions_of(state):
    """The array's colour and opacity functions the GUI exported (``state``), rebuilt as
    ``vtkColorTransferFunction`` and ``vtkPiecewiseFunction``."""
    from vtkmodules.vtkCommonDataModel import vtkPiecewiseFunction
    from vtkmodules.vtkRenderingCore import vtkColorTransferFunction

    ctf = vtkColorTransferFunction()
    for x, r, g, b in np.reshape(state["rgb_points"], (-1, 4)):
        ctf.AddRGBPoint(x, r, g, b)
    getattr(ctf, f"SetColorSpaceTo{state['color_space']}")()
    ctf.SetScale(int(state["lut_log"]))
    pwf = vtkPiecewiseFunction()
    for x, a, midpoint, sharpness in np.reshape(state["opacity_points"], (-1, 4)):
        pwf.AddPoint(x, a, midpoint, sharpness)
    pwf.SetUseLogScale(int(state["opacity_log"]))
    return ctf, pwf


def _reference(shared_data, state, **clip):
    """The render the GUI should show, made here with the library: hv.render of the
    engine for the view's camera and size and the array's colour map and opacity
    function (their points, rebuilt in this process's VTK), tone mapped as the
    filter's display (knee, unencoded)."""
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    import pv_hdrvol as hv
    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    assert state["settings"] == _DEFAULT_SETTINGS, state["settings"]
    assert state["scalars"] == ["POINTS", "ImageFile"], state["scalars"]
    assert state["filter_camera_fields"] == state["view_camera"]
    assert (state["lut"], state["pwf"]) == (state["array_lut"], state["array_pwf"]), \
        "HDR Volume Render does not use the array's colour map and opacity function"
    ctf, pwf = _functions_of(state)
    reader = vtkXMLImageDataReader()
    reader.SetFileName(str(shared_data / "structured" / "engine_256x256x128_uint8.vti"))
    reader.Update()
    position, focal_point, view_up, angle, parallel, scale = state["view_camera"]
    camera = hv.Camera(position, focal_point, view_up, view_angle=angle, parallel_projection=bool(parallel),
                       parallel_scale=scale)
    return hv.render(reader.GetOutput(), transfer_function_from_vtk(ctf, pwf), camera, tuple(state["view_size"]),
                     scalars="ImageFile", precision="float32", progress_bar=False, **clip)


def _on_screen(gui, reference, rgba, name, control=None):
    """The filter's output is the reference render (to float32 rounding across numba
    versions), and the screen shows it pixel for pixel: wait until, over the pixels the
    render covers, the view shows the reference tone mapped and blended as the view
    draws it (paraview_gui.screen_model) within 1 level on 88 % of them, and within 1
    level of the range of each pixel's 3x3 neighbourhood on 96 % (measured in the four
    views of the two GUI tests: 92.5-94.4 % and 97.6-98.6 %; the rest are sharp edges
    drawn as a mix of neighbours, and ParaView's outline of the input drawn over the
    render). ``control``, another render, must not match there (measured: the previous
    view's render 0.6-1.2 %, a picture 2 % darker 29 %). The filter's output equals the
    render made here to 1e-6 (measured 6e-8: numba 0.56 in ParaView, this one here)."""
    from paraview_gui import screen_match, screen_model

    print(f"{name}: filter output against hv.render here: largest difference "
          f"{np.abs(rgba.astype(np.float64) - reference.rgba).max():.3g}")
    np.testing.assert_allclose(rgba, reference.rgba, rtol=0, atol=1e-6)  # measured 6e-8
    alpha = reference.rgba[..., 3]
    assert (alpha >= 0.999).sum() > 2000, f"only {(alpha >= 0.999).sum()} opaque pixels in the render"
    expected, covered = screen_model(reference)
    assert len(np.unique(expected[alpha >= 0.999], axis=0)) > 50  # a picture, not a few flat colours
    found = []

    def matches():
        found[:] = screen_match(gui.screenshot(name), expected, covered)
        return found[2] >= 0.88 and found[3] >= 0.96

    try:
        gui.wait_for(f"the render on screen ({name})", matches, 120, interval=2.0)
    finally:
        if found:
            print(f"{name}: at {found[:2]}, {found[2]:.4f} of the pixels within 1 level, {found[3]:.4f} of their "
                  f"neighbourhoods'")
    if control is not None:
        other, other_covered = screen_model(control)
        same = screen_match(gui.screenshot(f"control_{name}"), other, other_covered, at=found[:2])[2]
        print(f"{name}: the control matches {same:.4f}")
        assert same < 0.5, f"another render matches the screen too ({same:.2f} of its pixels)"
    return found


def _panel_lists(gui, label):
    """Whether the Properties panel shows a property labelled ``label``: typed into its
    search box, the panel differs from the panel for a search that matches nothing
    (the advanced properties stay hidden: the gear is off). The search is cleared."""
    from paraview_gui import PROPERTIES_SEARCH

    panels = []
    for text in (label, "zzzzqq"):
        gui.search_properties(text)
        panels.append(gui.screenshot()[PROPERTIES_SEARCH[1] + 15:PROPERTIES_SEARCH[1] + 245, :280].astype(int))
    gui.click(*PROPERTIES_SEARCH)
    gui.xdotool("key", "Escape")
    time.sleep(1.0)
    return bool(np.abs(panels[0] - panels[1]).max() > 0)


def _quit_cleanly(gui):
    status = gui.quit()
    log = gui.log()
    assert status == 0, f"ParaView exited with {status}:\n{log[-3000:]}"
    for bad in ("Traceback", "SIGSEGV", "Cannot connect null objects", "Error"):
        assert bad not in log, f"{bad!r} in ParaView's output:\n{log[-3000:]}"


def _keep_screenshots(gui, tmp_path, names):
    keep = os.environ.get("PV_HDRVOL_GUI_SHOTS")  # where to keep the screenshots (docs/images)
    if gui.alive():
        gui.screenshot("failure.png")  # what the GUI showed, beside the log in tmp_path
    gui.close()
    for name in names if keep else ():
        if (tmp_path / name).exists():
            shutil.copy(tmp_path / name, os.path.join(keep, name))


def test_gui_filters_menu_apply_rotate_and_exit(shared_data, tmp_path):
    """ParaView's GUI as a person uses it, with real X events on Xvfb: open engine, Apply,
    Filters > pv_hdrvol > HDR Volume Render, Apply; the view shows the render pixel for
    pixel; a mouse drag turns the view and the volume is rendered again for the new
    camera; Ctrl+Q exits with status 0. Nothing crashes, and the GUI has one session
    (a second one, made by importing paraview.simple too early, crashed it at Apply)."""
    engine = shared_data / "structured" / "engine_256x256x128_uint8.vti"
    gui = _start_gui([str(engine)], tmp_path)
    try:
        gui.press_apply(timeout=120)  # the reader
        time.sleep(2)
        gui.menu(215, ["Up", "Right", "Up", "Return"])  # Filters > pv_hdrvol (last) > HDR Volume Render (last)
        gui.press_apply()
        time.sleep(2)
        # not a store: no out-of-core properties; the common ones are there
        assert not _panel_lists(gui, "Out Of Core"), "out-of-core properties in the panel for a plain image"
        assert _panel_lists(gui, "Global Alpha")
        _open_python_shell(gui)
        rgba1, shown1, state1 = _export(gui, tmp_path, 1)
        assert state1["connections"] == 1, "a second session (ParaView's Python has a builtin server of its own)"
        assert state1["lut"] == state1["array_lut"], "HDR Volume Render does not use the array's colour map"
        assert state1["filter_camera"] == state1["camera"]
        assert state1["image_size"] == state1["view_size"] == [shown1.shape[1], shown1.shape[0]]
        # the legend shown is the data's colour map (the one the render follows), not
        # one of the output's pixel colours ("colors Magnitude")
        assert state1["legends"] == [["ImageFile", "", state1["array_lut"]]], state1["legends"]
        reference1 = _reference(shared_data, state1)
        top, left = _on_screen(gui, reference1, rgba1, "before_rotation.png")[:2]
        # turn the view with the mouse: the filter renders the volume again for the new camera
        gui.drag((left + shown1.shape[1] // 2, top + shown1.shape[0] // 2), (160, 0))
        time.sleep(2)
        rgba2, shown2, state2 = _export(gui, tmp_path, 2)
        assert state2["camera"] != state1["camera"], "the drag did not turn the view"
        assert state2["filter_camera"] == state2["camera"]
        assert not np.array_equal(rgba1, rgba2)
        # the first view's render must not pass for the second's
        _on_screen(gui, _reference(shared_data, state2), rgba2, "after_rotation.png", control=reference1)
        _quit_cleanly(gui)
    finally:
        _keep_screenshots(gui, tmp_path, ("before_rotation.png", "after_rotation.png"))


#: ParaView 5.11's Camera Controls toolbar with --dr in a main window at least 1340
#: pixels wide: the second toolbar row (y 80), after the Representation toolbar, 33
#: pixels a button: Reset Camera, Reset Camera Closest, Zoom to Data, Zoom Closest to
#: Data, Zoom to Box, then the view directions +X -X +Y -Y +Z -Z (found by their
#: tooltips; the test checks the direction each click gives the view)
VIEW_DIRECTION_BUTTONS = {"+X": (849, 80), "-Y": (948, 80), "+Z": (981, 80)}
#: The screen, main window and Python Shell input of the camera test: a 1296x779 render
#: view beside the Properties panel, above the Python Shell
CAMERA_SCREEN, CAMERA_WINDOW, CAMERA_SHELL_INPUT = (1920, 1260), (1600, 1260), (967, 1100)


def _drag_and_watch(gui, rectangle, delta, steps=30, pause=0.03, every=6, watch=4.0):
    """A mouse drag of ``steps`` moves from the middle of the screen's ``rectangle``
    (top, left, rows, cols), that rectangle of the screen grabbed every ``every`` moves
    while the button is down, then as often as it can be read (every ~0.05 s) for
    ``watch`` s after the release: ``(during, after)``, lists of (rows, cols, 3) arrays,
    ``after`` as ``(seconds since the release when the grab was complete, array)``: an
    upper bound of when that picture was on screen."""
    top, left, rows, cols = rectangle

    def view():
        return gui.grab()[top:top + rows, left:left + cols]

    during = []
    gui.drag((left + cols // 2, top + rows // 2), delta, steps, pause,
             after_move=lambda i: during.append(view()) if i % every == 0 else None)
    released = time.monotonic()
    after = []
    while time.monotonic() - released < watch:
        shot = view()
        after.append((time.monotonic() - released, shot))
        time.sleep(0.02)
    return during, after


def test_gui_view_direction_buttons_and_a_drag_end_on_the_final_camera(shared_data, tmp_path):
    """The picture belongs to the view's current camera. Clicking the toolbar's view
    direction buttons (+X, -Y, +Z: a direction, then Reset Camera, then one render) shows
    the render of the final camera, never the speck or blank of the camera before the
    reset; after each Edit > Camera Undo the filter's output is the render of the
    view's camera. A mouse drag in a 1296x779 view: the view follows the mouse (the picture at
    the volume's depth turns with it; the volume is not rendered while the button is
    down), and the still frame, the render of the final camera, comes once, for the
    final camera: on screen within 3 s of the release on 2 cores (measured 1.62-2.20 s: the
    ray cast about 0.4-0.75 s, ParaView's update and drawing of the million-quad 'In
    View' surface about 0.8 s; docs/paraview.md; before, the view settled 7.1 s after
    a drag, rendering at full size during it)."""
    from paraview_gui import screen_match, screen_model, view_rectangle

    engine = shared_data / "structured" / "engine_256x256x128_uint8.vti"
    gui = _start_gui([str(engine)], tmp_path, screen=CAMERA_SCREEN)
    names = []
    try:
        gui.resize_window(*CAMERA_WINDOW)
        gui.press_apply(timeout=120)  # the reader
        time.sleep(2)
        gui.menu(215, ["Up", "Right", "Up", "Return"])  # Filters > pv_hdrvol > HDR Volume Render
        gui.press_apply()
        time.sleep(2)
        _open_python_shell(gui)
        previous = None
        for n, (direction, button) in enumerate(VIEW_DIRECTION_BUTTONS.items(), start=1):
            gui.click(*button)
            time.sleep(3)
            rgba, shown, state = _export(gui, tmp_path, n, CAMERA_SHELL_INPUT)
            position, focal_point = (np.array(v) for v in state["view_camera"][:2])
            axis = (focal_point - position) / np.linalg.norm(focal_point - position)  # the view direction
            want = {"X": 0, "Y": 1, "Z": 2}[direction[1]]
            np.testing.assert_allclose(axis, np.eye(3)[want] * (1 if direction[0] == "+" else -1), atol=1e-9,
                                       err_msg=f"the {direction} button did not give the view that direction")
            assert state["filter_camera_fields"] == state["view_camera"]
            reference = _reference(shared_data, state)
            names.append(f"direction_{direction}.png")
            found = _on_screen(gui, reference, rgba, names[-1], control=previous)
            previous = reference
        assert state["view_size"][0] >= 1290 and state["view_size"][1] >= 770, state["view_size"]
        # Edit > Camera Undo, twice: each undo changes the view's camera (ParaView records
        # a button's direction and its Reset Camera as separate steps), and after each the
        # filter's output is the render of the camera the view has then
        before = state["view_camera"]
        for undo in (1, 2):
            gui.click(55, 10)  # Edit
            time.sleep(1.0)
            gui.click(114, 86)  # Camera Undo (Ctrl+B)
            time.sleep(2)
            rgba, shown, state = _export(gui, tmp_path, 3 + undo, CAMERA_SHELL_INPUT)
            assert state["view_camera"] != before, f"Camera Undo {undo} did not change the camera"
            assert state["filter_camera_fields"] == state["view_camera"]
            np.testing.assert_allclose(rgba, _reference(shared_data, state).rgba, rtol=0, atol=1e-6)
            before = state["view_camera"]
        gui.click(*VIEW_DIRECTION_BUTTONS["+Z"])  # a view of the whole volume again, to drag
        time.sleep(3)

        # a drag across the middle of the view
        top, left, rows, cols = view_rectangle(gui.screenshot("before_drag.png"))
        during, after = _drag_and_watch(gui, (top, left, rows, cols), (240, 60))
        views = [shot.astype(int) for shot in during]
        steps = [float(np.abs(b - a).mean()) for a, b in zip(views, views[1:])]
        print(f"drag: mean change of the view between shots while the button is down {steps}")
        # (the shot after the first 6 moves may still show the view of before: measured
        # 0 change once; the following ones 4.8-6.6 levels)
        assert len(steps) == 4 and all(step > 1.0 for step in steps), f"the view did not follow the mouse: {steps}"
        rgba, shown, state = _export(gui, tmp_path, 9, CAMERA_SHELL_INPUT)
        assert state["filter_camera_fields"] == state["view_camera"]
        expected, covered = screen_model(_reference(shared_data, state))
        np.testing.assert_allclose(rgba, _reference(shared_data, state).rgba, rtol=0, atol=1e-6)
        # the expected picture where the view showed the buttons' renders (the view's corner)
        offset = (found[0] - top, found[1] - left)
        scores = [(seconds, screen_match(shot, expected, covered, at=offset)) for seconds, shot in after]
        print("after the release: " + ", ".join(f"{t:.2f} s {m[2]:.3f}" for t, m in scores))
        still = next((t for t, m in scores if m[2] >= 0.88 and m[3] >= 0.96), None)
        assert still is not None, "the still frame of the final camera never came"
        print(f"drag: the still frame was on screen {still:.2f} s after the release")
        assert still <= 3.0, f"the still frame came {still:.2f} s after the release"
        gui.screenshot("after_drag.png")
        names.append("after_drag.png")
        _quit_cleanly(gui)
    finally:
        _keep_screenshots(gui, tmp_path, names)


def test_gui_clip_checkbox_shows_the_plane_widget_and_cuts(shared_data, tmp_path):
    """Clipping as a person does it in the GUI: after Filters > pv_hdrvol > HDR Volume
    Render and Apply, type "Clip" in the Properties panel's search box, click the Clip
    check box found in the screenshot (an unchecked box), see Apply turn green and
    ParaView's implicit-plane widget appear in the view (the view's pixels change before
    Apply), press Apply. The Python Shell's export then shows Clip on with the plane's
    defaults (through the input's centre, normal +x) and the filter's output equals
    hv.render with that plane (the +x half kept, VTK's side) and differs from the whole
    render; ParaView logs no error or warning (the plugin's XML, the widget) and exits 0."""
    engine = shared_data / "structured" / "engine_256x256x128_uint8.vti"
    gui = _start_gui([str(engine)], tmp_path)
    try:
        gui.press_apply(timeout=120)  # the reader
        time.sleep(2)
        gui.menu(215, ["Up", "Right", "Up", "Return"])  # Filters > pv_hdrvol > HDR Volume Render
        gui.press_apply()
        time.sleep(3)
        from paraview_gui import view_rectangle

        gui.search_properties("Clip")
        shot = gui.screenshot("clip_search.png")
        box = gui.checkbox(shot)
        assert box is not None, "no Clip check box in the Properties panel (clip_search.png)"
        gui.click(*box)
        gui.wait_for("Apply to turn green after Clip was checked", gui.apply_button, 20)
        top, left, rows, cols = view_rectangle(shot)
        changed = []

        def widget_shown():  # the widget is drawn at the view's next render: poll
            widget = gui.screenshot("clip_widget.png")
            changed[:] = [np.any(widget[top:top + rows, left:left + cols] != shot[top:top + rows, left:left + cols],
                                 axis=2).sum()]
            return changed[0] > 500

        try:
            gui.wait_for("the plane widget in the view", widget_shown, 20)
        except AssertionError:
            gui.check_alive("after Clip was checked")
            raise AssertionError(f"the plane widget did not appear in the view within 20 s ({changed[0]} pixels "
                                 f"changed)") from None
        gui.press_apply()
        time.sleep(3)
        _open_python_shell(gui)
        rgba, shown, state = _export(gui, tmp_path, 1)
        assert state["connections"] == 1
        assert state["clip"] == [1, [127.5, 127.5, 63.5], [1.0, 0.0, 0.0]], state["clip"]
        plane = (tuple(state["clip"][1]), tuple(state["clip"][2]))
        reference = _reference(shared_data, state, clip_planes=plane)
        whole = _reference(shared_data, state)
        print(f"clip: filter output against hv.render(clip_planes=) here: largest difference "
              f"{np.abs(rgba.astype(np.float64) - reference.rgba).max():.3g}")
        np.testing.assert_allclose(rgba, reference.rgba, rtol=0, atol=1e-6)  # as _on_screen's check
        assert np.abs(whole.rgba - reference.rgba).max() > 0.05, "the plane cut nothing"
        _quit_cleanly(gui)
        log = gui.log()
        assert "Warning" not in log and "warning" not in log, f"a warning in ParaView's output:\n{log[-3000:]}"
    finally:
        _keep_screenshots(gui, tmp_path, ())


def test_gui_opens_a_store_and_renders_it_out_of_core(shared_data, tmp_path):
    """A multiresolution store in the GUI: File > Open, the store's path typed and OK
    (a directory the store reader takes; Return would navigate into it), Apply (one
    level loaded), Filters > pv_hdrvol > HDR Volume Render, Apply: the filter renders
    the store out of core, ``open_multiscale(store).render`` for the view's camera and
    size and the array's colour map (to float32 rounding across numba versions), and
    the view shows it pixel for pixel; ParaView exits 0 with nothing in its log."""
    pytest.importorskip("zarr")
    import pv_hdrvol as hv

    store = tmp_path / "engine.ome.zarr"
    hv.write_multiscale(shared_data / "structured" / "engine_256x256x128_uint8.vti", store, progress_bar=False)
    gui = _start_gui([], tmp_path)
    try:
        time.sleep(5)
        gui.menu(20, ["Down", "Return"])  # File > Open...
        time.sleep(3)
        gui.xdotool("type", "--delay", 10, str(store))
        time.sleep(1)
        gui.click(856, 487)  # the dialog's OK
        gui.press_apply(timeout=120)  # the store reader
        time.sleep(2)
        gui.menu(215, ["Up", "Right", "Up", "Return"])  # Filters > pv_hdrvol (last) > HDR Volume Render (last)
        gui.press_apply()
        time.sleep(2)
        # a store's input: the out-of-core properties are in the panel
        assert _panel_lists(gui, "Out Of Core"), "no Out Of Core property in the panel for a store"
        _open_python_shell(gui)
        rgba, shown, state = _export(gui, tmp_path, 1)
        assert state["connections"] == 1
        assert state["lut"] == state["array_lut"], "HDR Volume Render does not use the array's colour map"
        assert state["filter_camera_fields"] == state["view_camera"]
        reference = _store_reference(store, state)
        print(f"store: levels of the filter's render {reference.metadata['levels']}")
        _on_screen(gui, reference, rgba, "store.png")
        _quit_cleanly(gui)
    finally:
        _keep_screenshots(gui, tmp_path, ("store.png",))


def _store_reference(store, state):
    """What the GUI should show for a store: ``open_multiscale(store).render`` with the
    view's camera and size and the array's colour map and opacity (as :func:`_reference`
    rebuilds them)."""
    import pv_hdrvol as hv
    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    assert state["settings"] == _DEFAULT_SETTINGS, state["settings"]
    assert state["scalars"] == ["POINTS", "ImageFile"], state["scalars"]
    ctf, pwf = _functions_of(state)
    position, focal_point, view_up, angle, parallel, scale = state["view_camera"]
    camera = hv.Camera(position, focal_point, view_up, view_angle=angle, parallel_projection=bool(parallel),
                       parallel_scale=scale)
    with hv.open_multiscale(store) as volume:
        return volume.render(transfer_function_from_vtk(ctf, pwf), camera, tuple(state["view_size"]),
                             precision="float32")


def test_gui_loads_a_state_saved_in_pvbatch(shared_data, tmp_path):
    """File > Load State's path (``paraview --state``) for a state saved in pvbatch with HDR
    Volume Render shown: no traceback, nothing on the undo stack, the view shows the
    render, a drag re-renders it."""
    pvbatch = _tool("pvbatch")
    xvfb_run = _tool("xvfb-run")
    env = _paraview_environment()
    env.update(PV_PLUGIN_PATH=str(REPO_ROOT / "paraview_plugin"), PV_HDRVOL_DATA=str(shared_data))
    state = tmp_path / "hdr.pvsm"
    done = subprocess.run([xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", pvbatch,
                           str(REPO_ROOT / "tests" / "paraview" / "save_state.py"), str(state)], env=env,
                          cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=900)
    assert done.returncode == 0 and state.exists(), f"pvbatch could not save the state:\n{done.stdout[-3000:]}"
    assert "Traceback" not in done.stdout, done.stdout[-3000:]
    gui = _start_gui([f"--state={state}"], tmp_path)
    try:
        time.sleep(5)
        _open_python_shell(gui)
        # the plugin's bookkeeping (the camera and size it gives the filter, the colour
        # map it chooses; the view's resize by the Python Shell made it render again) is
        # not the user's: nothing to undo after loading a state (the Edit menu's list)
        gui.click(700, 600)
        gui.type_line(f"u = servermanager.vtkSMProxyManager.GetProxyManager().GetUndoStackBuilder().GetUndoStack(); "
                      f"open('{tmp_path}/undo.part', 'w').write(repr([u.GetUndoSetLabel(i) for i in "
                      f"range(u.GetNumberOfUndoSets())])); import os; os.replace('{tmp_path}/undo.part', "
                      f"'{tmp_path}/undo.txt')")
        gui.wait_for("the undo list", lambda: (tmp_path / "undo.txt").exists(), 120)
        assert (tmp_path / "undo.txt").read_text() == "[]", (tmp_path / "undo.txt").read_text()
        rgba1, shown1, state1 = _export(gui, tmp_path, 1)
        assert state1["connections"] == 1
        assert state1["lut"] == state1["array_lut"]
        reference1 = _reference(shared_data, state1)
        top, left = _on_screen(gui, reference1, rgba1, "state_loaded.png")[:2]
        gui.drag((left + shown1.shape[1] // 2, top + shown1.shape[0] // 2), (0, 120))
        time.sleep(2)
        rgba2, shown2, state2 = _export(gui, tmp_path, 2)
        assert state2["camera"] != state1["camera"] and state2["filter_camera"] == state2["camera"]
        _on_screen(gui, _reference(shared_data, state2), rgba2, "state_rotated.png", control=reference1)
        _quit_cleanly(gui)
    finally:
        _keep_screenshots(gui, tmp_path, ())


def test_gui_apply_on_a_mesh_hides_its_opaque_surface(shared_data, tmp_path):
    """Open the Blunt Fin (tetrahedra: ParaView shows it as an opaque Surface), Apply,
    Filters > pv_hdrvol > HDR Volume Render, Apply: the mesh's surface is hidden, as
    ParaView's own filters hide an input they replace (the Visibility hint), so nothing
    of the input stands in front of the volume; the 'In View' output is shown. A grid
    shown as its Outline keeps it (the engine tests: the outline stays)."""
    mesh = shared_data / "unstructured" / "bluntfin_187395tets.vtu"
    gui = _start_gui([str(mesh)], tmp_path)
    try:
        gui.press_apply(timeout=120)  # the reader: a Surface
        time.sleep(2)
        gui.menu(215, ["Up", "Right", "Up", "Return"])  # Filters > pv_hdrvol > HDR Volume Render
        gui.press_apply()
        time.sleep(2)
        _open_python_shell(gui)
        gui.click(700, 600)
        gui.type_line(
            "import json; v = GetActiveView(); m = FindSource('bluntfin_187395tets.vtu'); "
            "r = FindSource('HDRVolumeRender1'); "
            f"json.dump(dict(representation=GetDisplayProperties(m, v).Representation, "
            f"input=GetDisplayProperties(m, v).Visibility, shown=GetDisplayProperties(OutputPort(r, 1), v).Visibility),"
            f" open('{tmp_path}/mesh.part', 'w'), default=lambda p: p.GetData()); import os; "
            f"os.replace('{tmp_path}/mesh.part', '{tmp_path}/mesh.json')")
        gui.wait_for("the Python Shell's export", lambda: (tmp_path / "mesh.json").exists(), 60)
        import json

        facts = json.loads((tmp_path / "mesh.json").read_text())
        assert facts == {"representation": "Surface", "input": 0, "shown": 1}, facts
        gui.screenshot("mesh_applied.png")
        _quit_cleanly(gui)
    finally:
        _keep_screenshots(gui, tmp_path, ())


def test_a_state_loaded_after_reset_session_follows_its_view(shared_data, tmp_path):
    """Reset Session, then Load State (tests/paraview/reset_session.py): the new session
    numbers its proxies from 1 again and the state's view replaces the session's first;
    the filter follows the state's view (its saved Image Size kept until the view is
    resized), where it kept following a deleted view of the same ID before."""
    pvbatch = _tool("pvbatch")
    xvfb_run = _tool("xvfb-run")
    env = _paraview_environment()
    env.update(PV_PLUGIN_PATH=str(REPO_ROOT / "paraview_plugin"), PV_HDRVOL_DATA=str(shared_data))
    done = subprocess.run([xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", pvbatch,
                           str(REPO_ROOT / "tests" / "paraview" / "reset_session.py"), str(tmp_path)], env=env,
                          cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
    assert done.returncode == 0 and "followed the state's view after Reset Session" in done.stdout, \
        _failure_text(done.stdout)


def _warm_processes(cache):
    """PIDs of the processes compiling variants into the numba cache folder ``cache``."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                command = f.read().split(b"\0")
            with open(f"/proc/{pid}/environ", "rb") as f:
                environ = f.read().split(b"\0")
        except OSError:
            continue
        if b"pv_hdrvol.integrations.warm" in command and f"NUMBA_CACHE_DIR={cache}".encode() in environ:
            found.append(int(pid))
    return found


def test_loading_the_plugin_compiles_the_common_variants_in_the_background(tmp_path):
    """With numba's cache lacking them, loading the plugin starts ParaView's Python on
    ``pv_hdrvol.integrations.warm`` at the lowest priority, detached (pvbatch is done
    long before it); with the stamp of this source in the cache, nothing starts.
    tests/integrations/test_warm.py checks that a warmed cache serves a later render."""
    pvbatch = _tool("pvbatch")
    cache = tmp_path / "numba"
    env = _paraview_environment()
    env.pop("PV_HDRVOL_WARM")
    env["NUMBA_CACHE_DIR"] = str(cache)
    script = str(REPO_ROOT / "tests" / "paraview" / "load_only.py")
    done = subprocess.run([pvbatch, script], env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=300)
    assert done.returncode == 0 and "loaded: True" in done.stdout, done.stdout[-3000:]
    try:
        pids = _warm_processes(cache)
        assert len(pids) == 1, f"warming processes for {cache}: {pids}"
        assert os.getpriority(os.PRIO_PROCESS, pids[0]) == 19
        assert (cache / "pv_hdrvol-warm.log").exists()
    finally:
        for pid in _warm_processes(cache):
            os.kill(pid, 9)
    # a cache stamped for this source: loading starts nothing
    stamp = subprocess.run(["/usr/bin/python3", "-c", "import sys; from pv_hdrvol.integrations.warm import "
                            "stamp_path; print(stamp_path(sys.argv[1]))", str(cache)], env=env, cwd=REPO_ROOT,
                           stdout=subprocess.PIPE, text=True, check=True).stdout.strip()
    open(stamp, "w").close()
    done = subprocess.run([pvbatch, script], env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=300)
    assert done.returncode == 0 and _warm_processes(cache) == []


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
