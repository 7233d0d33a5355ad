"""Inverse kinematics, every branch: closed form for cylindrical P-R-P arms (the seed's PRP,
``prp``) and for 6R arms with a spherical wrist (the PUMA 560, ``wrist``), seeded multi-start
damped least squares for any other serial robot (``dls``); what they share in ``common``.

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

Closed form for a 6R arm with axes 2, 3, 4 parallel and axes 5, 6 meeting (K13, the Universal
Robots family, ``parallel``): q1 and q5 from the components along the parallel axes that
joints 2–4 cannot change, q6 from the direction of the parallel axes, then a planar 3R arm:
up to 8 solutions.  Every closed-form candidate is refined by a few Newton steps and checked
by forward kinematics, so round-off near a singularity loses no branch.

Damped least squares (K8) for any robot: Levenberg–Marquardt steps

    Δq = (JᵀJ + μ I)⁻¹ Jᵀ e,   e = [p_des − p_e; log(R_des R_eᵀ)]   (position rows only for a
                                                                  position target)

with μ adapted (÷3 on success, ×4 on failure), q clipped into the joint limits, and restarts
from seeded random configurations.  When the arm has no more joints than the task has rows
(6 for a pose, 3 for a position) its solutions are isolated, and every start is run: the
distinct converged ones (|Δq| > 10⁻⁶, angles compared on the circle, and no two along one
almost flat valley near a singularity: ``common.same_branch``) are returned, each within
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

import numpy as np

from armlab.errors import UnreachableTargetError
from armlab.inverse_kinematics.common import distance, parse_target
from armlab.inverse_kinematics.dls import dls_kernel, solve_dls
from armlab.inverse_kinematics.parallel import ParallelAxes6R, parallel_axes_structure, solve_parallel
from armlab.inverse_kinematics.prp import CylindricalPRP, cylindrical_prp_structure, solve_prp
from armlab.inverse_kinematics.wrist import (
    SphericalWrist6R,
    closed_form_wrist,
    solve_wrist,
    spherical_wrist_structure,
)
from armlab.model.robot import Robot
from armlab.spatial import euler_code

__all__ = ["METHODS", "CylindricalPRP", "ParallelAxes6R", "SphericalWrist6R", "UnreachableTargetError",
           "closed_form_wrist", "cylindrical_prp_structure", "dls_kernel", "inverse_kinematics",
           "parallel_axes_structure", "spherical_wrist_structure"]

METHODS = ("auto", "closed_form", "dls")


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
        seed's PRP; closed form (K9, K13, up to 8 branches) for a full pose of a 6R arm with a
        spherical wrist or with three parallel axes (UR); multi-start damped least squares (K8:
        the distinct solutions found, one for a redundant arm) otherwise.  ``"dls"`` forces K8.
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
    parsed = parse_target(robot, target, frame, euler)
    if q0 is not None:
        q0 = np.asarray(q0, dtype=float)
        if q0.shape != (robot.n,):
            raise ValueError(f"q0 must have shape ({robot.n},) for robot {robot.name!r}, got {q0.shape}")
    reference = np.zeros(robot.n) if q0 is None else q0
    geo = cylindrical_prp_structure(robot) if method != "dls" else None
    wrist = spherical_wrist_structure(robot) if method != "dls" and parsed.R is not None else None
    parallel = (parallel_axes_structure(robot) if method != "dls" and parsed.R is not None and wrist is None
                else None)
    if method == "closed_form" and geo is None and wrist is None and parallel is None:
        raise ValueError(f"method: no closed form for {robot.name!r} (cylindrical P-R-P arms, and "
                         "6R arms with a spherical wrist or three parallel axes given a full pose)")
    if wrist is not None or parallel is not None:
        solutions = (solve_wrist(robot, wrist, parsed, reference, respect_limits, tol) if wrist is not None
                     else solve_parallel(robot, parallel, parsed, reference, respect_limits, tol))
        if solutions is not None:
            return np.array(solutions)
        # Out of the closed form's reach (or lost to round-off): the numerical solver says why.
        solutions = solve_dls(robot, parsed, q0, reference, respect_limits, tol, max_iter, restarts,
                               seed, damping)
    elif geo is not None:
        solutions = solve_prp(robot, geo, parsed, reference, respect_limits, tol)
        if q0 is not None:
            solutions.sort(key=lambda q: distance(robot, q, q0))
    else:
        solutions = solve_dls(robot, parsed, q0, reference, respect_limits, tol, max_iter, restarts,
                               seed, damping)
    return np.array(solutions)
