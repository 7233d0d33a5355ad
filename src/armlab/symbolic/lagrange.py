"""A3 symbolically: Lagrangian, equations of motion, C(q, q̇) by Christoffel symbols, g(q).

    ℒ = T − U,   d/dt (∂ℒ/∂q̇)ᵀ − (∂ℒ/∂q)ᵀ + F_v q̇ + F_s sgn(q̇) = τ                      (L1)
    c_ijk = ½ (∂b_ij/∂q_k + ∂b_ik/∂q_j − ∂b_jk/∂q_i),   C_ij = Σ_k c_ijk q̇_k               (D4)
    g(q) = (∂U/∂q)ᵀ                                                                        (L2)
    N = Ḃ − 2C is skew-symmetric:  N + Nᵀ = 0                                              (L3)

Time derivatives use the chain rule d/dt f(q, q̇) = Σ_k ∂f/∂q_k q̇_k + ∂f/∂q̇_k q̈_k (the joint
variables are plain symbols, which keeps every printed formula free of "(t)").
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from armlab.symbolic.energy import inertia_matrix, kinetic_energy, potential_energy
from armlab.symbolic.kinematics import angles
from armlab.symbolic.model import SymbolicRobot
from armlab.symbolic.simplify import compact, compact_matrix


def time_derivative(expr, sr: SymbolicRobot):
    """d/dt of an expression (or matrix) of q, q̇ by the chain rule."""
    if isinstance(expr, sp.MatrixBase):
        return expr.applyfunc(lambda e: time_derivative(e, sr))
    return sum((sp.diff(expr, j.q) * j.qd + sp.diff(expr, j.qd) * j.qdd for j in sr.joints),
               sp.Integer(0))


def lagrangian(sr: SymbolicRobot) -> sp.Expr:
    """ℒ = T − U."""
    return compact(kinetic_energy(sr) - potential_energy(sr), angles(sr), collect_by=sr.qd)


@lru_cache(maxsize=32)
def equations_of_motion(sr: SymbolicRobot) -> sp.Matrix:
    """τ(q, q̇, q̈) of (L1), (n, 1), friction included."""
    L = kinetic_energy(sr) - potential_energy(sr)
    tau = []
    for j in sr.joints:
        term = time_derivative(sp.diff(L, j.qd), sr) - sp.diff(L, j.q)
        term += j.viscous * j.qd + j.coulomb * sp.sign(j.qd)
        tau.append(compact(term, angles(sr), collect_by=list(sr.qdd) + list(sr.qd), deep=True))
    return sp.Matrix(tau)


def christoffel_symbols(sr: SymbolicRobot, B: sp.Matrix | None = None) -> list:
    """c[i][j][k] of (D4) from B (default: the compact B of A2)."""
    B = inertia_matrix(sr) if B is None else B
    q = list(sr.q)
    n = sr.n
    dB = [B.diff(qk) for qk in q]
    return [[[(dB[k][i, j] + dB[j][i, k] - dB[i][j, k]) / 2 for k in range(n)]
             for j in range(n)] for i in range(n)]


@lru_cache(maxsize=32)
def coriolis_matrix(sr: SymbolicRobot) -> sp.Matrix:
    """C(q, q̇) of (D4), (n, n), compact."""
    c = christoffel_symbols(sr)
    n = sr.n
    C = sp.Matrix(n, n, lambda i, j: sum((c[i][j][k] * sr.qd[k] for k in range(n)), sp.Integer(0)))
    return compact_matrix(C, angles(sr), collect_by=sr.qd, deep=True)


@lru_cache(maxsize=32)
def gravity_vector(sr: SymbolicRobot) -> sp.Matrix:
    """g(q) = (∂U/∂q)ᵀ of (L2), (n, 1)."""
    U = potential_energy(sr)
    return compact_matrix(sp.Matrix([sp.diff(U, q) for q in sr.q]), angles(sr), deep=True)


def skew_check(sr: SymbolicRobot) -> tuple[sp.Matrix, sp.Matrix]:
    """(N, N + Nᵀ) of (L3) with N = Ḃ − 2C; the second is the zero matrix."""
    N = time_derivative(inertia_matrix(sr), sr) - 2 * coriolis_matrix(sr)
    N = compact_matrix(N, angles(sr), collect_by=sr.qd)
    return N, compact_matrix(N + N.T, angles(sr))
