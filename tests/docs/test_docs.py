"""The code in README.md and docs/*.md runs as shown, and prints what the text says.

Every fenced block whose info string is ``python`` is run, the blocks of one file in
order in one namespace, in a scratch folder. Blocks marked ``python fragment`` are
excerpts (names from the surrounding text, a test file's header) and are not run.
"""
import re

import pytest

from conftest import REPO_ROOT
from docblocks import python_blocks, run_blocks

def test_every_python_block_is_runnable_or_marked_a_fragment():
    docs = [REPO_ROOT / "README.md", *sorted((REPO_ROOT / "docs").glob("*.md"))]
    counted = {path.name: python_blocks(path) for path in docs}
    assert len(counted["README.md"][0]) == 3
    # the fragments are the known excerpts
    assert sorted(name for name, (_, frag) in counted.items() if frag) == ["data_types.md", "development.md",
                                                                          "gpu.md", "interactive.md", "lenses.md",
                                                                          "proxy.md", "shading.md", "tetrahedra.md"]


def test_readme_examples_run_and_print_what_the_readme_says(tmp_path, monkeypatch):
    pytest.importorskip("pyvista")
    pytest.importorskip("OpenEXR")
    readme = (REPO_ROOT / "README.md").read_text()
    blocks, _ = python_blocks(REPO_ROOT / "README.md")
    printed = run_blocks(blocks, tmp_path, monkeypatch)
    # the numbers the README states in its comments are the ones printed
    first = printed.splitlines()[0]
    stated = re.search(r"# (HDRImage\(256x256, float32, peak luminance [0-9.]+, [0-9.]+ decades), \.\.\.\)", readme)
    assert stated and first.startswith(stated.group(1)), (first, stated)
    per_precision = re.search(r"# (float64 [0-9.]+), (float32 [0-9.]+), (float16 [0-9.]+), (uint8 [0-9.]+)", readme)
    lines = printed.splitlines()
    for text in per_precision.groups():
        assert text in lines, (text, lines)
    assert "log (256, 256)" in lines
    assert (tmp_path / "blob.exr").is_file() and (tmp_path / "blob.png").is_file()
