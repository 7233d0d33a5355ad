"""SymPy building blocks: robot-file expressions, exact numbers, elementary transforms, skew.

Robot files hold numbers and expression strings over their ``[parameters]`` (``"L2/2"``,
``"-pi/2"``); :func:`parse_expression` turns them into SymPy expressions with the same grammar
as the numeric reader (``armlab.model.toml_io.evaluate_expression``): + − * / **, sqrt, sin,
cos, tan and pi.  Decimal numbers become exact rationals (9.81 → 981/100) so that symbolic
identities (Lagrange ≡ Newton–Euler, Steiner) simplify to an exact zero.
"""

from __future__ import annotations

import ast
import math
from fractions import Fraction

import sympy as sp

from armlab.model.toml_io import MAX_EXPONENT, expression_tree

_FUNCTIONS = {"sqrt": sp.sqrt, "sin": sp.sin, "cos": sp.cos, "tan": sp.tan}


def exact(value: float) -> sp.Expr:
    """The exact decimal value of a float (0.5 → 1/2, 9.81 → 981/100, 3.0 → 3)."""
    if isinstance(value, sp.Basic):
        return value
    if float(value).is_integer():
        return sp.Integer(int(value))
    return sp.Rational(repr(float(value)))


def exact_angle(value: float) -> sp.Expr:
    """An angle [rad] given as a float, recognising rational multiples of π (1.5708 → π/2)."""
    if abs(value) < 1e-14:
        return sp.Integer(0)
    ratio = sp.nsimplify(value / math.pi, tolerance=1e-12, rational=True)
    if ratio.q <= 12 and abs(float(ratio) * math.pi - value) < 1e-12:
        return ratio * sp.pi
    return exact(value)


def exact_entry(value: float) -> sp.Expr:
    """An entry of a numeric rotation/transform: rounding noise (6e-17) to 0, ±1 exactly,
    ±√(k/m) (e.g. √2/2) recognised from its square, anything else its exact decimal value."""
    nearest = round(value)
    if abs(value - nearest) < 1e-12:
        return sp.Integer(int(nearest))
    square = Fraction(value * value).limit_denominator(12)
    if abs(float(square) - value * value) < 1e-13:
        root = sp.sqrt(sp.Rational(square.numerator, square.denominator))
        return root if value > 0 else -root
    return exact(value)


def parse_expression(text, names: dict[str, sp.Expr]) -> sp.Expr:
    """SymPy value of a robot-file number or expression string over ``names``.

    The string is checked by the numeric reader's :func:`~armlab.model.toml_io.expression_tree`
    (grammar, length, depth) before anything is built, and a numeric exponent is bounded as
    there, so no input makes SymPy compute a huge power.  Raises ``ValueError`` naming the
    offending element (the numeric reader has already accepted the file, so this only fires
    for robots built by hand).
    """
    if isinstance(text, bool):
        raise ValueError(f"expected a number, got {text!r}")
    if isinstance(text, int):
        return sp.Integer(text)
    if isinstance(text, float):
        if not math.isfinite(text):
            raise ValueError(f"expected a finite number, got {text!r}")
        return exact(text)

    def walk(node):
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant):
            return sp.Integer(node.value) if isinstance(node.value, int) else exact(node.value)
        if isinstance(node, ast.BinOp):
            left, right = walk(node.left), walk(node.right)
            if isinstance(node.op, ast.Add):
                return left + right
            if isinstance(node.op, ast.Sub):
                return left - right
            if isinstance(node.op, ast.Mult):
                return left * right
            if isinstance(node.op, ast.Div):
                return left / right
            if right.is_number and abs(float(right)) > MAX_EXPONENT:
                raise ValueError(f"exponent {float(right):g} is beyond ±{MAX_EXPONENT}")
            return left**right
        if isinstance(node, ast.UnaryOp):
            value = walk(node.operand)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.Name):
            if node.id in names:
                return names[node.id]
            if node.id == "pi":
                return sp.pi
            raise ValueError(f"unknown name {node.id!r}")
        # A call of sqrt, sin, cos or tan with one argument (expression_tree allows no other).
        return _FUNCTIONS[node.func.id](walk(node.args[0]))

    return walk(expression_tree(text))


def rot_x(angle) -> sp.Matrix:
    c, s = sp.cos(angle), sp.sin(angle)
    return sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(angle) -> sp.Matrix:
    c, s = sp.cos(angle), sp.sin(angle)
    return sp.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(angle) -> sp.Matrix:
    c, s = sp.cos(angle), sp.sin(angle)
    return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def transform(R: sp.Matrix | None = None, p=None) -> sp.Matrix:
    """Homogeneous transform [[R, p], [0, 1]], (4, 4)."""
    T = sp.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = sp.Matrix(p)
    return T


def rpy_matrix(rpy) -> sp.Matrix:
    """URDF fixed-axis roll-pitch-yaw R = Rz(yaw) Ry(pitch) Rx(roll)."""
    roll, pitch, yaw = rpy
    return rot_z(yaw) * rot_y(pitch) * rot_x(roll)


def dh_matrix(a, alpha, d, theta, convention: str = "standard") -> sp.Matrix:
    """A_i^{i−1} of one DH row: standard Rz(θ)Tz(d)Tx(a)Rx(α), modified Rx(α)Tx(a)Rz(θ)Tz(d)."""
    if convention == "standard":
        return (transform(rot_z(theta), [0, 0, d]) * transform(rot_x(alpha), [a, 0, 0]))
    return transform(rot_x(alpha), [a, 0, 0]) * transform(rot_z(theta), [0, 0, d])


def skew(v) -> sp.Matrix:
    """S(v) with S(v) w = v × w, (3, 3)."""
    x, y, z = v
    return sp.Matrix([[0, -z, y], [z, 0, -x], [-y, x, 0]])


def inverse_transform(T: sp.Matrix) -> sp.Matrix:
    """[[Rᵀ, −Rᵀp], [0, 1]]."""
    R, p = T[:3, :3], T[:3, 3]
    return transform(R.T, -R.T * p)
