"""Compiled closed-form kernels against the numeric kernels, and a short simulation through
the closed form."""

from functools import cache

import numpy as np

import armlab
from armlab.kernels import dynamics as numeric
from armlab.kernels import kinematics as numeric_kin
from armlab.symbolic import closed_form_kernels, closed_form_torque

RNG = np.random.default_rng(7)


@cache
def setup():
    robot = armlab.load_robot("prp_actuated")  # motors (rotor, mass) and friction on every joint
    return robot, closed_form_kernels(robot), numeric.make_workspace(robot.n)


def test_generated_kernels_match_numeric_kernels():
    robot, closed, ws = setup()
    m, n = robot.arrays, robot.n
    out_a, out_b = np.empty((n, n)), np.empty((n, n))
    vec_a, vec_b = np.empty(n), np.empty(n)
    for _ in range(5):
        q, qd, qdd, tau = RNG.normal(size=(4, n)) * 0.3
        h_e = RNG.normal(size=6)
        closed.mass_matrix_into(m, ws, q, out_a)
        numeric.mass_matrix_into(m, ws, q, out_b)
        np.testing.assert_allclose(out_a, out_b, rtol=1e-12, atol=1e-14)
        closed.coriolis_matrix_into(m, ws, q, qd, out_a)
        numeric.coriolis_matrix_into(m, ws, q, qd, out_b)
        np.testing.assert_allclose(out_a, out_b, rtol=1e-10, atol=1e-13)
        closed.gravity_into(m, ws, q, vec_a)
        numeric.gravity_into(m, ws, q, vec_b)
        np.testing.assert_allclose(vec_a, vec_b, rtol=1e-12, atol=1e-14)
        closed.rnea_into(m, ws, q, qd, qdd, 1.0, h_e, vec_a)
        numeric.rnea_into(m, ws, q, qd, qdd, 1.0, h_e, vec_b)
        np.testing.assert_allclose(vec_a, vec_b, rtol=1e-10, atol=1e-12)
        closed.rnea_into(m, ws, q, qd, qdd, 0.0, np.zeros(6), vec_a)
        numeric.rnea_into(m, ws, q, qd, qdd, 0.0, np.zeros(6), vec_b)
        np.testing.assert_allclose(vec_a, vec_b, rtol=1e-10, atol=1e-12)
        assert closed.forward_dynamics_into(m, ws, q, qd, tau, h_e, vec_a)
        assert numeric.forward_dynamics_into(m, ws, q, qd, tau, h_e, vec_b)
        np.testing.assert_allclose(vec_a, vec_b, rtol=1e-9, atol=1e-11)
        T_a, T_b = np.empty((4, 4)), np.empty((4, 4))
        closed.forward_kinematics_kernel(m, q, T_a)
        numeric_kin.forward_kinematics_kernel(m, q, T_b)
        np.testing.assert_allclose(T_a, T_b, atol=1e-14)
        J_a, J_b = np.empty((6, n)), np.empty((6, n))
        closed.jacobian_kernel(m, q, J_a)
        numeric_kin.jacobian_kernel(m, q, J_b)
        np.testing.assert_allclose(J_a, J_b, atol=1e-14)


def test_simulation_through_the_closed_form_follows_the_numeric_plant():
    robot, closed, ws = setup()
    m, n = robot.arrays, robot.n

    def run(forward):
        q, qd = np.array([0.05, 0.4, 0.1]), np.zeros(n)
        tau = np.array([2.0, 0.05, 1.0])  # constant joint forces, friction and gravity act
        h_e = np.zeros(6)
        dt = 1e-3
        k = [np.empty(n) for _ in range(4)]
        for _ in range(300):  # RK4 on (q, q̇)
            forward(m, ws, q, qd, tau, h_e, k[0])
            forward(m, ws, q + dt / 2 * qd, qd + dt / 2 * k[0], tau, h_e, k[1])
            forward(m, ws, q + dt / 2 * (qd + dt / 2 * k[0]), qd + dt / 2 * k[1], tau, h_e, k[2])
            forward(m, ws, q + dt * (qd + dt / 2 * k[1]), qd + dt * k[2], tau, h_e, k[3])
            q = q + dt * (qd + dt / 6 * (k[0] + k[1] + k[2]))
            qd = qd + dt / 6 * (k[0] + 2 * k[1] + 2 * k[2] + k[3])
        return q, qd

    q_closed, qd_closed = run(closed.forward_dynamics_into)
    q_numeric, qd_numeric = run(numeric.forward_dynamics_into)
    assert np.abs(q_numeric - np.array([0.05, 0.4, 0.1])).max() > 1e-3  # the arm moved
    np.testing.assert_allclose(q_closed, q_numeric, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(qd_closed, qd_numeric, rtol=1e-9, atol=1e-11)


def test_one_formula_torque_matches_the_numeric_rnea():
    robot, _, ws = setup()
    tau_into = closed_form_torque(robot)
    m, n = robot.arrays, robot.n
    tau_a, tau_b = np.empty(n), np.empty(n)
    for _ in range(5):
        q, qd, qdd = RNG.normal(size=(3, n)) * 0.3
        tau_into(q, qd, qdd, tau_a)
        numeric.rnea_into(m, ws, q, qd, qdd, 1.0, np.zeros(6), tau_b)
        np.testing.assert_allclose(tau_a, tau_b, rtol=1e-10, atol=1e-12)
