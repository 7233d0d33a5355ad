"""A1 symbolically: DH tables, T_i^{i−1}, T_i^0, T_i^base, end-effector pose, inverse kinematics,
geometric and analytical (ZYZ) Jacobians.

    T_i^0 = A_1^0(q_1) ⋯ A_i^{i−1}(q_i),  T_e^0 = T_n^0 T_tool,  T_e^base = T_0^base T_e^0   (K2)
    J = [J_P; J_O],  J_P,i = z_{i−1} (prismatic) | z_{i−1} × (p_e − p_{i−1}),  J_O,i = 0 | z_{i−1}  (K3)
    J_A = ∂[p_e; φ_e]/∂q,  φ = ZYZ Euler angles of R_e                    (Siciliano (3.66))
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from armlab.symbolic.model import SymbolicRobot
from armlab.symbolic.simplify import compact, compact_matrix

FRAMES = ("0", "base")


def _check_frame(frame: str) -> str:
    if frame not in FRAMES:
        raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
    return frame


def angles(sr: SymbolicRobot) -> tuple:
    """The revolute joint variables (arguments of sin/cos)."""
    return tuple(j.q for j in sr.joints if j.revolute)


def dh_table(sr: SymbolicRobot, frame: str = "0") -> sp.Matrix | None:
    """Rows (a_i, α_i, d_i, θ_i) with the joint variables in place, (n, 4) — (n + 1, 4) from
    Σ_base when the base is itself a DH row; None for a robot not described by DH rows."""
    if any(j.dh is None for j in sr.joints):
        return None
    rows = [list(j.dh) for j in sr.joints]
    if _check_frame(frame) == "base" and sr.base_dh is not None:
        rows.insert(0, list(sr.base_dh))
    return sp.Matrix(rows)


@lru_cache(maxsize=32)
def relative_transforms(sr: SymbolicRobot) -> tuple[sp.Matrix, ...]:
    """T_i^{i−1}(q_i), i = 1…n, (4, 4) each (K1)."""
    return tuple(compact_matrix(j.transform(), angles(sr)) for j in sr.joints)


@lru_cache(maxsize=32)
def link_transforms(sr: SymbolicRobot, frame: str = "0") -> tuple[sp.Matrix, ...]:
    """T_i^0 (or T_i^base), i = 1…n, simplified after every product (K2)."""
    T = sp.eye(4) if _check_frame(frame) == "0" else sr.base
    result = []
    for A in relative_transforms(sr):
        T = compact_matrix(T * A, angles(sr))
        result.append(T)
    return tuple(result)


def end_effector_pose(sr: SymbolicRobot, frame: str = "0") -> sp.Matrix:
    """T_e^0 (or T_e^base) = T_n T_tool, (4, 4)."""
    return compact_matrix(link_transforms(sr, frame)[-1] * sr.tool, angles(sr))


def joint_axes(sr: SymbolicRobot, frame: str = "0") -> list[tuple[sp.Matrix, sp.Matrix]]:
    """(z, p) of every joint axis in ``frame``: the axis direction and a point on it."""
    T = sp.eye(4) if _check_frame(frame) == "0" else sr.base
    axes = []
    for joint, A in zip(sr.joints, relative_transforms(sr), strict=True):
        axis_frame = T * joint.before
        axes.append((compact_matrix(axis_frame[:3, 2], angles(sr)),
                     compact_matrix(axis_frame[:3, 3], angles(sr))))
        T = T * A
    return axes


@lru_cache(maxsize=32)
def geometric_jacobian(sr: SymbolicRobot, frame: str = "0") -> sp.Matrix:
    """Geometric Jacobian [J_P; J_O], (6, n), of Σ_e's origin, expressed in ``frame`` (K3)."""
    p_e = end_effector_pose(sr, frame)[:3, 3]
    columns = []
    for joint, (z, p) in zip(sr.joints, joint_axes(sr, frame), strict=True):
        if joint.revolute:
            columns.append(z.cross(p_e - p).col_join(z))
        else:
            columns.append(z.col_join(sp.zeros(3, 1)))
    return compact_matrix(sp.Matrix.hstack(*columns), angles(sr))


def euler_zyz(R: sp.Matrix, angle_symbols=()) -> sp.Matrix:
    """ZYZ Euler angles (φ, ϑ, ψ) of R on the branch sin ϑ > 0 (Siciliano (2.19)).

        φ = atan2(r23, r13),  ϑ = atan2(√(r13² + r23²), r33),  ψ = atan2(r32, −r31)
    """
    def s(e):
        return compact(e, angle_symbols)

    return sp.Matrix([sp.atan2(s(R[1, 2]), s(R[0, 2])),
                      sp.atan2(s(sp.sqrt(R[0, 2] ** 2 + R[1, 2] ** 2)), s(R[2, 2])),
                      sp.atan2(s(R[2, 1]), s(-R[2, 0]))])


@lru_cache(maxsize=32)
def analytical_jacobian(sr: SymbolicRobot, frame: str = "0") -> tuple[sp.Matrix, sp.Matrix]:
    """(J_A, φ_e): J_A = ∂[p_e; φ_e]/∂q, (6, n), with φ_e the ZYZ angles of R_e in ``frame``.

    Differentiating atan2 gives rational functions of the rotation entries that simplify to
    the closed form; where the representation is singular (sin ϑ = 0) J_A is undefined.
    """
    T = end_effector_pose(sr, frame)
    phi = euler_zyz(T[:3, :3], angles(sr))
    x = T[:3, 3].col_join(phi)
    J_A = x.jacobian(sr.q)
    # √(sin²) = |sin| and its derivative sign(sin) appear when R_e turns about a fixed axis;
    # on the branch where those arguments are positive they are the arguments and 1.
    J_A = J_A.replace(sp.Abs, lambda a: a).replace(sp.sign, lambda a: sp.Integer(1))
    phi = phi.replace(sp.Abs, lambda a: a)
    return compact_matrix(J_A, angles(sr)), phi


def analytical_jacobian_formula(sr: SymbolicRobot, frame: str = "0") -> tuple[sp.Matrix, sp.Matrix]:
    """(J_A, T⁻¹(φ)): J_A = blockdiag(I₃, T⁻¹(φ)) J with the ZYZ angles φ = (φ, ϑ, ψ) kept as
    symbols (Siciliano (3.66)) — the form that stays small for six joints, where
    differentiating φ_e(q) does not."""
    a, b, _ = sp.symbols("varphi vartheta psi", real=True)
    T = sp.Matrix([[0, -sp.sin(a), sp.cos(a) * sp.sin(b)],
                   [0, sp.cos(a), sp.sin(a) * sp.sin(b)],
                   [1, 0, sp.cos(b)]])
    T_inv = sp.simplify(T.inv())
    J = geometric_jacobian(sr, frame)
    return J[:3, :].col_join(T_inv * J[3:, :]), T_inv


def position_inverse_kinematics(sr: SymbolicRobot, frame: str = "0", position=None) -> list[dict]:
    """Every closed-form solution q(p) of p_e(q) = p, as a list of {q_i: expression}.

    sin q_i, cos q_i of each revolute joint become unknowns s_i, c_i tied by s_i² + c_i² = 1,
    so the position equations are polynomial and SymPy's solver returns every branch; each
    angle is then atan2(s_i, c_i).  Attempted for robots of up to three joints whose
    position depends on n coordinates; an empty list means no closed form was found.
    """
    if sr.n > 3:
        return []
    p = sp.Matrix(position) if position is not None else sp.Matrix(sp.symbols("p_x p_y p_z", real=True))
    p_e = end_effector_pose(sr, frame)[:3, 3]
    rows = [k for k in range(3) if p_e[k].free_symbols & set(sr.q)]
    if len(rows) != sr.n:
        return []
    unknowns, table = [], {}
    for joint in sr.joints:
        if joint.revolute:
            s, c = sp.symbols(f"s_{joint.q} c_{joint.q}", real=True)
            table[joint.q] = (s, c)
            unknowns += [s, c]
        else:
            unknowns.append(joint.q)
    equations = []
    for k in rows:
        e = sp.expand(sp.expand_trig(p_e[k] - p[k]))
        for q, (s, c) in table.items():
            e = e.subs({sp.sin(q): s, sp.cos(q): c})
        equations.append(e)
    equations += [s**2 + c**2 - 1 for s, c in table.values()]
    solutions = sp.solve(equations, unknowns, dict=True)
    result = []
    for solution in solutions:
        branch = {}
        for joint in sr.joints:
            if joint.revolute:
                s, c = table[joint.q]
                branch[joint.q] = _atan2(sp.simplify(solution.get(s, s)), sp.simplify(solution.get(c, c)))
            else:
                branch[joint.q] = sp.simplify(solution.get(joint.q, joint.q))
        result.append(branch)
    return result


def _atan2(y, x):
    """atan2(y, x) with a common non-negative denominator (a square root) cancelled."""
    (ny, dy), (nx, dx) = sp.fraction(sp.together(y)), sp.fraction(sp.together(x))
    if dy == dx and (dy.is_nonnegative or isinstance(dy, sp.Pow) and dy.exp == sp.S.Half):
        return sp.atan2(ny, nx)
    return sp.atan2(y, x)
