"""Test helper: the Python blocks of a Markdown page, and running them as a reader would
(tests/docs/test_docs.py and the pages' own checks in the other stages' tests)."""
import contextlib
import io
import re

BLOCK = re.compile(r"^```([^\n]*)\n(.*?)^```", re.S | re.M)


def python_blocks(path):
    """The runnable blocks of a Markdown file, and the fragments."""
    runnable, fragments = [], []
    for info, code in BLOCK.findall(path.read_text()):
        words = info.split()
        if words[:1] == ["python"]:
            (fragments if "fragment" in words[1:] else runnable).append(code)
    return runnable, fragments


def run_blocks(blocks, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = io.StringIO()
    namespace = {"__name__": "__docs__"}
    with contextlib.redirect_stdout(out):
        for code in blocks:
            exec(compile(code, "<docs>", "exec"), namespace)
    return out.getvalue()
