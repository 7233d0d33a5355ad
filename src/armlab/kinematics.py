"""Forward kinematics and Jacobians (public API over the compiled kernels).

Frames and conventions: ``docs/notation.md``.  ``frame="0"`` expresses results in Σ_0 (the
frame of the first joint's DH row), ``frame="base"`` in Σ_base = T_base0 · Σ_0.  The analytic
quantities use the Euler angles φ of R_e in that same frame (``euler="zyz"`` or ``"rpy"``,
``branch`` +1, −1 or a reference angle triple, see :func:`armlab.spatial.euler_from_matrix`).
Inverse kinematics lives in :mod:`armlab.inverse_kinematics`.
"""

from __future__ import annotations

import numpy as np

from armlab.kernels.kinematics import (
    analytic_jacobian_dot_qd_kernel,
    analytic_jacobian_kernel,
    end_effector_into,
    forward_kinematics_kernel,
    jacobian_dot_qd_kernel,
    jacobian_kernel,
    joint_frames_into,
    kinematics_workspace,
    pose_vector_into,
)
from armlab.model.robot import Robot
from armlab.spatial import (
    RepresentationSingularityError,
    _singularity_message,
    branch_arguments,
    euler_code,
)

FRAMES = ("base", "0")


def _check_q(robot: Robot, q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape != (robot.n,):
        raise ValueError(f"q must have shape ({robot.n},) for robot {robot.name!r}, got {q.shape}")
    return q


def _check_frame(frame: str) -> str:
    if frame not in FRAMES:
        raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
    return frame


def forward_kinematics(robot: Robot, q, frame: str = "base") -> np.ndarray:
    """Pose of the end effector Σ_e, (4, 4): T_base,e (``frame="base"``) or T_0e (``"0"``)."""
    q = _check_q(robot, q)
    T = np.empty((4, 4))
    forward_kinematics_kernel(robot.arrays, q, T)
    return robot.base @ T if _check_frame(frame) == "base" else T


def link_frames(robot: Robot, q, frame: str = "base") -> np.ndarray:
    """Frames Σ_0, Σ_1, …, Σ_n, Σ_e as an (n + 2, 4, 4) array, in Σ_base or Σ_0.

    Σ_i is the link frame of the robot description (the DH frame i for DH robots).
    """
    q = _check_q(robot, q)
    m = robot.arrays
    n = robot.n
    R = np.empty((n, 3, 3))
    p = np.empty((n, 3))
    joint_frames_into(m, q, R, p)
    frames = np.empty((n + 2, 4, 4))
    frames[0] = np.eye(4)
    for i, joint in enumerate(robot.joints):
        J = np.eye(4)
        J[:3, :3], J[:3, 3] = R[i], p[i]
        frames[i + 1] = J @ joint.after
    R_e, p_e = np.empty((3, 3)), np.empty(3)
    end_effector_into(m, R[-1], p[-1], R_e, p_e)
    frames[-1] = np.eye(4)
    frames[-1][:3, :3], frames[-1][:3, 3] = R_e, p_e
    if _check_frame(frame) == "base":
        frames = robot.base @ frames
    return frames


def geometric_jacobian(robot: Robot, q, frame: str = "base") -> np.ndarray:
    """Geometric Jacobian J = [J_P; J_O], (6, n), of Σ_e's origin, expressed in ``frame``.

        [ṗ_e; ω_e] = J(q) q̇                               (Siciliano (3.56))
    """
    q = _check_q(robot, q)
    J = np.empty((6, robot.n))
    jacobian_kernel(robot.arrays, q, J)
    if _check_frame(frame) == "base":
        R = robot.base[:3, :3]
        J = np.vstack((R @ J[:3], R @ J[3:]))
    return J


def _check_qd(robot: Robot, qd) -> np.ndarray:
    qd = np.asarray(qd, dtype=float)
    if qd.shape != (robot.n,):
        raise ValueError(f"qd must have shape ({robot.n},) for robot {robot.name!r}, got {qd.shape}")
    return qd


def pose_vector(robot: Robot, q, euler: str = "zyz", frame: str = "base", branch=1) -> np.ndarray:
    """Operational-space pose x = [p_e; φ_e], (6,) [m, rad], of Σ_e in ``frame`` (K5).

    φ_e are the ``euler`` angles of R_e (``"zyz"``: R = Rz(φ)Ry(ϑ)Rz(ψ), ``"rpy"``:
    R = Rz(φ)Ry(ϑ)Rx(ψ)); ``branch`` is +1 (ZYZ ϑ ∈ [0, π], RPY |ϑ| ≤ π/2), −1 (the other
    solution) or a reference triple (3,) [rad] whose nearest equivalent is returned.

    Example: the PRP at q = (0.1, 0, 0) in Σ_0 with ZYZ and ``branch=-1`` gives the seed's
    x0 = [0, −0.2, 0.5, π/2, −π/2, 0]; on that branch φ = θ2 + π/2, ϑ = −π/2, ψ = 0.
    """
    q = _check_q(robot, q)
    code = euler_code(euler)
    branch_code, reference = branch_arguments(branch)
    x = np.empty(6)
    pose_vector_into(robot.arrays, q, code, branch_code, reference, _check_frame(frame) == "base",
                     kinematics_workspace(robot.n), x)
    return x


def analytic_jacobian(robot: Robot, q, euler: str = "zyz", frame: str = "base", branch=1,
                      singular_tol: float = 1e-6) -> np.ndarray:
    """Analytic Jacobian J_A = T_A(φ)⁻¹ J, (6, n), with ẋ = J_A(q) q̇ for x = [p_e; φ_e] (K4).

        T_A(φ) = blockdiag(I₃, T(φ)),  ω = T(φ) φ̇          (Siciliano (3.65)–(3.66))

    ``euler``, ``frame`` and ``branch`` as in :func:`pose_vector`; T_A itself is
    :func:`armlab.spatial.analytic_transform` at ``pose_vector(...)[3:]``.  At a
    representation singularity (|det T(φ)| = |sin ϑ| (ZYZ) or |cos ϑ| (RPY) below
    ``singular_tol``) J_A does not exist and :class:`RepresentationSingularityError` is
    raised; no damped substitute is returned.  Units: rows 1–3 [m/(m | rad)], rows 4–6
    [rad/(m | rad)].
    """
    q = _check_q(robot, q)
    code = euler_code(euler)
    branch_code, reference = branch_arguments(branch)
    ws = kinematics_workspace(robot.n)
    J_A = np.empty((6, robot.n))
    det = analytic_jacobian_kernel(robot.arrays, q, code, branch_code, reference,
                                   _check_frame(frame) == "base", ws, J_A)
    if abs(det) < singular_tol:
        raise RepresentationSingularityError(_singularity_message(ws.angles, euler, det))
    return J_A


def jacobian_dot_qd(robot: Robot, q, qd, frame: str = "base", euler: str | None = None, branch=1,
                    singular_tol: float = 1e-6) -> np.ndarray:
    """J̇(q, q̇) q̇, (6,): the end-effector acceleration at q̈ = 0 (K6).

    With ``euler=None`` the geometric one, [p̈_e; ω̇_e] = J q̈ + J̇ q̇ at q̈ = 0 [m/s², rad/s²].
    With ``euler="zyz" | "rpy"`` the analytic one, ẍ = J_A q̈ + J̇_A q̇ at q̈ = 0:

        J̇_A q̇ = T_A(φ)⁻¹ (J̇ q̇ − Ṫ_A(φ, φ̇) ẋ),   ẋ = J_A q̇

    raising :class:`RepresentationSingularityError` where T(φ) is singular (see
    :func:`analytic_jacobian`).  ``q`` (n,), ``qd`` (n,) [m/s | rad/s]; result in ``frame``.
    """
    q = _check_q(robot, q)
    qd = _check_qd(robot, qd)
    in_base = _check_frame(frame) == "base"
    ws = kinematics_workspace(robot.n)
    out = np.empty(6)
    if euler is None:
        jacobian_dot_qd_kernel(robot.arrays, q, qd, in_base, ws, out)
        return out
    code = euler_code(euler)
    branch_code, reference = branch_arguments(branch)
    det = analytic_jacobian_dot_qd_kernel(robot.arrays, q, qd, code, branch_code, reference, in_base,
                                          ws, out)
    if abs(det) < singular_tol:
        raise RepresentationSingularityError(_singularity_message(ws.angles, euler, det))
    return out
