"""The notebook display of a :class:`~armlab.simulation.results.SimulationResult`: its summary
(:func:`armlab.display.result_summary`) and its first scope as an inline PNG.

``SimulationResult._repr_html_`` calls :func:`result_html`: a result shown in a notebook is
the one place where the library reaches the plotting package, when it is displayed.
"""

from __future__ import annotations

from armlab.display import block, escape, result_summary, table
from armlab.viz.html import png_data_uri
from armlab.viz.scopes import scope_layout, scope_png

NOTEBOOK_DPI = 72


def result_html(result) -> str:
    """The HTML of a SimulationResult: its summary and its first scope (positions against the
    reference, when logged) as an inline PNG."""
    parts = [table(["", ""], result_summary(result), caption="Run")]
    if len(result) > 1:
        scopes = scope_layout(result)
        if scopes:
            scope = scopes[0]
            uri = png_data_uri(scope_png(scope, dpi=NOTEBOOK_DPI))
            parts.append(f'<img alt="{escape(scope.title)}" src="{uri}">')
            if len(scopes) > 1:
                names = ", ".join(s.title for s in scopes[1:])
                note = escape("Further scopes (armlab.viz.plot_scopes): " + names)
                parts.append(f'<p class="note">{note}</p>')
    return block("SimulationResult", parts)
