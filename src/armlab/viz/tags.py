"""The equation tags the report uses (C2, E3, T1, H3 …), each defined where it is used.

Each tag has one source, told by its letter: the notation table in ``docs/notation.md``
("| C2 | equation | where |" rows, letters :data:`NOTATION_LETTERS`) or, for the theory's
predictions, the tags (H1)–(H6) of :mod:`armlab.theory`'s docstring (:data:`THEORY_LETTER`),
a letter the notation does not use.  :func:`legend_html` is the short legend an experiment of
the report carries of the tags its text, tables and figures use.
"""

from __future__ import annotations

import functools
import html
import re

from armlab.viz.notes import DOCS

NOTATION_LETTERS = "CKDRSTE"   # the tag letters of docs/notation.md's table
THEORY_LETTER = "H"            # armlab.theory's predictions
TAG = re.compile(rf"(?<![\w^_])([{NOTATION_LETTERS}{THEORY_LETTER}]\d{{1,2}})(?![\w])")
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
        if len(cells) >= 4 and not cells[0] and re.fullmatch(rf"[{NOTATION_LETTERS}]\d{{1,2}}", cells[1]):
            tags[cells[1]] = cells[2].replace("\\|", "|")
    return tags


@functools.cache
def theory_tags() -> dict[str, str]:
    """tag → statement of :mod:`armlab.theory`'s numbered results (its docstring's bullets).

    A bullet defines the tag that ends one of its lines, set off by a column of spaces
    ("…   (H3)"); a tag inside the text, "(H6)", refers to another result and stays.
    """
    import armlab.theory

    defining = re.compile(rf"\s{{3,}}\(({THEORY_LETTER}\d{{1,2}})\)\s*$", flags=re.M)
    tags = {}
    for bullet in re.split(r"\n\* ", "\n" + (armlab.theory.__doc__ or "")):
        match = defining.search(bullet)
        if not match:
            continue
        text = " ".join(line.strip() for line in defining.sub("", bullet).splitlines() if line.strip())
        text = re.sub(r":(?:func|mod):`~?([^`]+)`|``([^`]+)``", lambda m: m.group(1) or m.group(2), text)
        tags[match.group(1)] = text
    return tags


RANGE = re.compile(r"(?<![\w^_])([A-Z])(\d{1,2})–\1(\d{1,2})(?![\w])")  # "T1–T4"


def used_tags(text: str) -> list[str]:
    """The tags that ``text`` names, in order of first appearance (each once); a range
    "T1–T4" names T1, T2, T3 and T4."""
    def spelled(m: re.Match) -> str:
        return " ".join(f"{m.group(1)}{k}" for k in range(int(m.group(2)), int(m.group(3)) + 1))

    text = RANGE.sub(spelled, text)
    seen: list[str] = []
    for tag in TAG.findall(text):
        if tag not in seen:
            seen.append(tag)
    return seen


def definitions() -> dict[str, tuple[str, str]]:
    """tag → (source, definition) of every tag the report can use, from both sources."""
    return {**{tag: ("docs/notation.md", text) for tag, text in notation_tags().items()},
            **{tag: ("armlab.theory", text) for tag, text in theory_tags().items()}}


def legend(text: str) -> list[tuple[str, str, str]]:
    """(tag, source, definition) of every defined tag ``text`` names."""
    defined = definitions()
    return [(tag, *defined[tag]) for tag in used_tags(text) if tag in defined]


def legend_html(text: str) -> str:
    """The legend of :func:`legend` as a note ('' when ``text`` names no defined tag)."""
    rows = legend(text)
    if not rows:
        return ""
    items = "".join(f"<li><b>{html.escape(tag)}</b> ({html.escape(source)}): "
                    f"{html.escape(definition.replace('`', ''))}</li>" for tag, source, definition in rows)
    return f'<div class="note tags"><p>Equation tags used here:</p><ul>{items}</ul></div>'
