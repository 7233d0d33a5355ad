"""Declared joint limits in a simulation: reported, or enforced by joint stops.

``simulate(..., joint_limits=MODE)`` with MODE

* ``"ignore"`` — limits play no part (the run still diverges beyond ``limit_margin``);
* ``"warn"`` (default) — after the run, each joint whose logged q left [q_min, q_max] gets a
  :class:`JointLimitWarning` (first time, share of the run, worst excursion and when);
  ``result.meta["joint_limits"]`` records it for reports, and a run that left the limits
  logs the signal ``q_limit_excess`` (n,): q − q_max above, q − q_min below, 0 inside;
* ``"stop"`` — as ``"warn"``, and the plant gets joint stops: stiff damped unilateral springs
  (S4, :class:`armlab.simulation.disturbances.JointStop`, evaluated in every integrator stage
  with the other disturbances, so the logged ``tau_dist`` includes them).

Stop stiffness and damping.  A stop on joint i in contact alone adds K_i δ + D_i δ̇ to the
joint's equation; with the other joints free, the joint's effective inertia is
m_i = 1 / (B⁻¹(q₀))_ii, so the contact is the oscillator m_i δ̈ + D_i δ̇ + K_i δ = 0.  It is
made critically damped at the frequency ω_s:

    K_i = m_i ω_s²,   D_i = 2 m_i ω_s,   ω_s = 0.5 / dt                                   (S4)

Its eigenvalues are −ω_s (double), so ω_s dt = 0.5 lies well inside RK4's stability interval
(|λ dt| < 2.78 on the negative real axis) and the contact transient (a few 1/ω_s = a few
steps) is resolved by the fixed step: the stop is as stiff as the step allows and no stiffer.
The adaptive integrator uses the same K, D (its output grid dt).  A joint force τ pressing
into the stop holds it at a penetration δ = τ / K_i; a stiffer stop needs a smaller dt.
Excursions are measured on the logged samples (``log_every`` thins them).
"""

from __future__ import annotations

import inspect
import warnings
from pathlib import Path

import numpy as np

from armlab.errors import SimulationError
from armlab.simulation.disturbances import JointStop

MODES = ("ignore", "warn", "stop")
STOP_FREQUENCY_STEPS = 0.5
"""ω_s · dt of the stops (S4)."""


class JointLimitWarning(UserWarning):
    """A simulated joint left its declared limits."""


_PACKAGE = str(Path(__file__).resolve().parents[1])


def _user_stacklevel() -> int:
    """``warnings.warn``'s stacklevel, for this function's caller, of the first frame outside
    armlab: the user's line, however many of armlab's frames lie between (``simulate``, a
    scenario's ``run``, the cache repair around them)."""
    frames = inspect.stack(context=0)[1:]
    for level, frame in enumerate(frames, start=1):
        if not str(Path(frame.filename).resolve()).startswith(_PACKAGE):
            return level
    return len(frames)


def check_mode(mode) -> str:
    if mode not in MODES:
        raise SimulationError(f"joint_limits: {mode!r} is not one of {', '.join(map(repr, MODES))}")
    return mode


def joint_stop(plant, q0, dt: float) -> JointStop | None:
    """The stops (S4) of ``plant`` for a run of step ``dt`` from ``q0``; None when no joint
    has a finite limit."""
    from armlab.dynamics import inertia_matrix

    arrays = plant.arrays
    if not (np.isfinite(arrays.q_min).any() or np.isfinite(arrays.q_max).any()):
        return None
    omega = STOP_FREQUENCY_STEPS / dt
    mass = 1.0 / np.diag(np.linalg.inv(inertia_matrix(plant, np.asarray(q0, dtype=float))))
    return JointStop(lower=arrays.q_min.copy(), upper=arrays.q_max.copy(),
                     stiffness=mass * omega ** 2, damping=2.0 * mass * omega)


def excess(plant, q: np.ndarray) -> np.ndarray:
    """q − q_max above the limits, q − q_min below, 0 inside; (R, n)."""
    arrays = plant.arrays
    above = np.where(q > arrays.q_max, q - arrays.q_max, 0.0)
    below = np.where(q < arrays.q_min, q - arrays.q_min, 0.0)
    return above + below


def crossings(plant, t: np.ndarray, q: np.ndarray) -> dict:
    """{joint: {lower, upper, first, last, fraction, worst, at}} of the joints whose logged q
    left their limits (times [s], worst = the excursion of largest magnitude)."""
    arrays = plant.arrays
    # Most runs stay inside, which each joint's extremes tell: reduced along a contiguous copy
    # of the columns, ~20 µs for a 10 s log of the PRP at 1 kHz, where numpy's reductions and
    # comparisons across the rows of an (R, 3) array take 0.35 ms (8 % of the run).  fmax and
    # fmin pass over NaN samples, which excess() counts as inside.
    columns = np.ascontiguousarray(q.T)
    if not (q.size and (np.any(np.fmax.reduce(columns, axis=1) > arrays.q_max)
                        or np.any(np.fmin.reduce(columns, axis=1) < arrays.q_min))):
        return {}
    over = excess(plant, q)
    found = {}
    for i, name in enumerate(plant.joint_names):
        outside = np.nonzero(over[:, i])[0]
        if outside.size == 0:
            continue
        worst = int(outside[np.argmax(np.abs(over[outside, i]))])
        found[name] = {"lower": float(plant.arrays.q_min[i]), "upper": float(plant.arrays.q_max[i]),
                       "first": float(t[outside[0]]), "last": float(t[outside[-1]]),
                       "fraction": float(outside.size / len(t)), "worst": float(over[worst, i]),
                       "q_worst": float(q[worst, i]), "at": float(t[worst])}
    return found


def describe_crossing(plant, name: str, c: dict, mode: str = "warn") -> str:
    """One line: which joint, its limits, when and how far."""
    unit = "m" if plant.joints[plant.joint_names.index(name)].kind == "prismatic" else "rad"
    if mode == "stop":
        stop = c["upper"] if c["worst"] > 0 else c["lower"]
        return (f"joint {name} of {plant.name} met its stop at {stop:.4g} {unit} at t = {c['first']:.4g} s "
                f"(in contact in {c['fraction']:.0%} of the logged samples), deepest at "
                f"q = {c['q_worst']:.6g} {unit} at t = {c['at']:.4g} s")
    return (f"joint {name} of {plant.name} left its limits [{c['lower']:.4g}, {c['upper']:.4g}] {unit} "
            f"at t = {c['first']:.4g} s ({c['fraction']:.0%} of the logged samples), reaching "
            f"q = {c['q_worst']:.4g} {unit} at t = {c['at']:.4g} s")


def annotate(plant, mode: str, t, q, signals: dict, labels: dict, units: dict, meta: dict,
             stop: JointStop | None) -> None:
    """Add the excursion signal, the meta record and the warnings of ``mode`` (in place, on
    the dictionaries a result is about to be made of)."""
    if mode == "ignore":
        meta["joint_limits"] = {"mode": mode}
        return
    found = crossings(plant, t, q)
    if found:
        signals["q_limit_excess"] = excess(plant, q)
        labels["q_limit_excess"] = tuple(plant.joint_names)
        units["q_limit_excess"] = tuple("m" if j.kind == "prismatic" else "rad" for j in plant.joints)
    record = {"mode": mode, "crossed": found}
    if stop is not None:
        record["stop_stiffness"] = np.asarray(stop.stiffness).tolist()
        record["stop_damping"] = np.asarray(stop.damping).tolist()
    meta["joint_limits"] = record
    level = _user_stacklevel() if found else 1
    for name, c in found.items():
        warnings.warn(describe_crossing(plant, name, c, mode), JointLimitWarning, stacklevel=level)
