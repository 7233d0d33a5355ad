"""Rest equilibria of interaction control laws, from the closed loop's potential energy.

At rest (q̇ = 0) the compliance law (C11) against a conservative environment leaves the joint
torque balance

    J_sᵀ(q) K_P x̃_s(q) + ĝ(q) − g(q) = Jᵀ(q) h_e(q)                                        (H6)

((H6) and (H3) are the tags of :mod:`armlab.theory`'s predictions)

where J_sᵀK_P x̃_s = −∇_q ½ x̃_sᵀK_P x̃_s (x̃ = x_d − x, ∂x̃/∂q = −J_s for a constant x_d) and
Jᵀh_e = ∇_q U_e (U_e the environment's potential: ½ x_{r,e}ᵀK x_{r,e} for the spring E2, ½ k δ²
for a pressed wall E4 at rest).  With an exact gravity model the rest points are the critical
points of

    U(q) = ½ x̃_s(q)ᵀ K_P x̃_s(q) + U_e(q),

and the stable ones its minima.  (H6) holds for any Σ_r, Σ_d and any coupling of orientation
and position the arm imposes; the closed form (H3) x_e = (K_P + K)⁻¹(K_P x_d + K x_r) is its
special case where the arm can take every pose that formula asks for (Σ_r ∥ Σ_d, a reachable
x_e).  Everything here is computed from the forward kinematics and the potentials alone
(SciPy's minimiser on finite-difference gradients), not from the compiled law, so that a run
can be checked against it.  Poses in Σ_0; XYZ angles of relative rotations as in
``docs/notation.md`` (T1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from armlab.control.gains import gain_matrix
from armlab.dynamics import gravity_torque
from armlab.kinematics import forward_kinematics
from armlab.spatial import euler_from_matrix

STEP = 1e-6   # [m | rad] central-difference step of the gradients
GRADIENT_TOLERANCE = 1e-9   # [N | N·m] largest joint residual of (H6) accepted as a rest point


@dataclass(frozen=True)
class Statics:
    """A rest point of (H6): joints ``q`` (n,), end-effector position ``p_e`` (3,) [m] in Σ_0,
    the force ``f_e`` (3,) [N] the end effector exerts on the environment (Σ_0) and the largest
    joint residual of (H6) ``residual`` [N | N·m] at ``q``."""

    q: np.ndarray
    p_e: np.ndarray
    f_e: np.ndarray
    residual: float


def _xyz(R: np.ndarray) -> np.ndarray:
    """XYZ angles φ of R = Rx(φ₁) Ry(φ₂) Rz(φ₃) (intrinsic; SciPy's "XYZ")."""
    return Rotation.from_matrix(R).as_euler("XYZ")


def controller_error(controller, T_0e: np.ndarray) -> np.ndarray:
    """x̃ (6,) of a task-space controller with a constant reference at the pose T_0e (4, 4):
    ``frame="desired"`` −[R_dᵀ(p_e − p_d); φ_XYZ(R_dᵀR_e)], ``"base"`` [p_d − p_e; φ_d − φ_e]
    with the controller's Euler angles taken nearest to φ_d."""
    R_d, p_d = controller.reference.rotations[-1], controller.reference.positions[-1]
    R_e, p_e = T_0e[:3, :3], T_0e[:3, 3]
    if controller.frame == "desired":
        return -np.concatenate([R_d.T @ (p_e - p_d), _xyz(R_d.T @ R_e)])
    reference = (euler_from_matrix(R_d, controller.euler) if controller.angle_reference is None
                 else np.asarray(controller.angle_reference, dtype=float))
    phi_d = euler_from_matrix(R_d, controller.euler, branch=reference)
    phi_e = euler_from_matrix(R_e, controller.euler, branch=phi_d)
    return np.concatenate([p_d - p_e, phi_d - phi_e])


def environment_energy(environment, T_0e: np.ndarray) -> float:
    """U_e [J] at the pose T_0e: the spring's ½ x_{r,e}ᵀK x_{r,e} (E2), the wall's ½ k δ² while
    it is pressed (E4 at rest, δ = nᵀ(p_w − p_e)), 0 in free space."""
    from armlab.simulation.environment import PlanarWall, Spring

    R_e, p_e = T_0e[:3, :3], T_0e[:3, 3]
    if isinstance(environment, Spring):
        R_r = environment.rest_rotation
        x = np.concatenate([R_r.T @ (p_e - environment.rest_position), _xyz(R_r.T @ R_e)])
        return 0.5 * float(x @ environment.stiffness @ x)
    if isinstance(environment, PlanarWall):
        depth = float(environment.normal @ (environment.point - p_e))
        return 0.5 * environment.stiffness * depth**2 if depth > 0.0 else 0.0
    return 0.0


def environment_force(environment, T_0e: np.ndarray) -> np.ndarray:
    """f_e (3,) [N] in Σ_0 at rest: ∂U_e/∂p_e at fixed orientation, i.e. R_r (K x_{r,e})_{1:3}
    for the spring, −k δ n for a pressed wall."""
    from armlab.simulation.environment import PlanarWall, Spring

    R_e, p_e = T_0e[:3, :3], T_0e[:3, 3]
    if isinstance(environment, Spring):
        R_r = environment.rest_rotation
        x = np.concatenate([R_r.T @ (p_e - environment.rest_position), _xyz(R_r.T @ R_e)])
        return R_r @ (environment.stiffness @ x)[:3]
    if isinstance(environment, PlanarWall):
        depth = float(environment.normal @ (environment.point - p_e))
        return -environment.stiffness * depth * environment.normal if depth > 0.0 else np.zeros(3)
    return np.zeros(3)


def compliance_statics(plant, controller, environment, q0) -> Statics:
    """The rest point of (H6) that the descent of U from ``q0`` (n,) reaches, for a
    :class:`~armlab.control.interaction.ComplianceControl` ``controller`` (a constant
    reference) on ``plant`` against ``environment``.

    U is minimised (BFGS), then the joint residual of (H6) — with the gravity mismatch
    ĝ − g of the controller's model, zero for an exact one — is driven to zero by a root
    solve from there.  Raises ArithmeticError when no rest point is found.
    """
    from scipy.optimize import minimize, root

    task = list(controller.task)
    kp = gain_matrix(controller.kp, 6, "kp", components=task)

    def energy(q):
        T = forward_kinematics(plant, q, frame="0")
        e = controller_error(controller, T)[task]
        return 0.5 * float(e @ kp @ e) + environment_energy(environment, T)

    def gradient(q):
        columns = np.empty(q.size)
        for j in range(q.size):
            dq = np.zeros(q.size)
            dq[j] = STEP
            columns[j] = (energy(q + dq) - energy(q - dq)) / (2.0 * STEP)
        return columns

    def residual(q):
        # −∇U is the net torque of the law and the environment; ĝ − g adds what gravity leaves.
        return -gradient(q) + gravity_torque(controller.model, q) - gravity_torque(plant, q)

    q0 = np.asarray(q0, dtype=float)
    descent = minimize(energy, q0, jac=gradient, method="BFGS", options={"gtol": 1e-10, "maxiter": 2000})
    solution = root(residual, descent.x, tol=1e-13)
    q = solution.x if np.all(np.isfinite(solution.x)) else descent.x
    worst = float(np.abs(residual(q)).max())
    if worst > GRADIENT_TOLERANCE * max(1.0, float(np.abs(kp).max())):
        raise ArithmeticError(f"no rest point of (H6) found from q0 (residual {worst:.3g})")
    T = forward_kinematics(plant, q, frame="0")
    return Statics(q=q, p_e=T[:3, 3].copy(), f_e=environment_force(environment, T), residual=worst)
