"""The scopes of the arm's motion and effort: each tracked group against its reference
(``positions``, and task-space groups such as ``p`` with an admittance controller's compliant
frame and a spring's rest position Σ_r), every error signal ``<X>_err`` (a computed-torque run's
q̃ with its designed response) and the joint torques τ with their commands and limits
(``torques``).  :func:`armlab.viz.layout.scope_layout` puts them in its order.
"""

from __future__ import annotations

import numpy as np

from armlab.viz.scope_model import (
    ACTUAL,
    COMMAND,
    COMPLIANT,
    DESIRED,
    INSET_BANDS,
    LIMIT,
    MIDDLE_BAND,
    REST,
    TAIL,
    THEORY,
    ZOOM_RATIO,
    Panel,
    Scope,
    Zoom,
    _level,
    _reference_of,
    _Run,
    _tail,
    _unit_label,
    pretty,
)
from armlab.viz.theory import designed_error

# Controllers whose p_des is an internal x_d = 0, not a reference (pure force control, A14).
FORCE_ONLY_CONTROLLERS = ("ForceControl",)
# The frame the task error's components are in, by the controller's ``frame`` (A9–A13).
ERROR_FRAMES = {"base": "Σ_0", "desired": "Σ_d"}
OFF_SCALE = 3.0  # a torque limit this many times the largest |τ| is said, not drawn
CLIPPED = 4.0  # a commanded τ this many times its limit is cut from the view (its peak said)


def _finite_limit(meta: dict, n: int) -> np.ndarray | None:
    limit = meta.get("torque_limit")
    if limit is None:
        return None
    limit = np.broadcast_to(np.asarray(limit, dtype=float), (n,))
    return limit if np.any(np.isfinite(limit)) else None


def _peak(values) -> float:
    finite = [np.nanmax(np.abs(v)) for v in values if np.any(np.isfinite(v))]
    return float(max(finite)) if finite else 0.0


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
