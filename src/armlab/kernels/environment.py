"""Compiled environment laws: the wrench h_e = [f; μ] in Σ_0 the end effector exerts.

Each law follows the environment protocol of ``armlab.control.base``:

    law(t, R_0e, p_0e, v_e, params, h_e_out)

and writes h_e (6,) [N, N·m] in Σ_0, the torque taken about the end-effector origin o_e.
The generalised spring stores the potential (notation table, E2)

    U = ½ x_{r,e}ᵀ K x_{r,e},   x_{r,e} = [R_rᵀ (o_e − o_r); φ_{r,e}]                     (E2)

with φ_{r,e} the XYZ Euler angles of R_rᵀ R_e; the wrench work-conjugate to the twist is

    h_e^r = T_A^{−T}(φ_{r,e}) K x_{r,e},    h_e = blockdiag(R_r, R_r) h_e^r               (E3)

which is Siciliano et al. (9.23) h_e = K dx_{r,e} for small displacements (T(0) = I for XYZ
angles) and stays conservative for large ones.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from armlab.kernels.rotations import euler_xyz_from_matrix_into, euler_xyz_rate_inverse_into


class FreeSpaceParams(NamedTuple):
    """The ``params`` of :func:`free_space_law`: none."""


@njit(cache=True)
def free_space_law(t, R_0e, p_0e, v_e, params, h_e_out):
    """Free space: h_e = 0 (E1); ``params`` a :class:`FreeSpaceParams`."""
    for i in range(6):
        h_e_out[i] = 0.0


@njit(cache=True)
def spring_displacement_into(R_r, o_r, R_0e, p_0e, R_rel, x_out):
    """x_{r,e} = [R_rᵀ (o_e − o_r); φ_XYZ(R_rᵀ R_e)] (6,) of (E2); R_rel (3, 3) scratch."""
    for i in range(3):
        acc = 0.0
        for k in range(3):
            acc += R_r[k, i] * (p_0e[k] - o_r[k])
        x_out[i] = acc
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += R_r[k, i] * R_0e[k, j]
            R_rel[i, j] = acc
    euler_xyz_from_matrix_into(R_rel, x_out[3:])


class SpringParams(NamedTuple):
    """The ``params`` of :func:`spring_law` (E2, E3); the last three fields are scratch."""

    rest_rotation: np.ndarray       # (3, 3) R_r, the rest frame's axes in Σ_0
    rest_position: np.ndarray       # (3,) o_r [m], the rest frame's origin in Σ_0
    stiffness: np.ndarray           # (6, 6) K in Σ_r [N/m, N/rad; N·m/m, N·m/rad]
    work: np.ndarray                # (12,) x_{r,e} and K x_{r,e}
    R_rel: np.ndarray               # (3, 3) R_rᵀ R_e
    T_inv: np.ndarray               # (3, 3) T⁻¹(φ_{r,e}) of the XYZ angles


@njit(cache=True)
def spring_law(t, R_0e, p_0e, v_e, params, h_e_out):
    """Generalised spring (E2)–(E3); ``params`` a :class:`SpringParams`."""
    R_r, o_r, K = params.rest_rotation, params.rest_position, params.stiffness
    work, R_rel, T_inv = params.work, params.R_rel, params.T_inv
    x = work[:6]
    kx = work[6:]
    spring_displacement_into(R_r, o_r, R_0e, p_0e, R_rel, x)
    euler_xyz_rate_inverse_into(x[3], x[4], T_inv)
    for i in range(6):
        acc = 0.0
        for j in range(6):
            acc += K[i, j] * x[j]
        kx[i] = acc
    # h^r = [K x]_f ; T^{−T} [K x]_μ, then both halves rotated into Σ_0.
    for i in range(3):
        x[i] = T_inv[0, i] * kx[3] + T_inv[1, i] * kx[4] + T_inv[2, i] * kx[5]
    for i in range(3):
        h_e_out[i] = R_r[i, 0] * kx[0] + R_r[i, 1] * kx[1] + R_r[i, 2] * kx[2]
        h_e_out[3 + i] = R_r[i, 0] * x[0] + R_r[i, 1] * x[1] + R_r[i, 2] * x[2]


class PlanarWallParams(NamedTuple):
    """The ``params`` of :func:`wall_law` (E4)."""

    point: np.ndarray               # (3,) p_w [m], a point of the wall's plane in Σ_0
    normal: np.ndarray              # (3,) n, unit, pointing out of the wall into free space
    stiffness: float                # k [N/m] > 0
    damping: float                  # d [N·s/m] ≥ 0


@njit(cache=True)
def wall_law(t, R_0e, p_0e, v_e, params, h_e_out):
    """Planar elastic wall, unilateral, with optional damping (E4); ``params`` a
    :class:`PlanarWallParams`.  With the penetration δ = nᵀ(p_w − p_e) and its rate
    δ̇ = −nᵀ ṗ_e,

        f_e = −n · max(0, k δ + d δ̇)  if δ > 0,   f_e = 0 otherwise,   μ_e = 0           (E4)

    so the wall only pushes (a separating end effector is never pulled back by the damper).
    """
    point, normal, stiffness, damping = params.point, params.normal, params.stiffness, params.damping
    depth = 0.0
    rate = 0.0
    for i in range(3):
        depth += normal[i] * (point[i] - p_0e[i])
        rate -= normal[i] * v_e[i]
    magnitude = 0.0
    if depth > 0.0:
        magnitude = stiffness * depth + damping * rate
        if magnitude < 0.0:
            magnitude = 0.0
    for i in range(3):
        h_e_out[i] = -normal[i] * magnitude
        h_e_out[3 + i] = 0.0
