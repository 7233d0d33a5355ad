"""Interaction control (seed A11–A15) against closed-form equilibria and linear-system theory."""

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import interp1d

from armlab.control.interaction import (
    AdmittanceControl,
    ComplianceControl,
    ForceControl,
    ImpedanceControl,
    ParallelForcePosition,
)
from armlab.kinematics import geometric_jacobian
from armlab.references.task import ForceReference, PoseReference
from armlab.robots import load_robot
from armlab.simulation import SimulationDiverged, simulate
from armlab.simulation.environment import Spring
from armlab.spatial import euler_matrix, rot_z
from pinocchio_model import armlab_v, pinocchio_model, pinocchio_q

PRP = load_robot("prp")
Q0 = np.array([0.1, 0.0, 0.0])                          # the seed's x0 = [0, −0.2, 0.5, π/2, −π/2, 0]
R0 = euler_matrix([np.pi / 2, -np.pi / 2, 0.0], "zyz")   # Σ_d's axes: x_d = z_0, y_d = −x_0, z_d = −y_0
P0 = np.array([0.0, -0.2, 0.5])


def _linear_response(M, D, K, t, forcing, x0, xd0):
    """Solve M ẍ + D ẋ + K x = forcing(t) (k-D) with SciPy, sampled at t."""
    k = M.shape[0]
    Minv = np.linalg.inv(M)

    def rhs(time, s):
        return np.concatenate((s[k:], Minv @ (forcing(time) - D @ s[k:] - K @ s[:k])))

    sol = solve_ivp(rhs, (t[0], t[-1]), np.concatenate((x0, xd0)), t_eval=t, rtol=1e-10, atol=1e-12,
                    max_step=2e-3)
    return sol.y[:k].T


def _seed_spring(stiffness=(0.0, 0.0, 1e4, 10.0, 0.0, 0.0)):
    """The seed's A11 environment: stiff along y_0 (z_r = −y_0), rotational 10 about z_0 (= x_r),
    at rest at x0; K given in Σ_r = Σ_d axes."""
    return Spring(np.diag(stiffness), P0, R0)


def test_compliance_equilibrium_is_the_closed_form_direction_by_direction():
    """x_e = (K_P + K)⁻¹(K_P x_d + K x_r) in Σ_d: stiff environment along y_0 (the end effector
    stays near the rest position), soft along z_0 (it reaches x_d) — the seed's two cases."""
    kp = np.diag([20.0, 10.0, 20.0, 50.0, 50.0, 50.0])   # seed K_P (x, y, z)_0 = (10, 20, 20) in Σ_d axes
    goal = np.array([0.0, -0.1, 0.4])
    spring = _seed_spring()
    controller = ComplianceControl(PRP, PoseReference.constant(goal, R0), kp=kp,
                                   kd=np.diag([10.0, 10.0, 10.0, 5.0, 5.0, 5.0]))
    result = simulate(PRP, controller, q0=Q0, t_final=6.0, dt=1e-3, environment=spring)
    x_r = np.concatenate((R0.T @ (P0 - goal), np.zeros(3)))         # Σ_r seen from Σ_d
    K = spring.stiffness
    x_closed = np.linalg.solve(kp + K, kp @ np.zeros(6) + K @ x_r)  # x_d = 0 in Σ_d
    x_e = result.signals["x"][-1]
    np.testing.assert_allclose(x_e, x_closed, atol=1e-7)
    p_e = goal + R0 @ x_e[:3]
    assert p_e[2] == pytest.approx(goal[2], abs=1e-7)                  # soft along z_0: reaches z_d
    assert p_e[1] == pytest.approx(-0.2 + 0.1 * 20.0 / (20.0 + 1e4), abs=1e-7)   # stiff along y_0
    f_expected = R0 @ (K[:3, :3] @ (x_e - x_r)[:3])
    np.testing.assert_allclose(result.signals["h_e"][-1, :3], f_expected, atol=1e-6)
    assert result.signals["h_e"][-1, 1] == pytest.approx(1e4 * 0.1 * 20.0 / 10020.0, rel=1e-6)

    # At rest in contact the applied torque balances gravity and the contact wrench:
    # τ = g(q) + Jᵀ(q) h_e, with g from Pinocchio (an independent dynamics implementation).
    q, tau, h_e = result.q[-1], result.tau[-1], result.signals["h_e"][-1]
    assert np.abs(result.qd[-1]).max() < 1e-6
    model, data = pinocchio_model(PRP)
    g = armlab_v(PRP, model, pin.computeGeneralizedGravity(model, data, pinocchio_q(PRP, model, q)))
    J = geometric_jacobian(PRP, q, frame="0")
    np.testing.assert_allclose(tau, g + J.T @ h_e, atol=1e-6)
    assert np.abs(J.T @ h_e).max() > 0.5                               # the contact term matters


def _moving_reference():
    """Σ_d rises 0.1 m into the stiff direction and turns 0.3 rad about z_0 in 1.5 s."""
    return PoseReference([0.2, 1.7], [P0, [0.02, -0.1, 0.45]], [R0, rot_z(0.3) @ R0])


def test_impedance_error_obeys_the_designed_linear_system():
    """Perfect model: M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A along a moving Σ_d in contact, compared
    with SciPy's solution of that linear system driven by the measured wrench."""
    M, D, K = np.diag([2.0, 1.5, 1.0]), np.diag([20.0, 15.0, 30.0]), np.diag([50.0, 40.0, 100.0])
    reference = _moving_reference()
    spring = _seed_spring((0.0, 0.0, 1e3, 10.0, 0.0, 0.0))
    controller = ImpedanceControl(PRP, reference, kp=K, kd=D, mass=M)
    result = simulate(PRP, controller, q0=Q0, t_final=3.0, dt=1e-3, environment=spring)
    t = result.t
    f_d = np.array([reference.evaluate(s)[3:12].reshape(3, 3).T @ f
                    for s, f in zip(t, result.signals["h_e"][:, :3], strict=True)])   # R_dᵀ f_e
    forcing = interp1d(t, f_d, axis=0, kind="cubic")
    x_err = result.signals["x_err"][:, :3]
    expected = _linear_response(M, D, K, t, forcing, x_err[0], np.zeros(3))
    assert np.abs(f_d).max() > 5.0 and np.abs(x_err).max() > 0.01       # contact and error happen
    np.testing.assert_allclose(x_err, expected, atol=2e-6 * np.abs(x_err).max() + 1e-9)


def test_admittance_inner_loop_tracks_compliant_frame_which_obeys_its_admittance():
    Mt = np.diag([1.0, 1.0, 1.0, 0.1, 0.1, 0.1])
    Dt = np.diag([12.0, 12.0, 12.0, 1.0, 1.0, 1.0])
    Kt = np.diag([20.0, 10.0, 20.0, 5.0, 5.0, 5.0])
    kp, kd = 400.0, 40.0
    reference = _moving_reference()
    spring = _seed_spring((0.0, 0.0, 1e3, 10.0, 0.0, 0.0))
    controller = AdmittanceControl(PRP, reference, kp=kp, kd=kd, mass_t=Mt, kd_t=Dt, kp_t=Kt)
    q0 = Q0 + np.array([0.01, 0.0, -0.01])                 # start off Σ_t: the inner loop must converge
    result = simulate(PRP, controller, q0=q0, t_final=3.0, dt=1e-3, environment=spring)
    t = result.t
    # Inner loop: x̃_ẗ + K_D x̃_ṫ + K_P x̃_t = 0 (with the exact model), from the initial offset.
    x_t = result.signals["x_err"][:, :3]
    I3 = np.eye(3)
    free = _linear_response(I3, kd * I3, kp * I3, t, lambda s: np.zeros(3), x_t[0], np.zeros(3))
    np.testing.assert_allclose(x_t, free, atol=1e-6 * np.abs(x_t[0]).max())
    assert np.abs(x_t[-1]).max() < 1e-6
    # Outer loop: M_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e^d, driven by the measured wrench.
    h_d = np.array([np.kron(np.eye(2), reference.evaluate(s)[3:12].reshape(3, 3)).T @ h
                    for s, h in zip(t, result.signals["h_e"], strict=True)])
    z = result.z[:, :6]
    expected = _linear_response(Mt, Dt, Kt, t, interp1d(t, h_d, axis=0, kind="cubic"), z[0], np.zeros(6))
    assert np.abs(h_d[:, 2]).max() > 10.0 and np.abs(z).max() > 0.005
    np.testing.assert_allclose(z, expected, atol=1e-5 * np.abs(z).max())


def _floor():
    """The seed's A14/A15 environment: a spring along y_0 only (Image(K) = span{y_0}), rest
    surface through x0."""
    return Spring(np.diag([0.0, 1e3, 0.0, 0.0, 0.0, 0.0]), P0)


F_DES = ForceReference([0.0, -0.5, 0.0], start=0.0, duration=0.5)   # seed A14: f_d = [0, −0.5, 0] N


def test_force_control_inner_position_loop_reaches_fd_and_drifts_towards_the_origin():
    """f_e → f_d along y_0; along z_0 (outside Image(K)) x_F = 0 is a position reference, so the
    end effector slides towards z = 0, the seed's 'unexpected' z drift.  Without position gains
    along x and z (the seed's fix) it stays."""
    common = dict(kd=np.diag([20.0, 20.0, 20.0]), kf=1e-4, ki=2e-3, x_F0=[0.0, -0.2, 0.0])
    drift = ForceControl(PRP, F_DES, kp=100.0, inner="position", **common)
    result = simulate(PRP, drift, q0=Q0, t_final=6.0, dt=1e-3, environment=_floor())
    assert result.signals["h_e"][-1, :3] == pytest.approx([0.0, -0.5, 0.0], abs=1e-3)
    z = result.signals["p"][:, 2]
    assert z[0] == pytest.approx(0.5) and z[-1] < 0.01 and np.all(np.diff(z) <= 1e-12)
    fixed = ForceControl(PRP, F_DES, kp=np.diag([0.0, 100.0, 0.0]), inner="position",
                         **{**common, "kd": np.diag([0.0, 20.0, 0.0])})
    result = simulate(PRP, fixed, q0=Q0, t_final=6.0, dt=1e-3, environment=_floor())
    assert result.signals["h_e"][-1, :3] == pytest.approx([0.0, -0.5, 0.0], abs=1e-3)
    assert result.signals["p"][-1] == pytest.approx([0.0, -0.2005, 0.5], abs=1e-5)


def test_force_control_inner_velocity_loop_reaches_fd_without_drift():
    controller = ForceControl(PRP, F_DES, kp=100.0, kd=20.0, kf=4e-4, inner="velocity")
    result = simulate(PRP, controller, q0=Q0, t_final=6.0, dt=1e-3, environment=_floor())
    assert result.signals["h_e"][-1, :3] == pytest.approx([0.0, -0.5, 0.0], abs=1e-4)
    assert result.signals["p"][-1] == pytest.approx([0.0, -0.2005, 0.5], abs=1e-6)


def test_parallel_force_position_meets_fd_and_xd_on_the_unconstrained_directions():
    x_d = np.array([0.0, -0.1, 0.4])          # seed goal 2: y_d above the surface acts as a disturbance
    controller = ParallelForcePosition(PRP, F_DES, kp=100.0, kd=20.0, kf=1e-4, ki=2e-3,
                                       reference=PoseReference.constant(x_d, R0))
    result = simulate(PRP, controller, q0=Q0, t_final=8.0, dt=1e-3, environment=_floor())
    f_e, p_e = result.signals["h_e"][-1, :3], result.signals["p"][-1]
    assert f_e == pytest.approx([0.0, -0.5, 0.0], abs=1e-5)          # zero steady-state force error
    assert p_e[0] == pytest.approx(0.0, abs=1e-9) and p_e[2] == pytest.approx(0.4, abs=1e-6)
    assert p_e[1] == pytest.approx(-0.2005, abs=1e-6)                 # y_d is not reached (constrained)


def test_parallel_force_outside_image_of_K_ends_in_divergence_not_nan():
    """f_d with a z_0 component: no environment force can ever balance it, ∫(f_d − f_e) grows,
    x_F runs away and the simulator stops the run when d1 leaves its range."""
    force = ForceReference([0.0, -0.5, 0.5], duration=0.5)
    controller = ParallelForcePosition(PRP, force, kp=100.0, kd=20.0, kf=1e-4,
                                       ki=np.diag([2e-3, 2e-3, 0.5]),
                                       reference=PoseReference.constant([0.0, -0.1, 0.4], R0))
    with pytest.raises(SimulationDiverged, match="joint limit exceeded on joint d1") as info:
        simulate(PRP, controller, q0=Q0, t_final=10.0, dt=1e-3, environment=_floor())
    partial = info.value.result
    assert partial.status == "diverged" and partial.t[-1] < 10.0
    assert np.all(np.isfinite(partial.q)) and np.all(np.isfinite(partial.tau))
    assert partial.signals["h_e"][-1, 1] == pytest.approx(-0.5, abs=0.02)   # y still regulated

