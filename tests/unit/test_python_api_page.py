"""docs/python-api.md, the notebook walkthrough of the Python API, run whole as written: its Python blocks in order
in one namespace (in a temporary folder, where it writes its .mat file), each ```text block right after a Python
block equal to what that block printed."""

from __future__ import annotations

import contextlib
import io

import pytest
from helpers import doc_page_blocks

PAGE = "python-api.md"


def test_every_block_is_python_or_its_output():
    blocks = doc_page_blocks(PAGE)
    assert blocks and blocks[0][0] == "python"
    assert {language for language, _ in blocks} == {"python", "text"}
    for (before, _), (language, _) in zip(blocks, blocks[1:], strict=False):
        if language == "text":  # an output block follows the block that printed it, never another output
            assert before == "python"


def test_the_page_runs_and_prints_what_it_shows(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    printed = None
    compared = 0
    for number, (language, text) in enumerate(doc_page_blocks(PAGE)):
        if language == "python":
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                exec(compile(text, f"{PAGE} block {number}", "exec"), namespace)
            printed = out.getvalue()
        else:
            if printed is None:
                pytest.fail(f"{PAGE} block {number}: a text block that follows no Python block")
            assert text == printed, f"{PAGE} block {number}: the page shows other output than the code prints"
            compared += 1
            printed = None
    assert compared >= 8  # every section shows what it prints
    assert (tmp_path / "other_tool.mat").is_file()
