"""Robot files in TOML: parsing, validation with one-line errors, and named parameters.

The schema is documented in ``docs/robot-files.md``.  Any number in a robot file may be an
expression string over the file's ``[parameters]`` (``"L2/2 + 0.1"``, ``"-pi/2"``); the
raw text is kept in ``Robot.spec`` so that ``armlab.symbolic`` can rebuild the same robot with
symbols.  Every problem raises :class:`RobotFileError` whose message is one line:
``<file>: <field>: <what is wrong>``.
"""

from __future__ import annotations

import ast
import math
import operator
import tomllib
from pathlib import Path

import numpy as np

from armlab.errors import RobotFileError
from armlab.model.inertia import box_inertia, cylinder_inertia, inertia_problem, sphere_inertia, steiner
from armlab.model.robot import DHRow, Friction, Inertial, Joint, Link, Motor, Robot
from armlab.spatial import rpy_matrix, skew, transform

_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.Pow: operator.pow}
_UNARY = {ast.UAdd: operator.pos, ast.USub: operator.neg}
_FUNCTIONS = {"sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan}
_CONSTANTS = {"pi": math.pi}


def axis_alignment(axis) -> np.ndarray:
    """R_axis, (3, 3): the smallest rotation turning z onto the unit vector of ``axis`` (3,).

    A joint with axis a is placed as P = origin · R_axis, S = R_axisᵀ, so that its joint frame
    has z = a; R_axis = I for a = z, so a z-axis joint's joint frame is its link frame.
    Rodrigues' formula with v = z × a, c = z · a:  R = I + S(v) + S(v)² / (1 + c).
    """
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    c = a[2]
    if c < -1.0 + 1e-12:
        # a = −z: any half turn about a horizontal axis; take x.
        return np.diag([1.0, -1.0, -1.0])
    v = np.array([-a[1], a[0], 0.0])
    S = skew(v)
    return np.eye(3) + S + S @ S / (1.0 + c)


def evaluate_expression(text: str, names: dict[str, float]) -> float:
    """Value of an arithmetic expression over ``names`` (``+ − * / **``, sqrt/sin/cos/tan, pi).

    Only these operations are accepted: the robot file is data, never code.
    """

    def walk(node):
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            return _BINARY[type(node.op)](walk(node.left), walk(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            return _UNARY[type(node.op)](walk(node.operand))
        if isinstance(node, ast.Name):
            if node.id in names:
                return float(names[node.id])
            if node.id in _CONSTANTS:
                return _CONSTANTS[node.id]
            raise ValueError(f"unknown name {node.id!r}")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            if node.func.id not in _FUNCTIONS:
                raise ValueError(f"unknown function {node.func.id!r} "
                                 f"(allowed: {', '.join(sorted(_FUNCTIONS))})")
            if len(node.args) != 1 or node.keywords:
                raise ValueError(f"{node.func.id}() takes one argument")
            return _FUNCTIONS[node.func.id](walk(node.args[0]))
        raise ValueError(f"unsupported expression element {type(node).__name__} in {text!r} "
                         "(use numbers, parameter names, + − * / **, sqrt, sin, cos, tan, pi)")

    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as error:
        raise ValueError(f"cannot parse expression {text!r}") from error
    return walk(tree)


class _Reader:
    """Typed access to the parsed TOML with the field path kept for error messages."""

    def __init__(self, file: str, names: dict[str, float]):
        self.file, self.names = file, names

    def fail(self, field: str, reason: str):
        raise RobotFileError(self.file, field, reason)

    def number(self, value, field: str) -> float:
        if isinstance(value, bool):
            self.fail(field, f"expected a number, got {value!r}")
        if isinstance(value, (int, float)):
            result = float(value)
        elif isinstance(value, str):
            try:
                result = evaluate_expression(value, self.names)
            except (ValueError, ZeroDivisionError, OverflowError) as error:
                self.fail(field, str(error))
        else:
            self.fail(field, f"expected a number or an expression string, got {type(value).__name__}")
        if not math.isfinite(result):
            self.fail(field, f"is not finite ({value!r})")
        return result

    def vector(self, value, field: str, length: int) -> np.ndarray:
        if not isinstance(value, list):
            self.fail(field, f"expected a list of {length} numbers, got {type(value).__name__}")
        if len(value) != length:
            self.fail(field, f"expected {length} numbers, got {len(value)}")
        return np.array([self.number(v, f"{field}[{k}]") for k, v in enumerate(value)])

    def matrix(self, value, field: str) -> np.ndarray:
        if not isinstance(value, list) or len(value) != 3:
            self.fail(field, "expected a 3×3 matrix (three rows of three numbers)")
        return np.array([self.vector(row, f"{field}[{k}]", 3) for k, row in enumerate(value)])

    def name(self, value, field: str) -> str:
        if not isinstance(value, str) or not value.strip():
            self.fail(field, f"expected a non-empty string, got {value!r}")
        return value

    def table(self, value, field: str) -> dict:
        if not isinstance(value, dict):
            self.fail(field, f"expected a table, got {type(value).__name__}")
        return value

    def only(self, table: dict, field: str, allowed: set[str]):
        unknown = sorted(set(table) - allowed)
        if unknown:
            self.fail(f"{field}.{unknown[0]}" if field else unknown[0],
                      f"unknown field (allowed: {', '.join(sorted(allowed))})")

    def pose(self, value, field: str) -> np.ndarray:
        """A transform from {xyz, rpy} or {dh = {a, alpha, d, theta}} (standard DH)."""
        table = self.table(value, field)
        self.only(table, field, {"xyz", "rpy", "dh"})
        if "dh" in table:
            if {"xyz", "rpy"} & set(table):
                self.fail(field, "give either dh or xyz/rpy, not both")
            row = self.dh_row(table["dh"], f"{field}.dh", "standard")
            return Joint.from_dh("fixed", "revolute", row).transform(0.0)
        xyz = self.vector(table.get("xyz", [0, 0, 0]), f"{field}.xyz", 3)
        rpy = self.vector(table.get("rpy", [0, 0, 0]), f"{field}.rpy", 3)
        return transform(rpy_matrix(rpy), xyz)

    def dh_row(self, value, field: str, convention: str) -> DHRow:
        table = self.table(value, field)
        self.only(table, field, {"a", "alpha", "d", "theta"})
        missing = [k for k in ("a", "alpha", "d", "theta") if k not in table]
        if missing:
            self.fail(f"{field}.{missing[0]}", "missing")
        values = {k: self.number(table[k], f"{field}.{k}") for k in ("a", "alpha", "d", "theta")}
        return DHRow(convention=convention, **values)


def _inertial(reader: _Reader, table: dict, field: str) -> Inertial:
    reader.only(table, field, {"name", "mass", "com", "inertia", "inertia_origin", "shape"})
    mass = reader.number(table.get("mass", 0.0), f"{field}.mass")
    if mass < 0:
        reader.fail(f"{field}.mass", f"must be non-negative, got {mass:g} kg")
    com = reader.vector(table.get("com", [0, 0, 0]), f"{field}.com", 3)
    given = [k for k in ("inertia", "inertia_origin", "shape") if k in table]
    if len(given) > 1:
        reader.fail(field, f"give one of inertia, inertia_origin, shape (got {', '.join(given)})")
    shape = None
    if "inertia" in table:
        inertia = reader.matrix(table["inertia"], f"{field}.inertia")
        problem_field = f"{field}.inertia"
    elif "inertia_origin" in table:
        # Given about the link frame's origin: Steiner back to the centre of mass.
        about_origin = reader.matrix(table["inertia_origin"], f"{field}.inertia_origin")
        inertia = steiner(about_origin, -mass, com)
        problem_field = f"{field}.inertia_origin"
    elif "shape" in table:
        shape = reader.table(table["shape"], f"{field}.shape")
        inertia = _shape_inertia(reader, shape, mass, f"{field}.shape")
        problem_field = f"{field}.shape"
    else:
        inertia = np.zeros((3, 3))
        problem_field = field
    problem = inertia_problem(inertia)
    if problem:
        where = "inertia about the centre of mass" if "inertia_origin" in table else "inertia"
        reader.fail(problem_field, f"{where} {problem}")
    return Inertial(mass=mass, com=com, inertia=inertia, shape=shape)


def _shape_inertia(reader: _Reader, shape: dict, mass: float, field: str) -> np.ndarray:
    kind = shape.get("type")
    sizes = {"box": {"size"}, "cylinder": {"radius", "length"}, "sphere": {"radius"}}
    if kind not in sizes:
        reader.fail(f"{field}.type", f"unknown shape {kind!r} (use box, cylinder or sphere)")
    reader.only(shape, field, {"type", "rpy"} | sizes[kind])
    for key in sorted(sizes[kind]):
        if key not in shape:
            reader.fail(f"{field}.{key}", f"missing (a {kind} needs {', '.join(sorted(sizes[kind]))})")
    if kind == "box":
        size = reader.vector(shape["size"], f"{field}.size", 3)
        if np.any(size <= 0):
            reader.fail(f"{field}.size", "edge lengths must be positive")
        local = box_inertia(mass, size)
    else:
        radius = reader.number(shape["radius"], f"{field}.radius")
        if radius <= 0:
            reader.fail(f"{field}.radius", f"must be positive, got {radius:g}")
        if kind == "sphere":
            local = sphere_inertia(mass, radius)
        else:
            length = reader.number(shape["length"], f"{field}.length")
            if length <= 0:
                reader.fail(f"{field}.length", f"must be positive, got {length:g}")
            local = cylinder_inertia(mass, radius, length)
    R = rpy_matrix(reader.vector(shape.get("rpy", [0, 0, 0]), f"{field}.rpy", 3))
    return R @ local @ R.T


def _joint(reader: _Reader, table: dict, index: int, convention: str) -> tuple[Joint, Link]:
    field = f"joints[{index}]"
    reader.table(table, field)
    reader.only(table, field, {"name", "type", "dh", "origin", "axis", "limits", "motor",
                               "friction", "link"})
    name = reader.name(table.get("name", f"joint{index + 1}"), f"{field}.name")
    kind = table.get("type")
    if kind not in ("revolute", "prismatic"):
        reader.fail(f"{field}.type", f"unknown joint type {kind!r} (use revolute or prismatic)")
    motor_table = reader.table(table.get("motor", {}), f"{field}.motor")
    reader.only(motor_table, f"{field}.motor", {"gear_ratio", "rotor_inertia", "mass"})
    motor = Motor(
        gear_ratio=reader.number(motor_table.get("gear_ratio", 1.0), f"{field}.motor.gear_ratio"),
        rotor_inertia=reader.number(motor_table.get("rotor_inertia", 0.0), f"{field}.motor.rotor_inertia"),
        mass=reader.number(motor_table.get("mass", 0.0), f"{field}.motor.mass"),
    )
    if motor.gear_ratio == 0:
        # A negative ratio is a reversing gear (PUMA 560 joints 1 and 3); zero is no gear.
        reader.fail(f"{field}.motor.gear_ratio", "must be non-zero")
    for key, unit in (("rotor_inertia", "kg·m²"), ("mass", "kg")):
        if getattr(motor, key) < 0:
            reader.fail(f"{field}.motor.{key}", f"must be non-negative, got {getattr(motor, key):g} {unit}")
    friction_table = reader.table(table.get("friction", {}), f"{field}.friction")
    reader.only(friction_table, f"{field}.friction", {"viscous", "coulomb"})
    friction = Friction(
        viscous=reader.number(friction_table.get("viscous", 0.0), f"{field}.friction.viscous"),
        coulomb=reader.number(friction_table.get("coulomb", 0.0), f"{field}.friction.coulomb"),
    )
    for key in ("viscous", "coulomb"):
        if getattr(friction, key) < 0:
            reader.fail(f"{field}.friction.{key}", "must be non-negative")
    limits = (-np.inf, np.inf)
    if "limits" in table:
        lo, hi = reader.vector(table["limits"], f"{field}.limits", 2)
        if not lo < hi:
            reader.fail(f"{field}.limits", f"lower limit {lo:g} must be below upper limit {hi:g}")
        limits = (lo, hi)
    common = dict(limits=limits, motor=motor, friction=friction)
    if "dh" in table and ("origin" in table or "axis" in table):
        reader.fail(field, "give either dh or origin/axis, not both")
    if "dh" in table:
        row = reader.dh_row(table["dh"], f"{field}.dh", convention)
        joint = Joint.from_dh(name, kind, row, **common)
    elif "origin" in table or "axis" in table:
        origin = reader.pose(table.get("origin", {}), f"{field}.origin")
        axis = reader.vector(table.get("axis", [0, 0, 1]), f"{field}.axis", 3)
        if np.linalg.norm(axis) < 1e-9:
            reader.fail(f"{field}.axis", "must be a non-zero vector")
        align = transform(axis_alignment(axis))
        joint = Joint(name=name, kind=kind, before=origin @ align, after=np.linalg.inv(align), **common)
    else:
        reader.fail(field, "needs a placement: dh = {a, alpha, d, theta} or origin/axis")
    link_table = reader.table(table.get("link", {}), f"{field}.link")
    link = Link(name=reader.name(link_table.get("name", f"link{index + 1}"), f"{field}.link.name"),
                inertial=_inertial(reader, link_table, f"{field}.link"))
    return joint, link


def robot_from_dict(data: dict, file: str = "<robot>") -> Robot:
    """Build a :class:`Robot` from a parsed robot file (see ``docs/robot-files.md``)."""
    top = {"name", "description", "provenance", "dh_convention", "gravity", "base", "tool",
           "parameters", "joints"}
    bootstrap = _Reader(file, {})
    bootstrap.only(data, "", top)
    names: dict[str, float] = {}
    parameters = bootstrap.table(data.get("parameters", {}), "parameters")
    reader = _Reader(file, names)
    for key, value in parameters.items():
        # Parameters may refer to earlier parameters (TOML keeps the file's order).
        names[key] = reader.number(value, f"parameters.{key}")
    convention = data.get("dh_convention", "standard")
    if convention not in ("standard", "modified"):
        reader.fail("dh_convention", f"unknown convention {convention!r} (use standard or modified)")
    joint_tables = data.get("joints")
    if not isinstance(joint_tables, list) or not joint_tables:
        reader.fail("joints", "at least one [[joints]] entry is needed")
    pairs = [_joint(reader, table, i, convention) for i, table in enumerate(joint_tables)]
    for kind, used in (("joint", [j.name for j, _ in pairs]), ("link", [lk.name for _, lk in pairs])):
        for i, name in enumerate(used):
            if name in used[:i]:
                where = f"joints[{i}].name" if kind == "joint" else f"joints[{i}].link.name"
                reader.fail(where, f"{kind} name {name!r} is used twice")
    gravity = reader.vector(data.get("gravity", [0, 0, -9.81]), "gravity", 3)
    base = reader.pose(data.get("base", {}), "base")
    tool = reader.pose(data.get("tool", {}), "tool")
    return Robot(
        name=str(data.get("name", Path(file).stem)),
        joints=tuple(j for j, _ in pairs),
        links=tuple(lk for _, lk in pairs),
        gravity=gravity, base=base, tool=tool,
        description=str(data.get("description", "")),
        source=str(file), parameters=dict(names), spec=data,
    )


def load_robot_toml(path: str | Path) -> Robot:
    """Load a TOML robot file; malformed input raises :class:`RobotFileError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise RobotFileError(path, "file", f"cannot be read ({error.strerror})") from error
    except UnicodeDecodeError:
        raise RobotFileError(path, "file", "is not UTF-8 text") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise RobotFileError(path, "syntax", str(error)) from error
    return robot_from_dict(data, str(path))
