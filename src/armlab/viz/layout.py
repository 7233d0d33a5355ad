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
axis; every y label carries its unit (:mod:`armlab.viz.scope_model`).  :mod:`armlab.viz.scopes`
draws them.  The rules of each kind of figure are in :mod:`armlab.viz.layout_motion` (positions,
errors, torques), :mod:`armlab.viz.layout_contact` (forces, x̄), :mod:`armlab.viz.layout_estimates`
(estimates, Lyapunov function) and :mod:`armlab.viz.layout_signals` (singular values, the rest);
this module puts them in order.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from armlab.viz.layout_contact import _force_scopes, _parallel_error_scopes
from armlab.viz.layout_estimates import _estimate_scopes, _lyapunov_scopes
from armlab.viz.layout_motion import _error_scopes, _torque_scope, _tracking_scopes
from armlab.viz.layout_signals import _signal_scopes, _singular_value_scopes
from armlab.viz.scope_model import Panel, Scope, _run_of  # noqa: F401  (Panel: imported from here too)

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
