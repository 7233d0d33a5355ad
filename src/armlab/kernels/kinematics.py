"""Compiled kinematics in joint frames (see model/robot.py): poses, Jacobians, J̇q̇.

    T_{0,J_i} = T_{0,J_{i−1}} · X_i · M_i(q_i + offset_i),   T_{0,e} = T_{0,J_n} · X_tool   (K2)

J_i's z axis is joint i's axis z_{i−1} of the DH notation and its origin lies on that axis,
so the geometric Jacobian columns are (Siciliano (3.30)):

    prismatic: [z_i; 0],   revolute: [z_i × (p_e − p_i); z_i]                          (K3)

The analytic Jacobian and its time derivative follow from v = T_A(φ) ẋ (K9, K10, K11):

    J_A = T_A(φ)⁻¹ J,    J̇_A q̇ = T_A(φ)⁻¹ (J̇ q̇ − Ṫ_A(φ, φ̇) ẋ),  ẋ = J_A q̇          (K4, K6)

Every ``*_into`` kernel writes into caller-provided arrays and allocates nothing; the
``*_kernel`` entry points take a :class:`KinematicsWorkspace` for their scratch frames.  An
``in_base`` flag selects Σ_base (True) or Σ_0 (False) for the results.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from armlab.model.robot import PRISMATIC
from armlab.spatial import ZYZ, euler_angles_into, euler_rate_dot_times, euler_rates_from_omega

kernel = njit(cache=True)


@kernel
def joint_frames_into(m, q, R_out, p_out):
    """Poses of the joint frames J_1…J_n in Σ_0 (K2): R_out (n, 3, 3), p_out (n, 3).

    Written with plain indices: RobotArrays fields are read once and no sub-array views are
    made, because each field access or view inside the loop costs a reference-count round trip
    (measured 2–4× slower on a 6-joint arm).
    """
    n = q.shape[0]
    tree_R, tree_p, joint_type, offset = m.tree_R, m.tree_p, m.joint_type, m.offset
    for i in range(n):
        value = q[i] + offset[i]
        revolute = joint_type[i] != PRISMATIC
        c, s = (np.cos(value), np.sin(value)) if revolute else (1.0, 0.0)
        for r in range(3):
            # row r of A = R_{J_{i−1}} X_R and of the origin before the motion
            if i == 0:
                a0, a1, a2 = tree_R[0, r, 0], tree_R[0, r, 1], tree_R[0, r, 2]
                pr = tree_p[0, r]
            else:
                b0, b1, b2 = R_out[i - 1, r, 0], R_out[i - 1, r, 1], R_out[i - 1, r, 2]
                pr = p_out[i - 1, r] + b0 * tree_p[i, 0] + b1 * tree_p[i, 1] + b2 * tree_p[i, 2]
                a0 = b0 * tree_R[i, 0, 0] + b1 * tree_R[i, 1, 0] + b2 * tree_R[i, 2, 0]
                a1 = b0 * tree_R[i, 0, 1] + b1 * tree_R[i, 1, 1] + b2 * tree_R[i, 2, 1]
                a2 = b0 * tree_R[i, 0, 2] + b1 * tree_R[i, 1, 2] + b2 * tree_R[i, 2, 2]
            if revolute:
                R_out[i, r, 0] = a0 * c + a1 * s
                R_out[i, r, 1] = a1 * c - a0 * s
                p_out[i, r] = pr
            else:
                R_out[i, r, 0] = a0
                R_out[i, r, 1] = a1
                p_out[i, r] = pr + a2 * value
            R_out[i, r, 2] = a2


@kernel
def end_effector_into(m, R_last, p_last, R_e, p_e):
    """Σ_e in Σ_0 from the last joint frame: T_0e = T_{0,J_n} X_tool (K2)."""
    tool_R, tool_p = m.tool_R, m.tool_p
    for r in range(3):
        p_e[r] = p_last[r]
        for k in range(3):
            p_e[r] += R_last[r, k] * tool_p[k]
        for c in range(3):
            acc = 0.0
            for k in range(3):
                acc += R_last[r, k] * tool_R[k, c]
            R_e[r, c] = acc


@kernel
def geometric_jacobian_into(m, R_frames, p_frames, p_e, J_out):
    """Geometric Jacobian (6, n) = [J_P; J_O] in Σ_0 at the point p_e (K3)."""
    n = R_frames.shape[0]
    joint_type = m.joint_type
    for i in range(n):
        zx, zy, zz = R_frames[i, 0, 2], R_frames[i, 1, 2], R_frames[i, 2, 2]
        if joint_type[i] == PRISMATIC:
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


class KinematicsWorkspace(NamedTuple):
    """Scratch arrays of the ``*_kernel`` entry points (make one per robot and reuse it).

    ``R`` (n, 3, 3), ``p`` (n, 3): joint frames J_i in Σ_0; ``R_e`` (3, 3), ``p_e`` (3,): Σ_e
    (in Σ_0, or Σ_base after a kernel called with ``in_base``); ``J`` (6, n): Jacobian scratch;
    ``angles`` (3,): the Euler angles of the last analytic call.
    """

    R: np.ndarray
    p: np.ndarray
    R_e: np.ndarray
    p_e: np.ndarray
    J: np.ndarray
    angles: np.ndarray


def kinematics_workspace(n: int) -> KinematicsWorkspace:
    """A :class:`KinematicsWorkspace` for a robot with ``n`` joints."""
    return KinematicsWorkspace(R=np.zeros((n, 3, 3)), p=np.zeros((n, 3)), R_e=np.zeros((3, 3)),
                               p_e=np.zeros(3), J=np.zeros((6, n)), angles=np.zeros(3))


@kernel
def rotate_rows_inplace(R, A, row0):
    """A[row0:row0+3, :] ← R · A[row0:row0+3, :] for a (k, c) array A, column by column."""
    for c in range(A.shape[1]):
        x, y, z = A[row0, c], A[row0 + 1, c], A[row0 + 2, c]
        A[row0, c] = R[0, 0] * x + R[0, 1] * y + R[0, 2] * z
        A[row0 + 1, c] = R[1, 0] * x + R[1, 1] * y + R[1, 2] * z
        A[row0 + 2, c] = R[2, 0] * x + R[2, 1] * y + R[2, 2] * z


@kernel
def rotate_segment_inplace(R, v, start):
    """v[start:start+3] ← R · v[start:start+3]."""
    x, y, z = v[start], v[start + 1], v[start + 2]
    v[start] = R[0, 0] * x + R[0, 1] * y + R[0, 2] * z
    v[start + 1] = R[1, 0] * x + R[1, 1] * y + R[1, 2] * z
    v[start + 2] = R[2, 0] * x + R[2, 1] * y + R[2, 2] * z


@kernel
def end_effector_pose_kernel(m, q, in_base, ws):
    """Joint frames (Σ_0) into ws.R, ws.p and Σ_e into ws.R_e, ws.p_e (Σ_0 or Σ_base) (K2).

        T_base,e = T_base0 · T_0e
    """
    n = q.shape[0]
    joint_frames_into(m, q, ws.R, ws.p)
    end_effector_into(m, ws.R[n - 1], ws.p[n - 1], ws.R_e, ws.p_e)
    if in_base:
        rotate_rows_inplace(m.base_R, ws.R_e, 0)
        p_e, base_p = ws.p_e, m.base_p
        rotate_segment_inplace(m.base_R, p_e, 0)
        for r in range(3):
            p_e[r] += base_p[r]


@kernel
def frame_jacobian_kernel(m, q, in_base, ws, J_out):
    """Geometric Jacobian (6, n) of Σ_e in Σ_0 or Σ_base into J_out (K3).

        J^base = blockdiag(R_base0, R_base0) J^0
    """
    n = q.shape[0]
    joint_frames_into(m, q, ws.R, ws.p)
    end_effector_into(m, ws.R[n - 1], ws.p[n - 1], ws.R_e, ws.p_e)
    geometric_jacobian_into(m, ws.R, ws.p, ws.p_e, J_out)
    if in_base:
        rotate_rows_inplace(m.base_R, J_out, 0)
        rotate_rows_inplace(m.base_R, J_out, 3)


@kernel
def pose_vector_into(m, q, convention, branch, reference, in_base, ws, x_out):
    """x = [p_e; φ_e] (6,) [m, rad] into x_out, angles of R_e in the chosen frame (K5).

    ``convention`` is ``spatial.ZYZ`` or ``spatial.RPY``; ``branch`` +1, −1 or 0 (nearest to
    ``reference`` (3,)), see :func:`armlab.spatial.euler_angles_into`.
    """
    end_effector_pose_kernel(m, q, in_base, ws)
    euler_angles_into(ws.R_e, convention, branch, reference, ws.angles)
    for r in range(3):
        x_out[r] = ws.p_e[r]
        x_out[3 + r] = ws.angles[r]


@kernel
def analytic_jacobian_into(J, angles, convention, J_A_out):
    """J_A = T_A(φ)⁻¹ J (6, n) into J_A_out (may be J itself); returns det T(φ) (K4).

    J and φ must refer to the same frame.  Where det T = 0 the angular rows are inf/nan: the
    caller checks the returned determinant against its tolerance.
    """
    for c in range(J.shape[1]):
        a, b, d = euler_rates_from_omega(angles, convention, J[3, c], J[4, c], J[5, c])
        for r in range(3):
            J_A_out[r, c] = J[r, c]
        J_A_out[3, c], J_A_out[4, c], J_A_out[5, c] = a, b, d
    if convention == ZYZ:
        return -np.sin(angles[1])
    return -np.cos(angles[1])


@kernel
def analytic_jacobian_kernel(m, q, convention, branch, reference, in_base, ws, J_A_out):
    """Analytic Jacobian J_A (6, n) of x = [p_e; φ_e] into J_A_out; returns det T(φ) (K4).

    The Euler angles used are left in ``ws.angles``.
    """
    frame_jacobian_kernel(m, q, in_base, ws, J_A_out)
    if in_base:
        # frame_jacobian_kernel left R_e in Σ_0: rotate it to Σ_base for the angles.
        rotate_rows_inplace(m.base_R, ws.R_e, 0)
    euler_angles_into(ws.R_e, convention, branch, reference, ws.angles)
    return analytic_jacobian_into(J_A_out, ws.angles, convention, J_A_out)


@kernel
def jacobian_dot_qd_into(m, R_frames, p_frames, p_e, qd, out):
    """J̇(q, q̇) q̇ = [p̈_e; ω̇_e] at q̈ = 0, (6,) in Σ_0, by one outward recursion (K6).

    With ω_i, ω̇_i the angular velocity/acceleration of link i and a_i the acceleration of
    J_i's origin p_i (all at q̈ = 0), r_i = p_i − p_{i−1} fixed in link i−1 except for a
    prismatic q_i along z_i, and ż_i = ω_{i−1} × z_i:

        a_i = a_{i−1} + ω̇_{i−1} × r_i + ω_{i−1} × (ω_{i−1} × r_i) + 2 q̇_i ω_{i−1} × z_i  [prismatic]
        ω_i = ω_{i−1} + q̇_i z_i,   ω̇_i = ω̇_{i−1} + q̇_i ω_{i−1} × z_i                  [revolute]
        p̈_e = a_n + ω̇_n × r_e + ω_n × (ω_n × r_e),   r_e = p_e − p_n

    ``R_frames`` (n, 3, 3), ``p_frames`` (n, 3), ``p_e`` (3,) from :func:`joint_frames_into` /
    :func:`end_effector_into`; ``qd`` (n,) [m/s | rad/s]; ``out`` (6,) [m/s², rad/s²].
    """
    n = qd.shape[0]
    joint_type = m.joint_type
    wx = wy = wz = 0.0
    ax_ = ay_ = az_ = 0.0      # ω̇
    lx = ly = lz = 0.0         # acceleration of the current origin
    px = py = pz = 0.0         # current origin (Σ_0's origin before joint 1)
    for i in range(n + 1):
        if i < n:
            qx, qy, qz = p_frames[i, 0], p_frames[i, 1], p_frames[i, 2]
        else:
            qx, qy, qz = p_e[0], p_e[1], p_e[2]
        rx, ry, rz = qx - px, qy - py, qz - pz
        # ω × r and ω × (ω × r), ω̇ × r
        cx, cy, cz = wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx
        lx += ay_ * rz - az_ * ry + wy * cz - wz * cy
        ly += az_ * rx - ax_ * rz + wz * cx - wx * cz
        lz += ax_ * ry - ay_ * rx + wx * cy - wy * cx
        if i == n:
            break
        zx, zy, zz = R_frames[i, 0, 2], R_frames[i, 1, 2], R_frames[i, 2, 2]
        wzx, wzy, wzz = wy * zz - wz * zy, wz * zx - wx * zz, wx * zy - wy * zx   # ω_{i−1} × z_i
        if joint_type[i] == PRISMATIC:
            lx += 2.0 * qd[i] * wzx
            ly += 2.0 * qd[i] * wzy
            lz += 2.0 * qd[i] * wzz
        else:
            ax_ += qd[i] * wzx
            ay_ += qd[i] * wzy
            az_ += qd[i] * wzz
            wx += qd[i] * zx
            wy += qd[i] * zy
            wz += qd[i] * zz
        px, py, pz = qx, qy, qz
    out[0], out[1], out[2] = lx, ly, lz
    out[3], out[4], out[5] = ax_, ay_, az_


@kernel
def jacobian_dot_qd_kernel(m, q, qd, in_base, ws, out):
    """J̇q̇ (6,) = [p̈_e; ω̇_e] at q̈ = 0 in Σ_0 or Σ_base into out (K6)."""
    n = q.shape[0]
    joint_frames_into(m, q, ws.R, ws.p)
    end_effector_into(m, ws.R[n - 1], ws.p[n - 1], ws.R_e, ws.p_e)
    jacobian_dot_qd_into(m, ws.R, ws.p, ws.p_e, qd, out)
    if in_base:
        rotate_segment_inplace(m.base_R, out, 0)
        rotate_segment_inplace(m.base_R, out, 3)


@kernel
def analytic_jacobian_dot_qd_into(jdqd, J_A, qd, angles, convention, out):
    """J̇_A q̇ (6,) = T_A⁻¹ (J̇q̇ − Ṫ_A ẋ) with ẋ = J_A q̇, into out; returns det T (K6).

    ``jdqd`` (6,) is J̇q̇ and ``J_A`` (6, n) the analytic Jacobian, both in the frame of the
    angles ``angles`` (3,).  ``out`` may alias ``jdqd``.
    """
    rate0 = rate1 = rate2 = 0.0
    for c in range(qd.shape[0]):
        rate0 += J_A[3, c] * qd[c]
        rate1 += J_A[4, c] * qd[c]
        rate2 += J_A[5, c] * qd[c]
    rates = (rate0, rate1, rate2)
    t0, t1, t2 = euler_rate_dot_times(angles, rates, convention)
    a, b, d = euler_rates_from_omega(angles, convention, jdqd[3] - t0, jdqd[4] - t1, jdqd[5] - t2)
    for r in range(3):
        out[r] = jdqd[r]
    out[3], out[4], out[5] = a, b, d
    if convention == ZYZ:
        return -np.sin(angles[1])
    return -np.cos(angles[1])


@kernel
def analytic_jacobian_dot_qd_kernel(m, q, qd, convention, branch, reference, in_base, ws, out):
    """J̇_A q̇ (6,) of x = [p_e; φ_e] in Σ_0 or Σ_base into out; returns det T(φ) (K6).

    Leaves J_A in ``ws.J`` and the angles in ``ws.angles``.
    """
    det = analytic_jacobian_kernel(m, q, convention, branch, reference, in_base, ws, ws.J)
    # ws.R, ws.p, ws.p_e still hold the frames of q in Σ_0 (only ws.R_e was rotated).
    jacobian_dot_qd_into(m, ws.R, ws.p, ws.p_e, qd, out)
    if in_base:
        rotate_segment_inplace(m.base_R, out, 0)
        rotate_segment_inplace(m.base_R, out, 3)
    analytic_jacobian_dot_qd_into(out, ws.J, qd, ws.angles, convention, out)
    return det
