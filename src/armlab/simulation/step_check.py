"""Before an RK4 run: is the step small enough for the closed loop's fastest mode at q0?

A PD gain on a light joint (a wrist of 10⁻⁴ kg·m² under K_P = 25 N·m/rad) makes a mode of
|λ| = 500–20 000 1/s; RK4 at 1 ms then diverges within milliseconds and reports it as a joint
beyond its limits.  The joint-space laws linearised at rest at q0 are

    B(q0) δq̈ + (F_v + D) δq̇ + K δq = 0                                                     (S6)

with (K, D) from the law's gains and its model (B̂, and F̂_v, the viscous friction it
cancels): joint PD (C1) K = K_P, D = K_D; computed torque (C2) K = B̂(q0) K_P,
D = B̂(q0) K_D − F̂_v; Slotine–Li (C4) K = (K_D + F̂_v) Λ, D = K_D + B̂(q0) Λ.  Left out: ∂g/∂q
(compensated, or small against K_P by the gain rules), C q̇ (zero at rest), Coulomb friction
(no linear mode), torque saturation.  The modes are the eigenvalues λ of
[[0, I], [−B⁻¹K, −B⁻¹(F_v + D)]]; RK4 is stable for a step h when every λh lies in its region
|1 + z + z²/2 + z³/6 + z⁴/24| ≤ 1 (to 2.785 on the negative real axis, 2.83 on the imaginary).
:func:`check_step` warns (:class:`StepSizeWarning`) when ``dt`` exceeds the largest such h.
Other laws (task space, interaction, Python laws) are not estimated.
"""

from __future__ import annotations

import warnings

import numpy as np

MARGIN = 1.0
"""``dt`` may be this share of the largest stable step before :func:`check_step` warns."""


class StepSizeWarning(UserWarning):
    """An RK4 step larger than the closed loop's fastest mode allows (S6)."""


def inertia_at(robot, q: np.ndarray, kinetic_energy=None) -> np.ndarray:
    """B(q) (n × n) from the kinetic energy T(q, q̇) = ½ q̇ᵀ B(q) q̇ (D6) by polarisation:
    B_ii = 2 T(q, e_i), B_ij = T(q, e_i + e_j) − T(q, e_i) − T(q, e_j).

    With ``kinetic_energy`` (default: the general ``kinetic_energy_packed``), the kernel the
    loop calls for its energy check anyway, the step check compiles nothing of its own (the
    mass matrix's kernel, compiled for it alone, took ~3 s of a first A7 result with empty
    caches).  A robot-specialised kernel (``armlab.specialise``) holds its robot's numbers
    and ignores ``robot.packed``: pass one only with the robot it was made for."""
    from armlab.kernels.plant import kinetic_energy_packed, make_data

    energy = kinetic_energy_packed if kinetic_energy is None else kinetic_energy
    n, model, data = robot.n, robot.packed, make_data(robot.n)
    q, unit = np.ascontiguousarray(q, dtype=float), np.eye(n)
    half = [energy(model, data, q, unit[i]) for i in range(n)]
    B = np.diag(2.0 * np.array(half))
    for i in range(n):
        for j in range(i + 1, n):
            B[i, j] = B[j, i] = energy(model, data, q, unit[i] + unit[j]) - half[i] - half[j]
    return B


def loop_gains(controller, q0: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(K, D) (n × n) of (S6) for the joint-space laws, None for any other law."""
    from armlab.control.adaptive import SlotineLi
    from armlab.control.joint_space import JointInverseDynamics, JointPDGravity

    if type(controller) is JointPDGravity:
        return np.asarray(controller.kp, float), np.asarray(controller.kd, float)
    if type(controller) is JointInverseDynamics:
        B_hat = inertia_at(controller.model, q0)
        bias = controller.bias_model if controller.bias_model is not None else controller.model
        cancelled = np.diag(np.asarray(bias.arrays.viscous, dtype=float))   # F̂_v q̇ of n̂
        return (B_hat @ np.asarray(controller.kp, float),
                B_hat @ np.asarray(controller.kd, float) - cancelled)
    if type(controller) is SlotineLi:
        B_hat = inertia_at(controller.model, q0)
        kd, lam = np.asarray(controller.kd, float), np.asarray(controller.lam, float)
        viscous = np.diag(np.asarray(controller.model.arrays.viscous, dtype=float))  # F̂_v q̇_r of Ŷπ̂(0)
        return (kd + viscous) @ lam, kd + B_hat @ lam
    return None


def system_matrix(plant, K: np.ndarray, D: np.ndarray, q0: np.ndarray, kinetic_energy=None) -> np.ndarray:
    """A = [[0, I], [−B⁻¹K, −B⁻¹(F_v + D)]] (2n × 2n) of (S6) at q0; ``kinetic_energy`` the
    plant's kernel (:func:`inertia_at`)."""
    n = plant.n
    B = inertia_at(plant, q0, kinetic_energy)
    viscous = np.diag(np.asarray(plant.arrays.viscous, dtype=float))
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:] = -np.linalg.solve(B, np.hstack((K, viscous + D)))
    return A


def _rk4_growth(z: np.ndarray) -> np.ndarray:
    return np.abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)


def rk4_largest_step(eigenvalues: np.ndarray) -> float:
    """The largest h [s] with every λh (Re λ ≤ 0) inside RK4's stability region, found along
    each ray λh, h > 0 (a scan of |λ|h to 3, then bisection); inf when no mode limits it.
    A mode with Re λ > 0 is unstable in itself, the loop's fault and not the step's: skipped."""
    lam = np.asarray(eigenvalues, dtype=complex)
    size = np.abs(lam)
    keep = (size > 0) & (lam.real <= 1e-9 * size)
    if not keep.any():
        return np.inf
    lam, size = lam[keep], size[keep]
    direction = (lam / size)[:, None]
    reach = np.linspace(1e-3, 3.0, 3000)[None, :]
    outside = _rk4_growth(reach * direction) > 1 + 1e-12
    limited = outside.any(axis=1)
    if not limited.any():
        return np.inf
    first = np.argmax(outside[limited], axis=1)
    hi = reach[0, first]
    lo = np.where(first > 0, reach[0, np.maximum(first - 1, 0)], 0.0)
    direction = direction[limited, 0]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        inside = _rk4_growth(mid * direction) <= 1 + 1e-12
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    return float(np.min(lo / size[limited]))


def check_step(plant, controller, q0, dt: float, stacklevel: int = 2,
               kinetic_energy=None) -> float | None:
    """Warn when ``dt`` exceeds the largest stable RK4 step of (S6) at ``q0``; returns that
    step [s] (None for a law not estimated here, or when |λ| dt ≤ 1 for every mode).
    ``kinetic_energy``: the plant's own kernel, as the loop runs it (:func:`inertia_at`); the
    controller's model, which may differ from the plant, always takes the general one."""
    q0 = np.asarray(q0, dtype=float)
    gains = loop_gains(controller, q0)
    if gains is None:
        return None
    A = system_matrix(plant, *gains, q0, kinetic_energy)
    # Every |λ| is at most the largest row sum of |A| (its ∞-norm): most runs end here without
    # the eigenvalues (35 µs of a PRP's 0.4 ms set-up), with the answer they would give.
    if np.abs(A).sum(axis=1).max() * dt <= 1.0:
        return None
    eigenvalues = np.linalg.eigvals(A)
    if np.abs(eigenvalues).max() * dt <= 1.0:
        return None  # inside the half-disc |λh| ≤ 1 of Re ≤ 0, which RK4's region holds
    largest = rk4_largest_step(eigenvalues)
    if dt > MARGIN * largest:
        fastest = float(np.abs(eigenvalues).max())
        warnings.warn(f"dt = {dt:g} s is too large for the closed loop's fastest mode at q0 (|λ| = "
                      f"{fastest:.4g} 1/s, from the gains and B(q0)): RK4 is stable only for dt ≤ "
                      f"{largest:.3g} s, and the run will likely diverge", StepSizeWarning,
                      stacklevel=stacklevel)
    return largest
