"""Operational-space dynamics (D8)–(D10): the seed's A5 formulas for square tasks, Khatib's
task equation for every k ≤ n (checked through the joint-space forward dynamics), damping near
singularities and the n < 6 task selection."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import armlab
from armlab import (
    coriolis_matrix,
    forward_dynamics,
    geometric_jacobian,
    gravity_torque,
    inertia_matrix,
    pose_vector,
)
from armlab.model.robot import Friction
from armlab.operational_space import TaskSelectionError, operational_space_dynamics


def task_acceleration_fd(robot, q, qd, qdd, rows, euler="zyz", frame="base", eps=1e-4):
    """ẍ_T by central differences of the pose along the motion q(t) = q + qd t + ½ qdd t²."""
    def x(t):
        return pose_vector(robot, q + qd * t + 0.5 * qdd * t * t, euler=euler, frame=frame)[list(rows)]
    return (x(eps) - 2 * x(0.0) + x(-eps)) / eps ** 2


@pytest.mark.parametrize("name, rows", [("prp", (0, 1, 2)), ("puma560", (0, 1, 2, 3, 4, 5)),
                                         ("puma560", (0, 1, 2)), ("planar2r", (0, 1))])
def test_task_equation_holds_under_joint_space_dynamics(name, rows):
    # Apply τ = Jᵀ F, integrate nothing: q̈ from the joint-space forward dynamics, ẍ_T by finite
    # differences of the pose, then Λ ẍ_T + μ + p must equal F (D8).
    # Friction stays in the joint space (not part of μ), so it is removed here.
    loaded = armlab.load_robot(name)
    robot = loaded.replace(joints=tuple(replace(j, friction=Friction()) for j in loaded.joints))
    rng = np.random.default_rng(11)
    checked = 0
    while checked < 3:
        q = rng.uniform(np.maximum(robot.arrays.q_min, -1.5), np.minimum(robot.arrays.q_max, 1.5))
        qd = rng.uniform(-0.5, 0.5, robot.n)
        osd = operational_space_dynamics(robot, q, qd, rows=rows)
        if osd.sigma_min < 0.05:
            continue                      # near a singularity Λ is huge and the check ill-posed
        checked += 1
        assert not osd.damped
        F = rng.normal(size=len(rows))
        qdd = forward_dynamics(robot, q, qd, osd.jacobian.T @ F)
        xdd = task_acceleration_fd(robot, q, qd, qdd, rows)
        lhs = osd.inertia @ xdd + osd.bias + osd.gravity
        np.testing.assert_allclose(lhs, F, atol=1e-5 * max(1.0, np.abs(osd.gravity).max()))


def test_prp_position_task_equals_seed_A5_formulas():
    # k = n = 3: B_A = J⁻ᵀ B J⁻¹, C_A ẋ = J⁻ᵀ C q̇ − B_A J̇ q̇, g_A = J⁻ᵀ g, J = J_P in Σ_0,
    # J̇ q̇ by a central difference of J along q̇.
    robot = armlab.load_robot("prp")
    q, qd = np.array([0.1, 0.4, 0.05]), np.array([0.2, -0.3, 0.1])
    J = geometric_jacobian(robot, q, frame="0")[:3]
    eps = 1e-6
    J_dot = (geometric_jacobian(robot, q + eps * qd, frame="0")[:3]
             - geometric_jacobian(robot, q - eps * qd, frame="0")[:3]) / (2 * eps)
    J_inv = np.linalg.inv(J)
    B_A = J_inv.T @ inertia_matrix(robot, q) @ J_inv
    osd = operational_space_dynamics(robot, q, qd, rows=(0, 1, 2), frame="0")
    np.testing.assert_allclose(osd.inertia, B_A, rtol=1e-10)
    np.testing.assert_allclose(osd.gravity, J_inv.T @ gravity_torque(robot, q), rtol=1e-10, atol=1e-12)
    expected_bias = J_inv.T @ coriolis_matrix(robot, q, qd) @ qd - B_A @ J_dot @ qd
    np.testing.assert_allclose(osd.bias, expected_bias, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(osd.dynamic_inverse, J_inv, rtol=1e-10, atol=1e-12)


def test_prp_at_the_theta2_axis_is_damped_and_reports_sigma_min():
    # d3 = L4/2 puts Σ_e on the θ2 axis: J_P's θ2 column vanishes (ρ = 0).
    robot = armlab.load_robot("prp")
    q = np.array([0.1, 0.3, robot.parameters["L4"] / 2])
    osd = operational_space_dynamics(robot, q, np.zeros(3), rows=(0, 1, 2))
    assert osd.sigma_min < 1e-12
    assert osd.damped
    assert np.all(np.isfinite(osd.inertia)) and np.all(np.isfinite(osd.gravity))
    np.testing.assert_allclose(osd.inertia, osd.inertia.T)
    assert np.linalg.eigvalsh(osd.inertia).min() > 0
    # close to, but outside, the damping zone nothing is damped and σ_min grows like |ρ|
    q_far = q + np.array([0.0, 0.0, 0.05])
    far = operational_space_dynamics(robot, q_far, np.zeros(3), rows=(0, 1, 2))
    assert not far.damped and far.sigma_min == pytest.approx(0.05, rel=1e-9)


def test_task_selection_errors_name_rows():
    robot = armlab.load_robot("prp")
    with pytest.raises(TaskSelectionError, match="rows"):
        operational_space_dynamics(robot, np.zeros(3), np.zeros(3))
    with pytest.raises(TaskSelectionError, match="rows"):
        operational_space_dynamics(robot, np.zeros(3), np.zeros(3), rows=(0, 1, 2, 3))
    with pytest.raises(TaskSelectionError, match="rows"):
        operational_space_dynamics(robot, np.zeros(3), np.zeros(3), rows=(0, 0))
