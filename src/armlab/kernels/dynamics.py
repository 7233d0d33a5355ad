"""Compiled rigid-body dynamics in joint frames: RNEA, CRBA, g, C (Christoffel), forward dynamics.

Every kernel takes the robot's :class:`~armlab.model.robot.RobotArrays` ``m`` and a scratch
workspace ``ws`` from :func:`make_workspace` (``armlab.kernels.workspace``, re-exported here;
nothing is allocated inside a call), writes
into a caller-provided output and returns nothing (or the value named below).  All are
``@njit(cache=True)`` and can be called from other compiled code.  Every kernel writes the
scratch it reads, so a workspace can be reused by any sequence of calls; it must not be shared
by two threads at once.

Published API (n = number of joints; float64 arrays)::

    make_workspace(n) -> DynamicsWorkspace                       # Python or compiled
    workspace_size(n), workspace_from_buffer(buf, n)             # the same, over a caller's buffer
    rnea_into(m, ws, q, qd, qdd, gravity_scale, h_e, tau_out)    # τ of (D1), all terms (h_e: (6,)
                                                                 #   or None for free motion)
    mass_matrix_into(m, ws, q, B_out)                            # B(q), (n, n), CRBA (D2)
    gravity_into(m, ws, q, g_out)                                # g(q), (n,)
    bias_into(m, ws, q, qd, h_e, out)                            # C q̇ + F_v q̇ + F_s sgn q̇ + g + Jᵀh_e
    coriolis_matrix_into(m, ws, q, qd, C_out)                    # Christoffel C(q, q̇), (n, n) (D4)
    forward_dynamics_into(m, ws, q, qd, tau, h_e, qdd_out) -> ok # q̈ of (D1), Cholesky solve (D5);
                                                                 #   False if B is not positive definite

The Cholesky solve of (D5) is ``armlab.kernels.linalg.cholesky_solve_inplace``.

The potential energy (D7) is in ``armlab.kernels.energy`` (same arguments); the kinetic
energy (D6), ½ q̇ᵀ B q̇ with B q̇ from the RNEA, is ``armlab.kernels.plant.kinetic_energy_packed``.

``rnea_inline``, ``mass_matrix_inline`` and ``forward_dynamics_inline`` are the
implementations, inlined into their caller; the ``*_into`` kernels are each one of them behind
one call.  A call passes ``m`` and ``ws`` flattened, ~300 machine words, and under numba's
reference counting the callee counts its ~35 arrays in and out: ~0.25 µs, more than a 3-joint
RNEA.  Each inlined copy is compiled anew (the RNEA's takes ~3-5 s, once per machine), so
the kernels that run often inline them: ``armlab.kernels.plant.rnea_packed``, the one RNEA of
the plant and of ``armlab.inverse_dynamics``, and the CRBA of the plant's forward dynamics and
of ``armlab.inertia_matrix``; the task-space and adaptive laws call the ``*_into`` kernels.

Arguments: q, qd, qdd, tau (n,) [m | rad, /s, /s², N | N·m]; ``h_e`` (6,) = [f_e; μ_e], the
wrench the end effector exerts on the environment, in Σ_0, μ_e about the origin of Σ_e
[N, N·m]; ``gravity_scale`` multiplies g_0 (1.0 with gravity, 0.0 without).

The plant (Siciliano et al. §7.2–7.5; ``docs/notation.md``, section Dynamics):

    B(q) q̈ + C(q, q̇) q̇ + F_v q̇ + F_s sgn(q̇) + g(q) = τ − Jᵀ(q) h_e                     (D1)

Motor model (Siciliano §7.2, §7.5): the rotor of motor i sits on link i−1 (the base for
i = 1), turns about joint i's axis z_mi at k_ri q̇_i relative to link i−1 and has the axial
moment of inertia I_mi; its mass and transverse inertia belong to link i−1's inertial.  Its
kinetic energy is

    T_mi = ½ I_mi (z_miᵀ ω_{i−1} + k_ri q̇_i)²                                            (D3)

so it adds k_ri² I_mi to B_ii, k_ri I_mi z_miᵀ z_j to B_ij (j < i, revolute) and
I_mi z_mi z_miᵀ to link i−1's rotational inertia; in the RNEA it adds
I_mi (ṡ_i z_mi + s_i ω_{i−1} × z_mi) to the moment of link i−1 (s_i = z_miᵀ ω_{i−1} + k_ri q̇_i)
and k_ri I_mi ṡ_i to τ_i.  ``gear_ratio`` k_r is in rad/rad or rad/m.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.kernels.linalg import cholesky_solve_inplace
from armlab.kernels.workspace import DynamicsWorkspace as DynamicsWorkspace  # re-exported
from armlab.kernels.workspace import make_workspace as make_workspace
from armlab.kernels.workspace import workspace_from_buffer as workspace_from_buffer
from armlab.kernels.workspace import workspace_size as workspace_size
from armlab.model.robot import PRISMATIC, RobotArrays

# One fast-math liberty, "contract": a multiply followed by an add may become one fused
# multiply-add (one rounding instead of two, so never less accurate), which shortens the
# dependency chains of the recursions (a PRP CRBA 70 → 59 ns).  No reassociation, and NaN and
# infinities keep their meaning.  The last digit can differ from a machine without FMA.
# Code inlined into another function is compiled with that function's flags: compiled entries
# elsewhere (armlab.dynamics) that inline these kernels pass FASTMATH too.
FASTMATH = {"contract"}
kernel = njit(cache=True, fastmath=FASTMATH)
# Small helpers are inlined: a call passes m and ws flattened (~300 machine words).
small_kernel = njit(cache=True, inline="always", fastmath=FASTMATH)


@small_kernel
def local_transforms_into(m, q, R, p):
    """J_i in J_{i−1}: R[i] = X_R,i M_R(q_i), p[i] = X_p,i + M_p(q_i) (K1 in joint frames)."""
    n = q.shape[0]
    for i in range(n):
        value = q[i] + m.offset[i]
        X = m.tree_R[i]
        if m.joint_type[i] == PRISMATIC:
            for r in range(3):
                R[i, r, 0], R[i, r, 1], R[i, r, 2] = X[r, 0], X[r, 1], X[r, 2]
                p[i, r] = m.tree_p[i, r] + X[r, 2] * value
        else:
            c, s = np.cos(value), np.sin(value)
            for r in range(3):
                R[i, r, 0] = X[r, 0] * c + X[r, 1] * s
                R[i, r, 1] = X[r, 1] * c - X[r, 0] * s
                R[i, r, 2] = X[r, 2]
                p[i, r] = m.tree_p[i, r]


@small_kernel
def _has_wrench(h_e):
    for k in range(6):
        if h_e[k] != 0.0:
            return True
    return False


@small_kernel
def rnea_inline(m, ws, q, qd, qdd, gravity_scale, h_e, tau_out):
    """Inverse dynamics τ of (D1) with every term, by recursive Newton–Euler (Siciliano §7.5)
    in joint frames, inlined into its caller (see the module docstring):

        τ = B q̈ + C q̇ + F_v q̇ + F_s sgn q̇ + g_s + Jᵀ h_e ,  g_s = g(q) · gravity_scale   (D1)

    ``h_e`` (6,), or None for free motion: numba then compiles the wrench term away (an
    all-zero ``h_e`` skips it at run time).
    """
    local_transforms_into(m, q, ws.R, ws.p)
    n = q.shape[0]
    R, p, w, wd, a, f, mu = ws.R, ws.p, ws.w, ws.wd, ws.a, ws.f, ws.mu
    # Forward: velocities and accelerations; the base accelerates by −g_0 so gravity acts
    # on every link through its acceleration.
    for i in range(n):
        if i == 0:
            wpx = wpy = wpz = 0.0
            wdpx = wdpy = wdpz = 0.0
            tx = -gravity_scale * m.gravity[0]
            ty = -gravity_scale * m.gravity[1]
            tz = -gravity_scale * m.gravity[2]
        else:
            wpx, wpy, wpz = w[i - 1, 0], w[i - 1, 1], w[i - 1, 2]
            wdpx, wdpy, wdpz = wd[i - 1, 0], wd[i - 1, 1], wd[i - 1, 2]
            px, py, pz = p[i, 0], p[i, 1], p[i, 2]
            # ω × p
            cx = wpy * pz - wpz * py
            cy = wpz * px - wpx * pz
            cz = wpx * py - wpy * px
            tx = a[i - 1, 0] + wdpy * pz - wdpz * py + wpy * cz - wpz * cy
            ty = a[i - 1, 1] + wdpz * px - wdpx * pz + wpz * cx - wpx * cz
            tz = a[i - 1, 2] + wdpx * py - wdpy * px + wpx * cy - wpy * cx
        Ri = R[i]
        wx = Ri[0, 0] * wpx + Ri[1, 0] * wpy + Ri[2, 0] * wpz
        wy = Ri[0, 1] * wpx + Ri[1, 1] * wpy + Ri[2, 1] * wpz
        wz = Ri[0, 2] * wpx + Ri[1, 2] * wpy + Ri[2, 2] * wpz
        wdx = Ri[0, 0] * wdpx + Ri[1, 0] * wdpy + Ri[2, 0] * wdpz
        wdy = Ri[0, 1] * wdpx + Ri[1, 1] * wdpy + Ri[2, 1] * wdpz
        wdz = Ri[0, 2] * wdpx + Ri[1, 2] * wdpy + Ri[2, 2] * wdpz
        ax = Ri[0, 0] * tx + Ri[1, 0] * ty + Ri[2, 0] * tz
        ay = Ri[0, 1] * tx + Ri[1, 1] * ty + Ri[2, 1] * tz
        az = Ri[0, 2] * tx + Ri[1, 2] * ty + Ri[2, 2] * tz
        qdi, qddi = qd[i], qdd[i]
        if m.joint_type[i] == PRISMATIC:
            # a += q̈ z + 2 ω × q̇ z
            ax += 2.0 * wy * qdi
            ay -= 2.0 * wx * qdi
            az += qddi
        else:
            # ω̇ += q̈ z + ω_{i−1} × q̇ z ;  ω += q̇ z
            wdx += wy * qdi
            wdy -= wx * qdi
            wdz += qddi
            wz += qdi
        w[i, 0], w[i, 1], w[i, 2] = wx, wy, wz
        wd[i, 0], wd[i, 1], wd[i, 2] = wdx, wdy, wdz
        a[i, 0], a[i, 1], a[i, 2] = ax, ay, az
        # Link i alone: F = m a_C, μ_O = I_C ω̇ + ω × I_C ω + c × F.
        mass = m.mass[i]
        ccx, ccy, ccz = m.com[i, 0], m.com[i, 1], m.com[i, 2]
        ex = wy * ccz - wz * ccy
        ey = wz * ccx - wx * ccz
        ez = wx * ccy - wy * ccx
        acx = ax + wdy * ccz - wdz * ccy + wy * ez - wz * ey
        acy = ay + wdz * ccx - wdx * ccz + wz * ex - wx * ez
        acz = az + wdx * ccy - wdy * ccx + wx * ey - wy * ex
        Fx, Fy, Fz = mass * acx, mass * acy, mass * acz
        I = m.inertia[i]
        Iwx = I[0, 0] * wx + I[0, 1] * wy + I[0, 2] * wz
        Iwy = I[1, 0] * wx + I[1, 1] * wy + I[1, 2] * wz
        Iwz = I[2, 0] * wx + I[2, 1] * wy + I[2, 2] * wz
        f[i, 0], f[i, 1], f[i, 2] = Fx, Fy, Fz
        mu[i, 0] = (I[0, 0] * wdx + I[0, 1] * wdy + I[0, 2] * wdz + wy * Iwz - wz * Iwy
                    + ccy * Fz - ccz * Fy)
        mu[i, 1] = (I[1, 0] * wdx + I[1, 1] * wdy + I[1, 2] * wdz + wz * Iwx - wx * Iwz
                    + ccz * Fx - ccx * Fz)
        mu[i, 2] = (I[2, 0] * wdx + I[2, 1] * wdy + I[2, 2] * wdz + wx * Iwy - wy * Iwx
                    + ccx * Fy - ccy * Fx)
    # Rotor of motor 1 sits on the fixed base: only its spin k_r q̇_1 is inertial (D3).
    kr0 = m.gear_ratio[0]
    tau_out[0] = kr0 * kr0 * m.rotor_inertia[0] * qdd[0]
    for i in range(1, n):
        # Rotor i on link i−1, axis z_mi = z of J_i seen in J_{i−1} (D3).
        Im = m.rotor_inertia[i]
        kr = m.gear_ratio[i]
        if Im != 0.0:
            zx, zy, zz = m.tree_R[i, 0, 2], m.tree_R[i, 1, 2], m.tree_R[i, 2, 2]
            wpx, wpy, wpz = w[i - 1, 0], w[i - 1, 1], w[i - 1, 2]
            s = zx * wpx + zy * wpy + zz * wpz + kr * qd[i]
            sd = zx * wd[i - 1, 0] + zy * wd[i - 1, 1] + zz * wd[i - 1, 2] + kr * qdd[i]
            mu[i - 1, 0] += Im * (sd * zx + s * (wpy * zz - wpz * zy))
            mu[i - 1, 1] += Im * (sd * zy + s * (wpz * zx - wpx * zz))
            mu[i - 1, 2] += Im * (sd * zz + s * (wpx * zy - wpy * zx))
            tau_out[i] = kr * Im * sd
        else:
            tau_out[i] = 0.0
    if h_e is not None and _has_wrench(h_e):
        # The end effector pushes the environment with h_e: f_{n+1} = h_e, expressed in J_n.
        R0 = ws.R0
        for r in range(3):
            for c in range(3):
                R0[r, c] = R[0, r, c]
        for i in range(1, n):
            Ri = R[i]
            for r in range(3):
                b0, b1, b2 = R0[r, 0], R0[r, 1], R0[r, 2]
                R0[r, 0] = b0 * Ri[0, 0] + b1 * Ri[1, 0] + b2 * Ri[2, 0]
                R0[r, 1] = b0 * Ri[0, 1] + b1 * Ri[1, 1] + b2 * Ri[2, 1]
                R0[r, 2] = b0 * Ri[0, 2] + b1 * Ri[1, 2] + b2 * Ri[2, 2]
        fx = R0[0, 0] * h_e[0] + R0[1, 0] * h_e[1] + R0[2, 0] * h_e[2]
        fy = R0[0, 1] * h_e[0] + R0[1, 1] * h_e[1] + R0[2, 1] * h_e[2]
        fz = R0[0, 2] * h_e[0] + R0[1, 2] * h_e[1] + R0[2, 2] * h_e[2]
        mx = R0[0, 0] * h_e[3] + R0[1, 0] * h_e[4] + R0[2, 0] * h_e[5]
        my = R0[0, 1] * h_e[3] + R0[1, 1] * h_e[4] + R0[2, 1] * h_e[5]
        mz = R0[0, 2] * h_e[3] + R0[1, 2] * h_e[4] + R0[2, 2] * h_e[5]
        tpx, tpy, tpz = m.tool_p[0], m.tool_p[1], m.tool_p[2]
        k = n - 1
        f[k, 0] += fx
        f[k, 1] += fy
        f[k, 2] += fz
        mu[k, 0] += mx + tpy * fz - tpz * fy
        mu[k, 1] += my + tpz * fx - tpx * fz
        mu[k, 2] += mz + tpx * fy - tpy * fx
    # Backward: add the wrench of link i+1 (in J_i) and project on joint i's axis z.
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            Rc = R[i + 1]
            cfx, cfy, cfz = f[i + 1, 0], f[i + 1, 1], f[i + 1, 2]
            cmx, cmy, cmz = mu[i + 1, 0], mu[i + 1, 1], mu[i + 1, 2]
            gx = Rc[0, 0] * cfx + Rc[0, 1] * cfy + Rc[0, 2] * cfz
            gy = Rc[1, 0] * cfx + Rc[1, 1] * cfy + Rc[1, 2] * cfz
            gz = Rc[2, 0] * cfx + Rc[2, 1] * cfy + Rc[2, 2] * cfz
            px, py, pz = p[i + 1, 0], p[i + 1, 1], p[i + 1, 2]
            f[i, 0] += gx
            f[i, 1] += gy
            f[i, 2] += gz
            mu[i, 0] += Rc[0, 0] * cmx + Rc[0, 1] * cmy + Rc[0, 2] * cmz + py * gz - pz * gy
            mu[i, 1] += Rc[1, 0] * cmx + Rc[1, 1] * cmy + Rc[1, 2] * cmz + pz * gx - px * gz
            mu[i, 2] += Rc[2, 0] * cmx + Rc[2, 1] * cmy + Rc[2, 2] * cmz + px * gy - py * gx
        if m.joint_type[i] == PRISMATIC:
            tau_out[i] += f[i, 2]
        else:
            tau_out[i] += mu[i, 2]
        v = qd[i]
        tau_out[i] += m.viscous[i] * v
        coulomb = m.coulomb[i]
        if coulomb != 0.0:          # (a sign test only where there is Coulomb friction)
            if v > 0.0:
                tau_out[i] += coulomb
            elif v < 0.0:
                tau_out[i] -= coulomb


@kernel
def rnea_into(m, ws, q, qd, qdd, gravity_scale, h_e, tau_out):
    """:func:`rnea_inline` behind one call: τ of (D1), q, qd, qdd (n,); h_e (6,) in Σ_0;
    tau_out (n,) [N | N·m]."""
    rnea_inline(m, ws, q, qd, qdd, gravity_scale, h_e, tau_out)


@kernel
def gravity_into(m, ws, q, g_out):
    """Gravity torque g(q) = ∂U/∂q, (n,) [N | N·m] (RNEA with q̇ = q̈ = 0)."""
    rnea_inline(m, ws, q, ws.zero, ws.zero, 1.0, None, g_out)


@kernel
def bias_into(m, ws, q, qd, h_e, out):
    """Everything but inertia: C q̇ + F_v q̇ + F_s sgn q̇ + g + Jᵀ h_e, (n,) (RNEA with q̈ = 0)."""
    rnea_inline(m, ws, q, qd, ws.zero, 1.0, h_e, out)


@small_kernel
def crba_body(m, ws, n, B_out):
    """:func:`mass_matrix_into` on the transforms already in ``ws`` (inlined into callers)."""
    R, p, Ic, hc, mc = ws.R, ws.p, ws.Ic, ws.hc, ws.mc
    for i in range(n):
        mass = m.mass[i]
        cx, cy, cz = m.com[i, 0], m.com[i, 1], m.com[i, 2]
        mc[i] = mass
        hx, hy, hz = mass * cx, mass * cy, mass * cz
        hc[i, 0], hc[i, 1], hc[i, 2] = hx, hy, hz
        # Steiner to J_i's origin: I_O = I_C + m (cᵀc 1 − c cᵀ), symmetric (six entries).
        I, O = m.inertia[i], Ic[i]
        o00 = I[0, 0] + hy * cy + hz * cz
        o11 = I[1, 1] + hx * cx + hz * cz
        o22 = I[2, 2] + hx * cx + hy * cy
        o01 = I[0, 1] - hx * cy
        o02 = I[0, 2] - hx * cz
        o12 = I[1, 2] - hy * cz
        if i + 1 < n and m.rotor_inertia[i + 1] != 0.0:
            # Rotor i+1 turns with link i about its own axis too (D3).
            Im = m.rotor_inertia[i + 1]
            zx, zy, zz = m.tree_R[i + 1, 0, 2], m.tree_R[i + 1, 1, 2], m.tree_R[i + 1, 2, 2]
            o00 += Im * zx * zx
            o11 += Im * zy * zy
            o22 += Im * zz * zz
            o01 += Im * zx * zy
            o02 += Im * zx * zz
            o12 += Im * zy * zz
        O[0, 0], O[1, 1], O[2, 2] = o00, o11, o22
        O[0, 1], O[1, 0], O[0, 2], O[2, 0], O[1, 2], O[2, 1] = o01, o01, o02, o02, o12, o12
    for i in range(n - 1, 0, -1):
        # Composite i moved into J_{i−1}.  Every input is read into locals before any
        # output is written: Ic, R and p are views of one buffer, so the compiler must
        # otherwise reload the inputs after each store (that doubled this loop's time).
        Rc = R[i]
        r00, r01, r02 = Rc[0, 0], Rc[0, 1], Rc[0, 2]
        r10, r11, r12 = Rc[1, 0], Rc[1, 1], Rc[1, 2]
        r20, r21, r22 = Rc[2, 0], Rc[2, 1], Rc[2, 2]
        I = Ic[i]
        i00, i01, i02 = I[0, 0], I[0, 1], I[0, 2]
        i11, i12, i22 = I[1, 1], I[1, 2], I[2, 2]
        M = mc[i]
        px, py, pz = p[i, 0], p[i, 1], p[i, 2]
        h0, h1, h2 = hc[i, 0], hc[i, 1], hc[i, 2]
        # Rh
        hx = r00 * h0 + r01 * h1 + r02 * h2
        hy = r10 * h0 + r11 * h1 + r12 * h2
        hz = r20 * h0 + r21 * h1 + r22 * h2
        # T = R I, then the six entries of the symmetric T Rᵀ = R I Rᵀ.
        t00 = r00 * i00 + r01 * i01 + r02 * i02
        t01 = r00 * i01 + r01 * i11 + r02 * i12
        t02 = r00 * i02 + r01 * i12 + r02 * i22
        t10 = r10 * i00 + r11 * i01 + r12 * i02
        t11 = r10 * i01 + r11 * i11 + r12 * i12
        t12 = r10 * i02 + r11 * i12 + r12 * i22
        t20 = r20 * i00 + r21 * i01 + r22 * i02
        t21 = r20 * i01 + r21 * i11 + r22 * i12
        t22 = r20 * i02 + r21 * i12 + r22 * i22
        # −S(p)S(u) − S(u)S(p) = 2(pᵀu) 1 − p uᵀ − u pᵀ with u = Rh + M p/2 covers the M S(p)² term.
        ux, uy, uz = hx + 0.5 * M * px, hy + 0.5 * M * py, hz + 0.5 * M * pz
        pu2 = 2.0 * (px * ux + py * uy + pz * uz)
        s00 = t00 * r00 + t01 * r01 + t02 * r02 + pu2 - 2.0 * px * ux
        s11 = t10 * r10 + t11 * r11 + t12 * r12 + pu2 - 2.0 * py * uy
        s22 = t20 * r20 + t21 * r21 + t22 * r22 + pu2 - 2.0 * pz * uz
        s01 = t00 * r10 + t01 * r11 + t02 * r12 - (px * uy + ux * py)
        s02 = t00 * r20 + t01 * r21 + t02 * r22 - (px * uz + ux * pz)
        s12 = t10 * r20 + t11 * r21 + t12 * r22 - (py * uz + uy * pz)
        P = Ic[i - 1]
        P[0, 0] += s00
        P[1, 1] += s11
        P[2, 2] += s22
        P[0, 1] += s01
        P[1, 0] += s01
        P[0, 2] += s02
        P[2, 0] += s02
        P[1, 2] += s12
        P[2, 1] += s12
        hc[i - 1, 0] += hx + M * px
        hc[i - 1, 1] += hy + M * py
        hc[i - 1, 2] += hz + M * pz
        mc[i - 1] += M
    for i in range(n):
        # Spatial momentum (f, n about J_i's origin) of composite i moving with unit q̇_i.
        M = mc[i]
        hx, hy, hz = hc[i, 0], hc[i, 1], hc[i, 2]
        if m.joint_type[i] == PRISMATIC:
            fx, fy, fz = 0.0, 0.0, M
            nx, ny, nz = hy, -hx, 0.0
            B_out[i, i] = fz
        else:
            fx, fy, fz = -hy, hx, 0.0
            nx, ny, nz = Ic[i, 0, 2], Ic[i, 1, 2], Ic[i, 2, 2]
            B_out[i, i] = nz
        kr = m.gear_ratio[i]
        Im = m.rotor_inertia[i]
        B_out[i, i] += kr * kr * Im
        for j in range(i, 0, -1):
            Rc = R[j]
            gx = Rc[0, 0] * fx + Rc[0, 1] * fy + Rc[0, 2] * fz
            gy = Rc[1, 0] * fx + Rc[1, 1] * fy + Rc[1, 2] * fz
            gz = Rc[2, 0] * fx + Rc[2, 1] * fy + Rc[2, 2] * fz
            px, py, pz = p[j, 0], p[j, 1], p[j, 2]
            mx = Rc[0, 0] * nx + Rc[0, 1] * ny + Rc[0, 2] * nz + py * gz - pz * gy
            my = Rc[1, 0] * nx + Rc[1, 1] * ny + Rc[1, 2] * nz + pz * gx - px * gz
            mz = Rc[2, 0] * nx + Rc[2, 1] * ny + Rc[2, 2] * nz + px * gy - py * gx
            if j == i:
                # Rotor i (on link i−1) spins at k_r q̇_i about z_mi (D3).
                mx += kr * Im * m.tree_R[i, 0, 2]
                my += kr * Im * m.tree_R[i, 1, 2]
                mz += kr * Im * m.tree_R[i, 2, 2]
            fx, fy, fz, nx, ny, nz = gx, gy, gz, mx, my, mz
            value = fz if m.joint_type[j - 1] == PRISMATIC else nz
            B_out[j - 1, i] = value
            B_out[i, j - 1] = value


@small_kernel
def mass_matrix_inline(m, ws, q, B_out):
    """:func:`mass_matrix_into`, inlined into its caller."""
    local_transforms_into(m, q, ws.R, ws.p)
    crba_body(m, ws, q.shape[0], B_out)


@kernel
def mass_matrix_into(m, ws, q, B_out):
    """Joint-space inertia matrix B(q), (n, n), by the composite-rigid-body algorithm.

        B_ij = s_jᵀ Iᶜ_j s_i (j ≤ i), plus the rotor terms of (D3)                    (D2)

    Iᶜ_i is the inertia of links i…n (and their rotors) about J_i's origin, kept as mass,
    first moment h and rotational inertia: moving a body by (R, p) gives h' = R h + M p,
    I' = R I Rᵀ − S(p) S(Rh) − S(Rh) S(p) − M S(p)².
    """
    mass_matrix_inline(m, ws, q, B_out)


@small_kernel
def _frictionless(m, zero):
    """``m`` with F_v = F_s = 0 (``zero``: n zeros): the rigid body whose C (D4) is wanted."""
    return RobotArrays(m.joint_type, m.tree_R, m.tree_p, m.offset, m.tool_R, m.tool_p, m.base_R,
                       m.base_p, m.mass, m.com, m.inertia, m.gear_ratio, m.rotor_inertia, zero, zero,
                       m.q_min, m.q_max, m.gravity)


@kernel
def coriolis_matrix_into(m, ws, q, qd, C_out):
    """Christoffel-symbol C(q, q̇), (n, n), so that Ḃ − 2C is skew-symmetric.

        C_ij = Σ_k c_ijk q̇_k,  c_ijk = ½(∂B_ij/∂q_k + ∂B_ik/∂q_j − ∂B_jk/∂q_i)             (D4)

    With Γ(u, u) = C(q, u) u the velocity-quadratic RNEA term (no gravity, friction, q̈ or
    wrench), c_ijk = c_ikj makes Γ a symmetric bilinear form and C(q, q̇) e_j = Γ(e_j, q̇);
    polarisation gives it exactly: Γ(a, b) = ¼[Γ(a + b, a + b) − Γ(a − b, a − b)].  q̇ is
    normalised first so both arguments are of unit size (no cancellation).
    """
    n = q.shape[0]
    norm = 0.0
    for k in range(n):
        norm += qd[k] * qd[k]
    norm = np.sqrt(norm)
    if norm == 0.0:
        for r in range(n):
            for c in range(n):
                C_out[r, c] = 0.0
        return
    rigid = _frictionless(m, ws.zero)
    u, t1, t2 = ws.v1, ws.t1, ws.t2
    for j in range(n):
        # Γ(e_j + u, ·) into t1, then Γ(e_j − u, ·) into t2 (one inlined RNEA for both).
        for side in range(2):
            sign = 1.0 if side == 0 else -1.0
            for k in range(n):
                u[k] = sign * qd[k] / norm
            u[j] += 1.0
            rnea_inline(rigid, ws, q, u, ws.zero, 0.0, None, t1 if side == 0 else t2)
        for r in range(n):
            C_out[r, j] = 0.25 * norm * (t1[r] - t2[r])


@kernel
def forward_dynamics_into(m, ws, q, qd, tau, h_e, qdd_out):
    """Joint accelerations of (D1): B q̈ = τ − (C q̇ + F_v q̇ + F_s sgn q̇ + g + Jᵀ h_e).  (D5)

    B from the CRBA, then an in-place Cholesky solve in ``ws.L`` (no inverse, no allocation).
    Returns False (and leaves qdd_out undefined) if B is not positive definite.
    """
    return forward_dynamics_inline(m, ws, q, qd, tau, h_e, qdd_out)


@small_kernel
def forward_dynamics_inline(m, ws, q, qd, tau, h_e, qdd_out):
    """:func:`forward_dynamics_into`, inlined into its caller; the CRBA runs on the joint
    transforms the RNEA of the bias leaves in ``ws``."""
    n = q.shape[0]
    rnea_inline(m, ws, q, qd, ws.zero, 1.0, h_e, qdd_out)
    for k in range(n):
        qdd_out[k] = tau[k] - qdd_out[k]
    crba_body(m, ws, n, ws.L)
    return cholesky_solve_inplace(ws.L, qdd_out)
