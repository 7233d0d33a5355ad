"""B, C, g of larger arms (Puma 560) in compact form, in seconds: Newton–Euler over a
polynomial ring.

Christoffel symbols of an unsimplified B run to millions of operations for six joints, and
simplifying them afterwards does not finish.  Here instead:

1. every sin q_i, cos q_i becomes a generator s_i, c_i of the polynomial ring
   ℚ[s_i, c_i, prismatic q_i, parameters, q̇, q̈] (SymPy's sparse ``PolyRing``: dictionary
   arithmetic, orders of magnitude faster than expression trees);
2. the recursive Newton–Euler law (N1) of :mod:`armlab.symbolic.newton_euler` runs once
   with symbolic q̇, q̈ and every product is reduced modulo s_i² + c_i² − 1, so each
   intermediate quantity stays in its unique, expanded normal form — simplification happens
   along the way, never on a swollen result;
3. B, g and C are read off the one result τ(q, q̇, q̈):

        B = ∂τ/∂q̈,   g = τ|_{q̇ = 0, q̈ = 0},   C = ½ ∂(C q̇)/∂q̇,   C q̇ = τ − B q̈ − g      (N3)

   the last because (C q̇)_i = Σ_jk c_ijk q̇_j q̇_k with c_ijk = c_ikj, so
   ∂(C q̇)_i/∂q̇_j = 2 Σ_k c_ijk q̇_k = 2 C_ij: the Christoffel C without differentiating B.

The operation count is reported for the expanded normal form and for the same expressions
with common subexpressions shared (``sympy.cse``), the form code generation compiles.
"""

from __future__ import annotations

from typing import NamedTuple

import sympy as sp
from sympy.polys.rings import ring

from armlab.model.robot import Robot
from armlab.symbolic.model import SymbolicRobot, symbolic_robot
from armlab.symbolic.newton_euler import joint_frame_model
from armlab.symbolic.simplify import count_ops


class CompactDynamics(NamedTuple):
    """B (n, n), C (n, n) (Christoffel), g (n, 1) as SymPy matrices, with operation counts:
    ``ops`` of the expanded normal forms, ``ops_cse`` with shared subexpressions."""

    B: sp.Matrix
    C: sp.Matrix
    g: sp.Matrix
    ops: dict
    ops_cse: int


class _Ring:
    """The polynomial ring of one robot with the trigonometric reduction."""

    def __init__(self, sr: SymbolicRobot, expressions):
        self.table = {}
        for joint in sr.joints:
            if joint.revolute:
                self.table[sp.sin(joint.q)] = sp.Symbol(f"s_{joint.q}", real=True)
                self.table[sp.cos(joint.q)] = sp.Symbol(f"c_{joint.q}", real=True)
        trig = list(self.table.values())
        others = set()
        for e in expressions:
            e = self.to_symbols(e)
            if e.free_symbols or not e.is_Rational:
                others |= set(sp.Poly(e).gens)
        others -= set(trig)
        others -= set(sr.qd) | set(sr.qdd)
        extra = sorted(others, key=str)
        self.gens = trig + extra + list(sr.qd) + list(sr.qdd)
        self.R, *elements = ring(self.gens, sp.QQ)
        self.element = dict(zip(self.gens, elements, strict=True))
        # s_i² + c_i² − 1 for every revolute joint: with s_i ahead of c_i in the lex order,
        # the remainder modulo these replaces s_i² by 1 − c_i².
        sin_cos = [(self.element[self.table[sp.sin(j.q)]], self.element[self.table[sp.cos(j.q)]])
                   for j in sr.joints if j.revolute]
        self.ideal = [s**2 + c**2 - 1 for s, c in sin_cos]
        self.back = {v: k for k, v in self.table.items()}

    def to_symbols(self, expr):
        return sp.expand(sp.expand_trig(sp.sympify(expr))).xreplace(self.table)

    def __call__(self, expr):
        if expr == 0:
            return self.R.zero
        poly = sp.Poly(self.to_symbols(expr), *self.gens, domain=sp.QQ)
        return self.R.from_dict({m: sp.QQ.convert(c) for m, c in poly.as_dict().items()})

    def reduce(self, p):
        return p.rem(self.ideal) if self.ideal else p

    def to_expr(self, p):
        return p.as_expr().xreplace(self.back)


def _vec(ring_, v):
    return [ring_(e) for e in v]


def _mat(ring_, M):
    return [[ring_(M[r, c]) for c in range(3)] for r in range(3)]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _add(*vectors):
    return [sum(parts[1:], parts[0]) for parts in zip(*vectors, strict=True)]


def _scale(k, v):
    return [k * e for e in v]


def _mul(M, v):
    return [M[r][0] * v[0] + M[r][1] * v[1] + M[r][2] * v[2] for r in range(3)]


def _mul_t(M, v):
    return [M[0][r] * v[0] + M[1][r] * v[1] + M[2][r] * v[2] for r in range(3)]


def _newton_euler_ring(sr: SymbolicRobot, K: _Ring):
    """τ(q, q̇, q̈; g_0) of (N1) in the ring, friction excluded, every product reduced."""
    model = joint_frame_model(sr)
    red = K.reduce

    def tidy(v):
        return [red(e) for e in v]

    n = sr.n
    R = [_mat(K, M) for M in model.R]
    p = [_vec(K, v) for v in model.p]
    com = [_vec(K, v) for v in model.com]
    inertia = [_mat(K, M) for M in model.inertia]
    axis = [_vec(K, v) for v in model.rotor_axis]
    point = [_vec(K, v) for v in model.motor_point]
    mass = [K(link.mass) for link in sr.links]
    qd = [K.element[s] for s in sr.qd]
    qdd = [K.element[s] for s in sr.qdd]
    zero = [K.R.zero] * 3
    w_prev, wd_prev, a_prev = zero, zero, _scale(-1, _vec(K, sr.gravity))
    w, wd, a, f, mu = [], [], [], [], []
    for i, joint in enumerate(sr.joints):
        t = a_prev if i == 0 else _add(a_prev, _cross(wd_prev, p[i]), _cross(w_prev, _cross(w_prev, p[i])))
        wi, wdi, ai = tidy(_mul_t(R[i], w_prev)), tidy(_mul_t(R[i], wd_prev)), tidy(_mul_t(R[i], t))
        if joint.revolute:
            wdi = [wdi[0] + qd[i] * wi[1], wdi[1] - qd[i] * wi[0], wdi[2] + qdd[i]]
            wi = [wi[0], wi[1], wi[2] + qd[i]]
        else:
            ai = [ai[0] + 2 * qd[i] * wi[1], ai[1] - 2 * qd[i] * wi[0], ai[2] + qdd[i]]
        c = com[i]
        a_c = tidy(_add(ai, _cross(wdi, c), _cross(wi, _cross(wi, c))))
        F = _scale(mass[i], a_c)
        Iw = _mul(inertia[i], wi)
        w.append(wi)
        wd.append(wdi)
        a.append(ai)
        f.append(F)
        mu.append(tidy(_add(_mul(inertia[i], wdi), _cross(wi, Iw), _cross(c, F))))
        w_prev, wd_prev, a_prev = wi, wdi, ai
    tau = [K.R.zero] * n
    first = sr.joints[0]
    tau[0] = K(first.gear_ratio**2 * first.rotor_inertia) * qdd[0]
    for i in range(1, n):
        joint = sr.joints[i]
        if joint.motor_mass != 0:
            r = point[i]
            a_m = _add(a[i - 1], _cross(wd[i - 1], r), _cross(w[i - 1], _cross(w[i - 1], r)))
            F_m = _scale(K(joint.motor_mass), a_m)
            f[i - 1] = _add(f[i - 1], F_m)
            mu[i - 1] = _add(mu[i - 1], _cross(r, F_m))
        if joint.rotor_inertia != 0:
            z = axis[i]
            kr, Im = K(joint.gear_ratio), K(joint.rotor_inertia)
            spin = sum((z[k] * w[i - 1][k] for k in range(3)), K.R.zero) + kr * qd[i]
            rate = sum((z[k] * wd[i - 1][k] for k in range(3)), K.R.zero) + kr * qdd[i]
            mu[i - 1] = _add(mu[i - 1], _scale(Im, _add(_scale(rate, z), _scale(spin, _cross(w[i - 1], z)))))
            tau[i] = kr * Im * rate
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            child = _mul(R[i + 1], f[i + 1])
            f[i] = _add(f[i], child)
            mu[i] = _add(mu[i], _mul(R[i + 1], mu[i + 1]), _cross(p[i + 1], child))
        f[i], mu[i] = tidy(f[i]), tidy(mu[i])
        tau[i] = red(tau[i] + (mu[i][2] if sr.joints[i].revolute else f[i][2]))
    return tau


def compact_dynamics(robot: Robot | SymbolicRobot, *, numeric: bool = False) -> CompactDynamics:
    """B, C, g of ``robot`` by (N3) — the route that scales to six joints."""
    sr = robot if isinstance(robot, SymbolicRobot) else symbolic_robot(robot, numeric=numeric)
    model = joint_frame_model(sr)
    expressions = [e for M in (*model.R, *model.p, *model.com, *model.inertia, *model.rotor_axis,
                               *model.motor_point) for e in M]
    expressions += [link.mass for link in sr.links] + list(sr.gravity)
    expressions += [j.gear_ratio**2 * j.rotor_inertia + j.motor_mass for j in sr.joints]
    K = _Ring(sr, expressions)
    tau = _newton_euler_ring(sr, K)
    n = sr.n
    qd = [K.element[s] for s in sr.qd]
    qdd = [K.element[s] for s in sr.qdd]
    B = [[tau[i].diff(qdd[j]) for j in range(n)] for i in range(n)]
    rest = [tau[i] - sum((B[i][j] * qdd[j] for j in range(n)), K.R.zero) for i in range(n)]
    g = [e.subs([(x, 0) for x in qd]) for e in rest]
    c_qd = [rest[i] - g[i] for i in range(n)]
    C = [[c_qd[i].diff(qd[j]) * sp.Rational(1, 2) for j in range(n)] for i in range(n)]
    # Common factors out of B and g, C collected on the rates it is linear in.
    B_m = sp.Matrix(n, n, lambda i, j: sp.factor_terms(K.to_expr(B[i][j])))
    C_m = sp.Matrix(n, n, lambda i, j: sp.collect(K.to_expr(C[i][j]), list(sr.qd)))
    g_m = sp.Matrix([sp.factor_terms(K.to_expr(e)) for e in g])
    ops = {"B": count_ops(B_m), "C": count_ops(C_m), "g": count_ops(g_m)}
    replacements, reduced = sp.cse(list(B_m) + list(C_m) + list(g_m), order="none")
    ops_cse = sum(count_ops(e) for _, e in replacements) + count_ops(reduced)
    return CompactDynamics(B_m, C_m, g_m, ops, ops_cse)
