"""The comparisons the seed draws between runs, and the linear systems its designs promise,
as scope figures (:class:`~armlab.viz.layout.Scope`) for the report.

* A6: option 1 (ĝ = g(q)) against option 3 (ĝ = g(q_des)), the joint errors of both runs;
* A7: the high-gain step with and without ±20 N·m saturation over its first 0.3 s (the
  saturation lasts tens of milliseconds, invisible on the whole run), with the designed
  response q̃̈ + K_D q̃̇ + K_P q̃ = 0 and the torques against the limit;
* A12: the run's position error against the equivalent second-order system
  M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A driven by the measured wrench (h_A = R_dᵀ f_e for a position
  task in Σ_d), from the run's initial error.

A comparison is drawn when the report ran both of its scenarios; its caption states what the
runs measured (overshoot, time at the limit), computed here from the results.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.metrics import settling_time
from armlab.viz.scope_model import ACTUAL, COMMAND, LIMIT, THEORY, Panel, Scope, pretty
from armlab.viz.theory import designed_error, initial_rate, linear_response


@dataclass(frozen=True)
class Comparison:
    """Two scenarios' runs on one figure: ``runs`` (reference case first) named ``labels``;
    ``window`` [s] limits the figure to the runs' first seconds; ``torques`` adds the torque
    panels of the joints that reach their limit."""

    assignment: int
    name: str
    title: str
    runs: tuple[str, str]
    labels: tuple[str, str]
    window: float | None = None
    torques: bool = False


COMPARISONS = (
    Comparison(6, "a6_options", "option 1, ĝ = g(q), against option 3, ĝ = g(q_des): joint errors q̃",
               ("a6_pd_online", "a6_pd_desired"), ("option 1: g(q)", "option 3: g(q_des)")),
    Comparison(7, "a7_saturation", "high gains with and without ±20 saturation: the first 0.3 s",
               ("a7_id_high_gain", "a7_id_high_gain_saturated"), ("unsaturated", "saturated"),
               window=0.3, torques=True),
    Comparison(7, "a7_saturation_long", "ω_n = 60 rad/s with and without ±20 saturation: the overshoot "
               "the seed expects", ("a7_id_higher_gain", "a7_id_higher_gain_saturated"),
               ("unsaturated", "saturated"), window=0.6, torques=True),
)
STYLES = (dict(color=ACTUAL, lw=2.2), dict(color=COMMAND, lw=1.4, ls="--"))


def _window(t: np.ndarray, window: float | None) -> slice:
    if window is None:
        return slice(None)
    return slice(0, int(np.searchsorted(t, t[0] + window, side="right")))


def _limits(result) -> np.ndarray | None:
    limit = result.meta.get("torque_limit")
    if limit is None:
        return None
    limit = np.broadcast_to(np.asarray(limit, dtype=float), (result.n,))
    return limit if np.any(np.isfinite(limit)) else None


def _at_limit(result) -> np.ndarray:
    """(N, n) True where a joint's applied torque is at its limit."""
    limit = _limits(result)
    if limit is None:
        return np.zeros(result.tau.shape, dtype=bool)
    return np.abs(result.tau) >= limit * (1.0 - 1e-9)


def overshoot(e: np.ndarray) -> float:
    """The largest excursion of an error past zero, relative to |e(0)| [%] (0 for e(0) = 0)."""
    if e[0] == 0.0:
        return 0.0
    return 100.0 * max(0.0, float(np.max(-np.sign(e[0]) * e))) / abs(float(e[0]))


def comparison_scope(comparison: Comparison, first, second) -> Scope:
    """The figure of ``comparison`` from the two runs' results (same joints)."""
    results = (first, second)
    panels = []
    designed = designed_error(first)
    for k, label in enumerate(first.labels["q_err"]):
        panel = Panel(f"q̃ {pretty(label)} [{first.units['q_err'][k]}]")
        for result, name, style in zip(results, comparison.labels, STYLES, strict=True):
            part = _window(result.t, comparison.window)
            panel.curves.append((name, result.t[part], result.signals["q_err"][part, k], style))
        if designed is not None:
            part = _window(first.t, comparison.window)
            panel.curves.append(("designed", first.t[part], designed[part, k],
                                 dict(color=THEORY, lw=1.2, ls=":")))
        panel.hlines.append((0.0, dict(color="0.5", lw=0.8)))
        panels.append(panel)
    if comparison.torques:
        limit = _limits(second)
        for k in np.flatnonzero(np.any(_at_limit(second), axis=0) | np.any(_at_limit(first), axis=0)):
            label = first.labels["tau"][k]
            panel = Panel(f"τ {pretty(label)} [{first.units['tau'][k]}]")
            for result, name, style in zip(results, comparison.labels, STYLES, strict=True):
                part = _window(result.t, comparison.window)
                panel.curves.append((name, result.t[part], result.tau[part, k], style))
            if limit is not None:
                panel.hlines += [(limit[k], dict(color=LIMIT, lw=1.0, ls="-.", label="limit ±τ_max")),
                                 (-limit[k], dict(color=LIMIT, lw=1.0, ls="-."))]
            panels.append(panel)
    caption = comparison_caption(comparison, first, second)
    return Scope(comparison.name, comparison.title, panels, caption=caption)


def _intervals(rows: np.ndarray) -> list[tuple[int, int]]:
    """The runs of consecutive indices in the sorted ``rows``, as (first, last + 1)."""
    if rows.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(rows) > 1)
    firsts = np.r_[rows[0], rows[breaks + 1]]
    lasts = np.r_[rows[breaks], rows[-1]] + 1
    return [(int(a), int(b)) for a, b in zip(firsts, lasts, strict=True)]


def _first_crossing(e: np.ndarray) -> int | None:
    """The first sample at which ``e`` is on the other side of zero from e(0) (None if never)."""
    if e[0] == 0.0:
        return None
    rows = np.flatnonzero(np.sign(e) == -np.sign(e[0]))
    return int(rows[0]) if rows.size else None


def comparison_caption(comparison: Comparison, first, second) -> str:
    """What the two runs measured, in words: overshoot per joint (and, with ``torques``, when
    each joint of the second run sat at its limit and with which sign, whether its error
    crossed zero while it was there, whether the designed loop it returns to can carry it
    across zero from the state the saturation left, and when it settles)."""
    e1, e2 = first.signals["q_err"], second.signals["q_err"]
    parts = []
    for k, label in enumerate(first.labels["q_err"]):
        if e1[0, k] == 0.0 and e2[0, k] == 0.0:
            continue
        parts.append(f"{pretty(label)} {overshoot(e1[:, k]):.3g} % / {overshoot(e2[:, k]):.3g} %")
    text = f"Overshoot past zero, relative to the initial error ({' / '.join(comparison.labels)}): "
    text += "; ".join(parts) + "."
    if not comparison.torques:
        return text
    saturated = _at_limit(second)
    limit = _limits(second)
    controller = second.meta.get("controller") or {}
    kp = np.asarray(controller.get("kp", np.nan), dtype=float)
    gains = np.diag(kp) if kp.ndim == 2 else np.broadcast_to(kp, (second.n,))
    dt = float(second.t[1] - second.t[0]) if second.t.size > 1 else 0.0
    grown = []
    for k in np.flatnonzero(np.any(saturated, axis=0)):
        rows = np.flatnonzero(saturated[:, k])
        end = int(rows[-1]) + 1 if rows[-1] + 1 < second.t.size else int(rows[-1])
        unit = first.units["tau"][k]
        spans = []
        for a, b in _intervals(rows):
            sign = "+" if second.tau[a, k] > 0 else "\u2212"
            stop = second.t[b] if b < second.t.size else second.t[-1]
            spans.append(f"{sign}{limit[k]:.3g} {unit} for {1e3 * (b - a) * dt:.3g} ms "
                         f"(t = {second.t[a]:.3g}\u2013{stop:.3g} s)")
        text += (f" {pretty(first.labels['tau'][k])} is at the limit for {1e3 * rows.size * dt:.3g} ms: "
                 + ", then ".join(spans) + ".")
        crossing = _first_crossing(e2[:, k])
        crossed = crossing is not None and crossing <= end
        if crossing is not None and crossing <= rows[-1]:
            peak = int(np.argmax(-np.sign(e2[0, k]) * e2[:, k]))
            text += (f" Its error crosses zero at t = {second.t[crossing]:.3g} s, while the torque is "
                     f"held at the limit, and reaches q̃ = {_number(float(e2[peak, k]))} at t = "
                     f"{second.t[peak]:.3g} s: the overshoot happens under saturation.")
        e, v = float(e2[end, k]), float(second.signals["qd_err"][end, k])
        omega = float(np.sqrt(gains[k])) if np.isfinite(gains[k]) else float("nan")
        s = v + omega * e
        across = "back across zero" if crossed else "past zero"
        verdict = (f"the same sign as q̃: the designed loop cannot carry it {across}"
                   if s * e > 0 else f"the opposite sign of q̃: the designed loop carries it {across}")
        text += (f" From t = {second.t[end]:.3g} s the loop is the designed one (ζ = 1, ω_n = "
                 f"{omega:.3g} rad/s) started at q̃ = {_number(e)}, dq̃/dt = {_number(v)}, and "
                 f"dq̃/dt + ω_n q̃ = {_number(s)} has {verdict}.")
        settled = [settling_time(run.t, run.signals["q_err"][:, k]) for run in (first, second)]
        if e2[0, k] != 0.0 and None not in settled:
            text += (f" It settles (2 % band) at t = {settled[1]:.3g} s, against {settled[0]:.3g} s "
                     f"{comparison.labels[0]}.")
        if overshoot(e2[:, k]) > overshoot(e1[:, k]) + 0.05:
            grown.append(f"{pretty(first.labels['q_err'][k])} {overshoot(e2[:, k]):.3g} % against "
                         f"{overshoot(e1[:, k]):.3g} %")
    text += " The seed expects the overshoot to grow under saturation"
    if grown:
        text += f", and here it does: {'; '.join(grown)} {comparison.labels[0]}."
    else:
        text += (": with the inverse-dynamics law and an exact model it is the state that saturation "
                 "leaves that decides, and here it gives none: saturation only delays the approach.")
    return text


def _number(value: float) -> str:
    """``value`` to 3 significant digits with a true minus sign."""
    return f"{value:.3g}".replace("-", "\u2212")


def impedance_scope(result, mass, reference) -> Scope | None:
    """The run's x̃ (position components in Σ_d) against M_d x̃̈ + K_D x̃̇ + K_P x̃ = R_dᵀ f_e
    driven by the logged wrench from the run's x̃(0), x̃̇(0); None for a run that is not an
    impedance-controlled position task in Σ_d or not on a uniform time grid."""
    controller = result.meta.get("controller")
    if not (isinstance(controller, dict) and controller.get("type") == "ImpedanceControl"):
        return None
    if controller.get("frame") != "desired" or list(controller.get("task", [])) != [0, 1, 2]:
        return None
    if not {"x_err", "h_e"} <= set(result.signals):
        return None
    t = np.asarray(result.t)

    def matrix(value):
        value = np.asarray(value, dtype=float)
        return np.diag(np.broadcast_to(value, (3,))) if value.ndim < 2 else value[:3, :3]

    K, D, M = (matrix(controller["kp"]), matrix(controller["kd"]), matrix(mass))
    # R_d (row-major in the reference's output) turns the wrench's force into Σ_d's axes.
    force = np.array([np.asarray(reference.evaluate(s)[3:12]).reshape(3, 3).T @ f
                      for s, f in zip(t, result.signals["h_e"][:, :3], strict=True)])
    error = result.signals["x_err"][:, :3]
    expected = linear_response(M, D, K, t, error[0], initial_rate(t, error), force)
    if expected is None:
        return None
    panels = []
    for k, label in enumerate(result.labels["x_err"][:3]):
        panel = Panel(f"x̃ {pretty(label)} [{result.units['x_err'][k]}]")
        system = dict(color=THEORY, lw=1.3, ls="--")
        panel.curves += [("run", t, error[:, k], dict(color=ACTUAL, lw=2.2)),
                         ("designed system", t, expected[:, k], system)]
        panel.hlines.append((0.0, dict(color="0.5", lw=0.8)))
        deviation = float(np.max(np.abs(error[:, k] - expected[:, k])))
        panel.note = f"max |run − system|\n{deviation:.2g} {result.units['x_err'][k]}"
        panels.append(panel)
    caption = ("The equivalent second-order system of the impedance design, driven by the measured "
               "wrench h_A = R_dᵀ f_e from the run's x̃(0) and dx̃/dt(0): with an exact model the run "
               "follows it to the integration error.")
    title = "position error x̃ in Σ_d and the designed system M_d x̃'' + K_D x̃' + K_P x̃ = h_A"
    return Scope("impedance_system", title, panels, caption=caption)
