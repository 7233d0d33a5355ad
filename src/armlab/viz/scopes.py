"""Drawing the scope figures of a :class:`~armlab.simulation.SimulationResult` (the seed's Simulink scopes).

Which figures a run gets, and what is in their panels, is :func:`armlab.viz.layout.scope_layout`;
this module draws them.  Each figure is one column of panels sharing the time axis, which spans
the run from its first sample to its last; legends and notes (final values, what is off-scale)
sit in a column right of the panels, so they never cover a trace.  Long runs are decimated by
keeping each bucket's minimum and maximum (and the run's first and last sample), so saturation
and chattering stay visible.  :func:`render_scope` gives a figure; :func:`scope_png` gives the
same picture as PNG bytes faster, drawn on a figure kept for the next scope with as many panels.
"""

from __future__ import annotations

import re
import textwrap
import threading
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.transforms import blended_transform_factory

from armlab.errors import ScopeError
from armlab.files import replacing
from armlab.metrics import FORCE_REFERENCES, ROUNDING  # noqa: F401  (also imported from here by callers)
from armlab.viz.html import figure_png
from armlab.viz.layout import main_scopes, scope_layout  # noqa: F401  (also imported from here by callers)
from armlab.viz.scope_model import (  # noqa: F401  (also imported from here by callers)
    ACTUAL,
    COMMAND,
    DESIRED,
    INSET_BANDS,
    LIMIT,
    Panel,
    Scope,
    Zoom,
    pretty,
)

MAX_POINTS = 1000
ZERO = ROUNDING  # SI magnitudes below this are rounding noise (no quantity here is that small)
FORMATS = ("png", "svg")
SCOPE_DPI = 120  # scope PNGs of `armlab run --plot` and the report
# Figure geometry [in]: the panels' left margin, the column of legends and notes right of them
# (and its gap to the panels), one panel row, the title above and the time axis below, one
# line of footnote (caption, diagnosis).
WIDTH, LEFT, COLUMN, GAP = 8.0, 0.92, 1.55, 0.1
ROW, TITLE, AXIS, FOOT_LINE = 1.55, 0.42, 0.45, 0.15
FOOT_CHARACTERS = 130  # a footnote line at its font size across the figure
TITLE_CHARACTERS, TITLE_LINE = 88, 0.2  # a title line at its font size across the figure; its height [in]
FONT, SMALL = 9, 7.5


def decimate(t: np.ndarray, y: np.ndarray, max_points: int = MAX_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """At most ``max_points`` samples of (t (N,), y (N,)): the first and the last sample, and
    of each of ``max_points // 2 − 1`` buckets its min and max (both ends of a bucket that
    holds a non-finite value).  The ends are kept so the trace spans the whole run even where
    its last bucket is flat.  Vectorised: a report draws over a thousand traces."""
    n = t.size
    if n <= max_points:
        return t, y
    buckets = max_points // 2 - 1
    edges = np.linspace(0, n, buckets + 1).astype(int)
    starts, stops = edges[:-1], edges[1:]
    full = stops > starts
    starts, stops = starts[full], stops[full]
    sizes = stops - starts
    index = np.arange(n)
    finite = np.isfinite(y)
    clean = np.where(finite, y, 0.0)
    # First index of each bucket's min and max (what argmin/argmax give), all buckets at once.
    lows = np.repeat(np.minimum.reduceat(clean, starts), sizes)
    highs = np.repeat(np.maximum.reduceat(clean, starts), sizes)
    i_min = np.minimum.reduceat(np.where(clean == lows, index, n), starts)
    i_max = np.minimum.reduceat(np.where(clean == highs, index, n), starts)
    broken = ~np.logical_and.reduceat(finite, starts)
    i_min = np.where(broken, starts, i_min)
    i_max = np.where(broken, stops - 1, i_max)
    keep = np.unique(np.concatenate([[0, n - 1], i_min, i_max]))
    return t[keep], y[keep]


def _scenario_name(result) -> str:
    return str(result.meta.get("scenario") or result.meta.get("name") or result.meta.get("plant", "run"))


def file_stem(result) -> str:
    """The run's name as a file-name prefix: its scenario's name, characters other than
    letters, digits, '.', '-' and '_' replaced by '_' (a name never leaves ``out_dir``)."""
    return re.sub(r"[^\w.-]", "_", _scenario_name(result)).lstrip(".") or "run"


def _rounding_noise(panel: Panel) -> bool:
    """True when every curve and line of ``panel`` stays below :data:`ZERO` in magnitude."""
    values = [np.nanmax(np.abs(y)) for _, _, y, _ in panel.curves if np.any(np.isfinite(y))]
    values += [abs(v) for v, _ in panel.hlines]
    return bool(values) and max(values) < ZERO


def _footnotes(scope: Scope, diagnosis: str) -> list[tuple[str, str]]:
    """(text wrapped to the figure's width, colour) of the lines under the time axis."""
    notes = [(scope.caption, "0.3"), (diagnosis, LIMIT)]
    return [("\n".join(textwrap.wrap(text, FOOT_CHARACTERS)), colour) for text, colour in notes if text]


def _figure_size(rows: int, foot_lines: int = 0, title_lines: int = 1) -> tuple[float, float]:
    return WIDTH, TITLE + TITLE_LINE * (title_lines - 1) + AXIS - 0.27 + ROW * rows + FOOT_LINE * foot_lines


def _title_lines(title: str) -> str:
    """The figure title wrapped to the figure's width (a long one would be cut at its edges)."""
    return "\n".join(textwrap.wrap(title, TITLE_CHARACTERS)) or title


def _span(scope: Scope) -> tuple[float, float]:
    """The time span [s] of the run the scope shows: its first sample to its last."""
    starts = [float(t[0]) for panel in scope.panels for _, t, _, _ in panel.curves if len(t)]
    stops = [float(t[-1]) for panel in scope.panels for _, t, _, _ in panel.curves if len(t)]
    if not starts or max(stops) <= min(starts):
        return 0.0, 1.0
    return min(starts), max(stops)


def _style_panels(axes) -> None:
    """What every scope's panels share, set once per figure: grid, tick label size, no x
    margin, the time label under the last panel."""
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.tick_params(labelsize=8)
        # A small ×1e−8 above a panel stays in the gap to the panel above it.
        ax.yaxis.get_offset_text().set_fontsize(7)
        ax.margins(x=0)
    axes[-1].set_xlabel("t [s]", fontsize=FONT)


def _draw_zoom(ax, panel: Panel, end: float) -> None:
    """The inset of ``panel.zoom``: the panel's curves from its start to ``end``, in the right
    half of ``ax``, above or below the curves as the layout chose."""
    zoom = panel.zoom
    low, high = zoom.band or INSET_BANDS[zoom.above]
    inset = ax.inset_axes([0.5, low, 0.47, high - low])
    for _, t, y, style in panel.curves:
        t, y = np.asarray(t), np.asarray(y)
        inside = t >= zoom.start
        inset.plot(*decimate(t[inside], y[inside]), **style)
    for value, style in panel.hlines:
        # A level inside the inset (a spring's rest plane) is what the zoom compares with.
        if zoom.ylim[0] <= value <= zoom.ylim[1]:
            inset.axhline(value, **{key: v for key, v in style.items() if key != "label"})
    inset.set_xlim(zoom.start, end)
    inset.set_ylim(*zoom.ylim)
    inset.grid(True, lw=0.4, alpha=0.6)
    inset.tick_params(labelsize=6.5, pad=1.5, length=2.5)
    inset.patch.set_alpha(0.92)


def _draw_scope(fig, axes, scope: Scope, title_prefix: str, diagnosis: str) -> None:
    """Draw ``scope`` on ``fig``, whose ``axes`` (one per panel) are styled and empty."""
    footnotes = _footnotes(scope, diagnosis)
    title = _title_lines(f"{title_prefix}: {scope.title}" if title_prefix else scope.title)
    title_lines = title.count("\n") + 1
    foot_lines = sum(text.count("\n") + 1 for text, _ in footnotes)
    fig.set_size_inches(_figure_size(len(axes), foot_lines, title_lines))
    start, end = _span(scope)
    beside = 1.0 + GAP / (WIDTH - LEFT - COLUMN)  # the column right of the panels, in axes widths
    notes = {}
    for ax, panel in zip(axes, scope.panels, strict=True):
        if panel.log:
            ax.set_yscale("log")
        for label, t, y, style in panel.curves:
            td, yd = decimate(np.asarray(t), np.asarray(y))
            ax.plot(td, yd, label=label, **style)
        for value, style in panel.hlines:
            ax.axhline(value, **style)
        if panel.ylim is not None:
            ax.set_ylim(*panel.ylim)
        note, level = panel.note, panel.note_at
        if _rounding_noise(panel):
            # Values like 1e-16 are rounding noise; autoscaled they would look like a signal.
            ax.set_ylim(-1.0, 1.0)
            note, level = f"zero to rounding\n(|·| < {ZERO:g})", 0.0
        notes[id(panel)] = note, level
        ax.set_ylabel(panel.ylabel, fontsize=FONT)
        if panel.zoom is not None:
            _draw_zoom(ax, panel, end)
            # Beside the inset, away from the final value (which the tail puts in the other half).
            middle = sum(panel.zoom.band or INSET_BANDS[panel.zoom.above]) / 2
            ax.text(beside, middle, f"inset: zoom on\nt ≥ {panel.zoom.start:.3g} s",
                    transform=ax.transAxes, ha="left", va="center", fontsize=SMALL, color="0.15")
    axes[0].set_xlim(start, end)  # shared: every panel spans the run
    shown: set[str] = set()
    for ax, panel in zip(axes, scope.panels, strict=True):
        # Panels of one scope share their curve names: a legend where names appear that no
        # panel above has shown (every panel of the "signals" scope has its own).  A single
        # curve needs none: the y label names it.
        handles, labels = ax.get_legend_handles_labels()
        legend = len(handles) > 1 and not set(labels) <= shown
        if legend:
            ax.legend(fontsize=SMALL, loc="upper left", bbox_to_anchor=(beside, 1.0), borderaxespad=0.0,
                      frameon=False, handlelength=2.6, labelspacing=0.35)
            shown.update(labels)
        note, level = notes[id(panel)]
        if note:
            # Level with the value it gives (a final value) when no legend shares the column.
            at_value = level is not None and not legend
            transform = blended_transform_factory(ax.transAxes, ax.transData) if at_value else ax.transAxes
            ax.text(beside, level if at_value else 0.0, note, transform=transform, ha="left",
                    va="center" if at_value else "bottom", fontsize=SMALL, color="0.15", linespacing=1.25)
    fig.suptitle(title, fontsize=10.5, y=1.0 - 0.1 / fig.get_figheight(), va="top", linespacing=1.2)
    height = fig.get_figheight()
    bottom = 0.06
    for text, colour in reversed(footnotes):
        fig.text(0.5, bottom / height, text, ha="center", va="bottom", fontsize=SMALL, color=colour,
                 linespacing=1.2, gid="footnote")
        bottom += FOOT_LINE * (text.count("\n") + 1)
    # Fixed margins in inches (tight_layout would cost as much as drawing the figure).
    top = TITLE + TITLE_LINE * (title_lines - 1)
    fig.subplots_adjust(left=LEFT / WIDTH, right=1.0 - COLUMN / WIDTH, top=1.0 - top / height,
                        bottom=(AXIS + bottom - 0.06) / height, hspace=0.13)


def _tick_label_boxes(axis, renderer) -> list:
    """Display boxes of the tick labels ``axis`` draws: non-empty, at ticks inside the view.
    (Without any, a label goes next to the axes frame, not past the tick marks as matplotlib
    puts it; a scope panel always has tick labels.)"""
    low, high = sorted(axis.get_view_interval())
    close = 1e-10 * (high - low)  # the tolerance matplotlib draws ticks at the view's ends with
    coordinate = 0 if axis.axis_name == "x" else 1
    return [label.get_window_extent(renderer) for label in axis.get_ticklabels()
            if label.get_text() and low - close <= label.get_position()[coordinate] <= high + close]


def _place_labels(fig, axes) -> None:
    """The axis labels where matplotlib puts them when ``fig`` is drawn at its own dpi, the
    y labels aligned as by ``fig.align_ylabels``, but measured once here: matplotlib places
    them again at every draw, measuring the tick labels of every panel for each panel."""
    renderer = fig.canvas.get_renderer()
    frame = axes[0].bbox  # every panel spans the same width
    left = min([frame.x0] + [box.x0 for ax in axes for box in _tick_label_boxes(ax.yaxis, renderer)])
    x = (left - axes[0].yaxis.labelpad * fig.dpi / 72.0 - frame.x0) / frame.width
    for ax in axes:
        ax.yaxis.set_label_coords(x, 0.5)
    frame = axes[-1].bbox
    bottom = min([frame.y0] + [box.y0 for box in _tick_label_boxes(axes[-1].xaxis, renderer)])
    axes[-1].xaxis.set_label_coords(0.5, (bottom - axes[-1].xaxis.labelpad * fig.dpi / 72.0 - frame.y0)
                                    / frame.height)
    for ax in axes[:-1]:
        ax.xaxis.set_label_coords(0.5, 0.0)  # empty labels above the shared time axis


def render_scope(scope: Scope, *, title_prefix: str = "", diagnosis: str = ""):
    """A matplotlib Figure of ``scope``: one panel per row, shared time axis [s]."""
    rows = len(scope.panels)
    fig, axes = plt.subplots(rows, 1, sharex=True, figsize=_figure_size(rows), squeeze=False)
    axes = list(axes[:, 0])
    _style_panels(axes)
    _draw_scope(fig, axes, scope, title_prefix, diagnosis)
    fig.align_ylabels(axes)  # measured when drawn: the dpi it will be drawn at is not known here
    return fig


_KEPT = threading.local()  # {panel count: (figure, axes)}, per thread: matplotlib is not thread-safe


def _kept_figure(rows: int, dpi: float):
    """An empty scope figure with ``rows`` styled panels, kept for the next scope with as
    many panels: a fresh figure spends close to half its time creating axes and their ticks."""
    kept = getattr(_KEPT, "figures", None)
    if kept is None:
        kept = _KEPT.figures = {}
    if rows not in kept:
        fig = Figure(figsize=_figure_size(rows), dpi=dpi)
        FigureCanvasAgg(fig)
        axes = list(fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0])
        _style_panels(axes)
        kept[rows] = fig, axes
        return fig, axes
    fig, axes = kept[rows]
    fig.dpi = dpi  # the labels are aligned at the resolution the figure is drawn at
    for ax in axes:
        for artist in [*ax.lines, *ax.texts, *ax.child_axes]:
            artist.remove()
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        ax.set_yscale("linear")  # a log panel's scale, limits and ticks go with it
        ax.relim()
        ax.set_autoscaley_on(True)  # a panel of rounding noise had fixed its limits
        ax.set_prop_cycle(None)  # curves without a colour start from the first again
    for text in [t for t in fig.texts if t.get_gid() == "footnote"]:
        text.remove()
    return fig, axes


def scope_png(scope: Scope, *, title_prefix: str = "", diagnosis: str = "", dpi: int = SCOPE_DPI) -> bytes:
    """The PNG bytes of ``render_scope(scope, title_prefix=…, diagnosis=…)`` at ``dpi``, the
    same picture in a little over half the time: drawn on a figure kept for the next scope
    with as many panels (per thread), whose labels are placed once instead of at every draw."""
    fig, axes = _kept_figure(len(scope.panels), dpi)
    _draw_scope(fig, axes, scope, title_prefix, diagnosis)
    _place_labels(fig, axes)
    return figure_png(fig, dpi=dpi)


def plot_scopes(result, out_dir, formats=FORMATS) -> list[Path]:
    """Draw every scope of ``result`` and save it to ``out_dir`` as
    ``<scenario>_<scope>.<format>`` (e.g. ``a7_id_mismatch_q_err.png``: the runs of several
    scenarios can share a folder).

    Parameters
    ----------
    result : SimulationResult
    out_dir : str or Path
        Created if missing.
    formats : sequence of {"png", "svg", "pdf"}
        PNGs at :data:`SCOPE_DPI`.

    Returns
    -------
    The written files, in figure order then format order.
    """
    formats = tuple(formats)
    for fmt in formats:
        if fmt not in ("png", "svg", "pdf"):
            raise ScopeError(f"formats: unknown image format {fmt!r} (use png, svg or pdf)")
    if len(result.t) < 2:
        raise ScopeError("result: fewer than two samples, nothing to plot")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    prefix = _scenario_name(result)
    diagnosis = result.diagnosis if result.status != "ok" else ""
    for scope in scope_layout(result):
        fig, axes = _kept_figure(len(scope.panels), dpi=SCOPE_DPI)
        _draw_scope(fig, axes, scope, prefix, diagnosis)
        _place_labels(fig, axes)
        for fmt in formats:
            path = out_dir / f"{file_stem(result)}_{scope.name}.{fmt}"
            with replacing(path) as temporary:      # atomic: complete or not at all
                fig.savefig(temporary, format=fmt, dpi=SCOPE_DPI,
                            metadata={"Date": None} if fmt == "svg" else None)
            written.append(path)
    return written
