"""Inertia tensors of primitive shapes, Steiner's theorem and physical validity checks.

All tensors are (3, 3) in kg·m², expressed in the frame named by the caller.  A shape's own
frame has its origin at the centre of mass and, for a cylinder, its axis along z.
"""

from __future__ import annotations

import numpy as np


def box_inertia(mass: float, size) -> np.ndarray:
    """Solid cuboid with edge lengths ``size = (a, b, c)`` along the shape's x, y, z [m].

        I_C = m/12 · diag(b² + c², a² + c², a² + b²)
    """
    a, b, c = size
    return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])


def cylinder_inertia(mass: float, radius: float, length: float) -> np.ndarray:
    """Solid cylinder of ``radius`` and ``length`` with its axis along the shape's z [m].

        I_C = diag(m(3r² + h²)/12, m(3r² + h²)/12, m r²/2)
    """
    transverse = mass * (3.0 * radius * radius + length * length) / 12.0
    return np.diag([transverse, transverse, 0.5 * mass * radius * radius])


def sphere_inertia(mass: float, radius: float) -> np.ndarray:
    """Solid sphere: I_C = 2/5 m r² I₃."""
    return 0.4 * mass * radius * radius * np.eye(3)


def steiner(inertia_com: np.ndarray, mass: float, r) -> np.ndarray:
    """Inertia about a point displaced by ``r`` [m] from the centre of mass (parallel axes).

        I = I_C + m Sᵀ(r) S(r) = I_C + m (rᵀr I₃ − r rᵀ)
    """
    r = np.asarray(r, dtype=float)
    return np.asarray(inertia_com, dtype=float) + mass * (r @ r * np.eye(3) - np.outer(r, r))


def inertia_problem(inertia: np.ndarray, *, tol: float = 1e-12) -> str | None:
    """Why ``inertia`` cannot be a rigid body's tensor about its centre of mass, or None.

    A physical tensor is symmetric with principal moments λ ≥ 0 that satisfy the triangle
    inequalities λ_i + λ_j ≥ λ_k (the mass distribution has non-negative second moments).
    """
    inertia = np.asarray(inertia, dtype=float)
    if inertia.shape != (3, 3):
        return f"must be 3×3, got shape {inertia.shape}"
    if not np.all(np.isfinite(inertia)):
        return "has non-finite entries"
    scale = max(1.0, float(np.abs(inertia).max()))
    if not np.allclose(inertia, inertia.T, rtol=0.0, atol=tol * scale):
        return "is not symmetric"
    moments = np.linalg.eigvalsh(inertia)
    if moments.min() < -tol * scale:
        return f"is not positive semi-definite (principal moments {np.round(moments, 12).tolist()})"
    a, b, c = moments
    if a + b < c - tol * scale:
        return (
            "violates the triangle inequality of principal moments "
            f"({a:.6g} + {b:.6g} < {c:.6g})"
        )
    return None
