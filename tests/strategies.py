"""Hypothesis strategies: random valid serial robots, states and helpers for tests.

``robots()`` draws the structure (number of joints, revolute/prismatic, standard DH, modified
DH or origin/axis placement, whether motors and friction are present) from hypothesis and the
numbers from a NumPy generator seeded by hypothesis, so examples stay reproducible and cheap
to draw.  Every inertia tensor is physical: I_C = R diag(m(σ_y² + σ_z²), m(σ_x² + σ_z²),
m(σ_x² + σ_y²)) Rᵀ, the tensor of a mass distribution with second moments σ².

``mutated_tables`` and ``damaged_text`` turn the parsed TOML or the text of a valid file into
hostile variants for the fuzz tests of the file readers (``test_fuzz_files.py``).
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import replace

import numpy as np
from hypothesis import strategies as st

from armlab.model.robot import DHRow, Friction, Inertial, Joint, Link, Motor, Robot
from armlab.spatial import rotation_to_axis


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation matrix (3, 3) from a random unit quaternion (uniform on SO(3))."""
    w, x, y, z = _unit(rng)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=4)
    return v / np.linalg.norm(v)


def random_transform(rng: np.random.Generator, scale: float = 0.5) -> np.ndarray:
    """A homogeneous transform (4, 4) with a random rotation and translation in [−scale, scale]³."""
    T = np.eye(4)
    T[:3, :3] = random_rotation(rng)
    T[:3, 3] = rng.uniform(-scale, scale, 3)
    return T


def random_inertial(rng: np.random.Generator) -> Inertial:
    """Mass 0.2–5 kg, COM within 0.3 m of the link frame, a physical inertia tensor."""
    mass = rng.uniform(0.2, 5.0)
    sigma2 = rng.uniform(0.0005, 0.05, 3)
    principal = mass * np.array([sigma2[1] + sigma2[2], sigma2[0] + sigma2[2], sigma2[0] + sigma2[1]])
    R = random_rotation(rng)
    return Inertial(mass=mass, com=rng.uniform(-0.3, 0.3, 3), inertia=R @ np.diag(principal) @ R.T)


def _joint(rng: np.random.Generator, name: str, kind: str, placement: str, motor: bool,
           friction: bool) -> Joint:
    extras = {}
    if motor:
        extras["motor"] = Motor(gear_ratio=float(rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 100.0)),
                                rotor_inertia=rng.uniform(1e-6, 1e-4), mass=rng.uniform(0.0, 1.0))
    if friction:
        extras["friction"] = Friction(viscous=rng.uniform(0.0, 2.0), coulomb=rng.uniform(0.0, 1.0))
    if placement in ("standard", "modified"):
        row = DHRow(a=rng.uniform(-0.5, 0.5), alpha=rng.uniform(-np.pi, np.pi), d=rng.uniform(-0.5, 0.5),
                    theta=rng.uniform(-np.pi, np.pi), convention=placement)
        return Joint.from_dh(name, kind, row, limits=(-np.pi, np.pi), **extras)
    # origin/axis joint, as in URDF: P = origin · R_axis, S = R_axisᵀ
    align = np.eye(4)
    align[:3, :3] = rotation_to_axis(rng.normal(size=3))
    before = random_transform(rng) @ align
    return Joint(name=name, kind=kind, before=before, after=np.linalg.inv(align),
                 offset=rng.uniform(-0.3, 0.3), limits=(-np.pi, np.pi), **extras)


@st.composite
def robots(draw, min_joints: int = 1, max_joints: int = 7, motors: bool | None = False,
           friction: bool | None = False, placements=("standard", "modified", "origin")) -> Robot:
    """A random serial robot.  ``motors``/``friction``: True, False or None (either)."""
    n = draw(st.integers(min_joints, max_joints))
    kinds = draw(st.lists(st.sampled_from(["revolute", "prismatic"]), min_size=n, max_size=n))
    where = draw(st.lists(st.sampled_from(list(placements)), min_size=n, max_size=n))
    with_motors = draw(st.booleans()) if motors is None else motors
    with_friction = draw(st.booleans()) if friction is None else friction
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    joints = tuple(_joint(rng, f"j{i + 1}", kinds[i], where[i], with_motors, with_friction)
                   for i in range(n))
    links = tuple(Link(name=f"l{i + 1}", inertial=random_inertial(rng)) for i in range(n))
    gravity = rng.normal(size=3)
    gravity *= 9.81 / np.linalg.norm(gravity)
    return Robot(name=f"random{n}", joints=joints, links=links, gravity=gravity,
                 base=random_transform(rng), tool=random_transform(rng, 0.2))


@st.composite
def states(draw, n: int, scale: float = 2.0):
    """(q, qd, qdd), each (n,), entries in [−scale, scale], from a seeded generator."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    return tuple(rng.uniform(-scale, scale, n) for _ in range(3))


def without_actuators(robot: Robot) -> Robot:
    """The robot with rotor inertias and friction removed (motor masses kept on the links):
    the pure rigid-body tree that URDF and Pinocchio describe."""
    joints = tuple(replace(j, motor=Motor(gear_ratio=j.motor.gear_ratio, rotor_inertia=0.0,
                                          mass=j.motor.mass), friction=Friction())
                   for j in robot.joints)
    return robot.replace(joints=joints)



# ------------------------------------------------------------------ hostile mutations of files
# What a hostile or careless author writes where a value belongs: other types, non-finite and
# huge numbers, expressions that break naive evaluators, strings that break naive printers.
NON_FINITE = (math.nan, math.inf, -math.inf)
HOSTILE_VALUES = (
    *NON_FINITE, 10**400, -(10**400), 1e308, -1e308, 1e300, 1e13, 0, 0.0, -1, -1e-300, 1e-300,
    True, False, "", " ", "x", "nan", "inf", "1e999", "True", "(-1)**0.5", "10**10**10",
    "9**9**9", "2**-1e9", "0**-1", "sqrt(-1)", "pi/0", "+1" * 1000, "-" * 5000 + "1", "1" * 5000,
    "(" * 300 + "1" + ")" * 300, "__import__('os').getcwd()", "L2/2", "pi/2", "a\nb", "\x1b[2J",
    "x\u2028y", "fifo.toml", "zero.toml", "missing.toml", "directory.toml", [], [1], [1, 2],
    [0, 0, 0], [[1, 2], [3]], [[[[[1]]]]], [math.nan, 0, 0], [True, 0, 0], {}, {"type": "x"},
    {"a": 1},
)
"""Replacement values for a mutated TOML table."""


def is_poison(value, *, booleans: bool) -> bool:
    """Whether a TOML value can be right nowhere: NaN, ±inf, an integer beyond the float range,
    and (``booleans``: for files without boolean fields) true or false."""
    if isinstance(value, bool):
        return booleans
    if isinstance(value, float):
        return not math.isfinite(value)
    if isinstance(value, int):
        return abs(value) > 1.8e308
    if isinstance(value, list):
        return any(is_poison(v, booleans=booleans) for v in value)
    if isinstance(value, dict):
        return any(is_poison(v, booleans=booleans) for v in value.values())
    return False


def _places(data, found=None):
    """(container, key) of every value in a parsed TOML document, tables and arrays included."""
    found = [] if found is None else found
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        found.append((data, key))
        if isinstance(value, (dict, list)):
            _places(value, found)
    return found


@st.composite
def mutated_tables(draw, data: dict, max_mutations: int = 3) -> dict:
    """A deep copy of the parsed TOML ``data`` after 1…``max_mutations`` edits: a value replaced
    by one of :data:`HOSTILE_VALUES` or by another value of the same file (a name duplicated,
    a table where a number was), a key deleted, a key added, an array entry repeated."""
    data = copy.deepcopy(data)
    for _ in range(draw(st.integers(1, max_mutations))):
        places = _places(data)
        container, key = places[draw(st.integers(0, len(places) - 1))]
        operation = draw(st.sampled_from(["hostile", "hostile", "other", "delete", "add", "repeat"]))
        if operation == "hostile":
            container[key] = copy.deepcopy(draw(st.sampled_from(HOSTILE_VALUES)))
        elif operation == "other":
            source, source_key = places[draw(st.integers(0, len(places) - 1))]
            container[key] = copy.deepcopy(source[source_key])
        elif operation == "delete":
            del container[key]
        elif operation == "add":
            target = container[key] if isinstance(container[key], (dict, list)) else container
            value = copy.deepcopy(draw(st.sampled_from(HOSTILE_VALUES)))
            if isinstance(target, dict):
                target[draw(st.sampled_from(["extra", "name", "type", "mass", "a\nb", ""]))] = value
            else:
                target.append(value)
        elif isinstance(container, list):
            container.insert(key, copy.deepcopy(container[key]))
        else:
            container[key] = [copy.deepcopy(container[key])] * 2
    return data


def toml_dumps(data: dict) -> str:
    """TOML text of a parsed document (every table written inline; ``tomllib.loads`` gives
    ``data`` back, NaN and ±inf included)."""
    return "".join(f"{_toml_key(k)} = {_toml_value(v)}\n" for k, v in data.items())


def _toml_key(key: str) -> str:
    return _toml_string(key)


def _toml_string(text: str) -> str:
    # JSON's escapes are TOML's, except that TOML also wants DEL escaped.
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"


@st.composite
def damaged_text(draw, text: str) -> str:
    """``text`` cut short, or with a few characters inserted or deleted at random places."""
    operation = draw(st.sampled_from(["truncate", "insert", "delete"]))
    at = draw(st.integers(0, len(text)))
    if operation == "truncate":
        return text[:at]
    if operation == "insert":
        return text[:at] + draw(st.sampled_from(['"', "'", "[", "]", "{", "=", "\n", "<", ">", "&",
                                                "\x00", "\ufeff", "#", "\\", "nan"])) + text[at:]
    return text[:at] + text[at + draw(st.integers(1, 20)):]


HOSTILE_ATTRIBUTES = ("nan", "inf", "-inf", "1e999", "NaN 0 0", "0 0 inf", "1e308", "-1e308",
                      "1e300 0 0", "1e13", "1", "1 2", "1 2 3 4", "0 0 0", "", " ", "x", "-1",
                      "0x10", "1_0", "0 0 1", "base", "upper", "shoulder", "fixed", "floating")
"""Replacement attribute values for a mutated URDF."""

NUMERIC_URDF_ATTRIBUTES = {"origin": ("xyz", "rpy"), "axis": ("xyz",), "mass": ("value",),
                           "inertia": ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"),
                           "limit": ("lower", "upper", "effort", "velocity"),
                           "dynamics": ("damping", "friction")}
"""Where URDF holds numbers (the URDF specification): a non-finite value there is never valid."""

BILLION_LAUGHS = ('<!DOCTYPE robot [<!ENTITY a "aaaaaaaaaa">'
                  + "".join(f'<!ENTITY {chr(98 + k)} "{("&" + chr(97 + k) + ";") * 10}">'
                            for k in range(9)) + "]>\n")
EXTERNAL_ENTITY = '<!DOCTYPE robot [<!ENTITY x SYSTEM "file:///etc/hostname">]>\n'


@st.composite
def mutated_urdf(draw, text: str, max_mutations: int = 3) -> tuple[str, bool]:
    """(text, poisoned): ``text`` after 1…``max_mutations`` edits of its XML tree (an attribute
    given a hostile value, an element deleted, duplicated or renamed, the root renamed) or a DTD
    with entities put in front.  ``poisoned`` says that no valid robot can come out of the result
    (see :func:`urdf_poisoned`)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(text)
    doctype = ""
    for _ in range(draw(st.integers(1, max_mutations))):
        elements = list(root.iter())
        parents = {child: parent for parent in elements for child in parent}
        element = elements[draw(st.integers(0, len(elements) - 1))]
        operation = draw(st.sampled_from(["attribute", "attribute", "attribute", "delete",
                                          "duplicate", "rename", "doctype"]))
        if operation == "attribute":
            names = sorted(set(element.attrib) | set(NUMERIC_URDF_ATTRIBUTES.get(element.tag, ())))
            if names:
                element.set(draw(st.sampled_from(names)), draw(st.sampled_from(HOSTILE_ATTRIBUTES)))
        elif operation == "delete" and element in parents:
            parents[element].remove(element)
        elif operation == "duplicate" and element in parents:
            parents[element].append(copy.deepcopy(element))
        elif operation == "rename":
            element.tag = draw(st.sampled_from(["robot", "link", "joint", "origin", "sdf", "x"]))
        elif operation == "doctype":
            doctype = draw(st.sampled_from([BILLION_LAUGHS, EXTERNAL_ENTITY]))
            if draw(st.booleans()):
                root.set("name", "&j;" if doctype is BILLION_LAUGHS else "&x;")
    body = ET.tostring(root, encoding="unicode").replace("&amp;j;", "&j;").replace("&amp;x;", "&x;")
    return f'<?xml version="1.0"?>\n{doctype}{body}\n', urdf_poisoned(root, doctype)


def urdf_poisoned(root, doctype: str) -> bool:
    """Whether no valid robot can come from a URDF tree: a DTD (entities), a root other than
    <robot>, two links or two joints of one name, a non-finite number where URDF holds numbers."""
    if doctype or root.tag != "robot":
        return True
    for tag in ("link", "joint"):
        names = [child.get("name") for child in root if child.tag == tag and child.get("name")]
        if len(names) != len(set(names)):
            return True
    return any(not math.isfinite(float(part))
               for element in root.iter() for name in NUMERIC_URDF_ATTRIBUTES.get(element.tag, ())
               for part in element.get(name, "").split() if _is_float(part))


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
