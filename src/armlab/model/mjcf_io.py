"""MJCF in (``load_mjcf``): MuJoCo's own compiler reads the file, armlab reads the compiled model.

The ``mujoco`` package (``pip install armlab[mjcf]``) parses and compiles the file — includes,
defaults, ``<compiler angle= eulerseq= autolimits=>``, inertias computed from geoms — and its
public ``MjModel`` arrays give the tree.  That tree is written in URDF form and built by the
URDF loader (:func:`armlab.model.urdf_io.robot_from_tree`), so tips, locked side branches and
lumped inertials work alike for both formats.

MuJoCo's kinematics (``mj_kinematics``): body b sits at (``body_pos``, ``body_quat``) in its
parent's frame at the reference configuration ``qpos0``; its joints k = 1 … m (in order, each
with anchor p_k and axis a_k in the body frame) move it by

    T_parent,b(q) = T_b · J_1 · … · J_m,   J_k = Tr(p_k) · Rot(a_k, q_k − q0_k) · Tr(−p_k)   (M1)

(Rot a rotation about a_k for a hinge, a translation along it for a slide).  With
Rot(a, q − q0) = Rot(a, q) · Rot(a, −q0), (M1) is a URDF chain: joint k has origin
Tr(p_k) (after the fixed part of joint k − 1) and axis a_k, and a fixed transform
Rot(a_k, −q0_k) · Tr(−p_k) follows it.  So armlab's q is MuJoCo's ``qpos``, and the link frame
Σ_i is the MuJoCo body frame of the joint's body (a massless intermediate frame
``body:joint`` for all but the last of several joints in one body).

Read as: ``body_mass``, ``body_ipos``/``body_iquat``/``body_inertia`` → inertials;
``jnt_range`` (when ``jnt_limited``) → limits; ``dof_damping`` → viscous friction F_v;
``dof_frictionloss`` → Coulomb friction F_s; ``opt.gravity`` (in the world frame) → g, or
g = 0 when ``<flag gravity="disable"/>`` switches it off (``opt.disableflags``); the
geoms MuJoCo's viewer shows by default (meshes as compiled, and primitives) → ``visuals``, for
drawing only.
Not modelled, and named in ``robot.notes`` when present: ``dof_armature`` (MuJoCo adds it to
the diagonal of M; armlab's rotors also couple with the previous link), joint stiffness,
gravity compensation, and equality constraints among locked joints.  Free and ball joints and
equality constraints on the chain are refused.  Joints off the chain are locked at ``qpos0``
(the pose the model is written in, where ``mj_resetData`` puts it) unless ``lock`` says
otherwise.
"""

from __future__ import annotations

import threading
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from armlab.errors import RobotFileError
from armlab.model.robot import Robot
from armlab.spatial import transform


def _fail(path, field, reason):
    raise RobotFileError(path, field, reason)


_WARNINGS = threading.Lock()  # MuJoCo's warning handler is one global of the library


def _compile(path: Path, allow_outside: bool = False):
    """(mujoco, MjModel) of the MJCF file ``path``, its files checked first
    (:func:`~armlab.model.mjcf_files.check_mjcf_files`).  What MuJoCo warns while compiling
    (its default handler prints ``WARNING: …`` and appends to ``MUJOCO_LOG.TXT`` in the working
    folder) is captured instead: a warning of a NaN in the file refuses it (every value of a
    robot file is finite), the words of the others join a compile error's one line or
    ``robot.notes``."""
    try:
        import mujoco
    except ImportError:
        _fail(path, "file", "MJCF files are read by the mujoco package, which is not installed "
              "(pip install 'armlab[mjcf]')")
    from armlab.model.mjcf_files import check_mjcf_files

    check_mjcf_files(path, allow_outside=allow_outside)
    warned: list[str] = []
    with _WARNINGS:
        previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(lambda message: warned.append(" ".join(str(message).split())))
        try:
            m = mujoco.MjModel.from_xml_path(str(path))
            error = None
        except Exception as problem:  # mujoco raises ValueError with the compiler's message
            m, error = None, " ".join(str(problem).split()) or type(problem).__name__
        finally:
            mujoco.set_mju_user_warning(previous)
    said = "; ".join(dict.fromkeys(warned))
    if error is not None:
        _fail(path, "mjcf", error + (f" (MuJoCo warned: {said})" if said else ""))
    if any("nan" in message.lower() for message in warned):
        _fail(path, "mjcf", f"MuJoCo warned: {said} (every value must be a finite number)")
    return mujoco, m, [f"MuJoCo warned: {message}" for message in dict.fromkeys(warned)]


# (MjModel array, object kind, attribute in the file) of every value the robot is built from or
# drawn with; each must be finite and, but for joint ranges, at most MAX_MAGNITUDE in size.
_CHECKED = (("body_pos", "body", "pos"), ("body_quat", "body", "quat"), ("body_ipos", "body", "inertial.pos"),
            ("body_iquat", "body", "inertial.quat"), ("body_mass", "body", "mass"),
            ("body_inertia", "body", "inertia"), ("jnt_pos", "joint", "pos"), ("jnt_axis", "joint", "axis"),
            ("jnt_range", "joint", "range"), ("geom_pos", "geom", "pos"), ("geom_quat", "geom", "quat"),
            ("geom_size", "geom", "size"), ("mesh_vert", "mesh", "vertex"))
_PER_DOF = (("dof_damping", "damping"), ("dof_frictionloss", "frictionloss"), ("dof_armature", "armature"))


def _check_values(path, mujoco, m) -> None:
    """Every number armlab reads from the compiled model is finite and, but for joint ranges,
    within ±MAX_MAGNITUDE (1e12), as in a TOML or URDF robot file: MuJoCo compiles a body at
    1e200 m or a mass of 1e300 kg, whose dynamics is no number."""
    from armlab.model.toml_io import MAX_MAGNITUDE

    kinds = {"body": mujoco.mjtObj.mjOBJ_BODY, "joint": mujoco.mjtObj.mjOBJ_JOINT,
             "geom": mujoco.mjtObj.mjOBJ_GEOM, "mesh": mujoco.mjtObj.mjOBJ_MESH}

    def check(values, kind, index, attribute, bound):
        values = np.atleast_1d(np.asarray(values, dtype=float))
        bad = ~np.isfinite(values) | (np.abs(values) > bound)
        if bad.any():
            name = mujoco.mj_id2name(m, kinds[kind], index) if kind in kinds else None
            value = float(values[np.argmax(bad)])
            reason = (f"is not finite ({value:g})" if not np.isfinite(value) else
                      f"{value:g} is beyond ±{bound:g}, the largest magnitude of a geometric or "
                      "inertial value")
            _fail(path, f"{kind}[{name or index}].{attribute}", reason)

    for array, kind, attribute in _CHECKED:
        data = np.asarray(getattr(m, array), dtype=float)
        if kind == "mesh":   # vertices of all meshes in one array: name the mesh that holds one
            for mesh in range(m.nmesh):
                start, count = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
                check(data[start:start + count], "mesh", mesh, attribute, MAX_MAGNITUDE)
            continue
        for index in range(len(data)):
            check(data[index], kind, index, attribute, np.inf if array == "jnt_range" else MAX_MAGNITUDE)
    for array, attribute in _PER_DOF:
        data = np.asarray(getattr(m, array), dtype=float)
        for dof in range(len(data)):
            check(data[dof], "joint", int(m.dof_jntid[dof]), attribute, MAX_MAGNITUDE)
    check(m.opt.gravity, "option", 0, "gravity", MAX_MAGNITUDE)


def _rotation(axis, angle) -> np.ndarray:
    """Rot(a, angle) about the unit axis a (Rodrigues), (3, 3)."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


def _quat_matrix(mujoco, quat) -> np.ndarray:
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(quat, dtype=float))
    return R.reshape(3, 3)


def _record(**fields):
    return SimpleNamespace(**fields)


def _geom_visuals(mujoco, m) -> dict[int, list]:
    """``{body: [visual records]}`` of the geoms MuJoCo's viewer shows by default (their
    ``group`` on in ``mjv_defaultOption``: 0–2, so not the collision geoms the Menagerie puts in
    group 3), each with its frame in its body (``geom_pos``, ``geom_quat``) and its triangles in
    that frame (V1 with scale 1).  A mesh's are MuJoCo's compiled ``mesh_vert``/``mesh_face``:
    the compiler scales the file's vertices and moves them into the mesh frame (centred and
    turned to its principal axes) while moving the geom's frame onto it, so compiled vertex and
    compiled geom frame go together; a box, sphere, capsule, cylinder or ellipsoid is made of
    its ``geom_size`` (half sides, radius and half length, semi-axes).  Planes, height fields
    and SDF geoms are not drawn."""
    from armlab.model.shapes import primitive_mesh

    shown = np.asarray(mujoco.MjvOption().geomgroup, dtype=bool)
    T = mujoco.mjtGeom
    visuals: dict[int, list] = {}
    for g in range(m.ngeom):
        kind, size = int(m.geom_type[g]), np.asarray(m.geom_size[g], dtype=float)
        if not shown[min(max(int(m.geom_group[g]), 0), len(shown) - 1)]:
            continue
        if kind == int(T.mjGEOM_MESH):
            mesh = int(m.geom_dataid[g])
            v0, f0 = int(m.mesh_vertadr[mesh]), int(m.mesh_faceadr[mesh])
            triangles = (np.array(m.mesh_vert[v0:v0 + int(m.mesh_vertnum[mesh])], dtype=float),
                         np.array(m.mesh_face[f0:f0 + int(m.mesh_facenum[mesh])], dtype=np.int64))
        elif kind == int(T.mjGEOM_BOX):
            triangles = primitive_mesh("box", 2.0 * size)
        elif kind == int(T.mjGEOM_SPHERE):
            triangles = primitive_mesh("sphere", size[:1])
        elif kind in (int(T.mjGEOM_CAPSULE), int(T.mjGEOM_CYLINDER)):
            name = "capsule" if kind == int(T.mjGEOM_CAPSULE) else "cylinder"
            triangles = primitive_mesh(name, (size[0], 2.0 * size[1]))
        elif kind == int(T.mjGEOM_ELLIPSOID):
            triangles = primitive_mesh("ellipsoid", size)
        else:
            continue
        origin = transform(_quat_matrix(mujoco, m.geom_quat[g]), m.geom_pos[g])
        visuals.setdefault(int(m.geom_bodyid[g]), []).append(
            _record(origin=origin, geometry=_record(triangles=triangles)))
    return visuals


def mjcf_tree(path: Path, mujoco, m):
    """(model name, links, joints, world gravity, qpos0 per joint, frame names) of the compiled
    model ``m`` in URDF form (see the module docstring).  Each moving joint's child link is the
    frame right after its motion; ``frame names`` maps it to the name of the frame that the
    fixed rest of (M1) leads to (the body, or ``body:joint``)."""
    def name(kind, i, fallback):
        text = mujoco.mj_id2name(m, kind, i)
        return text if text else fallback

    body_names = [name(mujoco.mjtObj.mjOBJ_BODY, b, f"body{b}") for b in range(m.nbody)]
    joint_names = [name(mujoco.mjtObj.mjOBJ_JOINT, j, f"joint{j}") for j in range(m.njnt)]
    links, joints, qpos0, frame_names = [], [], {}, {}
    visuals = _geom_visuals(mujoco, m)
    for b in range(m.nbody):
        inertial = None
        if b > 0 and m.body_mass[b] > 0:
            inertial = _record(mass=float(m.body_mass[b]),
                               origin=transform(_quat_matrix(mujoco, m.body_iquat[b]), m.body_ipos[b]),
                               inertia=np.diag(m.body_inertia[b]))
        links.append(_record(name=body_names[b], inertial=inertial, visuals=visuals.get(b, [])))
        if b == 0:
            continue
        parent = body_names[m.body_parentid[b]]
        placement = transform(_quat_matrix(mujoco, m.body_quat[b]), m.body_pos[b])
        first, count = int(m.body_jntadr[b]), int(m.body_jntnum[b])
        for k, j in enumerate(range(first, first + count)):
            jname = joint_names[j]
            kind = int(m.jnt_type[j])
            if kind not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                label = {int(mujoco.mjtJoint.mjJNT_FREE): "free", int(mujoco.mjtJoint.mjJNT_BALL): "ball"}
                _fail(path, f"joint[{jname}].type", f"{label.get(kind, kind)} joints are not supported "
                      "(armlab models fixed-base serial chains of hinge and slide joints)")
            hinge = kind == int(mujoco.mjtJoint.mjJNT_HINGE)
            axis, anchor = np.array(m.jnt_axis[j], dtype=float), np.array(m.jnt_pos[j], dtype=float)
            q0 = float(m.qpos0[m.jnt_qposadr[j]])
            qpos0[jname] = q0
            child = body_names[b] if k == count - 1 else f"{body_names[b]}:{jname}"
            moved = f"{child}@{jname}"
            limit = None
            if m.jnt_limited[j]:
                lower, upper = (float(v) for v in m.jnt_range[j])
                limit = _record(lower=lower, upper=upper)
            dof = int(m.jnt_dofadr[j])
            joints.append(_record(
                name=jname, type="revolute" if hinge else "prismatic", parent=parent, child=moved,
                origin=placement @ transform(None, anchor), axis=axis, limit=limit, mimic=None,
                dynamics=_record(damping=float(m.dof_damping[dof]), friction=float(m.dof_frictionloss[dof]))))
            # The fixed rest of (M1) after joint k: Rot(a, −q0) · Tr(−p).
            unit = axis / np.linalg.norm(axis)
            undo = transform(_rotation(axis, -q0)) if hinge else transform(None, -q0 * unit)
            links.append(_record(name=moved, inertial=None))
            frame_names[moved] = child
            joints.append(_record(name=f"{moved}:fixed", type="fixed", parent=moved, child=child,
                                  origin=undo @ transform(None, -anchor), axis=None, limit=None,
                                  mimic=None, dynamics=None))
            if child != body_names[b]:
                links.append(_record(name=child, inertial=None))
            parent, placement = child, np.eye(4)
        if count == 0:
            joints.append(_record(name=f"{body_names[b]}:weld", type="fixed", parent=parent,
                                  child=body_names[b], origin=placement, axis=None, limit=None,
                                  mimic=None, dynamics=None))
    # MuJoCo's name buffer starts with the model's name.
    model_name = bytes(m.names).split(b"\0")[0].decode("utf-8", "replace")
    gravity = np.array(m.opt.gravity, dtype=float)
    if int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY):
        gravity = np.zeros(3)   # <flag gravity="disable"/>: MuJoCo's dynamics has no gravity
    return model_name, links, joints, gravity, qpos0, frame_names


def load_mjcf(path: str | Path, *, tip: str | None = None, gravity=None, name: str | None = None,
              lock: dict | None = None, allow_outside: bool = False) -> Robot:
    """Load the serial chain world → ``tip`` (a body name) of an MJCF file as a :class:`Robot`.

    ``tip``, ``lock``, ``gravity`` and ``name`` as for :func:`armlab.load_urdf`; off-chain
    joints are locked at ``qpos0`` by default.  Without ``tip`` the chain ends at the body
    whose path holds the most joints, when one body does (the others are then locked).
    armlab's q is MuJoCo's ``qpos``; Σ_base is MuJoCo's world frame; g is ``<option gravity>``
    (zero under ``<flag gravity="disable"/>``, as MuJoCo's dynamics has it) unless ``gravity``
    (g_0 in Σ_0) is given.  Included files, meshes and textures must lie under the file's own
    folder unless ``allow_outside`` (:mod:`armlab.model.references`).
    """
    from armlab.model.urdf_io import robot_from_tree

    path = Path(path)
    mujoco, m, warned = _compile(path, allow_outside)
    _check_values(path, mujoco, m)
    model_name, links, joints, g_world, qpos0, frame_names = mjcf_tree(path, mujoco, m)
    robot = robot_from_tree(path, model_name, links, joints, tip=tip, gravity=gravity, name=name,
                            lock=lock, file_kind="MJCF", root_gravity=g_world, default_lock=qpos0,
                            lock_rule="at qpos0 unless given", allow_outside=allow_outside,
                            longest=True)
    # Σ_i is the body frame (the intermediate frame of a joint that is not its body's last).
    renamed = tuple(replace(link, name=frame_names[link.name]) for link in robot.links)
    notes = list(robot.notes) + _ignored(path, mujoco, m, robot) + warned
    return robot.replace(links=renamed, notes=tuple(notes))


def _ignored(path, mujoco, m, robot: Robot) -> list[str]:
    """Notes on what MuJoCo models and armlab does not; equality constraints on the chain fail."""
    chain = set(robot.joint_names)
    # The names mjcf_tree gave the joints: an unnamed one is "joint<j>" there too.
    joint_id = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}": j for j in range(m.njnt)}
    dofs = [int(m.jnt_dofadr[joint_id[n]]) for n in robot.joint_names]
    notes = []
    armature = {n: float(m.dof_armature[d]) for n, d in zip(robot.joint_names, dofs, strict=True)
                if m.dof_armature[d] != 0}
    if armature:
        notes.append("armature not modelled (MuJoCo adds it to M's diagonal): "
                     + ", ".join(f"{k} = {v:.6g}" for k, v in armature.items()))
    stiff = [n for n in robot.joint_names if m.jnt_stiffness[joint_id[n]] != 0]
    if stiff:
        notes.append(f"joint stiffness not modelled: {', '.join(stiff)}")
    if np.any(m.body_gravcomp != 0):
        notes.append("gravity compensation (gravcomp) not modelled")
    ignored = 0
    for e in range(m.neq):
        involved = set()
        kind = int(m.eq_type[e])
        if kind == int(mujoco.mjtEq.mjEQ_JOINT):
            involved = {int(m.eq_obj1id[e]), int(m.eq_obj2id[e])} - {-1}
            on_chain = any(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) in chain for j in involved)
        elif kind == int(mujoco.mjtEq.mjEQ_TENDON):
            joints = set()
            for t in {int(m.eq_obj1id[e]), int(m.eq_obj2id[e])} - {-1}:
                start, count = int(m.tendon_adr[t]), int(m.tendon_num[t])
                joints |= {int(m.wrap_objid[w]) for w in range(start, start + count)
                           if int(m.wrap_type[w]) == int(mujoco.mjtWrap.mjWRAP_JOINT)}
            on_chain = any(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) in chain for j in joints)
        else:
            on_chain = True  # connect, weld, flex: closed loops armlab cannot lock away
        if on_chain:
            _fail(path, f"equality[{mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or e}]",
                  "constrains the chain (armlab models open serial chains; choose another tip)")
        ignored += 1
    if ignored:
        notes.append(f"{ignored} equality constraint{'s' if ignored > 1 else ''} among locked joints "
                     "ignored")
    return notes
