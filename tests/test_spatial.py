"""Rotations, transforms, Euler angles and their rate matrices (K9–K12 of docs/notation.md).

References are independent of the code under test: finite differences of R(φ(t)) for ω, the
definition of the cross product for skew, and angle-axis constructions written out here.
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from armlab.spatial import (
    RepresentationSingularityError,
    analytic_transform,
    analytic_transform_inverse,
    euler_code,
    euler_from_matrix,
    euler_matrix,
    euler_rate_dot_times,
    euler_rate_inverse,
    euler_rate_matrix,
    inverse_transform,
    rot_x,
    rot_y,
    rot_z,
    rotation_error,
    rpy_from_matrix,
    rpy_matrix,
    skew,
    transform,
)

angle = st.floats(-np.pi, np.pi, allow_nan=False)
big_angle = st.floats(-20.0, 20.0, allow_nan=False)
coordinate = st.floats(-5.0, 5.0, allow_nan=False)
vector = st.tuples(coordinate, coordinate, coordinate).map(np.array)
# ϑ away from the representation singularities of each convention
zyz_theta = st.floats(0.05, np.pi - 0.05)
rpy_theta = st.floats(-np.pi / 2 + 0.05, np.pi / 2 - 0.05)


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def axis_angle(axis, theta):
    """Rodrigues' formula written out independently of armlab."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K


def random_rotation(rng):
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@given(angle, angle, angle, st.sampled_from(["zyz", "rpy"]))
def test_euler_matrix_is_a_rotation(a, b, c, convention):
    R = euler_matrix((a, b, c), convention)
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(R), 1.0)


def test_elementary_rotations_turn_axes_the_right_way():
    assert np.allclose(rot_z(np.pi / 2) @ [1, 0, 0], [0, 1, 0])
    assert np.allclose(rot_x(np.pi / 2) @ [0, 1, 0], [0, 0, 1])
    assert np.allclose(rot_y(np.pi / 2) @ [0, 0, 1], [1, 0, 0])
    assert np.allclose(rot_z(0.3), axis_angle([0, 0, 1], 0.3))


@given(angle, zyz_theta, angle)
def test_zyz_round_trip_positive_branch(phi, theta, psi):
    R = euler_matrix((phi, theta, psi), "zyz")
    assert np.allclose(euler_from_matrix(R, "zyz"), (phi, theta, psi), atol=1e-9) or \
        np.allclose(wrap(euler_from_matrix(R, "zyz") - (phi, theta, psi)), 0, atol=1e-9)


@given(angle, zyz_theta, angle)
def test_zyz_negative_branch_is_the_other_solution(phi, theta, psi):
    R = euler_matrix((phi, theta, psi), "zyz")
    other = euler_from_matrix(R, "zyz", branch=-1)
    # (φ + π, −ϑ, ψ + π) gives the same rotation
    assert np.allclose(wrap(other - (phi + np.pi, -theta, psi + np.pi)), 0, atol=1e-9)
    assert np.allclose(euler_matrix(other, "zyz"), R, atol=1e-12)


@given(angle, rpy_theta, angle)
def test_rpy_round_trip_both_branches(phi, theta, psi):
    R = euler_matrix((phi, theta, psi), "rpy")
    assert np.allclose(wrap(euler_from_matrix(R, "rpy") - (phi, theta, psi)), 0, atol=1e-9)
    other = euler_from_matrix(R, "rpy", branch=-1)
    # (φ + π, π − ϑ, ψ + π) gives the same rotation
    assert np.allclose(wrap(other - (phi + np.pi, np.pi - theta, psi + np.pi)), 0, atol=1e-9)
    assert np.allclose(euler_matrix(other, "rpy"), R, atol=1e-12)


@given(big_angle, big_angle, big_angle, st.sampled_from(["zyz", "rpy"]),
       st.tuples(*[st.floats(-0.3, 0.3)] * 3))
def test_nearest_branch_recovers_angles_near_the_reference(a, b, c, convention, noise):
    angles = np.array([a, b, c])
    R = euler_matrix(angles, convention)
    theta = angles[1]
    regular = abs(np.sin(theta)) > 0.4 if convention == "zyz" else abs(np.cos(theta)) > 0.4
    got = euler_from_matrix(R, convention, branch=angles + np.array(noise))
    assert np.allclose(euler_matrix(got, convention), R, atol=1e-10)
    if regular:
        assert np.allclose(got, angles, atol=1e-9)


@given(angle, angle, st.sampled_from([("zyz", 0.0), ("zyz", np.pi), ("rpy", np.pi / 2), ("rpy", -np.pi / 2)]))
def test_singular_orientations_still_round_trip(phi, psi, case):
    convention, theta = case
    R = euler_matrix((phi, theta, psi), convention)
    for branch in (1, -1, np.array([phi, theta, psi])):
        assert np.allclose(euler_matrix(euler_from_matrix(R, convention, branch=branch), convention), R,
                           atol=1e-10)
    # the nearest-to-reference split returns the reference itself when it is exact
    assert np.allclose(euler_from_matrix(R, convention, branch=np.array([phi, theta, psi])),
                       (phi, theta, psi), atol=1e-9)


@given(st.integers(0, 2**32 - 1), st.sampled_from(["zyz", "rpy"]), st.sampled_from([1, -1]))
def test_any_rotation_round_trips_through_euler_angles(seed, convention, branch):
    R = random_rotation(np.random.default_rng(seed))
    angles = euler_from_matrix(R, convention, branch=branch)
    assert np.allclose(euler_matrix(angles, convention), R, atol=1e-9)


@given(angle, zyz_theta, angle, vector, st.sampled_from(["zyz", "rpy"]))
def test_euler_rate_matrix_maps_angle_rates_to_angular_velocity(phi, theta, psi, rates, convention):
    if convention == "rpy":
        theta = theta - np.pi / 2
    angles = np.array([phi, theta, psi])
    h = 1e-6
    R_plus = euler_matrix(angles + h * rates, convention)
    R_minus = euler_matrix(angles - h * rates, convention)
    W = (R_plus - R_minus) / (2 * h) @ euler_matrix(angles, convention).T      # S(ω) = Ṙ Rᵀ
    omega = np.array([W[2, 1], W[0, 2], W[1, 0]])
    T = euler_rate_matrix(angles, convention)
    assert np.allclose(T @ rates, omega, atol=1e-7 * (1 + np.abs(rates).max()))
    det = -np.sin(theta) if convention == "zyz" else -np.cos(theta)
    assert np.isclose(np.linalg.det(T), det, atol=1e-12)
    assert np.allclose(euler_rate_inverse(angles, convention) @ T, np.eye(3), atol=1e-9)
    T_A = analytic_transform(angles, convention)
    assert np.allclose(T_A[:3, :3], np.eye(3)) and np.allclose(T_A[3:, 3:], T)
    assert np.allclose(analytic_transform_inverse(angles, convention) @ T_A, np.eye(6), atol=1e-9)
    # Ṫ φ̇ by differencing T along φ̇
    T_dot = (euler_rate_matrix(angles + h * rates, convention)
             - euler_rate_matrix(angles - h * rates, convention)) / (2 * h)
    got = np.array(euler_rate_dot_times(angles, rates, euler_code(convention)))
    assert np.allclose(got, T_dot @ rates, atol=1e-6 * (1 + np.abs(rates).max() ** 2))


@pytest.mark.parametrize(("convention", "theta"), [("zyz", 0.0), ("zyz", np.pi), ("rpy", np.pi / 2)])
def test_singular_rate_matrix_raises(convention, theta):
    with pytest.raises(RepresentationSingularityError, match="representation singularity"):
        euler_rate_inverse((0.3, theta, 0.2), convention)


def test_unknown_convention_names_the_field():
    with pytest.raises(ValueError, match="euler: unknown Euler convention 'xyz'"):
        euler_matrix((0, 0, 0), "xyz")
    with pytest.raises(ValueError, match="branch"):
        euler_from_matrix(np.eye(3), branch=2)


@given(angle, angle, angle, vector)
def test_inverse_transform(a, b, c, p):
    T = transform(euler_matrix((a, b, c), "zyz"), p)
    assert np.allclose(inverse_transform(T) @ T, np.eye(4), atol=1e-12)
    assert np.allclose(T @ inverse_transform(T), np.eye(4), atol=1e-12)


@given(vector, vector)
def test_skew_is_the_cross_product(v, w):
    S = skew(v)
    assert np.allclose(S, -S.T)
    assert np.allclose(S @ w, np.cross(v, w))


@given(angle, angle, angle)
def test_urdf_rpy_round_trip(roll, pitch, yaw):
    pitch = pitch / 2.0 * 0.98
    back = rpy_from_matrix(rpy_matrix((roll, pitch, yaw)))
    assert np.allclose(wrap(back - (roll, pitch, yaw)), 0, atol=1e-9)
    assert np.allclose(rpy_matrix((roll, pitch, yaw)), rot_z(yaw) @ rot_y(pitch) @ rot_x(roll))


@given(st.integers(0, 2**32 - 1), st.floats(0.0, np.pi - 1e-7))
def test_rotation_error_is_the_rotation_vector(seed, theta):
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    R = random_rotation(rng)
    R_des = axis_angle(axis, theta) @ R
    assert np.allclose(rotation_error(R_des, R), theta * axis, atol=1e-6)


def test_rotation_error_at_half_turn_has_the_right_axis():
    axis = np.array([1.0, 2.0, -2.0]) / 3.0
    e = rotation_error(axis_angle(axis, np.pi), np.eye(3))
    assert np.isclose(np.linalg.norm(e), np.pi)
    assert np.isclose(abs(e @ axis), np.pi)
