"""Before an RK4 run the closed loop's fastest mode at q0 is estimated from the law's gains
and B(q0) (S6); a step too large for it is warned about with the largest stable step."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import armlab
from armlab.control.joint_space import JointInverseDynamics, JointPDGravity
from armlab.references.joint import Constant
from armlab.simulation.step_check import StepSizeWarning, check_step, inertia_at, rk4_largest_step

LINK = armlab.load_robot("link1")   # I = 0.1 kg·m² about the axis, F_v = 0.05 N·m·s/rad


def test_rk4_reach_on_the_axes_is_the_textbook_one():
    """RK4's stability interval: 2.7853 on the negative real axis, 2√2 on the imaginary one
    (Hairer & Wanner, Solving ODEs II, §IV.2)."""
    assert rk4_largest_step([-1.0]) == pytest.approx(2.785293563, rel=1e-8)
    assert rk4_largest_step([-1000.0, -1.0]) == pytest.approx(2.785293563e-3, rel=1e-8)
    assert rk4_largest_step([1j, -1j]) == pytest.approx(2 * np.sqrt(2), rel=1e-8)
    assert rk4_largest_step([0.5]) == np.inf   # unstable in itself: not the step's to fix


def _stiff_pd(kp=1e7):
    # K_D for a double pole at −√(K_P/I) counting the plant's F_v: (F_v + K_D)² = 4 K_P I.
    kd = 2 * np.sqrt(kp * 0.1) - 0.05
    return JointPDGravity(model=LINK, reference=Constant([0.1]), kp=kp, kd=kd)


def _run(controller, dt):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = armlab.simulate(LINK, controller, q0=[0.0], t_final=round(0.05 / dt) * dt, dt=dt,
                                 on_divergence="return")
    return result, [w for w in caught if issubclass(w.category, StepSizeWarning)]


def test_a_pd_gain_too_stiff_for_the_step_is_warned_about_with_the_stable_step():
    """A double pole at −10⁴ 1/s: RK4 holds it to dt = 2.785/10⁴ s.  The estimate agrees with
    the simulator itself: 10 % below it the run settles, 10 % above it diverges."""
    controller = _stiff_pd()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StepSizeWarning)
        limit = check_step(LINK, controller, [0.0], 1e-3)
    assert limit == pytest.approx(2.785293563e-4, rel=1e-5)
    result, warned = _run(controller, 1e-3)
    assert len(warned) == 1 and "stable only for dt ≤ 0.000279 s" in str(warned[0].message)
    assert result.status == "diverged"
    below, warned = _run(controller, 0.9 * limit)
    assert below.status == "ok" and not warned
    above, warned = _run(controller, 1.1 * limit)
    assert above.status == "diverged" and len(warned) == 1


def test_computed_torque_modes_are_its_designed_poles():
    """C2 with an exact model cancels the plant's F_v too (n̂ holds F̂_v q̇): at rest
    q̃̈ + K_D q̃̇ + K_P q̃ = 0, and K_P = 4·10⁶, K_D = 4·10³ put a double pole at −2000 1/s."""
    controller = JointInverseDynamics(model=LINK, reference=Constant([0.1]), kp=4e6, kd=4e3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StepSizeWarning)
        limit = check_step(LINK, controller, [0.0], 1e-3)
    assert limit == pytest.approx(2.785293563 / 2000, rel=1e-5)
    # And the simulator agrees: 10 % below the limit the run settles, 10 % above it diverges.
    assert _run(controller, 0.9 * limit)[0].status == "ok"
    assert _run(controller, 1.1 * limit)[0].status == "diverged"


def test_the_seed_scenarios_pass_without_a_step_warning():
    from armlab.scenarios import load_scenario

    for name in ("a6_pd_online", "a7_id_high_gain", "a8_case1_sine"):
        scenario = load_scenario(name)
        with warnings.catch_warnings():
            warnings.simplefilter("error", StepSizeWarning)
            scenario.run(t_final=0.1)


@pytest.mark.parametrize("name", ["prp", "puma560"])
def test_the_mass_matrix_from_the_kinetic_energy_is_the_crba_one(name):
    """inertia_at (B by polarisation of T = ½ q̇ᵀBq̇, with the loop's energy kernel) against
    armlab.inertia_matrix (the CRBA), at random configurations."""
    robot = armlab.load_robot(name)
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = rng.uniform(-1.0, 1.0, robot.n) * 0.3
        B = armlab.inertia_matrix(robot, q)
        assert np.abs(inertia_at(robot, q) - B).max() <= 1e-12 * np.abs(B).max()


def test_the_mass_matrix_from_a_robots_generated_energy_kernel_is_the_crba_one():
    """The same with the PRP's generated kernel, which the simulator passes for its plant."""
    from armlab.specialise import plant_kernels

    robot = armlab.load_robot("prp")
    _, _, kinetic_energy = plant_kernels(robot, "closed_form")
    for q in ([0.1, 0.3, -0.05], [-0.1, -1.2, 0.2]):
        B = armlab.inertia_matrix(robot, np.array(q))
        assert np.abs(inertia_at(robot, q, kinetic_energy) - B).max() <= 1e-12 * np.abs(B).max()


def test_the_norm_bound_shortcut_gives_the_eigenvalues_answer():
    """check_step returns None at once when the largest row sum of |A| times dt is at most 1
    (every |λ| is below it); otherwise it takes the eigenvalues as before.  Across gains from
    far below to far above the boundary its answer is the one the eigenvalues alone give, and
    both branches are taken."""
    from armlab.simulation.step_check import loop_gains, system_matrix

    prp = armlab.load_robot("prp")
    q0, dt = np.array([0.1, 0.4, 0.05]), 1e-3
    branches = set()
    for omega in np.geomspace(1.0, 3000.0, 25):
        controller = JointInverseDynamics.from_poles(prp, Constant(q0), omega)
        A = system_matrix(prp, *loop_gains(controller, q0), q0)
        eigenvalues = np.linalg.eigvals(A)
        expected = None if np.abs(eigenvalues).max() * dt <= 1.0 else rk4_largest_step(eigenvalues)
        branches.add((np.abs(A).sum(axis=1).max() * dt <= 1.0, expected is None))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", StepSizeWarning)
            assert check_step(prp, controller, q0, dt) == expected
    assert branches == {(True, True), (False, True), (False, False)}
