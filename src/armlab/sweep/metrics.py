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

from armlab.kernels.response import (
    DEVIATION,
    FINAL,
    OVERSHOOT,
    PEAK_TO_PEAK,
    SETTLING,
    error_size_into,
    peak_into,
    response_into,
    saturated_into,
)
from armlab.metrics import BAND, FORCE_REFERENCES, tail_slice

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
    return _tracking(result.signals)


def _tracking(signals) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(e, e_p) of :func:`tracking_error` from the signals (of one run, (R, w), or of several
    stacked, (N, R, w))."""
    if "q_err" in signals:
        return np.asarray(signals["q_err"]), None
    if "x_err" in signals:
        e = np.asarray(signals["x_err"])
        return e, e[..., :3]
    if "p_des" in signals and "p" in signals:
        e = np.asarray(signals["p_des"]) - np.asarray(signals["p"])
        return e, e
    return None, None


def _error_metrics(t, e, positional: bool) -> dict:
    """The error metrics of N runs at once: e (N, R, k) C-contiguous, ``positional`` whether its
    first three components are a position error; {name: (N,)}.

    Each run's numbers come from the compiled kernels of ``armlab.kernels.response``, which
    reduce one run at a time, so a run measured with others gets the bits it gets alone."""
    runs, _, k = e.shape
    out = np.empty((runs, k, 6))
    response_into(t, e, tail_slice(t).start, BAND, out)
    final, deviation = out[:, :, FINAL], out[:, :, DEVIATION]
    settling, overshoot = out[:, :, SETTLING], out[:, :, OVERSHOOT]
    sizes = np.empty((runs, 2))
    error_size_into(e, sizes)
    moving = ~(deviation <= FLOOR)            # else constant up to round-off: settled at t₀
    settle = np.where(moving, settling, float(t[0]))
    counted = moving & ~np.isnan(overshoot)
    largest_overshoot = np.where(counted, overshoot, -np.inf).max(axis=1)
    position = np.full(runs, math.nan)
    if positional:
        # e_p's mean over the window is the final value of e's first three components.
        position = np.array([float(np.linalg.norm(row)) for row in final[:, :3]])
    return {
        "settling_time": np.where(np.isnan(settle).any(axis=1), math.nan, settle.max(axis=1)),
        "overshoot": np.where(counted.any(axis=1), largest_overshoot, math.nan),
        "steady_state_error": np.abs(final).max(axis=1),
        "oscillation": out[:, :, PEAK_TO_PEAK].max(axis=1),
        "rms_error": sizes[:, 0],
        "max_error": sizes[:, 1],
        "position_error": position,
    }


def _torque_metrics(t, tau, limits, command) -> dict:
    """tau (N, R, n) applied torques, limits (N, n) (inf: none), command (N, R, n) or None
    (C-contiguous)."""
    step = float(t[1] - t[0]) if t.size > 1 else 0.0
    runs = tau.shape[0]
    peak, peak_command, saturated = np.empty(runs), np.full(runs, math.nan), np.empty(runs, dtype=np.int64)
    tau = np.ascontiguousarray(tau, dtype=float)
    peak_into(tau, peak)
    if command is not None:
        peak_into(np.ascontiguousarray(command, dtype=float), peak_command)
    saturated_into(tau, np.ascontiguousarray(limits, dtype=float), saturated)
    return {"peak_torque": peak, "peak_command": peak_command, "saturation_time": step * saturated}


def _force_metrics(h, desired, tail) -> dict:
    """h (N, R, 6) contact wrenches or None, desired (N, R, w) force references or None."""
    if h is None:
        return {}
    force = h[:, tail, :3].mean(axis=1)
    values = {"contact_force": np.array([float(np.linalg.norm(row)) for row in force])}
    if desired is not None:
        wanted = desired[:, tail, :3].mean(axis=1)
        values["force_error"] = np.array([float(np.linalg.norm(w - f[:w.size]))
                                          for w, f in zip(wanted, force, strict=True)])
    return values


def _adaptive_metrics(t, signals, z, truth) -> dict:
    """Y(π̂ − π) of controllers that log their regressor Y and estimate π̂ as their state:
    Y (N, R, p), z (N, R, p), truth π (p,) or None."""
    regressor = signals.get("Y")
    if regressor is None or truth is None or np.shape(z)[2] != np.shape(regressor)[2]:
        return {}
    mismatch = np.sum(regressor * (z - np.asarray(truth, dtype=float)), axis=2)
    half = slice(t.size // 2, None)
    converged = [convergence_time(t, row, PARAMETER_BAND) for row in mismatch]
    return {"param_error_rms": np.sqrt(np.mean(mismatch[:, half] ** 2, axis=1)),
            "param_error_time": np.array([math.nan if c is None else c for c in converged])}


def measure(result) -> dict[str, float]:
    """{metric: value} of every name in METRIC_NAMES for one run's :class:`SimulationResult`."""
    return measure_runs([result])[0]


def _limits(result) -> np.ndarray:
    limit = result.meta.get("torque_limit")
    return np.full(result.n, np.inf) if limit is None else np.broadcast_to(
        np.asarray(limit, dtype=float), (result.n,))


def measure_runs(results) -> list[dict[str, float]]:
    """:func:`measure` of each result, those of runs alike (the same status, samples and
    signals: a sweep's or a batch's) computed together, each to the bits of its own
    :func:`measure`."""
    rows = [dict.fromkeys(METRIC_NAMES, math.nan) for _ in results]
    groups: dict = {}
    for i, result in enumerate(results):
        if np.asarray(result.t).size == 0:
            continue
        key = (result.status == "ok", np.shape(result.tau), np.shape(result.z),
               tuple(sorted((name, np.shape(value)) for name, value in result.signals.items())),
               repr(result.meta.get("true_parameters")))
        groups.setdefault(key, []).append(i)
    for (ok, *_), members in groups.items():
        chosen = [results[i] for i in members]
        signals = {name: np.stack([np.asarray(r.signals[name]) for r in chosen])
                   for name in chosen[0].signals}
        values = measure_alike(np.asarray(chosen[0].t), np.stack([np.asarray(r.tau) for r in chosen]),
                               np.stack([_limits(r) for r in chosen]), signals,
                               np.stack([np.asarray(r.z) for r in chosen]), ok,
                               chosen[0].meta.get("true_parameters"))
        for position, i in enumerate(members):
            rows[i].update({name: float(column[position]) for name, column in values.items()})
    return rows


def measure_alike(t, tau, limits, signals, z, ok: bool, truth=None) -> dict[str, np.ndarray]:
    """{metric: (N,)} of N runs alike, from their stacked logs (C-contiguous arrays): t (R,),
    tau (N, R, n), limits (N, n) (inf: none), signals {name: (N, R, w)}, z (N, R, k), whether
    they ended ok, and the true parameters of an adaptive controller (or None)."""
    values = _torque_metrics(t, tau, limits, signals.get("tau_cmd"))
    if not ok:
        values["divergence_time"] = np.full(tau.shape[0], float(t[-1]))
        return values
    e, e_p = _tracking(signals)
    if e is not None and e.shape[2] > 0:
        values.update(_error_metrics(np.ascontiguousarray(t, dtype=float),
                                     np.ascontiguousarray(e, dtype=float), e_p is not None))
    reference = next((name for name in FORCE_REFERENCES if name in signals), None)
    values.update(_force_metrics(signals.get("h_e"), None if reference is None else signals[reference],
                                 tail_slice(t)))
    values.update(_adaptive_metrics(t, signals, z, truth))
    return values
