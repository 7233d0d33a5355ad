"""What a scope figure is, as data: a :class:`Scope` is a title and a column of :class:`Panel` s
sharing the time axis, and a panel may carry a :class:`Zoom` inset.  :func:`pretty` writes
their labels; :func:`trace_style` and the colours here style their traces.

``_Run`` is what the layout rules (:mod:`armlab.viz.layout` and the ``layout_*`` modules it
gathers) read from a result, with the small helpers they share.  :mod:`armlab.viz.scopes`
draws the figures.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

ACTUAL, DESIRED, LIMIT, COMMAND, COMPLIANT = "#1f5fd6", "#222222", "#d62728", "#f09030", "#2ca02c"
THEORY, REST = "#9467bd", "#8c564b"  # a response the theory predicts; the environment's rest pose
# Traces of one panel differ in colour, dash and width, widest first: a trace drawn over an
# identical one (σ1 = σ2 = 1) leaves the one below visible around its dashes.
TRACE_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
TRACE_LINES = (("-", 2.6), ("--", 1.8), (":", 2.0), ("-.", 1.4), ((0, (5, 1.5)), 1.2), ((0, (1, 1.2)), 1.5))
GREEK = {"theta": "θ", "phi": "φ", "psi": "ψ", "alpha": "α", "beta": "β", "gamma": "γ",
         "tau": "τ", "sigma": "σ", "lambda": "λ", "omega": "ω", "mu": "μ", "pi": "π"}
REFERENCE_SUFFIXES = ("_des", "_d", "_ref")
ZOOM_RATIO = 15.0  # a force panel whose range is this many times its tail's gets an inset
TAIL = 0.25  # the inset shows the last quarter of the run
INSET_BANDS = {True: (0.40, 0.93), False: (0.07, 0.60)}  # an inset's height in its panel, above / below
MIDDLE_BAND = (0.2, 0.8)  # between curves at the top and at the bottom (A11: x_d above, x_e at Σ_r)


def pretty(label: str) -> str:
    """"theta2" → "θ2", "phi_x" → "φ_x", "I_hat" → "Î", "int_fx" → "∫fx": Greek names as
    letters, estimates with a hat, integrals as ∫, for axis labels."""
    label = re.sub(r"([A-Za-z])_hat\b", "\\1\u0302", label)
    label = re.sub(r"\bint_", "∫", label)
    return re.sub(r"[a-z]+", lambda m: GREEK.get(m.group(0), m.group(0)), label)


def trace_style(k: int) -> dict:
    """Line style of the k-th trace of a panel whose traces are not told apart by meaning."""
    dash, width = TRACE_LINES[k % len(TRACE_LINES)]
    return dict(color=TRACE_COLOURS[k % len(TRACE_COLOURS)], ls=dash, lw=width)


@dataclass
class Zoom:
    """An inset of a panel: its curves from ``start`` [s] to the run's end within ``ylim``,
    in the upper half of the panel (``above``) or the lower."""

    start: float
    ylim: tuple[float, float]
    above: bool = True
    band: tuple[float, float] | None = None  # its height in the panel, if not INSET_BANDS[above]


@dataclass
class Panel:
    """One axes: curves (label, t, y, style) drawn against time, with a unit on the y label.

    ``note`` is printed beside the panel (final value, what is off-scale), level with the
    value ``note_at`` if given; ``log`` draws y on a log axis; ``zoom`` adds an inset.
    """

    ylabel: str
    curves: list = field(default_factory=list)
    hlines: list = field(default_factory=list)
    note: str = ""
    note_at: float | None = None
    log: bool = False
    zoom: Zoom | None = None
    ylim: tuple[float, float] | None = None  # fixed y limits (else autoscaled)


@dataclass
class Scope:
    """One figure: a title, a column of panels sharing the time axis, and an optional
    ``caption`` explaining what the figure shows (printed under it)."""

    name: str
    title: str
    panels: list[Panel]
    caption: str = ""


@dataclass
class _Run:
    """What the layout rules read from a result, and the groups already drawn."""

    result: object
    t: np.ndarray
    groups: dict
    labels: dict
    units: dict
    controller: dict
    used: set = field(default_factory=lambda: {"qd", "qdd"})

    @property
    def kind(self) -> str:
        return str(self.controller.get("type", ""))


def _unit_label(label: str, unit: str) -> str:
    return f"{pretty(label)} [{unit}]" if unit else pretty(label)


def _reference_of(groups: dict, name: str) -> str | None:
    for suffix in REFERENCE_SUFFIXES:
        if name + suffix in groups:
            return name + suffix
    return None


def _tail(t: np.ndarray, fraction: float) -> slice:
    """The samples of the last ``fraction`` of the time span (at least two)."""
    start = int(np.searchsorted(t, t[-1] - fraction * (t[-1] - t[0])))
    return slice(min(start, t.size - 2), None)


def _level(value) -> float | None:
    return float(value) if np.isfinite(value) else None


def _run_of(result) -> _Run:
    controller = result.meta.get("controller")
    return _Run(result, np.asarray(result.t), {"q": result.q, **result.signals}, result.labels, result.units,
                controller if isinstance(controller, dict) else {})
