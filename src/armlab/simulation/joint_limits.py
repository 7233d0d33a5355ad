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
m_i(q) = 1 / (B⁻¹(q))_ii, so the contact is the oscillator m_i δ̈ + D_i δ̇ + K_i δ = 0.  It is
made critically damped at the frequency ω_s:

    K_i = m_i ω_s²,   D_i = 2 m_i ω_s,   ω_s = 0.5 / dt                                   (S4)

Its eigenvalues are −ω_s (double), so ω_s dt = 0.5 lies well inside RK4's stability interval
(|λ dt| < 2.78 on the negative real axis) and the contact transient (a few 1/ω_s = a few
steps) is resolved by the fixed step: the stop is as stiff as the step allows and no stiffer.
m_i is taken where the stop acts: the least m_i(q) over configurations with q_i at that
limit and the other joints anywhere in theirs (:func:`contact_inertia`).  At q₀ alone it can
be many times too large (a 2R arm whose elbow folds: 60×; the Panda's joint 1: 47×), and then
ω dt exceeds RK4's interval at contact and the stop pumps energy into the arm.  Other joints
in contact too only make the joint heavier (m_i ≤ B_ii), so the stop stays stable.
The adaptive integrator uses the same K, D (its output grid dt).  A joint force τ pressing
into the stop holds it at a penetration δ = τ / K_i; a stiffer stop needs a smaller dt.
Excursions are measured on the logged samples (``log_every`` thins them).

Energy check.  Stops, friction and the arm are passive: with the stops' stored energy and the
work of the joint torques and other disturbances,

    H(t) = T + U + Σ ½ K_i δ_i² − ∫₀ᵗ q̇ᵀ (τ + τ_d − τ_stop) dt                             (S5)

never increases (the trapezoidal rule on the logged samples).  A run with stops whose H rises
by more than :data:`ENERGY_GAIN_SHARE` of its energy scale gets a :class:`StopEnergyWarning`
and ``meta["joint_limits"]["energy_gain"]``: its integration injected energy (a step too large
for the contact).  Checked on runs with stops, without an environment, logged at every step.
"""

from __future__ import annotations

import functools
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
    scenario's ``run``, the cache repair around them).

    It walks the frames' code objects (``inspect.currentframe``), not ``inspect.stack``: that
    one looks up every frame's module and source line: 0.26 ms of the 0.68 ms of Python around
    each 100-step A6 sweep run, where this call is made for every run."""
    frame = inspect.currentframe()
    frame = frame.f_back if frame is not None else None
    level = 0
    while frame is not None:
        level += 1
        if not _inside_armlab(frame.f_code.co_filename):
            return level
        frame = frame.f_back
    return max(level, 1)


@functools.lru_cache(maxsize=1024)
def _inside_armlab(filename: str) -> bool:
    return str(Path(filename).resolve()).startswith(_PACKAGE)


def check_mode(mode) -> str:
    if mode not in MODES:
        raise SimulationError(f"joint_limits: {mode!r} is not one of {', '.join(map(repr, MODES))}")
    return mode


CONTACT_SAMPLES = 64
"""Random configurations per stop over which :func:`contact_inertia` takes its least value
(besides the joints' limits, 0, ±π/2 and π one joint at a time)."""

ENERGY_GAIN_SHARE = 0.05
"""Rise of H (S5) beyond which a run with stops is flagged, as a share of its energy scale."""


class StopEnergyWarning(UserWarning):
    """A run's passive energy grew: its joint stops injected energy (S5)."""


def _sample_ranges(plant, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per joint the interval to sample: its limits, a revolute joint without them a full turn,
    a prismatic one without them its q₀."""
    lo, hi = plant.arrays.q_min.copy(), plant.arrays.q_max.copy()
    revolute = np.array([j.kind == "revolute" for j in plant.joints])
    for bound, default in ((lo, -np.pi), (hi, np.pi)):
        missing = ~np.isfinite(bound)
        bound[missing & revolute] = default
        bound[missing & ~revolute] = q0[missing & ~revolute]
    return lo, hi


def contact_inertia(plant, q0, i: int, at: float) -> float:
    """The least effective inertia m_i(q) = 1/(B⁻¹(q))_ii [kg | kg·m²] over configurations with
    q_i = ``at`` and the other joints in their ranges (:func:`_sample_ranges`): q₀, each other
    joint in turn at its ends, 0, ±π/2, π, and :data:`CONTACT_SAMPLES` seeded random ones."""
    from armlab.dynamics import inertia_matrix

    q0 = np.asarray(q0, dtype=float)
    lo, hi = _sample_ranges(plant, q0)
    base = q0.copy()
    base[i] = at
    samples = [base]
    for j in range(plant.n):
        if j == i:
            continue
        for value in (lo[j], hi[j], 0.0, np.pi / 2, -np.pi / 2, np.pi):
            if lo[j] <= value <= hi[j]:
                q = base.copy()
                q[j] = value
                samples.append(q)
    rng = np.random.default_rng(i)
    for _ in range(CONTACT_SAMPLES):
        q = rng.uniform(lo, hi)
        q[i] = at
        samples.append(q)
    return float(min(1.0 / np.linalg.inv(inertia_matrix(plant, q))[i, i] for q in samples))


def joint_stop(plant, q0, dt: float) -> JointStop | None:
    """The stops (S4) of ``plant`` for a run of step ``dt`` from ``q0``; None when no joint
    has a finite limit.  Each joint's K, D from the least of its contact inertias at its
    finite limits."""
    arrays = plant.arrays
    if not (np.isfinite(arrays.q_min).any() or np.isfinite(arrays.q_max).any()):
        return None
    omega = STOP_FREQUENCY_STEPS / dt
    mass = np.ones(plant.n)
    for i in range(plant.n):
        limits = [v for v in (arrays.q_min[i], arrays.q_max[i]) if np.isfinite(v)]
        if limits:
            mass[i] = min(contact_inertia(plant, q0, i, v) for v in limits)
    return JointStop(lower=arrays.q_min.copy(), upper=arrays.q_max.copy(),
                     stiffness=mass * omega ** 2, damping=2.0 * mass * omega)


def passive_energy(plant, stop: JointStop, t, q, qd, tau, tau_dist) -> tuple[np.ndarray, float]:
    """(H(t) of (S5) on the logged samples, the run's energy scale: the largest kinetic and
    stored energy plus the spans of U and of the work) [J]; ``tau_dist`` includes the stops."""
    from armlab.dynamics import kinetic_energy, potential_energy

    K, D = np.asarray(stop.stiffness, dtype=float), np.asarray(stop.damping, dtype=float)
    above = np.maximum(q - stop.upper, 0.0)
    below = np.minimum(q - stop.lower, 0.0)
    tau_stop = (np.minimum(0.0, -K * above - D * qd) * (above > 0)
                + np.maximum(0.0, -K * below - D * qd) * (below < 0))
    power = np.sum(qd * (tau + tau_dist - tau_stop), axis=1)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    stored = 0.5 * np.sum(K * (above ** 2 + below ** 2), axis=1)
    kinetic = np.array([kinetic_energy(plant, a, b) for a, b in zip(q, qd, strict=True)])
    potential = np.array([potential_energy(plant, a) for a in q])
    scale = kinetic.max() + stored.max() + np.ptp(potential) + np.ptp(work)
    return kinetic + potential + stored - work, float(scale)


def energy_gain(H: np.ndarray) -> float:
    """The largest rise of H over any earlier value [J] (0 for a log with non-finite values:
    the divergence check reports those)."""
    if H.size < 2 or not np.all(np.isfinite(H)):
        return 0.0
    return float(np.max(H - np.minimum.accumulate(H)))


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
             stop: JointStop | None, qd=None, tau=None) -> None:
    """Add the excursion signal, the meta record and the warnings of ``mode`` (in place, on
    the dictionaries a result is about to be made of); with stops, ``qd`` and ``tau`` (the
    applied torques), the energy check (S5)."""
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
    checkable = (stop is not None and found and qd is not None and tau is not None and "tau_dist" in signals
                 and "h_e" not in signals and meta.get("log_every", 1) == 1)
    if checkable:
        H, scale = passive_energy(plant, stop, t, q, qd, tau, signals["tau_dist"])
        rise = energy_gain(H)
        if rise > ENERGY_GAIN_SHARE * scale and rise > 1e-9:
            record["energy_gain"] = rise
            dt = meta.get("dt", float("nan"))
            warnings.warn(f"{plant.name}'s passive energy grew by {rise:.4g} J (energy scale {scale:.4g} J) "
                          f"with a joint at its stop: the step dt = {dt:g} s is too large for the contact, "
                          "and the run's data cannot be trusted", StopEnergyWarning,
                          stacklevel=_user_stacklevel())
