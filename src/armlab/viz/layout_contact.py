"""The scopes of contact (A11–A15): the contact wrench h_e against the desired force, with an
inset around f_d where a transient sets the scale (``forces``), and parallel force/position
control's x̄ = x_F + x̃ with x̃ and x_F (``x_bar``, A15).
"""

from __future__ import annotations

import numpy as np

from armlab.metrics import FORCE_REFERENCES
from armlab.viz.scope_model import (
    ACTUAL,
    COMPLIANT,
    DESIRED,
    INSET_BANDS,
    TAIL,
    ZOOM_RATIO,
    Panel,
    Scope,
    Zoom,
    _level,
    _Run,
    _tail,
    _unit_label,
)

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
