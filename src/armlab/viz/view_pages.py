"""The report's interactive 3-D views: one small page per run, next to ``report.html``.

The report itself runs no script (its Content-Security-Policy forbids every one); each view
is an ``<iframe loading="lazy">`` of a page of its own, which its browser loads only when it
scrolls into sight::

    report.html                      no script; CSP adds frame-src 'self' for the views
    view3d/plotly-<version>.min.js   plotly.js as the installed plotly package ships it (once)
    view3d/view3d.js                 draws the figure of the page that loads it
    view3d/<run>.html                one run: its figure as a JSON data block, CSP script-src 'self'

so plotly.js (≈ 4.8 MB) is written once per folder, not once per run, and every page asks for
nothing but those two local scripts (``'self'`` matches ``file:`` URLs in Chromium).  A
page's figure is :func:`armlab.viz.view3d.view3d_spec` with its coordinates as plotly.js typed
arrays of float32 (``{"dtype": "f4", "bdata": <base64>}``): half the size of float64, and
0.1 µm from the float64 coordinates of an arm a metre long.

Needs plotly (the optional extra ``viewer``) only for its plotly.js file: :func:`plotly_js`
is None without it, and the report then goes without views and says so.
"""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path

import numpy as np

from armlab.files import write_text
from armlab.viz.html import escape

FOLDER = "view3d"
LOADER = "view3d.js"

# The page's own policy: its two local scripts, inline style (plotly injects its CSS), data:
# images (plotly's icons); nothing else, and nothing from a network.
CONTENT_SECURITY_POLICY = "default-src 'none'; script-src 'self'; style-src 'unsafe-inline'; img-src data:"

# Draws the figure of the page's data block; plotly.js is loaded before it.  Animation frames
# are added once the plot exists (as plotly's own HTML export does); then the view is marked
# data-drawn="<frames>", which a reader of the page's DOM (a headless browser) can check.
LOADER_JS = """\
"use strict";
(function () {
  var figure = JSON.parse(document.getElementById("figure").textContent);
  var view = document.getElementById("view");
  Plotly.newPlot(view, figure.data, figure.layout, {displaylogo: false, responsive: true})
    .then(function () {
      return figure.frames.length ? Plotly.addFrames(view, figure.frames) : null;
    })
    .then(function () {
      view.setAttribute("data-drawn", String(figure.frames.length));
    });
})();
"""


def plotly_js() -> tuple[str, str] | None:
    """(file name, text) of the plotly.js bundled with the installed plotly package, or None
    when plotly is not installed."""
    try:
        from plotly.offline import get_plotlyjs, get_plotlyjs_version
    except ImportError:
        return None
    return f"plotly-{get_plotlyjs_version()}.min.js", get_plotlyjs()


def write_assets(out_dir: str | Path, script: tuple[str, str]) -> None:
    """Write plotly.js (``script`` from :func:`plotly_js`) and the loader into
    ``out_dir/view3d``; a plotly.js file of the same name and size is kept as it is."""
    folder = Path(out_dir) / FOLDER
    folder.mkdir(parents=True, exist_ok=True)
    name, text = script
    path = folder / name
    data = text.encode("utf-8")
    if not (path.is_file() and path.stat().st_size == len(data)):
        write_text(path, text)
    loader = folder / LOADER
    if not (loader.is_file() and loader.read_text(encoding="utf-8") == LOADER_JS):
        write_text(loader, LOADER_JS)


def _typed(value):
    """JSON of a NumPy array as a plotly.js typed array: float32, or the smallest integer type
    that holds it."""
    if isinstance(value, np.ndarray):
        if value.dtype.kind == "f":
            array, dtype = value.astype("<f4"), "f4"
        elif value.size and (value.min() < 0 or value.max() > 65535):
            array, dtype = value.astype("<i4"), "i4"
        else:
            array, dtype = value.astype("<u2"), "u2"
        data = base64.b64encode(np.ascontiguousarray(array).tobytes()).decode("ascii")
        return {"dtype": dtype, "bdata": data}
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def figure_json(spec: dict) -> str:
    """``spec`` as JSON that can sit inside a ``<script>`` element: arrays as typed arrays,
    every ``<`` escaped (no ``</script>`` can end the block)."""
    text = json.dumps(spec, default=_typed, allow_nan=False, separators=(",", ":"), ensure_ascii=False)
    return text.replace("<", "\\u003c")


def page_name(run: str) -> str:
    """The file of run ``run``'s view inside ``view3d/``."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", run) + ".html"


def view_page(spec: dict, title: str, script: str) -> str:
    """The HTML of one view: the figure ``spec`` drawn by plotly.js file ``script``."""
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f'<meta http-equiv="Content-Security-Policy" content="{CONTENT_SECURITY_POLICY}">'
            f"<title>{escape(title)}</title>"
            "<style>html, body { margin: 0; height: 100%; background: #fff; } "
            "#view { width: 100%; height: 100%; }</style></head><body>"
            '<div id="view"></div>'
            f'<script type="application/json" id="figure">{figure_json(spec)}</script>'
            f'<script src="{escape(script)}"></script><script src="{LOADER}"></script>'
            "</body></html>\n")


def write_view_page(out_dir: str | Path, run: str, spec: dict, title: str, script: str) -> str:
    """Write run ``run``'s view into ``out_dir/view3d``; returns its path relative to
    ``out_dir`` (the iframe's ``src``)."""
    relative = f"{FOLDER}/{page_name(run)}"
    write_text(Path(out_dir) / relative, view_page(spec, title, script))
    return relative


def view_iframe(src: str, run: str, caption: str) -> str:
    """The report's element for one view: a lazily loaded iframe and its caption."""
    return (f'<figure class="view3d" id="view-{escape(run)}" data-view3d="{escape(run)}">'
            f'<iframe loading="lazy" src="{escape(src)}" title="{escape(caption)}"></iframe>'
            f"<figcaption>{escape(caption)}</figcaption></figure>")
