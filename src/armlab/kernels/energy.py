"""Compiled potential energy of a robot (D7).

Used by ``armlab.potential_energy`` (and so by the joint stops' energy check), inlined into
its entry (it is small); it shares the joint-frame recursion conventions of
``armlab.kernels.dynamics`` (scratch space from its ``DynamicsWorkspace``).  The kinetic energy (D6) is
``armlab.kernels.plant.kinetic_energy_packed``: ½ q̇ᵀ B q̇ with B q̇ from the RNEA.
"""

from __future__ import annotations

from armlab.kernels.dynamics import local_transforms_into, small_kernel


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
