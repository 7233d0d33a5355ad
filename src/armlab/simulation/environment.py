"""Environments: the wrench h_e = [f_e; μ_e] the end effector exerts on its surroundings.

h_e is expressed in Σ_0, μ_e about the end-effector origin o_e, and enters the plant as

    B(q) q̈ + C(q, q̇) q̇ + F_v q̇ + F_s sgn q̇ + g(q) = τ − Jᵀ(q) h_e                       (D1)

(the environment pushes back with −h_e).  Models (notation table, E-tags; laws compiled in
``armlab.kernels.environment``):

* :class:`FreeSpace`  h_e = 0                                                             (E1)
* :class:`Spring`     generalised spring of stiffness K (6, 6) about the rest frame Σ_r:
  h_e^r = T_A^{−T}(φ_{r,e}) K x_{r,e},  x_{r,e} = [R_rᵀ(o_e − o_r); φ_{r,e}] (XYZ angles),
  the conservative spring of potential ½ x_{r,e}ᵀ K x_{r,e}; for small displacements this is
  Siciliano et al. (9.23), h_e = K dx_{r,e}                                          (E2, E3)
* :class:`PlanarWall` unilateral elastic plane with optional damping, pushing only:
  f_e = −n max(0, k δ + d δ̇) while the penetration δ = nᵀ(p_w − p_e) > 0              (E4)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from armlab.control.base import Environment
from armlab.errors import EnvironmentSpecError
from armlab.kernels.environment import (
    FreeSpaceParams,
    PlanarWallParams,
    SpringParams,
    free_space_law,
    spring_law,
    wall_law,
)
from armlab.registry import scenario_type
from armlab.spatial import checked_rotation


def _vector(value, name: str, size: int = 3) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != (size,) or not np.all(np.isfinite(array)):
        raise EnvironmentSpecError(f"{name}: must be a finite vector of {size} numbers")
    return array


def check_stiffness(K, name: str = "stiffness") -> np.ndarray:
    """K as a (6, 6) float array; symmetric positive semi-definite or an error naming ``name``."""
    K = np.asarray(K, dtype=float)
    if K.shape == (6,):
        K = np.diag(K)
    if K.shape != (6, 6) or not np.all(np.isfinite(K)):
        raise EnvironmentSpecError(f"{name}: must be a finite (6, 6) matrix or its diagonal (6,)")
    scale = max(np.abs(K).max(), 1.0)
    if np.abs(K - K.T).max() > 1e-9 * scale:
        raise EnvironmentSpecError(f"{name}: must be symmetric (a spring stores the energy ½xᵀKx)")
    lowest = np.linalg.eigvalsh(K).min()
    if lowest < -1e-9 * scale:
        raise EnvironmentSpecError(f"{name}: must be positive semi-definite (smallest eigenvalue "
                                   f"{lowest:.3g})")
    return K


def _freeze(obj, **arrays):
    for name, value in arrays.items():
        value = np.array(value, dtype=float)
        value.setflags(write=False)
        object.__setattr__(obj, name, value)


class _Evaluate:
    def wrench(self, T_0e, v_e=None, t: float = 0.0) -> np.ndarray:
        """h_e (6,) [N, N·m] in Σ_0 for the end-effector pose T_0e (4, 4) and twist v_e (6,)."""
        T_0e = np.asarray(T_0e, dtype=float)
        v = np.zeros(6) if v_e is None else np.asarray(v_e, dtype=float)
        out = np.empty(6)
        type(self).law(float(t), np.ascontiguousarray(T_0e[:3, :3]),
                       np.ascontiguousarray(T_0e[:3, 3]), v, self.params(), out)
        return out


@scenario_type("free_space")
@dataclass(frozen=True)
class FreeSpace(_Evaluate, Environment):
    """No contact: h_e = 0 (E1)."""

    law = free_space_law

    def params(self) -> FreeSpaceParams:
        return FreeSpaceParams()


@scenario_type("spring", poses={"rest_pose": ("rest_position", "rest_rotation")})
@dataclass(frozen=True)
class Spring(_Evaluate, Environment):
    """Generalised spring (E2, E3): stiffness ``stiffness`` K (6, 6) or its diagonal (6,)
    [N/m, N·m/rad], expressed in the rest frame Σ_r = (``rest_rotation`` R_r (3, 3),
    ``rest_position`` o_r (3,) [m]) in Σ_0.  K must be symmetric positive semi-definite;
    its zero directions are those along which the environment offers no resistance (outside
    Image(K))."""

    stiffness: np.ndarray
    rest_position: np.ndarray
    rest_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    law = spring_law

    def __post_init__(self):
        _freeze(self, stiffness=check_stiffness(self.stiffness, "stiffness"),
                rest_position=_vector(self.rest_position, "rest_position"),
                rest_rotation=checked_rotation(self.rest_rotation, "rest_rotation", EnvironmentSpecError))

    def params(self) -> SpringParams:
        return SpringParams(rest_rotation=np.ascontiguousarray(self.rest_rotation),
                            rest_position=self.rest_position.copy(),
                            stiffness=np.ascontiguousarray(self.stiffness), work=np.zeros(12),
                            R_rel=np.zeros((3, 3)), T_inv=np.zeros((3, 3)))

    def describe(self) -> dict:
        return {"type": "Spring", "stiffness": self.stiffness.tolist(),
                "rest_position": self.rest_position.tolist(),
                "rest_rotation": self.rest_rotation.tolist()}


@scenario_type("planar_wall")
@dataclass(frozen=True)
class PlanarWall(_Evaluate, Environment):
    """Unilateral elastic plane (E4) through ``point`` (3,) [m] with unit ``normal`` (3,)
    pointing into free space, ``stiffness`` k [N/m] > 0 and ``damping`` d [N·s/m] ≥ 0.
    It pushes the end effector out when it penetrates and never pulls it in."""

    point: np.ndarray
    normal: np.ndarray
    stiffness: float
    damping: float = 0.0

    law = wall_law

    def __post_init__(self):
        normal = _vector(self.normal, "normal")
        length = np.linalg.norm(normal)
        if length < 1e-12:
            raise EnvironmentSpecError("normal: must not be the zero vector")
        if not (np.isfinite(self.stiffness) and self.stiffness > 0.0):
            raise EnvironmentSpecError("stiffness: must be a finite number > 0 [N/m]")
        if not (np.isfinite(self.damping) and self.damping >= 0.0):
            raise EnvironmentSpecError("damping: must be a finite number ≥ 0 [N·s/m]")
        _freeze(self, point=_vector(self.point, "point"), normal=normal / length)
        object.__setattr__(self, "stiffness", float(self.stiffness))
        object.__setattr__(self, "damping", float(self.damping))

    def params(self) -> PlanarWallParams:
        return PlanarWallParams(point=self.point.copy(), normal=self.normal.copy(),
                                stiffness=self.stiffness, damping=self.damping)

    def describe(self) -> dict:
        return {"type": "PlanarWall", "point": self.point.tolist(), "normal": self.normal.tolist(),
                "stiffness": self.stiffness, "damping": self.damping}
