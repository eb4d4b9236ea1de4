"""Sphinx configuration of pv_hdrvol's documentation site.

Build it from the repository root (``docs/development.md``)::

    python3 -m pip install -e '.[docs]'
    python3 -m sphinx -W --keep-going -b html docs docs/_build/html

The pages are the Markdown files of this folder (MyST), read on GitHub as they are;
``examples/plot_*.py`` become the gallery (sphinx-gallery runs each, off screen, and
shows the figures it leaves open); ``api_reference.rst`` documents ``pv_hdrvol.__all__``
from the numpydoc docstrings.
"""
import os
import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))

# Off screen, before anything imports matplotlib or VTK: the examples run in this process.
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
if not os.environ.get("DISPLAY"):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
# The examples write their PNGs to docs/images when run as scripts; in the build they
# write them into the build folder, so building never changes the tracked pictures.
# (numba's NUMBA_CACHE_DIR is left as the caller set it: .ci/run gives the build the
# test run's cache folder, so the kernels the gallery compiles are the tests' too.)
os.environ.setdefault("PV_HDRVOL_FIGURES", str(DOCS / "_build" / "example_figures"))
Path(os.environ["PV_HDRVOL_FIGURES"]).mkdir(parents=True, exist_ok=True)

import pv_hdrvol  # noqa: E402

project = "pv_hdrvol"
author = "pv_hdrvol developers"
copyright = "pv_hdrvol developers"
release = version = pv_hdrvol.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

root_doc = "index"
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "_intersphinx", "auto_examples/*.ipynb", "auto_examples/*.py", "auto_examples/*.zip",
                    "auto_examples/*.md5", "auto_examples/*.json"]
templates_path = []

# --- Markdown pages (MyST) -----------------------------------------------------------
# The pages link each other's sections as GitHub does (page.md#a-heading): anchors for
# headings down to ####.
myst_heading_anchors = 4
myst_enable_extensions = ["dollarmath"]

# --- API reference ---------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# --- Gallery -----------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    # only plot_*.py run: pvbatch_sweep.py and pvpython_render.py need ParaView's
    # pvbatch, viewer_screenshot.py a Qt window
    "filename_pattern": r"/plot_",
    "ignore_pattern": r"^(pvbatch_sweep|pvpython_render|viewer_screenshot)\.py$",
    "image_scrapers": ("matplotlib",),
    "matplotlib_animations": False,
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    # an example that raises fails the build
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "show_memory": False,
    "min_reported_time": 1,
}

# --- Links to other projects -----------------------------------------------------------
# The docs sites may be unreachable (CI machines reach package registries only): an
# inventory that cannot be fetched would make -W fail. A copy in docs/_intersphinx/
# (NAME-objects.inv, e.g. fetched with `curl -o` where the site is reachable) is read
# first; a project with neither a copy nor a reachable site is left out, and its names
# appear as plain text. PV_HDRVOL_DOCS_OFFLINE=1 skips the network altogether.
INTERSPHINX = {
    "python": "https://docs.python.org/3.11/",  # the copy in _intersphinx/ is 3.11's
    "numpy": "https://numpy.org/doc/stable/",
    "pyvista": "https://docs.pyvista.org/",
    "vtk": "https://docs.vtk.org/en/latest/",
    "matplotlib": "https://matplotlib.org/stable/",
}


def _intersphinx_mapping():
    import urllib.request

    offline = os.environ.get("PV_HDRVOL_DOCS_OFFLINE", "").strip().lower() not in ("", "0", "false", "no")
    mapping = {}
    for name, url in INTERSPHINX.items():
        local = DOCS / "_intersphinx" / f"{name}-objects.inv"
        if local.is_file():
            mapping[name] = (url, str(local))
            continue
        if offline:
            continue
        try:
            with urllib.request.urlopen(url + "objects.inv", timeout=5) as response:
                response.read(16)
        except Exception as exc:  # unreachable: leave the project out, say so
            print(f"intersphinx: {name} left out ({url}objects.inv: {exc.__class__.__name__})")
            continue
        mapping[name] = (url, None)
    return mapping


intersphinx_mapping = _intersphinx_mapping()
intersphinx_timeout = 10

# --- HTML ---------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = "pv_hdrvol"
html_static_path = []
html_theme_options = {
    "navigation_with_keys": False,
    "header_links_before_dropdown": 4,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_show_sourcelink = False


# --- Pages written for GitHub, read by Sphinx -------------------------------------------
# docs/*.md link what lies outside docs/ as GitHub shows it; on the site the same links
# go to the gallery and the introduction (the README). The root page's table is its table of contents
# on GitHub; here it gets a hidden toctree listing the same pages.
LINKS_OUTSIDE_DOCS = [
    (re.compile(r"\]\(\.\./examples/?\)"), "](auto_examples/index.rst)"),
    (re.compile(r"\]\(\.\./README\.md"), "](introduction.md"),
]


def _page_order():
    """The pages in the order docs/index.md's table lists them."""
    table = (DOCS / "index.md").read_text()
    return [m.group(1) for m in re.finditer(r"^\| \[[^\]]*\]\(([a-z_]+)\.md\)", table, re.M)]


def _rewrite_markdown(app, docname, source):
    text = source[0]
    for pattern, replacement in LINKS_OUTSIDE_DOCS:
        text = pattern.sub(replacement, text)
    if docname == "index":
        pages = _page_order() + ["introduction", "auto_examples/index", "api_reference"]
        text += "\n```{toctree}\n:hidden:\n:maxdepth: 2\n\n" + "\n".join(pages) + "\n```\n"
    source[0] = text


def _check_reference_lists_all(app, env, docnames):
    """Every public name (pv_hdrvol.__all__) has its entry in api_reference.rst."""
    from sphinx.util import logging

    text = (DOCS / "api_reference.rst").read_text()
    listed = set(re.findall(r"^\s{3}(\w+)\s*$", text, re.M))
    for name in sorted(set(pv_hdrvol.__all__) - listed):
        logging.getLogger(__name__).warning(f"pv_hdrvol.{name} is in __all__ but not in api_reference.rst",
                                            location="api_reference")


def setup(app):
    app.connect("source-read", _rewrite_markdown)
    app.connect("env-before-read-docs", _check_reference_lists_all)
