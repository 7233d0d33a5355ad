"""The equation tags the report uses (C2, E3, T1 …), each defined where it is used.

The tags are those of the notation table in ``docs/notation.md`` ("| C2 | equation | where |"
rows) and, for the theory's predictions, the tags (T1)–(T5) of :mod:`armlab.theory`'s
docstring, which are numbered on their own: a ``T`` tag of an experiment that prints a
prediction with that tag is the theory's.  :func:`legend_html` is the short legend an
experiment of the report carries of the tags its text, tables and figures use.
"""

from __future__ import annotations

import functools
import html
import re

from armlab.viz.notes import DOCS

TAG = re.compile(r"(?<![\w^_])([CKDRSTE]\d{1,2})(?![\w])")
CELL = re.compile(r"(?<!\\)\|")  # a table cell's border, not an escaped \| inside it


@functools.cache
def notation_tags(docs=DOCS) -> dict[str, str]:
    """tag → equation, from the tables of ``docs/notation.md`` ({} without the docs)."""
    path = docs / "notation.md"
    if not path.is_file():
        return {}
    tags = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        cells = [cell.strip() for cell in CELL.split(line.strip())]
        if len(cells) >= 4 and not cells[0] and re.fullmatch(r"[CKDRSTE]\d{1,2}", cells[1]):
            tags[cells[1]] = cells[2].replace("\\|", "|")
    return tags


@functools.cache
def theory_tags() -> dict[str, str]:
    """tag → statement of :mod:`armlab.theory`'s numbered results (its docstring's bullets)."""
    import armlab.theory

    tags = {}
    for bullet in re.split(r"\n\* ", "\n" + (armlab.theory.__doc__ or "")):
        lines = [line.strip() for line in bullet.strip().splitlines() if line.strip()]
        if not lines:
            continue
        text = " ".join(lines)
        match = re.search(r"\((T\d)\)", text)
        if match:
            statement = re.sub(r"\s*\(T\d\)", "", text)
            statement = re.sub(r":func:`~?([^`]+)`|``([^`]+)``", lambda m: m.group(1) or m.group(2),
                               statement)
            tags[match.group(1)] = statement.strip()
    return tags


def used_tags(text: str) -> list[str]:
    """The tags that ``text`` names, in order of first appearance (each once)."""
    seen: list[str] = []
    for tag in TAG.findall(text):
        if tag not in seen:
            seen.append(tag)
    return seen


def legend(text: str, theory: set[str] = frozenset()) -> list[tuple[str, str, str]]:
    """(tag, source, definition) of every defined tag ``text`` names; the tags in ``theory``
    (those the experiment's predictions carry) are the theory's."""
    notation, proven = notation_tags(), theory_tags()
    rows = []
    for tag in used_tags(text):
        if tag in theory and tag in proven:
            rows.append((tag, "armlab.theory", proven[tag]))
        elif tag in notation:
            rows.append((tag, "docs/notation.md", notation[tag]))
        elif tag in proven:
            rows.append((tag, "armlab.theory", proven[tag]))
    return rows


def legend_html(text: str, theory: set[str] = frozenset()) -> str:
    """The legend of :func:`legend` as a note ('' when ``text`` names no defined tag)."""
    rows = legend(text, theory)
    if not rows:
        return ""
    items = "".join(f"<li><b>{html.escape(tag)}</b> ({html.escape(source)}): "
                    f"{html.escape(definition.replace('`', ''))}</li>" for tag, source, definition in rows)
    return f'<div class="note tags"><p>Equation tags used here:</p><ul>{items}</ul></div>'
