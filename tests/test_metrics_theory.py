"""The response metrics against closed-form signals, and the theory's predictions against runs.

The metrics (armlab.metrics) are checked on signals whose settling time, oscillation and
overshoot are known analytically; the predictions (armlab.theory) on the seed's scenarios, whose
runs are an independent computation of the same equilibria.
"""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab.metrics import overshoot, response, settling_time, steady_state, tail_slice
from armlab.scenarios import load_scenario
from armlab.theory import (
    compliance_equilibrium,
    computed_torque_equilibrium,
    gravity_gradient_bound,
    predictions,
)

T = np.linspace(0.0, 10.0, 100_001)


def test_a_constant_offset_settles_about_its_final_value():
    tau = 0.5
    e = 0.3 + 0.1 * np.exp(-T / tau)            # leaves the 2 % band of 0.1 at τ ln 50
    assert settling_time(T, e) == pytest.approx(tau * np.log(50.0), abs=2e-4)
    mean, rms, ptp = steady_state(T, e)
    assert mean == pytest.approx(0.3, abs=1e-9) and rms < 1e-9 and ptp < 1e-9


def test_oscillation_is_not_hidden_by_the_mean():
    e = 0.01 + 0.002 * np.sin(2 * np.pi * 2.0 * T)   # the window (0.5 s) holds one period
    mean, rms, ptp = steady_state(T, e)
    assert mean == pytest.approx(0.01, abs=1e-7)
    assert rms == pytest.approx(0.002 / np.sqrt(2), rel=1e-3)
    assert ptp == pytest.approx(0.004, rel=1e-6)
    assert settling_time(T, e) is None or settling_time(T, e) < 10.0


@pytest.mark.parametrize("zeta", [0.2, 0.5, 0.7])
def test_overshoot_of_a_second_order_step(zeta):
    wn = 5.0
    wd = wn * np.sqrt(1 - zeta**2)
    e = np.exp(-zeta * wn * T) * (np.cos(wd * T) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * T))
    expected = 100.0 * np.exp(-zeta * np.pi / np.sqrt(1 - zeta**2))
    # The lightest damping still rings at 1e-4 in the final window, which sets e_∞ (rel 1e-3).
    assert overshoot(T, e) == pytest.approx(expected, rel=1e-3)
    assert overshoot(T, np.exp(-T / 0.5)) < 1e-6   # monotone (e_∞ is a window mean: ~1e-9 off)
    assert overshoot(T, T * np.exp(-T)) is None     # starts at rest: not a step response


def _by_definition(t, e, band=0.02):
    """Settling time and overshoot of one component, written out sample by sample."""
    window = e[tail_slice(t)]
    # The mean about the window's first sample (armlab.kernels.response): a constant's is exact.
    final = window[0] + sum(value - window[0] for value in window) / len(window)
    deviation = [abs(value - final) for value in e]
    peak = max(deviation)
    settle = float(t[0])
    for i in range(len(e) - 1, -1, -1):
        if deviation[i] > band * peak:
            settle = None if i == len(e) - 1 else float(t[i + 1])
            break
    start = e[0] - final
    over = None
    if start != 0.0 and abs(start) >= peak * (1 - 1e-9):
        over = 100.0 * max(0.0, max(-np.sign(start) * (value - final) for value in e)) / abs(start)
    return settle, over


def test_components_measured_together_as_each_alone_and_by_definition():
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 2.0, 401)
    decay = np.exp(-t[:, None] * rng.uniform(1.0, 8.0, 4)) * np.cos(t[:, None] * rng.uniform(0.0, 9.0, 4))
    e = np.column_stack([decay, 0.3 + 0.0 * t, t * np.exp(-t), rng.normal(size=t.size).cumsum()])
    together = response(t, e)
    for k in range(e.shape[1]):
        alone = response(t, e[:, k].copy())
        for name in together._fields:
            column, single = getattr(together, name)[k:k + 1], getattr(alone, name)
            assert np.array_equal(column, single, equal_nan=True), name
        settle, over = _by_definition(t, e[:, k])
        assert settling_time(t, e[:, k]) == settle
        assert (overshoot(t, e[:, k]) is None) == (over is None)
        if over is not None:
            assert overshoot(t, e[:, k]) == pytest.approx(over, rel=1e-12, abs=1e-12)
    with pytest.raises(ValueError, match="one component"):
        settling_time(t, e)


def test_the_seeds_a7_mismatch_settles_at_its_equilibrium():
    """B̂ = B, ĝ from m_Link4 = 0.16 kg: the equilibrium of the seed's experiment,
    q̃ ≈ (0, −0.113, 0.063), where the run and (H1) agree; the whole-model variant settles elsewhere."""
    for name, expected in (("a7_id_mismatch_regulation", [0.0, -0.113, 0.063]),
                              ("a7_id_mismatch_whole_model_regulation", [0.0, -0.0721, 0.0812])):
        scenario = load_scenario(name)
        q_des = scenario.controller.reference.evaluate(10.0)[0]
        predicted = computed_torque_equilibrium(scenario.plant, scenario.controller, q_des)
        np.testing.assert_allclose(predicted, expected, atol=5e-4)
        run = scenario.run()
        np.testing.assert_allclose(run.signals["q_err"][-1], predicted, atol=1e-6)
    seed = load_scenario("a7_id_mismatch")
    assert seed.controller.model.links[2].inertial.mass == 0.2          # B̂ exact
    assert seed.controller.bias_model.links[2].inertial.mass == 0.16    # Ĉ, ĝ wrong


def test_an_exact_model_rests_at_zero_error_as_the_solver_finds():
    """With B̂ = B and ĝ = g, q̃ = 0 solves (H1) exactly: the equilibrium is zero, bit for bit
    what SciPy's solver returns from q̃ = 0, and the run settles there."""
    from scipy.optimize import root

    scenario = load_scenario("a7_id_regulation")
    plant, controller = scenario.plant, scenario.controller
    q_des = controller.reference.evaluate(10.0)[0]
    predicted = computed_torque_equilibrium(plant, controller, q_des)
    kp = np.asarray(controller.kp, dtype=float)

    def residual(e):
        q = q_des - e
        return (armlab.inertia_matrix(controller.model, q) @ (kp @ e)
                + armlab.gravity_torque(controller.model, q) - armlab.gravity_torque(plant, q))

    solved = root(residual, np.zeros_like(q_des), tol=1e-14).x
    assert np.array_equal(predicted, solved) and np.array_equal(np.signbit(predicted), np.signbit(solved))
    np.testing.assert_allclose(scenario.run().signals["q_err"][-1], predicted, atol=1e-6)


def test_compliance_equilibrium_matches_the_run():
    scenario = load_scenario("a11_compliance")
    rows = {p.quantity: p.values for p in predictions(scenario)}
    run = scenario.run()
    for prediction in predictions(scenario):
        np.testing.assert_allclose(prediction.measured(run), prediction.values, atol=1e-5)
    np.testing.assert_allclose(run.signals["p"][-1], rows["equilibrium p_e (H3)"], atol=1e-8)
    force = rows["equilibrium contact force f_e (H3)"]
    np.testing.assert_allclose(run.signals["h_e"][-1, :3], force, atol=1e-5)
    x_e, f = compliance_equilibrium([1.0, 2.0], [0.0, 2.0], [1.0, 1.0], [0.0, 0.0])
    np.testing.assert_allclose(x_e, [1.0, 0.5])
    np.testing.assert_allclose(f, [0.0, 1.0])


@pytest.mark.parametrize("normal", [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]], ids=["pressed", "free"])
def test_compliance_against_a_wall_rests_where_t3_says(normal):
    """The seed's A11 against a wall through its spring's rest point: with free space on the
    start's side x_d lies 10 cm inside the wall and the arm presses (K = k n nᵀ); turned round,
    x_d lies in free space and the arm rests there without touching it."""
    import dataclasses

    from armlab.simulation.environment import PlanarWall

    base = load_scenario("a11_compliance")
    wall = PlanarWall(point=[0.0, -0.2, 0.5], normal=normal, stiffness=2e3, damping=50.0)
    scenario = dataclasses.replace(base, environment=wall)
    rows = {p.quantity: p.values for p in predictions(scenario)}
    x_e, f = rows["equilibrium p_e (H3)"], rows["equilibrium contact force f_e (H3)"]
    run = scenario.run()
    np.testing.assert_allclose(run.signals["p"][-1], x_e, atol=1e-7)
    np.testing.assert_allclose(run.signals["h_e"][-1, :3], f, atol=1e-4)
    if normal[1] < 0:
        assert -0.2 < x_e[1] < -0.1 and f[1] > 1.0    # pressed: between the wall and x_d
    else:
        np.testing.assert_array_equal(f, 0.0)
        np.testing.assert_allclose(x_e, base.controller.reference.positions[-1], atol=1e-12)


def test_option_3_gains_against_the_gravity_gradient_bound():
    alpha = gravity_gradient_bound(armlab.load_robot("prp"))
    assert 1.9 < alpha < 2.1
    seed = load_scenario("a6_pd_desired").controller
    improved = load_scenario("a6_pd_desired_global").controller
    assert np.linalg.eigvalsh(seed.kp).min() < alpha < np.linalg.eigvalsh(improved.kp).min()


def _option_3_equilibria(kp2, kp3=10.0, count=20_001):
    """θ2 of the rest points of PD + g(q_des) on the PRP: K_P q̃ + g(q_des) − g(q) = 0, with
    d3 solved from the third row (g is affine in d3 at fixed θ2, g_1 = 0), over θ2 ∈ [−4π, 4π];
    beyond, K_P2 |θ̃2| exceeds any |g_2| the rows allow."""
    from armlab.dynamics import gravity_torque

    robot = armlab.load_robot("prp")
    q_des = np.array([0.1, np.pi / 3, 0.05])
    g_des = gravity_torque(robot, q_des)
    theta = np.linspace(-4 * np.pi, 4 * np.pi, count)
    residual = np.empty(count)
    for i, th in enumerate(theta):
        a = gravity_torque(robot, np.array([0.1, th, 0.0]))
        b = gravity_torque(robot, np.array([0.1, th, 1.0]))
        d3 = (kp3 * q_des[2] + g_des[2] - a[2]) / (kp3 + b[2] - a[2])
        residual[i] = kp2 * (q_des[1] - th) + g_des[1] - (a[1] + (b[1] - a[1]) * d3)
    return theta[np.flatnonzero(np.diff(np.sign(residual)) != 0)]


def test_the_seeds_option_3_has_a_single_equilibrium():
    """K_P2 = 0.5 < α: Tomei's condition fails, yet q_des is the only rest point (a minimum of
    the closed-loop potential: K_P + ∂g/∂q positive definite), so the convergence is global and
    the run from (0, −3, 0.3) reaches q_des; three rest points appear at K_P2 = 0.39."""
    from armlab.dynamics import gravity_torque

    (only,) = _option_3_equilibria(0.5)
    assert only == pytest.approx(np.pi / 3, abs=1e-3)
    assert len(_option_3_equilibria(0.39)) == 3 and len(_option_3_equilibria(0.40)) == 1
    robot, q_des = armlab.load_robot("prp"), np.array([0.1, np.pi / 3, 0.05])
    gradient = np.column_stack([(gravity_torque(robot, q_des + e) - gravity_torque(robot, q_des - e)) / 2e-6
                                for e in np.eye(3) * 1e-6])
    hessian = np.diag([25.0, 0.5, 10.0]) + gradient
    assert np.linalg.eigvalsh(0.5 * (hessian + hessian.T)).min() > 0.1
    scenario = load_scenario("a6_pd_desired_far")
    assert np.array_equal(scenario.controller.kp, load_scenario("a6_pd_desired").controller.kp)
    run = scenario.run()
    np.testing.assert_allclose(run.q[-1], q_des, atol=1e-4)
    assert "globally asymptotically stable" in scenario.description
    assert "local" not in load_scenario("a6_pd_desired").description.replace("globally", "")


def test_impedance_residual_vanishes_along_the_run():
    """(H5) holds along the whole A12 regulation run: the residual is the finite-difference
    error, small against the terms it balances."""
    scenario = load_scenario("a12_impedance_regulation")
    (prediction,) = predictions(scenario)
    run = scenario.run()
    rms = prediction.measured(run)
    assert np.all(rms < 5e-4 * np.abs(run.signals["h_e"][:, :3]).max())


def test_predictions_travel_to_worker_processes():
    import pickle

    for name in ("a7_id_mismatch", "a11_compliance", "a12_impedance_regulation", "a15_parallel_contact"):
        for prediction in pickle.loads(pickle.dumps(predictions(load_scenario(name)))):
            assert prediction.quantity


def _predicted_scenarios():
    from armlab.scenarios import list_scenarios

    return [s.name for s in list_scenarios() if s.plant.name.startswith("prp") or s.plant.name == "link1"]


@pytest.mark.parametrize("name", _predicted_scenarios())
def test_every_printed_prediction_matches_its_run(name):
    """What the report prints as theory lies within its stated tolerance of the run beside it;
    a scenario whose theory cannot be measured on its run prints none."""
    scenario = load_scenario(name)
    rows = predictions(scenario)
    if not rows:
        return
    run = scenario.run(on_divergence="return")
    for prediction in rows:
        assert prediction.measured is not None, prediction.quantity
        measured = prediction.measured(run)
        assert np.all(np.abs(measured - prediction.values) <= prediction.tolerance), (
            prediction.quantity, measured, prediction.values)


def test_the_diagonal_pose_is_predicted_by_the_closed_loop_statics():
    """Σ_d turned by π/4 about z_0 against a spring about Σ_r ∦ Σ_d: (H3) would put the arm at
    (0.0667, −0.2, 0.4) pressing 1.33 N; the PRP cannot turn without moving, and the rest point
    of the closed loop is θ2 = 0.648 rad, p = (0.151, −0.1997, 0.4), f_y = 2.710 N.  The
    prediction is that rest point, labelled (H6), and the run rests on it."""
    scenario = load_scenario("a11_compliance_diagonal")
    rows = {p.quantity: p.values for p in predictions(scenario)}
    assert set(rows) == {"equilibrium p_e (H6)", "equilibrium contact force f_e (H6)"}
    np.testing.assert_allclose(rows["equilibrium p_e (H6)"], [0.15116, -0.19973, 0.4], atol=2e-5)
    np.testing.assert_allclose(rows["equilibrium contact force f_e (H6)"], [0.0, 2.7100, 0.0], atol=2e-4)
    run = scenario.run()
    assert run.q[-1, 1] == pytest.approx(0.6479, abs=1e-4)
    np.testing.assert_allclose(run.signals["p"][-1], rows["equilibrium p_e (H6)"], atol=1e-8)


def test_the_closed_loop_statics_is_the_minimum_of_the_prp_potential():
    """An energy minimisation written out for the PRP alone agrees with armlab.statics on the
    diagonal pose.  p = (r sin θ2, −r cos θ2, 0.4 + d1) with r = 0.2 − d3; R_e is the rest
    orientation turned by θ2 about z_0 (= x_d = x_r), R_d the same turned by ψ = π/4.  With
    K_P = diag(20, 10, 20; 50) in Σ_d and the spring 10⁴ along z_r = −y_0, 10 about x_r:

        U = ½ (10 a_y² + 20 a_z²) + ½ 10⁴ (r cos θ2 − 0.2)² + ½ 50 (θ2 − ψ)² + ½ 10 θ2²,

    a = r u − p_d along Σ_d's y and z axes (u the arm's direction in the x_0 y_0 plane); z_0 is
    free of the spring, so d1 reaches z_d.  U is quadratic in r at fixed θ2: r is solved
    exactly, θ2 on a grid of 10⁻⁶ rad."""
    from armlab.statics import compliance_statics

    scenario = load_scenario("a11_compliance_diagonal")
    psi = np.pi / 4
    theta = np.linspace(0.55, 0.75, 200_001)
    u = np.stack([np.sin(theta), -np.cos(theta)])
    R_d = scenario.controller.reference.rotations[-1]
    ey, ez = R_d[:2, 1], R_d[:2, 2]             # Σ_d's y and z axes, in the x_0 y_0 plane
    p_d = np.array([0.1, -0.1])
    uy, uz, c = ey @ u, ez @ u, np.cos(theta)
    r = ((10 * uy * (p_d @ ey) + 20 * uz * (p_d @ ez) + 1e4 * 0.2 * c)
         / (10 * uy**2 + 20 * uz**2 + 1e4 * c**2))
    U = (0.5 * (10 * (r * uy - p_d @ ey) ** 2 + 20 * (r * uz - p_d @ ez) ** 2)
         + 0.5 * 1e4 * (r * c - 0.2) ** 2 + 0.5 * 50 * (theta - psi) ** 2 + 0.5 * 10 * theta**2)
    k = int(np.argmin(U))
    statics = compliance_statics(scenario.plant, scenario.controller, scenario.environment,
                                 scenario.simulation["q0"])
    assert statics.q[1] == pytest.approx(theta[k], abs=2e-6)
    assert 0.2 - statics.q[2] == pytest.approx(r[k], abs=1e-6)
    assert statics.q[0] == pytest.approx(0.0, abs=1e-9)
    # The force on the environment along y_0: the spring along z_r = −y_0, 10⁴ (0.2 − r cos θ2).
    assert statics.f_e[1] == pytest.approx(1e4 * (0.2 - r[k] * c[k]), rel=1e-4)
