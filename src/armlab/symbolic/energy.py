"""A2 symbolically: Steiner's theorem, link inertias, partial Jacobians, kinetic and potential
energy, B(q) (Siciliano et al. §7.2).

    T = Σ_i ½ m_i ṗ_Cᵢᵀ ṗ_Cᵢ + ½ ω_iᵀ R_i I_Cᵢ R_iᵀ ω_i + Σ_i T_mᵢ = ½ q̇ᵀ B(q) q̇          (D6)
    ṗ_Cᵢ = J_P^{ℓi} q̇,  ω_i = J_O^{ℓi} q̇                                                  (D11)
    T_mᵢ = ½ I_mᵢ (z_mᵢᵀ ω_{i−1} + k_rᵢ q̇_i)² + ½ m_mᵢ ṗ_mᵢᵀ ṗ_mᵢ                          (D3)
    U = −Σ_i m_i g_0ᵀ p_Cᵢ − Σ_i m_mᵢ g_0ᵀ p_mᵢ                                             (D7)

Motor i (Siciliano §7.2) sits on link i−1 at joint i's origin p_mᵢ: a point mass m_mᵢ and a
rotor of axial inertia I_mᵢ spinning at k_rᵢ q̇_i relative to link i−1 (motor 1 is on the
fixed base, so only its spin counts).

The link's own term uses the velocity of its centre of mass and the inertia *about the centre
of mass* (König); an inertia about another point (the Steiner-shifted tensor of the seed's
A2) may only be paired with that point's velocity — mixing the two counts m r² twice.
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from armlab.symbolic.expressions import skew
from armlab.symbolic.kinematics import angles, joint_axes, link_transforms
from armlab.symbolic.model import SymbolicRobot
from armlab.symbolic.simplify import compact, compact_matrix


def steiner_identity() -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
    """(lhs, rhs, lhs − rhs) of I_C + m Sᵀ(r) S(r) = I_C + m (rᵀr I₃ − r rᵀ) with a general
    symmetric I_C, mass m and offset r = (r_x, r_y, r_z); the difference expands to zero."""
    m = sp.Symbol("m", positive=True)
    r = sp.Matrix(sp.symbols("r_x r_y r_z", real=True))
    names = [["xx", "xy", "xz"], ["xy", "yy", "yz"], ["xz", "yz", "zz"]]
    I_C = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"I_C{names[i][j]}", real=True))
    lhs = I_C + m * skew(r).T * skew(r)
    rhs = I_C + m * ((r.T * r)[0] * sp.eye(3) - r * r.T)
    return lhs, rhs, sp.expand(lhs - rhs)


def inertia_about_origin(sr: SymbolicRobot, i: int) -> sp.Matrix:
    """Link i's inertia about Σ_i's origin (Steiner): I_C + m (r_Cᵀ r_C I₃ − r_C r_Cᵀ), Σ_i axes."""
    link = sr.links[i]
    r = link.com
    return compact_matrix(link.inertia + link.mass * ((r.T * r)[0] * sp.eye(3) - r * r.T))


@lru_cache(maxsize=32)
def com_positions(sr: SymbolicRobot) -> tuple[sp.Matrix, ...]:
    """p_Cᵢ in Σ_0, (3, 1) each."""
    return tuple(compact_matrix((T * link.com.col_join(sp.Matrix([1])))[:3, :], angles(sr))
                 for T, link in zip(link_transforms(sr), sr.links, strict=True))


@lru_cache(maxsize=32)
def partial_jacobians(sr: SymbolicRobot) -> tuple[tuple[sp.Matrix, sp.Matrix], ...]:
    """(J_P^{ℓi}, J_O^{ℓi}), (3, n) each, in Σ_0 (D11): J_P = ∂p_Cᵢ/∂q, J_O columns z_{j−1}
    for revolute j ≤ i."""
    axes = joint_axes(sr)
    result = []
    for i, p_c in enumerate(com_positions(sr)):
        J_P = compact_matrix(p_c.jacobian(sr.q), angles(sr))
        J_O = sp.zeros(3, sr.n)
        for j in range(i + 1):
            if sr.joints[j].revolute:
                J_O[:, j] = axes[j][0]
        result.append((J_P, J_O))
    return tuple(result)


def world_inertia(sr: SymbolicRobot, i: int) -> sp.Matrix:
    """R_i I_Cᵢ R_iᵀ: link i's inertia about its COM with Σ_0's axes."""
    R = link_transforms(sr)[i][:3, :3]
    return compact_matrix(R * sr.links[i].inertia * R.T, angles(sr))


@lru_cache(maxsize=32)
def kinetic_energies(sr: SymbolicRobot) -> tuple[tuple[sp.Expr, ...], tuple[sp.Expr, ...]]:
    """(links, rotors): T_ℓᵢ of (D6) and T_mᵢ of (D3) for every i (rotors all 0 without motors)."""
    qd = sr.qd
    links, rotors = [], []
    axes = joint_axes(sr)
    omegas = []
    for i, (J_P, J_O) in enumerate(partial_jacobians(sr)):
        v, w = J_P * qd, J_O * qd
        omegas.append(w)
        T_i = (sr.links[i].mass * (v.T * v)[0] + (w.T * world_inertia(sr, i) * w)[0]) / 2
        links.append(compact(T_i, angles(sr), collect_by=sr.qd, deep=True))
    for i, joint in enumerate(sr.joints):
        w_prev = omegas[i - 1] if i > 0 else sp.zeros(3, 1)
        spin = (axes[i][0].T * w_prev)[0] + joint.gear_ratio * joint.qd
        T_m = joint.rotor_inertia * spin**2 / 2
        if i > 0 and joint.motor_mass != 0:
            v_m = axes[i][1].jacobian(sr.q) * qd
            T_m += joint.motor_mass * (v_m.T * v_m)[0] / 2
        rotors.append(compact(T_m, angles(sr)))
    return tuple(links), tuple(rotors)


@lru_cache(maxsize=32)
def inertia_matrix(sr: SymbolicRobot) -> sp.Matrix:
    """B(q) = ∂²T/∂q̇², (n, n), in compact form (D6)."""
    links, rotors = kinetic_energies(sr)
    T = sum(links, sp.Integer(0)) + sum(rotors, sp.Integer(0))
    return compact_matrix(sp.hessian(sp.expand(T), list(sr.qd)), angles(sr), deep=True)


@lru_cache(maxsize=32)
def potential_energies(sr: SymbolicRobot) -> tuple[sp.Expr, ...]:
    """U_ℓᵢ = −m_i g_0ᵀ p_Cᵢ (D7), plus −m_m,i+1 g_0ᵀ p_m,i+1 of the motor link i carries."""
    axes = joint_axes(sr)
    result = []
    for i, (link, p) in enumerate(zip(sr.links, com_positions(sr), strict=True)):
        U = -link.mass * (sr.gravity.T * p)[0]
        if i + 1 < sr.n and sr.joints[i + 1].motor_mass != 0:
            U -= sr.joints[i + 1].motor_mass * (sr.gravity.T * axes[i + 1][1])[0]
        result.append(compact(U, angles(sr)))
    return tuple(result)


def kinetic_energy(sr: SymbolicRobot) -> sp.Expr:
    """T(q, q̇) = ½ q̇ᵀ B q̇ in compact form."""
    return compact((sr.qd.T * inertia_matrix(sr) * sr.qd)[0] / 2, angles(sr), collect_by=sr.qd)


def potential_energy(sr: SymbolicRobot) -> sp.Expr:
    return compact(sum(potential_energies(sr), sp.Integer(0)), angles(sr))
