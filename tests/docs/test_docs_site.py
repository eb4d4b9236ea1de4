"""The built documentation site in a real browser: its root page and a gallery page
show every picture they hold (each ``<img>`` loaded, ``naturalWidth > 0``), the
gallery page shows its example's figure, and the search page (Sphinx's search runs in
JavaScript) finds a word the pages use.

The site is built by ``python3 -m sphinx -W --keep-going -b html docs docs/_build/html``
(``docs/development.md``); ``.ci/run`` builds it before the test command and names the
folder in ``PV_HDRVOL_DOCS_HTML``. Needs Debian's ``chromium`` too. Without the site or
the browser the tests are skipped, except under CI, where they fail.

Each page is opened in an ``<iframe>`` of a checking page served from the same local
HTTP server (so the checking page may read the frame's document), and Chromium's
``--dump-dom`` returns the checking page with its findings as JSON.
"""
import functools
import html
import http.server
import json
import os
import re
import shutil
import subprocess
import threading
from pathlib import Path

import pytest

from conftest import REPO_ROOT, require

#: the gallery page the test opens, and the figure its example draws
GALLERY_PAGE = "auto_examples/plot_hdr_vs_8bit.html"
GALLERY_FIGURE = "sphx_glr_plot_hdr_vs_8bit_001.png"
#: a word of the pages (docs/tonemapping.md) that the search must find
SEARCH_WORD = "tonemap"

CHECK_PAGE = """<!doctype html>
<html><body><pre id="result">pending</pre>
<iframe id="frame" style="width: 1280px; height: 30000px"></iframe>
<script>
const target = %(target)s, wantSearch = %(search)s;
const frame = document.getElementById("frame");
const started = Date.now();
function report(extra) {
  const doc = frame.contentDocument;
  const images = Array.from(doc.images).map(img => ({
    src: img.getAttribute("src"), complete: img.complete, width: img.naturalWidth}));
  const result = Object.assign({url: doc.location.href, title: doc.title, images: images}, extra);
  document.getElementById("result").textContent = JSON.stringify(result);
}
function poll() {
  const doc = frame.contentDocument;
  const images = Array.from(doc.images);
  images.forEach(img => { if (img.loading === "lazy") img.loading = "eager"; });
  const waiting = images.some(img => !img.complete);
  let summary = null, hits = [];
  if (wantSearch) {
    const node = doc.querySelector(".search-summary");
    summary = node ? node.textContent : null;
    hits = Array.from(doc.querySelectorAll("#search-results li a")).map(a => a.getAttribute("href"));
  }
  const searching = wantSearch && !(summary && summary.startsWith("Search finished"));
  if ((waiting || searching) && Date.now() - started < 20000) { setTimeout(poll, 100); return; }
  report(wantSearch ? {summary: summary, hits: hits} : {});
}
frame.onload = () => setTimeout(poll, 100);
frame.src = target;
</script></body></html>
"""


def _site():
    """The built site's folder (PV_HDRVOL_DOCS_HTML if set, else docs/_build/html), or None."""
    root = Path(os.environ.get("PV_HDRVOL_DOCS_HTML") or REPO_ROOT / "docs" / "_build" / "html")
    return root if (root / "index.html").is_file() else None


@pytest.fixture(scope="module")
def browse():
    """``browse(path, search=False)``: open ``path`` of the built site in headless
    Chromium and return what the checking page found (a dict)."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    require(chromium is not None, "chromium is not installed (apt-get install chromium)")
    site = _site()
    require(site is not None, "the documentation site is not built (python3 -m pip install -e '.[docs]' && "
                              "python3 -m sphinx -W --keep-going -b html docs docs/_build/html)")
    pages = {}

    class Handler(http.server.SimpleHTTPRequestHandler):
        def do_GET(self):  # noqa: N802 (http.server's name)
            body = pages.get(self.path)
            if body is None:
                return super().do_GET()
            self.send_response(200)
            self.send_header("Content-Type", "text/html; charset=utf-8")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler, directory=str(site)))
    threading.Thread(target=server.serve_forever, daemon=True).start()

    def open_page(path, search=False):
        check = f"/__check_{len(pages)}__.html"
        pages[check] = (CHECK_PAGE % {"target": json.dumps("/" + path), "search": json.dumps(search)}).encode()
        done = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=30000",
                               "--dump-dom", f"http://127.0.0.1:{server.server_address[1]}{check}"],
                              capture_output=True, text=True, timeout=180)
        found = re.search(r'<pre id="result">(.*?)</pre>', done.stdout, re.S)
        assert found and found.group(1) != "pending", (done.stdout[-2000:], done.stderr[-3000:])
        return json.loads(html.unescape(found.group(1)))

    yield open_page
    server.shutdown()


def _assert_images_loaded(page):
    assert page["images"], f"{page['url']} has no picture"
    broken = [img["src"] for img in page["images"] if not (img["complete"] and img["width"] > 0)]
    assert not broken, f"{page['url']}: pictures that did not load: {broken}"


def test_the_root_page_shows_its_pictures(browse):
    page = browse("index.html")
    assert page["title"].startswith("pv_hdrvol documentation"), page["title"]
    _assert_images_loaded(page)
    assert any(img["src"].endswith("hdr_vs_8bit.png") for img in page["images"]), page["images"]


def test_a_gallery_page_shows_the_figure_its_example_drew(browse):
    page = browse(GALLERY_PAGE)
    _assert_images_loaded(page)
    assert any(img["src"].endswith(GALLERY_FIGURE) for img in page["images"]), \
        f"{GALLERY_PAGE} does not show {GALLERY_FIGURE} (was the gallery built with plot_gallery=0?): {page['images']}"


def test_the_search_page_finds_a_word_of_the_pages(browse):
    page = browse(f"search.html?q={SEARCH_WORD}", search=True)
    assert page["summary"] and page["summary"].startswith("Search finished"), page["summary"]
    assert page["hits"], f"searching {SEARCH_WORD!r} found nothing: {page['summary']}"
    assert any("tonemapping.html" in hit for hit in page["hits"]), page["hits"]
