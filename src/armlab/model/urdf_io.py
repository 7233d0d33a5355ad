"""URDF out (``to_urdf``, ``save_urdf``) and in (``load_urdf``, through ``yourdfpy``).

Export.  The URDF written for a :class:`Robot` has one link per frame of the description:

* ``world`` — only when gravity is not along −z of Σ_base: the root, z up, with a fixed joint
  ``world_to_base`` rotating Σ_base so that g points along −z of ``world`` (URDF has no
  gravity element; every reader takes it as −z of the root).  Reading the file back gives
  Σ_base = ``world``, so g_0 and the joint-space dynamics (B, C q̇, g) are unchanged while
  coordinates "in Σ_base" are those of ``world``.  Only the direction of g is written: a
  magnitude other than 9.81 m/s² is passed as ``load_urdf(gravity=)``;
* ``base`` — Σ_base, the root otherwise; a fixed joint ``base_to_sigma_0`` places ``sigma_0``
  (Σ_0) at the robot's base transform T_base0;
* one link per joint frame J_i, named after the robot's link i, moved by a joint named after
  the robot's joint i.  Its origin is the constant part of (K2) with the joint offset folded in,

      T_{J_{i−1} J_i}(q_i) = X_i · M_i(q_i + offset_i) = [X_i · M_i(offset_i)] · M_i(q_i)   (U1)

  (M_i is a rotation about or a translation along z, so M(a + b) = M(a) M(b)); the axis is z;
* the link's inertial (mass, centre of mass and inertia about it, in J_i — the values of
  ``robot.arrays``, motor masses lumped) on the J_i link;
* massless fixed child frames ``sigma_1`` … ``sigma_n`` (Σ_i = J_i · S_i, the DH frames of a
  DH robot) and ``sigma_e`` (Σ_e = Σ_n · T_tool, a child of ``sigma_n``), so every frame of
  :func:`armlab.link_frames` has a URDF link of its own.

Motor rotor inertias and gear ratios have no URDF element and are not written; friction is
written as ``<dynamics damping friction>`` (F_v, F_s).

Import.  :func:`load_urdf` reads the serial chain from the root link to a tip link.  Fixed
joints are merged: their child's inertial is lumped into the moving body that carries it
(parallel-axis theorem), and the fixed transforms fold into the next joint's placement
P_i = (fixed transforms) · origin · R_axis with S_i = R_axisᵀ, exactly as a TOML
``origin``/``axis`` joint.  Σ_0 is the link that carries the first moving joint; the fixed
transforms from the root up to it form the base transform T_base0.
"""

from __future__ import annotations

import io
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from armlab.inputs import URDF_LIMIT, read_input_bytes
from armlab.model.inertia import inertia_problem, steiner
from armlab.model.references import OUTSIDE_HINT
from armlab.model.robot import Friction, Inertial, Joint, Link, Robot, nonfinite_part
from armlab.model.toml_io import RobotFileError, axis_alignment
from armlab.model.urdf_check import check_urdf_document
from armlab.model.visuals import place_visuals
from armlab.spatial import hom_rot_z, inverse_transform, rpy_from_matrix, trans_z, transform

STANDARD_GRAVITY = np.array([0.0, 0.0, -9.81])
"""URDF has no gravity element; by convention the root frame's z axis points up [m/s²]."""


def _fmt(values) -> str:
    # repr() of a float is the shortest string that round-trips exactly.
    return " ".join(repr(float(v)) for v in np.atleast_1d(values))


def _origin(parent: ET.Element, T: np.ndarray) -> None:
    ET.SubElement(parent, "origin", xyz=_fmt(T[:3, 3]), rpy=_fmt(rpy_from_matrix(T[:3, :3])))


def _fixed(root: ET.Element, name: str, parent: str, child: str, T: np.ndarray) -> None:
    joint = ET.SubElement(root, "joint", name=name, type="fixed")
    _origin(joint, T)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)


def urdf_names(robot: Robot) -> tuple[list[str], list[str]]:
    """URDF names of the links (bodies in J_i) and joints of ``robot``, made unique
    against each other and the frame links ``base``, ``sigma_0`` … ``sigma_e``."""
    reserved = {"base", "sigma_0", "sigma_e", "base_to_sigma_0", "sigma_n_to_sigma_e",
                "world", "world_to_base"}
    reserved |= {f"sigma_{i + 1}" for i in range(robot.n)}
    reserved |= {f"to_sigma_{i + 1}" for i in range(robot.n)}
    used = set(reserved)
    out = []
    for names in ([lk.name for lk in robot.links], robot.joint_names):
        result = []
        for name in names:
            candidate, k = name, 1
            while candidate in used:
                k += 1
                candidate = f"{name}_{k}"
            used.add(candidate)
            result.append(candidate)
        out.append(result)
    return out[0], out[1]


def world_rotation(robot: Robot) -> np.ndarray:
    """R_world,base of the export: the smallest rotation taking g (in Σ_base) to −z, (3, 3);
    the identity when g is along −z already or zero (then no ``world`` link is written)."""
    g = robot.base[:3, :3] @ np.asarray(robot.gravity, dtype=float)
    norm = float(np.linalg.norm(g))
    if norm == 0.0:
        return np.eye(3)
    a, b = g / norm, np.array([0.0, 0.0, -1.0])
    v, c = np.cross(a, b), float(a @ b)
    if c < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])  # g along +z: half a turn about x
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    # Rodrigues for unit a → b: R = I + [v]× + [v]×² / (1 + c), v = a × b, c = a·b.
    R = np.eye(3) + K + K @ K / (1.0 + c)
    return np.eye(3) if np.allclose(R, np.eye(3), rtol=0.0, atol=1e-15) else R


def to_urdf(robot: Robot) -> str:
    """The URDF text of ``robot`` (see the module docstring for the frames it contains).

    Parameters
    ----------
    robot : Robot
        Any armlab robot; its links become URDF links in the joint frames J_i.

    Returns
    -------
    str
        A URDF document; Pinocchio's ``buildModelFromXML`` and ``yourdfpy`` read it.
    """
    m = robot.arrays
    link_names, joint_names = urdf_names(robot)
    root = ET.Element("robot", name=robot.name)
    R_world = world_rotation(robot)
    if not np.array_equal(R_world, np.eye(3)):
        ET.SubElement(root, "link", name="world")
        _fixed(root, "world_to_base", "world", "base", transform(R_world))
    ET.SubElement(root, "link", name="base")
    ET.SubElement(root, "link", name="sigma_0")
    _fixed(root, "base_to_sigma_0", "base", "sigma_0", robot.base)
    parent = "sigma_0"
    for i, joint in enumerate(robot.joints):
        revolute = joint.kind == "revolute"
        unlimited = not (np.isfinite(joint.limits[0]) and np.isfinite(joint.limits[1]))
        kind = ("continuous" if unlimited else "revolute") if revolute else "prismatic"
        element = ET.SubElement(root, "joint", name=joint_names[i], type=kind)
        # (U1): the constant part of the joint transform, offset folded in.
        _origin(element, transform(m.tree_R[i], m.tree_p[i]) @ joint.motion(0.0))
        ET.SubElement(element, "parent", link=parent)
        ET.SubElement(element, "child", link=link_names[i])
        ET.SubElement(element, "axis", xyz="0 0 1")
        if unlimited and not revolute:
            # URDF requires finite limits on a prismatic joint: an unbounded one gets ±1 km.
            lower, upper = -1e3, 1e3
        else:
            lower, upper = joint.limits
        if kind != "continuous":
            ET.SubElement(element, "limit", lower=_fmt(lower),
                          upper=_fmt(upper), effort="0", velocity="0")
        else:
            ET.SubElement(element, "limit", effort="0", velocity="0")
        ET.SubElement(element, "dynamics", damping=_fmt(joint.friction.viscous),
                      friction=_fmt(joint.friction.coulomb))
        link = ET.SubElement(root, "link", name=link_names[i])
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", xyz=_fmt(m.com[i]), rpy="0 0 0")
        ET.SubElement(inertial, "mass", value=_fmt(m.mass[i]))
        I = m.inertia[i]
        ET.SubElement(inertial, "inertia", ixx=_fmt(I[0, 0]), ixy=_fmt(I[0, 1]), ixz=_fmt(I[0, 2]),
                      iyy=_fmt(I[1, 1]), iyz=_fmt(I[1, 2]), izz=_fmt(I[2, 2]))
        ET.SubElement(root, "link", name=f"sigma_{i + 1}")
        _fixed(root, f"to_sigma_{i + 1}", link_names[i], f"sigma_{i + 1}", joint.after)
        parent = link_names[i]
    ET.SubElement(root, "link", name="sigma_e")
    _fixed(root, "sigma_n_to_sigma_e", f"sigma_{robot.n}", "sigma_e", robot.tool)
    ET.indent(root)
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def save_urdf(robot: Robot, path: str | Path) -> Path:
    """Write :func:`to_urdf` of ``robot`` to ``path`` (atomically: complete or not at all,
    ``armlab.files``); returns the path."""
    from armlab.files import write_text

    return write_text(Path(path), to_urdf(robot))


# ----------------------------------------------------------------------------------- import
_MOVING = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic"}


def _fail(path, field: str, reason: str):
    raise RobotFileError(path, field, reason)


def _parse(path: Path):
    """The ``yourdfpy`` robot of ``path``; unreadable or malformed files fail in one line.

    The file (a regular file of at most ``armlab.inputs.URDF_LIMIT`` bytes) is read once and
    checked by :func:`~armlab.model.urdf_check.check_urdf_document` — no DTD, so no entity is
    ever expanded or loaded; root ``<robot>``; unique names; finite numeric attributes of the
    right length — before ``yourdfpy`` parses the same bytes.
    """
    import yourdfpy

    data = read_input_bytes(path, RobotFileError, URDF_LIMIT)
    try:
        data.decode("utf-8")
    except UnicodeDecodeError:
        _fail(path, "file", "is not UTF-8 text")
    check_urdf_document(data, path)
    try:
        urdf = yourdfpy.URDF.load(io.BytesIO(data), build_scene_graph=False, load_meshes=False,
                                  build_collision_scene_graph=False, load_collision_meshes=False)
    except Exception as error:  # yourdfpy raises plain ValueError/TypeError on bad attributes
        _fail(path, "urdf", " ".join(str(error).split()) or type(error).__name__)
    return urdf.robot


def _number(path, field: str, value, default: float) -> float:
    if value is None:
        return default
    try:
        result = float(value)
    except (TypeError, ValueError):
        _fail(path, field, f"expected a number, got {value!r}")
    if not math.isfinite(result):
        _fail(path, field, f"is not finite ({value!r})")
    return result


def _listing(names, limit: int = 8) -> str:
    names = list(names)
    return ", ".join(names[:limit]) + (f", … ({len(names)} in all)" if len(names) > limit else "")


def _check_finite(path, robot: Robot) -> None:
    """Values finite one by one may still overflow together (a mass of 1e308 lumped with
    another): the robot's derived arrays must be finite, else the part is named."""
    part = nonfinite_part(robot)
    if part is not None:
        kind, i = part
        field = {"joint": f"joint[{robot.joints[i].name}]" if i is not None else "joint",
                 "link": f"link[{robot.links[i].name}].inertial" if i is not None else "link"}
        _fail(path, field.get(kind, kind), "its values overflow: the robot's transforms or "
                                           "inertials are not finite")


def _chain(path, joints: dict, children: dict, root: str, tip: str | None,
           longest: bool = False) -> list:
    """URDF joints on the path root → tip, choosing the tip when it is not given.

    Without ``tip`` the chain ends at the only leaf link whose path holds every moving joint;
    with ``longest``, else at the only leaf with the most moving joints on its path (the rest
    are then locked).  When several leaves qualify, or (without ``longest``) the moving joints
    lie on several branches, the error lists the candidate tips (the leaves with the most
    moving joints on their path) and the link where those branches split.
    """
    parent_joint = {j.child: j for j in joints.values()}

    def path_to(link):
        chain = []
        while link != root:
            joint = parent_joint[link]
            chain.append(joint)
            if len(chain) > len(joints):
                _fail(path, f"joint[{joint.name}]", "the joints form a cycle (a URDF is a tree)")
            link = joint.parent
        return chain[::-1]

    if tip is not None:
        if tip not in parent_joint and tip != root:
            _fail(path, "tip", f"no link named {tip!r}")
        return path_to(tip)
    moving = {name for name, j in joints.items() if j.type in _MOVING}
    leaves = [link for link in [root, *parent_joint] if not children.get(link)]
    count = {leaf: len(moving & {j.name for j in path_to(leaf)}) for leaf in leaves}
    full = sorted(leaf for leaf in leaves if count[leaf] == len(moving))
    if len(full) == 1:
        return path_to(full[0])
    if full:
        _fail(path, "tip", f"the chain ends in several links ({_listing(full)}); "
              "pass tip= to choose one")
    most = max(count.values())
    best = sorted(leaf for leaf in leaves if count[leaf] == most)
    if longest and len(best) == 1:
        return path_to(best[0])
    # The link where the best branches split: the last link common to all their paths.
    paths = [[root] + [j.child for j in path_to(leaf)] for leaf in best]
    split = root
    for links in zip(*paths, strict=False):
        if len(set(links)) > 1:
            break
        split = links[0]
    hint = f" or the link where they split ({split})" if split != root and len(best) > 1 else ""
    _fail(path, "tip", f"the moving joints lie on several branches; the longest chains "
          f"({most} joints) end in {_listing(best)}: pass tip= one of them{hint} (moving joints "
          "off the chain are then locked)")


def _axis_alignment(path, joint) -> np.ndarray:
    axis = np.asarray(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), dtype=float)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-9:
        _fail(path, f"joint[{joint.name}].axis", f"must be a non-zero 3-vector, got {axis.tolist()}")
    return transform(axis_alignment(axis))


def _limits(path, joint) -> tuple[float, float] | None:
    """(lower, upper) of a revolute or prismatic joint's ``<limit>``; None for no limit (a
    continuous joint, no ``<limit>``, or the 0..0 that files write for 'not given')."""
    if joint.type == "continuous" or joint.limit is None:
        return None
    field = f"joint[{joint.name}]"
    lower = _number(path, f"{field}.limit.lower", joint.limit.lower, -np.inf)
    upper = _number(path, f"{field}.limit.upper", joint.limit.upper, np.inf)
    if lower == upper:
        return None
    if not lower < upper:
        _fail(path, f"{field}.limit", f"lower limit {lower:g} must be below upper limit {upper:g}")
    return lower, upper


def _lock_values(path, joints: dict, on_chain: set, lock: dict, default: dict) -> dict:
    """q at which each moving joint off the chain is locked.

    A joint named in ``lock`` takes that value; a ``<mimic>`` joint follows its (locked)
    master, q = multiplier · q_master + offset; a joint named in ``default`` takes that value;
    any other joint is locked at 0 — Pinocchio's neutral configuration, the one
    ``buildReducedModel`` is usually given — moved into the joint's limits when 0 lies outside
    them.
    """
    off = {name: j for name, j in joints.items() if j.type in _MOVING and name not in on_chain}
    for name, value in lock.items():
        if name not in off:
            reason = "is on the chain (only joints off it are locked)" if name in on_chain else \
                f"is not a moving joint off the chain ({_listing(sorted(off)) or 'there is none'})"
            _fail(path, f"lock[{name}]", reason)
        if not math.isfinite(value):
            _fail(path, f"lock[{name}]", f"must be a finite joint value, got {value!r}")
    values: dict[str, float] = {}

    def value_of(name, seen=()):
        if name in values:
            return values[name]
        joint = off[name]
        if name in lock:
            value = float(lock[name])
        elif joint.mimic is not None:
            master = joint.mimic.joint
            if master in on_chain:
                _fail(path, f"joint[{name}].mimic", f"follows joint {master!r} of the chain: a side "
                      "branch driven by the chain cannot be locked (choose another tip)")
            if master not in off or master in seen:
                _fail(path, f"joint[{name}].mimic", f"follows {master!r}, which is not a moving "
                      "joint of a side branch (or the mimic tags form a cycle)")
            multiplier = _number(path, f"joint[{name}].mimic.multiplier", joint.mimic.multiplier, 1.0)
            offset = _number(path, f"joint[{name}].mimic.offset", joint.mimic.offset, 0.0)
            value = multiplier * value_of(master, (*seen, name)) + offset
        elif name in default:
            value = float(default[name])
        else:
            limits = _limits(path, joint)
            value = 0.0 if limits is None else min(max(0.0, limits[0]), limits[1])
        values[name] = value
        return value

    for name in off:
        value_of(name)
    return values


@np.errstate(all="ignore")  # overflow is caught by the checks, not reported on the way
def load_urdf(path: str | Path, *, tip: str | None = None, gravity=None,
              name: str | None = None, lock: dict | None = None, allow_outside: bool = False) -> Robot:
    """Load the serial chain root → ``tip`` of a URDF file as a :class:`Robot`.

    Parameters
    ----------
    path : str or Path
        The URDF file.
    tip : str, optional
        Name of the link that carries the end effector Σ_e.  By default the only leaf link whose
        path from the root holds every moving joint; when several leaves qualify (e.g. a flange
        and a tool frame) or the moving joints lie on different branches, a
        :class:`RobotFileError` lists the candidate tips.
    gravity : array_like (3,), optional
        g_0 in Σ_0 [m/s²].  By default (0, 0, −9.81) in the root frame (URDF's z-up
        convention), rotated into Σ_0.
    name : str, optional
        The robot's name; the URDF's ``<robot name>`` by default.
    lock : dict, optional
        Joint name → value [rad | m] at which a moving joint off the chain is locked.
    allow_outside : bool
        Read mesh files that lie outside the URDF's own folder (``package://``, ``file://``,
        absolute paths, ``..``).  By default such a mesh is not read and ``robot.notes`` names
        it (:mod:`armlab.model.references`); meshes are for drawing only.

    Returns
    -------
    Robot
        Joints in URDF form (P_i = fixed transforms · origin · R_axis, S_i = R_axisᵀ), so the
        link frames Σ_i are the URDF links moved by the joints; Σ_0 is the link carrying the
        first moving joint and ``base`` the fixed transform root → Σ_0; ``tool`` the fixed
        transform Σ_n → ``tip``.  Fixed children are merged into the moving link that carries
        them (Steiner).  Moving joints off the chain (grippers, fingers, heads, other limbs)
        are locked — at ``lock``, their mimic value or 0 moved into their limits, as
        Pinocchio's ``buildReducedModel`` at the neutral configuration — and their links
        merged likewise; ``robot.notes`` says which.  ``<dynamics damping friction>`` become
        viscous and Coulomb friction; URDF has no motors.  A ``<mimic>`` on a fixed joint is
        ignored (as by Pinocchio); on a joint of the chain it is refused (every chain joint is
        a degree of freedom).  Limits 0..0 are read as no limit (files write them for 'not
        given'; Pinocchio keeps them but no dynamics algorithm reads them).
    """
    path = Path(path)
    urdf = _parse(path)
    return robot_from_tree(path, urdf.name, urdf.links, urdf.joints, tip=tip, gravity=gravity,
                           name=name, lock=lock, file_kind="URDF", allow_outside=allow_outside)


def robot_from_tree(path, tree_name, tree_links, tree_joints, *, tip=None, gravity=None, name=None,
                    lock=None, file_kind="URDF", root_gravity=STANDARD_GRAVITY,
                    default_lock=None, lock_rule="at 0 within limits unless given or mimicking",
                    allow_outside: bool = False, longest: bool = False) -> Robot:
    """The serial chain root → ``tip`` of a tree of links and joints in URDF form (the records
    of ``yourdfpy``, or any objects with their attributes), as described by :func:`load_urdf`.
    ``path`` names the file in errors; without ``gravity`` (g_0 in Σ_0), g is ``root_gravity``
    in the root link's frame.  ``default_lock`` (joint → value) replaces 0 as the value at which
    joints off the chain are locked; ``lock_rule`` says how, in the note.  Mesh files outside
    the file's folder are left out (and noted) unless ``allow_outside``.  ``longest``: without
    ``tip``, a tree whose moving joints lie on several branches ends at the one leaf with the
    most of them when there is one (MJCF: side branches have a pose of their own, ``qpos0``)."""
    links = {link.name: link for link in tree_links}
    joints = {}
    children: dict[str, list] = {}
    for joint in tree_joints:
        field = f"joint[{joint.name}]"
        if joint.name in joints:
            _fail(path, field, "duplicate joint name")
        if joint.type not in (*_MOVING, "fixed"):
            _fail(path, f"{field}.type", f"{joint.type} joints are not supported "
                  "(armlab models fixed-base serial chains of revolute and prismatic joints)")
        for role in ("parent", "child"):
            if getattr(joint, role) not in links:
                _fail(path, f"{field}.{role}", f"no link named {getattr(joint, role)!r}")
        if any(j.child == joint.child for j in joints.values()):
            _fail(path, f"{field}.child", f"link {joint.child!r} has two parent joints")
        joints[joint.name] = joint
        children.setdefault(joint.parent, []).append(joint)
    roots = sorted(set(links) - {j.child for j in joints.values()})
    if len(roots) != 1:
        _fail(path, "link", f"expected one root link, found {len(roots)} ({', '.join(roots)})")
    root = roots[0]
    chain = _chain(path, joints, children, root, tip, longest)
    moving = [j for j in chain if j.type in _MOVING]
    if not moving:
        _fail(path, "joint", f"no revolute, continuous or prismatic joint between {root!r} and the tip")
    for joint in moving:
        if joint.mimic is not None:
            _fail(path, f"joint[{joint.name}].mimic", f"joint {joint.name!r} of the chain follows "
                  f"joint {joint.mimic.joint!r}: coupled joints are not supported (every chain "
                  "joint is a degree of freedom in armlab; choose a tip before it)")

    # Walk the whole tree once: each link gets its body (0 = ground, i = moving link i) and its
    # pose in that body's frame (Σ_0 for the ground, the URDF child link of joint i otherwise).
    on_chain = {j.name for j in chain}
    locked = _lock_values(path, joints, on_chain, dict(lock or {}), dict(default_lock or {}))
    moving_index = {j.name: i + 1 for i, j in enumerate(moving)}
    body_of = {root: 0}
    pose_in_body = {root: np.eye(4)}
    sigma0 = moving[0].parent
    placements = {}
    stack = [root]
    while stack:
        link = stack.pop()
        for joint in children.get(link, []):
            origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, dtype=float)
            T = pose_in_body[link] @ origin
            if joint.type == "fixed":
                body_of[joint.child], pose_in_body[joint.child] = body_of[link], T
            elif joint.name in on_chain:
                placements[joint.name] = T @ _axis_alignment(path, joint)
                body_of[joint.child], pose_in_body[joint.child] = moving_index[joint.name], np.eye(4)
            else:
                # A side branch locked at q: origin · R_axis · M(q) · R_axisᵀ, a fixed joint.
                align = _axis_alignment(path, joint)
                q = locked[joint.name]
                motion = hom_rot_z(q) if _MOVING[joint.type] == "revolute" else trans_z(q)
                body_of[joint.child] = body_of[link]
                pose_in_body[joint.child] = T @ align @ motion @ inverse_transform(align)
            if joint.child == sigma0:
                # The ground frame Σ_0 starts at the first moving joint's parent link.
                base = T
            stack.append(joint.child)
    if sigma0 == root:
        base = np.eye(4)
    ground_to_sigma0 = inverse_transform(base)
    for link, body in body_of.items():
        if body == 0:
            pose_in_body[link] = ground_to_sigma0 @ pose_in_body[link]
    first = moving[0].name
    placements[first] = ground_to_sigma0 @ placements[first]

    n = len(moving)
    mass = np.zeros(n + 1)
    first_moment = np.zeros((n + 1, 3))
    inertia_origin = np.zeros((n + 1, 3, 3))
    for link_name, body in body_of.items():
        inertial = links[link_name].inertial
        if inertial is None:
            continue
        field = f"link[{link_name}].inertial"
        m = _number(path, f"{field}.mass", inertial.mass, 0.0)
        if m < 0:
            _fail(path, f"{field}.mass", f"must be non-negative, got {m:g} kg")
        I = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=float)
        problem = inertia_problem(I)
        if problem:
            _fail(path, f"{field}.inertia", f"inertia {problem}")
        origin = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, dtype=float)
        T = pose_in_body[link_name] @ origin
        R, c = T[:3, :3], T[:3, 3]
        mass[body] += m
        first_moment[body] += m * c
        # Parallel axes: every part's inertia about its body's origin adds up.       (Steiner)
        inertia_origin[body] += steiner(R @ I @ R.T, m, c)

    robot_joints, robot_links = [], []
    unset_limits = []
    for i, joint in enumerate(moving, start=1):
        field = f"joint[{joint.name}]"
        kind = _MOVING[joint.type]
        limits = _limits(path, joint)
        if limits is None:
            if joint.type != "continuous" and joint.limit is not None:
                unset_limits.append(joint.name)
            limits = (-np.inf, np.inf)
        dynamics = joint.dynamics
        viscous = _number(path, f"{field}.dynamics.damping", getattr(dynamics, "damping", None), 0.0)
        coulomb = _number(path, f"{field}.dynamics.friction", getattr(dynamics, "friction", None), 0.0)
        for key, value in (("damping", viscous), ("friction", coulomb)):
            if value < 0:
                _fail(path, f"{field}.dynamics.{key}", f"must be non-negative, got {value:g}")
        align = _axis_alignment(path, joint)
        robot_joints.append(Joint(name=joint.name, kind=kind, before=placements[joint.name],
                                  after=inverse_transform(align), limits=limits,
                                  friction=Friction(viscous=viscous, coulomb=coulomb)))
        com = first_moment[i] / mass[i] if mass[i] > 0 else np.zeros(3)
        inertia = steiner(inertia_origin[i], -mass[i], com)
        robot_links.append(Link(name=joint.child, inertial=Inertial(mass=mass[i], com=com,
                                                                    inertia=inertia)))
    tip_link = chain[-1].child
    tool = pose_in_body[tip_link]
    if gravity is None:
        g0 = base[:3, :3].T @ np.asarray(root_gravity, dtype=float)
    else:
        g0 = np.asarray(gravity, dtype=float)
        if g0.shape != (3,):
            raise ValueError(f"gravity must have shape (3,), got {g0.shape}")
    notes = []
    if locked:
        values = ", ".join(f"{k} = {v:.6g}" for k, v in locked.items())
        notes.append(f"{len(locked)} joint{'s' if len(locked) > 1 else ''} off the chain {root} → "
                     f"{tip_link} locked ({lock_rule}) and lumped "
                     f"into the links carrying them: {values}")
    if unset_limits:
        notes.append(f"limits lower = upper read as no limit: {', '.join(unset_limits)}")
    visuals, missing, unsized, refused = place_visuals(path, links, body_of, pose_in_body,
                                                       allow_outside=allow_outside)
    if refused:
        notes.append(f"mesh files not read (those parts are drawn as their inertia shapes; "
                     f"{OUTSIDE_HINT} when outside): {_listing(refused, 4)}")
    if missing:
        notes.append(f"mesh files not found (those parts are drawn as their inertia shapes): "
                     f"{_listing(missing, 4)}")
    if unsized:
        notes.append(f"visual shapes with a size not positive, not drawn: {_listing(unsized, 4)}")
    robot = Robot(name=name or tree_name or Path(path).stem, joints=tuple(robot_joints),
                  links=tuple(robot_links), gravity=g0, base=base, tool=tool,
                  description=f"chain {root} → {tip_link} of the {file_kind} robot {tree_name!r}",
                  source=str(path), notes=tuple(notes), tip=tip_link, visuals=tuple(visuals))
    _check_finite(path, robot)
    return robot
