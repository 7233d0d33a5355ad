"""Inverse kinematics, every branch: closed form for cylindrical P-R-P arms (the seed's PRP) and
for 6R arms with a spherical wrist (the PUMA 560), seeded multi-start damped least squares for
any other serial robot.

Closed form (K7, derivation in ``docs/notation.md``).  A robot whose joints are prismatic,
revolute, prismatic with axis 1 ∥ axis 2 and axis 3 ⊥ axis 2 (the seed's PRP, whatever its
lengths, base or tool) has, with everything read off the forward kinematics at q = 0 in Σ_0
(a = axis 2, a₁ = axis 1, o = a point on axis 2, w = p_e(0) − o, u = axis 3):

    p_e(q) = o + d1 a₁ + Rot(a, θ2) (w + d3 u),     R_e(q) = Rot(a, θ2) R_e(0)

so  d1 = (p − o − w)·a / (a₁·a),  d3 = −w·u ± √((w·u)² − |w⊥|² + |t⊥|²)  with t = p − o − d1 a₁,
and θ2 the angle about a from w⊥ + d3 u to t⊥.  Both branches (±) are returned.

Closed form for a 6R arm whose axes 1 and 2 meet in a point s and whose axes 4, 5, 6 meet in
the wrist centre w (K9, Pieper's decoupling solved with the Paden–Kahan subproblems in the
product of exponentials FK(q) = exp(ξ₁q₁)…exp(ξ₆q₆) T_e(0), screws read off the joint frames at
q = 0): |w(q) − s| depends on q3 alone (subproblem 3, ≤ 2 roots), q1, q2 place w (subproblem 2,
≤ 2 pairs), the wrist's rotation gives q4, q5 (subproblem 2) and q6 (subproblem 1): up to 8
solutions for a full pose, each checked by forward kinematics.

Damped least squares (K8) for any robot: Levenberg–Marquardt steps

    Δq = (JᵀJ + μ I)⁻¹ Jᵀ e,   e = [p_des − p_e; log(R_des R_eᵀ)]   (position rows only for a
                                                                  position target)

with μ adapted (÷3 on success, ×4 on failure), q clipped into the joint limits, and restarts
from seeded random configurations.  When the arm has no more joints than the task has rows
(6 for a pose, 3 for a position) its solutions are isolated, and every start is run: the
distinct converged ones (|Δq| > 10⁻⁶, angles compared on the circle) are returned, each within
``tol`` of the target by forward kinematics — the branches the starts found, not a proof that
there are no others.  A redundant arm has a continuum of solutions; the first converged one is
returned.  The orientation error is the rotation vector (K12), so
an Euler-angle target never meets a representation singularity here.

Joint limits: solutions outside ``Joint.limits`` are dropped when ``respect_limits=True``
(the default); if none remains, :class:`UnreachableTargetError` says which joint left which
limit.  Revolute angles are returned as the 2π-equivalent nearest to ``q0`` (or to 0) that
lies inside the limits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from armlab.errors import UnreachableTargetError
from armlab.kernels.kinematics import (
    KinematicsWorkspace,
    end_effector_into,
    geometric_jacobian_into,
    joint_frames_into,
    kinematics_workspace,
)
from armlab.kernels.linalg import cholesky_solve_inplace
from armlab.model.robot import PRISMATIC, REVOLUTE, Robot
from armlab.spatial import euler_code, euler_matrix, rotation_error, rotation_error_into

METHODS = ("auto", "closed_form", "dls")
_STRUCTURE_TOL = 1e-9


# ------------------------------------------------------------------------------ targets


@dataclass(frozen=True)
class _Target:
    """The target in Σ_0: position p (3,) [m] and, for a full pose, R (3, 3)."""

    p: np.ndarray
    R: np.ndarray | None
    text: str


def _parse_target(robot: Robot, target, frame: str, euler: str) -> _Target:
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
    return _Target(p=np.array(p), R=None if R is None else np.ascontiguousarray(R), text=text)


def _residual_norms(robot: Robot, q: np.ndarray, target: _Target) -> tuple[float, float]:
    ws = kinematics_workspace(robot.n)
    joint_frames_into(robot.arrays, q, ws.R, ws.p)
    end_effector_into(robot.arrays, ws.R[-1], ws.p[-1], ws.R_e, ws.p_e)
    e_p = float(np.linalg.norm(target.p - ws.p_e))
    e_o = 0.0 if target.R is None else float(np.linalg.norm(rotation_error(target.R, ws.R_e)))
    return e_p, e_o


# ------------------------------------------------------------------------- joint limits


def _limits(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    return robot.arrays.q_min, robot.arrays.q_max


def _wrap_revolute(robot: Robot, q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Each revolute angle shifted by 2πk: inside its limits if possible, nearest the reference."""
    q = q.copy()
    q_min, q_max = _limits(robot)
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


def _distance(robot: Robot, q: np.ndarray, reference: np.ndarray) -> float:
    """|q − reference| with revolute differences taken on the circle (−π, π]."""
    diff = q - reference
    revolute = robot.arrays.joint_type == REVOLUTE
    diff[revolute] = np.angle(np.exp(1j * diff[revolute]))
    return float(np.linalg.norm(diff))


def _limit_violations(robot: Robot, q: np.ndarray, tol: float = 1e-12) -> list[str]:
    q_min, q_max = _limits(robot)
    out = []
    for i, joint in enumerate(robot.joints):
        if q[i] < q_min[i] - tol or q[i] > q_max[i] + tol:
            unit = "m" if joint.kind == "prismatic" else "rad"
            out.append(f"{joint.name} = {q[i]:.6g} {unit} outside [{q_min[i]:g}, {q_max[i]:g}]")
    return out


# --------------------------------------------------------------------- closed form (K7)


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
    if np.linalg.norm(np.cross(a1, a)) > _STRUCTURE_TOL or abs(u @ a) > _STRUCTURE_TOL:
        return None
    return CylindricalPRP(axis1=a1.copy(), axis=a.copy(), origin=ws.p[1].copy(),
                          w=ws.p_e - ws.p[1], u=u.copy(), R_e0=ws.R_e.copy())


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues: rotation by ``angle`` about the unit ``axis``."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


def _closed_form_prp(geo: CylindricalPRP, target: _Target, theta_reference: float) -> list[np.ndarray]:
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


def _solve_closed_form(robot, geo, target, reference, respect_limits, tol):
    raw = _closed_form_prp(geo, target, reference[1])
    if not raw:
        e_p = _distance_to_reach(geo, target)
        raise UnreachableTargetError(
            f"target {target.text} is out of reach of {robot.name!r}: it lies {e_p:.6g} m inside the "
            f"cylinder around joint 2's axis that joint 3 cannot enter", reason="out of reach",
            position_error=e_p)
    solutions = [_wrap_revolute(robot, q, reference) for q in raw]
    if target.R is not None:
        errors = [np.linalg.norm(rotation_error(target.R, _axis_rotation(geo.axis, q[1]) @ geo.R_e0))
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
    return _apply_limits(robot, solutions, target, respect_limits)


def _distance_to_reach(geo: CylindricalPRP, target: _Target) -> float:
    a = geo.axis
    d1 = (target.p - geo.origin - geo.w) @ a / (geo.axis1 @ a)
    t = target.p - geo.origin - d1 * geo.axis1
    w_perp = geo.w - (geo.w @ a) * a
    r_min = np.sqrt(max(w_perp @ w_perp - (w_perp @ geo.u) ** 2, 0.0))
    return float(r_min - np.linalg.norm(t - (t @ a) * a))


def _apply_limits(robot, solutions, target, respect_limits):
    if not respect_limits:
        return solutions
    inside = [q for q in solutions if not _limit_violations(robot, q)]
    if inside:
        return inside
    details = "; ".join(f"solution {k + 1} needs " + ", ".join(_limit_violations(robot, q))
                        for k, q in enumerate(solutions))
    raise UnreachableTargetError(
        f"target {target.text} is reachable by {robot.name!r} only outside its joint limits: {details}",
        reason="joint limits", best_q=solutions[0], position_error=0.0, orientation_error=0.0)


# ------------------------------------------------- 6R arms with a spherical wrist (K9, Pieper)


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


def spherical_wrist_structure(robot: Robot) -> SphericalWrist6R | None:
    """The :class:`SphericalWrist6R` geometry if ``robot`` has six revolute joints, axes 1 and
    2 meeting in a point and axes 4, 5, 6 meeting in another (the PUMA 560 and its kin), else
    None."""
    if robot.n != 6 or any(j.kind != "revolute" for j in robot.joints):
        return None
    ws = kinematics_workspace(6)
    joint_frames_into(robot.arrays, np.zeros(6), ws.R, ws.p)
    end_effector_into(robot.arrays, ws.R[5], ws.p[5], ws.R_e, ws.p_e)
    omega = np.array([ws.R[i][:, 2] for i in range(6)])
    point = np.array([ws.p[i] for i in range(6)])
    scale = max(1.0, float(np.abs(point).max()))
    tol = _STRUCTURE_TOL * scale
    s = _axes_meet(omega[0], point[0], omega[1], point[1], tol)
    w45 = _axes_meet(omega[3], point[3], omega[4], point[4], tol)
    w56 = _axes_meet(omega[4], point[4], omega[5], point[5], tol)
    if s is None or w45 is None or w56 is None or np.linalg.norm(w45 - w56) > tol:
        return None
    T_e0 = np.eye(4)
    T_e0[:3, :3], T_e0[:3, 3] = ws.R_e, ws.p_e
    return SphericalWrist6R(omega=omega, point=point, s=s, w=w45, T_e0=T_e0)


def _screw(omega, point, angle) -> np.ndarray:
    """exp(ξ θ) of a revolute screw (unit axis ω through ``point``), (4, 4)."""
    T = np.eye(4)
    R = _axis_rotation(omega, angle)
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
    gammas = [0.0] if g2 <= 1e-14 else [np.sqrt(g2), -np.sqrt(g2)]
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


def _closed_form_wrist(geo: SphericalWrist6R, T_des: np.ndarray) -> list[np.ndarray]:
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


def _solve_wrist(robot, geo, target, reference, respect_limits, tol):
    T_des = np.eye(4)
    T_des[:3, :3], T_des[:3, 3] = target.R, target.p
    verified = []
    for q in _closed_form_wrist(geo, T_des):
        e_p, e_o = _residual_norms(robot, q, target)
        # Round-off grows near the wrist singularity (q5 = 0); each branch is checked by FK.
        if e_p <= max(tol, 1e-9) and e_o <= max(tol, 1e-9):
            verified.append(q)
    if not verified:
        return None
    return _apply_limits(robot, _distinct(robot, verified, reference), target, respect_limits)


# ------------------------------------------------------------------- damped least squares (K8)


@njit(cache=True)
def _residual_into(m, q, R_des, p_des, full_pose, ws, e):
    """e = [p_des − p_e; log(R_des R_eᵀ)] (or zeros in the last 3) in Σ_0; returns ½|e|²."""
    n = q.shape[0]
    joint_frames_into(m, q, ws.R, ws.p)
    end_effector_into(m, ws.R[n - 1], ws.p[n - 1], ws.R_e, ws.p_e)
    for r in range(3):
        e[r] = p_des[r] - ws.p_e[r]
    if full_pose:
        rotation_error_into(R_des, ws.R_e, e[3:])
    else:
        e[3], e[4], e[5] = 0.0, 0.0, 0.0
    cost = 0.0
    for r in range(6):
        cost += e[r] * e[r]
    return 0.5 * cost


@njit(cache=True)
def dls_kernel(m, R_des, p_des, full_pose, q_min, q_max, q, max_iter, tol, damping, ws, A, dq,
               q_try, e, e_try):
    """Levenberg–Marquardt inverse kinematics from ``q`` (n,), updated in place (K8).

    ``R_des`` (3, 3), ``p_des`` (3,) [m]: target in Σ_0 (``R_des`` ignored unless
    ``full_pose``); q stays in [q_min, q_max].  Scratch: ``ws`` (:class:`KinematicsWorkspace`),
    ``A`` (n, n), ``dq``, ``q_try`` (n,), ``e``, ``e_try`` (6,).  Returns the iterations used; the final
    residual is left in ``e``.
    """
    n = q.shape[0]
    rows = 6 if full_pose else 3
    mu = damping
    for it in range(max_iter):
        cost = _residual_into(m, q, R_des, p_des, full_pose, ws, e)
        e_p = np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        e_o = np.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        if e_p <= tol and e_o <= tol:
            return it
        geometric_jacobian_into(m, ws.R, ws.p, ws.p_e, ws.J)
        accepted = False
        while mu < 1e10:
            for i in range(n):
                g = 0.0
                for r in range(rows):
                    g += ws.J[r, i] * e[r]
                dq[i] = g
                for j in range(i + 1):
                    s = 0.0
                    for r in range(rows):
                        s += ws.J[r, i] * ws.J[r, j]
                    A[i, j] = s
                    A[j, i] = s
                A[i, i] += mu
            if not cholesky_solve_inplace(A, dq):
                mu *= 4.0
                continue
            step = 0.0
            for i in range(n):
                q_try[i] = min(max(q[i] + dq[i], q_min[i]), q_max[i])
                step += (q_try[i] - q[i]) ** 2
            if step == 0.0:
                break
            cost_try = _residual_into(m, q_try, R_des, p_des, full_pose, ws, e_try)
            if cost_try < cost:
                for i in range(n):
                    q[i] = q_try[i]
                mu = max(mu / 3.0, 1e-12)
                accepted = True
                break
            mu *= 4.0
        if not accepted:
            # No descent step exists (a local minimum, possibly on a joint limit).
            _residual_into(m, q, R_des, p_des, full_pose, ws, e)
            return it
    _residual_into(m, q, R_des, p_des, full_pose, ws, e)
    return max_iter


def _starts(robot: Robot, q0, restarts: int, seed: int, respect_limits: bool) -> list[np.ndarray]:
    q_min, q_max = _limits(robot)
    if q0 is not None:
        first = np.asarray(q0, dtype=float)
    else:
        finite = np.isfinite(q_min) & np.isfinite(q_max)
        first = np.zeros(robot.n)
        first[finite] = 0.5 * (q_min[finite] + q_max[finite])
    if respect_limits:
        first = np.clip(first, q_min, q_max)
    rng = np.random.default_rng(seed)
    starts = [first]
    prismatic = robot.arrays.joint_type == PRISMATIC
    default_lo = np.where(prismatic, -1.0, -np.pi)
    default_hi = -default_lo
    lo = np.where(np.isfinite(q_min) & respect_limits, q_min, default_lo)
    hi = np.where(np.isfinite(q_max) & respect_limits, q_max, default_hi)
    starts += [rng.uniform(lo, hi) for _ in range(restarts)]
    return starts


def _run_dls(robot, target, starts, respect_limits, tol, max_iter, damping, found=None):
    """Best (q, e_p, e_o) over the starts.  Without ``found`` it stops at the first converged
    start; with a list ``found`` it runs every start and appends each converged q to it."""
    m = robot.arrays
    n = robot.n
    q_min, q_max = (m.q_min, m.q_max) if respect_limits else (np.full(n, -np.inf), np.full(n, np.inf))
    R_des = target.R if target.R is not None else np.eye(3)
    ws: KinematicsWorkspace = kinematics_workspace(n)
    A, dq, q_try, e, e_try = np.empty((n, n)), np.empty(n), np.empty(n), np.empty(6), np.empty(6)
    best = (None, np.inf, np.inf)
    for start in starts:
        q = np.array(start, dtype=float)
        dls_kernel(m, R_des, target.p, target.R is not None, q_min, q_max, q, max_iter, tol, damping,
                   ws, A, dq, q_try, e, e_try)
        e_p, e_o = float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:]))
        if e_p + e_o < best[1] + best[2]:
            best = (q, e_p, e_o)
        if e_p <= tol and e_o <= tol:
            if found is None:
                break
            found.append(q)
    return best


def _distinct(robot, solutions, reference):
    """The solutions wrapped (2π turns) and without repeats (|Δq| < 1e-6, revolute differences
    on the circle), nearest ``reference`` first."""
    out = []
    for q in sorted((_wrap_revolute(robot, q, reference) for q in solutions),
                    key=lambda q: _distance(robot, q, reference)):
        if all(_distance(robot, q, other) > 1e-6 for other in out):
            out.append(q)
    return out


def _solve_dls(robot, target, q0, reference, respect_limits, tol, max_iter, restarts, seed, damping):
    starts = _starts(robot, q0, restarts, seed, respect_limits)
    # A finite set of solutions exists when the task has as many rows as the arm has joints
    # (or more); a redundant arm has a continuum of them, of which one is returned.
    rows = 3 if target.R is None else 6
    found = [] if robot.n <= rows else None
    q, e_p, e_o = _run_dls(robot, target, starts, respect_limits, tol, max_iter, damping, found)
    if found:
        return _distinct(robot, found, reference)
    if e_p <= tol and e_o <= tol:
        return [_wrap_revolute(robot, q, reference)]
    miss = f"{e_p:.6g} m" + ("" if target.R is None else f" and {e_o:.6g} rad")
    if respect_limits:
        free_q, free_p, free_o = _run_dls(robot, target, _starts(robot, q0, restarts, seed, False), False,
                                          tol, max_iter, damping)
        if free_p <= tol and free_o <= tol:
            free_q = _wrap_revolute(robot, free_q, reference)
            violations = ", ".join(_limit_violations(robot, free_q)) or "joints at their limits"
            raise UnreachableTargetError(
                f"target {target.text} is out of reach of {robot.name!r} within its joint limits: the "
                f"best attempt inside them stays {miss} away, and a solution outside needs {violations}",
                reason="joint limits", best_q=q, position_error=e_p, orientation_error=e_o)
    raise UnreachableTargetError(
        f"target {target.text} is out of reach of {robot.name!r}: the best of {len(starts)} damped "
        f"least-squares attempts stays {miss} away (q = {np.round(q, 6).tolist()})",
        reason="out of reach", best_q=q, position_error=e_p, orientation_error=e_o)


# ------------------------------------------------------------------------------ public API


def inverse_kinematics(robot: Robot, target, q0=None, *, frame: str = "base", euler: str = "zyz",
                       method: str = "auto", respect_limits: bool = True, tol: float = 1e-9,
                       max_iter: int = 200, restarts: int = 32, seed: int = 0,
                       damping: float = 1e-3) -> np.ndarray:
    """Joint configurations q with FK(q) = target, as a (k, n) array (k ≥ 1), every branch
    found, nearest ``q0`` (or 0) first.

    Parameters
    ----------
    robot : Robot
    target : array_like
        Σ_e's origin (3,) [m]; or a pose vector x = [p; φ] (6,) [m, rad] in ``euler`` angles;
        or a pose T (4, 4); expressed in ``frame`` (``"base"``: Σ_base, ``"0"``: Σ_0).
    q0 : array_like (n,), optional
        Start of the damped least squares; orders the closed-form solutions (nearest first)
        and picks the 2π-equivalent of revolute angles.
    method : {"auto", "closed_form", "dls"}
        ``"auto"``: closed form (K7, all branches) for a cylindrical P-R-P arm such as the
        seed's PRP; closed form (K9, up to 8 branches) for a full pose of a 6R arm with a
        spherical wrist; multi-start damped least squares (K8: the distinct solutions found,
        one for a redundant arm) otherwise.  ``"dls"`` forces K8.
    respect_limits : bool
        Drop solutions outside the joint limits (DLS keeps q inside them).
    tol : float
        Residual tolerance, position [m] and orientation [rad].
    max_iter, restarts, seed, damping
        DLS iterations per start, number of seeded random restarts, their seed, initial μ.

    Raises
    ------
    UnreachableTargetError
        With the best attempt's distance and the reason: out of reach, joint limits, or (for a
        full pose on a robot with fewer than 6 joints) an unattainable orientation.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    euler_code(euler)
    parsed = _parse_target(robot, target, frame, euler)
    if q0 is not None:
        q0 = np.asarray(q0, dtype=float)
        if q0.shape != (robot.n,):
            raise ValueError(f"q0 must have shape ({robot.n},) for robot {robot.name!r}, got {q0.shape}")
    reference = np.zeros(robot.n) if q0 is None else q0
    geo = cylindrical_prp_structure(robot) if method != "dls" else None
    wrist = spherical_wrist_structure(robot) if method != "dls" and parsed.R is not None else None
    if method == "closed_form" and geo is None and wrist is None:
        raise ValueError(f"method: no closed form for {robot.name!r} (cylindrical P-R-P arms, and "
                         "6R arms with a spherical wrist given a full pose)")
    if wrist is not None:
        solutions = _solve_wrist(robot, wrist, parsed, reference, respect_limits, tol)
        if solutions is not None:
            return np.array(solutions)
        # Out of the closed form's reach (or lost to round-off): the numerical solver says why.
        solutions = _solve_dls(robot, parsed, q0, reference, respect_limits, tol, max_iter, restarts,
                               seed, damping)
    elif geo is not None:
        solutions = _solve_closed_form(robot, geo, parsed, reference, respect_limits, tol)
        if q0 is not None:
            solutions.sort(key=lambda q: _distance(robot, q, q0))
    else:
        solutions = _solve_dls(robot, parsed, q0, reference, respect_limits, tol, max_iter, restarts,
                               seed, damping)
    return np.array(solutions)
