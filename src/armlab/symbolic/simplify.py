"""Simplification to the compact forms a person would write, and operation counts.

Two routes, chosen by size:

* small expressions (the PRP, planar arms): ``trigsimp`` then factoring of common symbols;
* large ones (six-joint arms): a *trigonometric-polynomial* normal form — every sin q_i,
  cos q_i becomes a symbol s_i, c_i, the polynomial is expanded, reduced modulo
  s_i² + c_i² − 1 (s_i² → 1 − c_i²) and collected; this is exact, linear in the size of
  the expression and never blows up the way ``simplify`` does on a million-operation
  Christoffel sum.
"""

from __future__ import annotations

import sympy as sp

SMALL = 400  # count_ops below which the general-purpose simplifiers are affordable


def count_ops(obj) -> int:
    """Number of arithmetic operations of an expression or of every entry of a matrix."""
    if isinstance(obj, sp.MatrixBase):
        return int(sum(sp.count_ops(e) for e in obj))
    if isinstance(obj, (list, tuple)):
        return int(sum(count_ops(e) for e in obj))
    return int(sp.count_ops(obj))


def trig_symbols(expr, variables) -> dict:
    """{sin(q): s_q, cos(q): c_q} for every revolute variable appearing in ``expr``."""
    table = {}
    for q in variables:
        table[sp.sin(q)] = sp.Symbol(f"s__{q}", real=True)
        table[sp.cos(q)] = sp.Symbol(f"c__{q}", real=True)
    return table


def trig_poly_normal(expr, angles) -> sp.Expr:
    """Exact normal form of a polynomial in sin/cos of ``angles`` (s_i² → 1 − c_i²)."""
    expr = sp.expand(sp.expand_trig(expr)) if expr.has(*[sp.sin, sp.cos]) else sp.expand(expr)
    table = trig_symbols(expr, angles)
    poly_expr = expr.xreplace(table)
    back = {v: k for k, v in table.items()}
    for q in angles:
        s, c = table[sp.sin(q)], table[sp.cos(q)]
        if poly_expr.has(s):
            poly_expr = sp.expand(_reduce_square(poly_expr, s, c))
    return poly_expr.xreplace(back)


def _reduce_square(expr, s, c):
    """Replace s^k (k ≥ 2) by s^(k mod 2) (1 − c²)^(k // 2)."""
    def repl(power):
        base, exp = power.as_base_exp()
        if base == s and exp.is_Integer and exp >= 2:
            return s ** (exp % 2) * (1 - c**2) ** (exp // 2)
        return power
    return expr.replace(lambda e: e.is_Pow and e.base == s, repl)


def compact(expr, angles=(), *, collect_by=(), deep: bool = False) -> sp.Expr:
    """A compact equivalent of ``expr`` (see the module docstring for the two routes).

    ``deep`` also tries ``sympy.simplify`` (slow; for final results such as B, C, g) and keeps
    whichever form has fewer operations.
    """
    expr = sp.sympify(expr)
    if expr.is_Number or expr.is_Symbol:
        return expr
    if sp.count_ops(expr) >= SMALL:
        normal = trig_poly_normal(expr, angles)
        return sp.collect(normal, list(collect_by)) if collect_by else normal
    result = sp.expand(expr)
    if result.has(sp.sin, sp.cos):
        result = sp.trigsimp(result)
    result = sp.factor_terms(result)
    candidates = [result]
    if collect_by:
        candidates.append(sp.collect(sp.expand(result), list(collect_by)))
    if deep:
        candidates.append(sp.simplify(result))
    return min(candidates, key=sp.count_ops)


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
