"""The scopes of parameter estimation: estimates (a ``*_hat`` group, or a controller state of
``*_hat`` components) against the true values, with Y(π̂ − π) when the regressor ``Y`` is logged
(``estimates``), and a Slotine–Li run's sliding variable σ with its Lyapunov function
V = ½ I σ² + ½ π̃ᵀ Γ⁻¹ π̃ (``lyapunov``, :mod:`armlab.viz.theory`).
"""

from __future__ import annotations

import numpy as np

from armlab.viz.scope_model import (
    ACTUAL,
    COMMAND,
    COMPLIANT,
    DESIRED,
    Panel,
    Scope,
    _Run,
    _tail,
    _unit_label,
    pretty,
)
from armlab.viz.theory import lyapunov_function

NOTE_TAIL = 0.1  # Y(π̂ − π) is summarised by its RMS over the last tenth of the run


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
