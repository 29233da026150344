"""docs/python.md runs as written: its ```python blocks, in order, in one
namespace, in a copy of examples/data."""

import os
import pathlib
import re
import shutil

REPO = pathlib.Path(__file__).resolve().parents[3]


def python_blocks(text):
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_the_walk_through_runs(tmp_path, capsys):
    doc = (REPO / "docs" / "python.md").read_text()
    blocks = python_blocks(doc)
    assert len(blocks) >= 5
    shutil.copytree(REPO / "examples" / "data", tmp_path / "data")
    here = os.getcwd()
    os.chdir(tmp_path / "data")
    try:
        namespace = {"__name__": "__docs__"}
        for i, block in enumerate(blocks):
            code = compile(block, f"docs/python.md block {i + 1}", "exec")
            exec(code, namespace)
    finally:
        os.chdir(here)
    out = capsys.readouterr().out
    assert "contour error max" in out
    # The error example printed the program name and line of the refusal.
    assert "far.ngc 3" in out
