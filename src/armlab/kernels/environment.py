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

from numba import njit

from armlab.kernels.rotations import euler_xyz_from_matrix_into, euler_xyz_rate_inverse_into


@njit(cache=True)
def free_space_law(t, R_0e, p_0e, v_e, params, h_e_out):
    """Free space: h_e = 0 (E1)."""
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


@njit(cache=True)
def spring_law(t, R_0e, p_0e, v_e, params, h_e_out):
    """Generalised spring (E2)–(E3).

    ``params = (R_r (3, 3), o_r (3,) [m], K (6, 6) [N/m, N/rad, N·m/m, N·m/rad] in Σ_r,
    work (12,), R_rel (3, 3), T_inv (3, 3))``; the last three are scratch.
    """
    R_r, o_r, K, work, R_rel, T_inv = params
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


@njit(cache=True)
def wall_law(t, R_0e, p_0e, v_e, params, h_e_out):
    """Planar elastic wall, unilateral, with optional damping (E4).

    ``params = (point (3,) [m], normal (3,) unit, pointing out of the wall into free space,
    coefficients (2,) = (stiffness k [N/m], damping d [N·s/m]))``.  With the penetration
    δ = nᵀ(p_w − p_e) and its rate δ̇ = −nᵀ ṗ_e,

        f_e = −n · max(0, k δ + d δ̇)  if δ > 0,   f_e = 0 otherwise,   μ_e = 0           (E4)

    so the wall only pushes (a separating end effector is never pulled back by the damper).
    """
    point, normal, coefficients = params
    depth = 0.0
    rate = 0.0
    for i in range(3):
        depth += normal[i] * (point[i] - p_0e[i])
        rate -= normal[i] * v_e[i]
    magnitude = 0.0
    if depth > 0.0:
        magnitude = coefficients[0] * depth + coefficients[1] * rate
        if magnitude < 0.0:
            magnitude = 0.0
    for i in range(3):
        h_e_out[i] = -normal[i] * magnitude
        h_e_out[3 + i] = 0.0
