"""Immutable description of a serial manipulator and its plain-array form for compiled code.

Every joint i moves the frame of link i relative to the frame of link i−1 (Σ_0 for i = 1):

    T_{i−1,i}(q_i) = P_i · M_i(q_i + offset_i) · S_i                                  (K1)

where ``P_i`` (``joint.before``) and ``S_i`` (``joint.after``) are constant transforms and
``M_i`` is a rotation about (revolute) or a translation along (prismatic) the local z axis.
Standard DH gives P_i = I, S_i = Rz(θ)Tz(d)Tx(a)Rx(α) with the joint variable taken out;
modified DH gives P_i = Rx(α)Tx(a)Rz(θ)Tz(d), S_i = I; a URDF joint gives
P_i = origin·R_axis, S_i = R_axisᵀ.  See ``docs/notation.md``.

The frame after M_i, the *joint frame* J_i, always has the joint axis as its z axis and its
origin on that axis; the compiled kernels work in joint frames only, so every algorithm
(kinematics, RNEA, Jacobians) treats DH and URDF robots alike.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal, NamedTuple

import numpy as np

from armlab.model.inertia import steiner
from armlab.spatial import hom_rot_x, hom_rot_z, trans_x, trans_z

REVOLUTE, PRISMATIC = 0, 1
JOINT_KINDS = {"revolute": REVOLUTE, "prismatic": PRISMATIC}


def _frozen_array(value, shape) -> np.ndarray:
    array = np.array(value, dtype=float).reshape(shape)
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class DHRow:
    """One row of a Denavit–Hartenberg table; the joint variable adds to θ or d.

    ``convention`` is ``"standard"`` (A = Rz(θ) Tz(d) Tx(a) Rx(α)) or ``"modified"``
    (A = Rx(α) Tx(a) Rz(θ) Tz(d), Craig).  Lengths in m, angles in rad.
    """

    a: float
    alpha: float
    d: float
    theta: float
    convention: Literal["standard", "modified"] = "standard"


@dataclass(frozen=True)
class Motor:
    """Joint actuator: rotor of inertia ``rotor_inertia`` I_m [kg·m²] about the joint axis,
    geared by ``gear_ratio`` k_r (rotor angle = k_r · q; [rad/rad] or [rad/m]), total
    (stator + rotor) ``mass`` m_m [kg].

    Motor i sits on link i−1 at the origin of joint i (Siciliano et al. §7.2), so its reflected
    inertia k_r² I_m and its gyroscopic coupling with link i−1 enter the dynamics, and its mass
    is carried by link i−1 (:attr:`Robot.arrays` lumps it there as a point mass; motor 1 sits
    on the fixed base and its mass drops out).
    """

    gear_ratio: float = 1.0
    rotor_inertia: float = 0.0
    mass: float = 0.0


@dataclass(frozen=True)
class Friction:
    """Joint friction τ_f = F_v q̇ + F_s sign(q̇): ``viscous`` F_v [N·s/m | N·m·s/rad],
    ``coulomb`` F_s [N | N·m]."""

    viscous: float = 0.0
    coulomb: float = 0.0


@dataclass(frozen=True)
class Joint:
    """A 1-DoF joint; ``before``/``after`` are P_i and S_i of (K1), (4, 4)."""

    name: str
    kind: Literal["revolute", "prismatic"]
    before: np.ndarray
    after: np.ndarray
    offset: float = 0.0
    limits: tuple[float, float] = (-np.inf, np.inf)
    motor: Motor = field(default_factory=Motor)
    friction: Friction = field(default_factory=Friction)
    dh: DHRow | None = None

    def __post_init__(self):
        object.__setattr__(self, "before", _frozen_array(self.before, (4, 4)))
        object.__setattr__(self, "after", _frozen_array(self.after, (4, 4)))

    @classmethod
    def from_dh(cls, name: str, kind: str, row: DHRow, **kwargs) -> Joint:
        """The joint of a DH row; the joint variable is θ (revolute) or d (prismatic).

        The row's θ (revolute) or d (prismatic) becomes the joint offset.
        """
        if kind not in JOINT_KINDS:
            raise ValueError(f"unknown joint type {kind!r}")
        revolute = kind == "revolute"
        fixed_theta = np.eye(4) if revolute else hom_rot_z(row.theta)
        fixed_d = trans_z(row.d) if revolute else np.eye(4)
        offset = row.theta if revolute else row.d
        if row.convention == "standard":
            before = np.eye(4)
            after = fixed_theta @ fixed_d @ trans_x(row.a) @ hom_rot_x(row.alpha)
        elif row.convention == "modified":
            before = hom_rot_x(row.alpha) @ trans_x(row.a) @ fixed_theta @ fixed_d
            after = np.eye(4)
        else:
            raise ValueError(f"unknown DH convention {row.convention!r}")
        return cls(name=name, kind=kind, before=before, after=after, offset=offset, dh=row, **kwargs)

    def motion(self, q: float) -> np.ndarray:
        """M(q + offset), (4, 4)."""
        value = q + self.offset
        return hom_rot_z(value) if self.kind == "revolute" else trans_z(value)

    def transform(self, q: float) -> np.ndarray:
        """T_{i−1,i}(q) of (K1), (4, 4)."""
        return self.before @ self.motion(q) @ self.after


@dataclass(frozen=True)
class Inertial:
    """Mass properties of a link, in the link frame Σ_i.

    ``mass`` [kg], ``com`` r_C (3,) [m], ``inertia`` I_C (3, 3) [kg·m²] about the centre of
    mass with axes parallel to Σ_i.  ``shape`` records where the values came from (for
    drawing and documentation), e.g. ``{"type": "box", "size": [a, b, c], "rpy": [...]}``.
    """

    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    shape: dict | None = None

    def __post_init__(self):
        object.__setattr__(self, "com", _frozen_array(self.com, (3,)))
        object.__setattr__(self, "inertia", _frozen_array(self.inertia, (3, 3)))


@dataclass(frozen=True)
class Link:
    name: str
    inertial: Inertial = field(default_factory=Inertial)


@dataclass(frozen=True)
class Visual:
    """A visual shape of the robot file drawn on one of its frames: a URDF ``<visual>`` (a
    ``<mesh>`` file, or a ``<box>``, ``<cylinder>``, ``<sphere>``) or a visible MJCF geom.  Only
    drawings read it: kinematics and dynamics never do.

    A point p of the shape is drawn at

        p_frame = T · diag(scale) · p                                                   (V1)

    in Σ_0 (``body`` 0, parts fixed to the ground) or in link frame Σ_i (``body`` i = 1 … n,
    parts moved by joint i), ``T`` = ``pose`` (4, 4) folding the file's fixed joints and the
    visual's ``<origin>`` (an MJCF geom's frame in its body).  The points are those of the mesh
    file ``mesh`` (its path), or, when ``mesh`` is empty, the ``vertices`` (V, 3) of the
    triangles ``faces`` (F, 3) (a primitive shape, or a mesh as MuJoCo compiled it, in its mesh
    frame).  ``part`` is the file's link (MJCF: body) that carries it.
    """

    body: int
    pose: np.ndarray
    mesh: str = ""
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    part: str = ""
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "pose", _frozen_array(self.pose, (4, 4)))
        object.__setattr__(self, "scale", _frozen_array(self.scale, (3,)))
        if bool(self.mesh) == (self.vertices is not None or self.faces is not None):
            raise ValueError(f"visual of {self.part!r}: give a mesh file or vertices and faces, "
                             "one of the two")
        if self.mesh:
            return
        if self.vertices is None or self.faces is None:
            raise ValueError(f"visual of {self.part!r}: vertices and faces go together")
        vertices = np.array(self.vertices, dtype=float)
        faces = np.array(self.faces)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.all(np.isfinite(vertices)):
            raise ValueError(f"visual of {self.part!r}: vertices must be finite and of shape (V, 3), "
                             f"got {vertices.shape}")
        if (faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer)
                or (faces.size and (faces.min() < 0 or faces.max() >= len(vertices)))):
            raise ValueError(f"visual of {self.part!r}: faces must be (F, 3) indices of its "
                             f"{len(vertices)} vertices")
        faces = faces.astype(np.int64)
        vertices.setflags(write=False)
        faces.setflags(write=False)
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", faces)


class RobotArrays(NamedTuple):
    """The plain-array form of a :class:`Robot` consumed by the compiled kernels.

    Everything is expressed in joint frames J_i (z = joint axis):

    * ``joint_type`` (n,) int64: 0 revolute, 1 prismatic;
    * ``tree_R`` (n, 3, 3), ``tree_p`` (n, 3): X_i = S_{i−1} P_i, the constant transform
      from J_{i−1} (Σ_0 for i = 0) to J_i before the motion M_i(q_i);
    * ``offset`` (n,): joint offsets added to q before M_i;
    * ``tool_R`` (3, 3), ``tool_p`` (3,): S_n · T_tool, from J_n to the end effector Σ_e;
    * ``base_R`` (3, 3), ``base_p`` (3,): T_base0, Σ_0 in Σ_base;
    * ``mass`` (n,), ``com`` (n, 3), ``inertia`` (n, 3, 3): link i in J_i, about its COM,
      with the mass of motor i + 1 lumped in (see :class:`Motor`);
    * ``gear_ratio``, ``rotor_inertia``, ``viscous``, ``coulomb``, ``q_min``, ``q_max`` (n,);
    * ``gravity`` (3,): g_0 in Σ_0 [m/s²].
    """

    joint_type: np.ndarray
    tree_R: np.ndarray
    tree_p: np.ndarray
    offset: np.ndarray
    tool_R: np.ndarray
    tool_p: np.ndarray
    base_R: np.ndarray
    base_p: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    gear_ratio: np.ndarray
    rotor_inertia: np.ndarray
    viscous: np.ndarray
    coulomb: np.ndarray
    q_min: np.ndarray
    q_max: np.ndarray
    gravity: np.ndarray


def _lump_point_mass(mass, com, inertia, link, point_mass, point):
    """Add ``point_mass`` [kg] at ``point`` (3,) [m] to ``link`` of the (n,), (n, 3), (n, 3, 3)
    arrays, in place, keeping the inertia about the (new) centre of mass:

        m' = m + m_m,   c' = (m c + m_m p) / m',
        I' = I + m Sᵀ(c − c') S(c − c') + m_m Sᵀ(p − c') S(p − c')          (Steiner)
    """
    if point_mass == 0.0:
        return
    total = mass[link] + point_mass
    new_com = (mass[link] * com[link] + point_mass * point) / total
    inertia[link] = steiner(steiner(inertia[link], mass[link], com[link] - new_com),
                            point_mass, point - new_com)
    mass[link], com[link] = total, new_com


@dataclass(frozen=True)
class Robot:
    """A serial manipulator: joints, links, gravity, base and tool (immutable).

    ``joints[i]`` moves ``links[i]``.  ``base`` is T_base0 (Σ_0 seen from Σ_base), ``tool`` the
    end-effector frame Σ_e seen from the last link frame Σ_n.  ``gravity`` is g_0 in Σ_0
    [m/s²].  ``source`` names the file it was loaded from, ``description`` says what it is,
    ``parameters`` holds the named values of the robot file (L0, m_Link4, …) and ``spec`` the
    file's raw content, expressions unevaluated, for the symbolic derivations.  ``notes`` are
    one-line remarks of the loader on what it changed from the file (side branches locked,
    limits read as absent, the package a zoo robot came from); ``tip`` the link (URDF) or body
    (MJCF) of the file that carries Σ_e ("" for armlab's own files); ``visuals`` the meshes
    of the file's links (:class:`Visual`), drawn by :mod:`armlab.viz.view3d`.  ``arrays`` is its
    :class:`RobotArrays` and ``packed`` the same numbers in one array (:func:`pack_arrays`, what
    the compiled kernels take), both derived at construction and never written.
    """

    name: str
    joints: tuple[Joint, ...]
    links: tuple[Link, ...]
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    description: str = ""
    source: str = ""
    parameters: dict = field(default_factory=dict)
    spec: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    tip: str = ""
    visuals: tuple[Visual, ...] = ()
    arrays: RobotArrays = field(init=False, repr=False, compare=False)
    packed: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "joints", tuple(self.joints))
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "notes", tuple(self.notes))
        object.__setattr__(self, "visuals", tuple(self.visuals))
        object.__setattr__(self, "gravity", _frozen_array(self.gravity, (3,)))
        object.__setattr__(self, "base", _frozen_array(self.base, (4, 4)))
        object.__setattr__(self, "tool", _frozen_array(self.tool, (4, 4)))
        if len(self.joints) != len(self.links):
            raise ValueError(f"{len(self.joints)} joints but {len(self.links)} links")
        if not self.joints:
            raise ValueError("a robot needs at least one joint")
        # Derived once, here, before anyone holds the robot: nothing is written into it later.
        object.__setattr__(self, "arrays", _robot_arrays(self))
        object.__setattr__(self, "packed", pack_arrays(self.arrays))

    # Identity: a robot is equal only to itself, and hashes as such (object's own slots, which
    # a dict or weak map of robots calls without entering Python).
    __hash__ = object.__hash__
    __eq__ = object.__eq__

    def __repr__(self) -> str:
        kinds = "".join("P" if j.kind == "prismatic" else "R" for j in self.joints)
        where = f", source={self.source!r}" if self.source else ""
        return f"Robot({self.name!r}, {self.n} joints {kinds}{where})"

    def _repr_html_(self) -> str:
        """The robot in a notebook: its joint table, links, parameters, provenance."""
        from armlab.display import robot_html

        return robot_html(self)

    @property
    def n(self) -> int:
        """Number of joints (degrees of freedom)."""
        return len(self.joints)

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]

    @property
    def is_dh(self) -> bool:
        return all(j.dh is not None for j in self.joints)

    def replace(self, **changes) -> Robot:
        """A copy with fields changed (the robot itself is never mutated).  The copy drops the
        robot file's expressions (``spec``) unless ``spec`` is among the changes: they would
        no longer describe it, and ``armlab.symbolic`` rebuilds it from its numbers instead."""
        changes.setdefault("spec", {})
        return replace(self, **changes)

    def with_link_mass(self, link: int | str, mass: float, *, scale_inertia: bool = True) -> Robot:
        """A copy whose link ``link`` has ``mass`` [kg]; its inertia tensor scales with the mass
        (same shape, different density) unless ``scale_inertia`` is False."""
        names = [lk.name for lk in self.links]
        if isinstance(link, str):
            if link not in names:
                raise ValueError(f"link: {link!r} is not a link of {self.name!r} ({', '.join(names)})")
            index = names.index(link)
        elif isinstance(link, int) and -self.n <= link < self.n:
            index = link
        else:
            raise ValueError(f"link: {link!r} is not a link index of {self.name!r} (0…{self.n - 1})")
        if not (np.isfinite(mass) and mass >= 0):
            raise ValueError(f"mass: must be a finite non-negative mass [kg], got {mass!r}")
        old = self.links[index].inertial
        factor = mass / old.mass if (scale_inertia and old.mass > 0) else 1.0
        new_inertial = replace(old, mass=mass, inertia=old.inertia * factor)
        links = list(self.links)
        links[index] = replace(links[index], inertial=new_inertial)
        return self.replace(links=tuple(links))


def nonfinite_part(robot: Robot) -> tuple[str, int | None] | None:
    """The first part of ``robot`` whose numbers are not finite, or None.

    The part is ``("gravity" | "base" | "tool", None)``, ``("joint", i)`` (placement, offset,
    motor, friction; NaN limits — infinite limits mean none) or ``("link", i)`` (mass, centre
    of mass, inertia in ``robot.arrays``, motor masses lumped).  Values that are finite one by
    one can still overflow in the derived arrays (an inertia of 1e308 rotated into J_i): the
    file readers call this last and name the part in their error.
    """
    m = robot.arrays

    def finite(*arrays) -> bool:
        return all(np.all(np.isfinite(a)) for a in arrays)

    derived = [array for name, array in m._asdict().items() if name not in ("q_min", "q_max")]
    if (finite(robot.gravity, robot.base, robot.tool, *derived)
            and not np.isnan(np.concatenate([m.q_min, m.q_max])).any()
            and all(finite(j.before, j.after) for j in robot.joints)):
        return None  # the usual case, in one pass
    if not finite(robot.gravity, m.gravity):
        return "gravity", None
    if not finite(robot.base, m.base_R, m.base_p):
        return "base", None
    for i, joint in enumerate(robot.joints):
        if not (finite(joint.before, joint.after, m.tree_R[i], m.tree_p[i], m.offset[i],
                       m.gear_ratio[i], m.rotor_inertia[i], m.viscous[i], m.coulomb[i])
                and not np.isnan(m.q_min[i]) and not np.isnan(m.q_max[i])):
            return "joint", i
    for i, link in enumerate(robot.links):
        inertial = link.inertial
        if not finite(inertial.mass, inertial.com, inertial.inertia, m.mass[i], m.com[i], m.inertia[i]):
            return "link", i
    if not finite(robot.tool, m.tool_R, m.tool_p):
        return "tool", None
    return None


def _robot_arrays(robot: Robot) -> RobotArrays:
    """The :class:`RobotArrays` of ``robot`` (its attribute ``arrays``, made at construction)."""
    n = robot.n
    tree = np.zeros((n, 4, 4))
    previous_after = np.eye(4)
    com = np.zeros((n, 3))
    inertia = np.zeros((n, 3, 3))
    for i, (joint, link) in enumerate(zip(robot.joints, robot.links, strict=True)):
        tree[i] = previous_after @ joint.before
        previous_after = joint.after
        # The link's inertial is given in Σ_i = J_i · S_i; move it into J_i.
        R_after, p_after = joint.after[:3, :3], joint.after[:3, 3]
        com[i] = R_after @ link.inertial.com + p_after
        # Symmetric to the last bit: the CRBA reads one triangle, the RNEA the whole tensor
        # (files may carry an asymmetry up to 1e-12; a tensor built in code, any).
        rotated = R_after @ link.inertial.inertia @ R_after.T
        inertia[i] = 0.5 * (rotated + rotated.T)
    tool = previous_after @ robot.tool
    mass = np.array([lk.inertial.mass for lk in robot.links])
    for i in range(1, n):
        _lump_point_mass(mass, com, inertia, i - 1, robot.joints[i].motor.mass, tree[i, :3, 3])
    arrays = RobotArrays(
        joint_type=np.array([JOINT_KINDS[j.kind] for j in robot.joints], dtype=np.int64),
        tree_R=np.ascontiguousarray(tree[:, :3, :3]),
        tree_p=np.ascontiguousarray(tree[:, :3, 3]),
        offset=np.array([j.offset for j in robot.joints]),
        tool_R=np.ascontiguousarray(tool[:3, :3]),
        tool_p=np.ascontiguousarray(tool[:3, 3]),
        base_R=np.ascontiguousarray(robot.base[:3, :3]),
        base_p=np.ascontiguousarray(robot.base[:3, 3]),
        mass=mass,
        com=com,
        inertia=inertia,
        gear_ratio=np.array([j.motor.gear_ratio for j in robot.joints]),
        rotor_inertia=np.array([j.motor.rotor_inertia for j in robot.joints]),
        viscous=np.array([j.friction.viscous for j in robot.joints]),
        coulomb=np.array([j.friction.coulomb for j in robot.joints]),
        q_min=np.array([j.limits[0] for j in robot.joints], dtype=float),
        q_max=np.array([j.limits[1] for j in robot.joints], dtype=float),
        gravity=np.array(robot.gravity, dtype=float),
    )
    return arrays


# The float fields of RobotArrays in the order ``pack_arrays`` lays them out.
PACKED_FLOAT_FIELDS = RobotArrays._fields[1:]


def pack_arrays(m: RobotArrays) -> np.ndarray:
    """The robot's model as one float64 array, the form the compiled kernels take
    (``armlab.kernels.plant`` rebuilds the :class:`RobotArrays` of views from it)::

        [n | joint_type (n, int64 bits) | the float fields, in field order]

    One array because a compiled function pays for every array it receives (unboxing ~0.1 µs
    each from Python, and compile time for each array of its signature).  The array stays
    writeable, as ``arrays`` does, so that every caller gives the kernels one array type (a
    read-only one would be another type, and another compile); nothing writes it."""
    joint_type = np.ascontiguousarray(m.joint_type, dtype=np.int64)
    floats = [np.asarray(getattr(m, name), dtype=float).ravel() for name in PACKED_FLOAT_FIELDS]
    return np.concatenate([[float(joint_type.shape[0])], joint_type.view(np.float64), *floats])
