"""What every inverse-kinematics method shares: the target in Σ_0, residuals by forward
kinematics, revolute angles wrapped near a reference, joint-limit checks and distinct branches."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.errors import UnreachableTargetError
from armlab.kernels.kinematics import end_effector_into, joint_frames_into, kinematics_workspace
from armlab.model.robot import REVOLUTE, Robot
from armlab.spatial import euler_matrix, rotation_error

STRUCTURE_TOL = 1e-9
"""How exactly axes must be parallel, perpendicular or meet for a closed form to apply."""


@dataclass(frozen=True)
class Target:
    """The target in Σ_0: position p (3,) [m] and, for a full pose, R (3, 3)."""

    p: np.ndarray
    R: np.ndarray | None
    text: str


def parse_target(robot: Robot, target, frame: str, euler: str) -> Target:
    """Position (3,), pose vector [p; φ] (6,) in ``euler`` angles, or pose (4, 4), in ``frame``."""
    if frame not in ("base", "0"):
        raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
    array = np.asarray(target, dtype=float)
    if not np.all(np.isfinite(array)):
        raise ValueError("target: must be finite")
    if array.shape == (3,):
        p, R = array, None
    elif array.shape == (6,):
        p, R = array[:3], euler_matrix(array[3:], euler)
    elif array.shape == (4, 4):
        p, R = array[:3, 3], array[:3, :3]
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-8) or np.linalg.det(R) < 0:
            raise ValueError("target: the (4, 4) pose's rotation block is not a rotation matrix")
    else:
        raise ValueError(f"target: must be a position (3,), a pose vector [p; φ] (6,) or a pose "
                         f"(4, 4), got shape {array.shape}")
    where = "Σ_base" if frame == "base" else "Σ_0"
    text = f"position {np.round(p, 6).tolist()} m in {where}" + ("" if R is None else " with orientation")
    if frame == "base":
        R_b0, p_b0 = robot.base[:3, :3], robot.base[:3, 3]
        p = R_b0.T @ (p - p_b0)
        R = None if R is None else R_b0.T @ R
    return Target(p=np.array(p), R=None if R is None else np.ascontiguousarray(R), text=text)


def residual_norms(robot: Robot, q: np.ndarray, target: Target) -> tuple[float, float]:
    ws = kinematics_workspace(robot.n)
    joint_frames_into(robot.arrays, q, ws.R, ws.p)
    end_effector_into(robot.arrays, ws.R[-1], ws.p[-1], ws.R_e, ws.p_e)
    e_p = float(np.linalg.norm(target.p - ws.p_e))
    e_o = 0.0 if target.R is None else float(np.linalg.norm(rotation_error(target.R, ws.R_e)))
    return e_p, e_o


# ------------------------------------------------------------------------- joint limits


def joint_limits(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    return robot.arrays.q_min, robot.arrays.q_max


def wrap_revolute(robot: Robot, q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Each revolute angle shifted by 2πk: inside its limits if possible, nearest the reference."""
    q = q.copy()
    q_min, q_max = joint_limits(robot)
    two_pi = 2 * np.pi
    for i, kind in enumerate(robot.arrays.joint_type):
        if kind != REVOLUTE:
            continue
        nearest = q[i] + two_pi * np.round((reference[i] - q[i]) / two_pi)
        if q_min[i] <= nearest <= q_max[i]:
            q[i] = nearest
            continue
        # the turns that fit inside the (finite) limits, if any
        k_lo = np.ceil((q_min[i] - q[i]) / two_pi) if np.isfinite(q_min[i]) else -np.inf
        k_hi = np.floor((q_max[i] - q[i]) / two_pi) if np.isfinite(q_max[i]) else np.inf
        if k_lo > k_hi:
            q[i] = nearest
            continue
        k_ref = np.round((reference[i] - q[i]) / two_pi)
        q[i] += two_pi * min(max(k_ref, k_lo), k_hi)
    return q


def distance(robot: Robot, q: np.ndarray, reference: np.ndarray) -> float:
    """|q − reference| with revolute differences taken on the circle (−π, π]."""
    diff = q - reference
    revolute = robot.arrays.joint_type == REVOLUTE
    diff[revolute] = np.angle(np.exp(1j * diff[revolute]))
    return float(np.linalg.norm(diff))


def limit_violations(robot: Robot, q: np.ndarray, tol: float = 1e-12) -> list[str]:
    q_min, q_max = joint_limits(robot)
    out = []
    for i, joint in enumerate(robot.joints):
        if q[i] < q_min[i] - tol or q[i] > q_max[i] + tol:
            unit = "m" if joint.kind == "prismatic" else "rad"
            out.append(f"{joint.name} = {q[i]:.6g} {unit} outside [{q_min[i]:g}, {q_max[i]:g}]")
    return out


# --------------------------------------------------------------------- closed form (K7)


def apply_limits(robot, solutions, target, respect_limits):
    if not respect_limits:
        return solutions
    inside = [q for q in solutions if not limit_violations(robot, q)]
    if inside:
        return inside
    details = "; ".join(f"solution {k + 1} needs " + ", ".join(limit_violations(robot, q))
                        for k, q in enumerate(solutions))
    raise UnreachableTargetError(
        f"target {target.text} is reachable by {robot.name!r} only outside its joint limits: {details}",
        reason="joint limits", best_q=solutions[0], position_error=0.0, orientation_error=0.0)


SAME_BRANCH = 1e-6
"""|Δq| below which two solutions are one (revolute differences on the circle)."""

NEAR_BRANCH = 0.25
"""|Δq| [rad, m] below which two solutions are one branch when the arm between them stays on
target (on a continuum of solutions at a singularity, or along an almost flat valley)."""


def same_branch(robot, a, b, target=None, tol: float = 1e-9) -> bool:
    """Whether ``a`` and ``b`` are one solution branch: closer than :data:`SAME_BRANCH`, or,
    given the ``target``, closer than :data:`NEAR_BRANCH` with the configurations ¼, ½ and ¾
    of the way between them also within 10 ``tol`` of it.  Near a singularity a solver stops
    anywhere along an almost flat valley (UR5 at q5 = 10⁻⁴: converged starts 2–6·10⁻⁶ rad
    apart), at it on a continuum (q4 + q6 fixed); two true branches have a ridge between
    them, where the residual grows as |Δq|² (10⁻⁹ already at |Δq| ≈ 10⁻⁴ on a 1 m arm)."""
    d = distance(robot, a, b)
    if d <= SAME_BRANCH:
        return True
    if target is None or d > NEAR_BRANCH:
        return False
    diff = b - a
    revolute = robot.arrays.joint_type == REVOLUTE
    diff[revolute] = np.angle(np.exp(1j * diff[revolute]))
    limit = 10 * max(tol, 1e-9)
    return all(max(residual_norms(robot, a + f * diff, target)) <= limit for f in (0.5, 0.25, 0.75))


def distinct(robot, solutions, reference, target=None, tol: float = 1e-9):
    """The solutions wrapped (2π turns) and without repeats (:func:`same_branch`), nearest
    ``reference`` first."""
    out = []
    for q in sorted((wrap_revolute(robot, q, reference) for q in solutions),
                    key=lambda q: distance(robot, q, reference)):
        if not any(same_branch(robot, q, other, target, tol) for other in out):
            out.append(q)
    return out


def axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: rotation by ``angle`` about the unit ``axis``."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K
