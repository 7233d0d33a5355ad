"""Closed-form inverse kinematics of a cylindrical P-R-P arm (K7), both branches.

A robot whose joints are prismatic, revolute, prismatic with axis 1 ∥ axis 2 and axis 3 ⊥
axis 2 (the seed's PRP, whatever its lengths, base or tool) has, with everything read off the
forward kinematics at q = 0 in Σ_0 (a = axis 2, a₁ = axis 1, o = a point on axis 2,
w = p_e(0) − o, u = axis 3):

    p_e(q) = o + d1 a₁ + Rot(a, θ2) (w + d3 u),     R_e(q) = Rot(a, θ2) R_e(0)

so  d1 = (p − o − w)·a / (a₁·a),  d3 = −w·u ± √((w·u)² − |w⊥|² + |t⊥|²)  with t = p − o − d1 a₁,
and θ2 the angle about a from w⊥ + d3 u to t⊥ (derivation in ``docs/notation.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.errors import UnreachableTargetError
from armlab.inverse_kinematics.common import STRUCTURE_TOL, Target, apply_limits, axis_rotation, wrap_revolute
from armlab.kernels.kinematics import end_effector_into, joint_frames_into, kinematics_workspace
from armlab.model.robot import Robot
from armlab.spatial import rotation_error


@dataclass(frozen=True)
class CylindricalPRP:
    """Geometry of a cylindrical P-R-P arm in Σ_0 at q = 0 (see the module docstring)."""

    axis1: np.ndarray   # a₁, unit direction of joint 1
    axis: np.ndarray    # a, unit axis of joint 2
    origin: np.ndarray  # o, a point of axis 2 at d1 = 0 [m]
    w: np.ndarray       # p_e(0) − o [m]
    u: np.ndarray       # unit direction of joint 3 at θ2 = 0
    R_e0: np.ndarray    # R_e at q = 0


def cylindrical_prp_structure(robot: Robot) -> CylindricalPRP | None:
    """The :class:`CylindricalPRP` geometry if ``robot`` is one (joint kinds P, R, P with
    axis 1 ∥ axis 2 and axis 3 ⊥ axis 2, as the seed's PRP), else None."""
    if [j.kind for j in robot.joints] != ["prismatic", "revolute", "prismatic"]:
        return None
    ws = kinematics_workspace(3)
    joint_frames_into(robot.arrays, np.zeros(3), ws.R, ws.p)
    end_effector_into(robot.arrays, ws.R[2], ws.p[2], ws.R_e, ws.p_e)
    a1, a, u = ws.R[0][:, 2], ws.R[1][:, 2], ws.R[2][:, 2]
    if np.linalg.norm(np.cross(a1, a)) > STRUCTURE_TOL or abs(u @ a) > STRUCTURE_TOL:
        return None
    return CylindricalPRP(axis1=a1.copy(), axis=a.copy(), origin=ws.p[1].copy(),
                          w=ws.p_e - ws.p[1], u=u.copy(), R_e0=ws.R_e.copy())


def closed_form_prp(geo: CylindricalPRP, target: Target, theta_reference: float) -> list[np.ndarray]:
    """All (d1, θ2, d3) reaching the target position (K7), in branch order (−√ then +√)."""
    a = geo.axis
    d1 = (target.p - geo.origin - geo.w) @ a / (geo.axis1 @ a)
    t = target.p - geo.origin - d1 * geo.axis1
    t_perp = t - (t @ a) * a
    w_perp = geo.w - (geo.w @ a) * a
    b = w_perp @ geo.u
    disc = b * b - w_perp @ w_perp + t_perp @ t_perp
    if disc < 0.0:
        return []
    root = np.sqrt(disc)
    solutions = []
    for d3 in (-b - root, -b + root) if root > 0.0 else (-b,):
        v = w_perp + d3 * geo.u
        if np.linalg.norm(v) < 1e-12:
            # Target on axis 2: θ2 is free; keep the reference angle.
            theta = theta_reference
        else:
            theta = np.arctan2(a @ np.cross(v, t_perp), v @ t_perp)
        solutions.append(np.array([d1, theta, d3]))
    return solutions


def solve_prp(robot, geo, target, reference, respect_limits, tol):
    raw = closed_form_prp(geo, target, reference[1])
    if not raw:
        e_p = _distance_to_reach(geo, target)
        raise UnreachableTargetError(
            f"target {target.text} is out of reach of {robot.name!r}: it lies {e_p:.6g} m inside the "
            f"cylinder around joint 2's axis that joint 3 cannot enter", reason="out of reach",
            position_error=e_p)
    solutions = [wrap_revolute(robot, q, reference) for q in raw]
    if target.R is not None:
        errors = [np.linalg.norm(rotation_error(target.R, axis_rotation(geo.axis, q[1]) @ geo.R_e0))
                  for q in solutions]
        matching = [q for q, err in zip(solutions, errors, strict=True) if err <= max(tol, 1e-9)]
        if not matching:
            best = int(np.argmin(errors))
            raise UnreachableTargetError(
                f"target {target.text}: orientation not attainable by {robot.name!r} (3 joints): the "
                f"position is reached but the orientation stays {errors[best]:.6g} rad off",
                reason="orientation", best_q=solutions[best], position_error=0.0,
                orientation_error=errors[best])
        solutions = matching
    return apply_limits(robot, solutions, target, respect_limits)


def _distance_to_reach(geo: CylindricalPRP, target: Target) -> float:
    a = geo.axis
    d1 = (target.p - geo.origin - geo.w) @ a / (geo.axis1 @ a)
    t = target.p - geo.origin - d1 * geo.axis1
    w_perp = geo.w - (geo.w @ a) * a
    r_min = np.sqrt(max(w_perp @ w_perp - (w_perp @ geo.u) ** 2, 0.0))
    return float(r_min - np.linalg.norm(t - (t @ a) * a))


# ------------------------------------------------- 6R arms with a spherical wrist (K9, Pieper)
