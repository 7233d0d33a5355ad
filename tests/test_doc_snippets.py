"""Every ```python block of the README and docs/*.md runs as written (in a fresh namespace,
blocks of one page in order, so that a later block may use an earlier one's names).  A block
with an elided body (a line ``...``) is a sketch of code to write, and is not run."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
ELIDED = re.compile(r"^\s*\.\.\.\s*$", re.M)


def _blocks(page: Path) -> list[str]:
    return [b for b in BLOCK.findall(page.read_text(encoding="utf-8")) if not ELIDED.search(b)]


def _pages_with_snippets():
    return [p for p in PAGES if _blocks(p)]


def test_the_snippet_reader_finds_the_pages_with_python():
    names = {p.name for p in _pages_with_snippets()}
    assert {"README.md", "A7-inverse-dynamics.md"} <= names


@pytest.mark.slow
@pytest.mark.parametrize("page", _pages_with_snippets(), ids=lambda p: p.name)
def test_python_snippets_of_the_docs_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a snippet that writes files writes them here
    namespace: dict = {"__name__": "__doc_snippet__"}
    for k, code in enumerate(_blocks(page)):
        exec(compile(code, f"{page.name} python block {k + 1}", "exec"), namespace)
