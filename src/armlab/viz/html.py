"""Pieces of a self-contained HTML document: sections, tables, inline images, MathML.

Nothing here reaches the network: images are ``data:`` URIs, the style sheet is inline and
formulas are presentation MathML (``sympy.printing.mathml``), which browsers render natively
(MathML Core), so the document needs no script and no font download.
"""

from __future__ import annotations

import base64
import html
import io
import zlib

from PIL import Image

STYLE = """
:root { --ink: #1b1f24; --muted: #5b6570; --rule: #d8dde3; --accent: #1f5fd6; --bad: #b42318; }
* { box-sizing: border-box; }
body { margin: 0; font: 15px/1.5 "DejaVu Sans", "Liberation Sans", sans-serif; color: var(--ink);
       background: #fbfcfd; }
header { padding: 28px 40px 18px; border-bottom: 1px solid var(--rule); background: #fff; }
header h1 { margin: 0 0 4px; font-size: 26px; }
header p { margin: 2px 0; color: var(--muted); }
nav { padding: 10px 40px; border-bottom: 1px solid var(--rule); background: #f3f5f8; font-size: 14px; }
nav a { margin-right: 14px; color: var(--accent); text-decoration: none; white-space: nowrap; }
main { padding: 8px 40px 60px; max-width: 1320px; }
section.assignment { margin-top: 34px; padding-top: 6px; border-top: 3px solid var(--accent); }
section.assignment > h2 { font-size: 22px; margin: 8px 0 6px; }
article.experiment { margin: 22px 0 10px; padding: 14px 18px; background: #fff;
                     border: 1px solid var(--rule); border-radius: 6px; }
article.experiment h3 { margin: 0 0 6px; font-size: 18px; }
.description { color: #2d343c; max-width: 980px; }
.figures { display: flex; flex-wrap: wrap; gap: 14px; margin-top: 10px; }
figure { margin: 0; padding: 6px; background: #fff; border: 1px solid var(--rule); border-radius: 4px; }
figure img { display: block; max-width: 100%; height: auto; }
figure.scope img { width: 570px; }
figure.drawing img { width: 400px; }
figure.diagram img { width: auto; max-width: 100%; }
figure.diagram figcaption { max-width: 900px; }
figure.drawing figcaption { max-width: 400px; }
figure.view3d iframe { display: block; width: 760px; max-width: 100%; height: 610px; border: 0; }
figure.view3d figcaption { max-width: 760px; }
figcaption { font-size: 12.5px; color: var(--muted); padding: 4px 2px 0; max-width: 570px; }
/* A table wider than its box (a metrics table of 13 components is ~1600 px) scrolls inside it
   rather than running out of the article and off the page. */
.table-scroll { max-width: 100%; overflow-x: auto; margin: 8px 0; }
.table-scroll > table { margin: 0; }
table { border-collapse: collapse; margin: 8px 0; font-size: 13.5px; }
th, td { border: 1px solid var(--rule); padding: 3px 9px; text-align: left; vertical-align: top; }
th { background: #f0f3f7; font-weight: 600; }
td.num { text-align: right; font-variant-numeric: tabular-nums; font-family: "DejaVu Sans Mono", monospace; }
.tables { display: flex; flex-wrap: wrap; gap: 0 24px; align-items: flex-start; }
.tables td { max-width: 250px; overflow-wrap: anywhere; }
/* A metrics table's quantity column stays in view while its components scroll past. */
.tables table.metrics td:first-child { min-width: 210px; overflow-wrap: normal; }
table.metrics th:first-child, table.metrics td:first-child { position: sticky; left: 0; z-index: 1;
  background: #fff; box-shadow: inset -1px 0 0 var(--rule); }
table.metrics th:first-child { background: #f0f3f7; }
.table-scroll > table > caption { text-align: left; }
.tables td.num { font-size: 12.5px; white-space: nowrap; }
/* A formula too wide for the space beside its label goes under it; one still too wide (a single
   term wider than the page) scrolls inside its box. */
.formula { margin: 8px 0; overflow-x: auto; overflow-y: hidden; padding: 2px 0; display: flex;
           flex-wrap: wrap; align-items: center; gap: 4px 18px; }
.formula .label { flex: 0 0 250px; }
.formula math { margin: 0; }
math { font-family: "DejaVu Math TeX Gyre", "STIX Two Math", "Latin Modern Math", math; }
math mtable.matrix { padding: 1px 6px; border-left: 1.4px solid currentColor;
  border-right: 1.4px solid currentColor;
  background: linear-gradient(currentColor, currentColor) top left / 6px 1.4px no-repeat,
              linear-gradient(currentColor, currentColor) bottom left / 6px 1.4px no-repeat,
              linear-gradient(currentColor, currentColor) top right / 6px 1.4px no-repeat,
              linear-gradient(currentColor, currentColor) bottom right / 6px 1.4px no-repeat; }
.formula .label { color: var(--muted); font-size: 13px; margin-bottom: 2px; }
math[display="block"] { font-size: 17px; text-align: left; }
.diverged { color: var(--bad); font-weight: 600; }
.missing { color: var(--muted); font-style: italic; }
.note { color: var(--muted); font-size: 13.5px; }
.tags { font-size: 12.5px; margin-top: 8px; }
.tags p { margin: 2px 0; }
.tags ul { margin: 2px 0; padding-left: 20px; }
.seed-note { max-width: 1000px; margin: 10px 0 16px; padding: 8px 16px; background: #f4f7fb;
             border-left: 3px solid var(--accent); font-size: 14px; }
.seed-note h3 { margin: 2px 0 4px; font-size: 16px; }
.seed-note h4 { margin: 8px 0 2px; font-size: 14px; }
.seed-note ul { margin: 4px 0; padding-left: 20px; }
.seed-note p { margin: 4px 0; }
.seed-note pre { font: 12.5px/1.4 "DejaVu Sans Mono", monospace; background: #eef1f5; padding: 6px 10px;
                 overflow-x: auto; }
code { font-family: "DejaVu Sans Mono", monospace; font-size: 13px; background: #eef1f5;
       padding: 1px 4px; border-radius: 3px; }
"""


def escape(text) -> str:
    return html.escape(str(text), quote=True)


def png_data_uri(data: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def gif_data_uri(data: bytes) -> str:
    return "data:image/gif;base64," + base64.b64encode(data).decode("ascii")


def figure_png(fig, *, dpi: int = 96, tight: bool = False) -> bytes:
    """The PNG bytes of a matplotlib Figure (``tight`` crops the empty margin)."""
    buffer = io.BytesIO()
    if tight or not hasattr(fig.canvas, "buffer_rgba"):
        crop = {"bbox_inches": "tight", "pad_inches": 0.08} if tight else {}
        fig.savefig(buffer, format="png", dpi=dpi, **crop)
        return buffer.getvalue()
    # Drawn and encoded here rather than by savefig, which always writes RGBA: an opaque figure
    # saved as RGB with zlib's default strategy is ~13 % smaller and encodes in half the time.
    saved = fig.dpi
    fig.dpi = dpi
    try:
        fig.canvas.draw()
        image = Image.frombuffer("RGBA", fig.canvas.get_width_height(physical=True),
                                 fig.canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        if image.getextrema()[3][0] == 255:
            image = image.convert("RGB")
        image.save(buffer, format="png", dpi=(dpi, dpi), compress_level=4,
                   compress_type=zlib.Z_DEFAULT_STRATEGY)
    finally:
        fig.dpi = saved
    return buffer.getvalue()


def figure(uri: str, caption: str, *, kind: str, ident: str) -> str:
    """An inline image with its caption; ``kind`` is the CSS class, ``ident`` the element id."""
    return (f'<figure class="{escape(kind)}" id="{escape(ident)}" data-figure="{escape(ident)}">'
            f'<img alt="{escape(caption)}" src="{uri}"><figcaption>{escape(caption)}</figcaption></figure>')


def table(headers: list[str], rows: list[list], *, numeric: set[int] = frozenset(), caption: str = "",
          kind: str = "") -> str:
    """A table in a box that scrolls sideways when it is wider than the page; the columns in
    ``numeric`` are right-aligned, ``kind`` is the table's CSS class."""
    head = "".join(f"<th>{escape(h)}</th>" for h in headers)
    body = []
    for row in rows:
        cells = "".join(f'<td class="num">{escape(c)}</td>' if k in numeric else f"<td>{escape(c)}</td>"
                        for k, c in enumerate(row))
        body.append(f"<tr>{cells}</tr>")
    cap = f"<caption>{escape(caption)}</caption>" if caption else ""
    opening = f'<table class="{escape(kind)}">' if kind else "<table>"
    return scrolling(f"{opening}{cap}<thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>")


def scrolling(table_html: str) -> str:
    """``table_html`` inside a box as wide as the page at most that scrolls sideways."""
    return f'<div class="table-scroll">{table_html}</div>'


def bracket_matrices(mathml: str) -> str:
    """Matrices drawn with CSS brackets instead of ``<mo>[</mo>`` … ``<mo>]</mo>``.

    A bracket operator only stretches to the height of its matrix when the browser has an
    OpenType MATH font; a bordered table looks right with any font.
    """
    return (mathml.replace("<mo>[</mo><mtable>", '<mtable class="matrix">')
            .replace("</mtable><mo>]</mo>", "</mtable>"))


def math_block(label: str, body: str) -> str:
    """``label`` (text) over a formula given as presentation MathML ``body`` (no <math> tag)."""
    body = bracket_matrices(body)
    return (f'<div class="formula"><div class="label">{escape(label)}</div>'
            f'<math display="block">{body}</math></div>')


# The page forbids itself every fetch: images only from data: URIs, inline style, no script.
# A browser that meets anything else blocks it and reports a console error.
CONTENT_SECURITY_POLICY = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"
# A page with interactive 3-D views also frames pages of its own origin (its view3d/ folder;
# 'self' matches file: URLs): still no script in the page itself.
FRAMING_POLICY = CONTENT_SECURITY_POLICY + "; frame-src 'self'"


def document(title: str, subtitle: list[str], nav: list[tuple[str, str]], body: str, *,
             frames: bool = False) -> str:
    """The whole HTML page: header, navigation, body; no external resource and no script
    (enforced by its Content-Security-Policy; ``frames`` lets it frame its own local pages)."""
    links = "".join(f'<a href="#{escape(i)}">{escape(t)}</a>' for i, t in nav)
    lines = "".join(f"<p>{escape(s)}</p>" for s in subtitle)
    policy = FRAMING_POLICY if frames else CONTENT_SECURITY_POLICY
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f'<meta http-equiv="Content-Security-Policy" content="{policy}">'
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{escape(title)}</title><style>{STYLE}</style></head><body>"
            f"<header><h1>{escape(title)}</h1>{lines}</header><nav>{links}</nav>"
            f"<main>{body}</main></body></html>\n")
