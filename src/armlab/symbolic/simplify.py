"""Simplification to the compact forms a person would write, and operation counts.

Every sin q_i, cos q_i of a revolute joint becomes a symbol s_i, c_i, the expression is
expanded as a polynomial and reduced modulo s_i² + c_i² − 1 (s_i² → 1 − c_i²): an exact normal
form (zero iff the expression is identically zero) computed in time linear in the size of the
expression, unlike ``trigsimp``/``simplify``, which stall on large Christoffel sums.  From it
:func:`compact` keeps the shortest of a few equivalent forms — common factors pulled out,
collected on given symbols, factored (small expressions only), over a common denominator or
not — measured by ``count_ops``.
"""

from __future__ import annotations

import sympy as sp

SMALL = 400  # count_ops below which polynomial factoring is affordable


def count_ops(obj) -> int:
    """Number of arithmetic operations of an expression or of every entry of a matrix."""
    if isinstance(obj, sp.MatrixBase):
        return int(sum(sp.count_ops(e) for e in obj))
    if isinstance(obj, (list, tuple)):
        return int(sum(count_ops(e) for e in obj))
    return int(sp.count_ops(obj))


def trig_symbols(variables) -> dict:
    """{sin(q): s_q, cos(q): c_q} for every revolute variable."""
    table = {}
    for q in variables:
        table[sp.sin(q)] = sp.Symbol(f"s__{q}", real=True)
        table[sp.cos(q)] = sp.Symbol(f"c__{q}", real=True)
    return table


def _polynomial_form(expr, angles) -> tuple[sp.Expr, dict]:
    """(P, back): ``expr`` with sin/cos of ``angles`` as symbols, expanded and reduced modulo
    s² + c² − 1 (s^k → s^(k mod 2) (1 − c²)^(k // 2)); ``back`` maps the symbols back."""
    if angles and expr.has(sp.sin, sp.cos):
        expr = sp.expand_trig(expr)
    table = trig_symbols(angles)
    P = sp.expand(expr.xreplace(table))
    for q in angles:
        s, c = table[sp.sin(q)], table[sp.cos(q)]
        if P.has(s):
            P = sp.expand(P.replace(
                lambda e, s=s: e.is_Pow and e.base == s and e.exp.is_Integer and e.exp >= 2,
                lambda e, s=s, c=c: s ** (e.exp % 2) * (1 - c**2) ** (e.exp // 2)))
    return P, {v: k for k, v in table.items()}


def trig_poly_normal(expr, angles) -> sp.Expr:
    """Exact normal form of a polynomial in sin/cos of ``angles`` (zero iff ``expr`` ≡ 0)."""
    P, back = _polynomial_form(sp.sympify(expr), tuple(angles))
    return P.xreplace(back)


def compact(expr, angles=(), *, collect_by=(), deep: bool = False) -> sp.Expr:
    """A compact equivalent of ``expr``: the trigonometric-polynomial normal form of its
    numerator and denominator, with common factors pulled out, collected on ``collect_by``
    and, with ``deep``, factored; whichever of these has the fewest operations is returned.
    """
    expr = sp.sympify(expr)
    if expr.is_Number or expr.is_Symbol or not expr.free_symbols:
        return expr
    angles = tuple(angles)
    numerator, denominator = sp.fraction(sp.together(expr)) if deep else (expr, sp.Integer(1))
    P, back = _polynomial_form(numerator, angles)
    Q, _ = _polynomial_form(denominator, angles)
    candidates = [P, sp.factor_terms(P)]
    if collect_by:
        candidates.append(sp.collect(P, list(collect_by)))
    if deep and sp.count_ops(P) < SMALL:
        factored = sp.factor(P)
        candidates.append(factored)
        if collect_by:
            candidates.append(sp.collect(sp.factor_terms(P), list(collect_by), func=sp.factor))
    best = min(candidates, key=sp.count_ops)
    if Q != 1:
        Q = min([Q, sp.factor(Q)], key=sp.count_ops) if sp.count_ops(Q) < SMALL else Q
        best = best / Q
        # Over a common denominator is not always shorter (4π² I_m/p² + m stays a sum).
        P0, _ = _polynomial_form(expr, angles)
        alternatives = [P0, sp.factor_terms(P0)]
        if collect_by:
            alternatives.append(sp.collect(P0, list(collect_by)))
        best = min([best, *alternatives], key=sp.count_ops)
    return best.xreplace(back)


def compact_matrix(M, angles=(), *, collect_by=(), deep: bool = False) -> sp.Matrix:
    """:func:`compact` applied to every entry of ``M``."""
    return sp.Matrix(M).applyfunc(lambda e: compact(e, angles, collect_by=collect_by, deep=deep))


def is_zero(expr, angles=()) -> bool:
    """True when ``expr`` (scalar or matrix) is identically zero; exact, no sampling."""
    if isinstance(expr, sp.MatrixBase):
        return all(is_zero(e, angles) for e in expr)
    expr = sp.sympify(expr)
    if expr == 0:
        return True
    numerator, _ = sp.fraction(sp.together(expr))
    if trig_poly_normal(numerator, angles) == 0:
        return True
    return sp.simplify(expr) == 0
