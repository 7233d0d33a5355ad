"""Which scope figures a :class:`~armlab.simulation.SimulationResult` gets (the seed's Simulink scopes).

The figures are chosen from the signals a run logged, by name, so every controller gets the
plots a control engineer expects without plotting code of its own:

* ``positions``  — q with its reference ``q_des`` (any group ``X`` with ``X_des`` or ``X_d``
  is drawn against it the same way, e.g. ``p`` and ``p_des``; an admittance controller's
  compliant frame ``p_t`` is drawn with them; the internal x_d = 0 of pure force control is not;
  against a spring environment, ``p`` with the spring's rest position Σ_r);
* ``<X>_err``    — every error signal, one panel per component, with its final value and the
  frame its components are expressed in when the controller's description names it; a
  computed-torque run's q̃ with the designed response q̃̈ + K_D q̃̇ + K_P q̃ = 0 from the run's
  own initial error (:mod:`armlab.viz.theory`);
* ``torques``    — applied τ, commanded τ (``tau_cmd``) and the saturation limits ±τ_max (said
  to be off-scale where they would flatten the trace);
* ``forces``     — the contact wrench h_e against the desired force (``f_d``/``f_des``/``h_d``),
  with an inset around f_d where a transient sets the scale;
* ``x_bar``      — parallel force/position control (A15): the seed's x̄ = x_F + x̃ = x_F + x_d − x_e
  per component, with x̃ and x_F, from the logged ``x_F``, ``p_des`` and ``p``;
* ``estimates``  — parameter estimates (a group named ``*_hat``, or a controller state whose
  components are all named ``*_hat``) against the true values (``<name>_true`` signal or
  ``meta["true_parameters"]``), with Y(π̂ − π) when the regressor ``Y`` is logged;
* ``lyapunov``   — Slotine–Li runs of the 1-DoF law: σ and V = ½ I σ² + ½ π̃ᵀ Γ⁻¹ π̃;
* ``singular_values`` — the Jacobian's singular values (``jacobian_sv``, ``singular_values``),
  on a log axis with the warning threshold when σ_min comes near it;
* ``signals``    — every remaining logged signal and the controller state, one panel per
  signal and unit.

:func:`main_scopes` gives the few of them that show what the controller is for (the tracking
of its space, the contact wrench, x̄, the estimates): all that ``armlab report --quick`` draws.

Each figure is a :class:`Scope`: a title and a column of :class:`Panel` s sharing the time
axis; every y label carries its unit.  :mod:`armlab.viz.scopes` draws them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace

import numpy as np

from armlab.metrics import FORCE_REFERENCES
from armlab.viz.theory import designed_error, lyapunov_function

ACTUAL, DESIRED, LIMIT, COMMAND, COMPLIANT = "#1f5fd6", "#222222", "#d62728", "#f09030", "#2ca02c"
THEORY, REST = "#9467bd", "#8c564b"  # a response the theory predicts; the environment's rest pose
# Traces of one panel differ in colour, dash and width, widest first: a trace drawn over an
# identical one (σ1 = σ2 = 1) leaves the one below visible around its dashes.
TRACE_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
TRACE_LINES = (("-", 2.6), ("--", 1.8), (":", 2.0), ("-.", 1.4), ((0, (5, 1.5)), 1.2), ((0, (1, 1.2)), 1.5))
GREEK = {"theta": "θ", "phi": "φ", "psi": "ψ", "alpha": "α", "beta": "β", "gamma": "γ",
         "tau": "τ", "sigma": "σ", "lambda": "λ", "omega": "ω", "mu": "μ", "pi": "π"}
REFERENCE_SUFFIXES = ("_des", "_d", "_ref")
SINGULAR_VALUE_NAMES = ("jacobian_sv", "singular_values", "sv", "sigma_j", "jacobian_singular_values")
# Controllers whose p_des is an internal x_d = 0, not a reference (pure force control, A14).
FORCE_ONLY_CONTROLLERS = ("ForceControl",)
# The frame the task error's components are in, by the controller's ``frame`` (A9–A13).
ERROR_FRAMES = {"base": "Σ_0", "desired": "Σ_d"}
OFF_SCALE = 3.0  # a torque limit this many times the largest |τ| is said, not drawn
CLIPPED = 4.0  # a commanded τ this many times its limit is cut from the view (its peak said)
ZOOM_RATIO = 15.0  # a force panel whose range is this many times its tail's gets an inset
TAIL = 0.25  # the inset shows the last quarter of the run
INSET_BANDS = {True: (0.40, 0.93), False: (0.07, 0.60)}  # an inset's height in its panel, above / below
MIDDLE_BAND = (0.2, 0.8)  # between curves at the top and at the bottom (A11: x_d above, x_e at Σ_r)
NOTE_TAIL = 0.1  # Y(π̂ − π) is summarised by its RMS over the last tenth of the run


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


def _finite_limit(meta: dict, n: int) -> np.ndarray | None:
    limit = meta.get("torque_limit")
    if limit is None:
        return None
    limit = np.broadcast_to(np.asarray(limit, dtype=float), (n,))
    return limit if np.any(np.isfinite(limit)) else None


def _is_singular_value_group(name: str) -> bool:
    return name.lower() in SINGULAR_VALUE_NAMES or "singular" in name.lower()


def _tail(t: np.ndarray, fraction: float) -> slice:
    """The samples of the last ``fraction`` of the time span (at least two)."""
    start = int(np.searchsorted(t, t[-1] - fraction * (t[-1] - t[0])))
    return slice(min(start, t.size - 2), None)


def _peak(values) -> float:
    finite = [np.nanmax(np.abs(v)) for v in values if np.any(np.isfinite(v))]
    return float(max(finite)) if finite else 0.0


def _level(value) -> float | None:
    return float(value) if np.isfinite(value) else None


def _run_of(result) -> _Run:
    controller = result.meta.get("controller")
    return _Run(result, np.asarray(result.t), {"q": result.q, **result.signals}, result.labels, result.units,
                controller if isinstance(controller, dict) else {})


DIVERGENCE_RANGE = 3.0  # a diverged run is drawn until its state leaves this many times its early range


def before_divergence(result) -> tuple[object, str]:
    """``result`` cut where a diverged run leaves its range, and a sentence saying so ('' for a
    run that did not diverge): the first sample where a joint position or velocity exceeds
    :data:`DIVERGENCE_RANGE` times its largest magnitude over the run's first half.  Drawn
    whole, the last samples (10¹⁶ rad) would flatten everything before them to a line."""
    if result.status != "diverged" or len(result.t) < 4:
        return result, ""
    state = np.hstack([result.q, result.qd])
    finite = np.all(np.isfinite(state), axis=1)
    last = int(np.argmin(finite)) if not finite.all() else len(finite)   # the first non-finite row
    early = np.abs(state[: max(last // 2, 1)]).max(axis=0)
    beyond = np.any(np.abs(state[:last]) > DIVERGENCE_RANGE * early + 1e-9, axis=1)
    stop = int(np.argmax(beyond)) + 1 if beyond.any() else last
    stop = max(stop, 2)
    if stop >= len(result.t):
        return result, ""
    cut = slice(0, stop)
    kept = replace(result, t=result.t[cut], q=result.q[cut], qd=result.qd[cut], qdd=result.qdd[cut],
                   tau=result.tau[cut], z=result.z[cut],
                   signals={name: value[cut] for name, value in result.signals.items()})
    note = (f"Drawn up to t = {kept.t[-1]:.4g} s, where the state leaves {DIVERGENCE_RANGE:g}× its range of "
            f"the first half; the samples after it, to t = {result.t[-1]:.4g} s, are the blow-up.")
    return kept, note


def _noted(scopes: list[Scope], note: str) -> list[Scope]:
    for scope in scopes:
        scope.caption = f"{scope.caption} {note}".strip()
    return scopes


def scope_layout(result) -> list[Scope]:
    """The figures to draw for ``result``, chosen from its groups (see the module docstring);
    a diverged run's up to its divergence (:func:`before_divergence`)."""
    result, note = before_divergence(result)
    run = _run_of(result)
    return _noted([*_tracking_scopes(run), *_error_scopes(run), _torque_scope(run), *_force_scopes(run),
                   *_parallel_error_scopes(run), *_estimate_scopes(run), *_lyapunov_scopes(run),
                   *_singular_value_scopes(run), *_signal_scopes(run)], note)


def main_scopes(result) -> list[Scope]:
    """The figures of :func:`scope_layout` that show what the run's controller is for, in its
    order: the tracking of the space the controller works in (each task-space group against
    its reference when the run logs one, e.g. ``p``; else ``positions``), the contact wrench
    (``forces``, A11–A15), x̄ (``x_bar``, A15) and the parameter estimates (``estimates``, A8).
    Built alone, not
    picked from the whole layout: the errors' designed response would import SciPy's signal
    package (over a second)."""
    result, note = before_divergence(result)
    run = _run_of(result)
    tracking = _tracking_scopes(run)
    return _noted([*(tracking[1:] or tracking), *_force_scopes(run), *_parallel_error_scopes(run),
                   *_estimate_scopes(run)], note)


# ----------------------------------------------------------------------------- tracking


def _tracking(run: _Run, name: str, ref: str | None, extra: tuple = ()) -> list[Panel]:
    """One panel per component of ``name``: actual, the reference ``ref`` dashed and the
    ``extra`` groups (label, group, style) of the same width."""
    data = run.groups[name]
    panels = []
    for k, label in enumerate(run.labels[name]):
        panel = Panel(_unit_label(label, run.units[name][k]))
        # Wider under other curves of the same width that may coincide with it (Σ_t and Σ_e).
        panel.curves.append(("actual", run.t, data[:, k], dict(color=ACTUAL, lw=2.4 if extra else 1.4)))
        if ref is not None:
            reference = run.groups[ref][:, k]
            panel.curves.append(("desired", run.t, reference, dict(color=DESIRED, lw=1.1, ls="--")))
        for curve, group, style in extra:
            panel.curves.append((curve, run.t, run.groups[group][:, k], style))
        panels.append(panel)
    run.used.update({name, ref} - {None})
    run.used.update(group for _, group, _ in extra)
    return panels


def _tracking_scopes(run: _Run) -> list[Scope]:
    ref = _reference_of(run.groups, "q")
    if ref is not None and run.groups[ref].shape[1] != run.groups["q"].shape[1]:
        ref = None
    title = "joint positions q and references q_des" if ref else "joint positions q"
    scopes = [Scope("positions", title, _tracking(run, "q", ref))]
    for name in list(run.result.signals):
        if name in run.used or name.endswith("_err") or name.startswith("tau") or name == "h_e":
            continue
        ref = _reference_of(run.groups, name)
        if ref is None:
            continue
        if run.groups[ref].shape[1] != run.groups[name].shape[1]:
            continue
        if run.kind in FORCE_ONLY_CONTROLLERS:
            # Pure force control logs x_d = 0 as p_des; drawn, it would look like a position
            # the arm fails to reach and set the panel's scale.
            panels = _tracking(run, name, None)
            run.used.add(ref)
            title = f"{pretty(name)} (pure force control: no position reference)"
        elif name + "_t" in run.groups and run.groups[name + "_t"].shape == run.groups[name].shape:
            compliant = (f"compliant {pretty(name)}_t", name + "_t", dict(color=COMPLIANT, lw=1.4, ls=":"))
            panels = _tracking(run, name, ref, (compliant,))
            title = f"{pretty(name)}, its reference {pretty(ref)} and the compliant frame {pretty(name)}_t"
        else:
            panels = _tracking(run, name, ref)
            title = f"{pretty(name)} and its reference {pretty(ref)}"
        if name == "p" and _rest_position(run) is not None:
            rest = dict(color=REST, lw=1.0, ls=(0, (6, 3)), label="Σ_r (spring rest)")
            for panel, value in zip(panels, _rest_position(run), strict=False):
                panel.hlines.append((value, rest))
                zoom = _rest_zoom(run.t, panel, value)
                if zoom is not None:
                    final = float(np.mean(panel.curves[0][2][_tail(run.t, 0.05)]))
                    panel.zoom, panel.note_at = zoom, final
                    panel.note = f"final {final:.5g} {run.units[name][0]}:\n{final - value:+.3g} from Σ_r"
            title += ", spring rest Σ_r"
        scopes.append(Scope(name, title, panels))
    return scopes


def _rest_zoom(t: np.ndarray, panel: Panel, rest: float) -> Zoom | None:
    """An inset of the last :data:`TAIL` of the run around the final value of the panel's
    first curve (the actual position) and the spring's rest level ``rest`` when the two are
    :data:`ZOOM_RATIO` times closer than the panel's range (A11: 0.2 mm from the rest plane
    on a 0.1 m scale), in the half of the panel its curves do not run through; else None."""
    tail = _tail(t, TAIL)
    y = panel.curves[0][2]
    near = np.append(y[tail], rest)
    every = np.concatenate([curve[2] for curve in panel.curves] + [[rest]])
    if not (np.all(np.isfinite(near)) and np.any(np.isfinite(every))):
        return None
    low, high = float(near.min()), float(near.max())
    full_low, full_high = float(np.nanmin(every)), float(np.nanmax(every))
    width = high - low
    if width < 1e-9 or full_high - full_low < ZOOM_RATIO * width:
        return None
    right = t >= t[0] + 0.5 * (t[-1] - t[0])
    there = (np.concatenate([curve[2][right] for curve in panel.curves]) - full_low) / (full_high - full_low)
    there = (there + 0.05) / 1.1
    ylim = (low - 0.5 * width, high + 0.5 * width)
    for band in (INSET_BANDS[True], INSET_BANDS[False], MIDDLE_BAND):
        if not np.any((there > band[0] - 0.02) & (there < band[1] + 0.02)):
            return Zoom(float(t[tail.start]), ylim, above=band != INSET_BANDS[False], band=band)
    return None


def _rest_position(run: _Run) -> np.ndarray | None:
    """The rest position [m] (in Σ_0) of a spring environment, None for none or a wall."""
    environment = run.result.meta.get("environment")
    rest = environment.get("rest_position") if isinstance(environment, dict) else None
    if rest is None:
        return None
    rest = np.asarray(rest, dtype=float)
    return rest if rest.shape == (3,) and np.all(np.isfinite(rest)) else None


# ----------------------------------------------------------------------------- errors


def _error_title(run: _Run, name: str) -> str:
    frame = run.controller.get("frame")
    if name == "x_err" and run.kind == "AdmittanceControl":
        return f"errors {pretty(name)} (Σ_t relative to Σ_e: compliant − actual, components in Σ_t)"
    if name == "x_err" and frame in ERROR_FRAMES:
        return f"errors {pretty(name)} (desired − actual, components in {ERROR_FRAMES[frame]})"
    return f"errors {pretty(name)} (desired − actual)"


def _error_scopes(run: _Run) -> list[Scope]:
    scopes = []
    for name in run.result.signals:
        if not name.endswith("_err"):
            continue
        data = run.groups[name]
        panels = []
        for k, label in enumerate(run.labels[name]):
            unit = run.units[name][k]
            panel = Panel(_unit_label(label, unit))
            panel.curves.append((name, run.t, data[:, k], dict(color=ACTUAL, lw=1.3)))
            panel.hlines.append((0.0, dict(color="0.5", lw=0.8)))
            panel.note = f"final {data[-1, k]:.4g} {unit}".strip()
            panel.note_at = _level(data[-1, k])
            panels.append(panel)
        run.used.add(name)
        caption = ""
        designed = designed_error(run.result) if name == "q_err" else None
        if designed is not None:
            for k, panel in enumerate(panels):
                panel.curves.append(("designed", run.t, designed[:, k], dict(color=THEORY, lw=1.2, ls="--")))
            caption = ("designed: the solution of q̃̈ + K_D q̃̇ + K_P q̃ = 0 from the run's q̃(0), q̃̇(0), "
                       "which an exact model and unsaturated torques give; where the run leaves it, the "
                       "model or the actuators differ from the design.")
        scopes.append(Scope(name, _error_title(run, name), panels, caption=caption))
    return scopes


# ----------------------------------------------------------------------------- torques


def _torque_scope(run: _Run) -> Scope:
    result = run.result
    panels = []
    limit = _finite_limit(result.meta, result.n)
    for k, label in enumerate(run.labels["tau"]):
        unit = run.units["tau"][k]
        panel = Panel(_unit_label(f"τ {label}", unit))
        panel.curves.append(("applied", run.t, result.tau[:, k], dict(color=ACTUAL, lw=1.4)))
        if "tau_cmd" in result.signals:
            # Drawn over the applied torque, dashed: the two differ only where τ saturates.
            panel.curves.append(("commanded", run.t, result.signals["tau_cmd"][:, k],
                                 dict(color=COMMAND, lw=1.1, ls="--")))
        if "tau_dist" in result.signals:
            stops = (result.meta.get("joint_limits") or {}).get("mode") == "stop"
            panel.curves.append(("disturbance + stop" if stops else "disturbance", run.t,
                                 result.signals["tau_dist"][:, k],
                                 dict(color="0.45", lw=1.0, ls=":")))
        if limit is not None and np.isfinite(limit[k]):
            if limit[k] > OFF_SCALE * _peak(y for _, _, y, _ in panel.curves):
                # Lines at ±τ_max would set the scale and flatten a small trace to a line.
                panel.note = f"±{limit[k]:g} {unit} limit\noff-scale".replace("  ", " ")
            else:
                panel.hlines += [(limit[k], dict(color=LIMIT, lw=1.0, ls="-.", label="limit ±τ_max")),
                                 (-limit[k], dict(color=LIMIT, lw=1.0, ls="-."))]
                _saturation_view(panel, float(limit[k]), unit)
        panels.append(panel)
    run.used.update({"tau", "tau_cmd", "tau_dist"})
    return Scope("torques", "joint torques / forces τ", panels)


def _saturation_view(panel: Panel, limit: float, unit: str) -> None:
    """Where the commanded τ goes :data:`CLIPPED` times past ±τ_max (A7 ω_n = 60: 540 N against
    20 N), the panel shows the band ±τ_max and the applied τ inside it, not the commanded peak
    that would flatten both to a line; the note gives the peak."""
    commanded = [y for label, _, y, _ in panel.curves if label == "commanded"]
    peak = _peak(commanded)
    if not commanded or peak <= CLIPPED * limit:
        return
    others = _peak(y for label, _, y, _ in panel.curves if label != "commanded")
    reach = max(1.35 * limit, 1.1 * others)
    panel.ylim = (-reach, reach)
    signed = float(commanded[0][np.nanargmax(np.abs(commanded[0]))])
    panel.note = f"commanded τ peaks at\n{signed:.3g} {unit}: off-scale".replace("  ", " ")


# ----------------------------------------------------------------------------- forces


def _force_zoom(t: np.ndarray, h: np.ndarray, desired: np.ndarray | None) -> Zoom | None:
    """An inset of the last :data:`TAIL` of the run around the desired force when a transient
    makes the panel's range :data:`ZOOM_RATIO` times the tail's, else None; placed in the
    half of the panel the tail does not run through."""
    if desired is None:
        return None
    tail = _tail(t, TAIL)
    near = np.concatenate([h[tail], desired[tail]])
    whole = np.concatenate([h, desired])
    if not (np.all(np.isfinite(near)) and np.any(np.isfinite(whole))):
        return None
    low, high = float(near.min()), float(near.max())
    full_low, full_high = float(np.nanmin(whole)), float(np.nanmax(whole))
    width = max(high - low, 0.1 * float(np.abs(desired[tail]).max()), 1e-6)
    if full_high - full_low < ZOOM_RATIO * width:
        return None
    pad = 0.5 * width
    # The inset covers the right half of the panel, its upper or lower part (INSET_BANDS): it
    # goes where the curves there do not run (their height as a fraction of the panel's,
    # with matplotlib's 5 % margins), else it is left out.
    right = t >= t[0] + 0.5 * (t[-1] - t[0])
    there = (np.concatenate([h[right], desired[right]]) - full_low) / (full_high - full_low)
    there = (there + 0.05) / 1.1
    if np.nanmax(there) < INSET_BANDS[True][0] - 0.02:
        above = True
    elif np.nanmin(there) > INSET_BANDS[False][1] + 0.02:
        above = False
    else:
        return None
    return Zoom(float(t[tail.start]), (low - pad, high + pad), above=above)


def _force_scopes(run: _Run) -> list[Scope]:
    result = run.result
    if "h_e" not in result.signals:
        return []
    h = result.signals["h_e"]
    ref = next((r for r in FORCE_REFERENCES if r in result.signals), None)
    desired = result.signals[ref] if ref else None
    panels = []
    for k, label in enumerate(run.labels["h_e"]):
        has_ref = desired is not None and k < desired.shape[1]
        active = np.nanmax(np.abs(h[:, k])) > 1e-9
        active = active or (has_ref and np.nanmax(np.abs(desired[:, k])) > 1e-9)
        if not active and k >= 3:
            continue
        unit = run.units["h_e"][k]
        panel = Panel(_unit_label(label, unit))
        panel.curves.append(("h_e", run.t, h[:, k], dict(color=ACTUAL, lw=1.4)))
        if has_ref:
            panel.curves.append((ref, run.t, desired[:, k], dict(color=DESIRED, lw=1.1, ls="--")))
        panel.note = f"final {h[-1, k]:.4g} {unit}".strip()
        panel.note_at = _level(h[-1, k])
        if active:
            panel.zoom = _force_zoom(run.t, h[:, k], desired[:, k] if has_ref else None)
        panels.append(panel)
    run.used.update({"h_e", ref} - {None})
    return [Scope("forces", "contact wrench h_e (exerted on the environment, in Σ_0)", panels)]


# ----------------------------------------------------------------------------- x̄ (A15)

PARALLEL_CONTROLLERS = ("ParallelForcePosition",)
X_BAR_CAPTION = ("x̄ = x_F + x̃ = x_F + x_d − x_e is what the position loop of parallel control drives "
                 "to zero (at rest K_P x̄ = 0). Along Image(K) x̃ stays where the environment holds the "
                 "end effector and x_F, the force loop's output, takes up the difference; outside "
                 "Image(K), where f_d asks for no force, x_F = 0 and x̄ = x̃.")


def _parallel_error_scopes(run: _Run) -> list[Scope]:
    """The seed's x̄ scope of parallel force/position control: x̄ = x_F + x̃ per component,
    drawn with x̃ = p_des − p and x_F; none for other controllers."""
    groups = run.groups
    if run.kind not in PARALLEL_CONTROLLERS or not {"x_F", "p", "p_des"} <= set(groups):
        return []
    x_f, x_tilde = groups["x_F"], groups["p_des"] - groups["p"]
    if x_f.shape != x_tilde.shape:
        return []
    x_bar = x_f + x_tilde
    panels = []
    for k, label in enumerate(run.labels["x_F"]):
        unit = run.units["x_F"][k]
        panel = Panel(_unit_label(label, unit))
        panel.curves += [("x̄ = x_F + x̃", run.t, x_bar[:, k], dict(color=ACTUAL, lw=2.2)),
                         ("x̃ = x_d − x_e", run.t, x_tilde[:, k], dict(color=DESIRED, lw=1.2, ls="--")),
                         ("x_F", run.t, x_f[:, k], dict(color=COMPLIANT, lw=1.5, ls=":"))]
        panel.hlines.append((0.0, dict(color="0.5", lw=0.8)))
        panel.note = f"final x̄ {x_bar[-1, k]:.3g} {unit}\nx̃ {x_tilde[-1, k]:.3g} {unit}"
        panel.note_at = _level(x_bar[-1, k])
        panels.append(panel)
    run.used.add("x_F")
    return [Scope("x_bar", "x̄ = x_F + x̃ (the position loop's error), x̃ = x_d − x_e and x_F", panels,
                  caption=X_BAR_CAPTION)]


# ----------------------------------------------------------------------------- estimates


def _square_wave_caption(run: _Run, final: float, unit: str) -> str:
    """Why Y(π̂ − π) spikes in a run with a square-wave q̈_des ('' for other references)."""
    reference = run.controller.get("reference")
    if not (isinstance(reference, dict) and reference.get("type") == "SquareWaveAcceleration"):
        return ""
    if run.result.meta.get("disturbance"):
        return ""  # a wrong plant: Y(π̂ − π) is then dominated by the terms Y π cannot represent
    step = 2.0 * float(reference.get("amplitude", 0.0))
    half = 0.5 * float(reference.get("period", 0.0))
    return (f"Y(π̂ − π) jumps at every switch of the square-wave q̈_des (every {half:g} s): the q̈_r column "
            f"of Y steps by 2A = {step:g} rad/s² and multiplies Î − I ≠ 0, until the loop absorbs the "
            f"step. The panel gives the RMS over the last {100 * NOTE_TAIL:g} % of the run, not the sample "
            f"at t_final ({final:.3g}\u00a0{unit}), which may fall on a switch.")


def _estimate_scopes(run: _Run) -> list[Scope]:
    result = run.result
    true_values = result.meta.get("true_parameters")
    scopes = []
    for name in result.signals:
        if not name.endswith("_hat") or name in run.used:
            continue
        truth = result.signals.get(name[:-4] + "_true")
        panels = []
        for k, label in enumerate(run.labels[name]):
            panel = Panel(_unit_label(label, run.units[name][k]))
            panel.curves.append(("estimate", run.t, run.groups[name][:, k], dict(color=ACTUAL, lw=1.4)))
            if truth is not None:
                panel.curves.append(("true", run.t, truth[:, k], dict(color=DESIRED, lw=1.1, ls="--")))
            elif true_values is not None and k < len(true_values):
                true_line = dict(color=DESIRED, lw=1.1, ls="--", label="true")
                panel.hlines.append((float(true_values[k]), true_line))
            panels.append(panel)
        run.used.update({name, name[:-4] + "_true"})
        scopes.append(Scope("estimates", f"parameter estimates {pretty(name)} and true values", panels))

    z_labels = tuple(run.labels.get("z", ()))
    if not (z_labels and all(label.endswith("_hat") for label in z_labels)):
        return scopes
    known = true_values is not None and len(true_values) == len(z_labels)
    panels = []
    for k, label in enumerate(z_labels):
        panel = Panel(_unit_label(label, run.units["z"][k]))
        panel.curves.append(("estimate", run.t, result.z[:, k], dict(color=ACTUAL, lw=1.4)))
        if known:
            panel.hlines.append((float(true_values[k]), dict(color=DESIRED, lw=1.1, ls="--",
                                                             label="true value")))
        panels.append(panel)
    caption = ""
    regressor = result.signals.get("Y")
    if known and regressor is not None and regressor.shape[1] == len(z_labels):
        # Y(π̂ − π): what the wrong estimates cost in torque; it vanishes although π̂ ≠ π.
        mismatch = np.sum(regressor * (result.z - np.asarray(true_values, dtype=float)), axis=1)
        unit = run.units["tau"][0]
        panel = Panel(_unit_label("Y(π̂ − π)", unit))
        panel.curves.append(("Y(π̂ − π)", run.t, mismatch, dict(color=COMMAND, lw=1.3)))
        panel.hlines.append((0.0, dict(color="0.5", lw=0.8)))
        tail = _tail(run.t, NOTE_TAIL)
        rms = float(np.sqrt(np.mean(mismatch[tail] ** 2)))
        panel.note = f"RMS, last {run.t[-1] - run.t[tail.start]:.3g} s:\n{rms:.3g} {unit}"
        panels.append(panel)
        run.used.add("Y")
        caption = _square_wave_caption(run, float(mismatch[-1]), unit)
    run.used.add("z")
    title = "parameter estimates π̂ (controller state) and true values π"
    if "Y" in run.used:
        title += ", and Y(π̂ − π)"
    scopes.append(Scope("estimates", title, panels, caption=caption))
    return scopes


def _lyapunov_scopes(run: _Run) -> list[Scope]:
    terms = lyapunov_function(run.result)
    if terms is None:
        return []
    sigma = Panel(_unit_label("σ", run.units["sigma"][0]))
    sigma.curves.append(("σ", run.t, run.result.signals["sigma"][:, 0], dict(color=ACTUAL, lw=1.3)))
    sigma.hlines.append((0.0, dict(color="0.5", lw=0.8)))
    V = terms["V"]
    panel = Panel("V [J]")
    panel.curves += [("V", run.t, V, dict(color=ACTUAL, lw=2.2)),
                     ("½ I σ²", run.t, terms["kinetic"], dict(color=COMMAND, lw=1.3, ls="--")),
                     ("½ π̃ᵀ Γ⁻¹ π̃", run.t, terms["parameters"], dict(color=COMPLIANT, lw=1.5, ls=":"))]
    rise = float(np.max(np.diff(V))) if V.size > 1 else 0.0
    if rise <= 1e-9 * abs(V[0]):
        panel.note = f"V never increases:\nlargest step {rise:.2g} J"
    else:
        disturbed = bool(run.result.meta.get("disturbance"))
        why = "\n(the plant has terms\noutside Y π)" if disturbed else ""
        panel.note = f"V increases:\nV(t_f)/V(0) = {V[-1] / V[0]:.3g}{why}"
    run.used.add("sigma")
    title = "sliding variable σ and Lyapunov function V = ½ I σ² + ½ π̃ᵀ Γ⁻¹ π̃"
    return [Scope("lyapunov", title, [sigma, panel])]


# ----------------------------------------------------------------------------- singular values


def singular_warning(controller: dict) -> float:
    """The σ_min below which the task controller of this description warns (its own value,
    else the task controllers' default)."""
    from armlab.control.task_space import TaskController

    value = controller.get("singular_warning", TaskController.singular_warning)
    return float(value)


def _singular_value_scopes(run: _Run) -> list[Scope]:
    scopes = []
    for name in run.result.signals:
        if not _is_singular_value_group(name) or name in run.used:
            continue
        data = run.groups[name]
        panel = Panel(_unit_label("σ_i(J)", run.units[name][0] if run.units[name] else ""))
        for k, label in enumerate(run.labels[name]):
            panel.curves.append((pretty(label), run.t, data[:, k], trace_style(k)))
        run.used.add(name)
        if data.shape[1] and np.any(np.isfinite(data)):
            # σ_min as the controller's warning reads it: the k-th value of a k-component task.
            task = run.controller.get("task")
            k = len(task) if isinstance(task, list) and task else data.shape[1]
            column = min(k, data.shape[1]) - 1
            smallest = data[:, column]
            index = int(np.nanargmin(smallest))
            threshold = singular_warning(run.controller)
            panel.note = f"min σ_min = {smallest[index]:.3g}\nat t = {run.t[index]:.3g} s"
            if smallest[index] < 5.0 * threshold and np.nanmin(data) > 0.0:
                panel.log = True
                warning = dict(color=LIMIT, lw=1.1, ls="--", label="warning threshold")
                panel.hlines.append((threshold, warning))
                panel.note += f"\n(warning below {threshold:g})"
        scopes.append(Scope("singular_values", "singular values of the Jacobian", [panel]))
    return scopes


# ----------------------------------------------------------------------------- the rest


def _unit_blocks(units: tuple) -> list[tuple[str, list[int]]]:
    """The columns of a group by unit, in order of first appearance."""
    blocks: dict[str, list[int]] = {}
    for k, unit in enumerate(units):
        blocks.setdefault(unit, []).append(k)
    return list(blocks.items())


def _signal_panels(run: _Run, name: str, data: np.ndarray, state: bool) -> list[Panel]:
    """One panel per unit of group ``name``, its traces named by their components (the
    controller state's by its own component names, e.g. ∫fx, ∫fy, ∫fz)."""
    labels, units = run.labels[name], run.units[name]
    panels = []
    blocks = _unit_blocks(units)
    for unit, columns in blocks:
        title = "controller state" if state else name
        if len(columns) == 1 and data.shape[1] > 1:
            # A unit's only column of a wider group (g_comp's θ2): the label names the joint.
            title = f"{title} {labels[columns[0]]}"
        elif len(blocks) > 1 and not state and sum(len(labels[k]) for k in columns) <= 12:
            # A signal split by unit (a pose: x, y, z in m, φ1…φ3 in rad) names its components
            # when they are short (the legend names them too; the state's by its own labels).
            title = f"{title} ({', '.join(labels[k] for k in columns)})"
        panel = Panel(_unit_label(title, unit))
        for j, k in enumerate(columns):
            # A one-column signal is the signal itself (σ, not the name of its joint).
            entry = pretty(name) if data.shape[1] == 1 and not state else pretty(labels[k])
            style = trace_style(j) if len(columns) > 1 else dict(color=ACTUAL, lw=1.3)
            panel.curves.append((entry, run.t, data[:, k], style))
        panels.append(panel)
    return panels


def _signal_scopes(run: _Run) -> list[Scope]:
    result = run.result
    panels = []
    for name in result.signals:
        if name not in run.used:
            panels += _signal_panels(run, name, run.groups[name], state=False)
    has_state = result.z.shape[1] > 0 and "z" not in run.used
    if has_state:
        panels += _signal_panels(run, "z", result.z, state=True)
    if not panels:
        return []
    title = "other logged signals and the controller state" if has_state else "other logged signals"
    return [Scope("signals", title, panels)]
