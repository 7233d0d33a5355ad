"""Inverse kinematics of any serial robot by seeded multi-start damped least squares (K8).

Levenberg–Marquardt steps

    Δq = (JᵀJ + μ I)⁻¹ Jᵀ e,   e = [p_des − p_e; log(R_des R_eᵀ)]   (position rows only for a
                                                                  position target)

with μ adapted (÷3 on success, ×4 on failure), q clipped into the joint limits, and restarts
from seeded random configurations.  The orientation error is the rotation vector (K12), so an
Euler-angle target never meets a representation singularity here.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.errors import UnreachableTargetError
from armlab.inverse_kinematics.common import distinct, joint_limits, limit_violations, wrap_revolute
from armlab.kernels.kinematics import (
    KinematicsWorkspace,
    end_effector_into,
    geometric_jacobian_into,
    joint_frames_into,
    kinematics_workspace,
)
from armlab.kernels.linalg import cholesky_solve_inplace
from armlab.model.robot import PRISMATIC, Robot
from armlab.spatial import rotation_error_into


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


POLISH_FROM = 1e-5
"""Residual [m, rad] of a closed-form candidate still worth Newton steps: round-off near a
singularity leaves 10⁻⁸–10⁻⁷ (Puma560 at |q5| ≈ 10⁻⁷), a spurious root leaves ≳ 10⁻²."""


def verified(robot: Robot, candidates, target, tol: float) -> list[np.ndarray]:
    """The closed-form ``candidates`` that reach ``target`` within max(``tol``, 10⁻⁹) by
    forward kinematics, each first refined towards ``tol`` by up to 20 undamped Gauss–Newton
    steps (:func:`dls_kernel` without joint limits) when its residual is below
    :data:`POLISH_FROM`."""
    accept, tol = max(tol, 1e-9), max(tol, 1e-14)
    m = robot.arrays
    n = robot.n
    ws = kinematics_workspace(n)
    A, dq, q_try, e, e_try = np.empty((n, n)), np.empty(n), np.empty(n), np.empty(6), np.empty(6)
    free = np.full(n, np.inf)
    R_des = target.R if target.R is not None else np.eye(3)
    out = []
    for candidate in candidates:
        q = np.array(candidate, dtype=float)
        _residual_into(m, q, R_des, target.p, target.R is not None, ws, e)
        if max(np.linalg.norm(e[:3]), np.linalg.norm(e[3:])) > POLISH_FROM:
            continue
        dls_kernel(m, R_des, target.p, target.R is not None, -free, free, q, 20, tol, 1e-12,
                   ws, A, dq, q_try, e, e_try)
        if np.linalg.norm(e[:3]) <= accept and np.linalg.norm(e[3:]) <= accept:
            out.append(q)
    return out


def _starts(robot: Robot, q0, restarts: int, seed: int, respect_limits: bool) -> list[np.ndarray]:
    q_min, q_max = joint_limits(robot)
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


def solve_dls(robot, target, q0, reference, respect_limits, tol, max_iter, restarts, seed, damping):
    starts = _starts(robot, q0, restarts, seed, respect_limits)
    # A finite set of solutions exists when the task has as many rows as the arm has joints
    # (or more); a redundant arm has a continuum of them, of which one is returned.
    rows = 3 if target.R is None else 6
    found = [] if robot.n <= rows else None
    q, e_p, e_o = _run_dls(robot, target, starts, respect_limits, tol, max_iter, damping, found)
    if found:
        return distinct(robot, found, reference, target, tol)
    if e_p <= tol and e_o <= tol:
        return [wrap_revolute(robot, q, reference)]
    miss = f"{e_p:.6g} m" + ("" if target.R is None else f" and {e_o:.6g} rad")
    if respect_limits:
        free_q, free_p, free_o = _run_dls(robot, target, _starts(robot, q0, restarts, seed, False), False,
                                          tol, max_iter, damping)
        if free_p <= tol and free_o <= tol:
            free_q = wrap_revolute(robot, free_q, reference)
            violations = ", ".join(limit_violations(robot, free_q)) or "joints at their limits"
            raise UnreachableTargetError(
                f"target {target.text} is out of reach of {robot.name!r} within its joint limits: the "
                f"best attempt inside them stays {miss} away, and a solution outside needs {violations}",
                reason="joint limits", best_q=q, position_error=e_p, orientation_error=e_o)
    raise UnreachableTargetError(
        f"target {target.text} is out of reach of {robot.name!r}: the best of {len(starts)} damped "
        f"least-squares attempts stays {miss} away (q = {np.round(q, 6).tolist()})",
        reason="out of reach", best_q=q, position_error=e_p, orientation_error=e_o)


# ------------------------------------------------------------------------------ public API
