"""Closed-form inverse kinematics of a 6R arm with three parallel axes (K13), up to 8 branches.

The Universal Robots family (UR3, UR5, UR10, their e-series) has axes 2, 3, 4 parallel (unit
direction ω_p at q = 0), axis 1 not parallel to them, and axes 5 and 6 meeting in a point c.
In the product of exponentials FK(q) = exp(ξ₁q₁)…exp(ξ₆q₆) T_e(0), with G = T_des T_e(0)⁻¹
(screws read off the joint frames at q = 0; s₁ a point on axis 1, R_i the rotation of e_i):

* c is fixed by joints 5 and 6, so c_des = G c.  Joints 2–4 rotate about ω_p and keep every
  point's ω_p component, so  (R₁ ω_p)·(c_des − s₁) = ω_p·(c − s₁):  q1, 0–2 roots;
* the same for axis 6's direction ω₆ (fixed by joint 6):  (R₁ ω_p)·(R_G ω₆) = ω_p·(R₅ ω₆):
  q5, 0–2 roots;
* with G' = e₁⁻¹ G = e₂e₃e₄e₅e₆ and ω_pᵀ R₂R₃R₄ = ω_pᵀ:  R₆ᵀ R₅ᵀ ω_p = R_G'ᵀ ω_p gives q6
  (Paden–Kahan 1 on directions; any q6 when axis 6 ∥ ω_p, the wrist singularity);
* H = G' e₆⁻¹ e₅⁻¹ = e₂e₃e₄ is a planar arm: a point w on axis 4 satisfies e₂e₃ w = H w, so
  |e₃ w − r₂| = |H w − r₂| (r₂ on axis 2) gives q3 (subproblem 3, 0–2 roots), subproblem 1
  gives q2, and q4 follows from e₄ = (e₂e₃)⁻¹ H (subproblem 1).

2 × 2 × 2 = 8 candidates; each is polished by a few Newton steps and checked by forward
kinematics (``dls.verified``), which removes the spurious roots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.inverse_kinematics.common import STRUCTURE_TOL, apply_limits, distinct
from armlab.inverse_kinematics.dls import verified
from armlab.inverse_kinematics.wrist import _axes_meet, _screw, _subproblem1, _subproblem3, screw_axes
from armlab.model.robot import Robot


@dataclass(frozen=True)
class ParallelAxes6R:
    """Screw axes of a 6R arm at q = 0 in Σ_0 (ω_i unit axis, r_i a point on it), the point c
    where axes 5 and 6 meet, and T_e(0)."""

    omega: np.ndarray   # (6, 3)
    point: np.ndarray   # (6, 3)
    c: np.ndarray
    T_e0: np.ndarray


def parallel_axes_structure(robot: Robot) -> ParallelAxes6R | None:
    """The :class:`ParallelAxes6R` geometry if ``robot`` has six revolute joints, axes 2, 3, 4
    parallel and distinct, axis 1 not parallel to them and axes 5, 6 meeting (the UR family),
    else None."""
    if robot.n != 6 or any(j.kind != "revolute" for j in robot.joints):
        return None
    omega, point, T_e0 = screw_axes(robot)
    tol = STRUCTURE_TOL * max(1.0, float(np.abs(point).max()))
    w_p = omega[1]
    parallel = all(np.linalg.norm(np.cross(w_p, omega[k])) < 1e-9 for k in (2, 3))
    if not parallel or np.linalg.norm(np.cross(w_p, omega[0])) < 1e-6:
        return None

    def off_axis(a, b):  # distance of axis b's point from the line of axis a
        d = point[b] - point[a]
        return np.linalg.norm(d - (d @ w_p) * w_p)

    # q5 must change axis 6's ω_p component: axis 5 neither ∥ ω_p nor ∥ axis 6.
    if min(off_axis(1, 2), off_axis(2, 3)) < 1e-6 or abs(omega[4] @ w_p) > 1 - 1e-6:
        return None
    c = _axes_meet(omega[4], point[4], omega[5], point[5], tol)
    if c is None:
        return None
    return ParallelAxes6R(omega=omega, point=point, c=c, T_e0=T_e0)


def _dot_after_rotation(axis, a, b, value) -> list[float]:
    """Every θ with (Rot(axis, θ) a)·b = value: A cos θ + B sin θ + C = value (0–2 roots;
    both roots are kept when they nearly coincide, forward kinematics decides)."""
    along = (a @ axis) * axis
    perpendicular = a - along
    A, B, C = perpendicular @ b, np.cross(axis, perpendicular) @ b, along @ b
    r = np.hypot(A, B)
    if r < 1e-12:
        return []
    cosine = (value - C) / r
    if abs(cosine) > 1 + 1e-9:
        return []
    phi, spread = np.arctan2(B, A), np.arccos(np.clip(cosine, -1.0, 1.0))
    return [phi + spread, phi - spread]


def _direction_angle(axis, u, v) -> float:
    """θ with Rot(axis, θ) u ∥ v, for directions u, v (subproblem 1 with the origin on the axis)."""
    return _subproblem1(axis, np.zeros(3), u, v)


def closed_form_parallel(geo: ParallelAxes6R, T_des: np.ndarray) -> list[np.ndarray]:
    """Candidate q (≤ 8) for T_e(q) = T_des (K13, see the module docstring); unverified."""
    om, pt = geo.omega, geo.point
    w_p = om[1]
    G = T_des @ np.linalg.inv(geo.T_e0)
    c_des = G[:3, :3] @ geo.c + G[:3, 3]
    w6_des = G[:3, :3] @ om[5]
    on_axis4 = pt[3]
    side = np.cross(w_p, [1.0, 0.0, 0.0] if abs(w_p[0]) < 0.9 else [0.0, 1.0, 0.0])
    off = on_axis4 + side / np.linalg.norm(side)  # a point off axis 4, for q4
    candidates = []
    for q1 in _dot_after_rotation(om[0], w_p, c_des - pt[0], w_p @ (geo.c - pt[0])):
        e1 = _screw(om[0], pt[0], q1)
        n = e1[:3, :3] @ w_p
        for q5 in _dot_after_rotation(om[4], om[5], w_p, n @ w6_des):
            e5 = _screw(om[4], pt[4], q5)
            G1 = np.linalg.inv(e1) @ G
            q6 = _direction_angle(om[5], G1[:3, :3].T @ w_p, e5[:3, :3].T @ w_p)
            e6 = _screw(om[5], pt[5], q6)
            H = G1 @ np.linalg.inv(e6) @ np.linalg.inv(e5)
            w_des = H[:3, :3] @ on_axis4 + H[:3, 3]
            for q3 in _subproblem3(om[2], pt[2], on_axis4, pt[1], np.linalg.norm(w_des - pt[1])):
                e3 = _screw(om[2], pt[2], q3)
                q2 = _subproblem1(om[1], pt[1], e3[:3, :3] @ on_axis4 + e3[:3, 3], w_des)
                e4 = np.linalg.inv(_screw(om[1], pt[1], q2) @ e3) @ H
                q4 = _subproblem1(om[3], pt[3], off, e4[:3, :3] @ off + e4[:3, 3])
                candidates.append(np.array([q1, q2, q3, q4, q5, q6]))
    return candidates


def solve_parallel(robot, geo, target, reference, respect_limits, tol):
    T_des = np.eye(4)
    T_des[:3, :3], T_des[:3, 3] = target.R, target.p
    solutions = verified(robot, closed_form_parallel(geo, T_des), target, tol)
    if not solutions:
        return None
    return apply_limits(robot, distinct(robot, solutions, reference, target), target, respect_limits)
