"""Prose the report takes from where it is written once: the seed-discrepancy notes of the
assignment pages ``docs/A<n>-*.md`` and the metric definitions of :mod:`armlab.viz.metrics`.

The notes are read when the report is built, never copied: a page's section whose ``##``
heading speaks of the seed ("Where the seed differs", "Notes on the seed", …) is the
assignment's note, up to the next ``##`` heading.  They are rendered by :func:`markdown_html`,
which knows the Markdown the docs use (paragraphs, bullet lists, indented and fenced code,
pipe tables, ``code``, **bold**, *emphasis*) and nothing else; links keep their text only,
since the report is a single self-contained file.
"""

from __future__ import annotations

import html
import re
from pathlib import Path

# The repository's docs folder (src/armlab/viz/notes.py → the checkout's docs/); an installed
# package has none, and the report then says so.
DOCS = Path(__file__).resolve().parents[3] / "docs"
SEED_HEADING = re.compile(r"^##\s+(?!#).*\bseed\b", re.IGNORECASE)


def seed_notes(number: int, docs: Path = DOCS) -> list[tuple[str, str]]:
    """``(heading, markdown)`` of every ``##`` section of assignment ``number``'s page in
    ``docs`` whose heading speaks of the seed, in page order; [] when there is none."""
    pages = sorted(docs.glob(f"A{number}-*.md")) if docs.is_dir() else []
    if not pages:
        return []
    lines = pages[0].read_text(encoding="utf-8").splitlines()
    found = []
    for start, line in enumerate(lines):
        if SEED_HEADING.match(line):
            stop = next((k for k in range(start + 1, len(lines)) if re.match(r"^##?\s", lines[k])),
                        len(lines))
            found.append((line.lstrip("#").strip(), "\n".join(lines[start + 1:stop]).strip("\n")))
    return found


# "above" that points at the page's text, not at a place in space ("above the surface", "above
# its rest plane", "above x_d", "above 0.1 m").
POINTER = re.compile(r"\babove\b(?!\s+(?:the|its?|an?|[xyzσΣ]|\d|in docs/))")


def anchored(text: str, page: str) -> str:
    """``text`` of a note taken out of its docs ``page`` with each "see above", "the output
    above" … pointing at the page ("above in docs/A6-joint-pd.md"): the report shows the note
    without what stood above it."""
    return POINTER.sub(f"above in {page}", text) if page else text


def source_name(number: int, docs: Path = DOCS) -> str:
    """The docs page of assignment ``number`` as the report names it (``docs/A7-….md``)."""
    pages = sorted(docs.glob(f"A{number}-*.md")) if docs.is_dir() else []
    return f"docs/{pages[0].name}" if pages else ""


def _inline(text: str) -> str:
    """One line of Markdown prose as HTML: escaped, with code spans, bold, emphasis and the
    text of links."""
    parts = re.split(r"(`[^`]*`)", text)
    out = []
    for k, part in enumerate(parts):
        if k % 2:
            out.append(f"<code>{html.escape(part[1:-1])}</code>")
            continue
        part = html.escape(part, quote=False)
        part = re.sub(r"\[([^\]]+)\]\([^)]*\)", r"\1", part)
        part = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", part)
        part = re.sub(r"(?<![\w*])\*(?!\s)(.+?)(?<!\s)\*(?![\w*])", r"<em>\1</em>", part)
        out.append(part)
    return "".join(out)


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def _table(rows: list[str]) -> str:
    cells = [[c.strip() for c in row.strip().strip("|").split("|")] for row in rows]
    body = [r for r in cells[1:] if not all(re.fullmatch(r":?-+:?", c) for c in r)]
    head = "".join(f"<th>{_inline(c)}</th>" for c in cells[0])
    rows_html = "".join("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>" for r in body)
    # In the box armlab.viz.html.scrolling draws: a wide table scrolls inside its note.
    table = f"<table><thead><tr>{head}</tr></thead><tbody>{rows_html}</tbody></table>"
    return f'<div class="table-scroll">{table}</div>'


def markdown_html(text: str) -> str:
    """The subset of Markdown the docs use, as HTML (see the module docstring)."""
    lines = text.splitlines()
    out: list[str] = []
    k = 0
    while k < len(lines):
        line = lines[k]
        if not line.strip():
            k += 1
        elif line.startswith("```"):
            stop = next((j for j in range(k + 1, len(lines)) if lines[j].startswith("```")), len(lines))
            out.append(f"<pre>{html.escape(chr(10).join(lines[k + 1:stop]))}</pre>")
            k = stop + 1
        elif line.startswith("|"):
            stop = next((j for j in range(k, len(lines)) if not lines[j].startswith("|")), len(lines))
            out.append(_table(lines[k:stop]))
            k = stop
        elif _indent(line) >= 4:
            stop = next((j for j in range(k, len(lines)) if lines[j].strip() and _indent(lines[j]) < 4),
                        len(lines))
            out.append(f"<pre>{html.escape(chr(10).join(x[4:] for x in lines[k:stop]).rstrip())}</pre>")
            k = stop
        elif re.match(r"^#{1,6}\s", line):
            out.append(f"<h4>{_inline(line.lstrip('#').strip())}</h4>")
            k += 1
        elif re.match(r"^[*-]\s", line):
            items = []
            while k < len(lines) and re.match(r"^[*-]\s", lines[k]):
                body = [lines[k][2:].strip()]
                k += 1
                # The item's lines: indented continuations, and blank lines followed by more.
                while k < len(lines) and (lines[k].startswith("  ") or not lines[k].strip()):
                    if not lines[k].strip() and not (k + 1 < len(lines) and lines[k + 1].startswith("  ")):
                        break
                    body.append(lines[k][2:] if lines[k].strip() else "")
                    k += 1
                items.append(f"<li>{markdown_html(chr(10).join(body))}</li>")
                while k < len(lines) and not lines[k].strip():
                    k += 1
            out.append(f"<ul>{''.join(items)}</ul>")
        else:
            stop = k
            while stop < len(lines) and lines[stop].strip() and not re.match(r"^([*-]\s|```|\||#{1,6}\s)",
                                                                             lines[stop]):
                stop += 1
            paragraph = " ".join(x.strip() for x in lines[k:stop])
            out.append(f"<p>{_inline(paragraph)}</p>")
            k = stop
    # A list item of one paragraph shows as its text, not as a paragraph inside the item.
    result = "".join(out)
    return result[3:-4] if len(out) == 1 and result.startswith("<p>") else result


def metric_definitions() -> str:
    """The definitions of :mod:`armlab.metrics` and the rows of :mod:`armlab.viz.metrics`, from
    their docstrings, as HTML."""
    import armlab.metrics
    from armlab.viz import metrics

    text = "\n\n".join(module.__doc__ or "" for module in (armlab.metrics, metrics))
    text = re.sub(r":\w+:`~?([^`]+)`", r"`\1`", text)  # reST roles and literals
    return markdown_html(text.replace("``", "`"))
