"""Joint-space dynamics of a serial robot (public API over the compiled kernels).

The plant, with every term of the robot description (``docs/notation.md``, section Dynamics):

    B(q) q̈ + C(q, q̇) q̇ + F_v q̇ + F_s sgn(q̇) + g(q) = τ − Jᵀ(q) h_e                     (D1)

B includes the motor rotors (reflected inertia k_r² I_m and their coupling with the link that
carries them, Siciliano et al. §7.2), C is the Christoffel-symbol matrix (Ḃ − 2C is
skew-symmetric), h_e = [f_e; μ_e] is the wrench the end effector exerts on the environment,
in Σ_0, with μ_e about Σ_e's origin.  Units SI; q̇ [m/s | rad/s], τ [N | N·m].

Each function is a thin, checked wrapper of a compiled kernel of
:mod:`armlab.kernels.dynamics`; compiled code (simulation loops) calls those kernels directly.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.errors import ArmlabError
from armlab.kernels.dynamics import (
    coriolis_matrix_into,
    forward_dynamics_into,
    gravity_into,
    kinetic_energy_kernel,
    mass_matrix_into,
    potential_energy_kernel,
    rnea_into,
    workspace_from_buffer,
    workspace_size,
)
from armlab.kernels.packed import pack_robot, unpack_robot
from armlab.model.robot import Robot

_CACHE_KEY = "_dynamics_packed"
_FLOAT = np.dtype(np.float64)
# Writeable (never written) so that it has the same numba type as a caller's h_e.
_NO_WRENCH = np.zeros(6)


class SingularInertiaError(ArmlabError):
    """B(q) is not positive definite (a link without mass moved by a joint)."""


def _packed(robot: Robot):
    """(joint_type, data, workspace buffer) of ``robot``: its arrays packed for cheap calls and
    a scratch buffer, kept in the robot's instance dictionary next to ``robot.arrays`` (a
    plain attribute lookup; a weak-key dictionary costs more than the dynamics of a small
    arm).  The packed arrays depend only on the immutable robot; every kernel writes the
    scratch it reads first, so sharing the buffer between calls (serialised by the GIL, which
    the kernels keep) cannot change a result."""
    packed = robot.__dict__.get(_CACHE_KEY)
    if packed is None:
        joint_type, data = pack_robot(robot.arrays)
        packed = robot.__dict__[_CACHE_KEY] = (joint_type, data, np.zeros(workspace_size(robot.n)))
    return packed


def _vector(robot: Robot, value, name: str) -> np.ndarray:
    # Fast path first: a contiguous float64 vector of the right length goes to the kernel as it
    # is (other layouts are copied, so the kernels compile for one array type only).
    if (type(value) is np.ndarray and value.dtype is _FLOAT and value.shape == (len(robot.joints),)
            and value.strides[0] == 8):
        return value
    array = np.ascontiguousarray(value, dtype=np.float64)
    if array.shape != (robot.n,):
        raise ValueError(f"{name} must have shape ({robot.n},) for robot {robot.name!r}, got {array.shape}")
    return array


def _wrench(h_e) -> np.ndarray:
    if h_e is None:
        return _NO_WRENCH
    array = np.ascontiguousarray(h_e, dtype=np.float64)
    if array.shape != (6,):
        raise ValueError(f"h_e must have shape (6,) = [f_e; μ_e], got {array.shape}")
    return array


# Entry points from Python: the robot travels packed and the workspace is a view of one
# buffer, so a call unboxes a handful of arrays instead of 35 (see kernels/packed.py).
entry = njit(cache=True, _nrt=False)


@entry
def _rnea_entry(joint_type, data, buf, q, qd, qdd, gravity_scale, h_e, out):
    n = q.shape[0]
    rnea_into(unpack_robot(joint_type, data), workspace_from_buffer(buf, n), q, qd, qdd, gravity_scale,
              h_e, out)


@entry
def _mass_matrix_entry(joint_type, data, buf, q, out):
    mass_matrix_into(unpack_robot(joint_type, data), workspace_from_buffer(buf, q.shape[0]), q, out)


@entry
def _gravity_entry(joint_type, data, buf, q, out):
    gravity_into(unpack_robot(joint_type, data), workspace_from_buffer(buf, q.shape[0]), q, out)


@entry
def _coriolis_entry(joint_type, data, buf, q, qd, out):
    coriolis_matrix_into(unpack_robot(joint_type, data), workspace_from_buffer(buf, q.shape[0]), q, qd,
                         out)


@entry
def _forward_entry(joint_type, data, buf, q, qd, tau, h_e, out):
    return forward_dynamics_into(unpack_robot(joint_type, data), workspace_from_buffer(buf, q.shape[0]),
                                 q, qd, tau, h_e, out)


@entry
def _kinetic_entry(joint_type, data, buf, q, qd):
    return kinetic_energy_kernel(unpack_robot(joint_type, data), workspace_from_buffer(buf, q.shape[0]),
                                 q, qd)


@entry
def _potential_entry(joint_type, data, buf, q):
    return potential_energy_kernel(unpack_robot(joint_type, data), workspace_from_buffer(buf, q.shape[0]),
                                   q)


def inverse_dynamics(robot: Robot, q, qd, qdd, h_e=None, gravity: bool = True) -> np.ndarray:
    """Joint forces τ (n,) [N | N·m] that produce q̈ at (q, q̇) under (D1), by recursive
    Newton–Euler (Siciliano et al. §7.5), motors and friction included.

        τ = B(q) q̈ + C(q, q̇) q̇ + F_v q̇ + F_s sgn(q̇) + g(q) + Jᵀ(q) h_e                   (D1)

    Parameters
    ----------
    q, qd, qdd : (n,) joint positions, velocities, accelerations [m | rad, /s, /s²].
    h_e : (6,) or None, wrench [f_e; μ_e] the end effector exerts on the environment, in Σ_0
        [N, N·m], μ_e about Σ_e's origin; None for free motion.
    gravity : include g(q) (False: g_0 = 0).
    """
    joint_type, data, buf = _packed(robot)
    tau = np.empty(robot.n)
    _rnea_entry(joint_type, data, buf, _vector(robot, q, "q"), _vector(robot, qd, "qd"),
                _vector(robot, qdd, "qdd"), 1.0 if gravity else 0.0, _wrench(h_e), tau)
    return tau


def inertia_matrix(robot: Robot, q) -> np.ndarray:
    """Joint-space inertia matrix B(q), (n, n), symmetric positive definite, rotors included
    (D2, D3), by the composite-rigid-body algorithm.  Units kg | kg·m | kg·m²."""
    joint_type, data, buf = _packed(robot)
    B = np.empty((robot.n, robot.n))
    _mass_matrix_entry(joint_type, data, buf, _vector(robot, q, "q"), B)
    return B


def coriolis_matrix(robot: Robot, q, qd) -> np.ndarray:
    """Coriolis/centrifugal matrix C(q, q̇), (n, n), from the Christoffel symbols of B:

        C_ij = Σ_k ½(∂B_ij/∂q_k + ∂B_ik/∂q_j − ∂B_jk/∂q_i) q̇_k                            (D4)

    so that Ḃ − 2C is skew-symmetric (Siciliano et al. (7.49)).
    """
    joint_type, data, buf = _packed(robot)
    C = np.empty((robot.n, robot.n))
    _coriolis_entry(joint_type, data, buf, _vector(robot, q, "q"), _vector(robot, qd, "qd"), C)
    return C


def gravity_torque(robot: Robot, q) -> np.ndarray:
    """Gravity torques g(q) = (∂U/∂q)ᵀ, (n,) [N | N·m], with U of (D7)."""
    joint_type, data, buf = _packed(robot)
    g = np.empty(robot.n)
    _gravity_entry(joint_type, data, buf, _vector(robot, q, "q"), g)
    return g


def forward_dynamics(robot: Robot, q, qd, tau, h_e=None) -> np.ndarray:
    """Joint accelerations q̈ (n,) of (D1) under the joint forces τ (n,) [N | N·m]:

        B(q) q̈ = τ − C q̇ − F_v q̇ − F_s sgn(q̇) − g(q) − Jᵀ h_e                            (D5)

    solved by Cholesky factorisation of B (never an inverse).  ``h_e`` as in
    :func:`inverse_dynamics`.  Raises :class:`SingularInertiaError` if B is not positive
    definite.
    """
    joint_type, data, buf = _packed(robot)
    qdd = np.empty(robot.n)
    ok = _forward_entry(joint_type, data, buf, _vector(robot, q, "q"), _vector(robot, qd, "qd"),
                        _vector(robot, tau, "tau"), _wrench(h_e), qdd)
    if not ok:
        raise SingularInertiaError(f"robot {robot.name!r}: inertia matrix B(q) is not positive definite")
    return qdd


def kinetic_energy(robot: Robot, q, qd) -> float:
    """Kinetic energy T = ½ q̇ᵀ B(q) q̇ [J] of links and motor rotors, summed body by body:

        T = Σ_i ½ m_i ‖ṗ_Ci‖² + ½ ω_iᵀ I_Ci ω_i + ½ I_mi (z_miᵀ ω_{i−1} + k_ri q̇_i)²       (D6)
    """
    joint_type, data, buf = _packed(robot)
    return float(_kinetic_entry(joint_type, data, buf, _vector(robot, q, "q"), _vector(robot, qd, "qd")))


def potential_energy(robot: Robot, q) -> float:
    """Gravitational potential energy U = −Σ_i m_i g_0ᵀ p_Ci [J], zero at Σ_0's origin (D7).

    Rotor masses are part of the link inertials, so this is the whole potential energy.
    """
    joint_type, data, buf = _packed(robot)
    return float(_potential_entry(joint_type, data, buf, _vector(robot, q, "q")))
