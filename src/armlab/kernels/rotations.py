"""Compiled XYZ Euler-angle kernels of the frame-relative task errors (``docs/notation.md``, T1).

R(φ) = Rx(φ₁) Ry(φ₂) Rz(φ₃); ω = T(φ) φ̇ with ω in the first frame, T(0) = I, det T = cos φ₂.
The general Euler conventions (ZYZ, RPY …) of the analytical Jacobian are in
:mod:`armlab.spatial`; these three-argument forms are what the task-space laws call per step.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def euler_xyz_from_matrix_into(R, out):
    """XYZ Euler angles (φ₁, φ₂, φ₃) of R = Rx(φ₁) Ry(φ₂) Rz(φ₃), φ₂ ∈ [−π/2, π/2] (T1)."""
    out[1] = np.arctan2(R[0, 2], np.sqrt(R[0, 0] * R[0, 0] + R[0, 1] * R[0, 1]))
    out[0] = np.arctan2(-R[1, 2], R[2, 2])
    out[2] = np.arctan2(-R[0, 1], R[0, 0])


@njit(cache=True)
def euler_xyz_matrix_into(phi1, phi2, phi3, R):
    """R = Rx(φ₁) Ry(φ₂) Rz(φ₃), (3, 3)."""
    c1, s1 = np.cos(phi1), np.sin(phi1)
    c2, s2 = np.cos(phi2), np.sin(phi2)
    c3, s3 = np.cos(phi3), np.sin(phi3)
    R[0, 0], R[0, 1], R[0, 2] = c2 * c3, -c2 * s3, s2
    R[1, 0] = c1 * s3 + s1 * s2 * c3
    R[1, 1] = c1 * c3 - s1 * s2 * s3
    R[1, 2] = -s1 * c2
    R[2, 0] = s1 * s3 - c1 * s2 * c3
    R[2, 1] = s1 * c3 + c1 * s2 * s3
    R[2, 2] = c1 * c2


@njit(cache=True)
def euler_xyz_rate_into(phi1, phi2, T):
    """T(φ) of the XYZ angles, ω = T(φ) φ̇ (ω in the first frame), (3, 3); det T = cos φ₂.

        T = [[1, 0, s₂], [0, c₁, −s₁ c₂], [0, s₁, c₁ c₂]]
    """
    c1, s1, c2, s2 = np.cos(phi1), np.sin(phi1), np.cos(phi2), np.sin(phi2)
    T[0, 0], T[0, 1], T[0, 2] = 1.0, 0.0, s2
    T[1, 0], T[1, 1], T[1, 2] = 0.0, c1, -s1 * c2
    T[2, 0], T[2, 1], T[2, 2] = 0.0, s1, c1 * c2


@njit(cache=True)
def euler_xyz_rate_inverse_into(phi1, phi2, T_inv):
    """T⁻¹(φ) of the XYZ angles, (3, 3); singular (inf) at cos φ₂ = 0.

        T⁻¹ = [[1, s₁ s₂ / c₂, −c₁ s₂ / c₂], [0, c₁, s₁], [0, −s₁ / c₂, c₁ / c₂]]
    """
    c1, s1, c2, s2 = np.cos(phi1), np.sin(phi1), np.cos(phi2), np.sin(phi2)
    T_inv[0, 0], T_inv[0, 1], T_inv[0, 2] = 1.0, s1 * s2 / c2, -c1 * s2 / c2
    T_inv[1, 0], T_inv[1, 1], T_inv[1, 2] = 0.0, c1, s1
    T_inv[2, 0], T_inv[2, 1], T_inv[2, 2] = 0.0, -s1 / c2, c1 / c2


@njit(cache=True)
def euler_xyz_rate_dot_into(phi1, phi2, dphi1, dphi2, T_dot):
    """Ṫ(φ, φ̇) of the XYZ angles, (3, 3)."""
    c1, s1, c2, s2 = np.cos(phi1), np.sin(phi1), np.cos(phi2), np.sin(phi2)
    T_dot[0, 0], T_dot[0, 1], T_dot[0, 2] = 0.0, 0.0, c2 * dphi2
    T_dot[1, 0], T_dot[1, 1], T_dot[1, 2] = 0.0, -s1 * dphi1, -c1 * c2 * dphi1 + s1 * s2 * dphi2
    T_dot[2, 0], T_dot[2, 1], T_dot[2, 2] = 0.0, c1 * dphi1, -s1 * c2 * dphi1 - c1 * s2 * dphi2
