"""The notebook editor in a real browser: its widgets exported with their state
(``ipywidgets.embed``), drawn by the Jupyter widgets' HTML manager
(``@jupyter-widgets/html-manager``, from the npm registry) in headless Chromium; the
screenshot holds our tone-mapped render and the editor's picture pixel for pixel.

Needs Debian's ``chromium`` and the html-manager's ``embed.js``: the folder named by
``PV_HDRVOL_WIDGETS_EMBED`` (``.ci/run`` installs both: ``npm install --prefix DIR
@jupyter-widgets/html-manager@1``), else ``tests/.widgets/node_modules/...``. Without
them the test is skipped, except under CI, where it fails.
"""
import functools
import http.server
import os
import shutil
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO_ROOT, require

pytest.importorskip("ipywidgets")

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.viewer.notebook import TransferFunctionEditor, editor_picture  # noqa: E402

EMBED = "node_modules/@jupyter-widgets/html-manager/dist/embed.js"


def _embed_js():
    for root in (os.environ.get("PV_HDRVOL_WIDGETS_EMBED"), REPO_ROOT / "tests" / ".widgets"):
        if root and (Path(root) / EMBED).is_file():
            return Path(root) / EMBED
    return None


def _find(haystack, needle):
    """(row, col) where ``needle`` lies in ``haystack`` exactly, or None."""
    h, w = needle.shape[:2]
    first = needle[0, 0]
    rows, cols = np.nonzero(np.all(haystack == first, axis=-1))
    for r, c in zip(rows, cols):
        if r + h <= haystack.shape[0] and c + w <= haystack.shape[1] and \
                np.array_equal(haystack[r:r + h, c:c + w], needle):
            return int(r), int(c)
    return None


def test_the_editor_draws_in_headless_chromium(tmp_path):
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    require(chromium is not None, "chromium is not installed (apt-get install chromium)")
    embed = _embed_js()
    require(embed is not None, "the Jupyter widgets' html-manager is not installed "
                             "(npm install --prefix tests/.widgets @jupyter-widgets/html-manager@1)")
    from ipywidgets.embed import embed_minimal_html

    z, y, x = np.mgrid[0:20, 0:22, 0:24].astype(np.float64)
    volume = hv.volume_from_array(np.exp(-((x - 12) ** 2 + (y - 11) ** 2 + (z - 10) ** 2) / 30.0))
    tf = hv.TransferFunction([0.0, 0.3, 1.0], [[0.1, 0.2, 1.0], [1.0, 1.0, 1.0], [1.0, 0.3, 0.0]], [0.0, 0.05, 0.4])
    editor = TransferFunctionEditor(volume, tf, size=(96, 80), live=False, precision="float64")
    editor.refresh()
    editor.model.add_focus(0.5, 0.1, 3.0)
    shutil.copy(embed, tmp_path / "embed.js")
    embed_minimal_html(tmp_path / "page.html", views=[editor.widget], title="pv_hdrvol editor", requirejs=False,
                       embed_url="embed.js")
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(tmp_path))
    handler.log_message = lambda *args: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        done = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                               "--force-device-scale-factor=1", "--force-color-profile=srgb", "--window-size=1200,900",
                               "--virtual-time-budget=15000", f"--screenshot={tmp_path / 'shot.png'}",
                               f"http://127.0.0.1:{server.server_address[1]}/page.html"],
                              capture_output=True, text=True, timeout=180)
    finally:
        server.shutdown()
    assert (tmp_path / "shot.png").is_file(), done.stderr[-3000:]
    import imageio.v3 as iio

    shot = iio.imread(tmp_path / "shot.png")[..., :3]
    assert _find(shot, editor.picture) is not None, "the render is not on the page, pixel for pixel"
    assert _find(shot, editor_picture(editor.model)) is not None, "the editor's picture is not on the page"
