"""``armlab robots``: list the bundled robots, or describe one (DH table or joint placements,
inertials, motors, friction) and optionally export it as URDF."""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import numpy as np

from armlab.commands import (
    add_allow_outside_argument,
    add_tip_argument,
    format_matrix,
    format_number,
    format_table,
)

if TYPE_CHECKING:
    from armlab.model.robot import Robot

KIND_LETTER = {"revolute": "R", "prismatic": "P"}
JOINT_VARIABLE = {"revolute": "theta", "prismatic": "d"}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "robots", help="list the bundled robots or describe one",
        description="Without NAME: a table of the bundled robots.  With NAME (a bundled robot or "
                    "a .toml/.urdf file): its DH table or joint placements, inertials, motors and "
                    "friction.")
    parser.add_argument("name", nargs="?", metavar="NAME", help="bundled robot name or robot file")
    add_tip_argument(parser)
    add_allow_outside_argument(parser)
    parser.add_argument("--urdf", metavar="PATH", help="also write the robot as URDF to PATH")
    parser.add_argument("--zoo", action="store_true",
                        help="list the arms of installed description packages (example-robot-data), "
                             "loadable by name")
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.robots import load_robot

    if args.zoo:
        print(zoo_table())
        return 0
    if args.name is None:
        print(robots_table())
        return 0
    robot = load_robot(args.name, tip=args.tip, allow_outside=args.allow_outside)
    print(describe(robot))
    if args.urdf:
        from armlab.model.urdf_io import save_urdf

        print(f"\nURDF written to {save_urdf(robot, args.urdf)}")
    return 0


def joint_kinds(robot: Robot) -> str:
    """``"PRP"``: one letter per joint, base to tip."""
    return "".join(KIND_LETTER[j.kind] for j in robot.joints)


def robots_table() -> str:
    from armlab.robots import bundled_robot_names, load_robot

    rows = []
    for name in bundled_robot_names():
        robot = load_robot(name)
        rows.append([name, robot.n, joint_kinds(robot), robot.description])
    return format_table(["name", "DoF", "joints", "description"], rows)


def zoo_table() -> str:
    """The zoo's arms: name, DoF and joints when the package is installed, file and package."""
    from armlab.robots import load_robot, zoo

    rows, missing = [], set()
    for name in zoo.zoo_names():
        entry = zoo.ZOO[name]
        if zoo.installed(entry):
            robot = load_robot(name)
            rows.append([name, robot.n, joint_kinds(robot), entry.description, zoo.provenance(name)])
        else:
            missing.add(entry.package)
    out = [format_table(["name", "DoF", "joints", "description", "from"], rows)] if rows else []
    for package in sorted(missing):
        count = sum(entry.package == package for entry in zoo.ZOO.values())
        out.append(f"{count} arms of {package}, which is not installed: pip install {package}")
    return "\n".join(out)


# ------------------------------------------------------------------ symbolic-looking DH rows
def pretty_expression(raw) -> str:
    """A robot-file value as text: numbers compact, ``pi`` as π, ``*`` as ·."""
    if isinstance(raw, (int, float)):
        return format_number(float(raw))
    text = re.sub(r"\bpi\b", "π", str(raw).strip())
    return text.replace("**", "^").replace("*", "·")


def _with_variable(raw, variable: str) -> str:
    """The DH entry of the joint variable: ``L2/2 + d1``, ``d3 - L4/2``, ``θ2``."""
    if isinstance(raw, (int, float)) and raw == 0 or str(raw).strip() in ("0", "0.0"):
        return variable
    text = pretty_expression(raw)
    if text.startswith("-"):
        return f"{variable} - {text[1:].strip()}"
    return f"{text} + {variable}"


def _variable_name(joint, index: int) -> str:
    name = joint.name
    return name.replace("theta", "θ") if name else f"{JOINT_VARIABLE[joint.kind]}{index + 1}"


def dh_rows(robot: Robot, *, symbolic: bool = True, q=None) -> list[list[str]]:
    """Rows ``[i−1 → i, a, α, d, θ]`` of the DH table from Σ_0 (standard or modified, as the
    robot's rows), symbolic (expressions of the robot file, joint variable added) or numeric
    at ``q``.  A base row ``base → 0`` comes first when the base transform is a DH row."""
    rows = []
    spec = robot.spec or {}
    base_dh = (spec.get("base") or {}).get("dh") if isinstance(spec.get("base"), dict) else None
    if base_dh is not None:
        values = [base_dh.get(k, 0) for k in ("a", "alpha", "d", "theta")]
        if symbolic:
            rows.append(["base → 0", *[pretty_expression(v) for v in values]])
        else:
            from armlab.model.toml_io import evaluate_expression

            numbers = [v if isinstance(v, (int, float)) else evaluate_expression(v, robot.parameters)
                       for v in values]
            rows.append(["base → 0", *[format_number(float(v)) for v in numbers]])
    q = np.zeros(robot.n) if q is None else np.asarray(q, dtype=float)
    spec_joints = spec.get("joints") or [{}] * robot.n
    for i, joint in enumerate(robot.joints):
        row = joint.dh
        if row is None:
            raise ValueError(f"joint {joint.name!r} is not given by a DH row")
        label = f"{i} → {i + 1}"
        raw = (spec_joints[i].get("dh") if i < len(spec_joints) else None) or {
            "a": row.a, "alpha": row.alpha, "d": row.d, "theta": row.theta}
        if symbolic:
            variable = _variable_name(joint, i)
            a, alpha = pretty_expression(raw["a"]), pretty_expression(raw["alpha"])
            d = (_with_variable(raw["d"], variable) if joint.kind == "prismatic"
                 else pretty_expression(raw["d"]))
            theta = (_with_variable(raw["theta"], variable) if joint.kind == "revolute"
                     else pretty_expression(raw["theta"]))
            rows.append([label, a, alpha, d, theta])
        else:
            d = row.d + (q[i] if joint.kind == "prismatic" else 0.0)
            theta = row.theta + (q[i] if joint.kind == "revolute" else 0.0)
            rows.append([label, *[format_number(v) for v in (row.a, row.alpha, d, theta)]])
    return rows


DH_HEADERS = ["i−1 → i", "a [m]", "α [rad]", "d [m]", "θ [rad]"]


# ---------------------------------------------------------------------------- description
def _vector(v) -> str:
    return "(" + ", ".join(format_number(x) for x in v) + ")"


def describe(robot: Robot) -> str:
    """Multi-line description of ``robot`` (what ``armlab robots NAME`` prints)."""
    from armlab.spatial import rpy_from_matrix

    out = [f"{robot.name}: {robot.description}".rstrip(": ")]
    provenance = (robot.spec or {}).get("provenance")
    if provenance:
        out.append(f"provenance: {provenance}")
    if robot.source:
        out.append(f"file: {robot.source}")
    for note in robot.notes:
        out.append(f"note: {note}")
    out.append(f"{robot.n} joints ({joint_kinds(robot)}), gravity g_0 = {_vector(robot.gravity)} m/s² in Σ_0")
    if robot.parameters:
        out.append("\nParameters")
        out.append(format_table(["name", "value"],
                                [[k, format_number(v, 6)] for k, v in robot.parameters.items()], "  "))
    if robot.is_dh:
        convention = robot.joints[0].dh.convention
        out.append(f"\nDH table ({convention} convention; the joint variable adds to d or θ; a first "
                   "row base → 0 is the fixed transform Σ_base → Σ_0)")
        out.append(format_table(DH_HEADERS, dh_rows(robot), "  "))
    else:
        out.append("\nJoint placements T_{i−1,i}(0) (origin in Σ_{i−1}, RPY [rad], axis in Σ_{i−1})")
        rows = []
        for joint in robot.joints:
            T = joint.transform(0.0)
            rows.append([joint.name, joint.kind, _vector(T[:3, 3]), _vector(rpy_from_matrix(T[:3, :3])),
                         _vector(joint.before[:3, 2])])
        out.append(format_table(["joint", "type", "origin [m]", "rpy [rad]", "axis"], rows, "  "))
    out.append("\nBase T_base,0 (Σ_0 in Σ_base)")
    out.append(format_matrix(robot.base, "  "))
    if not np.allclose(robot.tool, np.eye(4)):
        out.append("Tool T_n,e (Σ_e in Σ_n)")
        out.append(format_matrix(robot.tool, "  "))
    out.append("\nJoints: limits, motors (k_r gear ratio, I_m rotor inertia, m_m mass) and friction")
    rows = []
    for joint in robot.joints:
        unit = "m" if joint.kind == "prismatic" else "rad"
        lo, hi = joint.limits
        motor = joint.motor
        rows.append([joint.name, f"[{format_number(lo)}, {format_number(hi)}] {unit}",
                     format_number(motor.gear_ratio), f"{motor.rotor_inertia:.3g}",
                     format_number(motor.mass), f"{motor.gear_ratio ** 2 * motor.rotor_inertia:.4g}",
                     format_number(joint.friction.viscous), format_number(joint.friction.coulomb)])
    out.append(format_table(["joint", "limits", "k_r", "I_m [kg·m²]", "m_m [kg]", "k_r²·I_m",
                             "F_v", "F_s"], rows, "  "))
    out.append("\nLinks: mass, centre of mass and inertia about it, in the link frame Σ_i")
    rows = []
    for link in robot.links:
        inertial = link.inertial
        I = inertial.inertia
        shape = inertial.shape.get("type", "") if inertial.shape else ""
        rows.append([link.name, format_number(inertial.mass), _vector(inertial.com),
                     _vector([I[0, 0], I[1, 1], I[2, 2]]), _vector([I[0, 1], I[0, 2], I[1, 2]]), shape])
    out.append(format_table(["link", "mass [kg]", "com [m]", "Ixx, Iyy, Izz [kg·m²]",
                             "Ixy, Ixz, Iyz", "shape"], rows, "  "))
    if any(j.motor.mass for j in robot.joints[1:]):
        out.append("  (motor i's mass is carried by link i−1 at joint i: see robot.arrays)")
    return "\n".join(out)
