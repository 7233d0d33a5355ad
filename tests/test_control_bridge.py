"""The python-control bridge: armlab's plant and closed loops as ``control.nlsys`` and their
linearisation, checked against the closed-loop poles the control laws are designed for and
against armlab's own simulator."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

control = pytest.importorskip("control", reason="python-control is not installed (extra 'control')")

import armlab  # noqa: E402
from armlab.control.bridge import (  # noqa: E402
    closed_loop_system,
    initial_state,
    linearize,
    plant_system,
)
from armlab.scenarios import load_scenario  # noqa: E402
from armlab.simulation.disturbances import ConstantTorque  # noqa: E402


def computed_torque(kp, kd):
    scenario = load_scenario("a7_id_regulation")
    controller = replace(scenario.controller, kp=np.asarray(kp, float), kd=np.asarray(kd, float))
    return scenario.plant, controller, controller.reference.evaluate(0.0)[0]


def test_computed_torque_has_the_designed_poles():
    # s² + K_D s + K_P per joint: roots −2, −3 | −4, −5 | −6, −7 (distinct: well conditioned).
    plant, controller, q_des = computed_torque([6, 20, 42], [5, 9, 13])
    system = closed_loop_system(plant, controller)
    x_eq = initial_state(plant, controller, q_des)
    assert np.abs(system.dynamics(0.0, x_eq, np.zeros(3))).max() < 1e-12
    poles = linearize(system, x_eq).poles()
    assert np.abs(poles.imag).max() < 1e-8
    np.testing.assert_allclose(np.sort(poles.real), [-7, -6, -5, -4, -3, -2], atol=1e-8, rtol=0)


def test_critically_damped_computed_torque_is_the_stabilised_double_integrator():
    # ω_n = 5, ζ = 1 on every joint: a double pole −5 per joint.  A repeated pole of a Jordan
    # block moves by √ε under a perturbation ε, so the check is on the matrix and on the
    # characteristic polynomial (s² + 10 s + 25)³, not on the computed eigenvalues.
    plant, controller, q_des = computed_torque([25, 25, 25], [10, 10, 10])
    linear = linearize(closed_loop_system(plant, controller), initial_state(plant, controller, q_des))
    n = 3
    expected = np.block([[np.zeros((n, n)), np.eye(n)], [-25 * np.eye(n), -10 * np.eye(n)]])
    np.testing.assert_allclose(linear.A, expected, atol=1e-8, rtol=0)
    np.testing.assert_allclose(np.poly(linear.A), np.poly([-5.0] * 6), rtol=1e-8, atol=1e-8)


def test_impedance_control_has_the_poles_of_the_impedance():
    scenario = load_scenario("a12_impedance_regulation")
    mass, damping, stiffness = np.array([1.0, 2.0, 0.5]), np.array([10.0, 10, 10]), np.array([20.0, 10, 30])
    controller = replace(scenario.controller, mass=mass, kd=damping, kp=stiffness)
    plant = scenario.plant
    q_eq = armlab.inverse_kinematics(plant, controller.reference.positions[0], frame="0")[0]
    system = closed_loop_system(plant, controller)  # free space: the regulation equilibrium
    x_eq = initial_state(plant, controller, q_eq)
    assert np.abs(system.dynamics(0.0, x_eq, np.zeros(3))).max() < 1e-10
    poles = np.sort_complex(linearize(system, x_eq).poles())
    # Roots of M_d s² + K_D s + K_P, axis by axis (diagonal gains).
    expected = np.sort_complex(np.concatenate([np.roots([m, d, k])
                                               for m, d, k in zip(mass, damping, stiffness, strict=True)]))
    np.testing.assert_allclose(poles, expected, atol=1e-8, rtol=0)


def test_the_linear_model_step_response_matches_armlabs_run_near_the_equilibrium():
    plant, controller, q_des = computed_torque([6, 20, 42], [5, 9, 13])
    step = np.array([1e-3, 2e-3, -1e-3])  # τ_d [N, N·m, N] from t = 0, at rest on q_des
    run = armlab.simulate(plant, controller, q0=q_des, t_final=3.0, dt=1e-3,
                          disturbance=ConstantTorque(step))
    linear = linearize(closed_loop_system(plant, controller), initial_state(plant, controller, q_des))
    response = control.forced_response(linear, T=run.t, U=np.outer(step, np.ones(run.t.size)))
    deviation = run.q - q_des
    peak = np.abs(deviation).max(axis=0)
    assert np.all(peak > 1e-5)  # the step moved every joint
    np.testing.assert_allclose(response.states[:3].T, deviation, atol=1e-3 * peak.max(), rtol=0)


def test_the_nonlinear_closed_loop_reproduces_armlabs_run():
    # A controller with a state (Slotine–Li's estimates z) and a tracking reference.
    scenario = load_scenario("a8_case1_sine")
    plant, controller = scenario.plant, scenario.controller
    run = armlab.simulate(plant, controller, q0=[0.0], t_final=2.0, dt=1e-3, method="adaptive")
    system = closed_loop_system(plant, controller)
    response = control.input_output_response(system, run.t, 0.0, initial_state(plant, controller, [0.0]),
                                             solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12})
    np.testing.assert_allclose(response.states[0], run.q[:, 0], atol=1e-7)
    np.testing.assert_allclose(response.states[2:].T, run.z, atol=1e-7)


def test_the_plant_alone_falls_as_forward_dynamics_says():
    plant = armlab.load_robot("prp")
    system = plant_system(plant)
    q, qd, tau = np.array([0.1, 0.3, 0.05]), np.array([0.2, -0.1, 0.3]), np.array([1.0, 0.2, -0.5])
    xdot = system.dynamics(0.0, np.concatenate([q, qd]), tau)
    np.testing.assert_allclose(xdot[:3], qd)
    np.testing.assert_allclose(xdot[3:], armlab.forward_dynamics(plant, q, qd, tau))
    # Its linearisation's input matrix is B(q)⁻¹ under the velocity rows.
    linear = linearize(system, np.concatenate([q, qd]), tau)
    np.testing.assert_allclose(linear.B[3:], np.linalg.inv(armlab.inertia_matrix(plant, q)), rtol=1e-8,
                               atol=1e-10)


def test_a_controller_for_another_robot_is_refused_in_one_line():
    from armlab.errors import ProtocolError

    plant, controller, _ = computed_torque([1, 1, 1], [1, 1, 1])
    with pytest.raises(ProtocolError, match="3 joints, the plant 1"):
        closed_loop_system(armlab.load_robot("link1"), controller)


def _with_coulomb(robot, coulomb):
    from armlab.model.robot import Friction

    joints = [replace(j, friction=Friction(viscous=j.friction.viscous, coulomb=c))
              for j, c in zip(robot.joints, coulomb, strict=True)]
    return robot.replace(joints=joints)


def test_linearize_refuses_the_sgn_discontinuity_of_coulomb_friction_at_rest():
    """At q̇ = 0 the difference of F_s sgn q̇ is F_s / h: the fastest pole followed the step
    (−2.1·10⁴ at 10⁻³, −2.1·10⁵ at 10⁻⁴).  It is refused, naming the joint."""
    plant, controller, q_des = computed_torque([6, 20, 42], [5, 9, 13])
    rough = _with_coulomb(plant, [0.0, 2.0, 0.0])
    system = closed_loop_system(rough, controller)
    with pytest.raises(armlab.errors.InputError, match=f"joint {rough.joints[1].name} .* Coulomb friction"):
        linearize(system, initial_state(rough, controller, q_des))
    with pytest.raises(ValueError, match="no derivative at q̇ = 0"):
        linearize(plant_system(rough), np.concatenate([q_des, np.zeros(3)]), step=1e-4)


def test_linearize_with_coulomb_friction_while_sliding_is_independent_of_the_step():
    """Away from q̇ = 0, F_s sgn q̇ is constant near the point: the same A at any step."""
    plant, controller, q_des = computed_torque([6, 20, 42], [5, 9, 13])
    rough = _with_coulomb(plant, [0.0, 2.0, 0.0])
    x = np.concatenate([q_des, [0.0, 0.5, 0.0]])
    system = plant_system(rough)
    a, b = linearize(system, x, step=1e-3).A, linearize(system, x, step=1e-4).A
    np.testing.assert_allclose(a, b, atol=1e-6, rtol=1e-6)
