"""Slotine–Li adaptive control in joint space (seed A8).

With the reference velocity and the sliding variable (q_err = q_des − q, Λ ≻ 0)

    q̇_r = q̇_des + Λ q_err,   q̈_r = q̈_des + Λ q̇_err,   σ = q̇_r − q̇                    (C4)

the law and the adaptation are (Slotine & Li 1987; Siciliano et al. §8.5.4)

    τ = Y(q, q̇, q̇_r, q̈_r) π̂ + K_D σ,     dπ̂/dt = Γ Yᵀ σ                                   (C5)

where Y π = B(q) q̈_r + C(q, q̇) q̇_r + F q̇_r + g(q) is linear in the parameters π (C with
Christoffel symbols, so Ḃ − 2C is skew).  With π̃ = π̂ − π the closed loop is
B σ̇ + (C + F + K_D) σ = −Y π̃ and

    V = ½ σᵀ B σ + ½ π̃ᵀ Γ⁻¹ π̃,    V̇ = −σᵀ (F + K_D) σ ≤ 0                                   (C6)

so σ → 0 (hence q_err → 0) and Y π̃ → 0, while π̂ need not converge to π (only to the set
where Y π̃ = 0 along the trajectory) — the seed's observation.  The estimates π̂ are the
controller state z.

Two regressors:

* :class:`SlotineLi1DoF` — the seed's link I q̈ + F q̇ + G sin q = τ with π = [I, F, G] and
  Y = [q̈_r, q̇_r, sin q]                                                                  (C7)
* :class:`SlotineLi` — any serial robot; π stacks per link the ten standard inertial
  parameters in its joint frame J_i, [m, m c_x, m c_y, m c_z, I_xx, I_xy, I_xz, I_yy, I_yz,
  I_zz] (I the inertia tensor about J_i's origin, tensor entries: I_xy = −∫xy dm), and the
  viscous coefficient F_v,i.  Y is built numerically from the RNEA, which is linear in π: with
  T(a, b, s) = RNEA(q, q̇ = a, q̈ = b, gravity × s) (no friction),

      ¼[T(q̇ + q̇_r, 2q̈_r, 2) − T(q̇ − q̇_r, −2q̈_r, −2)] = B q̈_r + C(q, q̇) q̇_r + g          (C8)

  by polarisation of the quadratic velocity term, and column k of Y is (C8) for a robot whose
  link i has parameters π₀ + e_k minus the same for π₀ (exact: (C8) is linear in π).
  Motor rotor inertia and Coulomb friction are not estimated (the model must not have them).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from armlab.control.base import Controller, ProtocolError, Signal
from armlab.control.gains import gain_matrix
from armlab.control.joint_space import _check_reference
from armlab.errors import ControllerSpecError
from armlab.kernels.dynamics import DynamicsWorkspace, make_workspace, rnea_into
from armlab.model.robot import Robot, RobotArrays
from armlab.references.joint import JointReference, reference_into
from armlab.registry import scenario_type

PARAMETER_NAMES = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz", "Fv")


kernel = njit(cache=True)
# The seed link's law is small: inlined into the loop that calls it.
law_kernel = njit(cache=True, inline="always")


class SlotineLi1DoFParams(NamedTuple):
    """The ``params`` of :func:`slotine_li_1dof_law` (C4), (C5), (C7); the last four scratch."""

    reference: np.ndarray           # a writeable copy of ``JointReference.data`` (one joint)
    kd: np.ndarray                  # (1,) K_D [N·m·s/rad]
    lam: np.ndarray                 # (1,) Λ [1/s]
    gamma: np.ndarray               # (3, 3) Γ of dπ̂/dt = Γ Yᵀσ [π_i π_j / J]
    q_des: np.ndarray               # (1,) q_des(t) [rad]
    qd_des: np.ndarray              # (1,) q̇_des(t) [rad/s]
    qdd_des: np.ndarray             # (1,) q̈_des(t) [rad/s²]
    Y: np.ndarray                   # (3,) the regressor [q̈_r, q̇_r, sin q] [rad/s², rad/s, 1]


@law_kernel
def slotine_li_1dof_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """(C4), (C5) with the seed's regressor (C7); z = π̂ = [Î, F̂, Ĝ]; ``params`` a
    :class:`SlotineLi1DoFParams`."""
    ref, kd, lam, gamma, Y = params.reference, params.kd, params.lam, params.gamma, params.Y
    q_des, qd_des, qdd_des = params.q_des, params.qd_des, params.qdd_des
    reference_into(ref, t, q_des, qd_des, qdd_des)
    q_err = q_des[0] - q[0]
    qd_err = qd_des[0] - qd[0]
    qd_r = qd_des[0] + lam[0] * q_err
    qdd_r = qdd_des[0] + lam[0] * qd_err
    sigma = qd_r - qd[0]
    Y[0], Y[1], Y[2] = qdd_r, qd_r, np.sin(q[0])
    tau_out[0] = Y[0] * z[0] + Y[1] * z[1] + Y[2] * z[2] + kd[0] * sigma
    for r in range(3):
        zdot_out[r] = (gamma[r, 0] * Y[0] + gamma[r, 1] * Y[1] + gamma[r, 2] * Y[2]) * sigma
    signals_out[0] = q_des[0]
    signals_out[1] = q_err
    signals_out[2] = sigma
    signals_out[3], signals_out[4], signals_out[5] = Y[0], Y[1], Y[2]


@scenario_type("slotine_li_1dof")
@dataclass(frozen=True, eq=False)
class SlotineLi1DoF(Controller):
    """Slotine–Li adaptive control of the seed's 1-DoF link (C4)–(C7), π = [I, F, G].

    ``initial_estimate`` π̂(0) [kg·m², N·m·s/rad, N·m] (seed: [0.2, 0.1, 0]); ``kd`` K_D
    [N·m·s/rad]; ``lam`` Λ [1/s]; ``gamma`` Γ (3, 3) or (3,) diagonal, the adaptation gain.
    ``model`` only names the joint (the law needs no other model: it learns π).

    Signals: ``q_des``, ``q_err``, ``sigma`` [rad/s], ``Y`` (q̈_r, q̇_r, sin q) so that
    Y (π̂ − π) can be formed afterwards for any assumed true π (:func:`parameter_mismatch`).
    """

    model: Robot
    reference: JointReference
    kd: float
    lam: float
    gamma: np.ndarray
    initial_estimate: np.ndarray = (0.2, 0.1, 0.0)
    law = slotine_li_1dof_law

    def __post_init__(self):
        if self.model.n != 1:
            raise ProtocolError(f"model: SlotineLi1DoF needs a 1-joint robot, got {self.model.n}")
        _check_reference(self.reference, 1)
        object.__setattr__(self, "gamma", gain_matrix(self.gamma, 3, "gamma", positive_definite=True))
        estimate = np.asarray(self.initial_estimate, dtype=float)
        if estimate.shape != (3,):
            raise ControllerSpecError("initial_estimate: expected 3 numbers [I, F, G]")
        object.__setattr__(self, "initial_estimate", estimate)
        for name in ("kd", "lam"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.size != 1 or not np.isfinite(value).all() or float(value.reshape(-1)[0]) <= 0:
                raise ControllerSpecError(f"{name}: must be one positive number, got {getattr(self, name)!r}")
            object.__setattr__(self, name, float(value.reshape(-1)[0]))

    def params(self):
        return SlotineLi1DoFParams(
            reference=np.array(self.reference.data), kd=np.array([float(self.kd)]),
            lam=np.array([float(self.lam)]), gamma=self.gamma,
            q_des=np.zeros(1), qd_des=np.zeros(1), qdd_des=np.zeros(1), Y=np.zeros(3))

    def initial_state(self):
        return self.initial_estimate.copy()

    def state_labels(self):
        return ("I_hat", "F_hat", "G_hat")

    def state_units(self):
        return ("kg·m²", "N·m·s/rad", "N·m")

    def signals(self):
        return (Signal.joint("q_des", self.model, "position"), Signal.joint("q_err", self.model, "error"),
                Signal("sigma", (self.model.joint_names[0],), ("rad/s",)),
                Signal("Y", ("qdd_r", "qd_r", "sin_q"), ("rad/s²", "rad/s", "1")))


def link1_parameters(robot: Robot) -> np.ndarray:
    """π = [I, F, G] of a 1-joint revolute robot (I q̈ + F q̇ + G sin q = τ) from its inertial:
    I about the axis, F the viscous friction, G = ∂g/∂(sin q) (checked: g(q) = G sin q)."""
    from armlab.kernels.dynamics import gravity_into, mass_matrix_into

    arrays = robot.arrays
    ws = make_workspace(1)
    B = np.zeros((1, 1))
    mass_matrix_into(arrays, ws, np.zeros(1), B)
    g = np.zeros(1)
    gravity_into(arrays, ws, np.array([np.pi / 2]), g)
    return np.array([B[0, 0], arrays.viscous[0], g[0]])


def parameter_mismatch(result, true_parameters) -> np.ndarray:
    """Y (π̂ − π) (N,) [N·m] of a :class:`SlotineLi1DoF` run, the seed's A8 plot."""
    return np.sum(result.signals["Y"] * (result.z - np.asarray(true_parameters, dtype=float)), axis=1)


# --------------------------------------------------------------------------- n-DoF

@kernel
def _set_link(ms, i, pi):
    """Give link i of the scratch robot the standard parameters pi (10,) (see module docstring)."""
    mass = pi[0]
    ms.mass[i] = mass
    cx, cy, cz = pi[1] / mass, pi[2] / mass, pi[3] / mass
    ms.com[i, 0], ms.com[i, 1], ms.com[i, 2] = cx, cy, cz
    I = ms.inertia[i]
    I[0, 0], I[0, 1], I[0, 2] = pi[4], pi[5], pi[6]
    I[1, 0], I[1, 1], I[1, 2] = pi[5], pi[7], pi[8]
    I[2, 0], I[2, 1], I[2, 2] = pi[6], pi[8], pi[9]
    # I_C = I_O − m (cᵀc 1 − c cᵀ)  (Steiner)
    c = (cx, cy, cz)
    cc = cx * cx + cy * cy + cz * cz
    for r in range(3):
        for k in range(3):
            I[r, k] += mass * c[r] * c[k]
        I[r, r] -= mass * cc


@kernel
def _polarised(ms, ws, q, qd, qd_r, qdd_r, u, a, zero6, t1, t2, out):
    """B q̈_r + C(q, q̇) q̇_r + g of robot ms by (C8)."""
    n = q.shape[0]
    for k in range(n):
        u[k] = qd[k] + qd_r[k]
        a[k] = 2.0 * qdd_r[k]
    rnea_into(ms, ws, q, u, a, 2.0, zero6, t1)
    for k in range(n):
        u[k] = qd[k] - qd_r[k]
        a[k] = -2.0 * qdd_r[k]
    rnea_into(ms, ws, q, u, a, -2.0, zero6, t2)
    for k in range(n):
        out[k] = 0.25 * (t1[k] - t2[k])


@kernel
def regressor_into(ms, ws, q, qd, qd_r, qdd_r, work, Y_out):
    """Y(q, q̇, q̇_r, q̈_r) (n, 11n) with Y π = B q̈_r + C q̇_r + F_v q̇_r + g (C5), built by (C8).

    ``ms`` is a scratch RobotArrays (writeable, friction and rotors zero) whose inertial
    parameters are overwritten; ``work`` (8, max(n, 10)) scratch rows: u, a, t1, t2, base, col,
    π (10 entries) and a zero wrench (6 entries, stays 0)."""
    n = q.shape[0]
    u, a, t1, t2, base, col, pi = work[0], work[1], work[2], work[3], work[4], work[5], work[6]
    zero6 = work[7][:6]
    for i in range(n):
        ms.mass[i] = 0.0
        for r in range(3):
            ms.com[i, r] = 0.0
            for k in range(3):
                ms.inertia[i, r, k] = 0.0
    for i in range(n):
        for k in range(10):
            pi[k] = 0.0
        pi[0] = 1.0
        _set_link(ms, i, pi)
        _polarised(ms, ws, q, qd, qd_r, qdd_r, u, a, zero6, t1, t2, base)
        for k in range(10):
            pi[k] += 1.0
            _set_link(ms, i, pi)
            _polarised(ms, ws, q, qd, qd_r, qdd_r, u, a, zero6, t1, t2, col)
            for r in range(n):
                Y_out[r, 11 * i + k] = col[r] - base[r]
            pi[k] -= 1.0
        for r in range(n):
            Y_out[r, 11 * i + 10] = qd_r[i] if r == i else 0.0
        ms.mass[i] = 0.0
        for r in range(3):
            ms.com[i, r] = 0.0
            for k in range(3):
                ms.inertia[i, r, k] = 0.0


class SlotineLiParams(NamedTuple):
    """The ``params`` of :func:`slotine_li_law` (C4), (C5), (C8) for n joints; from ``q_des``
    on, scratch."""

    scratch_model: RobotArrays      # model copy without friction or rotors; inertials overwritten
    workspace: DynamicsWorkspace    # scratch of ``rnea_into``
    reference: np.ndarray           # a writeable copy of ``JointReference.data``
    kd: np.ndarray                  # (n, n) K_D [N·s/m | N·m·s/rad]
    lam: np.ndarray                 # (n, n) Λ [1/s]
    gamma: np.ndarray               # (11n, 11n) Γ of dπ̂/dt = Γ Yᵀσ [π_i π_j / J]
    q_des: np.ndarray               # (n,) q_des(t) [m | rad]
    qd_des: np.ndarray              # (n,) q̇_des(t) [m/s | rad/s]
    qdd_des: np.ndarray             # (n,) q̈_des(t) [m/s² | rad/s²]
    qd_r: np.ndarray                # (n,) q̇_r [m/s | rad/s]
    qdd_r: np.ndarray               # (n,) q̈_r [m/s² | rad/s²]
    sigma: np.ndarray               # (n,) σ = q̇_r − q̇ [m/s | rad/s]
    work: np.ndarray                # (8, max(n, 10)) scratch rows of ``regressor_into``
    Y: np.ndarray                   # (n, 11n) the regressor Y(q, q̇, q̇_r, q̈_r)


@kernel
def slotine_li_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    """(C4), (C5) with the numeric regressor (C8); z = π̂ (11n,); ``params`` a
    :class:`SlotineLiParams`."""
    ms, ws, work, Y = params.scratch_model, params.workspace, params.work, params.Y
    ref, kd, lam, gamma = params.reference, params.kd, params.lam, params.gamma
    q_des, qd_des, qdd_des = params.q_des, params.qd_des, params.qdd_des
    qd_r, qdd_r, sigma = params.qd_r, params.qdd_r, params.sigma
    n = q.shape[0]
    reference_into(ref, t, q_des, qd_des, qdd_des)
    for i in range(n):
        qd_r[i] = qd_des[i]
        qdd_r[i] = qdd_des[i]
        for j in range(n):
            qd_r[i] += lam[i, j] * (q_des[j] - q[j])
            qdd_r[i] += lam[i, j] * (qd_des[j] - qd[j])
        sigma[i] = qd_r[i] - qd[i]
    regressor_into(ms, ws, q, qd, qd_r, qdd_r, work, Y)
    p = z.shape[0]
    for i in range(n):
        acc = 0.0
        for k in range(p):
            acc += Y[i, k] * z[k]
        for j in range(n):
            acc += kd[i, j] * sigma[j]
        tau_out[i] = acc
    for k in range(p):
        acc = 0.0
        for r in range(p):
            ys = 0.0
            for i in range(n):
                ys += Y[i, r] * sigma[i]
            acc += gamma[k, r] * ys
        zdot_out[k] = acc
    for i in range(n):
        signals_out[i] = q_des[i]
        signals_out[n + i] = q_des[i] - q[i]
        signals_out[2 * n + i] = sigma[i]


def standard_parameters(robot: Robot) -> np.ndarray:
    """π (11n,) of ``robot``: per link [m, m c, I_O entries, F_v] in its joint frame (C8)."""
    arrays = robot.arrays
    out = []
    for i in range(robot.n):
        mass, c = arrays.mass[i], arrays.com[i]
        I_O = arrays.inertia[i] + mass * (c @ c * np.eye(3) - np.outer(c, c))
        out += [mass, *(mass * c), I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2],
                arrays.viscous[i]]
    return np.array(out)


@scenario_type("slotine_li")
@dataclass(frozen=True, eq=False)
class SlotineLi(Controller):
    """Slotine–Li adaptive control (C4)–(C6) for any serial robot, regressor (C8).

    π̂(0) = the standard parameters of ``model`` (the controller's belief), ``kd`` K_D,
    ``lam`` Λ (n, n) [1/s], ``gamma`` Γ (11n, 11n) or (11n,) diagonal.  Signals ``q_des``,
    ``q_err``, ``sigma``.  The model must have no motor rotor inertia or Coulomb friction.
    """

    model: Robot
    reference: JointReference
    kd: np.ndarray
    lam: np.ndarray
    gamma: np.ndarray
    law = slotine_li_law

    def __post_init__(self):
        n = self.model.n
        _check_reference(self.reference, n)
        arrays = self.model.arrays
        if np.any(arrays.rotor_inertia != 0) or np.any(arrays.coulomb != 0):
            raise ProtocolError("model: SlotineLi does not estimate rotor inertia or Coulomb friction")
        object.__setattr__(self, "kd", gain_matrix(self.kd, n, "kd"))
        object.__setattr__(self, "lam", gain_matrix(self.lam, n, "lam", positive_definite=True))
        object.__setattr__(self, "gamma", gain_matrix(self.gamma, 11 * n, "gamma", positive_definite=True))

    def params(self):
        n = self.n
        base = self.model.arrays
        zero = np.zeros(n)
        scratch = RobotArrays(*[np.array(a, copy=True) for a in base])._replace(
            viscous=zero.copy(), coulomb=zero.copy(), rotor_inertia=zero.copy())
        return SlotineLiParams(
            scratch_model=scratch, workspace=make_workspace(n), reference=np.array(self.reference.data),
            kd=self.kd, lam=self.lam, gamma=self.gamma,
            q_des=np.zeros(n), qd_des=np.zeros(n), qdd_des=np.zeros(n),
            qd_r=np.zeros(n), qdd_r=np.zeros(n), sigma=np.zeros(n),
            work=np.zeros((8, max(n, 10))), Y=np.zeros((n, 11 * n)))

    def initial_state(self):
        return standard_parameters(self.model)

    def state_labels(self):
        return tuple(f"{name}_{link.name}" for link in self.model.links for name in PARAMETER_NAMES)

    def signals(self):
        return (Signal.joint("q_des", self.model, "position"), Signal.joint("q_err", self.model, "error"),
                Signal.joint("sigma", self.model, "velocity"))
