"""Robot files in TOML: parsing, validation with one-line errors, and named parameters.

The schema is documented in ``docs/robot-files.md``.  Any number in a robot file may be an
expression string over the file's ``[parameters]`` (``"L2/2 + 0.1"``, ``"-pi/2"``); the
raw text is kept in ``Robot.spec`` so that ``armlab.symbolic`` can rebuild the same robot with
symbols.  Every problem raises :class:`RobotFileError` whose message is one line:
``<file>: <field>: <what is wrong>``.
"""

from __future__ import annotations

import ast
import functools
import keyword
import math
import operator
from pathlib import Path

import numpy as np

from armlab.errors import RobotFileError
from armlab.inputs import read_input_toml
from armlab.model.inertia import box_inertia, cylinder_inertia, inertia_problem, sphere_inertia, steiner
from armlab.model.robot import DHRow, Friction, Inertial, Joint, Link, Motor, Robot, nonfinite_part
from armlab.spatial import rpy_matrix, skew, transform

_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.Pow: operator.pow}
_UNARY = {ast.UAdd: operator.pos, ast.USub: operator.neg}
_FUNCTIONS = {"sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan}
_CONSTANTS = {"pi": math.pi}
_RESERVED = {*_FUNCTIONS, *_CONSTANTS}


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


MAX_MAGNITUDE = 1e12
"""Largest magnitude of a robot file's values (joint limits excepted) in SI units: far beyond
any manipulator, small enough that the dynamics (products of masses, squared lengths and
squared rates) cannot overflow."""

MAX_NAME_LENGTH = 1000
"""Longest name (robot, joint, link, parameter) of a robot file [characters]."""

MAX_EXPRESSION_LENGTH = 1000
"""Longest expression string of a robot or scenario file [characters]."""

MAX_EXPRESSION_DEPTH = 100
"""Deepest nesting of operations in an expression (``-(-(-x))`` is 4 deep; a sum of k terms
is k deep)."""

MAX_EXPONENT = 100
"""Largest |exponent| of ``**`` in an expression (``10**10**10`` is refused, not computed)."""

_NODES = (ast.Expression, ast.Constant, ast.BinOp, ast.UnaryOp, ast.Name, ast.Call, ast.Load,
          *_BINARY, *_UNARY)


def expression_tree(text) -> ast.Expression:
    """The syntax tree of an expression string, checked before anything is evaluated.

    Only numbers, names, ``+ − * / **``, unary ±, and calls ``f(x)`` of a single argument are
    allowed, at most :data:`MAX_EXPRESSION_LENGTH` characters and :data:`MAX_EXPRESSION_DEPTH`
    levels deep, so that walking the tree recursively is safe.  Raises ``ValueError`` saying
    what is wrong; both the numeric reader and ``armlab.symbolic`` read expressions through it.
    """
    if not isinstance(text, str):
        raise ValueError(f"expected a number or an expression string, got {type(text).__name__}")
    if len(text) > MAX_EXPRESSION_LENGTH:
        raise ValueError(f"expression of {len(text)} characters is longer than the "
                         f"{MAX_EXPRESSION_LENGTH} allowed")
    return _checked_tree(text)


@functools.lru_cache(maxsize=4096)
def _checked_tree(text: str) -> ast.Expression:
    """:func:`expression_tree` of a string of allowed length, remembered: a sweep or a batch
    reads the same few expressions ("pi/3") of its scenario for every run, and parsing them
    cost more than the rest of building a reference (a failure is not remembered; callers only
    read the tree)."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        raise ValueError(f"cannot parse expression {text!r}") from None
    stack = [(tree, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_EXPRESSION_DEPTH:
            raise ValueError(f"expression nested more than {MAX_EXPRESSION_DEPTH} levels deep")
        if not isinstance(node, _NODES) or (isinstance(node, ast.Constant) and (
                isinstance(node.value, bool) or not isinstance(node.value, (int, float)))):
            shown = ast.unparse(node) if isinstance(node, ast.expr) else type(node).__name__
            raise ValueError(f"unsupported expression element {shown[:40]!r} in {text!r} "
                             "(use numbers, parameter names, + − * / **, sqrt, sin, cos, tan, pi)")
        if isinstance(node, ast.Call) and (not isinstance(node.func, ast.Name)
                                           or node.func.id not in _FUNCTIONS):
            raise ValueError(f"unknown function {ast.unparse(node.func)[:40]!r} "
                             f"(allowed: {', '.join(sorted(_FUNCTIONS))})")
        if isinstance(node, ast.Call) and (len(node.args) != 1 or node.keywords):
            raise ValueError(f"a function call takes one argument, as in sqrt(x), in {text!r}")
        children = [node.args[0]] if isinstance(node, ast.Call) else ast.iter_child_nodes(node)
        stack.extend((child, depth + 1) for child in children)
    return tree


def _power(base: float, exponent: float) -> float:
    if abs(exponent) > MAX_EXPONENT:
        raise ValueError(f"exponent {exponent:g} is beyond ±{MAX_EXPONENT}")
    result = base**exponent
    if isinstance(result, complex):
        raise ValueError(f"({base:g})**{exponent:g} is not a real number")
    return result


def evaluate_expression(text: str, names: dict[str, float]) -> float:
    """Value of an arithmetic expression over ``names`` (``+ − * / **``, sqrt/sin/cos/tan, pi).

    Only these operations are accepted (see :func:`expression_tree`): the robot file is data,
    never code.  Raises ``ValueError`` saying what is wrong (also for a division by zero or an
    overflow); the value may still be ±inf (``1e308*10``), which callers refuse.
    """

    def walk(node):
        if isinstance(node, ast.Expression):
            return walk(node.body)
        if isinstance(node, ast.Constant):
            return float(node.value)
        if isinstance(node, ast.BinOp):
            left, right = walk(node.left), walk(node.right)
            if isinstance(node.op, ast.Pow):
                return _power(left, right)
            return _BINARY[type(node.op)](left, right)
        if isinstance(node, ast.UnaryOp):
            return _UNARY[type(node.op)](walk(node.operand))
        if isinstance(node, ast.Name):
            if node.id in names:
                return float(names[node.id])
            if node.id in _CONSTANTS:
                return _CONSTANTS[node.id]
            raise ValueError(f"unknown name {node.id!r}")
        # A call of a known function with one argument (expression_tree allows nothing else).
        argument = walk(node.args[0])
        if node.func.id == "sqrt" and argument < 0:
            raise ValueError(f"sqrt of a negative number ({argument:g})")
        return _FUNCTIONS[node.func.id](argument)

    tree = expression_tree(text)
    try:
        return walk(tree)
    except ZeroDivisionError:
        raise ValueError(f"division by zero in {_shorten(text)}") from None
    except OverflowError:
        raise ValueError(f"{_shorten(text)} overflows the range of a float") from None


def _shorten(value, limit: int = 60) -> str:
    """``repr(value)``, cut to ``limit`` characters for a message."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}…"


class _Reader:
    """Typed access to the parsed TOML with the field path kept for error messages."""

    def __init__(self, file: str, names: dict[str, float]):
        self.file, self.names = file, names

    def fail(self, field: str, reason: str):
        raise RobotFileError(self.file, field, reason)

    def number(self, value, field: str, bounded: bool = True) -> float:
        if isinstance(value, bool):
            self.fail(field, f"expected a number, got {value!r}")
        if not isinstance(value, (int, float, str)):
            self.fail(field, f"expected a number or an expression string, got {type(value).__name__}")
        try:
            result = evaluate_expression(value, self.names) if isinstance(value, str) else float(value)
        except OverflowError:
            self.fail(field, f"is beyond the range of a float ({_shorten(value)})")
        except ValueError as error:
            self.fail(field, str(error))
        if not math.isfinite(result):
            self.fail(field, f"is not finite ({_shorten(value)})")
        if bounded and abs(result) > MAX_MAGNITUDE:
            self.fail(field, f"{result:g} is beyond ±{MAX_MAGNITUDE:g}, the largest magnitude of a "
                             "robot file's value")
        return result

    def vector(self, value, field: str, length: int, bounded: bool = True) -> np.ndarray:
        if not isinstance(value, list):
            self.fail(field, f"expected a list of {length} numbers, got {type(value).__name__}")
        if len(value) != length:
            self.fail(field, f"expected {length} numbers, got {len(value)}")
        return np.array([self.number(v, f"{field}[{k}]", bounded) for k, v in enumerate(value)])

    def matrix(self, value, field: str) -> np.ndarray:
        if not isinstance(value, list) or len(value) != 3:
            self.fail(field, "expected a 3×3 matrix (three rows of three numbers)")
        return np.array([self.vector(row, f"{field}[{k}]", 3) for k, row in enumerate(value)])

    def name(self, value, field: str) -> str:
        """A name: a non-empty single line of text without control characters."""
        if not isinstance(value, str) or not value.strip():
            self.fail(field, f"expected a non-empty string, got {_shorten(value)}")
        if not value.isprintable():
            self.fail(field, f"must be one line of printable text, got {_shorten(value)}")
        if len(value) > MAX_NAME_LENGTH:
            self.fail(field, f"is longer than {MAX_NAME_LENGTH} characters")
        return value

    def text(self, value, field: str) -> str:
        """Free text (a description): any string."""
        if not isinstance(value, str):
            self.fail(field, f"expected a string, got {type(value).__name__}")
        return value

    def table(self, value, field: str) -> dict:
        if not isinstance(value, dict):
            self.fail(field, f"expected a table, got {type(value).__name__}")
        return value

    def only(self, table: dict, field: str, allowed: set[str]):
        unknown = sorted(set(table) - allowed)
        if unknown:
            key = unknown[0] if unknown[0].isidentifier() else repr(unknown[0])
            self.fail(f"{field}.{key}" if field else key,
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
    if not isinstance(kind, str) or kind not in sizes:
        reader.fail(f"{field}.type", f"unknown shape {_shorten(kind)} (use box, cylinder or sphere)")
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
        reader.fail(f"{field}.type", f"unknown joint type {_shorten(kind)} (use revolute or prismatic)")
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
        lo, hi = reader.vector(table["limits"], f"{field}.limits", 2, bounded=False)
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
    """Build a :class:`Robot` from a parsed robot file (see ``docs/robot-files.md``).

    Every value is checked where it is read; finally the robot's derived arrays
    (``Robot.arrays``, the transforms and inertials the kernels use) must be finite, which
    catches values that are finite one by one but overflow together (an inertia of 1e308).
    """
    # Overflow is detected by the checks, not reported by NumPy as warnings on the way.
    with np.errstate(all="ignore"):
        return _robot(data, str(file))


def _robot(data: dict, file: str) -> Robot:
    top = {"name", "description", "provenance", "dh_convention", "gravity", "base", "tool",
           "parameters", "joints"}
    bootstrap = _Reader(file, {})
    bootstrap.table(data, "")
    bootstrap.only(data, "", top)
    names: dict[str, float] = {}
    parameters = bootstrap.table(data.get("parameters", {}), "parameters")
    reader = _Reader(file, names)
    for key, value in parameters.items():
        field = f"parameters.{key}"
        if not key.isidentifier() or keyword.iskeyword(key) or key in _RESERVED:
            reader.fail(field, "a parameter name must be an identifier (letters, digits, _) other "
                               f"than a Python keyword or {', '.join(sorted(_RESERVED))}")
        reader.name(key, field)
        # Parameters may refer to earlier parameters (TOML keeps the file's order).
        names[key] = reader.number(value, field)
    convention = data.get("dh_convention", "standard")
    if convention not in ("standard", "modified"):
        reader.fail("dh_convention", f"unknown convention {_shorten(convention)} (use standard or modified)")
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
    name = reader.name(data.get("name", Path(file).stem or "robot"), "name")
    description = reader.text(data.get("description", ""), "description")
    reader.text(data.get("provenance", ""), "provenance")
    robot = Robot(
        name=name,
        joints=tuple(j for j, _ in pairs),
        links=tuple(lk for _, lk in pairs),
        gravity=gravity, base=base, tool=tool,
        description=description,
        source=str(file), parameters=dict(names), spec=data,
    )
    part = nonfinite_part(robot)
    if part is not None:
        kind, i = part
        field = {"joint": f"joints[{i}]", "link": f"joints[{i}].link"}.get(kind, kind)
        reader.fail(field, "its values overflow: the robot's transforms or inertials are not finite")
    return robot


def load_robot_toml(path: str | Path) -> Robot:
    """Load a TOML robot file; malformed input raises :class:`RobotFileError`.

    The file must be a regular file of at most ``armlab.inputs.TOML_LIMIT`` bytes.
    """
    data = read_input_toml(path, RobotFileError)
    return robot_from_dict(data, str(path))
