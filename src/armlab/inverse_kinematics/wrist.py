"""Closed-form inverse kinematics of a 6R arm with a spherical wrist (K9), up to 8 branches.

For an arm whose axes 1 and 2 meet in a point s and whose axes 4, 5, 6 meet in the wrist
centre w: Pieper's decoupling solved with the Paden–Kahan subproblems in the product of
exponentials FK(q) = exp(ξ₁q₁)…exp(ξ₆q₆) T_e(0), screws read off the joint frames at q = 0.
|w(q) − s| depends on q3 alone (subproblem 3, ≤ 2 roots), q1, q2 place w (subproblem 2, ≤ 2
pairs), the wrist's rotation gives q4, q5 (subproblem 2) and q6 (subproblem 1): up to 8
solutions for a full pose, each checked by forward kinematics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.inverse_kinematics.common import (
    STRUCTURE_TOL,
    apply_limits,
    axis_rotation,
    distinct,
)
from armlab.inverse_kinematics.dls import verified
from armlab.kernels.kinematics import end_effector_into, joint_frames_into, kinematics_workspace
from armlab.model.robot import Robot


@dataclass(frozen=True)
class SphericalWrist6R:
    """Screw axes of a 6R arm at q = 0 in Σ_0 (ω_i unit axis, r_i a point on it), the point s
    where axes 1 and 2 meet, the wrist centre w where axes 4, 5, 6 meet, and T_e(0)."""

    omega: np.ndarray   # (6, 3)
    point: np.ndarray   # (6, 3)
    s: np.ndarray
    w: np.ndarray
    T_e0: np.ndarray


def _axes_meet(w1, r1, w2, r2, tol):
    """The point where two lines (unit direction w, point r) meet, or None (parallel or skew)."""
    n = np.cross(w1, w2)
    if np.linalg.norm(n) < 1e-9:
        return None
    # Closest points r1 + a w1, r2 + b w2: solve the 2×2 normal equations.
    d = r2 - r1
    c = w1 @ w2
    a = (d @ w1 - c * (d @ w2)) / (1 - c * c)
    b = (c * (d @ w1) - d @ w2) / (1 - c * c)
    p1, p2 = r1 + a * w1, r2 + b * w2
    return 0.5 * (p1 + p2) if np.linalg.norm(p1 - p2) <= tol else None


def screw_axes(robot: Robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ω (n, 3), r (n, 3), T_e(0) (4, 4)): each joint's unit axis and a point on it at q = 0
    in Σ_0 (the z axis and origin of the frame it moves about), and Σ_e's pose at q = 0."""
    n = robot.n
    ws = kinematics_workspace(n)
    joint_frames_into(robot.arrays, np.zeros(n), ws.R, ws.p)
    end_effector_into(robot.arrays, ws.R[n - 1], ws.p[n - 1], ws.R_e, ws.p_e)
    T_e0 = np.eye(4)
    T_e0[:3, :3], T_e0[:3, 3] = ws.R_e, ws.p_e
    return np.array([ws.R[i][:, 2] for i in range(n)]), np.array([ws.p[i] for i in range(n)]), T_e0


def spherical_wrist_structure(robot: Robot) -> SphericalWrist6R | None:
    """The :class:`SphericalWrist6R` geometry if ``robot`` has six revolute joints, axes 1 and
    2 meeting in a point and axes 4, 5, 6 meeting in another (the PUMA 560 and its kin), else
    None."""
    if robot.n != 6 or any(j.kind != "revolute" for j in robot.joints):
        return None
    omega, point, T_e0 = screw_axes(robot)
    scale = max(1.0, float(np.abs(point).max()))
    tol = STRUCTURE_TOL * scale
    s = _axes_meet(omega[0], point[0], omega[1], point[1], tol)
    w45 = _axes_meet(omega[3], point[3], omega[4], point[4], tol)
    w56 = _axes_meet(omega[4], point[4], omega[5], point[5], tol)
    if s is None or w45 is None or w56 is None or np.linalg.norm(w45 - w56) > tol:
        return None
    return SphericalWrist6R(omega=omega, point=point, s=s, w=w45, T_e0=T_e0)


def _screw(omega, point, angle) -> np.ndarray:
    """exp(ξ θ) of a revolute screw (unit axis ω through ``point``), (4, 4)."""
    T = np.eye(4)
    R = axis_rotation(omega, angle)
    T[:3, :3], T[:3, 3] = R, point - R @ point
    return T


def _subproblem1(omega, r, p, q):
    """θ with exp(ξθ) p = q about the axis (ω, r) (Paden–Kahan 1), or None."""
    u, v = p - r, q - r
    u_p, v_p = u - (omega @ u) * omega, v - (omega @ v) * omega
    if np.linalg.norm(u_p) < 1e-12:
        return 0.0  # p on the axis: any angle
    return float(np.arctan2(omega @ np.cross(u_p, v_p), u_p @ v_p))


def _subproblem2(w1, w2, r, p, q):
    """(θ1, θ2) with exp(ξ1θ1) exp(ξ2θ2) p = q, axes meeting at r (Paden–Kahan 2): 0–2 pairs."""
    u, v = p - r, q - r
    c = w1 @ w2
    denom = c * c - 1.0
    alpha = (c * (w2 @ u) - w1 @ v) / denom
    beta = (c * (w1 @ v) - w2 @ u) / denom
    cross = np.cross(w1, w2)
    g2 = (u @ u - alpha ** 2 - beta ** 2 - 2 * alpha * beta * c) / (cross @ cross)
    if g2 < -1e-10:
        return []
    # Both roots even when they nearly coincide: at the wrist singularity's edge (q5 ~ 1e-7,
    # g2 ~ 1e-14) the two wrist branches are distinct, and forward kinematics decides.
    gamma = np.sqrt(max(g2, 0.0))
    gammas = [gamma, -gamma]
    out = []
    for gamma in gammas:
        z = alpha * w1 + beta * w2 + gamma * cross
        c_point = r + z
        out.append((_subproblem1(w1, r, c_point, q), _subproblem1(w2, r, p, c_point)))
    return out


def _subproblem3(omega, r, p, q, delta):
    """θ with |exp(ξθ) p − q| = δ about the axis (ω, r) (Paden–Kahan 3): 0–2 angles."""
    u, v = p - r, q - r
    u_p, v_p = u - (omega @ u) * omega, v - (omega @ v) * omega
    d2 = delta ** 2 - (omega @ (p - q)) ** 2
    nu, nv = np.linalg.norm(u_p), np.linalg.norm(v_p)
    if nu < 1e-12 or nv < 1e-12:
        return []
    theta0 = np.arctan2(omega @ np.cross(u_p, v_p), u_p @ v_p)
    cosine = (nu ** 2 + nv ** 2 - d2) / (2 * nu * nv)
    if abs(cosine) > 1 + 1e-10:
        return []
    phi = np.arccos(np.clip(cosine, -1.0, 1.0))
    return [theta0] if phi < 1e-12 else [theta0 + phi, theta0 - phi]


def closed_form_wrist(geo: SphericalWrist6R, T_des: np.ndarray) -> list[np.ndarray]:
    """Every q (≤ 8) with T_e(q) = T_des (K9): FK(q) = exp(ξ1q1)…exp(ξ6q6) T_e(0), so with
    G = T_des T_e(0)⁻¹ the wrist centre obeys exp(ξ1q1)exp(ξ2q2)exp(ξ3q3) w = G w.  Its distance
    to s (fixed by joints 1, 2) fixes q3 (subproblem 3); q1, q2 put it in place (subproblem 2);
    the wrist's rotation H = (e1e2e3)⁻¹G gives q4, q5 from a point on axis 6 (subproblem 2)
    and q6 from a point off it (subproblem 1)."""
    om, pt = geo.omega, geo.point
    G = T_des @ np.linalg.inv(geo.T_e0)
    w_des = G[:3, :3] @ geo.w + G[:3, 3]
    solutions = []
    for q3 in _subproblem3(om[2], pt[2], geo.w, geo.s, np.linalg.norm(w_des - geo.s)):
        e3 = _screw(om[2], pt[2], q3)
        w3 = e3[:3, :3] @ geo.w + e3[:3, 3]
        for q1, q2 in _subproblem2(om[0], om[1], geo.s, w3, w_des):
            arm = _screw(om[0], pt[0], q1) @ _screw(om[1], pt[1], q2) @ e3
            H = np.linalg.inv(arm) @ G
            on_axis6 = geo.w + om[5]
            target = H[:3, :3] @ on_axis6 + H[:3, 3]
            for q4, q5 in _subproblem2(om[3], om[4], geo.w, on_axis6, target):
                e45 = _screw(om[3], pt[3], q4) @ _screw(om[4], pt[4], q5)
                off = geo.w + np.cross(om[5], [1.0, 0.0, 0.0] if abs(om[5][0]) < 0.9 else [0.0, 1.0, 0.0])
                back = np.linalg.inv(e45) @ H
                q6 = _subproblem1(om[5], pt[5], off, back[:3, :3] @ off + back[:3, 3])
                solutions.append(np.array([q1, q2, q3, q4, q5, q6]))
    return solutions


def solve_wrist(robot, geo, target, reference, respect_limits, tol):
    T_des = np.eye(4)
    T_des[:3, :3], T_des[:3, 3] = target.R, target.p
    # Round-off grows near the wrist singularity (q5 → 0): each branch is polished and checked by FK.
    solutions = verified(robot, closed_form_wrist(geo, T_des), target, tol)
    if not solutions:
        return None
    return apply_limits(robot, distinct(robot, solutions, reference, target), target, respect_limits)


# ------------------------------------------------------------------- damped least squares (K8)
