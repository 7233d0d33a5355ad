"""Task-space references: desired end-effector poses Σ_d(t) and desired forces f_d(t).

A pose reference is evaluated by the compiled :func:`pose_reference_into` into a
*frame-motion vector* (24,) — [o_d (3) [m], R_d row-major (9), ȯ_d (3) [m/s], ω_d (3)
[rad/s], ö_d (3) [m/s²], ω̇_d (3) [rad/s²]], everything in Σ_0 — the format every task-space
controller reads (``armlab.kernels.task_space``).

Via-poses (Σ_j at time t_j) are joined rest-to-rest, position along the straight segment and
orientation along the geodesic (a rotation about one fixed axis), both with the same quintic
time law (notation table, R6):

    o_d = o_j + s(u) (o_{j+1} − o_j),   R_d = Rot(r_j, s(u) ϑ_j) R_j,   Rot(r_j, ϑ_j) = R_{j+1} R_jᵀ
    ω_d = ṡ ϑ_j r_j,   ω̇_d = s̈ ϑ_j r_j,   s(u) = 10u³ − 15u⁴ + 6u⁵,  u = (t − t_j)/(t_{j+1} − t_j)

No Euler angles are interpolated, so the path never meets a representation singularity the
via-poses do not contain, and consecutive poses are joined by the shortest rotation.  What an
interpolator cannot know is the *robot's* singular set: the straight segment between two
reachable positions may pass near it (for the PRP, the z_0 axis, where J_P is singular).
:func:`path_singular_values` samples a reference through a robot's inverse kinematics and
returns σ_min(J) along it, so a scenario can check its path before running it.

A force reference f_d(t) (3,) [N] in Σ_0 moves from f_0 to f_1 with the same quintic law over
[t_0, t_0 + T] (T = 0: a step) (R7).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from armlab.errors import TaskReferenceError
from armlab.references.joint import quintic
from armlab.registry import scenario_type
from armlab.spatial import checked_rotation, euler_matrix

FRAME_SIZE = 24


@njit(cache=True)
def _write_pose(data, base_p, base_R, j, frame_out):
    for i in range(3):
        frame_out[i] = data[base_p + 3 * j + i]
    for i in range(9):
        frame_out[3 + i] = data[base_R + 9 * j + i]


@njit(cache=True)
def pose_reference_into(data, t, frame_out):
    """Σ_d(t) of a :class:`PoseReference` (its ``data``) into ``frame_out`` (24,) (R6)."""
    count = int(data[0])
    base_t = 1
    base_p = base_t + count
    base_R = base_p + 3 * count
    base_axis = base_R + 9 * count
    for i in range(12, FRAME_SIZE):
        frame_out[i] = 0.0
    if count == 1 or t <= data[base_t]:
        _write_pose(data, base_p, base_R, 0, frame_out)
        return
    if t >= data[base_t + count - 1]:
        _write_pose(data, base_p, base_R, count - 1, frame_out)
        return
    j = 0
    while t >= data[base_t + j + 1]:
        j += 1
    duration = data[base_t + j + 1] - data[base_t + j]
    s, ds, dds = quintic((t - data[base_t + j]) / duration)
    ds /= duration
    dds /= duration * duration
    a = base_axis + 4 * j
    rx, ry, rz, angle = data[a], data[a + 1], data[a + 2], data[a + 3]
    for i in range(3):
        delta = data[base_p + 3 * (j + 1) + i] - data[base_p + 3 * j + i]
        frame_out[i] = data[base_p + 3 * j + i] + s * delta
        frame_out[12 + i] = ds * delta
        frame_out[18 + i] = dds * delta
    frame_out[15], frame_out[16], frame_out[17] = ds * angle * rx, ds * angle * ry, ds * angle * rz
    frame_out[21], frame_out[22], frame_out[23] = dds * angle * rx, dds * angle * ry, dds * angle * rz
    # Rodrigues: Rot(r, sϑ) = I + sin S(r) + (1 − cos) S(r)²; R_d = Rot · R_j.
    c, sn = np.cos(s * angle), np.sin(s * angle)
    v = 1.0 - c
    rot00, rot01, rot02 = c + v * rx * rx, v * rx * ry - sn * rz, v * rx * rz + sn * ry
    rot10, rot11, rot12 = v * rx * ry + sn * rz, c + v * ry * ry, v * ry * rz - sn * rx
    rot20, rot21, rot22 = v * rx * rz - sn * ry, v * ry * rz + sn * rx, c + v * rz * rz
    b = base_R + 9 * j
    for col in range(3):
        r0, r1, r2 = data[b + col], data[b + 3 + col], data[b + 6 + col]
        frame_out[3 + col] = rot00 * r0 + rot01 * r1 + rot02 * r2
        frame_out[6 + col] = rot10 * r0 + rot11 * r1 + rot12 * r2
        frame_out[9 + col] = rot20 * r0 + rot21 * r1 + rot22 * r2


@njit(cache=True)
def force_reference_into(data, t, f_out):
    """f_d(t) (3,) [N] in Σ_0 of a :class:`ForceReference` (its ``data``) (R7)."""
    start, duration = data[0], data[1]
    if t <= start:
        s = 0.0
    elif duration <= 0.0 or t >= start + duration:
        s = 1.0
    else:
        s = quintic((t - start) / duration)[0]
    for i in range(3):
        f_out[i] = data[2 + i] + s * (data[5 + i] - data[2 + i])


def _axis_angle(R: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit axis r and angle ϑ ∈ [0, π] of a rotation R (axis (0, 0, 1) when ϑ = 0)."""
    c = np.clip(0.5 * (np.trace(R) - 1.0), -1.0, 1.0)
    v = 0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    angle = float(np.arctan2(np.linalg.norm(v), c))
    if angle < 1e-12:
        return np.array([0.0, 0.0, 1.0]), 0.0
    if c > -0.9:
        return v / np.linalg.norm(v), angle
    # Near π: r rᵀ = (R + Rᵀ − 2c I) / (2 (1 − c)); take the largest column.
    S = (R + R.T - 2.0 * c * np.eye(3)) / (2.0 * (1.0 - c))
    k = int(np.argmax(np.diag(S)))
    r = S[:, k] / np.sqrt(S[k, k])
    if r @ v < 0.0:
        r = -r
    return r, angle


@scenario_type("pose", poses={"poses": ("positions", "rotations")})
@dataclass(frozen=True)
class PoseReference:
    """Desired end-effector poses Σ_d(t) through via-poses (R6); one pose = constant.

    ``times`` (N,) [s] strictly increasing; ``positions`` (N, 3) [m] and ``rotations``
    (N, 3, 3) in Σ_0.  Repeat a pose with a later time to hold it.
    """

    times: np.ndarray
    positions: np.ndarray
    rotations: np.ndarray
    data: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        times = np.atleast_1d(np.asarray(self.times, dtype=float))
        positions = np.asarray(self.positions, dtype=float).reshape(-1, 3)
        rotations = np.asarray(self.rotations, dtype=float).reshape(-1, 3, 3)
        count = times.shape[0]
        if positions.shape[0] != count or rotations.shape[0] != count:
            raise TaskReferenceError(f"positions/rotations: need one per time ({count}), got "
                                     f"{positions.shape[0]} and {rotations.shape[0]}")
        if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0.0):
            raise TaskReferenceError("times: must be finite and strictly increasing")
        if not np.all(np.isfinite(positions)):
            raise TaskReferenceError("positions: must be finite")
        for j in range(count):
            checked_rotation(rotations[j], f"rotations[{j}]", TaskReferenceError)
        segments = []
        for j in range(count - 1):
            axis, angle = _axis_angle(rotations[j + 1] @ rotations[j].T)
            segments.append(np.append(axis, angle))
        data = np.concatenate(([float(count)], times, positions.ravel(), rotations.ravel(),
                               np.ravel(segments) if segments else np.zeros(0)))
        for name, value in (("times", times), ("positions", positions), ("rotations", rotations),
                            ("data", data)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @classmethod
    def constant(cls, position, rotation) -> PoseReference:
        """Σ_d fixed at ``position`` (3,) [m], ``rotation`` (3, 3)."""
        return cls(np.zeros(1), np.reshape(position, (1, 3)), np.reshape(rotation, (1, 3, 3)))

    @classmethod
    def from_pose_vectors(cls, times, poses, euler: str = "zyz") -> PoseReference:
        """Via-poses given as x = [p; φ] (N, 6) [m, rad] with Euler angles ``euler`` (the
        seed's x0 = [0, −0.2, 0.5, π/2, −π/2, 0] is ZYZ)."""
        poses = np.atleast_2d(np.asarray(poses, dtype=float))
        if poses.shape[1] != 6:
            raise TaskReferenceError(f"poses: need rows [x, y, z, φ, ϑ, ψ], got shape {poses.shape}")
        rotations = np.array([euler_matrix(row[3:], euler) for row in poses])
        return cls(np.atleast_1d(times), poses[:, :3], rotations)

    def evaluate(self, t: float) -> np.ndarray:
        """The frame-motion vector (24,) at time t (see the module docstring)."""
        out = np.empty(FRAME_SIZE)
        pose_reference_into(self.data, float(t), out)
        return out

    def describe(self) -> dict:
        return {"type": "PoseReference", "times": self.times.tolist(),
                "positions": self.positions.tolist(), "rotations": self.rotations.tolist()}


@scenario_type("force")
@dataclass(frozen=True)
class ForceReference:
    """Desired force f_d(t) (3,) [N] in Σ_0 (the force the end effector exerts): ``initial``
    until ``start`` [s], then a quintic move to ``final`` over ``duration`` [s] (0: step) (R7)."""

    final: np.ndarray
    initial: np.ndarray = field(default_factory=lambda: np.zeros(3))
    start: float = 0.0
    duration: float = 0.0
    data: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        final = np.asarray(self.final, dtype=float)
        initial = np.asarray(self.initial, dtype=float)
        for name, value in (("final", final), ("initial", initial)):
            if value.shape != (3,) or not np.all(np.isfinite(value)):
                raise TaskReferenceError(f"{name}: must be a finite force (3,) [N]")
        if not (np.isfinite(self.start) and np.isfinite(self.duration)) or self.duration < 0.0:
            raise TaskReferenceError("duration: must be finite and ≥ 0")
        data = np.concatenate(([float(self.start), float(self.duration)], initial, final))
        for name, value in (("final", final), ("initial", initial), ("data", data)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    def evaluate(self, t: float) -> np.ndarray:
        out = np.empty(3)
        force_reference_into(self.data, float(t), out)
        return out

    def describe(self) -> dict:
        return {"type": "ForceReference", "final": self.final.tolist(),
                "initial": self.initial.tolist(), "start": self.start, "duration": self.duration}


def path_singular_values(robot, reference: PoseReference, q0, *, samples: int = 200,
                         rows=(0, 1, 2), t_final: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(t (samples,), σ_min (samples,)) of J[rows] along the positions of ``reference``.

    The joint path follows the reference positions by damped Newton steps from ``q0``
    (each sample starts from the previous solution, so the branch is kept).  A σ_min near 0
    means the path itself runs through a singular configuration of ``robot``.
    """
    from armlab.kinematics import forward_kinematics, geometric_jacobian

    rows = list(rows)
    q = np.asarray(q0, dtype=float).copy()
    end = reference.times[-1] if t_final is None else t_final
    times = np.linspace(reference.times[0], end, samples)
    sigma = np.empty(samples)
    for k, t in enumerate(times):
        target = reference.evaluate(t)[:3]
        for _ in range(50):
            error = target - forward_kinematics(robot, q, frame="0")[:3, 3]
            if np.linalg.norm(error) < 1e-10:
                break
            J = geometric_jacobian(robot, q, frame="0")[:3]
            q += J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(3), error)
        sigma[k] = np.linalg.svd(geometric_jacobian(robot, q, frame="0")[rows], compute_uv=False).min()
    return times, sigma
