"""Compiled forward kinematics and geometric Jacobian in joint frames (see model/robot.py).

    T_{0,J_i} = T_{0,J_{i−1}} · X_i · M_i(q_i + offset_i),   T_{0,e} = T_{0,J_n} · X_tool   (K2)

J_i's z axis is joint i's axis z_{i−1} of the DH notation and its origin lies on that axis,
so the geometric Jacobian columns are (Siciliano (3.30)):

    prismatic: [z_i; 0],   revolute: [z_i × (p_e − p_i); z_i]                          (K3)
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.model.robot import PRISMATIC


@njit(cache=True, fastmath=False)
def compose_joint(R_prev, p_prev, X_R, X_p, kind, value, R_out, p_out):
    """R_out, p_out ← (R_prev, p_prev) · (X_R, X_p) · M(value); M about/along local z."""
    for r in range(3):
        p_out[r] = p_prev[r] + R_prev[r, 0] * X_p[0] + R_prev[r, 1] * X_p[1] + R_prev[r, 2] * X_p[2]
    # A = R_prev X_R
    a00 = R_prev[0, 0] * X_R[0, 0] + R_prev[0, 1] * X_R[1, 0] + R_prev[0, 2] * X_R[2, 0]
    a01 = R_prev[0, 0] * X_R[0, 1] + R_prev[0, 1] * X_R[1, 1] + R_prev[0, 2] * X_R[2, 1]
    a02 = R_prev[0, 0] * X_R[0, 2] + R_prev[0, 1] * X_R[1, 2] + R_prev[0, 2] * X_R[2, 2]
    a10 = R_prev[1, 0] * X_R[0, 0] + R_prev[1, 1] * X_R[1, 0] + R_prev[1, 2] * X_R[2, 0]
    a11 = R_prev[1, 0] * X_R[0, 1] + R_prev[1, 1] * X_R[1, 1] + R_prev[1, 2] * X_R[2, 1]
    a12 = R_prev[1, 0] * X_R[0, 2] + R_prev[1, 1] * X_R[1, 2] + R_prev[1, 2] * X_R[2, 2]
    a20 = R_prev[2, 0] * X_R[0, 0] + R_prev[2, 1] * X_R[1, 0] + R_prev[2, 2] * X_R[2, 0]
    a21 = R_prev[2, 0] * X_R[0, 1] + R_prev[2, 1] * X_R[1, 1] + R_prev[2, 2] * X_R[2, 1]
    a22 = R_prev[2, 0] * X_R[0, 2] + R_prev[2, 1] * X_R[1, 2] + R_prev[2, 2] * X_R[2, 2]
    if kind == PRISMATIC:
        R_out[0, 0], R_out[0, 1], R_out[0, 2] = a00, a01, a02
        R_out[1, 0], R_out[1, 1], R_out[1, 2] = a10, a11, a12
        R_out[2, 0], R_out[2, 1], R_out[2, 2] = a20, a21, a22
        p_out[0] += a02 * value
        p_out[1] += a12 * value
        p_out[2] += a22 * value
    else:
        c, s = np.cos(value), np.sin(value)
        R_out[0, 0], R_out[0, 1], R_out[0, 2] = a00 * c + a01 * s, a01 * c - a00 * s, a02
        R_out[1, 0], R_out[1, 1], R_out[1, 2] = a10 * c + a11 * s, a11 * c - a10 * s, a12
        R_out[2, 0], R_out[2, 1], R_out[2, 2] = a20 * c + a21 * s, a21 * c - a20 * s, a22


@njit(cache=True)
def joint_frames_into(m, q, R_out, p_out):
    """Poses of the joint frames J_1…J_n in Σ_0 (K2): R_out (n, 3, 3), p_out (n, 3)."""
    n = q.shape[0]
    eye = np.eye(3)
    zero = np.zeros(3)
    for i in range(n):
        if i == 0:
            compose_joint(eye, zero, m.tree_R[0], m.tree_p[0], m.joint_type[0],
                          q[0] + m.offset[0], R_out[0], p_out[0])
        else:
            compose_joint(R_out[i - 1], p_out[i - 1], m.tree_R[i], m.tree_p[i], m.joint_type[i],
                          q[i] + m.offset[i], R_out[i], p_out[i])


@njit(cache=True)
def end_effector_into(m, R_last, p_last, R_e, p_e):
    """Σ_e in Σ_0 from the last joint frame: T_0e = T_{0,J_n} X_tool (K2)."""
    for r in range(3):
        p_e[r] = p_last[r]
        for k in range(3):
            p_e[r] += R_last[r, k] * m.tool_p[k]
        for c in range(3):
            acc = 0.0
            for k in range(3):
                acc += R_last[r, k] * m.tool_R[k, c]
            R_e[r, c] = acc


@njit(cache=True)
def geometric_jacobian_into(m, R_frames, p_frames, p_e, J_out):
    """Geometric Jacobian (6, n) = [J_P; J_O] in Σ_0 at the point p_e (K3)."""
    n = R_frames.shape[0]
    for i in range(n):
        zx, zy, zz = R_frames[i, 0, 2], R_frames[i, 1, 2], R_frames[i, 2, 2]
        if m.joint_type[i] == PRISMATIC:
            J_out[0, i], J_out[1, i], J_out[2, i] = zx, zy, zz
            J_out[3, i], J_out[4, i], J_out[5, i] = 0.0, 0.0, 0.0
        else:
            dx = p_e[0] - p_frames[i, 0]
            dy = p_e[1] - p_frames[i, 1]
            dz = p_e[2] - p_frames[i, 2]
            J_out[0, i] = zy * dz - zz * dy
            J_out[1, i] = zz * dx - zx * dz
            J_out[2, i] = zx * dy - zy * dx
            J_out[3, i], J_out[4, i], J_out[5, i] = zx, zy, zz


@njit(cache=True)
def forward_kinematics_kernel(m, q, T_out):
    """T_0e (4, 4) into T_out; allocates its scratch frames (use the *_into kernels in loops)."""
    n = q.shape[0]
    R = np.empty((n, 3, 3))
    p = np.empty((n, 3))
    joint_frames_into(m, q, R, p)
    R_e = np.empty((3, 3))
    p_e = np.empty(3)
    end_effector_into(m, R[n - 1], p[n - 1], R_e, p_e)
    for r in range(3):
        for c in range(3):
            T_out[r, c] = R_e[r, c]
        T_out[r, 3] = p_e[r]
        T_out[3, r] = 0.0
    T_out[3, 3] = 1.0


@njit(cache=True)
def jacobian_kernel(m, q, J_out):
    """Geometric Jacobian (6, n) of Σ_e in Σ_0 into J_out."""
    n = q.shape[0]
    R = np.empty((n, 3, 3))
    p = np.empty((n, 3))
    joint_frames_into(m, q, R, p)
    R_e = np.empty((3, 3))
    p_e = np.empty(3)
    end_effector_into(m, R[n - 1], p[n - 1], R_e, p_e)
    geometric_jacobian_into(m, R, p, p_e, J_out)
