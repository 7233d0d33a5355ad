"""Environment models: spring stiffness, conservativeness, unilateral wall, validation."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from armlab.simulation.environment import EnvironmentSpecError, FreeSpace, PlanarWall, Spring
from armlab.spatial import rot_x, rot_y, rot_z


def _pose(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def test_free_space_exerts_nothing():
    h = FreeSpace().wrench(_pose(rot_z(0.3), [1.0, 2.0, 3.0]), np.ones(6))
    assert np.array_equal(h, np.zeros(6))


def test_spring_small_translation_is_K_times_displacement_in_rest_axes():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(6, 6))
    K = A @ A.T
    R_r = rot_z(0.4) @ rot_x(-0.9)
    o_r = np.array([0.1, -0.2, 0.3])
    spring = Spring(K, o_r, R_r)
    d_r = np.array([1e-3, -2e-3, 0.5e-3])           # displacement in Σ_r axes
    h = spring.wrench(_pose(R_r, o_r + R_r @ d_r))
    expected = np.concatenate((R_r @ (K[:3, :3] @ d_r), R_r @ (K[3:, :3] @ d_r)))
    np.testing.assert_allclose(h, expected, rtol=1e-12, atol=1e-12)


def test_spring_small_rotation_about_rest_axis():
    K = np.diag([0.0, 1e4, 0.0, 10.0, 20.0, 30.0])
    R_r = rot_y(0.7)
    spring = Spring(K, np.zeros(3), R_r)
    angle = 1e-5
    for axis, rot in enumerate((rot_x, rot_y, rot_z)):
        h = spring.wrench(_pose(R_r @ rot(angle), np.zeros(3)))
        # torque K_ii·angle about Σ_r's axis i, expressed in Σ_0
        np.testing.assert_allclose(h[3:], K[3 + axis, 3 + axis] * angle * R_r[:, axis], rtol=1e-8, atol=1e-14)
        np.testing.assert_allclose(h[:3], 0.0, atol=1e-12)


def _potential(spring, T):
    R_r, o_r, K = spring.rest_rotation, spring.rest_position, spring.stiffness
    R_rel = R_r.T @ T[:3, :3]
    # XYZ intrinsic angles (Rx Ry Rz) from scipy, independent of armlab's extraction
    phi = Rotation.from_matrix(R_rel).as_euler("XYZ")
    x = np.concatenate((R_r.T @ (T[:3, 3] - o_r), phi))
    return 0.5 * x @ K @ x


def test_spring_is_conservative_power_equals_energy_rate():
    """dU/dt = h_eᵀ v_e along a large, random motion (U = ½ xᵀ K x): the wrench is the
    work-conjugate of the twist, not just its small-displacement approximation."""
    rng = np.random.default_rng(7)
    A = rng.normal(size=(6, 6))
    spring = Spring(A @ A.T * 100.0, rng.normal(size=3) * 0.1, rot_x(0.3) @ rot_z(-1.0))
    R0, p0 = rot_y(0.5) @ rot_z(0.8), rng.normal(size=3) * 0.2
    w, pd = rng.normal(size=3), rng.normal(size=3)

    def pose(t):
        return _pose(Rotation.from_rotvec(w * t).as_matrix() @ R0, p0 + pd * t)

    for t in (0.0, 0.3, 0.7):
        eps = 1e-6
        rate = (_potential(spring, pose(t + eps)) - _potential(spring, pose(t - eps))) / (2 * eps)
        power = spring.wrench(pose(t)) @ np.concatenate((pd, w))
        assert power == pytest.approx(rate, rel=1e-6, abs=1e-8)


def test_wall_pushes_only_when_penetrated_and_never_pulls():
    wall = PlanarWall(point=[0.0, -0.2, 0.0], normal=[0.0, 2.0, 0.0], stiffness=1e4, damping=50.0)
    above = _pose(np.eye(3), [0.1, -0.19, 0.4])
    assert np.array_equal(wall.wrench(above, [0, -1.0, 0, 0, 0, 0]), np.zeros(6))
    inside = _pose(np.eye(3), [0.1, -0.201, 0.4])
    h_static = wall.wrench(inside)
    np.testing.assert_allclose(h_static, [0, -10.0, 0, 0, 0, 0], atol=1e-9)
    # pressing further in: damping adds to the push (the end effector exerts −y on the wall)
    h_in = wall.wrench(inside, [0, -0.1, 0, 0, 0, 0])
    np.testing.assert_allclose(h_in[1], -10.0 - 50.0 * 0.1, rtol=1e-12)
    # leaving fast: k δ + d δ̇ < 0 would pull; the wall lets go instead
    h_out = wall.wrench(inside, [0, 1.0, 0, 0, 0, 0])
    assert np.array_equal(h_out, np.zeros(6))


@pytest.mark.parametrize("K, word", [
    (np.diag([1.0, -1.0, 0, 0, 0, 0]), "semi-definite"),
    (np.triu(np.ones((6, 6))), "symmetric"),
    (np.ones((3, 3)), "(6, 6)"),
    (np.full(6, np.nan), "finite"),
])
def test_spring_rejects_non_physical_stiffness(K, word):
    with pytest.raises(EnvironmentSpecError, match=word) as info:
        Spring(K, np.zeros(3))
    assert str(info.value).startswith("stiffness:")


def test_spring_and_wall_reject_bad_geometry():
    with pytest.raises(EnvironmentSpecError, match="rest_rotation"):
        Spring(np.zeros(6), np.zeros(3), np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(EnvironmentSpecError, match="normal"):
        PlanarWall([0, 0, 0], [0, 0, 0], 1.0)
    with pytest.raises(EnvironmentSpecError, match="stiffness"):
        PlanarWall([0, 0, 0], [0, 1, 0], -1.0)
    with pytest.raises(EnvironmentSpecError, match="damping"):
        PlanarWall([0, 0, 0], [0, 1, 0], 1.0, damping=-2.0)
