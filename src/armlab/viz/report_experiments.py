"""The report's A6–A15 articles: one per scenario run, with its set-up, its measured numbers
(:func:`metric_table`: the components of a group side by side), what went wrong in it, its loop
diagram, scope figures and 3-D view, and the legend of the equation tags it names; and the
figures comparing two runs (:data:`armlab.viz.comparisons.COMPARISONS`).
"""

from __future__ import annotations

import re
from dataclasses import replace

from armlab.simulation.joint_limits import describe_crossing
from armlab.viz import html
from armlab.viz.comparisons import COMPARISONS, comparison_scope
from armlab.viz.experiments import Experiment
from armlab.viz.metrics import Metric
from armlab.viz.report_animation import VIEW_FRAMES
from armlab.viz.scopes import SCOPE_DPI, scope_png
from armlab.viz.tags import legend_html
from armlab.viz.view_pages import view_iframe

# ----------------------------------------------------------------------------- A6–A15


# Components printed side by side, in this order, where the first of them comes: a wrench's
# fy measured by h_e and its fx, fz predicted by the theory are one group of columns.
COLUMN_GROUPS = (("x", "y", "z"), ("φ1", "φ2", "φ3"), ("fx", "fy", "fz", "mx", "my", "mz"))


def column_order(components: list[str]) -> list[str]:
    """``components`` in order of first appearance, those of a :data:`COLUMN_GROUPS` group
    together and in the group's order, at the place of the group's first."""
    ordered: list[str] = []
    for component in components:
        if component in ordered:
            continue
        group = next((g for g in COLUMN_GROUPS if component in g), (component,))
        ordered += [c for c in group if c in components and c not in ordered]
    return ordered


def metric_table(metrics: list[Metric]) -> tuple[list[str], list[list[str]]]:
    """Metrics as one row per quantity and one column per component ("value unit" cells),
    the components of a group (fx, fy, fz …) side by side (:func:`column_order`)."""
    components: list[str] = []
    cells: dict[str, dict[str, str]] = {}
    for m in metrics:
        if m.component not in components:
            components.append(m.component)
        text = f"{m.formatted()} {m.unit}".strip()
        cells.setdefault(m.quantity, {})[m.component] = text
    components = column_order(components)
    headers = ["measured", *[c or "value" for c in components]]
    rows = [[quantity, *[row.get(c, "") for c in components]] for quantity, row in cells.items()]
    return headers, rows


def _experiment_html(exp: Experiment) -> str:
    name = html.escape(exp.name)
    parts = [f'<article class="experiment" id="exp-{name}" data-experiment="{name}">',
             f"<h3>{html.escape(exp.title)} <code>{html.escape(exp.name)}</code></h3>",
             f'<p class="description">{html.escape(exp.description)}</p>']
    tables = []
    if exp.parameters:
        tables.append(html.table(["parameter", "value"], [list(p) for p in exp.parameters],
                                 caption="set-up"))
    if exp.metrics:
        headers, rows = metric_table(exp.metrics)
        tables.append(html.table(headers, rows, numeric=set(range(1, len(headers))), kind="metrics",
                                 caption=f"measured on the run (simulated in {_seconds(exp.seconds)} wall "
                                         "time, compilation included; definitions at the end of the report)"))
    parts.append('<div class="tables">' + "".join(tables) + "</div>")
    result = exp.result
    if exp.error:
        parts.append(f'<p class="diverged">{html.escape(exp.error)}</p>')
    elif result is not None and getattr(result, "status", "ok") != "ok":
        parts.append(f'<p class="diverged">{html.escape(result.diagnosis)}</p>')
    limits = (getattr(result, "meta", None) or {}).get("joint_limits") or {}
    for name, crossing in (limits.get("crossed") or {}).items():
        # A declared joint limit left (or a stop met) is part of what the run shows.
        line = describe_crossing(exp.robot, name, crossing, limits.get("mode", "warn"))
        parts.append(f'<p class="diverged">{html.escape(line)}</p>')
    if exp.diagram:
        caption = (f"{exp.name}: the closed loop as simulated, drawn from the scenario's objects "
                   "(controller, gains, saturation, disturbance, environment, sensors); under the row, "
                   "the measured signals fed back."
                   + (f" Its blocks' equations: {', '.join(exp.diagram_tags)}." if exp.diagram_tags else ""))
        parts.append('<div class="figures">' + html.figure(html.png_data_uri(exp.diagram), caption,
                                                            kind="diagram", ident=f"fig-{exp.name}-loop")
                     + "</div>")
    if exp.figures:
        items = [html.figure(html.png_data_uri(data), caption, kind="scope", ident=f"fig-{exp.name}-{scope}")
                 for scope, caption, data in exp.figures]
        parts.append('<div class="figures">' + "".join(items) + "</div>")
    if exp.view:
        caption = (f"{exp.name} in 3-D: drag to turn, scroll to zoom, ▶ play or move the time slider "
                   f"(the run resampled to at most {VIEW_FRAMES} frames). The page {exp.view} next to "
                   "this file draws it with plotly.js from that folder: no network.")
        parts.append('<div class="figures">' + view_iframe(exp.view, exp.name, caption) + "</div>")
    parts.append(_tags_html(exp, "".join(parts)))
    parts.append("</article>")
    return "".join(parts)


def _tags_html(exp: Experiment, text: str) -> str:
    """The legend of the equation tags the article's text names (:mod:`armlab.viz.tags`)."""
    return legend_html(re.sub(r"<[^>]+>|data:[^\"]+", " ", text))


def _comparisons_html(planned: list[Experiment]) -> dict[int, list[str]]:
    """The figures of :data:`armlab.viz.comparisons.COMPARISONS` whose two runs the report
    has, as HTML blocks by assignment."""
    runs = {e.name: e.result for e in planned if e.result is not None and len(e.result.t) >= 2}
    blocks: dict[int, list[str]] = {}
    for comparison in COMPARISONS:
        if not all(name in runs for name in comparison.runs):
            continue
        scope = comparison_scope(comparison, *(runs[name] for name in comparison.runs))
        # The caption is the article's text above the figure, not repeated under its axes.
        data = scope_png(replace(scope, caption=""), title_prefix=f"A{comparison.assignment}", dpi=SCOPE_DPI)
        ident = f"cmp-{comparison.name}"
        caption = f"{' and '.join(comparison.runs)}: {scope.title}"
        blocks.setdefault(comparison.assignment, []).append(
            f'<article class="experiment" id="{ident}" data-comparison="{ident}">'
            f"<h3>Comparison: {html.escape(scope.title)}</h3>"
            f'<p class="description">{html.escape(scope.caption)}</p><div class="figures">'
            f'{html.figure(html.png_data_uri(data), caption, kind="scope", ident=f"fig-{ident}")}'
            "</div></article>")
    return blocks


def _seconds(seconds: float) -> str:
    """A wall time as a reader wants it: 3.2 s, 0.21 s, 4 ms (a 10 s run takes milliseconds
    once compiled: "0.0 s" would say nothing)."""
    return f"{seconds:.1f} s" if seconds >= 1 else (f"{seconds:.2g} s" if seconds >= 0.01
                                                    else f"{1e3 * seconds:.2g} ms")
