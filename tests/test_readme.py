"""The README's walkthrough runs as written: every ```python block after a `<!-- walkthrough -->`
marker is executed in order, in one namespace, from the repository root."""

from __future__ import annotations

import os
import re

from conftest import ROOT

MARK = "<!-- walkthrough -->"


def walkthrough_blocks() -> list[str]:
    text = (ROOT / "README.md").read_text()
    return re.findall(re.escape(MARK) + r"\s*```python\n(.*?)```", text, flags=re.S)


def test_readme_walkthrough_runs(capsys):
    blocks = walkthrough_blocks()
    assert len(blocks) == 3, "the README walkthrough lost a snippet (or its marker)"
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        ns: dict = {}
        for i, code in enumerate(blocks):
            exec(compile(code, f"README.md walkthrough block {i + 1}", "exec"), ns)
    finally:
        os.chdir(cwd)
    out = capsys.readouterr().out
    assert "solved" in out and "placed" in out
