"""Trajectories (R8): trapezoidal velocity, blended via points, cubic and quintic splines —
derivatives consistent by finite differences, the designed limits and via points met, and
every one followed by a controller in the compiled loop."""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab.references import BlendedViaPoints, JointReference, ReferenceSpecError, Spline, Trapezoidal
from armlab.registry import scenario_types

TIMES = [0.0, 1.0, 2.5, 4.0]
VALUES = [[0.0, 0.0, 0.0], [0.1, 1.0, 0.05], [0.05, 1.2, 0.1], [0.15, 0.3, 0.0]]

TRAJECTORIES = [
    Trapezoidal([0.0, 1.0, 0.0], [0.1, -1.0, 0.1], [0.4, 1.0, 0.2], [1.0, 2.0, 0.5], t_start=0.5),
    Trapezoidal([0.0, 0.0, 0.0], [0.1, 0.05, 0.0], 10.0, 1.0),            # triangle: no cruise
    BlendedViaPoints(TIMES, VALUES, 0.4),
    Spline(TIMES, VALUES, 3),
    Spline(TIMES, VALUES, 5),
]
IDS = ["trapezoid", "triangle", "blended", "cubic", "quintic"]


@pytest.mark.parametrize("ref", TRAJECTORIES, ids=IDS)
def test_velocity_and_acceleration_are_derivatives_of_position(ref):
    t = np.linspace(-0.3, 5.0, 1061)
    h = 1e-6
    q_plus, qd_plus, qdd_plus = ref.evaluate(t + h)
    q_minus, qd_minus, qdd_minus = ref.evaluate(t - h)
    _, qd, qdd = ref.evaluate(t)
    np.testing.assert_allclose((q_plus - q_minus) / (2 * h), qd, atol=1e-6)  # velocity is continuous
    # Acceleration: away from its jumps (trapezoid corners, blend ends, the held ends of a spline).
    smooth = np.all(np.abs(qdd_plus - qdd_minus) < 1e-3, axis=1)
    assert smooth.mean() > 0.9
    np.testing.assert_allclose(((qd_plus - qd_minus) / (2 * h))[smooth], qdd[smooth], atol=1e-5)


@pytest.mark.parametrize("ref", TRAJECTORIES, ids=IDS)
def test_starts_and_ends_at_rest(ref):
    data = ref.data
    first, last = data[3], data[3 + int(data[2])]
    for t in (first - 1.0, first, last, last + 1.0):
        _, qd, qdd = ref.evaluate(t)
        np.testing.assert_allclose(qd, 0.0, atol=1e-12)
    q_start, q_end = ref.evaluate(first - 1.0)[0], ref.evaluate(last + 1.0)[0]
    np.testing.assert_allclose(ref.evaluate(first + 1e-9)[0], q_start, atol=1e-8)
    np.testing.assert_allclose(ref.evaluate(last - 1e-9)[0], q_end, atol=1e-8)


def test_trapezoid_keeps_every_joint_within_its_limits_and_reaches_one():
    ref = TRAJECTORIES[0]
    v_max, a_max = np.array([0.4, 1.0, 0.2]), np.array([1.0, 2.0, 0.5])
    T, tb, _ = ref.profile()
    t = np.linspace(0.5, 0.5 + T, 4001)
    q, qd, qdd = ref.evaluate(t)
    assert np.all(np.abs(qd) <= v_max * (1 + 1e-12))
    assert np.all(np.abs(qdd) <= a_max * (1 + 1e-12))
    # Joint 2 (Δ = −2 rad) is the slowest: it cruises at its v_max and accelerates at its a_max.
    np.testing.assert_allclose(np.abs(qd[:, 1]).max(), 1.0, rtol=1e-12)
    np.testing.assert_allclose(np.abs(qdd[:, 1]).max(), 2.0, rtol=1e-12)
    # Straight in joint space: every joint on the same time law.
    s = (q - q[0]) / (q[-1] - q[0])
    np.testing.assert_allclose(s[:, 0], s[:, 1], atol=1e-12)
    # Closed form: T = Δ/v + v/a = 2/1 + 1/2, blend t_b = v/a = 0.5 s.
    np.testing.assert_allclose([T, tb], [2.5, 0.5])
    np.testing.assert_allclose(ref.evaluate(0.5 + T)[0], [0.1, -1.0, 0.1], atol=1e-15)


def test_triangle_profile_when_the_cruise_speed_is_not_reached():
    T, tb, a = TRAJECTORIES[1].profile()
    # Δ = 0.1 at a_max = 1: s̈ = 10, T = 2 √(1/10).
    np.testing.assert_allclose([T, tb, a], [2 * np.sqrt(0.1), np.sqrt(0.1), 10.0])


def test_blends_join_straight_segments_at_the_via_slopes():
    ref = BlendedViaPoints(TIMES, VALUES, 0.4)
    values, b = np.array(VALUES), 0.4
    # Between the blends around t = 1 (ends 1.2) and t = 2.5 (starts 2.3), the velocity is the
    # slope between the via points 1 and 2.
    _, qd, qdd = ref.evaluate(np.linspace(1.25, 2.25, 11))
    np.testing.assert_allclose(qd, np.tile((values[2] - values[1]) / 1.5, (11, 1)), atol=1e-12)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-12)
    # In a blend the acceleration is (v_out − v_in)/b; the path misses the via point by
    # (v_out − v_in) b/8 (a parabola under its two tangents).
    v_in, v_out = (values[1] - values[0]) / (1.0 - b / 2), (values[2] - values[1]) / 1.5
    q1, _, qdd1 = ref.evaluate(1.0)
    np.testing.assert_allclose(qdd1, (v_out - v_in) / b, atol=1e-12)
    np.testing.assert_allclose(q1 - values[1], (v_out - v_in) * b / 8, atol=1e-12)


def test_overlapping_blends_are_refused_in_one_line():
    with pytest.raises(ReferenceSpecError, match="blend: 1 s is too long") as error:
        BlendedViaPoints(TIMES, VALUES, 1.0).data
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("degree", [3, 5])
def test_splines_pass_through_every_via_point(degree):
    ref = Spline(TIMES, VALUES, degree)
    np.testing.assert_allclose(ref.evaluate(np.array(TIMES))[0], VALUES, atol=1e-12)
    if degree == 5:
        _, _, qdd = ref.evaluate(np.array([TIMES[0], TIMES[-1]]) + np.array([1e-9, -1e-9]))
        np.testing.assert_allclose(qdd, 0.0, atol=1e-6)


def test_a_spline_of_another_degree_is_refused():
    with pytest.raises(ReferenceSpecError, match="degree: must be 3"):
        Spline(TIMES, VALUES, 4).data


def test_scenario_files_can_name_them():
    names = scenario_types(JointReference)
    assert {"trapezoidal", "blended_via_points", "spline"} <= set(names)


@pytest.mark.parametrize("ref", TRAJECTORIES, ids=IDS)
def test_computed_torque_follows_each_trajectory(ref):
    from armlab.control.joint_space import JointInverseDynamics

    plant = armlab.load_robot("prp")
    controller = JointInverseDynamics(plant, ref, kp=25.0, kd=10.0)
    q0 = ref.evaluate(-1.0)[0]
    # The adaptive integrator: q̈_des jumps (trapezoid corners, blend ends), which a fixed RK4
    # step straddling one integrates with an error of order Δq̈ dt / ω_n.
    result = armlab.simulate(plant, controller, q0=q0, t_final=5.0, dt=1e-2, method="adaptive")
    q_des = ref.evaluate(result.t)[0]
    # A perfect model and no initial error: q follows q_des up to the integration error.
    assert np.abs(result.q - q_des).max() < 1e-7
    assert np.abs(result.q[-1] - ref.evaluate(10.0)[0]).max() < 1e-7
