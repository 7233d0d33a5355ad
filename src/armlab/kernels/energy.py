"""Compiled kinetic and potential energy of a robot, rotors included (D6, D7).

Used by the energy-conservation checks of the simulator and by ``armlab.kinetic_energy`` /
``armlab.potential_energy``, inlined into those entries (they are small); they share the
joint-frame recursion conventions of ``armlab.kernels.dynamics`` (scratch space from its
``DynamicsWorkspace``).
"""

from __future__ import annotations

from armlab.kernels.dynamics import local_transforms_into, small_kernel
from armlab.model.robot import PRISMATIC


@small_kernel
def kinetic_energy_kernel(m, ws, q, qd):
    """Kinetic energy [J] summed body by body, rotors included (D3, D6):

        T = Σ_i ½ m_i ‖ṗ_Ci‖² + ½ ω_iᵀ I_Ci ω_i + ½ I_mi (z_miᵀ ω_{i−1} + k_ri q̇_i)²       (D6)
    """
    n = q.shape[0]
    R, p, w, v = ws.R, ws.p, ws.w, ws.a
    local_transforms_into(m, q, R, p)
    energy = 0.0
    for i in range(n):
        if i == 0:
            wpx = wpy = wpz = 0.0
            tx = ty = tz = 0.0
        else:
            wpx, wpy, wpz = w[i - 1, 0], w[i - 1, 1], w[i - 1, 2]
            px, py, pz = p[i, 0], p[i, 1], p[i, 2]
            tx = v[i - 1, 0] + wpy * pz - wpz * py
            ty = v[i - 1, 1] + wpz * px - wpx * pz
            tz = v[i - 1, 2] + wpx * py - wpy * px
        kr = m.gear_ratio[i]
        zx, zy, zz = m.tree_R[i, 0, 2], m.tree_R[i, 1, 2], m.tree_R[i, 2, 2]
        s = zx * wpx + zy * wpy + zz * wpz + kr * qd[i]
        energy += 0.5 * m.rotor_inertia[i] * s * s
        Ri = R[i]
        wx = Ri[0, 0] * wpx + Ri[1, 0] * wpy + Ri[2, 0] * wpz
        wy = Ri[0, 1] * wpx + Ri[1, 1] * wpy + Ri[2, 1] * wpz
        wz = Ri[0, 2] * wpx + Ri[1, 2] * wpy + Ri[2, 2] * wpz
        vx = Ri[0, 0] * tx + Ri[1, 0] * ty + Ri[2, 0] * tz
        vy = Ri[0, 1] * tx + Ri[1, 1] * ty + Ri[2, 1] * tz
        vz = Ri[0, 2] * tx + Ri[1, 2] * ty + Ri[2, 2] * tz
        if m.joint_type[i] == PRISMATIC:
            vz += qd[i]
        else:
            wz += qd[i]
        w[i, 0], w[i, 1], w[i, 2] = wx, wy, wz
        v[i, 0], v[i, 1], v[i, 2] = vx, vy, vz
        cx, cy, cz = m.com[i, 0], m.com[i, 1], m.com[i, 2]
        ux = vx + wy * cz - wz * cy
        uy = vy + wz * cx - wx * cz
        uz = vz + wx * cy - wy * cx
        I = m.inertia[i]
        rot = (wx * (I[0, 0] * wx + I[0, 1] * wy + I[0, 2] * wz)
               + wy * (I[1, 0] * wx + I[1, 1] * wy + I[1, 2] * wz)
               + wz * (I[2, 0] * wx + I[2, 1] * wy + I[2, 2] * wz))
        energy += 0.5 * m.mass[i] * (ux * ux + uy * uy + uz * uz) + 0.5 * rot
    return energy


@small_kernel
def potential_energy_kernel(m, ws, q):
    """Gravitational potential energy [J], zero at Σ_0's origin:

        U = −Σ_i m_i g_0ᵀ p_Ci      (p_Ci, g_0 in Σ_0)                                   (D7)
    """
    n = q.shape[0]
    R, p, A = ws.R, ws.p, ws.R0
    local_transforms_into(m, q, R, p)
    for r in range(3):
        for c in range(3):
            A[r, c] = 1.0 if r == c else 0.0
    ox = oy = oz = 0.0
    energy = 0.0
    g = m.gravity
    for i in range(n):
        Ri = R[i]
        px, py, pz = p[i, 0], p[i, 1], p[i, 2]
        ox, oy, oz = (ox + A[0, 0] * px + A[0, 1] * py + A[0, 2] * pz,
                      oy + A[1, 0] * px + A[1, 1] * py + A[1, 2] * pz,
                      oz + A[2, 0] * px + A[2, 1] * py + A[2, 2] * pz)
        for r in range(3):
            b0, b1, b2 = A[r, 0], A[r, 1], A[r, 2]
            A[r, 0] = b0 * Ri[0, 0] + b1 * Ri[1, 0] + b2 * Ri[2, 0]
            A[r, 1] = b0 * Ri[0, 1] + b1 * Ri[1, 1] + b2 * Ri[2, 1]
            A[r, 2] = b0 * Ri[0, 2] + b1 * Ri[1, 2] + b2 * Ri[2, 2]
        cx, cy, cz = m.com[i, 0], m.com[i, 1], m.com[i, 2]
        gx = ox + A[0, 0] * cx + A[0, 1] * cy + A[0, 2] * cz
        gy = oy + A[1, 0] * cx + A[1, 1] * cy + A[1, 2] * cz
        gz = oz + A[2, 0] * cx + A[2, 1] * cy + A[2, 2] * cz
        energy -= m.mass[i] * (g[0] * gx + g[1] * gy + g[2] * gz)
    return energy
