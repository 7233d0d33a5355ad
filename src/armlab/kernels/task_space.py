"""Compiled task-space kernels: frame-relative pose errors, their Jacobians and drift terms.

Interaction control (Siciliano et al. ch. 9) expresses the end-effector pose relative to a
(possibly moving) frame Σ_a — the desired frame Σ_d, or the compliant frame Σ_t — as

    x̃ = −[o^a_{a,e}; φ_{a,e}],   o^a_{a,e} = R_aᵀ (o_e − o_a),   R(φ_{a,e}) = R_aᵀ R_e      (T1)

with φ_{a,e} the **XYZ** Euler angles, R(φ) = Rx(φ₁) Ry(φ₂) Rz(φ₃), chosen because their
T(φ) (ω = T(φ) φ̇, ω in the first frame) is the identity at φ = 0, so x̃ is a set of
independent small displacements along and about Σ_a's axes; T is singular only at
φ₂ = ±π/2, a 90° tilt between Σ_a and Σ_e.  Differentiating (T1):

    x̃̇ = −J_{A_a}(q) q̇ + b,   J_{A_a} = T_A⁻¹(φ_{a,e}) blockdiag(R_aᵀ, R_aᵀ) J(q)          (T2)
    b = [R_aᵀ ȯ_a + S(ω_a^a) o^a_{a,e}; T⁻¹(φ_{a,e}) ω_a^a]                                (T3)
    x̃̈ = −J_{A_a} q̈ + c(q, q̇, t),   c = x̃̈ evaluated at q̈ = 0                             (T4)

(T2)–(T3) are Siciliano (9.27)–(9.28); c = ḃ − J̇_{A_a} q̇ is computed directly from the
second derivatives of (T1), see :func:`relative_error_into`.

The XYZ-angle kernels are in :mod:`armlab.kernels.rotations`, the small dense linear algebra
(3-vectors, the task systems) in :mod:`armlab.kernels.linalg`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from armlab.kernels.kinematics import (
    analytic_jacobian_dot_qd_into,
    analytic_jacobian_into,
    end_effector_into,
    geometric_jacobian_into,
    jacobian_dot_qd_into,
    joint_frames_into,
)
from armlab.kernels.linalg import cross_into, det3, matTvec3, matvec3, singular_values_into
from armlab.kernels.rotations import (
    euler_xyz_from_matrix_into,
    euler_xyz_matrix_into,
    euler_xyz_rate_dot_into,
    euler_xyz_rate_into,
    euler_xyz_rate_inverse_into,
)
from armlab.spatial import (
    euler_angles_into,
    euler_rate_dot_times,
    euler_rate_matrix_into,
    euler_rates_from_omega,
)


@njit(cache=True)
def frame_from_vector(frame, R_out):
    """R_out (3, 3) ← the rotation of a frame-motion vector (see :func:`relative_error_into`)."""
    for r in range(3):
        for c in range(3):
            R_out[r, c] = frame[3 + 3 * r + c]


@njit(cache=True)
def relative_error_into(frame, R_e, o_e, J, v_e, a0, vec, mat, x_err, x_err_dot, c_out, JA_out):
    """Pose error of Σ_e relative to the moving frame Σ_a and its derivatives, (T1)–(T4).

    Parameters
    ----------
    frame : (24,) Σ_a's motion in Σ_0, a *frame-motion vector*: [o_a [m], R_a row-major (9),
        ȯ_a [m/s], ω_a [rad/s], ö_a [m/s²], ω̇_a [rad/s²]]
    R_e, o_e : (3, 3), (3,) end-effector pose in Σ_0 [m]
    J : (6, n) geometric Jacobian in Σ_0;  v_e : (6,) twist J q̇;  a0 : (6,) J̇ q̇ in Σ_0
    vec : (8, 3), mat : (4, 3, 3) scratch
    x_err, x_err_dot, c_out : (6,) x̃, x̃̇ and the drift c of (T4), in Σ_a [m, rad, /s, /s²]
    JA_out : (6, n) J_{A_a} of (T2)

    Notes
    -----
    With Δ = o_e − o_a and ω_{a,e} = ω_e − ω_a (Σ_0), Ṙ_a = S(ω_a) R_a gives

        x̃̈_P = −R_aᵀ [ö_e − ö_a − 2 ω_a × Δ̇ − ω̇_a × Δ + ω_a × (ω_a × Δ)]
        x̃̈_O = −T⁻¹ (R_aᵀ(ω̇_e − ω̇_a − ω_a × ω_{a,e}) − Ṫ φ̇),   φ̇ = T⁻¹ R_aᵀ ω_{a,e}

    and c is this with [ö_e; ω̇_e] replaced by the velocity-product part J̇ q̇ = a0.
    """
    R_a, R_rel, T_inv, T_dot = mat[0], mat[1], mat[2], mat[3]
    d, dd, t1, t2, t3, phi, phid, w_rel = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5], vec[6], vec[7]
    frame_from_vector(frame, R_a)
    o_a, od_a, w_a = frame[0:3], frame[12:15], frame[15:18]
    odd_a, wd_a = frame[18:21], frame[21:24]
    for i in range(3):
        d[i] = o_e[i] - o_a[i]
        dd[i] = v_e[i] - od_a[i]
        w_rel[i] = v_e[3 + i] - w_a[i]
    # Position: x̃_P = −R_aᵀΔ, x̃̇_P = −R_aᵀ(Δ̇ − ω_a × Δ).
    matTvec3(R_a, d, t1)
    cross_into(w_a, d, t2)
    for i in range(3):
        x_err[i] = -t1[i]
        t3[i] = dd[i] - t2[i]
    matTvec3(R_a, t3, t1)
    for i in range(3):
        x_err_dot[i] = -t1[i]
    cross_into(w_a, dd, t1)
    cross_into(wd_a, d, t3)
    for i in range(3):
        t1[i] = a0[i] - odd_a[i] - 2.0 * t1[i] - t3[i]
    cross_into(w_a, t2, t3)
    for i in range(3):
        t1[i] += t3[i]
    matTvec3(R_a, t1, t2)
    for i in range(3):
        c_out[i] = -t2[i]
    # Orientation: R(φ) = R_aᵀ R_e.
    for r in range(3):
        for c in range(3):
            R_rel[r, c] = R_a[0, r] * R_e[0, c] + R_a[1, r] * R_e[1, c] + R_a[2, r] * R_e[2, c]
    euler_xyz_from_matrix_into(R_rel, phi)
    euler_xyz_rate_inverse_into(phi[0], phi[1], T_inv)
    matTvec3(R_a, w_rel, t1)
    matvec3(T_inv, t1, phid)
    euler_xyz_rate_dot_into(phi[0], phi[1], phid[0], phid[1], T_dot)
    for i in range(3):
        x_err[3 + i] = -phi[i]
        x_err_dot[3 + i] = -phid[i]
    cross_into(w_a, w_rel, t1)
    for i in range(3):
        t1[i] = a0[3 + i] - wd_a[i] - t1[i]
    matTvec3(R_a, t1, t2)
    matvec3(T_dot, phid, t3)
    for i in range(3):
        t2[i] -= t3[i]
    matvec3(T_inv, t2, t1)
    for i in range(3):
        c_out[3 + i] = -t1[i]
    # J_{A_a} = T_A⁻¹ blockdiag(R_aᵀ, R_aᵀ) J.
    n = J.shape[1]
    for j in range(n):
        for i in range(3):
            t1[i] = J[i, j]
            t2[i] = J[3 + i, j]
        matTvec3(R_a, t1, t3)
        JA_out[0, j], JA_out[1, j], JA_out[2, j] = t3[0], t3[1], t3[2]
        matTvec3(R_a, t2, t3)
        matvec3(T_inv, t3, t1)
        JA_out[3, j], JA_out[4, j], JA_out[5, j] = t1[0], t1[1], t1[2]






RELATIVE, ABSOLUTE = 0, 1


class TaskWorkspace(NamedTuple):
    """Scratch of the task-space laws for an n-joint robot and a k-component task.

    Kinematics (Σ_0): ``R`` (n, 3, 3), ``p`` (n, 3) joint frames, ``R_e`` (3, 3), ``p_e`` (3,),
    ``J`` (6, n), ``v_e`` (6,) = J q̇, ``a0`` (6,) = J̇ q̇.  Errors: ``frame`` (24,) the target
    frame motion, ``x_err``, ``x_err_dot``, ``c`` (6,), ``JA`` (6, n), ``x_e`` (6,) pose logged.
    Task system: ``A`` (k, n), ``rhs`` (k,), ``G`` (n, n), ``y`` (n,), ``sv`` (n,).  Other:
    ``vec`` (8, 3), ``mat`` (4, 3, 3), ``h`` (6,), ``h_task`` (6,), ``w6`` (6,), ``tau`` (n,),
    ``angles`` (3,), ``T`` (3, 3).
    """

    R: np.ndarray
    p: np.ndarray
    R_e: np.ndarray
    p_e: np.ndarray
    J: np.ndarray
    v_e: np.ndarray
    a0: np.ndarray
    frame: np.ndarray
    x_err: np.ndarray
    x_err_dot: np.ndarray
    c: np.ndarray
    JA: np.ndarray
    x_e: np.ndarray
    A: np.ndarray
    rhs: np.ndarray
    G: np.ndarray
    y: np.ndarray
    sv: np.ndarray
    vec: np.ndarray
    mat: np.ndarray
    h: np.ndarray
    h_task: np.ndarray
    w6: np.ndarray
    tau: np.ndarray
    angles: np.ndarray
    T: np.ndarray


def task_workspace(n: int, k: int) -> TaskWorkspace:
    """A :class:`TaskWorkspace` for n joints and k task components."""
    return TaskWorkspace(
        R=np.zeros((n, 3, 3)), p=np.zeros((n, 3)), R_e=np.zeros((3, 3)), p_e=np.zeros(3),
        J=np.zeros((6, n)), v_e=np.zeros(6), a0=np.zeros(6), frame=np.zeros(24),
        x_err=np.zeros(6), x_err_dot=np.zeros(6), c=np.zeros(6), JA=np.zeros((6, n)),
        x_e=np.zeros(6), A=np.zeros((k, n)), rhs=np.zeros(k), G=np.zeros((n, n)), y=np.zeros(n),
        sv=np.zeros(n), vec=np.zeros((8, 3)), mat=np.zeros((4, 3, 3)), h=np.zeros(6),
        h_task=np.zeros(6), w6=np.zeros(6), tau=np.zeros(n), angles=np.zeros(3), T=np.zeros((3, 3)))


@njit(cache=True)
def measure_into(m, q, qd, ws):
    """End-effector pose, J, twist v_e = J q̇ and J̇ q̇ (all Σ_0) into the workspace."""
    n = q.shape[0]
    joint_frames_into(m, q, ws.R, ws.p)
    end_effector_into(m, ws.R[n - 1], ws.p[n - 1], ws.R_e, ws.p_e)
    geometric_jacobian_into(m, ws.R, ws.p, ws.p_e, ws.J)
    for i in range(6):
        acc = 0.0
        for j in range(n):
            acc += ws.J[i, j] * qd[j]
        ws.v_e[i] = acc
    jacobian_dot_qd_into(m, ws.R, ws.p, ws.p_e, qd, ws.a0)


@njit(cache=True)
def absolute_error_into(frame, convention, angle_reference, qd, ws):
    """x̃ = x_d − x_e, x̃̇ and c of x̃̈ = −J_A q̈ + c for x = [p; φ] in Σ_0 (T6).

        x̃̇ = ẋ_d − J_A q̇,   c = ẍ_d − J̇_A q̇,   J_A = T_A⁻¹(φ_e) J   (Siciliano (3.66), §8.6)

    φ are Euler angles ``convention`` (``spatial.ZYZ``/``RPY``); φ_d is the triple nearest to
    ``angle_reference`` (3,) and φ_e the one nearest to φ_d, so errors never jump by 2π or
    between branches.  φ̇_d = T⁻¹(φ_d) ω_d, φ̈_d = T⁻¹(φ_d)(ω̇_d − Ṫ φ̇_d).  Reads ws.R_e, ws.p_e,
    ws.J, ws.a0, ws.v_e (from :func:`measure_into`); writes ws.x_err, ws.x_err_dot, ws.c,
    ws.JA, ws.x_e.  Returns det T(φ_e) (0 at a representation singularity).
    """
    R_d = ws.mat[0]
    frame_from_vector(frame, R_d)
    phi_d = ws.vec[0]
    rate_d = ws.vec[1]
    acc_d = ws.vec[2]
    euler_angles_into(R_d, convention, 0, angle_reference, phi_d)
    euler_angles_into(ws.R_e, convention, 0, phi_d, ws.angles)
    a, b, d = euler_rates_from_omega(phi_d, convention, frame[15], frame[16], frame[17])
    rate_d[0], rate_d[1], rate_d[2] = a, b, d
    t0, t1, t2 = euler_rate_dot_times(phi_d, rate_d, convention)
    a, b, d = euler_rates_from_omega(phi_d, convention, frame[21] - t0, frame[22] - t1, frame[23] - t2)
    acc_d[0], acc_d[1], acc_d[2] = a, b, d
    det = analytic_jacobian_into(ws.J, ws.angles, convention, ws.JA)
    analytic_jacobian_dot_qd_into(ws.a0, ws.JA, qd, ws.angles, convention, ws.w6)
    n = qd.shape[0]
    for i in range(6):
        rate = 0.0
        for j in range(n):
            rate += ws.JA[i, j] * qd[j]
        if i < 3:
            ws.x_e[i] = ws.p_e[i]
            ws.x_err[i] = frame[i] - ws.p_e[i]
            ws.x_err_dot[i] = frame[12 + i] - rate
            ws.c[i] = frame[18 + i] - ws.w6[i]
        else:
            ws.x_e[i] = ws.angles[i - 3]
            ws.x_err[i] = phi_d[i - 3] - ws.angles[i - 3]
            ws.x_err_dot[i] = rate_d[i - 3] - rate
            ws.c[i] = acc_d[i - 3] - ws.w6[i]
    return det


@njit(cache=True)
def task_error_into(mode, frame, convention, angle_reference, qd, ws):
    """Fill ws.x_err, ws.x_err_dot, ws.c, ws.JA (and ws.x_e) for the target frame ``frame``.

    ``mode`` RELATIVE: (T1)–(T4), errors in Σ_a's axes, XYZ angles of R_aᵀR_e, x_e the logged
    [o^a_{a,e}; φ_{a,e}];  ABSOLUTE: (T6), x = [p; φ] in Σ_0.  Returns det T(φ).
    """
    if mode == RELATIVE:
        relative_error_into(frame, ws.R_e, ws.p_e, ws.J, ws.v_e, ws.a0, ws.vec, ws.mat,
                            ws.x_err, ws.x_err_dot, ws.c, ws.JA)
        for i in range(6):
            ws.x_e[i] = -ws.x_err[i]
        return np.cos(ws.x_e[4])
    return absolute_error_into(frame, convention, angle_reference, qd, ws)


@njit(cache=True)
def select_rows_into(task, A6, out):
    """out (k, n) ← rows ``task`` (k,) of A6 (6, n)."""
    for r in range(task.shape[0]):
        for c in range(A6.shape[1]):
            out[r, c] = A6[task[r], c]


@njit(cache=True)
def wrench_in_task_into(mode, convention, frame, phi, h_e, R_a, T, w, h_out):
    """h_A (6,), the wrench work-conjugate to the task coordinates x (T7).

        RELATIVE: h_A = T_Aᵀ(φ_{a,e}) blockdiag(R_aᵀ, R_aᵀ) h_e   (Siciliano (9.30))
        ABSOLUTE: h_A = T_Aᵀ(φ_e) h_e   (power h_eᵀ v_e = h_Aᵀ ẋ with v_e = T_A ẋ)

    ``frame`` (24,) Σ_a's motion (its rotation R_a is read in RELATIVE mode); ``phi`` (3,) the
    Euler angles of the current pose in the task coordinates: φ_{a,e} (XYZ, RELATIVE) or φ_e
    (``convention``, ABSOLUTE), as :func:`task_error_into` leaves them in ``ws.x_e[3:]`` and
    ``ws.angles``; ``h_e`` (6,) [N, N·m] in Σ_0.  ``R_a``, ``T`` (3, 3) and ``w`` (3,) scratch.
    """
    if mode == RELATIVE:
        frame_from_vector(frame, R_a)
        for i in range(3):
            h_out[i] = R_a[0, i] * h_e[0] + R_a[1, i] * h_e[1] + R_a[2, i] * h_e[2]
            w[i] = R_a[0, i] * h_e[3] + R_a[1, i] * h_e[4] + R_a[2, i] * h_e[5]
        euler_xyz_rate_into(phi[0], phi[1], T)
    else:
        for i in range(3):
            h_out[i] = h_e[i]
            w[i] = h_e[3 + i]
        euler_rate_matrix_into(phi, convention, T)
    for i in range(3):
        h_out[3 + i] = T[0, i] * w[0] + T[1, i] * w[1] + T[2, i] * w[2]


@njit(cache=True)
def log_task_signals(ws, task, signals_out, start):
    """Write σ(J_task) (n,) and the seed's det of J's linear part (1) at ``start``; returns
    the next free index.  ``ws.A`` must hold the selected task Jacobian."""
    n = ws.y.shape[0]
    singular_values_into(ws.A, ws.G, ws.sv)
    for i in range(n):
        signals_out[start + i] = ws.sv[i]
    signals_out[start + n] = det3(ws.J) if n == 3 else 0.0
    return start + n + 1


@njit(cache=True)
def position_error_into(frame, qd, ws):
    """Position-only task in Σ_0 (T8): x̃ = p_d − p_e, x̃̇ = ṗ_d − J_P q̇, c = p̈_d − J̇_P q̇.

    Rows 3–5 of the outputs are zero (x_err, x_err_dot, c) and J_O (JA); ws.x_e = [p_e; 0].
    """
    n = qd.shape[0]
    for i in range(3):
        rate = 0.0
        for j in range(n):
            rate += ws.J[i, j] * qd[j]
            ws.JA[i, j] = ws.J[i, j]
            ws.JA[3 + i, j] = ws.J[3 + i, j]
        ws.x_e[i] = ws.p_e[i]
        ws.x_e[3 + i] = 0.0
        ws.x_err[i] = frame[i] - ws.p_e[i]
        ws.x_err_dot[i] = frame[12 + i] - rate
        ws.c[i] = frame[18 + i] - ws.a0[i]
        ws.x_err[3 + i] = 0.0
        ws.x_err_dot[3 + i] = 0.0
        ws.c[3 + i] = 0.0


@njit(cache=True)
def compliant_frame_into(frame_d, zt, zt_dot, zt_ddot, vec, mat, frame_t):
    """Motion of the compliant frame Σ_t (24,) in Σ_0 from Σ_d's (24,) and z̃ = −[o^d_{d,t};
    φ_{d,t}] with its rates (6,) each (T9).  With u = R_d o^d_{d,t}, w = R_d T(φ) φ̇:

        o_t = o_d + u,   ȯ_t = ȯ_d + ω_d × u + R_d ȯ^d_{d,t}
        ö_t = ö_d + ω̇_d × u + ω_d × (ω_d × u) + 2 ω_d × (R_d ȯ^d_{d,t}) + R_d ö^d_{d,t}
        R_t = R_d R(φ),   ω_t = ω_d + w,   ω̇_t = ω̇_d + ω_d × w + R_d (Ṫ φ̇ + T φ̈)

    ``vec`` (8, 3), ``mat`` (4, 3, 3) scratch.
    """
    R_d, R_rel, T, T_dot = mat[0], mat[1], mat[2], mat[3]
    u, v, a, phi, phid, phidd, t1, t2 = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5], vec[6], vec[7]
    frame_from_vector(frame_d, R_d)
    w_d, wd_d = frame_d[15:18], frame_d[21:24]
    for i in range(3):
        t1[i] = -zt[i]
        t2[i] = -zt_dot[i]
        a[i] = -zt_ddot[i]
        phi[i] = -zt[3 + i]
        phid[i] = -zt_dot[3 + i]
        phidd[i] = -zt_ddot[3 + i]
    matvec3(R_d, t1, u)
    matvec3(R_d, t2, v)
    matvec3(R_d, a, t1)                 # R_d ö^d
    for i in range(3):
        frame_t[i] = frame_d[i] + u[i]
    cross_into(w_d, u, t2)
    for i in range(3):
        frame_t[12 + i] = frame_d[12 + i] + t2[i] + v[i]
    cross_into(w_d, t2, a)              # ω_d × (ω_d × u)
    for i in range(3):
        t1[i] += a[i]
    cross_into(wd_d, u, a)
    for i in range(3):
        t1[i] += a[i]
    cross_into(w_d, v, a)
    for i in range(3):
        frame_t[18 + i] = frame_d[18 + i] + t1[i] + 2.0 * a[i]
    euler_xyz_matrix_into(phi[0], phi[1], phi[2], R_rel)
    for r in range(3):
        for c in range(3):
            frame_t[3 + 3 * r + c] = (R_d[r, 0] * R_rel[0, c] + R_d[r, 1] * R_rel[1, c]
                                      + R_d[r, 2] * R_rel[2, c])
    euler_xyz_rate_into(phi[0], phi[1], T)
    euler_xyz_rate_dot_into(phi[0], phi[1], phid[0], phid[1], T_dot)
    matvec3(T, phid, t1)
    matvec3(R_d, t1, u)                 # w
    matvec3(T_dot, phid, t1)
    matvec3(T, phidd, t2)
    for i in range(3):
        t1[i] += t2[i]
    matvec3(R_d, t1, t2)
    cross_into(w_d, u, t1)
    for i in range(3):
        frame_t[15 + i] = w_d[i] + u[i]
        frame_t[21 + i] = wd_d[i] + t1[i] + t2[i]
