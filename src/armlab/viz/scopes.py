"""Scope plots of a :class:`~armlab.results.SimulationResult` (the seed's Simulink scopes).

The figures are chosen from the signals a run logged, by name, so every controller gets the
plots a control engineer expects without plotting code of its own:

* ``positions``  — q with its reference ``q_des`` (any group ``X`` with ``X_des`` or ``X_d``
  is drawn against it the same way, e.g. ``x`` and ``x_des``);
* ``<X>_err``    — every error signal, one panel per component, with its final value;
* ``torques``    — applied τ, commanded τ (``tau_cmd``) and the saturation limits ±τ_max;
* ``forces``     — the contact wrench h_e against the desired force (``f_d``/``f_des``/``h_d``);
* ``estimates``  — parameter estimates (a group named ``*_hat``, or a controller state whose
  components are all named ``*_hat``) against the true values (``<name>_true`` signal or
  ``meta["true_parameters"]``), with Y(π̂ − π) when the regressor ``Y`` is logged;
* ``singular_values`` — the Jacobian's singular values (``jacobian_sv``, ``singular_values``);
* ``signals``    — every remaining logged signal and the controller state, one panel each.

Each figure is one column of panels sharing the time axis, every y label carries its unit.
Long runs are decimated by keeping each bucket's minimum and maximum, so saturation and
chattering stay visible.  :func:`render_scope` gives a figure; :func:`scope_png` gives the same
picture as PNG bytes faster, drawn on a figure kept for the next scope with as many panels.
"""

from __future__ import annotations

import re
import threading
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from armlab.errors import ArmlabError  # noqa: E402
from armlab.viz.html import figure_png  # noqa: E402

MAX_POINTS = 1000
ZERO = 1e-10  # SI magnitudes below this are rounding noise (no quantity here is that small)
ACTUAL, DESIRED, LIMIT, COMMAND = "#1f5fd6", "#222222", "#d62728", "#f09030"
GREEK = {"theta": "θ", "phi": "φ", "psi": "ψ", "alpha": "α", "beta": "β", "gamma": "γ",
         "tau": "τ", "sigma": "σ", "lambda": "λ", "omega": "ω", "mu": "μ", "pi": "π"}
REFERENCE_SUFFIXES = ("_des", "_d", "_ref")
FORCE_REFERENCES = ("f_d", "f_des", "h_d", "h_des", "f_ref")
SINGULAR_VALUE_NAMES = ("jacobian_sv", "singular_values", "sv", "sigma_j", "jacobian_singular_values")
FORMATS = ("png", "svg")


class ScopeError(ArmlabError, ValueError):
    """Scope plots that cannot be made (unknown format, empty result)."""


def pretty(label: str) -> str:
    """"theta2" → "θ2", "phi_x" → "φ_x", "I_hat" → "Î": Greek names as letters, estimates
    with a hat, for axis labels."""
    label = re.sub(r"([A-Za-z])_hat\b", "\\1\u0302", label)
    return re.sub(r"[a-z]+", lambda m: GREEK.get(m.group(0), m.group(0)), label)


def decimate(t: np.ndarray, y: np.ndarray, max_points: int = MAX_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """At most ``max_points`` samples of (t (N,), y (N,)), keeping each bucket's min and max
    (both ends of a bucket that holds a non-finite value).  Vectorised: a report draws over a
    thousand traces."""
    n = t.size
    if n <= max_points:
        return t, y
    buckets = max_points // 2
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
    keep = np.unique(np.concatenate([i_min, i_max]))
    return t[keep], y[keep]


@dataclass
class Panel:
    """One axes: curves (label, t, y, style) drawn against time, with a unit on the y label."""

    ylabel: str
    curves: list = field(default_factory=list)
    hlines: list = field(default_factory=list)
    note: str = ""


@dataclass
class Scope:
    """One figure: a title and a column of panels sharing the time axis."""

    name: str
    title: str
    panels: list[Panel]


def _unit_label(label: str, unit: str) -> str:
    return f"{pretty(label)} [{unit}]" if unit else pretty(label)


def _reference_of(groups: dict, name: str) -> str | None:
    for suffix in REFERENCE_SUFFIXES:
        if name + suffix in groups:
            return name + suffix
    return None


def _finite_limit(meta: dict, n: int) -> np.ndarray | None:
    limit = meta.get("torque_limit")
    if limit is None:
        return None
    limit = np.broadcast_to(np.asarray(limit, dtype=float), (n,))
    return limit if np.any(np.isfinite(limit)) else None


def _is_singular_value_group(name: str) -> bool:
    return name.lower() in SINGULAR_VALUE_NAMES or "singular" in name.lower()


def scope_layout(result) -> list[Scope]:
    """The figures to draw for ``result``, chosen from its groups (see the module docstring)."""
    t = np.asarray(result.t)
    groups = {"q": result.q, **result.signals}
    labels, units = result.labels, result.units
    used: set[str] = {"qd", "qdd"}
    scopes: list[Scope] = []

    def tracking(name: str, title: str, scope_name: str):
        ref = _reference_of(groups, name)
        panels = []
        for k, label in enumerate(labels[name]):
            panel = Panel(_unit_label(label, units[name][k]))
            panel.curves.append(("actual", t, groups[name][:, k], dict(color=ACTUAL, lw=1.4)))
            if ref is not None and groups[ref].shape[1] == groups[name].shape[1]:
                panel.curves.append(("desired", t, groups[ref][:, k], dict(color=DESIRED, lw=1.1, ls="--")))
            panels.append(panel)
        used.update({name, ref} - {None})
        scopes.append(Scope(scope_name, title, panels))

    tracking("q", "joint positions q and references q_des", "positions")
    for name in list(result.signals):
        if name in used or name.endswith("_err") or name.startswith("tau") or name == "h_e":
            continue
        ref = _reference_of(groups, name)
        if ref is not None:
            tracking(name, f"{pretty(name)} and its reference {pretty(ref)}", name)

    for name in result.signals:
        if name.endswith("_err"):
            data = groups[name]
            panels = []
            for k, label in enumerate(labels[name]):
                panel = Panel(_unit_label(label, units[name][k]))
                panel.curves.append((name, t, data[:, k], dict(color=ACTUAL, lw=1.3)))
                panel.hlines.append((0.0, dict(color="0.5", lw=0.8)))
                panel.note = f"final {data[-1, k]:.3g} {units[name][k]}"
                panels.append(panel)
            used.add(name)
            scopes.append(Scope(name, f"errors {pretty(name)} (desired − actual)", panels))

    panels = []
    limit = _finite_limit(result.meta, result.n)
    for k, label in enumerate(labels["tau"]):
        panel = Panel(_unit_label(f"τ {label}", units["tau"][k]))
        panel.curves.append(("applied", t, result.tau[:, k], dict(color=ACTUAL, lw=1.4)))
        if "tau_cmd" in result.signals:
            # Drawn over the applied torque, dashed: the two differ only where τ saturates.
            panel.curves.append(("commanded", t, result.signals["tau_cmd"][:, k],
                                 dict(color=COMMAND, lw=1.1, ls="--")))
        if "tau_dist" in result.signals:
            panel.curves.append(("disturbance", t, result.signals["tau_dist"][:, k],
                                 dict(color="0.45", lw=1.0, ls=":")))
        if limit is not None and np.isfinite(limit[k]):
            panel.hlines += [(limit[k], dict(color=LIMIT, lw=1.0, ls="-.", label="limit ±τ_max")),
                             (-limit[k], dict(color=LIMIT, lw=1.0, ls="-."))]
        panels.append(panel)
    used.update({"tau", "tau_cmd", "tau_dist"})
    scopes.append(Scope("torques", "joint torques / forces τ", panels))

    if "h_e" in result.signals:
        h = result.signals["h_e"]
        ref = next((r for r in FORCE_REFERENCES if r in result.signals), None)
        desired = result.signals[ref] if ref else None
        panels = []
        for k, label in enumerate(labels["h_e"]):
            has_ref = desired is not None and k < desired.shape[1]
            active = np.nanmax(np.abs(h[:, k])) > 1e-9
            active = active or (has_ref and np.nanmax(np.abs(desired[:, k])) > 1e-9)
            if not active and k >= 3:
                continue
            panel = Panel(_unit_label(label, units["h_e"][k]))
            panel.curves.append(("h_e", t, h[:, k], dict(color=ACTUAL, lw=1.4)))
            if has_ref:
                panel.curves.append((ref, t, desired[:, k], dict(color=DESIRED, lw=1.1, ls="--")))
            panel.note = f"final {h[-1, k]:.3g} {units['h_e'][k]}"
            panels.append(panel)
        used.update({"h_e", ref} - {None})
        scopes.append(Scope("forces", "contact wrench h_e (exerted on the environment, in Σ_0)", panels))

    for name in result.signals:
        if name.endswith("_hat") and name not in used:
            truth = result.signals.get(name[:-4] + "_true")
            true_values = result.meta.get("true_parameters")
            panels = []
            for k, label in enumerate(labels[name]):
                panel = Panel(_unit_label(label, units[name][k]))
                panel.curves.append(("estimate", t, groups[name][:, k], dict(color=ACTUAL, lw=1.4)))
                if truth is not None:
                    panel.curves.append(("true", t, truth[:, k], dict(color=DESIRED, lw=1.1, ls="--")))
                elif true_values is not None and k < len(true_values):
                    panel.hlines.append((float(true_values[k]), dict(color=DESIRED, lw=1.1, ls="--",
                                                                     label="true")))
                panels.append(panel)
            used.update({name, name[:-4] + "_true"})
            scopes.append(Scope("estimates", f"parameter estimates {pretty(name)} and true values", panels))

    z_labels = tuple(labels.get("z", ()))
    if z_labels and all(label.endswith("_hat") for label in z_labels):
        true_values = result.meta.get("true_parameters")
        known = true_values is not None and len(true_values) == len(z_labels)
        panels = []
        for k, label in enumerate(z_labels):
            panel = Panel(_unit_label(label, units["z"][k]))
            panel.curves.append(("estimate", t, result.z[:, k], dict(color=ACTUAL, lw=1.4)))
            if known:
                panel.hlines.append((float(true_values[k]), dict(color=DESIRED, lw=1.1, ls="--",
                                                                 label="true value")))
            panels.append(panel)
        regressor = result.signals.get("Y")
        if known and regressor is not None and regressor.shape[1] == len(z_labels):
            # Y(π̂ − π): what the wrong estimates cost in torque; it vanishes although π̂ ≠ π.
            mismatch = np.sum(regressor * (result.z - np.asarray(true_values, dtype=float)), axis=1)
            panel = Panel(_unit_label("Y(π̂ − π)", units["tau"][0]))
            panel.curves.append(("Y(π̂ − π)", t, mismatch, dict(color=COMMAND, lw=1.3)))
            panel.hlines.append((0.0, dict(color="0.5", lw=0.8)))
            panel.note = f"final {mismatch[-1]:.3g} {units['tau'][0]}"
            panels.append(panel)
            used.add("Y")
        used.add("z")
        scopes.append(Scope("estimates", "parameter estimates π̂ (controller state) and true values π",
                            panels))

    for name in result.signals:
        if _is_singular_value_group(name) and name not in used:
            panel = Panel(_unit_label("σ_i(J)", units[name][0] if units[name] else ""))
            for k, label in enumerate(labels[name]):
                panel.curves.append((pretty(label), t, groups[name][:, k], dict(lw=1.3)))
            used.add(name)
            scopes.append(Scope("singular_values", "singular values of the Jacobian", [panel]))

    rest = [g for g in result.signals if g not in used]
    if result.z.shape[1] > 0 and "z" not in used:
        rest.append("z")
        groups["z"] = result.z
    panels = []
    for name in rest:
        unit_set = sorted(set(units[name]))
        panel = Panel(f"{pretty(name)} [{', '.join(unit_set)}]" if any(unit_set) else pretty(name))
        for k, label in enumerate(labels[name]):
            panel.curves.append((pretty(label), t, groups[name][:, k], dict(lw=1.2)))
        panels.append(panel)
    if panels:
        scopes.append(Scope("signals", "other logged signals", panels))
    return scopes


def _scenario_name(result) -> str:
    return str(result.meta.get("scenario") or result.meta.get("name") or result.meta.get("plant", "run"))


def _rounding_noise(panel: Panel) -> bool:
    """True when every curve and line of ``panel`` stays below :data:`ZERO` in magnitude."""
    values = [np.nanmax(np.abs(y)) for _, _, y, _ in panel.curves if np.any(np.isfinite(y))]
    values += [abs(v) for v, _ in panel.hlines]
    return bool(values) and max(values) < ZERO


def _figure_size(rows: int) -> tuple[float, float]:
    return 7.2, 0.6 + 1.55 * rows


def _style_panels(axes) -> None:
    """What every scope's panels share, set once per figure: grid, tick label size, no x
    margin, the time label under the last panel."""
    for ax in axes:
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.tick_params(labelsize=8)
        ax.margins(x=0)
    axes[-1].set_xlabel("t [s]", fontsize=9)


def _draw_scope(fig, axes, scope: Scope, title_prefix: str, diagnosis: str) -> None:
    """Draw ``scope`` on ``fig``, whose ``axes`` (one per panel) are styled and empty."""
    for ax, panel in zip(axes, scope.panels, strict=True):
        for label, t, y, style in panel.curves:
            td, yd = decimate(np.asarray(t), np.asarray(y))
            ax.plot(td, yd, label=label, **style)
        for value, style in panel.hlines:
            ax.axhline(value, **style)
        note = panel.note
        if _rounding_noise(panel):
            # Values like 1e-16 are rounding noise; autoscaled they would look like a signal.
            ax.set_ylim(-1.0, 1.0)
            note = f"zero to rounding (|·| < {ZERO:g})"
        ax.set_ylabel(panel.ylabel, fontsize=9)
        if note:
            ax.text(0.99, 0.94, note, transform=ax.transAxes, ha="right", va="top", fontsize=8,
                    bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.8", alpha=0.85))
    first = axes[0].get_legend_handles_labels()[1]
    for index, ax in enumerate(axes):
        # Panels of one scope share their curve names: one legend on the first panel is enough,
        # unless a panel has curves of its own (the "signals" scope).
        handles, labels = ax.get_legend_handles_labels()
        wanted = index == 0 or labels != first
        if handles and len(handles) <= 8 and wanted and (len(handles) > 1 or len(axes) == 1 or index > 0):
            ax.legend(fontsize=7.5, loc="best", ncol=min(4, len(handles)), framealpha=0.85)
    title = f"{title_prefix}: {scope.title}" if title_prefix else scope.title
    fig.suptitle(title, fontsize=10.5)
    if diagnosis:
        fig.text(0.5, 0.01, diagnosis, ha="center", va="bottom", fontsize=8, color=LIMIT, wrap=True,
                 gid="diagnosis")
    # Fixed margins in inches (tight_layout would cost as much as drawing the figure).
    height = fig.get_figheight()
    fig.subplots_adjust(left=0.125, right=0.985, top=1.0 - 0.42 / height,
                        bottom=(0.62 if diagnosis else 0.45) / height, hspace=0.13)


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
        for artist in [*ax.lines, *ax.texts]:
            artist.remove()
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        ax.relim()
        ax.set_autoscaley_on(True)  # a panel of rounding noise had fixed its limits
        ax.set_prop_cycle(None)  # curves without a colour start from the first again
    for text in [t for t in fig.texts if t.get_gid() == "diagnosis"]:
        text.remove()
    return fig, axes


def scope_png(scope: Scope, *, title_prefix: str = "", diagnosis: str = "", dpi: int = 80) -> bytes:
    """The PNG bytes of ``render_scope(scope, title_prefix=…, diagnosis=…)`` at ``dpi``, the
    same picture in a little over half the time: drawn on a figure kept for the next scope
    with as many panels (per thread), whose labels are placed once instead of at every draw."""
    fig, axes = _kept_figure(len(scope.panels), dpi)
    _draw_scope(fig, axes, scope, title_prefix, diagnosis)
    _place_labels(fig, axes)
    return figure_png(fig, dpi=dpi)


def plot_scopes(result, out_dir, formats=FORMATS) -> list[Path]:
    """Draw every scope of ``result`` and save it to ``out_dir`` as ``<name>.<format>``.

    Parameters
    ----------
    result : SimulationResult
    out_dir : str or Path
        Created if missing.
    formats : sequence of {"png", "svg", "pdf"}

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
        fig, axes = _kept_figure(len(scope.panels), dpi=110)
        _draw_scope(fig, axes, scope, prefix, diagnosis)
        _place_labels(fig, axes)
        for fmt in formats:
            path = out_dir / f"{scope.name}.{fmt}"
            fig.savefig(path, dpi=110, metadata={"Date": None} if fmt == "svg" else None)
            written.append(path)
    return written
