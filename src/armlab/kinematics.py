"""Forward kinematics and Jacobians (public API over the compiled kernels).

Frames and conventions: ``docs/notation.md``.  ``frame="0"`` expresses results in Σ_0 (the
frame of the first joint's DH row), ``frame="base"`` in Σ_base = T_base0 · Σ_0.
"""

from __future__ import annotations

import numpy as np

from armlab.kernels.kinematics import (
    end_effector_into,
    forward_kinematics_kernel,
    jacobian_kernel,
    joint_frames_into,
)
from armlab.model.robot import Robot

FRAMES = ("base", "0")


def _check_q(robot: Robot, q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape != (robot.n,):
        raise ValueError(f"q must have shape ({robot.n},) for robot {robot.name!r}, got {q.shape}")
    return q


def _check_frame(frame: str) -> str:
    if frame not in FRAMES:
        raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
    return frame


def forward_kinematics(robot: Robot, q, frame: str = "base") -> np.ndarray:
    """Pose of the end effector Σ_e, (4, 4): T_base,e (``frame="base"``) or T_0e (``"0"``)."""
    q = _check_q(robot, q)
    T = np.empty((4, 4))
    forward_kinematics_kernel(robot.arrays, q, T)
    return robot.base @ T if _check_frame(frame) == "base" else T


def link_frames(robot: Robot, q, frame: str = "base") -> np.ndarray:
    """Frames Σ_0, Σ_1, …, Σ_n, Σ_e as an (n + 2, 4, 4) array, in Σ_base or Σ_0.

    Σ_i is the link frame of the robot description (the DH frame i for DH robots).
    """
    q = _check_q(robot, q)
    m = robot.arrays
    n = robot.n
    R = np.empty((n, 3, 3))
    p = np.empty((n, 3))
    joint_frames_into(m, q, R, p)
    frames = np.empty((n + 2, 4, 4))
    frames[0] = np.eye(4)
    for i, joint in enumerate(robot.joints):
        J = np.eye(4)
        J[:3, :3], J[:3, 3] = R[i], p[i]
        frames[i + 1] = J @ joint.after
    R_e, p_e = np.empty((3, 3)), np.empty(3)
    end_effector_into(m, R[-1], p[-1], R_e, p_e)
    frames[-1] = np.eye(4)
    frames[-1][:3, :3], frames[-1][:3, 3] = R_e, p_e
    if _check_frame(frame) == "base":
        frames = robot.base @ frames
    return frames


def geometric_jacobian(robot: Robot, q, frame: str = "base") -> np.ndarray:
    """Geometric Jacobian J = [J_P; J_O], (6, n), of Σ_e's origin, expressed in ``frame``.

        [ṗ_e; ω_e] = J(q) q̇                               (Siciliano (3.56))
    """
    q = _check_q(robot, q)
    J = np.empty((6, robot.n))
    jacobian_kernel(robot.arrays, q, J)
    if _check_frame(frame) == "base":
        R = robot.base[:3, :3]
        J = np.vstack((R @ J[:3], R @ J[3:]))
    return J
