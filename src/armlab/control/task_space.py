"""Operational-space motion control (seed A9, A10; Siciliano et al. §8.6).

Both controllers regulate or track a :class:`~armlab.references.task.PoseReference` Σ_d(t)
in one of two task coordinates (``frame``):

* ``"base"`` — x = [p_e; φ_e] in Σ_0 with Euler angles ``euler`` (the seed's ZYZ), error
  x̃ = x_d − x_e and analytic Jacobian J_A = T_A⁻¹(φ_e) J  (T6);
* ``"desired"`` — Σ_d-relative, x̃ = −[o^d_{d,e}; φ_{d,e}] (XYZ angles, T(0) = I) and
  J_{A_d} = T_A⁻¹(φ_{d,e}) blockdiag(R_dᵀ, R_dᵀ) J  (T1–T4), the form of chapter 9.

A robot with fewer than six joints cannot follow a 6-D task: ``task`` selects the k components
of x controlled (default: position, (0, 1, 2)); gains are k × k (or 6 × 6 / 6-vectors, sliced
to the task).  Where a law must invert the k × n task Jacobian J_s it uses its exact inverse
when k = n and ``damping`` = 0, else the damped least-squares y = (J_sᵀJ_s + λ²I)⁻¹J_sᵀ r (T5).
Every controller logs the singular values σ of J_s (``jacobian_sv``) and the seed's det J_P
(``det_JP``, 3-joint robots); :meth:`TaskController.check` warns (``SingularityWarning``) when
σ_min fell below ``singular_warning``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Literal, NamedTuple

import numpy as np
from numba import njit

from armlab.control.base import Controller, Signal
from armlab.control.gains import gain_matrix
from armlab.errors import ControllerSpecError
from armlab.kernels.dynamics import (
    DynamicsWorkspace,
    bias_into,
    gravity_into,
    make_workspace,
    mass_matrix_into,
)
from armlab.kernels.linalg import task_solve_into
from armlab.kernels.task_space import (
    ABSOLUTE,
    RELATIVE,
    TaskWorkspace,
    log_task_signals,
    measure_into,
    select_rows_into,
    task_error_into,
    task_workspace,
    wrench_in_task_into,
)
from armlab.model.robot import Robot, RobotArrays
from armlab.references.task import PoseReference, pose_reference_into
from armlab.registry import scenario_type
from armlab.spatial import euler_code, euler_from_matrix

FRAMES = {"desired": RELATIVE, "base": ABSOLUTE}


class SingularityWarning(UserWarning):
    """The task Jacobian came close to singular during a run."""


COMPONENT_LABELS = ("x", "y", "z", "phi1", "phi2", "phi3")


@dataclass(frozen=True)
class TaskController(Controller):
    """Fields shared by the task-space controllers (see the module docstring)."""

    model: Robot
    reference: PoseReference
    kp: object
    kd: object
    task: tuple[int, ...] = (0, 1, 2)
    frame: Literal["base", "desired"] = "base"
    euler: str = "zyz"
    angle_reference: object = None
    damping: float = 0.0
    singular_warning: float = 0.02
    _derived: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        task = tuple(int(i) for i in self.task)
        if not task or len(set(task)) != len(task) or not all(0 <= i < 6 for i in task):
            raise ControllerSpecError(f"task: must be distinct components of [x, y, z, φ1, φ2, φ3] "
                                      f"numbered 0–5, got {self.task}")
        object.__setattr__(self, "task", task)
        if self.frame not in FRAMES:
            raise ControllerSpecError(f"frame: {self.frame!r} is not 'base' or 'desired'")
        try:
            convention = euler_code(self.euler)
        except ValueError as error:
            raise ControllerSpecError(str(error)) from None
        if not isinstance(self.reference, PoseReference):
            raise ControllerSpecError("reference: must be a PoseReference")
        if not (np.isfinite(self.damping) and self.damping >= 0.0):
            raise ControllerSpecError("damping: must be ≥ 0")
        if self.damping == 0.0 and len(task) != self.model.n and self.needs_inverse:
            raise ControllerSpecError(f"damping: a {len(task)}-component task on a {self.model.n}-joint "
                                      f"robot has no exact inverse; give damping > 0 (damped least squares)")
        if self.angle_reference is None:
            angles = euler_from_matrix(self.reference.rotations[0], self.euler)
        else:
            angles = np.asarray(self.angle_reference, dtype=float)
            if angles.shape != (3,) or not np.all(np.isfinite(angles)):
                raise ControllerSpecError("angle_reference: must be three finite Euler angles [rad]")
        object.__setattr__(self, "_derived", {
            "task": np.array(task, dtype=np.int64), "convention": convention,
            "angles": np.array(angles, dtype=float), "mode": FRAMES[self.frame],
            "kp": gain_matrix(self.kp, 6, "kp", components=task),
            "kd": gain_matrix(self.kd, 6, "kd", components=task)})

    needs_inverse = False

    @property
    def k(self) -> int:
        return len(self.task)

    def _common(self) -> dict:
        """The fields every task-space law's parameters begin with, as keyword arguments."""
        d = self._derived
        return dict(model=self.model.arrays, workspace=make_workspace(self.model.n),
                    task_workspace=task_workspace(self.model.n, self.k),
                    reference=np.array(self.reference.data), task=d["task"], kp=d["kp"], kd=d["kd"],
                    mode=d["mode"], convention=d["convention"], angle_reference=d["angles"].copy())

    def _task_signals(self) -> tuple[Signal, ...]:
        angle_unit = "rad"
        units6 = ("m",) * 3 + (angle_unit,) * 3
        return (Signal("x_err", COMPONENT_LABELS, units6),
                Signal("x", COMPONENT_LABELS, units6),
                Signal("p", ("x", "y", "z"), ("m",) * 3),
                Signal("p_des", ("x", "y", "z"), ("m",) * 3)) + jacobian_signals(self.model)

    def signals(self) -> tuple[Signal, ...]:
        return self._task_signals()

    def check(self, result) -> list[str]:
        """Warn (``SingularityWarning``) if σ_min of the task Jacobian went below
        ``singular_warning`` during ``result``; returns the messages."""
        messages = []
        sigma = result.signals.get("jacobian_sv")
        if sigma is not None and sigma.shape[0]:
            low = sigma[:, self.k - 1] if self.k <= sigma.shape[1] else sigma[:, -1]
            index = int(np.argmin(low))
            if low[index] < self.singular_warning:
                messages.append(f"task Jacobian near singular: σ_min = {low[index]:.3g} at "
                                f"t = {result.t[index]:.4g} s (threshold {self.singular_warning:g})")
        for message in messages:
            warnings.warn(message, SingularityWarning, stacklevel=2)
        return messages

    def describe(self) -> dict:
        out = {"type": type(self).__name__, "model": self.model.name,
               "reference": self.reference.describe(), "task": list(self.task), "frame": self.frame,
               "euler": self.euler, "damping": self.damping, "singular_warning": self.singular_warning}
        for key, value in self._derived.items():
            if key.startswith("k") or key.startswith("m"):
                out[key] = value.tolist() if isinstance(value, np.ndarray) else value
        return out


def jacobian_signals(robot: Robot) -> tuple[Signal, Signal]:
    """The singular values of J_s (``jacobian_sv``, units mixed by the task's rows: none) and
    det J_P (``det_JP``), whose unit is m per revolute joint: a prismatic joint's column of J_P
    is a pure number [m/m], a revolute joint's is in m/rad."""
    n = robot.n
    revolute = sum(joint.kind != "prismatic" for joint in robot.joints)
    unit = {0: "", 1: "m"}.get(revolute, f"m^{revolute}")
    return (Signal("jacobian_sv", tuple(f"sigma{i + 1}" for i in range(n)), ("",) * n),
            Signal("det_JP", ("det",), (unit,)))


@njit(cache=True)
def log_pose_signals(ws, signals_out):
    """x_err (6), x (6), p (3), p_des (3) before σ and det_JP; returns the next free index."""
    for i in range(6):
        signals_out[i] = ws.x_err[i]
        signals_out[6 + i] = ws.x_e[i]
    for i in range(3):
        signals_out[12 + i] = ws.p_e[i]
        signals_out[15 + i] = ws.frame[i]
    return 18


class OperationalPDParams(NamedTuple):
    """The ``params`` of :func:`operational_pd_law` (C9) for n joints and k task components."""

    model: RobotArrays              # the controller's model
    workspace: DynamicsWorkspace    # scratch of the dynamics kernels
    task_workspace: TaskWorkspace   # scratch of the task-space kernels (also what is logged)
    reference: np.ndarray           # a writeable copy of ``PoseReference.data``
    task: np.ndarray                # (k,) int64, the controlled components of x (0–5)
    kp: np.ndarray                  # (k, k) K_P [N/m, N·m/rad]
    kd: np.ndarray                  # (k, k) K_D [N·s/m, N·m·s/rad]
    mode: int                       # RELATIVE (frame "desired") or ABSOLUTE ("base")
    convention: int                 # Euler angles of x, ``spatial.euler_code``
    angle_reference: np.ndarray     # (3,) [rad] φ_d is the Euler triple nearest to it
    joint_damping: np.ndarray       # (n, n) K_q [N·m·s/rad | N·s/m]; zeros: the plain (C9)


@njit(cache=True)
def operational_pd_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """τ = g(q) + J_sᵀ (K_P x̃_s − K_D J_s q̇) − K_q q̇   (C9, Siciliano (8.110); (9.15) in Σ_d);
    ``params`` an :class:`OperationalPDParams`."""
    m, dws, ws = params.model, params.workspace, params.task_workspace
    task, kp, kd, kq = params.task, params.kp, params.kd, params.joint_damping
    ref, mode, convention, angles = params.reference, params.mode, params.convention, params.angle_reference
    k = task.shape[0]
    n = q.shape[0]
    pose_reference_into(ref, t, ws.frame)
    measure_into(m, q, qd, ws)
    task_error_into(mode, ws.frame, convention, angles, qd, ws)
    select_rows_into(task, ws.JA, ws.A)
    for r in range(k):
        rate = 0.0
        for j in range(n):
            rate += ws.A[r, j] * qd[j]
        ws.w6[r] = rate
    for r in range(k):
        acc = 0.0
        for c in range(k):
            acc += kp[r, c] * ws.x_err[task[c]] - kd[r, c] * ws.w6[c]
        ws.rhs[r] = acc
    gravity_into(m, dws, q, tau_out)
    for j in range(n):
        acc = 0.0
        for r in range(k):
            acc += ws.A[r, j] * ws.rhs[r]
        # Only the nonzero entries of K_q: with K_q = 0 the sum stays +0.0 and τ is the plain
        # (C9) bit for bit (x − 0.0 = x), even where a product 0 · q̇ would not be 0.
        damp = 0.0
        for i in range(n):
            if kq[j, i] != 0.0:
                damp += kq[j, i] * qd[i]
        tau_out[j] += acc
        tau_out[j] -= damp
    log_task_signals(ws, task, signals_out, log_pose_signals(ws, signals_out))


class OperationalInverseDynamicsParams(NamedTuple):
    """The ``params`` of :func:`inverse_dynamics_law` (C10, C12) for n joints and k task
    components."""

    model: RobotArrays              # the controller's model
    workspace: DynamicsWorkspace    # scratch of the dynamics kernels
    task_workspace: TaskWorkspace   # scratch of the task-space kernels (also what is logged)
    reference: np.ndarray           # a writeable copy of ``PoseReference.data``
    task: np.ndarray                # (k,) int64, the controlled components of x (0–5)
    kp: np.ndarray                  # (k, k) K_P [1/s²] (impedance: [N/m, N·m/rad])
    kd: np.ndarray                  # (k, k) K_D [1/s] (impedance: [N·s/m, N·m·s/rad])
    mode: int                       # RELATIVE (frame "desired") or ABSOLUTE ("base")
    convention: int                 # Euler angles of x, ``spatial.euler_code``
    angle_reference: np.ndarray     # (3,) [rad] φ_d is the Euler triple nearest to it
    mass_inverse: np.ndarray        # (k, k) M_d⁻¹ [1/kg, 1/(kg·m²)] (I: plain inverse dynamics)
    with_force: float               # w: 1.0 impedance (h_e fed back, Jᵀh_e compensated), else 0.0
    damping: float                  # λ of the damped least squares (T5), 0: exact inverse


@njit(cache=True)
def inverse_dynamics_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """Operational-space inverse dynamics / impedance (C10, C12):

        J_s y = M_d⁻¹ (K_D x̃̇_s + K_P x̃_s − w h_{A,s}) + c_s,    τ = B(q) y + n(q, q̇) + w Jᵀ h_e

    with c = ẍ_d − J̇_A q̇ (T6) or its Σ_d form (T4), w = 1 for impedance (measured h_e fed back
    and compensated), w = 0 for plain inverse dynamics (M_d = I); ``params`` an
    :class:`OperationalInverseDynamicsParams`.
    """
    m, dws, ws = params.model, params.workspace, params.task_workspace
    task, kp, kd, md_inv = params.task, params.kp, params.kd, params.mass_inverse
    ref, mode, convention, angles = params.reference, params.mode, params.convention, params.angle_reference
    w, damping = params.with_force, params.damping
    with_force = w != 0.0
    k = task.shape[0]
    pose_reference_into(ref, t, ws.frame)
    measure_into(m, q, qd, ws)
    task_error_into(mode, ws.frame, convention, angles, qd, ws)
    select_rows_into(task, ws.JA, ws.A)
    if with_force:
        phi = ws.x_e[3:] if mode == RELATIVE else ws.angles
        wrench_in_task_into(mode, convention, ws.frame, phi, h_e, ws.mat[0], ws.T, ws.w6, ws.h_task)
    for r in range(k):
        acc = 0.0
        for c in range(k):
            acc += kd[r, c] * ws.x_err_dot[task[c]] + kp[r, c] * ws.x_err[task[c]]
        if with_force:
            acc -= ws.h_task[task[r]]
        ws.h[r] = acc
    for r in range(k):
        acc = ws.c[task[r]]
        for c in range(k):
            acc += md_inv[r, c] * ws.h[c]
        ws.rhs[r] = acc
    task_solve_into(ws.A, ws.rhs, damping, ws.G, ws.y)
    solve_and_apply(m, dws, ws, q, qd, h_e, w, tau_out)
    log_task_signals(ws, task, signals_out, log_pose_signals(ws, signals_out))


@njit(cache=True)
def solve_and_apply(m, dws, ws, q, qd, h_e, compensate, tau_out):
    """τ = B(q) ws.y + n(q, q̇) (+ Jᵀ h_e when ``compensate`` ≠ 0) into tau_out.

    ``compensate`` is a float (1.0 or 0.0), not a bool: a literal True would be part of the
    compiled signature, and callers passing literals and computed flags compiled it twice."""
    n = q.shape[0]
    for i in range(6):
        ws.w6[i] = h_e[i] if compensate != 0.0 else 0.0
    bias_into(m, dws, q, qd, ws.w6, tau_out)
    mass_matrix_into(m, dws, q, ws.G)
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += ws.G[i, j] * ws.y[j]
        tau_out[i] += acc


@scenario_type("operational_pd")
@dataclass(frozen=True)
class OperationalPD(TaskController):
    """Operational-space PD with gravity compensation (seed A9; Siciliano (8.110)):

        τ = g(q) + J_sᵀ(q) (K_P x̃_s − K_D J_s(q) q̇) − K_q q̇                              (C9)

    J_s = S J_A (``frame="base"``) or S J_{A_d} (``frame="desired"``), S the task selection.
    Regulation law: the reference's velocity is not fed forward.  The seed's "equivalent"
    second form g + J_AᵀK_P x̃ − K_D q̇ damps in joint space instead and is a different law.
    ``kp``, ``kd`` (k, k) [N/m, N·s/m; N·m/rad, N·m·s/rad].

    ``joint_damping`` K_q (a number, n diagonal entries or an n × n matrix, symmetric positive
    semi-definite, [N·m·s/rad | N·s/m]; default 0, the plain law of the seed) damps the joint
    velocities the task does not see.  With a constant x_d and (for ``frame="base"``)
    ẋ̃_s = −J_s q̇, the energy V = ½ q̇ᵀB q̇ + ½ x̃_sᵀK_P x̃_s (+ the environment's potential, whose
    rate cancels the contact power) has, by the skew symmetry of Ḃ − 2C,

        V̇ = −q̇ᵀ (J_sᵀK_D J_s + K_q + F_v) q̇        (F_v the plant's viscous friction)

    J_sᵀK_D J_s has rank k: when the arm has more joints than task components (n > k) and no
    friction, V̇ = 0 on the n − k directions of the self-motion, which keeps moving undamped.
    K_q > 0 makes V̇ negative definite in q̇, so by LaSalle every motion ends at rest, where
    J_sᵀK_P x̃_s = Jᵀh_e: the same equilibria as without K_q (q̇ = 0 there), only reached.
    K_q also damps the task's own motion (by J̄ᵀK_q J̄ in task space, J̄ the inertia-weighted
    inverse of J_s): it changes the transient, not where the arm settles.
    """

    joint_damping: object = 0.0

    law = operational_pd_law

    def __post_init__(self):
        super().__post_init__()
        self._derived["joint_damping"] = gain_matrix(self.joint_damping, self.model.n, "joint_damping")

    def params(self) -> OperationalPDParams:
        return OperationalPDParams(**self._common(), joint_damping=self._derived["joint_damping"].copy())

    def describe(self) -> dict:
        return {**super().describe(), "joint_damping": self._derived["joint_damping"].tolist()}


@scenario_type("operational_inverse_dynamics")
@dataclass(frozen=True)
class OperationalInverseDynamics(TaskController):
    """Operational-space inverse dynamics (seed A10; Siciliano (8.114)–(8.115)):

        τ = B(q) y + n(q, q̇),   J_s y = ẍ_d,s + K_D x̃̇_s + K_P x̃_s − (J̇_A q̇)_s              (C10)

    so that (model exact) x̃̈_s + K_D x̃̇_s + K_P x̃_s = 0.  ``kp`` [1/s²], ``kd`` [1/s] (k, k).
    J_s is inverted exactly when k = n, by damped least squares (``damping`` λ) otherwise.
    """

    needs_inverse = True
    law = inverse_dynamics_law

    def params(self) -> OperationalInverseDynamicsParams:
        return OperationalInverseDynamicsParams(**self._common(), mass_inverse=np.eye(self.k),
                                                with_force=0.0, damping=float(self.damping))
