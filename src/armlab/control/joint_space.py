"""Joint-space controllers of seed assignments A6 (PD + gravity) and A7 (inverse dynamics).

Both follow the protocol of ``armlab.control.base``; both compute their model terms from
their own ``model`` (a :class:`~armlab.model.robot.Robot`, possibly different from the plant).
Errors are q_err = q_des − q (the seed's q̃).  Notation: ``docs/notation.md``, C-tags.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numba import njit

from armlab.control.base import Controller, ProtocolError, Signal
from armlab.control.gains import gain_matrix
from armlab.errors import ControllerSpecError
from armlab.kernels.dynamics import DynamicsWorkspace, gravity_into, make_workspace
from armlab.kernels.plant import make_data
from armlab.model.robot import Robot, RobotArrays
from armlab.references.joint import JointReference, reference_into
from armlab.registry import scenario_type
from armlab.specialise import (
    ClosedFormUnavailable,
    choice_problem,
    inverse_dynamics_function,
    numeric_inverse_dynamics,
)

COMPENSATION = {"online": 0, "desired": 1, "none": 2}


def _check_reference(reference, n, field="reference"):
    if not isinstance(reference, JointReference):
        raise ProtocolError(f"{field}: {reference!r} is not a JointReference")
    if reference.n != n:
        raise ProtocolError(f"{field}: has {reference.n} components, the model {n} joints")


# The laws are inlined into the entry that calls them (no call boundary passing the robot's
# arrays by value).
law_kernel = njit(cache=True, inline="always")


class JointPDGravityParams(NamedTuple):
    """The ``params`` of :func:`joint_pd_gravity_law` (C1); n joints, the last four scratch."""

    model: RobotArrays              # the controller's model, whose gravity is ĝ
    workspace: DynamicsWorkspace    # scratch of ``gravity_into``
    reference: np.ndarray           # a writeable copy of ``JointReference.data``
    kp: np.ndarray                  # (n, n) K_P [N/m | N·m/rad]
    kd: np.ndarray                  # (n, n) K_D [N·s/m | N·m·s/rad]
    compensation: np.ndarray        # (1,) int64, ``COMPENSATION``: 0 ĝ(q), 1 ĝ(q_des), 2 none
    q_des: np.ndarray               # (n,) q_des(t) [m | rad]
    qd_des: np.ndarray              # (n,) q̇_des(t) [m/s | rad/s]
    qdd_des: np.ndarray             # (n,) q̈_des(t) [m/s² | rad/s²]
    gravity: np.ndarray             # (n,) ĝ(q_g) [N | N·m]


@law_kernel
def joint_pd_gravity_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """(C1): τ = ĝ(q_g) + K_P (q_des − q) − K_D q̇, q_g per compensation mode;
    ``params`` a :class:`JointPDGravityParams`."""
    m, ws, ref, kp, kd = params.model, params.workspace, params.reference, params.kp, params.kd
    q_des, qd_des, qdd_des, g = params.q_des, params.qd_des, params.qdd_des, params.gravity
    mode = params.compensation
    n = q.shape[0]
    reference_into(ref, t, q_des, qd_des, qdd_des)
    if mode[0] == 0:
        gravity_into(m, ws, q, g)
    elif mode[0] == 1:
        gravity_into(m, ws, q_des, g)
    else:
        for i in range(n):
            g[i] = 0.0
    for i in range(n):
        acc = g[i]
        for j in range(n):
            acc += kp[i, j] * (q_des[j] - q[j]) - kd[i, j] * qd[j]
        tau_out[i] = acc
        signals_out[i] = q_des[i]
        signals_out[n + i] = q_des[i] - q[i]
        signals_out[2 * n + i] = g[i]


@scenario_type("joint_pd_gravity")
@dataclass(frozen=True, eq=False)
class JointPDGravity(Controller):
    """Joint-space PD with gravity compensation (seed A6).

        τ = ĝ(q_g) + K_P (q_des − q) − K_D q̇                                              (C1)

    ``compensation``: "online" (q_g = q: global asymptotic stability of a constant q_des with
    zero error), "desired" (q_g = q_des(t), a feed-forward computed from the reference), or
    "none" (ĝ = 0: the equilibrium satisfies K_P q_err = g(q), a steady-state error on the
    joints that gravity loads).  ĝ is the gravity of the controller's ``model``.
    ``kp``, ``kd``: (n, n), (n,) or scalars [N/m | N·m/rad], [N·s/m | N·m·s/rad].

    Signals: ``q_des``, ``q_err`` (= q_des − q), ``g_comp`` (the ĝ term) — the A6 scopes.
    """

    model: Robot
    reference: JointReference
    kp: np.ndarray
    kd: np.ndarray
    compensation: Literal["online", "desired", "none"] = "online"
    law = joint_pd_gravity_law

    def __post_init__(self):
        n = self.model.n
        _check_reference(self.reference, n)
        if self.compensation not in COMPENSATION:
            raise ControllerSpecError(f"compensation: {self.compensation!r} is not one of "
                                f"{', '.join(COMPENSATION)}")
        object.__setattr__(self, "kp", gain_matrix(self.kp, n, "kp"))
        object.__setattr__(self, "kd", gain_matrix(self.kd, n, "kd"))

    def params(self):
        n = self.n
        return JointPDGravityParams(
            model=self.model.arrays, workspace=make_workspace(n),
            reference=np.array(self.reference.data), kp=self.kp, kd=self.kd,
            compensation=np.array([COMPENSATION[self.compensation]], dtype=np.int64),
            q_des=np.zeros(n), qd_des=np.zeros(n), qdd_des=np.zeros(n), gravity=np.zeros(n))

    def signals(self):
        return (Signal.joint("q_des", self.model, "position"), Signal.joint("q_err", self.model, "error"),
                Signal.joint("g_comp", self.model, "effort"))


class JointInverseDynamicsParams(NamedTuple):
    """The ``params`` of :func:`joint_inverse_dynamics_law` (C2); n joints, ``q_des`` to ``y``
    scratch."""

    inverse_dynamics: object        # ID(model, data, q, q̇, q̈, τ_out) of the model: its closed
                                    # form or its RNEA (``dynamics``), a compiled function
                                    # (``armlab.kernels.plant.INVERSE_DYNAMICS``)
    rnea: object                    # the RNEA's ID, for n̂ of a bias model (the same kind)
    model: np.ndarray               # the model's ``Robot.packed`` (never written)
    model_data: np.ndarray          # its data: the workspace of its kernels (scratch)
    reference: np.ndarray           # a writeable copy of ``JointReference.data``
    kp: np.ndarray                  # (n, n) K_P [1/s²]
    kd: np.ndarray                  # (n, n) K_D [1/s]
    diagonal: np.ndarray            # (1,) int64: 1 when K_P and K_D are diagonal (the sums skip zeros)
    q_des: np.ndarray               # (n,) q_des(t) [m | rad]
    qd_des: np.ndarray              # (n,) q̇_des(t) [m/s | rad/s]
    qdd_des: np.ndarray             # (n,) q̈_des(t) [m/s² | rad/s²]
    y: np.ndarray                   # (n,) outer-loop acceleration y [m/s² | rad/s²]
    bias_model: np.ndarray          # ``Robot.packed`` of n̂'s model when it is not B̂'s (else empty)
    bias_data: np.ndarray           # its data (scratch; empty without a bias model)
    zero: np.ndarray                # (n,) zeros: q̈ of the bias terms
    bias: np.ndarray                # (n,) scratch for n̂


@law_kernel
def joint_inverse_dynamics_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """(C2): τ = B̂(q) y + n̂(q, q̇), y = q̈_des + K_D (q̇_des − q̇) + K_P (q_des − q);
    ``params`` a :class:`JointInverseDynamicsParams`."""
    model, data, ref = params.model, params.model_data, params.reference
    kp, kd, diagonal, y = params.kp, params.kd, params.diagonal, params.y
    q_des, qd_des, qdd_des = params.q_des, params.qd_des, params.qdd_des
    n = q.shape[0]
    reference_into(ref, t, q_des, qd_des, qdd_des)
    for i in range(n):
        acc = qdd_des[i]
        if diagonal[0]:
            # Diagonal gains (``from_poles``): the same sum without its zero terms.
            acc += kd[i, i] * (qd_des[i] - qd[i]) + kp[i, i] * (q_des[i] - q[i])
        else:
            for j in range(n):
                acc += kd[i, j] * (qd_des[j] - qd[j]) + kp[i, j] * (q_des[j] - q[j])
        y[i] = acc
    # B̂ y + n̂ is exactly the model's inverse dynamics at q̈ = y (no B is formed).
    params.inverse_dynamics(model, data, q, qd, y, tau_out)
    if params.bias_model.size:
        # n̂ from its own model (the seed's A7 mismatch): τ += n̂_bias(q, q̇) − n̂_model(q, q̇).
        bias, zero = params.bias, params.zero
        params.rnea(params.bias_model, params.bias_data, q, qd, zero, bias)
        for i in range(n):
            tau_out[i] += bias[i]
        params.rnea(model, data, q, qd, zero, bias)
        for i in range(n):
            tau_out[i] -= bias[i]
    for i in range(n):
        signals_out[i] = q_des[i]
        signals_out[n + i] = q_des[i] - q[i]
        signals_out[2 * n + i] = qd_des[i] - qd[i]
        signals_out[3 * n + i] = y[i]


@scenario_type("joint_inverse_dynamics")
@dataclass(frozen=True, eq=False)
class JointInverseDynamics(Controller):
    """Joint-space inverse dynamics (computed torque) with a PD outer loop (seed A7).

        τ = B̂(q) y + n̂(q, q̇),   n̂ = Ĉ(q, q̇) q̇ + F̂_v q̇ + F̂_s sgn q̇ + ĝ(q)
        y = q̈_des + K_D (q̇_des − q̇) + K_P (q_des − q)                                      (C2)

    B̂, n̂ come from the controller's ``model``.  With a perfect model (model = plant) the inner
    loop linearises and decouples the arm to q̈ = y, so the error obeys

        q̃̈ + K_D q̃̇ + K_P q̃ = 0                                                             (C3)

    per joint a second-order system with ω_n² = k_P, 2ζω_n = k_D (:meth:`from_poles`).  With a
    wrong model (e.g. ``plant.with_link_mass("link4", 0.16)``) the residual
    B̂⁻¹[(B − B̂)q̈ + n − n̂] drives q̃ off zero: a steady-state error where gravity is
    mis-compensated.  h_e is not compensated (free-space control).

    ``bias_model`` (optional) is the model of n̂ alone, B̂ staying the ``model``'s: the seed's A7
    mismatch keeps B̂ = B and computes Ĉ, ĝ with m_Link4 = 0.16 kg.  Its equilibrium at rest
    (q̇ = 0, constant q_des) is B̂(q) K_P q̃ = g(q) − ĝ(q), q = q_des − q̃
    (:func:`armlab.theory.computed_torque_equilibrium`).

    B̂ y + n̂ is evaluated as the model's inverse dynamics at q̈ = y, by its closed form or its
    RNEA as ``dynamics`` says ("auto", "closed_form" or "numeric", see ``armlab.specialise``).

    Signals: ``q_des``, ``q_err``, ``qd_err``, ``y`` (the outer-loop acceleration).
    """

    model: Robot
    reference: JointReference
    kp: np.ndarray
    kd: np.ndarray
    dynamics: Literal["auto", "closed_form", "numeric"] = "auto"
    bias_model: Robot | None = None
    law = joint_inverse_dynamics_law

    def __post_init__(self):
        n = self.model.n
        _check_reference(self.reference, n)
        object.__setattr__(self, "kp", gain_matrix(self.kp, n, "kp"))
        object.__setattr__(self, "kd", gain_matrix(self.kd, n, "kd"))
        if choice_problem(self.dynamics):
            raise ControllerSpecError(f"dynamics: {choice_problem(self.dynamics)}")
        if self.bias_model is not None and self.bias_model.n != n:
            raise ControllerSpecError(f"bias_model: has {self.bias_model.n} joints, the model {n}")

    @classmethod
    def from_poles(cls, model: Robot, reference: JointReference, omega_n, zeta=1.0):
        """Gains for (C3) with natural frequency ``omega_n`` [rad/s] and damping ratio ``zeta``:
        K_P = diag(ω_n²), K_D = diag(2ζω_n)."""
        omega = np.broadcast_to(np.asarray(omega_n, dtype=float), (model.n,))
        zeta = np.broadcast_to(np.asarray(zeta, dtype=float), (model.n,))
        return cls(model, reference, omega**2, 2.0 * zeta * omega)

    def params(self):
        n = self.n
        try:
            inverse_dynamics = inverse_dynamics_function(self.model, self.dynamics, "dynamics")
        except ClosedFormUnavailable as error:
            raise ControllerSpecError(f"dynamics: {error}") from None
        diagonal = not (np.any(self.kp - np.diag(np.diag(self.kp)))
                        or np.any(self.kd - np.diag(np.diag(self.kd))))
        bias = self.bias_model is not None
        return JointInverseDynamicsParams(
            # Without a bias model ``rnea`` is never called: the same function stands in.
            inverse_dynamics=inverse_dynamics, rnea=numeric_inverse_dynamics() if bias else inverse_dynamics,
            model=self.model.packed, model_data=make_data(n), reference=np.array(self.reference.data),
            kp=self.kp, kd=self.kd, diagonal=np.array([diagonal], dtype=np.int64),
            q_des=np.zeros(n), qd_des=np.zeros(n), qdd_des=np.zeros(n), y=np.zeros(n),
            bias_model=self.bias_model.packed if bias else np.zeros(0),
            bias_data=make_data(n) if bias else np.zeros(0),
            zero=np.zeros(n), bias=np.zeros(n))

    def signals(self):
        return (Signal.joint("q_des", self.model, "position"), Signal.joint("q_err", self.model, "error"),
                Signal.joint("qd_err", self.model, "velocity"),
                Signal.joint("y", self.model, "acceleration"))
