"""Hypothesis strategies: random valid serial robots, states and helpers for tests.

``robots()`` draws the structure (number of joints, revolute/prismatic, standard DH, modified
DH or origin/axis placement, whether motors and friction are present) from hypothesis and the
numbers from a NumPy generator seeded by hypothesis, so examples stay reproducible and cheap
to draw.  Every inertia tensor is physical: I_C = R diag(m(σ_y² + σ_z²), m(σ_x² + σ_z²),
m(σ_x² + σ_y²)) Rᵀ, the tensor of a mass distribution with second moments σ².
"""

from __future__ import annotations

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

