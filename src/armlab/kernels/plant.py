"""The kernels over a robot's model and data: its packed array and a scratch workspace.

Compiled code pays for every array it receives: unboxing one from Python costs ~0.1 µs, and
compiling a function whose arguments hold the 17 arrays of ``RobotArrays`` and the 17 of a
``DynamicsWorkspace`` costs ~0.6 s before it does anything.  The public dynamics functions and
the simulation loop therefore pass a robot as two arrays — the role of Pinocchio's ``Model``
and ``Data`` — and rebuild the named tuples of views inside compiled code (no copy, no
allocation):

    model  ``robot.packed`` (:func:`armlab.model.robot.pack_arrays`): the robot's numbers,
           never written, shared by every caller and thread;
    data   a workspace buffer of ``workspace_size(n)`` zeros (:func:`make_data`): scratch, one
           per thread (``armlab.dynamics.DynamicsData``, a slice of the simulation's scratch).

Kernels (all arrays float64, C-contiguous; (n,) unless stated):

    rnea_packed(model, data, q, qd, qdd, gravity_scale, h_e, tau_out)
                                            τ of (D1) with g(q) · gravity_scale and h_e (an
                                            all-zero h_e, the workspace's ``no_wrench``, skips
                                            the wrench at run time): the one compiled RNEA of
                                            the plant, of a law's numeric model, of
                                            ``armlab.inverse_dynamics``, ``gravity_torque``
                                            and the kinetic energy
    forward_dynamics_packed(model, data, q, qd, tau, h_e, qdd_out) -> 0 | 1 wrong length |
                                                                      2 B not PD
    kinetic_energy_packed(model, data, q, qd) -> T [J] (NaN for a wrong length), by the RNEA
    measure_packed(model, q, qd, work, R_0e, p_0e, v_e)   pose (3, 3), (3,) and twist (6,) of Σ_e
                                                          in Σ_0; work (18 n,) scratch

"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from armlab.kernels.boundary import borrowed, buffer_view
from armlab.kernels.dynamics import (
    crba_body,
    kernel,
    rnea_inline,
    workspace_from_buffer,
    workspace_size,
)
from armlab.kernels.kinematics import end_effector_into, geometric_jacobian_into, joint_frames_into
from armlab.kernels.linalg import cholesky_solve_inplace
from armlab.kernels.packed import unpack_robot
from armlab.kernels.workspace import rest_of


def make_data(n: int) -> np.ndarray:
    """A robot's data: the zeroed scratch workspace of the kernels below for n joints."""
    return np.zeros(workspace_size.py_func(n))


@njit(cache=True, inline="always")
def unpack_model(model):
    """(n, m): the joint count and the :class:`RobotArrays` of views into ``model``, borrowed
    (they add no reference count: ~18 arrays, whose counting would cost more than a small arm's
    dynamics, and live no longer than the call that holds ``model``)."""
    model = borrowed(model)
    n = int(model[0])
    joint_type = buffer_view(model, 1, n, np.int64)
    start = 1 + n
    return n, unpack_robot(joint_type, buffer_view(model, start, model.shape[0] - start, np.float64))


@njit(cache=True, inline="always")
def unpack_plant(model, data):
    """(n, m, ws): :func:`unpack_model` and the workspace of views into ``data``, borrowed."""
    n, m = unpack_model(model)
    return n, m, workspace_from_buffer(borrowed(data), n)


@kernel
def rnea_packed(model, data, q, qd, qdd, gravity_scale, h_e, tau_out):
    """τ = B q̈ + C q̇ + F_v q̇ + F_s sgn q̇ + g · gravity_scale + Jᵀ h_e (D1) by the RNEA,
    leaving the joint transforms in the workspace; lengths unchecked.

    The forward dynamics below calls it rather than inlining it: its inlined RNEA with a
    wrench cost ~10 s of compile time with empty caches, the call and the CRBA ~3 s more
    than this kernel, and the call costs a few nanoseconds of a numeric PRP step (within
    noise)."""
    n, m, ws = unpack_plant(model, data)
    rnea_inline(m, ws, q, qd, qdd, gravity_scale, h_e, tau_out)


# (model, data, q, qd, qdd, tau_out) -> None: a model's inverse dynamics as a law calls it
# (``armlab.specialise.inverse_dynamics_function``).
INVERSE_DYNAMICS = types.void(*(types.float64[::1],) * 6)


@kernel
def forward_dynamics_packed(model, data, q, qd, tau, h_e, qdd_out):
    """q̈ of (D1) as :func:`~armlab.kernels.dynamics.forward_dynamics_into` computes it:
    the bias by :func:`rnea_packed` (q̈ = 0), then the CRBA on the joint transforms it leaves
    in the workspace and an in-place Cholesky solve (D5).
    Returns 0 (done), 1 (a wrong length: nothing touched) or 2 (B not positive definite)."""
    n, m, ws = unpack_plant(model, data)
    if (q.shape[0] != n or qd.shape[0] != n or tau.shape[0] != n or h_e.shape[0] != 6
            or qdd_out.shape[0] != n):
        return 1
    rnea_packed(model, data, q, qd, ws.zero, 1.0, h_e, qdd_out)
    for k in range(n):
        qdd_out[k] = tau[k] - qdd_out[k]
    crba_body(m, ws, n, ws.L)
    return 0 if cholesky_solve_inplace(ws.L, qdd_out) else 2


@kernel
def kinetic_energy_packed(model, data, q, qd):
    """Kinetic energy T = ½ q̇ᵀ B(q) q̇ (D6) [J], rotors included, or NaN for a wrong length.

    B(q) q̇ is the RNEA's τ at q̈ = q̇ with zero velocity, no gravity and no wrench: with
    q̇ = 0 no Coriolis, centrifugal or friction term is left (F_s sgn 0 = 0).  So the energy
    check of a numeric simulation compiles no kernel of its own (the body-by-body sum of (D6)
    took 1.3–1.6 s to compile with empty caches, on the way to every first result)."""
    n = int(model[0])
    if q.shape[0] != n or qd.shape[0] != n:
        return np.nan
    zero, momentum, no_wrench = rest_of(data, n)
    rnea_packed(model, data, q, zero, qd, 0.0, no_wrench, momentum)
    total = 0.0
    for i in range(n):
        total += qd[i] * momentum[i]
    return 0.5 * total


@kernel
def measure_packed(model, q, qd, work, R_0e, p_0e, v_e):
    """Pose (R_0e, p_0e) and twist v_e = J(q) q̇ of Σ_e in Σ_0 (K2, K3); ``work`` (18 n,)."""
    n, m = unpack_model(model)
    R_frames = buffer_view(work, 0, (n, 3, 3), np.float64)
    p_frames = buffer_view(work, 9 * n, (n, 3), np.float64)
    J = buffer_view(work, 12 * n, (6, n), np.float64)
    joint_frames_into(m, q, R_frames, p_frames)
    end_effector_into(m, R_frames[n - 1], p_frames[n - 1], R_0e, p_0e)
    geometric_jacobian_into(m, R_frames, p_frames, p_0e, J)
    for r in range(6):
        acc = 0.0
        for c in range(n):
            acc += J[r, c] * qd[c]
        v_e[r] = acc
