"""A5 symbolically: the dynamic model in operational space (Siciliano et al. §7.8).

With x the task coordinates (rows of x = [p_e; φ_e] chosen below) and J_A = ∂x/∂q square:

    B_A = J_A⁻ᵀ B J_A⁻¹,   C_A ẋ = J_A⁻ᵀ C q̇ − B_A J̇_A q̇,   g_A = J_A⁻ᵀ g               (O1)
    T_A(φ) = blockdiag(I₃, T(φ)),  v = T_A(φ) ẋ,  u = T_Aᵀ h                              (O2)

Rows: a robot with n < 6 joints cannot control six task coordinates, so the first n rows of
x (position first, then φ, ψ, ϑ order of x) that raise the rank of J_A are used — for the PRP
the three position rows (x = p_e), for a planar 2R arm (p_x, p_y).  Then T_A restricted to
those rows is the identity.  (The seed stacked a 6×3 J_A and a permuted T_A instead; its B_A is
then not defined — J_A has no inverse.)
"""

from __future__ import annotations

import random
from functools import lru_cache
from typing import NamedTuple

import sympy as sp

from armlab.symbolic.energy import inertia_matrix
from armlab.symbolic.kinematics import analytical_jacobian, angles
from armlab.symbolic.lagrange import coriolis_matrix, gravity_vector, time_derivative
from armlab.symbolic.model import SymbolicRobot
from armlab.symbolic.simplify import compact_matrix

TASK_LABELS = ("p_x", "p_y", "p_z", "φ", "ϑ", "ψ")


def euler_rate_matrix(phi=None) -> tuple[sp.Matrix, sp.Matrix]:
    """(T_A(φ), φ): ZYZ T(φ) = [[0, −sφ, cφ sϑ], [0, cφ, sφ sϑ], [1, 0, cϑ]] in (O2)."""
    if phi is None:
        phi = sp.Matrix(sp.symbols("varphi vartheta psi", real=True))
    a, b, _ = phi
    T = sp.Matrix([[0, -sp.sin(a), sp.cos(a) * sp.sin(b)],
                   [0, sp.cos(a), sp.sin(a) * sp.sin(b)],
                   [1, 0, sp.cos(b)]])
    return sp.diag(sp.eye(3), T), phi


def task_rows(sr: SymbolicRobot, frame: str = "0") -> list[int]:
    """Indices of the n rows of x = [p; φ] whose Jacobian rows are independent (generic q)."""
    J_A, _ = analytical_jacobian(sr, frame)
    rng = random.Random(1)
    point = {s: sp.Rational(rng.randint(11, 97), 37) for s in J_A.free_symbols}
    numeric = J_A.xreplace(point).evalf()
    rows: list[int] = []
    for k in range(6):
        trial = numeric.extract(rows + [k], list(range(sr.n)))
        if trial.rank(iszerofunc=lambda e: abs(e) < 1e-9) == len(rows) + 1:
            rows.append(k)
        if len(rows) == sr.n:
            break
    return rows


class OperationalModel(NamedTuple):
    """(O1) on the task ``rows``: J_A, its inverse and T_A; B_A, C_A ẋ, g_A in full, and the
    same written with the entries b_ij, (C q̇)_i, g_i of A2–A3 as symbols (``named``: a dict
    of the compact forms and ``definitions`` {symbol: expression})."""

    rows: list
    J_A: sp.Matrix
    J_inv: sp.Matrix
    T_A: sp.Matrix
    B_A: sp.Matrix
    C_A_xd: sp.Matrix
    g_A: sp.Matrix
    named: dict
    definitions: dict


def _named(M: sp.Matrix, letter: str, symmetric: bool = False) -> tuple[sp.Matrix, dict]:
    """M with each non-constant entry replaced by a symbol letter_ij (letter_i for vectors)."""
    definitions = {}

    def entry(i, j):
        e = M[i, j]
        if e.is_number:
            return e
        a, b = (min(i, j), max(i, j)) if symmetric else (i, j)
        name = f"{letter}_{a + 1}{b + 1}" if M.cols > 1 else f"{letter}_{a + 1}"
        symbol = sp.Symbol(name, real=True)
        definitions[symbol] = e
        return symbol

    return sp.Matrix(M.rows, M.cols, entry), definitions


@lru_cache(maxsize=32)
def operational_model(sr: SymbolicRobot, frame: str = "0") -> OperationalModel | None:
    """B_A, C_A ẋ, g_A of (O1) on the task rows; None when they cannot form a square J_A."""
    rows = task_rows(sr, frame)
    if len(rows) != sr.n:
        return None
    J_full, phi = analytical_jacobian(sr, frame)
    J_A = J_full.extract(rows, list(range(sr.n)))
    ang = angles(sr)
    J_inv = compact_matrix(J_A.inv(method="LU"), ang, deep=True)
    J_dot_qd = compact_matrix(time_derivative(J_A, sr) * sr.qd, ang)
    B, C_qd, g = inertia_matrix(sr), coriolis_matrix(sr) * sr.qd, gravity_vector(sr)
    B_n, defs_B = _named(B, "b", symmetric=True)
    C_n, defs_C = _named(compact_matrix(C_qd, ang), "h")
    g_n, defs_g = _named(g, "g")
    # With B, C q̇, g as letters the plain products are already the compact forms: expanding
    # them (as the normal form does) would multiply out J_A⁻¹'s denominators.
    named = {"B_A": (J_inv.T * B_n * J_inv).applyfunc(sp.factor_terms)}
    named["C_A_xd"] = (J_inv.T * C_n - named["B_A"] * J_dot_qd).applyfunc(sp.factor_terms)
    named["g_A"] = (J_inv.T * g_n).applyfunc(sp.factor_terms)
    definitions = {**defs_B, **defs_C, **defs_g}
    B_A = compact_matrix(J_inv.T * B * J_inv, ang, deep=True)
    C_A_xd = compact_matrix(J_inv.T * C_qd - B_A * J_dot_qd, ang, deep=True)
    g_A = compact_matrix(J_inv.T * g, ang, deep=True)
    T_full, _ = euler_rate_matrix(phi)
    T_A = T_full.extract(rows, rows)
    return OperationalModel(rows, J_A, J_inv, compact_matrix(T_A, ang), B_A, C_A_xd, g_A, named,
                            definitions)
