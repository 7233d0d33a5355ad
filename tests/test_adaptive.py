"""Slotine–Li adaptive control (A8): convergence, Lyapunov function, parameter drift, regressor."""

import numpy as np
import pytest

import armlab
from armlab.control.adaptive import (
    SlotineLi,
    SlotineLi1DoF,
    link1_parameters,
    parameter_mismatch,
    regressor_into,
    standard_parameters,
)
from armlab.references.joint import Sinusoid, SquareWaveAcceleration
from armlab.simulation import simulate

LINK1 = armlab.load_robot("link1")
TRUE = np.array([0.1, 0.05, -0.981])
GAMMA = np.array([0.5, 0.5, 0.5])


def test_link1_file_has_the_seed_parameters():
    # From the robot's own dynamics (B and g of the kernels), not from the file's numbers.
    np.testing.assert_allclose(link1_parameters(LINK1), TRUE, atol=1e-12)
    q = np.linspace(-3, 3, 7)
    g = np.array([armlab.gravity_torque(LINK1, [v])[0] for v in q])
    np.testing.assert_allclose(g, TRUE[2] * np.sin(q), atol=1e-12)


@pytest.fixture(scope="module")
def case1():
    controller = SlotineLi1DoF(LINK1, Sinusoid([0.0], 1.0, 1.0), kd=1.0, lam=5.0, gamma=GAMMA,
                               initial_estimate=[0.2, 0.1, 0.0])
    return controller, simulate(LINK1, controller, q0=[0.0], t_final=50.0, dt=1e-3)


def lyapunov(result):
    sigma = result.signals["sigma"][:, 0]
    error = result.z - TRUE
    return 0.5 * TRUE[0] * sigma**2 + 0.5 * np.sum(error**2 / GAMMA, axis=1)


def test_tracking_error_goes_to_zero(case1):
    _, result = case1
    error = np.abs(result.signals["q_err"][:, 0])
    assert error[:5000].max() > 0.05
    # Slow: with q_des = sin t the columns q̈_r and sin q are nearly collinear (poor excitation).
    assert error[-5000:].max() < 0.05 * error[:5000].max()


def test_lyapunov_function_never_increases_and_decreases_as_predicted(case1):
    controller, result = case1
    V = lyapunov(result)
    assert np.diff(V).max() < 1e-9 * V[0]
    # (C6): V̇ = −(F + K_D) σ², integrated with the trapezoidal rule.
    sigma = result.signals["sigma"][:, 0]
    rate = -(TRUE[1] + controller.kd) * sigma**2
    integral = np.concatenate([[0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(result.t))])
    np.testing.assert_allclose(V - V[0], integral, atol=1e-5 * V[0])


def test_prediction_error_vanishes_while_the_estimates_do_not_converge(case1):
    _, result = case1
    mismatch = np.abs(parameter_mismatch(result, TRUE))
    assert mismatch[:2000].max() > 0.1
    assert mismatch[-5000:].max() < 0.05 * mismatch[:2000].max()
    assert np.abs(result.z[-1] - TRUE).max() > 0.1


def test_square_wave_acceleration_case_tracks():
    controller = SlotineLi1DoF(LINK1, SquareWaveAcceleration([0.0], 2.0, 4.0), kd=5.0, lam=5.0,
                               gamma=[5.0, 5.0, 5.0])
    result = simulate(LINK1, controller, q0=[0.0], qd0=[-2.0], t_final=50.0, dt=1e-3)
    error = np.abs(result.signals["q_err"][:, 0])
    assert error[-5000:].max() < 0.5 * error[:5000].max()


def test_numeric_regressor_reproduces_the_dynamics_terms():
    robot = armlab.load_robot("prp")
    controller = SlotineLi(robot, Sinusoid([0, 0, 0], 0.1, 1.0), 1.0, 1.0, 1.0)
    params = controller.params()
    scratch, workspace, work = params[0], params[1], params[12]
    pi = standard_parameters(robot)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q, qd, qd_r, qdd_r = rng.normal(size=(4, 3))
        Y = np.zeros((3, 33))
        regressor_into(scratch, workspace, q, qd, qd_r, qdd_r, work, Y)
        # Christoffel C from the dynamics front end (D4), B and g likewise.
        expected = (armlab.inertia_matrix(robot, q) @ qdd_r + armlab.coriolis_matrix(robot, q, qd) @ qd_r
                    + armlab.gravity_torque(robot, q) + robot.arrays.viscous * qd_r)
        np.testing.assert_allclose(Y @ pi, expected, atol=1e-12)
        assert np.abs(Y @ (1.2 * pi) - expected).max() > 1e-3


def test_n_dof_adaptation_beats_the_fixed_wrong_model_on_the_prp():
    robot = armlab.load_robot("prp")
    model = robot.with_link_mass("link4", 0.16)
    reference = Sinusoid([0.1, 0.5, 0.1], [0.05, 0.3, 0.05], 2.0)
    errors = []
    for gamma in (0.01, 1e-12):          # adapting, and (practically) not adapting
        controller = SlotineLi(model, reference, kd=[5.0, 0.05, 2.0], lam=5.0, gamma=gamma)
        result = simulate(robot, controller, q0=[0.1, 0.5, 0.1], t_final=3.0, dt=2e-3)
        assert result.z.shape == (1501, 33)
        errors.append(np.sqrt(np.mean(result.signals["q_err"][-500:] ** 2)))   # RMS, last 1 s
    assert errors[0] < 0.5 * errors[1]
