"""Interaction control (seed A11–A15; Siciliano et al. ch. 9).

Indirect force control works on the pose relative to the desired frame Σ_d
(``frame="desired"``, x̃ = −[o^d_{d,e}; φ_{d,e}], XYZ angles, T1–T4):

* :class:`ComplianceControl` (A11)   τ = g + J_{A_d}ᵀ (K_P x̃ − K_D J_{A_d} q̇) − K_q q̇         (C11)
* :class:`ImpedanceControl` (A12)    M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A imposed through inverse
  dynamics with the measured wrench                                                        (C12)
* :class:`AdmittanceControl` (A13)   compliant frame Σ_t from M_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e^d,
  tracked by an inner inverse-dynamics motion loop                                         (C13)

Direct force control works on the position in Σ_0 and the force f_e = h_e[:3] in Σ_0:

* :class:`ForceControl` (A14)        x_F = C_F (f_d − f_e) as a position (inner position loop)
  or a velocity (inner velocity loop) reference                                            (C14)
* :class:`ParallelForcePosition` (A15) the inner position loop fed with x̃ + x_F            (C15)

with C_F = K_F + K_I/s; the integral ∫(f_d − f_e) dt is the controller state.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, NamedTuple

import numpy as np
from numba import njit

from armlab.control.base import Controller, Signal
from armlab.control.gains import gain_matrix
from armlab.control.task_space import (
    COMPONENT_LABELS,
    ControllerSpecError,
    OperationalInverseDynamicsParams,
    OperationalPD,
    TaskController,
    inverse_dynamics_law,
    jacobian_signals,
    log_pose_signals,
    solve_and_apply,
)
from armlab.kernels.dynamics import DynamicsWorkspace, make_workspace
from armlab.kernels.linalg import task_solve_into
from armlab.kernels.task_space import (
    TaskWorkspace,
    compliant_frame_into,
    frame_from_vector,
    log_task_signals,
    measure_into,
    position_error_into,
    select_rows_into,
    task_error_into,
    task_workspace,
)
from armlab.model.robot import Robot, RobotArrays
from armlab.references.task import ForceReference, PoseReference, force_reference_into, pose_reference_into
from armlab.registry import scenario_type

ALL6 = (0, 1, 2, 3, 4, 5)


@scenario_type("compliance")
@dataclass(frozen=True)
class ComplianceControl(OperationalPD):
    """Compliance control (seed A11; Siciliano (9.15)): PD + gravity in Σ_d,

        τ = g(q) + J_{A_d}ᵀ(q, x̃) (K_P x̃ − K_D J_{A_d}(q, x̃) q̇) − K_q q̇                      (C11)

    At rest in contact with a spring environment of stiffness K about Σ_r ∥ Σ_d (E2, E3) the
    equilibrium is K_P x̃ = K x_{r,e}, i.e. x_e = (K_P + K)⁻¹(K_P x_d + K x_r) component by
    component of Σ_d (the directions the robot can move).  No inverse is needed, so every
    component may be controlled (``task`` default: all six, in Σ_d's axes).

    ``joint_damping`` K_q is :class:`~armlab.control.task_space.OperationalPD`'s: with
    V = ½ q̇ᵀB q̇ + ½ x̃ᵀK_P x̃ + ½ x_{r,e}ᵀK x_{r,e}, V̇ = −q̇ᵀ(J_{A_d}ᵀK_D J_{A_d} + K_q + F_v) q̇,
    negative definite in q̇ with K_q > 0 even on an arm with more joints than task components,
    whose self-motion K_D alone leaves undamped; the equilibrium (q̇ = 0) is the one above.
    """

    task: tuple[int, ...] = ALL6
    frame: Literal["base", "desired"] = "desired"


@scenario_type("impedance")
@dataclass(frozen=True)
class ImpedanceControl(TaskController):
    """Impedance control (seed A12; Siciliano (9.29)–(9.31)), inverse dynamics with the
    measured contact wrench:

        τ = B(q) y + n(q, q̇) + Jᵀ(q) h_e
        J_{A_d,s} y = M_d⁻¹ (K_D x̃̇_s + K_P x̃_s − h_{A,s}) + c_s,  c = ḃ − J̇_{A_d} q̇          (C12)

    so that, with an exact model, M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A with h_A = T_Aᵀ(φ_{d,e}) h_e^d
    on the task components.  The seed writes −M_d b and h_e^d in y: the drift term enters with
    +M_d ḃ (from x̃̈ = −J_{A_d} q̈ − J̇_{A_d} q̇ + ḃ) and the wrench as h_A (= h_e^d only where
    T(φ_{d,e}) = I).  ``mass`` M_d (k, k) [kg, kg·m²] positive definite.
    """

    mass: object = 1.0
    frame: Literal["base", "desired"] = "desired"

    needs_inverse = True
    law = inverse_dynamics_law

    def params(self) -> OperationalInverseDynamicsParams:
        mass = gain_matrix(self.mass, 6, components=self.task, field="mass", positive_definite=True)
        return OperationalInverseDynamicsParams(**self._common(), mass_inverse=np.linalg.inv(mass),
                                                with_force=1.0, damping=float(self.damping))


class AdmittanceParams(NamedTuple):
    """The ``params`` of :func:`admittance_law` (C13) for n joints and k task components;
    ``frame_t``, ``h_d`` and ``zdd`` are scratch."""

    model: RobotArrays              # the controller's model
    workspace: DynamicsWorkspace    # scratch of the dynamics kernels
    task_workspace: TaskWorkspace   # scratch of the task-space kernels (also what is logged)
    reference: np.ndarray           # a writeable copy of ``PoseReference.data`` (Σ_d)
    task: np.ndarray                # (k,) int64, the controlled components of x̃_t (0–5)
    kp: np.ndarray                  # (k, k) K_P of the inner motion loop [1/s²]
    kd: np.ndarray                  # (k, k) K_D of the inner motion loop [1/s]
    mode: int                       # RELATIVE (admittance control works in Σ_d)
    convention: int                 # Euler code (unused by RELATIVE errors, which are XYZ)
    angle_reference: np.ndarray     # (3,) [rad] (unused by RELATIVE errors)
    mass_t_inverse: np.ndarray      # (6, 6) M_t⁻¹ [1/kg, 1/(kg·m²)] in Σ_d's axes
    kd_t: np.ndarray                # (6, 6) K_Dt [N·s/m, N·m·s/rad]
    kp_t: np.ndarray                # (6, 6) K_Pt [N/m, N·m/rad]
    frame_t: np.ndarray             # (24,) the compliant frame Σ_t(t), as ``PoseReference`` frames
    h_d: np.ndarray                 # (6,) h_e^d, the measured wrench in Σ_d's axes [N, N·m]
    zdd: np.ndarray                 # (6,) z̃̈ [m/s², rad/s²]
    damping: float                  # λ of the damped least squares (T5), 0: exact inverse


@njit(cache=True)
def admittance_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """Admittance control (C13):

        M_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e^d,   z̃ = −[o^d_{d,t}; φ_{d,t}]   (state z = [z̃; z̃̇])
        τ = B y + n + Jᵀ h_e,   J_{A_t,s} y = K_D x̃̇_{t,s} + K_P x̃_{t,s} + c_{t,s}

    x̃_t the pose error relative to the compliant frame Σ_t (T1–T4 with Σ_a = Σ_t, T9);
    ``params`` an :class:`AdmittanceParams`.
    """
    m, dws, ws = params.model, params.workspace, params.task_workspace
    task, kp, kd = params.task, params.kp, params.kd
    ref, mode, convention, angles = params.reference, params.mode, params.convention, params.angle_reference
    mt_inv, kdt, kpt, damping = params.mass_t_inverse, params.kd_t, params.kp_t, params.damping
    frame_t, h_d, zdd = params.frame_t, params.h_d, params.zdd
    k = task.shape[0]
    pose_reference_into(ref, t, ws.frame)
    R_d = ws.mat[0]
    frame_from_vector(ws.frame, R_d)
    for i in range(3):
        h_d[i] = R_d[0, i] * h_e[0] + R_d[1, i] * h_e[1] + R_d[2, i] * h_e[2]
        h_d[3 + i] = R_d[0, i] * h_e[3] + R_d[1, i] * h_e[4] + R_d[2, i] * h_e[5]
    for i in range(6):
        acc = h_d[i]
        for j in range(6):
            acc -= kdt[i, j] * z[6 + j] + kpt[i, j] * z[j]
        ws.w6[i] = acc
    for i in range(6):
        acc = 0.0
        for j in range(6):
            acc += mt_inv[i, j] * ws.w6[j]
        zdd[i] = acc
        zdot_out[i] = z[6 + i]
        zdot_out[6 + i] = acc
    compliant_frame_into(ws.frame, z[:6], z[6:], zdd, ws.vec, ws.mat, frame_t)
    measure_into(m, q, qd, ws)
    # mode is RELATIVE (frame 'desired' is enforced); the parameter, not the literal constant,
    # so that task_error_into is the version every other law links.
    task_error_into(mode, frame_t, convention, angles, qd, ws)
    select_rows_into(task, ws.JA, ws.A)
    for r in range(k):
        acc = ws.c[task[r]]
        for c in range(k):
            acc += kd[r, c] * ws.x_err_dot[task[c]] + kp[r, c] * ws.x_err[task[c]]
        ws.rhs[r] = acc
    task_solve_into(ws.A, ws.rhs, damping, ws.G, ws.y)
    solve_and_apply(m, dws, ws, q, qd, h_e, 1.0, tau_out)
    start = log_task_signals(ws, task, signals_out, log_pose_signals(ws, signals_out))
    for i in range(3):
        signals_out[start + i] = frame_t[i]


@scenario_type("admittance")
@dataclass(frozen=True)
class AdmittanceControl(TaskController):
    """Admittance control (seed A13; Siciliano §9.3), law (C13) in ``admittance_law``.

    The outer admittance M_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e^d (``mass_t``, ``kd_t``, ``kp_t``,
    (6, 6) or diagonals, in Σ_d's axes) turns the measured wrench into the compliant frame Σ_t;
    the inner loop (``kp`` [1/s²], ``kd`` [1/s], (k, k)) makes Σ_e follow Σ_t with
    x̃̈_t + K_D x̃̇_t + K_P x̃_t = 0 on the task components.  The inner loop should be faster than
    the admittance.  Signals: the pose signals relative to Σ_t and ``p_t`` (Σ_t's origin in
    Σ_0); z̃ and z̃̇ are the controller state z.
    """

    mass_t: object = 1.0
    kd_t: object = 1.0
    kp_t: object = 1.0
    frame: Literal["desired"] = "desired"

    needs_inverse = True
    law = admittance_law

    def params(self) -> AdmittanceParams:
        if self.frame != "desired":
            raise ControllerSpecError("frame: admittance control works in Σ_d ('desired')")
        mass_t = gain_matrix(self.mass_t, 6, components=ALL6, field="mass_t", positive_definite=True)
        return AdmittanceParams(**self._common(), mass_t_inverse=np.linalg.inv(mass_t),
                                kd_t=gain_matrix(self.kd_t, 6, components=ALL6, field="kd_t"),
                                kp_t=gain_matrix(self.kp_t, 6, components=ALL6, field="kp_t"),
                                frame_t=np.zeros(24),
                                h_d=np.zeros(6), zdd=np.zeros(6), damping=float(self.damping))

    def initial_state(self) -> np.ndarray:
        return np.zeros(12)

    def state_labels(self) -> tuple[str, ...]:
        return tuple(f"zt_{c}" for c in COMPONENT_LABELS) + tuple(f"zt_dot_{c}" for c in COMPONENT_LABELS)

    def state_units(self) -> tuple[str, ...]:
        return ("m",) * 3 + ("rad",) * 3 + ("m/s",) * 3 + ("rad/s",) * 3

    def signals(self) -> tuple[Signal, ...]:
        return self._task_signals() + (Signal("p_t", ("x", "y", "z"), ("m",) * 3),)


class ForceMotionParams(NamedTuple):
    """The ``params`` of :func:`force_motion_law` (C14, C15) for n joints; the last two fields
    are scratch."""

    model: RobotArrays              # the controller's model
    workspace: DynamicsWorkspace    # scratch of the dynamics kernels
    task_workspace: TaskWorkspace   # scratch of the task-space kernels (k = 3, also what is logged)
    reference: np.ndarray           # a writeable copy of ``PoseReference.data``, x_d(t)
    task: np.ndarray                # (3,) int64 [0, 1, 2]: the position components
    kp: np.ndarray                  # (3, 3) K_P [1/s²]
    kd: np.ndarray                  # (3, 3) K_D [1/s]
    mass_inverse: np.ndarray        # (3, 3) M_d⁻¹ [1/kg]
    force_reference: np.ndarray     # a writeable copy of ``ForceReference.data``, f_d(t)
    kf: np.ndarray                  # (3, 3) K_F [m/N]
    ki: np.ndarray                  # (3, 3) K_I [m/(N·s)]
    position_feedback: float        # w: 1.0 inner position loop, 0.0 inner velocity loop
    damping: float                  # λ of the damped least squares (T5), 0: exact inverse
    f_d: np.ndarray                 # (3,) f_d(t) [N]
    x_f: np.ndarray                 # (3,) x_F [m]


@njit(cache=True)
def force_motion_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """Force control with inner position / velocity loop and parallel force/position (C14, C15):

        x_F = K_F (f_d − f_e) + K_I ∫(f_d − f_e) dt                     (state z = ∫(f_d − f_e))
        J_P y = M_d⁻¹ (K_D x̃̇ + K_P (w x̃ + x_F)) + c,   τ = B y + n + Jᵀ h_e

    x̃ = x_d − p_e, x̃̇ = ẋ_d − ṗ_e, c = ẍ_d − J̇_P q̇ (T8); w = 1 (position loop; x_d = 0 for pure
    force control, the reference for parallel control), w = 0 (velocity loop, x_d = 0);
    ``params`` a :class:`ForceMotionParams`.
    """
    m, dws, ws, ref = params.model, params.workspace, params.task_workspace, params.reference
    task, kp, kd, md_inv = params.task, params.kp, params.kd, params.mass_inverse
    force_ref, kf, ki, f_d, x_f = params.force_reference, params.kf, params.ki, params.f_d, params.x_f
    position_feedback, damping = params.position_feedback, params.damping
    force_reference_into(force_ref, t, f_d)
    for i in range(3):
        zdot_out[i] = f_d[i] - h_e[i]
    for i in range(3):
        acc = 0.0
        for j in range(3):
            acc += kf[i, j] * (f_d[j] - h_e[j]) + ki[i, j] * z[j]
        x_f[i] = acc
    pose_reference_into(ref, t, ws.frame)
    measure_into(m, q, qd, ws)
    position_error_into(ws.frame, qd, ws)
    select_rows_into(task, ws.JA, ws.A)
    for r in range(3):
        acc = 0.0
        for c in range(3):
            acc += kd[r, c] * ws.x_err_dot[c] + kp[r, c] * (position_feedback * ws.x_err[c] + x_f[c])
        ws.h[r] = acc
    for r in range(3):
        acc = ws.c[r]
        for c in range(3):
            acc += md_inv[r, c] * ws.h[c]
        ws.rhs[r] = acc
    task_solve_into(ws.A, ws.rhs, damping, ws.G, ws.y)
    solve_and_apply(m, dws, ws, q, qd, h_e, 1.0, tau_out)
    for i in range(3):
        signals_out[i] = f_d[i]
        signals_out[3 + i] = x_f[i]
        signals_out[6 + i] = ws.p_e[i]
        signals_out[9 + i] = ws.frame[i]
    # 4 f_d.shape[0] = 12 written above; not the literal 12, which would compile
    # log_task_signals once more (a literal int is part of the compiled signature).
    log_task_signals(ws, task, signals_out, 4 * f_d.shape[0])


INNER_LOOPS = ("position", "velocity")


@dataclass(frozen=True)
class _ForceBase(Controller):
    model: Robot
    force: ForceReference
    kp: object
    kd: object
    kf: object
    ki: object = 0.0
    mass: object = 1.0
    damping: float = 0.0
    singular_warning: float = 0.02

    law = force_motion_law

    def _check(self):
        if not isinstance(self.force, ForceReference):
            raise ControllerSpecError("force: must be a ForceReference")
        if not (np.isfinite(self.damping) and self.damping >= 0.0):
            raise ControllerSpecError("damping: must be ≥ 0")
        if self.damping == 0.0 and self.model.n != 3:
            raise ControllerSpecError(f"damping: a 3-component position task on a {self.model.n}-joint "
                                      f"robot has no exact inverse; give damping > 0")
        for name in ("kp", "kd", "kf", "ki"):
            gain_matrix(getattr(self, name), 6, components=(0, 1, 2), field=name)
        gain_matrix(self.mass, 6, components=(0, 1, 2), field="mass", positive_definite=True)

    def _params(self, reference: PoseReference, position_feedback: float) -> ForceMotionParams:
        task = (0, 1, 2)
        mass = gain_matrix(self.mass, 6, components=task, field="mass", positive_definite=True)
        return ForceMotionParams(
            model=self.model.arrays, workspace=make_workspace(self.model.n),
            task_workspace=task_workspace(self.model.n, 3), reference=np.array(reference.data),
            task=np.array(task, dtype=np.int64), kp=gain_matrix(self.kp, 6, components=task, field="kp"),
            kd=gain_matrix(self.kd, 6, components=task, field="kd"), mass_inverse=np.linalg.inv(mass),
            force_reference=np.array(self.force.data),
            kf=gain_matrix(self.kf, 6, components=task, field="kf"),
            ki=gain_matrix(self.ki, 6, components=task, field="ki"), position_feedback=position_feedback,
            damping=float(self.damping), f_d=np.zeros(3), x_f=np.zeros(3))

    k = 3
    check = TaskController.check

    def initial_state(self) -> np.ndarray:
        return np.zeros(3)

    def state_labels(self) -> tuple[str, ...]:
        return ("int_fx", "int_fy", "int_fz")

    def state_units(self) -> tuple[str, ...]:
        return ("N·s",) * 3

    def signals(self) -> tuple[Signal, ...]:
        xyz = ("x", "y", "z")
        return (Signal("f_des", xyz, ("N",) * 3), Signal("x_F", xyz, ("m",) * 3),
                Signal("p", xyz, ("m",) * 3), Signal("p_des", xyz, ("m",) * 3)) + jacobian_signals(self.model)

    def describe(self) -> dict:
        out = {"type": type(self).__name__, "model": self.model.name, "force": self.force.describe(),
               "singular_warning": self.singular_warning}
        for name in ("kp", "kd", "kf", "ki", "mass"):
            out[name] = np.asarray(getattr(self, name), dtype=float).tolist()
        return out


_ORIGIN = PoseReference.constant(np.zeros(3), np.eye(3))


@scenario_type("force")
@dataclass(frozen=True)
class ForceControl(_ForceBase):
    """Force control with an inner position or velocity loop (seed A14; Siciliano §9.4),
    law (C14) in ``force_motion_law``.

    ``inner="position"``: M_d ẍ_e + K_D ẋ_e + K_P x_e = K_P x_F — x_F is a *position* in Σ_0,
    so along directions where the environment gives no force (outside Image(K)) x_F stays 0
    and the end effector is driven towards Σ_0's origin: the drift the seed saw along z.
    ``inner="velocity"``: M_d ẍ_e + K_D ẋ_e = K_P x_F — K_D⁻¹ K_P x_F is a velocity reference,
    directions without force stay where they are.  f_e → f_d along Image(K) with K_I > 0 (position loop)
    or with K_F alone (velocity loop, its integrator is the environment's position).
    ``kf`` [m/N] (x_F is a length with either loop), ``ki`` [m/(N·s)], ``kp`` [1/s²], ``kd``
    [1/s], ``mass`` M_d.

    ``x_F0`` (3,) [m] starts the integrator at ∫(f_d − f_e) = K_I⁺ x_F0 (it must lie in the range
    of K_I), so that the force loop begins from a position instead of Σ_0's origin — e.g. the
    environment's rest position along its normal, while the other components stay 0 as in the
    seed.
    """

    inner: Literal["position", "velocity"] = "position"
    x_F0: object = None

    def __post_init__(self):
        if self.inner not in INNER_LOOPS:
            raise ControllerSpecError(f"inner: {self.inner!r} is not 'position' or 'velocity'")
        self._check()
        z0 = np.zeros(3)
        if self.x_F0 is not None:
            target = np.asarray(self.x_F0, dtype=float)
            if target.shape != (3,) or not np.all(np.isfinite(target)):
                raise ControllerSpecError("x_F0: must be a finite position (3,) [m]")
            ki = gain_matrix(self.ki, 6, components=(0, 1, 2), field="ki")
            z0 = np.linalg.lstsq(ki, target, rcond=None)[0]
            if np.abs(ki @ z0 - target).max() > 1e-9 * max(1.0, np.abs(target).max()):
                raise ControllerSpecError("x_F0: must lie in the range of ki (the integral gain)")
        object.__setattr__(self, "_z0", z0)

    def initial_state(self) -> np.ndarray:
        return self._z0.copy()

    def params(self) -> ForceMotionParams:
        return self._params(_ORIGIN, 1.0 if self.inner == "position" else 0.0)


@scenario_type("parallel_force_position")
@dataclass(frozen=True)
class ParallelForcePosition(_ForceBase):
    """Parallel force/position control (seed A15; Siciliano §9.4.3), law (C15):

        M_d ẍ_e + K_D ẋ_e + K_P x_e = K_P (x_d + x_F),   x_F = K_F (f_d − f_e) + K_I ∫(f_d − f_e)

    At equilibrium with a spring environment, f_e = f_d along Image(K) (integral action) and
    x_e = x_d along the unconstrained directions; a component of f_d outside Image(K) is never
    met, its integral grows without bound and the end effector runs away (the seed's last
    experiment; the simulator stops it as diverged).  ``reference`` gives x_d (positions).
    """

    reference: PoseReference = field(default=_ORIGIN)

    def __post_init__(self):
        if not isinstance(self.reference, PoseReference):
            raise ControllerSpecError("reference: must be a PoseReference")
        self._check()

    def params(self) -> ForceMotionParams:
        return self._params(self.reference, 1.0)
