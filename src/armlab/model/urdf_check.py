"""The checks a URDF document passes before any URDF library sees it.

A URDF file is untrusted XML.  It is read once with ``expat`` (the standard library's
non-validating parser) configured so that nothing outside the document is ever read and
nothing inside it expands:

* a document type declaration (``<!DOCTYPE …>``) is refused outright, so no entity — internal
  (the "billion laughs" expansion bomb) or external (a local file, a URL) — can be declared,
  and parameter entities are never parsed; URDF needs none;
* the root element is ``<robot>``; elements nest at most :data:`MAX_DEPTH` deep;
* every ``<link>`` and ``<joint>`` of the robot has a name used once; names (the robot's too)
  are single lines of printable text;
* every numeric attribute URDF defines (``<origin xyz rpy>``, ``<axis xyz>``, ``<mass value>``,
  ``<inertia ixx … izz>``, ``<limit>``, ``<dynamics>``, shapes, colours …) holds the right number
  of finite numbers, at most ``MAX_MAGNITUDE`` (1e12) in magnitude except joint limits.

Every problem raises :class:`RobotFileError` naming the file and the element, e.g.
``arm.urdf: joint[elbow].origin.xyz: expected 3 numbers, got 2``.
"""

from __future__ import annotations

import math
from xml.parsers import expat

from armlab.errors import RobotFileError
from armlab.model.toml_io import MAX_MAGNITUDE

MAX_DEPTH = 32
"""Deepest nesting of elements accepted in a URDF (real files nest about 5 deep)."""

# (element, attribute) → how many numbers it holds (a tuple: any of these counts).
_INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
NUMERIC_ATTRIBUTES: dict[str, dict[str, tuple[int, ...]]] = {
    "origin": {"xyz": (3,), "rpy": (3,)},
    "axis": {"xyz": (3,)},
    "mass": {"value": (1,)},
    "inertia": {key: (1,) for key in _INERTIA},
    "limit": {key: (1,) for key in ("lower", "upper", "effort", "velocity")},
    "dynamics": {"damping": (1,), "friction": (1,)},
    "mimic": {"multiplier": (1,), "offset": (1,)},
    "safety_controller": {key: (1,) for key in ("soft_lower_limit", "soft_upper_limit",
                                                 "k_position", "k_velocity")},
    "calibration": {"rising": (1,), "falling": (1,)},
    "box": {"size": (3,)},
    "cylinder": {"radius": (1,), "length": (1,)},
    "sphere": {"radius": (1,)},
    "capsule": {"radius": (1,), "length": (1,)},
    "mesh": {"scale": (1, 3)},
    "color": {"rgba": (4,)},
}


# Joint limits may be as large as any float (a "no limit" written as ±1e16); the others are
# bounded like every number of a TOML robot file.
_UNBOUNDED = {"limit", "safety_controller", "calibration"}


class _Scan:
    """expat handlers that check the document as it is read."""

    def __init__(self, path):
        self.path = path
        self.stack: list[str] = []  # field path of the open elements: ["joint[elbow]", "origin"]
        self.names: dict[str, set[str]] = {"link": set(), "joint": set()}

    def fail(self, field: str, reason: str):
        raise RobotFileError(self.path, field, reason)

    def doctype(self, *_):
        self.fail("xml", "a document type declaration (<!DOCTYPE>) is not allowed in a URDF "
                         "(no entities are ever expanded or loaded)")

    def entity(self, *_):
        self.fail("xml", "entity declarations are not allowed in a URDF")

    def start(self, tag: str, attributes: dict):
        depth = len(self.stack)
        if depth == 0 and tag != "robot":
            self.fail("xml", f"the root element is <{tag[:40]}>, not <robot>")
        if depth == 0 and not attributes.get("name", "x").isprintable():
            self.fail("robot.name", "must be one line of printable text")
        if depth >= MAX_DEPTH:
            self.fail(".".join(self.stack[:3]) + ".…", f"elements nested more than {MAX_DEPTH} deep")
        segment = tag
        if depth == 1 and tag in self.names:
            name = attributes.get("name")
            if not name:
                self.fail(tag, f"a <{tag}> without a name")
            if not name.isprintable():
                self.fail(f"{tag}[{name}]", "the name must be one line of printable text")
            if name in self.names[tag]:
                self.fail(f"{tag}[{name}]", f"{tag} name {name!r} is used twice")
            self.names[tag].add(name)
            segment = f"{tag}[{name}]"
        self.stack.append(segment)
        bound = math.inf if tag in _UNBOUNDED else MAX_MAGNITUDE
        for attribute, counts in NUMERIC_ATTRIBUTES.get(tag, {}).items():
            if attribute in attributes:
                field = ".".join([*self.stack[1:], attribute])
                self.numbers(attributes[attribute], counts, field, bound)

    def end(self, _tag: str):
        self.stack.pop()

    def numbers(self, text: str, counts: tuple[int, ...], field: str, bound: float):
        parts = text.split()
        if len(parts) not in counts:
            expected = " or ".join(str(c) for c in counts)
            self.fail(field, f"expected {expected} number{'s' if counts != (1,) else ''}, "
                             f"got {len(parts)} ({text[:60]!r})")
        for part in parts:
            try:
                value = float(part)
            except ValueError:
                self.fail(field, f"expected a number, got {part[:40]!r}")
            if not math.isfinite(value):
                self.fail(field, f"expected a finite number, got {part[:40]!r}")
            if abs(value) > bound:
                self.fail(field, f"{value:g} is beyond ±{bound:g}, the largest magnitude of a "
                                 "geometric or inertial value")


def check_urdf_document(data: bytes, path) -> None:
    """Check the URDF document ``data`` (the file's bytes) as the module docstring says."""
    scan = _Scan(path)
    parser = expat.ParserCreate()
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    parser.StartDoctypeDeclHandler = scan.doctype
    parser.EntityDeclHandler = scan.entity
    parser.StartElementHandler = scan.start
    parser.EndElementHandler = scan.end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as error:
        raise RobotFileError(path, "xml", f"not well-formed XML ({expat.ErrorString(error.code)}: "
                                          f"line {error.lineno}, column {error.offset})") from None
