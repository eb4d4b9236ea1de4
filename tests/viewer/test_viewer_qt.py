"""The Qt viewer in a real window: tests/qt/qt_*.py run with pytest-qt under xvfb-run
(Debian's xvfb), in a subprocess of their own (a Qt application per process). Without
xvfb-run or the Qt packages the test is skipped, except under CI, where it fails."""
import importlib.util
import os
import shutil
import subprocess
import sys

from conftest import REPO_ROOT, require


def test_the_qt_viewer_checks_pass_under_xvfb():
    xvfb_run = shutil.which("xvfb-run")
    require(xvfb_run is not None, "xvfb-run is not installed (apt-get install xvfb xauth)")
    for module in ("qtpy", "pyvistaqt", "pytestqt"):
        require(importlib.util.find_spec(module) is not None,
                f"{module} is not installed (pip install -e '.[test]')")
    env = {k: v for k, v in os.environ.items() if k not in ("QT_QPA_PLATFORM", "VTK_DEFAULT_OPENGL_WINDOW")}
    files = sorted(str(p) for p in (REPO_ROOT / "tests" / "qt").glob("qt_*.py"))
    done = subprocess.run([xvfb_run, "-a", "-s", "-screen 0 1280x1024x24", sys.executable, "-m", "pytest", "-q",
                           "-p", "no:cacheprovider", "-rs", "--rootdir", str(REPO_ROOT), "-c", os.devnull, *files],
                          env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=1800)
    sys.stdout.write(done.stdout[-6000:])
    assert done.returncode == 0, f"Qt viewer checks failed (exit {done.returncode}):\n{done.stdout[-6000:]}"
    summary = done.stdout.strip().splitlines()[-1]
    assert " passed" in summary and "skipped" not in summary, summary
