"""Pinocchio reference models of armlab robots, built from armlab's own URDF export.

Pinocchio is an independent implementation of the kinematics and dynamics of rigid-body trees,
so agreement between armlab and the model built here checks armlab's algorithms *and* its URDF
export.  Pinocchio's world frame is the URDF root: ``base`` (Σ_base), or ``world`` when the
export rotates Σ_base so that gravity points along −z (R_world,base of ``world_rotation``).
armlab's gravity g_0 is given in Σ_0, so it is rotated into that root:
g_world = R_world,base R_base0 g_0; frames are returned in Σ_base.

Motor rotor inertias are not part of a URDF; ``armature=True`` adds the reflected inertia
k_r² I_m of each rotor to the diagonal of Pinocchio's mass matrix (the rotor's gyroscopic
coupling with the preceding link, Siciliano et al. §7.2, is not modelled by Pinocchio).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from armlab.model.urdf_io import to_urdf, urdf_names, world_rotation


def pinocchio_model(robot, *, armature: bool = False):
    """(model, data) of ``robot`` loaded by ``pinocchio.buildModelFromXML(to_urdf(robot))``."""
    model = pin.buildModelFromXML(to_urdf(robot))
    model.gravity.linear = world_rotation(robot) @ robot.base[:3, :3] @ np.asarray(robot.gravity, dtype=float)
    if armature:
        m = robot.arrays
        for i, v in enumerate(v_index(robot, model)):
            model.armature[v] = m.gear_ratio[i] ** 2 * m.rotor_inertia[i]
    return model, model.createData()


def _joint_ids(robot, model) -> list[int]:
    return [model.getJointId(name) for name in urdf_names(robot)[1]]


def q_index(robot, model) -> list[int]:
    """Index in Pinocchio's configuration vector of armlab joint i (i = 0 … n−1).

    A revolute joint without limits is a URDF ``continuous`` joint, which Pinocchio stores as
    (cos q, sin q) at q_index and q_index + 1; use :func:`pinocchio_q` to convert.
    """
    return [model.joints[j].idx_q for j in _joint_ids(robot, model)]


def v_index(robot, model) -> list[int]:
    """Index in Pinocchio's velocity vector (and in τ, rows of B) of armlab joint i."""
    return [model.joints[j].idx_v for j in _joint_ids(robot, model)]


def pinocchio_q(robot, model, q) -> np.ndarray:
    """Pinocchio's configuration vector for armlab's q (n,)."""
    q_pin = pin.neutral(model)
    for i, j in enumerate(_joint_ids(robot, model)):
        joint = model.joints[j]
        if joint.nq == 2:
            q_pin[joint.idx_q:joint.idx_q + 2] = np.cos(q[i]), np.sin(q[i])
        else:
            q_pin[joint.idx_q] = q[i]
    return q_pin


def pinocchio_v(robot, model, qd) -> np.ndarray:
    """Pinocchio's velocity (or acceleration, torque) vector for armlab's qd (n,)."""
    v = np.zeros(model.nv)
    v[v_index(robot, model)] = qd
    return v


def armlab_v(robot, model, v) -> np.ndarray:
    """armlab's (n,) vector from a Pinocchio velocity-space vector (nv,)."""
    return np.asarray(v)[v_index(robot, model)]


def frame_names(robot) -> list[str]:
    """Pinocchio frame names of Σ_0, Σ_1, …, Σ_n, Σ_e (the order of ``armlab.link_frames``)."""
    return ["sigma_0"] + [f"sigma_{i + 1}" for i in range(robot.n)] + ["sigma_e"]


def pinocchio_frames(robot, model, data, q) -> np.ndarray:
    """Σ_0 … Σ_e in Σ_base computed by Pinocchio, (n + 2, 4, 4)."""
    pin.framesForwardKinematics(model, data, pinocchio_q(robot, model, q))
    base_from_world = np.eye(4)
    base_from_world[:3, :3] = world_rotation(robot).T
    return np.array([base_from_world @ data.oMf[model.getFrameId(name, pin.BODY)].homogeneous
                     for name in frame_names(robot)])
