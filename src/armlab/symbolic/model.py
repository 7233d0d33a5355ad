"""A robot rebuilt with SymPy: every ``[parameters]`` name a symbol, joint variables named.

:func:`symbolic_robot` reads ``Robot.spec`` (the raw robot file, expressions unevaluated) with
the same semantics as ``armlab.model.toml_io`` so that the symbolic robot *is* the numeric
one with letters: ``L2/2`` stays ``L_2/2``, a box of size ``(a2, b2, L2)`` keeps its inertia
``m/12 diag(b2² + L2², …)`` in letters, ``-pi/2`` stays exact.  With ``numeric=True`` (or for a
robot without a spec, e.g. one read from URDF) the parameter values are used instead, as exact
rationals.

Joint variables are named after the joints (``d1``, ``theta2``, ``d3`` for the PRP); their
rates are ``ddot_1`` (ḋ₁), ``thetadot_2`` (θ̇₂) and ``thetaddot_2`` (θ̈₂), names that SymPy's
LaTeX and Unicode printers render with dots.  A joint name that is not an identifier becomes
``q<i>``.
"""

from __future__ import annotations

import keyword
from dataclasses import dataclass, field

import numpy as np
import sympy as sp
from sympy.printing.conventions import split_super_sub

from armlab.model.robot import Robot
from armlab.spatial import rotation_to_axis
from armlab.symbolic.expressions import (
    dh_matrix,
    exact,
    exact_angle,
    exact_entry,
    inverse_transform,
    parse_expression,
    rot_x,
    rot_z,
    rpy_matrix,
    transform,
)


@dataclass(frozen=True)
class SymbolicJoint:
    """Joint i: T_{i−1,i} = P · M(q + offset) · S (K1), every entry a SymPy expression.

    ``dh`` is the row (a, α, d, θ) *with the joint variable added* (θ + q or d + q) for DH
    joints, else None.  Motor and friction constants are expressions (0 when absent).
    """

    name: str
    kind: str
    q: sp.Symbol
    qd: sp.Symbol
    qdd: sp.Symbol
    before: sp.Matrix
    after: sp.Matrix
    offset: sp.Expr
    dh: tuple | None = None
    gear_ratio: sp.Expr = sp.Integer(1)
    rotor_inertia: sp.Expr = sp.Integer(0)
    motor_mass: sp.Expr = sp.Integer(0)
    viscous: sp.Expr = sp.Integer(0)
    coulomb: sp.Expr = sp.Integer(0)

    @property
    def revolute(self) -> bool:
        return self.kind == "revolute"

    def motion(self) -> sp.Matrix:
        """M(q + offset): rotation about or translation along the local z axis."""
        value = self.q + self.offset
        return transform(rot_z(value)) if self.revolute else transform(None, [0, 0, value])

    def transform(self) -> sp.Matrix:
        """T_{i−1,i}(q_i) of (K1), (4, 4)."""
        return self.before * self.motion() * self.after


@dataclass(frozen=True)
class SymbolicLink:
    """Mass properties in the link frame Σ_i: ``mass``, ``com`` (3, 1), ``inertia`` (3, 3)
    about the centre of mass; ``shape`` says where the inertia came from (for the A2 text)."""

    name: str
    mass: sp.Expr
    com: sp.Matrix
    inertia: sp.Matrix
    shape: str = ""


@dataclass(frozen=True)
class SymbolicRobot:
    """The symbolic twin of a :class:`~armlab.model.robot.Robot`.

    ``parameters`` maps each robot-file parameter name to its symbol (empty when numeric),
    ``values`` each symbol to its exact numeric value; ``base`` is T_base0, ``tool`` Σ_e in
    Σ_n, ``gravity`` g_0 in Σ_0 (3, 1); ``base_dh`` the base's DH row when the file gives one.
    """

    name: str
    joints: tuple[SymbolicJoint, ...]
    links: tuple[SymbolicLink, ...]
    gravity: sp.Matrix
    base: sp.Matrix
    tool: sp.Matrix
    base_dh: tuple | None = None
    convention: str = "standard"
    parameters: dict = field(default_factory=dict)
    values: dict = field(default_factory=dict)
    numeric: bool = False

    def __hash__(self):
        return id(self)

    def __eq__(self, other):
        return self is other

    @property
    def n(self) -> int:
        return len(self.joints)

    @property
    def q(self) -> sp.Matrix:
        return sp.Matrix([j.q for j in self.joints])

    @property
    def qd(self) -> sp.Matrix:
        return sp.Matrix([j.qd for j in self.joints])

    @property
    def qdd(self) -> sp.Matrix:
        return sp.Matrix([j.qdd for j in self.joints])

    @property
    def has_motors(self) -> bool:
        return any(j.rotor_inertia != 0 or j.motor_mass != 0 for j in self.joints)

    @property
    def has_motor_masses(self) -> bool:
        return any(j.motor_mass != 0 for j in self.joints[1:])

    @property
    def has_friction(self) -> bool:
        return any(j.viscous != 0 or j.coulomb != 0 for j in self.joints)

    def numeric_substitution(self) -> dict:
        """{symbol: exact value} turning every parameter symbol into its number."""
        return dict(self.values)


def joint_symbols(name: str, index: int, taken: set[str]) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """(q, q̇, q̈) symbols of joint ``index`` (0-based) named after ``name`` when possible."""
    if not name.isidentifier() or keyword.iskeyword(name) or name in taken or name == "pi":
        name = f"q{index + 1}"
    base, _, subs = split_super_sub(name)
    if subs:
        sub = "_" + "".join(subs)
        rate, accel = f"{base}dot{sub}", f"{base}ddot{sub}"
    else:
        rate, accel = f"{name}dot", f"{name}ddot"
    return sp.Symbol(name, real=True), sp.Symbol(rate, real=True), sp.Symbol(accel, real=True)


class _SpecReader:
    """Reads the raw robot file with SymPy values (the numeric reader validated it already)."""

    def __init__(self, names: dict[str, sp.Expr]):
        self.names = names

    def value(self, raw, default=0) -> sp.Expr:
        return parse_expression(default if raw is None else raw, self.names)

    def vector(self, raw, default=(0, 0, 0)) -> sp.Matrix:
        return sp.Matrix([self.value(v) for v in (default if raw is None else raw)])

    def dh_row(self, table: dict) -> tuple:
        return tuple(self.value(table[k]) for k in ("a", "alpha", "d", "theta"))

    def pose(self, table: dict | None) -> tuple[sp.Matrix, tuple | None]:
        table = table or {}
        if "dh" in table:
            row = self.dh_row(table["dh"])
            return dh_matrix(*row, "standard"), row
        R = rpy_matrix(list(self.vector(table.get("rpy"))))
        return transform(R, self.vector(table.get("xyz"))), None

    def inertia(self, link: dict, mass: sp.Expr, com: sp.Matrix) -> tuple[sp.Matrix, str]:
        if "inertia" in link:
            return sp.Matrix([[self.value(v) for v in row] for row in link["inertia"]]), "given"
        if "inertia_origin" in link:
            about_origin = sp.Matrix([[self.value(v) for v in row] for row in link["inertia_origin"]])
            return about_origin - mass * ((com.T * com)[0] * sp.eye(3) - com * com.T), "inertia_origin"
        if "shape" not in link:
            return sp.zeros(3, 3), ""
        shape = link["shape"]
        kind = shape["type"]
        if kind == "box":
            a, b, c = (self.value(v) for v in shape["size"])
            local = mass / 12 * sp.diag(b**2 + c**2, a**2 + c**2, a**2 + b**2)
        elif kind == "cylinder":
            r, h = self.value(shape["radius"]), self.value(shape["length"])
            transverse = mass * (3 * r**2 + h**2) / 12
            local = sp.diag(transverse, transverse, mass * r**2 / 2)
        else:
            r = self.value(shape["radius"])
            local = sp.Rational(2, 5) * mass * r**2 * sp.eye(3)
        R = rpy_matrix(list(self.vector(shape.get("rpy"))))
        return sp.simplify(R * local * R.T), kind


def _from_spec(robot: Robot, numeric: bool) -> SymbolicRobot:
    spec = robot.spec
    names: dict[str, sp.Expr] = {}
    symbols: dict[str, sp.Symbol] = {}
    values: dict[sp.Symbol, sp.Expr] = {}
    reader = _SpecReader(names)
    for key, raw in spec.get("parameters", {}).items():
        if numeric:
            names[key] = exact(robot.parameters[key])
        elif isinstance(raw, (int, float)) and not isinstance(raw, bool):
            symbol = sp.Symbol(key, real=True)
            names[key] = symbols[key] = symbol
            values[symbol] = exact(raw)
        else:
            # A derived parameter (an expression over earlier ones) stays that expression.
            names[key] = reader.value(raw)
    convention = spec.get("dh_convention", "standard")
    base, base_dh = reader.pose(spec.get("base"))
    tool, _ = reader.pose(spec.get("tool"))
    joints, links = [], []
    taken = set(names)
    for i, table in enumerate(spec["joints"]):
        numeric_joint = robot.joints[i]
        q, qd, qdd = joint_symbols(numeric_joint.name, i, taken)
        taken.add(str(q))
        kind = table["type"]
        motor, friction = table.get("motor", {}), table.get("friction", {})
        constants = dict(gear_ratio=reader.value(motor.get("gear_ratio"), 1),
                         rotor_inertia=reader.value(motor.get("rotor_inertia")),
                         motor_mass=reader.value(motor.get("mass")),
                         viscous=reader.value(friction.get("viscous")),
                         coulomb=reader.value(friction.get("coulomb")))
        if "dh" in table:
            a, alpha, d, theta = reader.dh_row(table["dh"])
            revolute = kind == "revolute"
            fixed = (transform(None, [0, 0, d]) if revolute else transform(rot_z(theta)))
            tail = transform(None, [a, 0, 0]) * transform(rot_x(alpha))
            if convention == "standard":
                before, after = sp.eye(4), fixed * tail
            else:
                before, after = transform(rot_x(alpha), [a, 0, 0]) * fixed, sp.eye(4)
            offset = theta if revolute else d
            row = (a, alpha, d, theta + q) if revolute else (a, alpha, d + q, theta)
            joint = SymbolicJoint(numeric_joint.name, kind, q, qd, qdd, before, after, offset,
                                  dh=row, **constants)
        else:
            origin, _ = reader.pose(table.get("origin"))
            axis = np.array([float(v) for v in _numeric_axis(table.get("axis"), robot.parameters)])
            align = sp.Matrix(3, 3, [exact_entry(v) for v in rotation_to_axis(axis).ravel()])
            joint = SymbolicJoint(numeric_joint.name, kind, q, qd, qdd, origin * transform(align),
                                  inverse_transform(transform(align)), sp.Integer(0), **constants)
        link_table = table.get("link", {})
        mass = reader.value(link_table.get("mass"))
        com = reader.vector(link_table.get("com"))
        inertia, shape = reader.inertia(link_table, mass, com)
        joints.append(joint)
        links.append(SymbolicLink(robot.links[i].name, mass, com, inertia, shape))
    gravity = reader.vector(spec.get("gravity"), (0, 0, -9.81))
    return SymbolicRobot(robot.name, tuple(joints), tuple(links), gravity, base, tool, base_dh,
                         convention, symbols, values, numeric)


def _numeric_axis(raw, parameters: dict) -> list[float]:
    from armlab.model.toml_io import evaluate_expression

    raw = [0, 0, 1] if raw is None else raw
    return [v if isinstance(v, (int, float)) else evaluate_expression(v, parameters) for v in raw]


def _from_numbers(robot: Robot) -> SymbolicRobot:
    """A robot without a spec (URDF, built in code): its numbers, exact where recognisable."""

    def matrix(array):
        return sp.Matrix(array.shape[0], array.shape[1], [exact_entry(v) for v in array.ravel()])

    joints, links = [], []
    taken: set[str] = set()
    for i, (joint, link) in enumerate(zip(robot.joints, robot.links, strict=True)):
        q, qd, qdd = joint_symbols(joint.name, i, taken)
        taken.add(str(q))
        row = None
        offset = exact_angle(joint.offset) if joint.kind == "revolute" else exact_entry(joint.offset)
        if joint.dh is not None:
            a, alpha, d, theta = (exact_entry(joint.dh.a), exact_angle(joint.dh.alpha),
                                  exact_entry(joint.dh.d), exact_angle(joint.dh.theta))
            row = (a, alpha, d, theta + q) if joint.kind == "revolute" else (a, alpha, d + q, theta)
        joints.append(SymbolicJoint(
            joint.name, joint.kind, q, qd, qdd, matrix(joint.before), matrix(joint.after), offset,
            dh=row, gear_ratio=exact(joint.motor.gear_ratio),
            rotor_inertia=exact(joint.motor.rotor_inertia),
            motor_mass=exact(getattr(joint.motor, "mass", 0.0)), viscous=exact(joint.friction.viscous),
            coulomb=exact(joint.friction.coulomb)))
        inertial = link.inertial
        links.append(SymbolicLink(link.name, exact(inertial.mass),
                                  sp.Matrix([exact_entry(v) for v in inertial.com]),
                                  matrix(inertial.inertia)))
    return SymbolicRobot(robot.name, tuple(joints), tuple(links),
                         sp.Matrix([exact(v) for v in robot.gravity]), matrix(robot.base),
                         matrix(robot.tool), numeric=True)


def symbolic_robot(robot: Robot, *, numeric: bool = False) -> SymbolicRobot:
    """The :class:`SymbolicRobot` of ``robot``: from its file's expressions when it has a spec
    (parameters as symbols, or as their values with ``numeric=True``), else from its numbers."""
    if robot.spec and "joints" in robot.spec:
        return _from_spec(robot, numeric)
    return _from_numbers(robot)
