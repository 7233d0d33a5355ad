"""One row of numbers per run: the scalar metrics of a sweep's table (``docs/sweeps.md``).

The tracking error e(t) of a run is its controller's ``q_err`` signal (joint space), else its
``x_err`` (task space), else ``p_des − p`` (the force controllers' position part); e_k is its
component k, T_tail the last 5 % of the run, T_half its second half, h the logging step.

====================  =====================================================================
settling_time [s]     max_k of ``armlab.metrics.settling_time`` of e_k: the time after which
                      |e_k − e_k,∞| ≤ 0.02 max_t |e_k − e_k,∞|, e_k,∞ = mean_{T_tail} e_k (a
                      component that moves less than 1e-9 settles at t₀: round-off); NaN if
                      a component is outside its band at the last sample
overshoot [%]         max_k of ``armlab.metrics.overshoot`` of e_k: how far e_k goes past
                      e_k,∞, in % of |e_k(0) − e_k,∞|, over the components whose e_k starts at
                      its largest distance from e_k,∞ (step responses); NaN if none does
steady_state_error    max_k |mean_{T_tail} e_k| (each component in its own unit)
oscillation           max_k (max_{T_tail} e_k − min_{T_tail} e_k): what is left oscillating
rms_error             sqrt(mean_t ‖e(t)‖²) over the whole run
max_error             max_t max_k |e_k(t)|
position_error [m]    ‖mean_{T_tail} e_p‖, e_p the position part of a task-space error
peak_torque           max_t max_k |τ_k| (τ applied, after saturation) [N | N·m]
peak_command          max_t max_k |τ_cmd,k| (the law's command before saturation; NaN if the
                      run has no torque limit)
saturation_time [s]   h · (number of samples at which some joint is at its torque limit)
contact_force [N]     ‖mean_{T_tail} f_e‖, f_e the force part of the contact wrench h_e
force_error [N]       ‖mean_{T_tail} (f_d − f_e)‖ over the components the reference f_d has
param_error_rms       sqrt(mean_{T_half} (Y(π̂ − π))²): adaptive control's parameter error
                      seen through the regressor (A8) [N·m]
param_error_time [s]  the time after which |Y(π̂ − π)| stays below 5 % of its peak (NaN if
                      it is above at the end)
divergence_time [s]   time of the last sample before divergence; NaN if the run did not diverge
====================  =====================================================================

A diverged run keeps peak_torque, peak_command, saturation_time and divergence_time; its
error and force metrics are NaN (a truncated run has no steady state).  Every metric a run has
no signal for is NaN.
"""

from __future__ import annotations

import math

import numpy as np

from armlab.metrics import FORCE_REFERENCES, response, tail_slice

PARAMETER_BAND = 0.05
FLOOR = 1e-9
"""Deviations below this (in the signal's unit, m or rad) are round-off: a component that
moves less than that is constant (an orientation error of 1e-13 rad has nothing to settle)."""

METRICS: tuple[tuple[str, str], ...] = (
    ("settling_time", "s"), ("overshoot", "%"), ("steady_state_error", ""), ("oscillation", ""),
    ("rms_error", ""), ("max_error", ""), ("position_error", "m"), ("peak_torque", "N·m"),
    ("peak_command", "N·m"), ("saturation_time", "s"), ("contact_force", "N"), ("force_error", "N"),
    ("param_error_rms", "N·m"), ("param_error_time", "s"), ("divergence_time", "s"),
)
"""(column, unit) of every metric, in table order (units of mixed joints: N or N·m, m or rad)."""

METRIC_NAMES = tuple(name for name, _ in METRICS)


def convergence_time(t: np.ndarray, e: np.ndarray, band: float) -> float | None:
    """Time [s] after which |e| stays below ``band`` · max_t |e| (convergence to zero); None if
    the last sample is above it."""
    magnitude = np.abs(e)
    peak = float(np.nanmax(magnitude))
    outside = np.flatnonzero(magnitude > band * peak) if peak > 0 else np.array([], dtype=int)
    if outside.size == 0:
        return float(t[0])
    last = int(outside[-1])
    return None if last == t.size - 1 else float(t[last + 1])


def tracking_error(result) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(e, e_p): the run's tracking error (N, k) and its position part (N, 3) if it has one."""
    signals = result.signals
    if "q_err" in signals:
        return np.asarray(signals["q_err"]), None
    if "x_err" in signals:
        e = np.asarray(signals["x_err"])
        return e, e[:, :3]
    if "p_des" in signals and "p" in signals:
        e = np.asarray(signals["p_des"]) - np.asarray(signals["p"])
        return e, e
    return None, None


def _error_metrics(t, e, e_p) -> dict:
    tail = tail_slice(t)
    r = response(t, e)
    moving = ~(r.deviation <= FLOOR)            # else constant up to round-off: settled at t₀
    settle = np.where(moving, r.settling_time, float(t[0]))
    overshoots = r.overshoot[moving & ~np.isnan(r.overshoot)]
    return {
        "settling_time": math.nan if np.isnan(settle).any() else float(settle.max()),
        "overshoot": float(overshoots.max()) if overshoots.size else math.nan,
        "steady_state_error": float(np.abs(r.final).max()),
        "oscillation": float(r.peak_to_peak.max()),
        "rms_error": float(np.sqrt(np.mean(np.sum(e ** 2, axis=1)))),
        "max_error": float(np.max(np.abs(e))),
        "position_error": math.nan if e_p is None else float(np.linalg.norm(e_p[tail].mean(axis=0))),
    }


def _torque_metrics(result) -> dict:
    tau = np.asarray(result.tau)
    limit = result.meta.get("torque_limit")
    limits = np.full(result.n, np.inf) if limit is None else np.broadcast_to(
        np.asarray(limit, dtype=float), (result.n,))
    step = float(result.t[1] - result.t[0]) if result.t.size > 1 else 0.0
    at_limit = np.abs(tau) >= limits * (1.0 - 1e-9)
    command = result.signals.get("tau_cmd")
    return {"peak_torque": float(np.max(np.abs(tau))),
            "peak_command": math.nan if command is None else float(np.max(np.abs(command))),
            "saturation_time": step * int(np.count_nonzero(at_limit.any(axis=1)))}


def _force_metrics(result, tail) -> dict:
    h = result.signals.get("h_e")
    if h is None:
        return {}
    force = np.asarray(h)[tail, :3].mean(axis=0)
    values = {"contact_force": float(np.linalg.norm(force))}
    ref = next((r for r in FORCE_REFERENCES if r in result.signals), None)
    if ref is not None:
        desired = np.asarray(result.signals[ref])[tail, :3].mean(axis=0)
        values["force_error"] = float(np.linalg.norm(desired - force[:desired.size]))
    return values


def _adaptive_metrics(result, t) -> dict:
    """Y(π̂ − π) of a controller that logs its regressor Y and estimates π̂ as its state."""
    regressor = result.signals.get("Y")
    truth = result.meta.get("true_parameters")
    if regressor is None or truth is None or np.shape(result.z)[1] != np.shape(regressor)[1]:
        return {}
    mismatch = np.sum(np.asarray(regressor) * (np.asarray(result.z) - np.asarray(truth, dtype=float)), axis=1)
    half = slice(t.size // 2, None)
    converged = convergence_time(t, mismatch, PARAMETER_BAND)
    return {"param_error_rms": float(np.sqrt(np.mean(mismatch[half] ** 2))),
            "param_error_time": math.nan if converged is None else converged}


def measure(result) -> dict[str, float]:
    """{metric: value} of every name in METRIC_NAMES for one run's :class:`SimulationResult`."""
    values = dict.fromkeys(METRIC_NAMES, math.nan)
    t = np.asarray(result.t)
    if t.size == 0:
        return values
    values.update(_torque_metrics(result))
    if result.status != "ok":
        values["divergence_time"] = float(t[-1])
        return values
    e, e_p = tracking_error(result)
    if e is not None and e.shape[1] > 0:
        values.update(_error_metrics(t, e, e_p))
    values.update(_force_metrics(result, tail_slice(t)))
    values.update(_adaptive_metrics(result, t))
    return values
