"""A4 symbolically: recursive Newton–Euler with motor and friction terms (Siciliano et al. §7.5).

The recursion runs in joint frames J_i (z = joint i's axis, origin on it; ``model/robot.py``),
exactly as the compiled kernel ``armlab.kernels.dynamics.rnea_into`` does, so the two are
the same law in two arithmetics.  With R_i, p_i the pose of J_i in J_{i−1}, z = (0, 0, 1):

    forward  ω_i = R_iᵀ ω_{i−1} + q̇_i z                         (revolute)
             ω̇_i = R_iᵀ ω̇_{i−1} + q̈_i z + q̇_i (R_iᵀ ω_{i−1}) × z
             a_i = R_iᵀ (a_{i−1} + ω̇_{i−1} × p_i + ω_{i−1} × (ω_{i−1} × p_i))
                   [+ q̈_i z + 2 q̇_i ω_i × z  (prismatic)],   a_0 = −g_0
             a_Cᵢ = a_i + ω̇_i × c_i + ω_i × (ω_i × c_i)
    backward f_i = m_i a_Cᵢ + R_{i+1} f_{i+1}
             μ_i = I_Cᵢ ω̇_i + ω_i × I_Cᵢ ω_i + c_i × m_i a_Cᵢ + R_{i+1} μ_{i+1}
                   + p_{i+1} × R_{i+1} f_{i+1} + I_m,i+1 (ṡ_{i+1} z_m + s_{i+1} ω_i × z_m)
             τ_i = zᵀ μ_i | zᵀ f_i  + k_rᵢ I_mᵢ ṡ_i + F_vᵢ q̇_i + F_sᵢ sgn q̇_i          (N1)

with the rotor spin s_i = z_mᵢᵀ ω_{i−1} + k_rᵢ q̇_i of (D3); motor i's mass m_mᵢ is a point of
link i−1 at joint i's origin p_mᵢ, adding m_mᵢ a_mᵢ to f_{i−1} and p_mᵢ × m_mᵢ a_mᵢ to μ_{i−1}.
From it (seed A4):

    B e_j = NE(q, 0, e_j; 0),   C q̇ = NE(q, q̇, 0; 0),   g = NE(q, 0, 0; g_0)              (N2)
"""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import sympy as sp

from armlab.symbolic.kinematics import angles
from armlab.symbolic.model import SymbolicRobot
from armlab.symbolic.simplify import compact, compact_matrix

Z = sp.Matrix([0, 0, 1])


class JointFrameModel(NamedTuple):
    """The symbolic counterpart of ``RobotArrays`` (joint frames J_i).

    ``R``, ``p``: J_i in J_{i−1} at q (lists of (3, 3), (3, 1)); ``com``, ``inertia``: link i
    in J_i; ``rotor_axis``, ``motor_point``: z_mᵢ and motor i's position in J_{i−1};
    ``to_link``: rotation J_i → Σ_i (Σ_i axes of a vector given in J_i: to_link[i] · v);
    ``tool_p``: Σ_e's origin in J_n.
    """

    R: list
    p: list
    com: list
    inertia: list
    rotor_axis: list
    motor_point: list
    to_link: list
    tool_p: sp.Matrix


@lru_cache(maxsize=32)
def joint_frame_model(sr: SymbolicRobot) -> JointFrameModel:
    R, p, com, inertia, rotor_axis, motor_point, to_link = [], [], [], [], [], [], []
    previous_after = sp.eye(4)
    for joint, link in zip(sr.joints, sr.links, strict=True):
        X = previous_after * joint.before
        T = X * joint.motion()
        R.append(compact_matrix(T[:3, :3], angles(sr)))
        p.append(compact_matrix(T[:3, 3], angles(sr)))
        rotor_axis.append(X[:3, 2])
        motor_point.append(X[:3, 3])
        S = joint.after
        com.append(compact_matrix(S[:3, :3] * link.com + S[:3, 3]))
        inertia.append(compact_matrix(S[:3, :3] * link.inertia * S[:3, :3].T))
        to_link.append(S[:3, :3].T)
        previous_after = S
    tool = previous_after * sr.tool
    return JointFrameModel(R, p, com, inertia, rotor_axis, motor_point, to_link, tool[:3, 3])


class NewtonEulerResult(NamedTuple):
    """τ (n, 1) and the recursion's intermediate quantities, each a list over links, in the
    link frames Σ_i: ``omega`` ω_i, ``omega_dot`` ω̇_i, ``acc_com`` p̈_Cᵢ, ``force`` f_i."""

    tau: sp.Matrix
    omega: list
    omega_dot: list
    acc_com: list
    force: list


def newton_euler(sr: SymbolicRobot, qd=None, qdd=None, gravity=None, *, friction: bool = True,
                 h_e=None, simplify: bool = True) -> NewtonEulerResult:
    """NE(q, q̇, q̈; g_0) of (N1); defaults: the symbols q̇, q̈ and the robot's g_0.

    ``h_e`` (6, 1) is the wrench [f; μ] the end effector exerts on the environment, in Σ_0,
    μ about Σ_e's origin.  ``simplify`` compacts every intermediate vector (keeps the PRP's
    expressions small); without it the raw recursion is returned.
    """
    n = sr.n
    qd = sr.qd if qd is None else sp.Matrix(qd)
    qdd = sr.qdd if qdd is None else sp.Matrix(qdd)
    g0 = sr.gravity if gravity is None else sp.Matrix(gravity)
    model = joint_frame_model(sr)
    ang = angles(sr)

    def tidy(v):
        return compact_matrix(v, ang) if simplify else v

    w_prev, wd_prev, a_prev = sp.zeros(3, 1), sp.zeros(3, 1), -g0
    w, wd, a, a_origin, f, mu = [], [], [], [], [], []
    for i, joint in enumerate(sr.joints):
        R, p = model.R[i], model.p[i]
        if i > 0:
            t = a_prev + wd_prev.cross(p) + w_prev.cross(w_prev.cross(p))
        else:
            t = a_prev
        wi, wdi, ai = R.T * w_prev, R.T * wd_prev, R.T * t
        if joint.revolute:
            wdi = wdi + qdd[i] * Z + qd[i] * wi.cross(Z)
            wi = wi + qd[i] * Z
        else:
            ai = ai + qdd[i] * Z + 2 * qd[i] * wi.cross(Z)
        wi, wdi, ai = tidy(wi), tidy(wdi), tidy(ai)
        c, I_C, m = model.com[i], model.inertia[i], sr.links[i].mass
        a_c = tidy(ai + wdi.cross(c) + wi.cross(wi.cross(c)))
        F = m * a_c
        w.append(wi)
        wd.append(wdi)
        a_origin.append(ai)
        a.append(a_c)
        f.append(F)
        mu.append(I_C * wdi + wi.cross(I_C * wi) + c.cross(F))
        w_prev, wd_prev, a_prev = wi, wdi, ai
    tau = [sp.Integer(0)] * n
    first = sr.joints[0]
    tau[0] = first.gear_ratio**2 * first.rotor_inertia * qdd[0]
    for i in range(1, n):
        joint = sr.joints[i]
        if joint.motor_mass != 0:
            # Motor i is a point mass carried by link i−1 at its joint's origin.
            r = model.motor_point[i]
            a_m = a_origin[i - 1] + wd[i - 1].cross(r) + w[i - 1].cross(w[i - 1].cross(r))
            F_m = joint.motor_mass * a_m
            f[i - 1] = f[i - 1] + F_m
            mu[i - 1] = mu[i - 1] + r.cross(F_m)
        if joint.rotor_inertia == 0:
            continue
        z_m = model.rotor_axis[i]
        spin = (z_m.T * w[i - 1])[0] + joint.gear_ratio * qd[i]
        spin_rate = (z_m.T * wd[i - 1])[0] + joint.gear_ratio * qdd[i]
        mu[i - 1] = mu[i - 1] + joint.rotor_inertia * (spin_rate * z_m + spin * w[i - 1].cross(z_m))
        tau[i] = joint.gear_ratio * joint.rotor_inertia * spin_rate
    if h_e is not None:
        h_e = sp.Matrix(h_e)
        R_0n = sp.eye(3)
        for R in model.R:
            R_0n = R_0n * R
        f_e, mu_e = R_0n.T * h_e[:3, :], R_0n.T * h_e[3:, :]
        f[-1] = f[-1] + f_e
        mu[-1] = mu[-1] + mu_e + model.tool_p.cross(f_e)
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            R, p = model.R[i + 1], model.p[i + 1]
            g_child = R * f[i + 1]
            f[i] = f[i] + g_child
            mu[i] = mu[i] + R * mu[i + 1] + p.cross(g_child)
        f[i], mu[i] = tidy(f[i]), tidy(mu[i])
        joint = sr.joints[i]
        tau[i] += f[i][2] if not joint.revolute else mu[i][2]
        if friction:
            tau[i] += joint.viscous * qd[i] + joint.coulomb * sp.sign(qd[i])
    to_link = model.to_link
    return NewtonEulerResult(
        tau=sp.Matrix(tau),
        omega=[tidy(to_link[i] * w[i]) for i in range(n)],
        omega_dot=[tidy(to_link[i] * wd[i]) for i in range(n)],
        acc_com=[tidy(to_link[i] * a[i]) for i in range(n)],
        force=[tidy(to_link[i] * f[i]) for i in range(n)],
    )


@lru_cache(maxsize=32)
def full_equations(sr: SymbolicRobot) -> NewtonEulerResult:
    """NE(q, q̇, q̈; g_0) with symbolic rates and friction; τ compacted."""
    result = newton_euler(sr)
    tau = sp.Matrix([compact(e, angles(sr), collect_by=list(sr.qdd) + list(sr.qd), deep=True)
                     for e in result.tau])
    return result._replace(tau=tau)


@lru_cache(maxsize=32)
def inertia_matrix_ne(sr: SymbolicRobot) -> sp.Matrix:
    """B(q) column by column, B e_j = NE(q, 0, e_j; 0) (N2)."""
    n = sr.n
    zero = sp.zeros(n, 1)
    columns = [newton_euler(sr, zero, sp.eye(n)[:, j], sp.zeros(3, 1), friction=False).tau
               for j in range(n)]
    return compact_matrix(sp.Matrix.hstack(*columns), angles(sr), deep=True)


@lru_cache(maxsize=32)
def coriolis_vector_ne(sr: SymbolicRobot) -> sp.Matrix:
    """C(q, q̇) q̇ = NE(q, q̇, 0; 0) (N2), (n, 1)."""
    tau = newton_euler(sr, None, sp.zeros(sr.n, 1), sp.zeros(3, 1), friction=False).tau
    return compact_matrix(tau, angles(sr), collect_by=sr.qd, deep=True)


@lru_cache(maxsize=32)
def gravity_vector_ne(sr: SymbolicRobot) -> sp.Matrix:
    """g(q) = NE(q, 0, 0; g_0) (N2), (n, 1)."""
    zero = sp.zeros(sr.n, 1)
    return compact_matrix(newton_euler(sr, zero, zero, friction=False).tau, angles(sr), deep=True)
