"""
The Qt viewer on the engine
===========================

Opens :func:`pv_hdrvol.view`'s window on the engine CT (../shared/data), waits for the
full frame, turns the magnifier lens on over the engine's middle and saves a grab of
the window: the render (Reinhard), the transfer-function editor over the histogram,
the display panel and, in the status bar, the probe. Needs Qt and a display::

    xvfb-run -a -s '-screen 0 1280x1024x24' python3 examples/viewer_screenshot.py   # docs/images/viewer.png
"""
import sys
import time
from pathlib import Path

import pyvista as pv
from qtpy import QtWidgets

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.viewer.qt import HDRViewer  # noqa: E402


def main(out=ROOT / "docs" / "images" / "viewer.png"):
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    grid = pv.read(ROOT.parent / "shared" / "data" / "structured" / "engine_256x256x128_uint8.vti")
    viewer = HDRViewer(hv.volume_from_dataset(grid), title="pv_hdrvol: engine_256x256x128_uint8.vti")
    viewer.resize(1000, 760)
    viewer.show()

    def settle(timeout=120):
        end = time.monotonic() + timeout
        while time.monotonic() < end and not viewer.actor.up_to_date:
            app.processEvents()
            time.sleep(0.01)
        for _ in range(20):
            app.processEvents()
            time.sleep(0.01)

    settle()
    cols, rows = viewer.actor.scene.GetSize()
    found = viewer.actor.probe(cols // 2, rows // 2)  # (a lens's rays have no data point to probe)
    r, g, b, a = found["rgba"]
    text = f"({cols // 2}, {rows // 2})  HDR RGBA {r:.4g} {g:.4g} {b:.4g} {a:.4g}  depth {found['depth']:.4g}"
    if found["value"] is not None:
        text += f"  value {found['value']:.6g}"
    viewer.model.add_focus(0.5, 0.15, 3.0)
    viewer.toggle_lens(True)
    settle()
    viewer.probe_label.setText(text)
    app.processEvents()
    viewer.grab().save(str(out))
    print(f"wrote {out}")
    viewer.close()


if __name__ == "__main__":
    main()
