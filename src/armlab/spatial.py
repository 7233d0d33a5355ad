"""Rotations, homogeneous transforms, skew matrices and Euler angles.

Conventions are those of ``docs/notation.md``: a rotation ``R_ab`` maps coordinates in
frame b to coordinates in frame a, ``T_ab = [[R_ab, p_ab], [0, 1]]``; angles in radians,
lengths in metres.  Euler angles are *intrinsic* (moving-axes) sequences:

* ``"zyz"``: R = Rz(φ) Ry(ϑ) Rz(ψ)  (Siciliano et al. §2.4.1), singular where sin ϑ = 0;
* ``"rpy"``: R = Rz(φ) Ry(ϑ) Rx(ψ)  (roll ψ about x, pitch ϑ about y, yaw φ about z,
  Siciliano et al. §2.4.2), singular where cos ϑ = 0.

The angle triple is always ordered ``(φ, ϑ, ψ)`` as the factors appear in the product.
"""

from __future__ import annotations

import numpy as np

EULER_CONVENTIONS = ("zyz", "rpy")


def rot_x(angle: float) -> np.ndarray:
    """Elementary rotation about x, (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle: float) -> np.ndarray:
    """Elementary rotation about y, (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle: float) -> np.ndarray:
    """Elementary rotation about z, (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def transform(rotation: np.ndarray | None = None, translation=None) -> np.ndarray:
    """Homogeneous transform (4, 4) from a rotation (3, 3) and a translation (3,) [m]."""
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    if translation is not None:
        T[:3, 3] = translation
    return T


def trans_x(d: float) -> np.ndarray:
    return transform(translation=(d, 0.0, 0.0))


def trans_z(d: float) -> np.ndarray:
    return transform(translation=(0.0, 0.0, d))


def hom_rot_x(angle: float) -> np.ndarray:
    return transform(rot_x(angle))


def hom_rot_z(angle: float) -> np.ndarray:
    return transform(rot_z(angle))


def inverse_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of a homogeneous transform: [[Rᵀ, −Rᵀp], [0, 1]]."""
    R, p = T[:3, :3], T[:3, 3]
    return transform(R.T, -R.T @ p)


def skew(v) -> np.ndarray:
    """S(v) with S(v) w = v × w, (3, 3)."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rpy_matrix(rpy) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    roll, pitch, yaw = rpy
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


def rpy_from_matrix(R: np.ndarray) -> np.ndarray:
    """URDF (roll, pitch, yaw) of R = Rz(yaw) Ry(pitch) Rx(roll); pitch in [−π/2, π/2]."""
    phi, theta, psi = euler_from_matrix(R, "rpy")
    return np.array([psi, theta, phi])


def rotation_to_axis(axis) -> np.ndarray:
    """A rotation whose third column is the unit vector ``axis`` (3,)."""
    z = np.asarray(axis, dtype=float)
    z = z / np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack((x, y, z))


def _check_convention(convention: str) -> str:
    if convention not in EULER_CONVENTIONS:
        raise ValueError(f"unknown Euler convention {convention!r}; use one of {EULER_CONVENTIONS}")
    return convention


def euler_matrix(angles, convention: str = "zyz") -> np.ndarray:
    """R(φ, ϑ, ψ) for the intrinsic sequence ``convention`` (see module docstring)."""
    phi, theta, psi = angles
    if _check_convention(convention) == "zyz":
        return rot_z(phi) @ rot_y(theta) @ rot_z(psi)
    return rot_z(phi) @ rot_y(theta) @ rot_x(psi)


def euler_from_matrix(R: np.ndarray, convention: str = "zyz", *, branch: int = 1) -> np.ndarray:
    """Euler angles (φ, ϑ, ψ) of R.

    ``branch=+1`` picks ϑ ∈ [0, π] for ZYZ and ϑ ∈ [−π/2, π/2] for RPY; ``branch=−1`` the
    other solution (ϑ ∈ [−π, 0] for ZYZ, |ϑ| ≥ π/2 for RPY).  At a representation
    singularity φ + ψ (ZYZ) or φ − ψ (RPY) is defined only; ψ = 0 is returned then.
    """
    R = np.asarray(R, dtype=float)
    if branch not in (1, -1):
        raise ValueError("branch must be +1 or -1")
    if _check_convention(convention) == "zyz":
        s_theta = branch * np.hypot(R[0, 2], R[1, 2])
        theta = np.arctan2(s_theta, R[2, 2])
        if abs(s_theta) < 1e-12:
            # ϑ = 0 or π: only the sum (or difference) of φ and ψ is observable.
            phi = np.arctan2(R[1, 0], R[0, 0]) if R[2, 2] > 0 else np.arctan2(-R[1, 0], -R[0, 0])
            return np.array([phi, theta, 0.0])
        phi = np.arctan2(branch * R[1, 2], branch * R[0, 2])
        psi = np.arctan2(branch * R[2, 1], -branch * R[2, 0])
        return np.array([phi, theta, psi])
    c_theta = branch * np.hypot(R[0, 0], R[1, 0])
    theta = np.arctan2(-R[2, 0], c_theta)
    if abs(c_theta) < 1e-12:
        phi = np.arctan2(-R[0, 1], R[1, 1])
        return np.array([phi, theta, 0.0])
    phi = np.arctan2(branch * R[1, 0], branch * R[0, 0])
    psi = np.arctan2(branch * R[2, 1], branch * R[2, 2])
    return np.array([phi, theta, psi])


def euler_rate_matrix(angles, convention: str = "zyz") -> np.ndarray:
    """T(φ) with ω = T(φ) φ̇, (3, 3); ω and φ̇ in the fixed frame (Siciliano (3.64)).

    ZYZ: T = [[0, −sφ, cφ sϑ], [0, cφ, sφ sϑ], [1, 0, cϑ]], det T = −sin ϑ.
    RPY: T = [[0, −sφ, cφ cϑ], [0, cφ, sφ cϑ], [1, 0, −sϑ]], det T = −cos ϑ.
    """
    phi, theta, _ = angles
    cf, sf, ct, st = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta)
    if _check_convention(convention) == "zyz":
        return np.array([[0.0, -sf, cf * st], [0.0, cf, sf * st], [1.0, 0.0, ct]])
    return np.array([[0.0, -sf, cf * ct], [0.0, cf, sf * ct], [1.0, 0.0, -st]])


def analytic_transform(angles, convention: str = "zyz") -> np.ndarray:
    """T_A(φ) = blockdiag(I₃, T(φ)), (6, 6), with v = T_A(φ) ẋ for x = [p; φ]."""
    T_A = np.eye(6)
    T_A[3:, 3:] = euler_rate_matrix(angles, convention)
    return T_A
