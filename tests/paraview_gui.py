"""Drive ParaView's GUI as a person does: real X events (XTest through ``xdotool``) on a
private Xvfb, screenshots read from the X screen's framebuffer (Xvfb's ``-fbdir`` file:
a copy of memory, so polling the screen takes little from the GUI being timed).

Used by tests/integrations/test_paraview.py from the main suite's interpreter (not inside ParaView).
What the GUI holds is read back the way a user would: typed into View > Python Shell,
which writes files the test reads. Coordinates are those of ParaView 5.11's default
layout (``--dr``: no saved settings) on a 1280x1024 screen; the Apply button and the
render view are found in the screenshot by their colours, not assumed.
"""
import os
import subprocess
import time

import numpy as np

SCREEN = (1280, 1024)
#: ParaView's default render-view background, (0.32, 0.34, 0.43) as 8-bit sRGB
BACKGROUND = (82, 87, 110)
#: The Apply button while something waits to be applied (ParaView's green)
APPLY_GREEN = ((100, 200), (180, 255), (100, 200))  # (low, high) of R, G, B


#: The Properties panel's search box ("Search ... (use Esc to clear text)") in the default layout
PROPERTIES_SEARCH = (133, 455)


class GUIError(AssertionError):
    pass


class ParaViewGUI:
    """A ParaView GUI on its own Xvfb display of ``screen`` pixels, started with
    ``args`` and ``env``."""

    def __init__(self, args, env, log_path, shot_dir, screen=SCREEN):
        import tempfile

        self.shot_dir = shot_dir
        self._fbdir = tempfile.TemporaryDirectory(prefix="xvfb-fb-")
        self.xvfb = subprocess.Popen(["Xvfb", "-displayfd", "1", "-screen", "0", f"{screen[0]}x{screen[1]}x24",
                                      "-fbdir", self._fbdir.name, "-nolisten", "tcp"], stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, text=True)
        display = self.xvfb.stdout.readline().strip()
        if not display.isdigit():
            self.xvfb.kill()
            raise GUIError(f"Xvfb gave no display number ({display!r})")
        self.env = dict(env, DISPLAY=f":{display}")
        self.log_path = log_path
        self._log = open(log_path, "w")
        self.process = subprocess.Popen(args, env=self.env, stdout=self._log, stderr=subprocess.STDOUT)
        self.shots = 0

    # -- X ---------------------------------------------------------------------------
    def xdotool(self, *args):
        subprocess.run(["xdotool", *map(str, args)], env=self.env, check=True, timeout=60)

    def grab(self):
        """The X screen now as an (rows, cols, 3) uint8 array, read from Xvfb's
        framebuffer file (XWD: a big-endian header, a colour map, then 32-bit pixels
        B, G, R, unused, least significant byte first)."""
        with open(os.path.join(self._fbdir.name, "Xvfb_screen0"), "rb") as f:
            data = f.read()
        header = np.frombuffer(data[:100], ">u4")
        size, cols, rows, bits, line, colours = (int(header[i]) for i in (0, 4, 5, 11, 12, 19))
        if bits != 32 or int(header[7]) != 0:
            raise GUIError(f"unexpected framebuffer layout: {bits} bits a pixel, byte order {int(header[7])}")
        start = size + 12 * colours
        pixels = np.frombuffer(data, np.uint8, rows * line, start).reshape(rows, line // 4, 4)[:, :cols]
        return np.ascontiguousarray(pixels[..., 2::-1])

    def screenshot(self, name=None):
        """The X screen as an (rows, cols, 3) uint8 array (and a PNG in shot_dir)."""
        from vtkmodules.util.numpy_support import numpy_to_vtk
        from vtkmodules.vtkCommonDataModel import vtkImageData
        from vtkmodules.vtkIOImage import vtkPNGWriter

        self.shots += 1
        pixels = self.grab()
        rows, cols = pixels.shape[:2]
        image = vtkImageData()
        image.SetDimensions(cols, rows, 1)
        image.GetPointData().SetScalars(numpy_to_vtk(np.ascontiguousarray(pixels[::-1]).reshape(-1, 3), deep=True))
        writer = vtkPNGWriter()
        writer.SetFileName(os.path.join(self.shot_dir, name or f"shot{self.shots:02d}.png"))
        writer.SetInputData(image)
        writer.Write()
        return pixels

    def alive(self):
        return self.process.poll() is None

    def log(self):
        self._log.flush()
        with open(self.log_path) as f:
            return f.read()

    def check_alive(self, step):
        if not self.alive():
            raise GUIError(f"ParaView died ({self.process.returncode}) {step}:\n{self.log()[-4000:]}")

    def wait_for(self, what, condition, timeout, interval=1.0):
        """Poll ``condition()`` until it is true; fail naming ``what`` after ``timeout`` s."""
        end = time.monotonic() + timeout
        while True:
            self.check_alive(f"while waiting for {what}")
            value = condition()
            if value:
                return value
            if time.monotonic() > end:
                raise GUIError(f"timed out after {timeout} s waiting for {what}")
            time.sleep(interval)

    def wait_for_window(self, timeout=120):
        def found():
            done = subprocess.run(["xdotool", "search", "--onlyvisible", "--name", "ParaView"], env=self.env,
                                  stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            return done.stdout.split()

        self.wait_for("ParaView's window", found, timeout)

    def resize_window(self, width, height):
        """Move ParaView's main window to the screen's corner and give it this size (what
        a person does by dragging its corner; the layout of the panels follows)."""
        found = subprocess.run(["xdotool", "search", "--onlyvisible", "--name", "ParaView"], env=self.env,
                               stdout=subprocess.PIPE, text=True, timeout=60).stdout.split()
        if not found:
            raise GUIError("no ParaView window to resize")
        self.xdotool("windowmove", found[0], 0, 0)
        self.xdotool("windowsize", found[0], width, height)
        time.sleep(3)

    # -- what a person does ----------------------------------------------------------
    def click(self, x, y, button=1):
        self.xdotool("mousemove", x, y)
        time.sleep(0.2)
        self.xdotool("click", button)

    def apply_button(self, shot=None):
        """Centre of the green (pending) Apply button, or None."""
        shot = self.screenshot() if shot is None else shot
        (r0, r1), (g0, g1), (b0, b1) = APPLY_GREEN
        panel = shot[300:600, :300].astype(int)
        mask = ((panel[..., 0] >= r0) & (panel[..., 0] <= r1) & (panel[..., 1] >= g0) & (panel[..., 1] <= g1)
                & (panel[..., 2] >= b0) & (panel[..., 2] <= b1) & (panel[..., 1] > panel[..., 0] + 30))
        if mask.sum() < 200:
            return None
        rows, cols = np.nonzero(mask)
        return int(cols.mean()), int(rows.mean()) + 300

    def checkbox(self, shot=None, top=470, bottom=700, right=60):
        """Centre of the topmost unchecked check box in the Properties panel's left column
        (an all-white square of at least 9x9 pixels, ParaView's default style), or None."""
        shot = self.screenshot() if shot is None else shot
        white = np.all(shot[top:bottom, :right] >= 250, axis=2)
        for y in range(white.shape[0] - 9):
            for x in range(white.shape[1] - 9):
                if white[y:y + 9, x:x + 9].all():
                    return x + 5, y + 5 + top
        return None

    def search_properties(self, text):
        """Type ``text`` into the Properties panel's search box (below Apply in the
        default layout): the panel shows only the properties whose label matches."""
        self.click(*PROPERTIES_SEARCH)
        self.xdotool("key", "ctrl+a")
        self.xdotool("type", "--delay", 20, text)
        time.sleep(1.5)

    def press_apply(self, timeout=60, done_timeout=400):
        """Click the green Apply button, then wait until it is no longer green: Apply has
        run and the GUI draws again. ParaView applies in its GUI thread, so while a filter
        executes (HDR Volume Render's first render loads or compiles the ray caster: 25 s
        on 2 cores with numba's cache, over a minute without) the window is not repainted
        and a screenshot shows the screen of before the click, Apply still green; X events
        sent meanwhile wait in the queue and are handled after."""
        x, y = self.wait_for("the Apply button to turn green", self.apply_button, timeout)
        self.click(x, y)
        self.wait_for("Apply to be done (its button no longer green)", lambda: self.apply_button() is None,
                      done_timeout)

    def menu(self, x_title, keys):
        """Open the menu whose title is at ``x_title`` on the menu bar, then press ``keys``."""
        self.click(x_title, 10)
        time.sleep(1.0)
        for key in keys:
            self.xdotool("key", key)
            time.sleep(0.5)

    def drag(self, start, delta, steps=12, pause=0.05, after_move=None):
        """Press the left button at ``start``, move by ``delta`` in ``steps`` moves
        ``pause`` s apart (``after_move(i)`` after the i-th, 1-based), release."""
        x, y = start
        self.xdotool("mousemove", x, y)
        time.sleep(0.2)
        self.xdotool("mousedown", 1)
        for i in range(1, steps + 1):
            self.xdotool("mousemove", x + delta[0] * i // steps, y + delta[1] * i // steps)
            time.sleep(pause)
            if after_move is not None:
                after_move(i)
        self.xdotool("mouseup", 1)

    def type_line(self, text):
        self.xdotool("type", "--delay", 4, text)
        self.xdotool("key", "Return")

    def quit(self, timeout=60):
        """File > Exit by its shortcut; the exit status."""
        self.xdotool("key", "ctrl+q")
        try:
            return self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            raise GUIError(f"ParaView did not exit within {timeout} s of Ctrl+Q") from None

    def close(self):
        for proc in (self.process, self.xvfb):
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        self._log.close()
        self._fbdir.cleanup()


def view_rectangle(shot):
    """(top, left, rows, cols) of the render view: the bounding box of its background colour."""
    mask = np.all(shot == BACKGROUND, axis=2)
    rows = np.nonzero(mask.sum(axis=1) > 50)[0]
    cols = np.nonzero(mask.sum(axis=0) > 50)[0]
    if rows.size == 0 or cols.size == 0:
        raise GUIError("no render view (its background colour) in the screenshot")
    return rows[0], cols[0], rows[-1] - rows[0] + 1, cols[-1] - cols[0] + 1


def screen_model(reference, operator="knee"):
    """What the render view shows of HDR Volume Render's 'In View' surface for the
    HDRImage ``reference``: ``(expected, covered)``, expected (rows, cols, 3) float
    screen levels and covered (rows, cols) bool, the pixels the surface draws.

    The tone-mapped picture over black (8 bits, the operator's own encoding) is drawn as quads of straight
    alpha, ``colors / alpha`` clipped to 255 with alpha in 8 bits
    (pv_hdrvol.integrations.vtk_surface), blended over the view's background; pixels
    with less alpha than half a level are not drawn (the background shows)."""
    import pv_hdrvol as hv
    from pv_hdrvol.integrations.vtk_surface import MIN_ALPHA

    colors = hv.tonemap(reference, operator).rgb8.astype(np.float64)
    alpha = np.nan_to_num(reference.rgba[..., 3].astype(np.float64), nan=0.0)
    covered = alpha >= MIN_ALPHA
    straight = np.clip(np.rint(colors / np.maximum(alpha, MIN_ALPHA)[..., None]), 0, 255)
    a8 = (np.clip(np.rint(alpha * 255.0), 0, 255) / 255.0)[..., None]
    expected = np.where(covered[..., None], straight * a8 + (1 - a8) * np.array(BACKGROUND, float),
                        np.array(BACKGROUND, float))
    return expected, covered


def screen_match(shot, expected, covered, at=None, search=6):
    """Where ``expected`` (:func:`screen_model`) lies in ``shot``: ``(top, left, same,
    near)`` over the ``covered`` pixels: ``same`` the fraction whose three levels are
    within 1 of the expected (rounded) at that pixel, ``near`` the fraction within 1
    level of the range of the expected 3x3 neighbourhood, channel by channel (a pixel
    at a sharp edge of the picture may show a mix of its neighbours: the quads the view
    draws lie at the volume's depth and meet to within rounding). At ``at``, or at the
    offset within ``search`` pixels of the render view's rectangle with the largest
    ``same``."""
    rows, cols = expected.shape[:2]
    target = np.rint(expected)
    padded = np.pad(target, ((1, 1), (1, 1), (0, 0)), mode="edge")
    around = np.stack([padded[dr:dr + rows, dc:dc + cols] for dr in range(3) for dc in range(3)])
    low, high = around.min(axis=0) - 1, around.max(axis=0) + 1
    ii, jj = np.nonzero(covered)

    def score(t, l):
        if t < 0 or l < 0 or t + rows > shot.shape[0] or l + cols > shot.shape[1] or ii.size == 0:
            return -1.0, -1.0
        seen = shot[t + ii, l + jj].astype(np.float64)
        same = np.abs(seen - target[ii, jj]).max(axis=1) <= 1
        near = np.all((seen >= low[ii, jj]) & (seen <= high[ii, jj]), axis=1)
        return float(same.mean()), float(near.mean())

    if at is not None:
        return (at[0], at[1], *score(*at))
    top, left, _, _ = view_rectangle(shot)
    best = (top, left, -1.0, -1.0)
    for dt in range(-search, search + 1):
        for dl in range(-search, search + 1):
            same = score(top + dt, left + dl)
            if same[0] > best[2]:
                best = (top + dt, left + dl, *same)
    return best
