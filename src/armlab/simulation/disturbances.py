"""Additive joint torque disturbances and unmodelled plant terms, evaluated by one compiled kernel.

The plant integrated by ``armlab.simulate`` is (D1) with an extra torque τ_d at the joints:

    B q̈ + C q̇ + F_v q̇ + F_s sgn q̇ + g = sat(τ) + τ_d(t, q, q̇) − Jᵀ h_e                  (S1)

τ_d is the sum of the terms below (notation table, S-tags of ``docs/notation.md``), each given
per joint [N | N·m]:

* :class:`ConstantTorque`        τ_d = c
* :class:`SinusoidalTorque`      τ_d = a sin(ω t + φ)   (seed A6 "sinusoidal disturbances")
* :class:`StepTorque`            τ_d = before for t < t_step, after from t_step on
* :class:`QuadraticFriction`     τ_d = −F₂ q̇|q̇| (``form="drag"``), or τ_d = −F₂ q̇² (``form="seed"``)
* :class:`CosineGravity`         τ_d = −G₂ cos q

and, added by ``simulate(joint_limits="stop")`` rather than written by hand,

* :class:`JointStop`             τ_d = unilateral spring-damper at the joint limits (S4)

QuadraticFriction and CosineGravity are the "wrong plant" variants of seed A8,
I q̈ + F q̇ + F₂ q̇² + G sin q + G₂ cos q = τ: terms the controller's model does not contain.
The seed writes F₂ q̇², which is not odd in q̇ and so not a friction (it pushes towards
negative q̇ whichever way the joint turns); ``"drag"`` is the dissipative reading F₂ q̇|q̇|,
``"seed"`` reproduces the seed's equation literally.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numba import njit

from armlab.errors import DisturbanceSpecError
from armlab.registry import scenario_type

CONSTANT, SINUSOIDAL, STEP, QUADRATIC_FRICTION, COSINE_GRAVITY, JOINT_STOP = 0, 1, 2, 3, 4, 5


kernel = njit(cache=True)


@kernel
def disturbance_into(dist, t, q, qd, tau_d_out):
    """τ_d(t, q, q̇) (n,) [N | N·m] of (S2): the sum of the terms encoded in ``dist``."""
    n = q.shape[0]
    for i in range(n):
        tau_d_out[i] = 0.0
    count = int(dist[0])
    k = 1
    for _ in range(count):
        kind = int(dist[k])
        k += 1
        if kind == CONSTANT:
            for i in range(n):
                tau_d_out[i] += dist[k + i]
            k += n
        elif kind == SINUSOIDAL:
            for i in range(n):
                tau_d_out[i] += dist[k + i] * np.sin(dist[k + n + i] * t + dist[k + 2 * n + i])
            k += 3 * n
        elif kind == STEP:
            t_step = dist[k]
            for i in range(n):
                tau_d_out[i] += dist[k + 1 + n + i] if t >= t_step else dist[k + 1 + i]
            k += 1 + 2 * n
        elif kind == QUADRATIC_FRICTION:
            seed_form = dist[k + n] != 0.0
            for i in range(n):
                v = qd[i]
                tau_d_out[i] -= dist[k + i] * (v * v if seed_form else v * abs(v))
            k += n + 1
        elif kind == COSINE_GRAVITY:
            for i in range(n):
                tau_d_out[i] -= dist[k + i] * np.cos(q[i])
            k += n
        else:
            # JOINT_STOP (S4): push back only, never pull towards the stop.
            for i in range(n):
                lower, upper = dist[k + i], dist[k + n + i]
                stiffness, damping = dist[k + 2 * n + i], dist[k + 3 * n + i]
                if q[i] > upper:
                    force = -stiffness * (q[i] - upper) - damping * qd[i]
                    if force < 0.0:
                        tau_d_out[i] += force
                elif q[i] < lower:
                    force = -stiffness * (q[i] - lower) - damping * qd[i]
                    if force > 0.0:
                        tau_d_out[i] += force
            k += 4 * n


def _vector(value, n: int, field: str) -> np.ndarray:
    array = np.atleast_1d(np.asarray(value, dtype=float))
    if array.ndim != 1 or array.shape[0] not in (1, n):
        raise DisturbanceSpecError(f"{field}: expected {n} values (one per joint), got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise DisturbanceSpecError(f"{field}: values must be finite")
    return np.broadcast_to(array, (n,)).astype(float)


class TorqueDisturbance:
    """Base of the disturbance terms; ``encode(n)`` gives the kernel's numbers."""

    def describe(self) -> dict:
        return {"type": type(self).__name__,
                **{k: np.asarray(v).tolist() if not isinstance(v, str) else v for k, v in vars(self).items()}}


@scenario_type("constant")
@dataclass(frozen=True, eq=False)
class ConstantTorque(TorqueDisturbance):
    """τ_d = value (n,) [N | N·m]."""

    value: np.ndarray

    def encode(self, n):
        return np.concatenate([[CONSTANT], _vector(self.value, n, "value")])


@scenario_type("sinusoidal")
@dataclass(frozen=True, eq=False)
class SinusoidalTorque(TorqueDisturbance):
    """τ_d = amplitude sin(omega t + phase); amplitude [N | N·m], omega [rad/s], phase [rad]."""

    amplitude: np.ndarray
    omega: np.ndarray
    phase: np.ndarray = 0.0

    def encode(self, n):
        return np.concatenate([[SINUSOIDAL], _vector(self.amplitude, n, "amplitude"),
                               _vector(self.omega, n, "omega"), _vector(self.phase, n, "phase")])


@scenario_type("step")
@dataclass(frozen=True, eq=False)
class StepTorque(TorqueDisturbance):
    """τ_d = before until t_step [s], after from then on."""

    t_step: float
    after: np.ndarray
    before: np.ndarray = 0.0

    def encode(self, n):
        return np.concatenate([[STEP, float(self.t_step)], _vector(self.before, n, "before"),
                               _vector(self.after, n, "after")])


@scenario_type("quadratic_friction")
@dataclass(frozen=True, eq=False)
class QuadraticFriction(TorqueDisturbance):
    """Unmodelled friction τ_d = −F₂ q̇|q̇| ("drag") or −F₂ q̇² ("seed"); F₂ [N·m·s²/rad²]."""

    coefficient: np.ndarray
    form: Literal["drag", "seed"] = "drag"

    def encode(self, n):
        if self.form not in ("drag", "seed"):
            raise DisturbanceSpecError(f"form: {self.form!r} is not 'drag' or 'seed'")
        return np.concatenate([[QUADRATIC_FRICTION], _vector(self.coefficient, n, "coefficient"),
                               [1.0 if self.form == "seed" else 0.0]])


@scenario_type("cosine_gravity")
@dataclass(frozen=True, eq=False)
class CosineGravity(TorqueDisturbance):
    """Unmodelled gravity-like term τ_d = −G₂ cos q; G₂ [N·m]."""

    coefficient: np.ndarray

    def encode(self, n):
        return np.concatenate([[COSINE_GRAVITY], _vector(self.coefficient, n, "coefficient")])


@dataclass(frozen=True, eq=False)
class JointStop(TorqueDisturbance):
    """Joint stops as stiff damped unilateral springs (S4): beyond q_max,

        τ_d = min(0, −K (q − q_max) − D q̇),   and beyond q_min   τ_d = max(0, −K (q − q_min) − D q̇)

    (zero between the limits).  ``lower``/``upper`` [m | rad] (±inf: no stop), ``stiffness``
    K [N/m | N·m/rad], ``damping`` D [N·s/m | N·m·s/rad].  See ``armlab.simulation.joint_limits``
    for the values ``simulate`` chooses."""

    lower: np.ndarray
    upper: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray

    def encode(self, n):
        lower, upper = (np.broadcast_to(np.asarray(v, dtype=float), (n,)) for v in (self.lower, self.upper))
        if np.any(np.isnan(lower)) or np.any(np.isnan(upper)) or np.any(lower > upper):
            raise DisturbanceSpecError("joint stop: limits must be ordered numbers (±inf for none)")
        stiffness, damping = _vector(self.stiffness, n, "stiffness"), _vector(self.damping, n, "damping")
        if np.any(stiffness < 0) or np.any(damping < 0):
            raise DisturbanceSpecError("joint stop: stiffness and damping must be non-negative")
        return np.concatenate([[JOINT_STOP], lower, upper, stiffness, damping])


def encode_disturbances(terms, n: int) -> np.ndarray:
    """The flat array read by :func:`disturbance_into` for a term, a list of terms or None."""
    if terms is None:
        terms = []
    elif isinstance(terms, TorqueDisturbance):
        terms = [terms]
    for term in terms:
        if not isinstance(term, TorqueDisturbance):
            raise DisturbanceSpecError(f"disturbance: {term!r} is not a TorqueDisturbance")
    return np.concatenate([[float(len(terms))], *[t.encode(n) for t in terms]])

