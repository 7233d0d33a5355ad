"""Operational-space dynamics (seed A5; Siciliano et al. §7.8, Khatib 1987).

For the task coordinates x_T = S x, a selection S of k rows of the pose x = [p_e; φ_e] (K5),
with Jacobian J = S J_A (k, n) and k ≤ n, the joint dynamics (D1) seen in task space read

    Λ(q) ẍ_T + μ(q, q̇) + p(q) = F,        τ = Jᵀ F (+ torques in the null space of J̄ᵀ)    (D8)

    Λ = (J B⁻¹ Jᵀ)⁻¹,   J̄ = B⁻¹ Jᵀ Λ,   μ = J̄ᵀ C q̇ − Λ J̇ q̇,   p = J̄ᵀ g                 (D9)

For a square, non-singular J (k = n) J̄ = J⁻¹ and these are the seed's A5 quantities
B_A = J_A⁻ᵀ B J_A⁻¹, C_A ẋ = J_A⁻ᵀ C q̇ − B_A J̇_A q̇, g_A = J_A⁻ᵀ g.  For k < n (a redundant
task) J̄ is the dynamically consistent generalised inverse.  Friction and h_e are left in the
joint space (add J̄ᵀ(F_v q̇ + F_s sgn q̇) to μ if wanted).

**n < 6.** A robot with fewer than six joints cannot impose all six pose coordinates: pass the
``rows`` it controls (the PRP: ``rows=(0, 1, 2)``, the position of Σ_e).  Rows 0–2 use the
geometric (positional) Jacobian, so position tasks never meet an Euler-angle singularity.

**Near singularities** of J (σ_min below ``threshold``) Λ⁻¹ = J B⁻¹ Jᵀ loses rank and is
inverted with a variable damping (Chiaverini's damped least squares):

    Λ = (J B⁻¹ Jᵀ + λ² I)⁻¹,   λ² = δ² ‖J B⁻¹ Jᵀ‖₂ (1 − (σ_min/threshold)²)  if σ_min < threshold    (D10)

with the relative damping δ = ``damping``; the result reports σ_min (the distance to the
singularity) and λ².  Every inverse above is a Cholesky or least-squares solve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from armlab.dynamics import coriolis_matrix, gravity_torque, inertia_matrix
from armlab.errors import TaskSelectionError
from armlab.kinematics import analytic_jacobian, geometric_jacobian, jacobian_dot_qd
from armlab.model.robot import Robot


@dataclass(frozen=True)
class OperationalSpaceDynamics:
    """Task-space dynamics (D8)–(D10) at one state; k = len(rows).

    ``inertia`` Λ = B_A (k, k); ``bias`` μ = C_A ẋ (k,); ``gravity`` p = g_A (k,);
    ``jacobian`` J (k, n) and ``jacobian_dot_qd`` J̇ q̇ (k,) of the task rows;
    ``dynamic_inverse`` J̄ (n, k); ``rows`` the selected rows of x = [p_e; φ_e];
    ``sigma_min`` the smallest singular value of J; ``lambda2`` the λ² of (D10) actually used (0 when exact).
    Units follow x: [kg] and [N] on position rows, [kg·m²] and [N·m] on Euler-angle rows.
    """

    inertia: np.ndarray
    bias: np.ndarray
    gravity: np.ndarray
    jacobian: np.ndarray
    jacobian_dot_qd: np.ndarray
    dynamic_inverse: np.ndarray
    rows: tuple[int, ...]
    sigma_min: float
    lambda2: float

    @property
    def damped(self) -> bool:
        """True when (D10) damped the inversion (σ_min below the threshold)."""
        return self.lambda2 > 0.0


def _rows(robot: Robot, rows) -> tuple[int, ...]:
    if rows is None:
        if robot.n < 6:
            raise TaskSelectionError(
                f"rows: robot {robot.name!r} has {robot.n} joints and cannot control all 6 pose "
                "coordinates; choose at most that many rows of x = [p; φ], e.g. rows=(0, 1, 2)")
        return tuple(range(6))
    selected = tuple(int(r) for r in rows)
    if not selected or len(set(selected)) != len(selected) or not all(0 <= r < 6 for r in selected):
        raise TaskSelectionError(f"rows: need distinct indices of x = [p; φ] in 0…5, got {rows!r}")
    if len(selected) > robot.n:
        raise TaskSelectionError(f"rows: {len(selected)} task rows exceed the {robot.n} joints of "
                                 f"robot {robot.name!r}")
    return selected


def operational_space_dynamics(robot: Robot, q, qd, rows=None, euler: str = "zyz",
                               frame: str = "base", branch=1, threshold: float = 1e-2,
                               damping: float = 0.1) -> OperationalSpaceDynamics:
    """Λ, μ, p of (D8)–(D9) for the task rows ``rows`` of x = [p_e; φ_e] in ``frame``.

    Parameters
    ----------
    q, qd : (n,) joint positions and velocities [m | rad, /s].
    rows : indices into x = [p_e; φ_e] (0–2 position [m], 3–5 Euler angles [rad]); None means
        all six (needs n ≥ 6).  At most n rows.
    euler, branch : the Euler convention (``"zyz"`` | ``"rpy"``) and branch of φ_e (K5); only
        used when an angle row is selected.  A representation singularity raises
        :class:`~armlab.spatial.RepresentationSingularityError`.
    frame : ``"base"`` or ``"0"``, the frame of x.
    threshold : σ_min of J below which (D10) damps the inversion.
    damping : relative damping δ of (D10).
    """
    selected = _rows(robot, rows)
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qd, dtype=float)
    if all(r < 3 for r in selected):
        J_full = geometric_jacobian(robot, q, frame=frame)
        Jdqd_full = jacobian_dot_qd(robot, q, qd, frame=frame)
    else:
        J_full = analytic_jacobian(robot, q, euler=euler, frame=frame, branch=branch)
        Jdqd_full = jacobian_dot_qd(robot, q, qd, frame=frame, euler=euler, branch=branch)
    index = list(selected)
    J = J_full[index]
    Jdqd = Jdqd_full[index]
    B_factor = cho_factor(inertia_matrix(robot, q))
    B_inv_JT = cho_solve(B_factor, J.T)                        # B⁻¹ Jᵀ, (n, k)
    Lambda_inv = J @ B_inv_JT
    Lambda_inv = 0.5 * (Lambda_inv + Lambda_inv.T)
    sigma_min = float(np.linalg.svd(J, compute_uv=False).min())
    lam2 = 0.0
    if sigma_min < threshold:
        scale = float(np.linalg.eigvalsh(Lambda_inv).max())
        lam2 = damping ** 2 * scale * (1.0 - (sigma_min / threshold) ** 2)
    k = len(selected)
    Lambda = cho_solve(cho_factor(Lambda_inv + lam2 * np.eye(k)), np.eye(k))
    Lambda = 0.5 * (Lambda + Lambda.T)
    J_bar = B_inv_JT @ Lambda                                  # (n, k)
    bias = J_bar.T @ (coriolis_matrix(robot, q, qd) @ qd) - Lambda @ Jdqd
    gravity = J_bar.T @ gravity_torque(robot, q)
    return OperationalSpaceDynamics(inertia=Lambda, bias=bias, gravity=gravity, jacobian=J,
                                    jacobian_dot_qd=Jdqd, dynamic_inverse=J_bar, rows=selected,
                                    sigma_min=sigma_min, lambda2=lam2)
