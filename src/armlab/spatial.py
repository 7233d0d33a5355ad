"""Rotations, homogeneous transforms, skew matrices, Euler angles and their rate matrices.

Conventions are those of ``docs/notation.md``: a rotation ``R_ab`` maps coordinates in
frame b to coordinates in frame a, ``T_ab = [[R_ab, p_ab], [0, 1]]``; angles in radians,
lengths in metres.  Euler angles are *intrinsic* (moving-axes) sequences:

* ``"zyz"``: R = Rz(φ) Ry(ϑ) Rz(ψ)  (Siciliano et al. §2.4.1), singular where sin ϑ = 0;
* ``"rpy"``: R = Rz(φ) Ry(ϑ) Rx(ψ)  (roll ψ about x, pitch ϑ about y, yaw φ about z,
  Siciliano et al. §2.4.2), singular where cos ϑ = 0.

The angle triple is always ordered ``(φ, ϑ, ψ)`` as the factors appear in the product.

The compiled functions (``*_into`` and the scalar-returning ``euler_rates_from_omega`` /
``euler_rate_dot_times``) take their outputs as arguments, allocate nothing and can be called
from other ``numba`` code; the convention is passed there as an integer (``ZYZ`` or ``RPY``).
The plain functions below wrap them for Python callers.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.errors import RepresentationSingularityError

EULER_CONVENTIONS = ("zyz", "rpy")
ZYZ, RPY = 0, 1
EULER_CODES = {"zyz": ZYZ, "rpy": RPY}
# |sin ϑ| (ZYZ) or |cos ϑ| (RPY) below this: the angles are at a representation singularity.
EULER_SINGULAR_EPS = 1e-12

# Division by zero gives inf/nan instead of raising.
compiled = njit(cache=True, error_model="numpy")


def checked_rotation(R, name: str, error=ValueError) -> np.ndarray:
    """``R`` as a (3, 3) float array if it is a rotation matrix (RᵀR = I to 1e-6, det R > 0),
    else ``error`` naming ``name`` (each caller passes its own error class)."""
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise error(f"{name}: must be a finite (3, 3) rotation matrix")
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0.0:
        raise error(f"{name}: not a rotation matrix (RᵀR ≠ I or det R < 0)")
    return R


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
    """Pure translation by d [m] along x, (4, 4)."""
    return transform(translation=(d, 0.0, 0.0))


def trans_z(d: float) -> np.ndarray:
    """Pure translation by d [m] along z, (4, 4)."""
    return transform(translation=(0.0, 0.0, d))


def hom_rot_x(angle: float) -> np.ndarray:
    """Pure rotation about x as a homogeneous transform, (4, 4)."""
    return transform(rot_x(angle))


def hom_rot_z(angle: float) -> np.ndarray:
    """Pure rotation about z as a homogeneous transform, (4, 4)."""
    return transform(rot_z(angle))


def inverse_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of a homogeneous transform: T_ba = T_ab⁻¹ = [[Rᵀ, −Rᵀp], [0, 1]]."""
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


# ---------------------------------------------------------------- compiled Euler-angle functions


@compiled
def _wrap_near(angle, reference):
    """angle + 2πk closest to ``reference``."""
    two_pi = 2.0 * np.pi
    return angle + two_pi * np.round((reference - angle) / two_pi)


@compiled
def _euler_branch(R, convention, branch, out):
    """Angles of one branch into ``out``; returns the observable combination type at a
    singularity (+1: φ + ψ, −1: φ − ψ) or 0 when regular.  ψ = 0 at a singularity."""
    if convention == ZYZ:
        s_theta = branch * np.hypot(R[0, 2], R[1, 2])
        out[1] = np.arctan2(s_theta, R[2, 2])
        if abs(s_theta) < EULER_SINGULAR_EPS:
            # ϑ = 0: R = Rz(φ + ψ);  ϑ = π: R = Rz(φ − ψ) Ry(π).
            if R[2, 2] > 0.0:
                out[0] = np.arctan2(R[1, 0], R[0, 0])
                out[2] = 0.0
                return 1
            out[0] = np.arctan2(-R[1, 0], -R[0, 0])
            out[2] = 0.0
            return -1
        out[0] = np.arctan2(branch * R[1, 2], branch * R[0, 2])
        out[2] = np.arctan2(branch * R[2, 1], -branch * R[2, 0])
        return 0
    c_theta = branch * np.hypot(R[0, 0], R[1, 0])
    out[1] = np.arctan2(-R[2, 0], c_theta)
    if abs(c_theta) < EULER_SINGULAR_EPS:
        # ϑ = +π/2: R depends on ψ − φ only;  ϑ = −π/2: on φ + ψ only.
        out[0] = np.arctan2(-R[0, 1], R[1, 1])
        out[2] = 0.0
        return -1 if -R[2, 0] > 0.0 else 1
    out[0] = np.arctan2(branch * R[1, 0], branch * R[0, 0])
    out[2] = np.arctan2(branch * R[2, 1], branch * R[2, 2])
    return 0


@compiled
def euler_angles_into(R, convention, branch, reference, out):
    """Euler angles (φ, ϑ, ψ) [rad] of the rotation R (3, 3) into ``out`` (3,).

    ``branch`` = +1 picks ϑ ∈ [0, π] (ZYZ) or ϑ ∈ [−π/2, π/2] (RPY), −1 the other solution
    (ϑ ∈ [−π, 0], resp. |ϑ| ≥ π/2), both with φ, ψ ∈ (−π, π].  ``branch`` = 0 returns,
    among both branches and all 2π shifts, the triple nearest to ``reference`` (3,) — for
    continuity along a trajectory; at a singularity it splits the observable φ ± ψ evenly
    about the reference.  Otherwise ``reference`` is ignored and ψ = 0 at a singularity.
    """
    if branch != 0:
        _euler_branch(R, convention, branch, out)
        return
    best = np.inf
    f0 = f1 = f2 = 0.0
    for b in (1, -1):
        kind = _euler_branch(R, convention, b, out)
        theta = _wrap_near(out[1], reference[1])
        if kind == 0:
            phi = _wrap_near(out[0], reference[0])
            psi = _wrap_near(out[2], reference[2])
        else:
            gamma = out[0]  # the observable φ + kind·ψ
            delta = _wrap_near(gamma - (reference[0] + kind * reference[2]), 0.0)
            phi = reference[0] + 0.5 * delta
            psi = reference[2] + kind * 0.5 * delta
        dist = (phi - reference[0]) ** 2 + (theta - reference[1]) ** 2 + (psi - reference[2]) ** 2
        if dist < best:
            best = dist
            f0, f1, f2 = phi, theta, psi
    out[0], out[1], out[2] = f0, f1, f2


@compiled
def euler_rate_matrix_into(angles, convention, out):
    """T(φ) (3, 3) into ``out`` with ω = T(φ) φ̇ (K9); returns det T (−sin ϑ | −cos ϑ).

    ZYZ: T = [[0, −sφ, cφ sϑ], [0, cφ, sφ sϑ], [1, 0, cϑ]]
    RPY: T = [[0, −sφ, cφ cϑ], [0, cφ, sφ cϑ], [1, 0, −sϑ]]
    """
    cf, sf = np.cos(angles[0]), np.sin(angles[0])
    ct, st = np.cos(angles[1]), np.sin(angles[1])
    k, last = (st, ct) if convention == ZYZ else (ct, -st)
    out[0, 0], out[0, 1], out[0, 2] = 0.0, -sf, cf * k
    out[1, 0], out[1, 1], out[1, 2] = 0.0, cf, sf * k
    out[2, 0], out[2, 1], out[2, 2] = 1.0, 0.0, last
    return -k


@compiled
def euler_rates_from_omega(angles, convention, wx, wy, wz):
    """φ̇ = T(φ)⁻¹ ω (K10) as a scalar triple; ω [rad/s] in the frame of R.

    ZYZ: ψ̇ = (cφ ωx + sφ ωy)/sϑ,  ϑ̇ = −sφ ωx + cφ ωy,  φ̇ = ωz − cϑ ψ̇
    RPY: ψ̇ = (cφ ωx + sφ ωy)/cϑ,  ϑ̇ = −sφ ωx + cφ ωy,  φ̇ = ωz + sϑ ψ̇
    Division by zero at the singularity gives inf/nan: callers check det T first.
    """
    cf, sf = np.cos(angles[0]), np.sin(angles[0])
    ct, st = np.cos(angles[1]), np.sin(angles[1])
    radial = cf * wx + sf * wy
    theta_dot = -sf * wx + cf * wy
    if convention == ZYZ:
        psi_dot = radial / st
        return wz - ct * psi_dot, theta_dot, psi_dot
    psi_dot = radial / ct
    return wz + st * psi_dot, theta_dot, psi_dot


@compiled
def euler_rate_inverse_into(angles, convention, out):
    """T(φ)⁻¹ (3, 3) into ``out`` (K10); returns det T.  Rows are inf/nan where det T = 0."""
    for c in range(3):
        e0 = 1.0 if c == 0 else 0.0
        e1 = 1.0 if c == 1 else 0.0
        e2 = 1.0 if c == 2 else 0.0
        a, b, d = euler_rates_from_omega(angles, convention, e0, e1, e2)
        out[0, c], out[1, c], out[2, c] = a, b, d
    if convention == ZYZ:
        return -np.sin(angles[1])
    return -np.cos(angles[1])


@compiled
def euler_rate_dot_times(angles, rates, convention):
    """Ṫ(φ, φ̇) φ̇ as a scalar triple (K11): the part of ω̇ = T φ̈ + Ṫ φ̇ not due to φ̈.

    ZYZ: Ṫ φ̇ = [−cφ φ̇ ϑ̇ − sφ sϑ φ̇ ψ̇ + cφ cϑ ϑ̇ ψ̇,  −sφ φ̇ ϑ̇ + cφ sϑ φ̇ ψ̇ + sφ cϑ ϑ̇ ψ̇,  −sϑ ϑ̇ ψ̇]
    RPY: Ṫ φ̇ = [−cφ φ̇ ϑ̇ − sφ cϑ φ̇ ψ̇ − cφ sϑ ϑ̇ ψ̇,  −sφ φ̇ ϑ̇ + cφ cϑ φ̇ ψ̇ − sφ sϑ ϑ̇ ψ̇,  −cϑ ϑ̇ ψ̇]
    """
    cf, sf = np.cos(angles[0]), np.sin(angles[0])
    ct, st = np.cos(angles[1]), np.sin(angles[1])
    fd, td, pd = rates[0], rates[1], rates[2]
    if convention == ZYZ:
        # d/dt of the third column (cφ sϑ, sφ sϑ, cϑ)
        dk0 = -sf * st * fd + cf * ct * td
        dk1 = cf * st * fd + sf * ct * td
        dk2 = -st * td
    else:
        # d/dt of the third column (cφ cϑ, sφ cϑ, −sϑ)
        dk0 = -sf * ct * fd - cf * st * td
        dk1 = cf * ct * fd - sf * st * td
        dk2 = -ct * td
    # d/dt of the second column (−sφ, cφ, 0) is (−cφ φ̇, −sφ φ̇, 0); the first column is constant.
    return -cf * fd * td + dk0 * pd, -sf * fd * td + dk1 * pd, dk2 * pd


@compiled
def rotation_error_into(R_des, R, out):
    """Rotation vector e_O = ϑ r of R_des Rᵀ (axis r, angle ϑ ∈ [0, π]) into ``out`` (3,) (K12).

    Both rotations are expressed in the same frame; e_O is in that frame.  Exact (log map), so
    it stays meaningful for large errors; robust near ϑ = π where the skew part vanishes.
    """
    q00 = R_des[0, 0] * R[0, 0] + R_des[0, 1] * R[0, 1] + R_des[0, 2] * R[0, 2]
    q01 = R_des[0, 0] * R[1, 0] + R_des[0, 1] * R[1, 1] + R_des[0, 2] * R[1, 2]
    q02 = R_des[0, 0] * R[2, 0] + R_des[0, 1] * R[2, 1] + R_des[0, 2] * R[2, 2]
    q10 = R_des[1, 0] * R[0, 0] + R_des[1, 1] * R[0, 1] + R_des[1, 2] * R[0, 2]
    q11 = R_des[1, 0] * R[1, 0] + R_des[1, 1] * R[1, 1] + R_des[1, 2] * R[1, 2]
    q12 = R_des[1, 0] * R[2, 0] + R_des[1, 1] * R[2, 1] + R_des[1, 2] * R[2, 2]
    q20 = R_des[2, 0] * R[0, 0] + R_des[2, 1] * R[0, 1] + R_des[2, 2] * R[0, 2]
    q21 = R_des[2, 0] * R[1, 0] + R_des[2, 1] * R[1, 1] + R_des[2, 2] * R[1, 2]
    q22 = R_des[2, 0] * R[2, 0] + R_des[2, 1] * R[2, 1] + R_des[2, 2] * R[2, 2]
    # v = sin ϑ · r from the skew part, cos ϑ from the trace
    vx, vy, vz = 0.5 * (q21 - q12), 0.5 * (q02 - q20), 0.5 * (q10 - q01)
    c = min(1.0, max(-1.0, 0.5 * (q00 + q11 + q22 - 1.0)))
    s = np.sqrt(vx * vx + vy * vy + vz * vz)
    angle = np.arctan2(s, c)
    if c > -0.9:
        # ϑ/sin ϑ → 1 as ϑ → 0: the rotation vector is v to first order.
        scale = angle / s if s > 1e-12 else 1.0
        out[0], out[1], out[2] = scale * vx, scale * vy, scale * vz
        return
    # Near π the skew part is tiny; the symmetric part is cos ϑ I + (1 − cos ϑ) r rᵀ.
    d0, d1, d2 = (q00 - c) / (1.0 - c), (q11 - c) / (1.0 - c), (q22 - c) / (1.0 - c)
    if d0 >= d1 and d0 >= d2:
        rx = np.sqrt(max(d0, 0.0))
        ry = 0.5 * (q01 + q10) / (1.0 - c) / rx
        rz = 0.5 * (q02 + q20) / (1.0 - c) / rx
    elif d1 >= d2:
        ry = np.sqrt(max(d1, 0.0))
        rx = 0.5 * (q01 + q10) / (1.0 - c) / ry
        rz = 0.5 * (q12 + q21) / (1.0 - c) / ry
    else:
        rz = np.sqrt(max(d2, 0.0))
        rx = 0.5 * (q02 + q20) / (1.0 - c) / rz
        ry = 0.5 * (q12 + q21) / (1.0 - c) / rz
    if rx * vx + ry * vy + rz * vz < 0.0:
        rx, ry, rz = -rx, -ry, -rz
    norm = np.sqrt(rx * rx + ry * ry + rz * rz)
    out[0], out[1], out[2] = angle * rx / norm, angle * ry / norm, angle * rz / norm


# ------------------------------------------------------------------------- Python wrappers


def euler_code(convention: str) -> int:
    """The integer code (``ZYZ``, ``RPY``) the compiled functions take for ``convention``."""
    if convention not in EULER_CODES:
        raise ValueError(f"euler: unknown Euler convention {convention!r}; use one of {EULER_CONVENTIONS}")
    return EULER_CODES[convention]


def branch_arguments(branch) -> tuple[int, np.ndarray]:
    """(branch code, reference) for the compiled functions from ``branch`` = +1, −1 or a triple."""
    if isinstance(branch, (int, np.integer)) and not isinstance(branch, bool):
        if branch not in (1, -1):
            raise ValueError(f"branch: must be +1, -1 or a reference angle triple, got {branch}")
        return int(branch), np.zeros(3)
    reference = np.asarray(branch, dtype=float)
    if reference.shape != (3,) or not np.all(np.isfinite(reference)):
        raise ValueError("branch: must be +1, -1 or a finite reference angle triple (3,) [rad]")
    return 0, reference


def euler_matrix(angles, convention: str = "zyz") -> np.ndarray:
    """R(φ, ϑ, ψ) for the intrinsic sequence ``convention`` (see module docstring)."""
    phi, theta, psi = angles
    if euler_code(convention) == ZYZ:
        return rot_z(phi) @ rot_y(theta) @ rot_z(psi)
    return rot_z(phi) @ rot_y(theta) @ rot_x(psi)


def euler_from_matrix(R: np.ndarray, convention: str = "zyz", *, branch=1) -> np.ndarray:
    """Euler angles (φ, ϑ, ψ) [rad] of the rotation R (3, 3).

    ``branch=+1`` picks ϑ ∈ [0, π] for ZYZ and ϑ ∈ [−π/2, π/2] for RPY; ``branch=−1`` the
    other solution (ϑ ∈ [−π, 0] for ZYZ, |ϑ| ≥ π/2 for RPY); a reference triple (3,) picks
    the equivalent angles nearest to it (continuity along a trajectory).  At a representation
    singularity only φ + ψ or φ − ψ is defined; ψ = 0 is returned then (or the split nearest
    the reference).
    """
    code = euler_code(convention)
    branch_code, reference = branch_arguments(branch)
    out = np.empty(3)
    euler_angles_into(np.ascontiguousarray(R, dtype=float), code, branch_code, reference, out)
    return out


def euler_rate_matrix(angles, convention: str = "zyz") -> np.ndarray:
    """T(φ) with ω = T(φ) φ̇, (3, 3); ω and φ̇ in the fixed frame (K9, Siciliano (3.64)).

    ZYZ: T = [[0, −sφ, cφ sϑ], [0, cφ, sφ sϑ], [1, 0, cϑ]], det T = −sin ϑ.
    RPY: T = [[0, −sφ, cφ cϑ], [0, cφ, sφ cϑ], [1, 0, −sϑ]], det T = −cos ϑ.
    """
    out = np.empty((3, 3))
    euler_rate_matrix_into(np.asarray(angles, dtype=float), euler_code(convention), out)
    return out


def euler_rate_inverse(angles, convention: str = "zyz", singular_tol: float = 1e-6) -> np.ndarray:
    """T(φ)⁻¹, (3, 3) (K10); raises :class:`RepresentationSingularityError` if |det T| < tol."""
    out = np.empty((3, 3))
    det = euler_rate_inverse_into(np.asarray(angles, dtype=float), euler_code(convention), out)
    if abs(det) < singular_tol:
        raise RepresentationSingularityError(_singularity_message(angles, convention, det))
    return out


def analytic_transform(angles, convention: str = "zyz") -> np.ndarray:
    """T_A(φ) = blockdiag(I₃, T(φ)), (6, 6), with v = [ṗ; ω] = T_A(φ) ẋ for x = [p; φ] (K9)."""
    T_A = np.eye(6)
    T_A[3:, 3:] = euler_rate_matrix(angles, convention)
    return T_A


def analytic_transform_inverse(angles, convention: str = "zyz", singular_tol: float = 1e-6) -> np.ndarray:
    """T_A(φ)⁻¹ = blockdiag(I₃, T(φ)⁻¹), (6, 6) (K10); raises at a representation singularity."""
    T_A_inv = np.eye(6)
    T_A_inv[3:, 3:] = euler_rate_inverse(angles, convention, singular_tol)
    return T_A_inv


def rotation_error(R_des: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) [rad] of R_des Rᵀ: the rotation taking R to R_des (K12)."""
    out = np.empty(3)
    rotation_error_into(np.ascontiguousarray(R_des, dtype=float), np.ascontiguousarray(R, dtype=float), out)
    return out


def _singularity_message(angles, convention: str, det: float) -> str:
    where = "sin ϑ = 0, ϑ ∈ {0, π}" if convention == "zyz" else "cos ϑ = 0, ϑ = ±π/2"
    other = "rpy" if convention == "zyz" else "zyz"
    return (f"euler: {convention.upper()} angles {np.round(np.asarray(angles, float), 6).tolist()} "
            f"are at a representation singularity ({where}; det T = {det:.2e}): the analytic "
            f"Jacobian does not exist here; use euler='{other}', another frame, or the geometric Jacobian")
