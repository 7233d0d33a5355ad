"""Joint-space PD + gravity (A6) and inverse dynamics (A7) against theory."""

import numpy as np
import pytest

import armlab
from armlab.control.base import ProtocolError
from armlab.control.joint_space import JointInverseDynamics, JointPDGravity
from armlab.errors import ControllerSpecError
from armlab.references.joint import Constant, Sinusoid, ViaPoints
from armlab.simulation import simulate

PRP = armlab.load_robot("prp")
TARGET = np.array([0.15, np.pi / 6, 0.1])
KP, KD = [25, 0.5, 10], [10, 0.08, 3]


def test_perfect_model_inverse_dynamics_follows_the_designed_second_order_system():
    # (C3) with ω_n = 5, ζ = 1 from rest at q0: q̃(t) = q̃0 (1 + ω t) e^{−ω t}.
    omega = 5.0
    controller = JointInverseDynamics.from_poles(PRP, Constant(TARGET), omega, 1.0)
    result = simulate(PRP, controller, q0=[0, 0, 0], t_final=2.0, dt=1e-3)
    t = result.t[:, None]
    expected = TARGET * (1 + omega * t) * np.exp(-omega * t)
    np.testing.assert_allclose(result.signals["q_err"], expected, atol=1e-9)


def test_underdamped_design_overshoots_as_designed():
    omega, zeta = 8.0, 0.3
    controller = JointInverseDynamics.from_poles(PRP, Constant(TARGET), omega, zeta)
    result = simulate(PRP, controller, q0=[0, 0, 0], t_final=2.0, dt=1e-3)
    wd = omega * np.sqrt(1 - zeta**2)
    t = result.t[:, None]
    expected = TARGET * np.exp(-zeta * omega * t) * (np.cos(wd * t) + zeta * omega / wd * np.sin(wd * t))
    np.testing.assert_allclose(result.signals["q_err"], expected, atol=1e-8)


def test_wrong_link4_mass_leaves_steady_state_error_on_joints_2_and_3_only():
    model = PRP.with_link_mass("link4", 0.16)
    reference = ViaPoints([1, 2, 5, 6], [[0, 0, 0], [0.1, np.pi / 3, 0.05], [0.1, np.pi / 3, 0.05], TARGET])
    perfect = simulate(PRP, JointInverseDynamics(PRP, reference, 25.0, 10.0), q0=[0, 0, 0],
                       t_final=10.0, dt=2e-3)
    wrong = simulate(PRP, JointInverseDynamics(model, reference, 25.0, 10.0), q0=[0, 0, 0],
                     t_final=10.0, dt=2e-3)
    assert np.abs(perfect.signals["q_err"]).max() < 1e-8
    final = np.abs(wrong.signals["q_err"][-1])
    assert final[0] < 1e-9 and final[1] > 1e-3 and final[2] > 1e-3
    # Steady state of a regulation (q̈ = q̇ = 0 in (C2)): B̂ K_P q̃ + ĝ(q) = g(q), so
    # K_P q̃ = B̂⁻¹ (g − ĝ) — checked with the armlab.dynamics front end, not the controller.
    regulation = simulate(PRP, JointInverseDynamics(model, Constant(TARGET), 25.0, 10.0), q0=[0, 0, 0],
                          t_final=20.0, dt=2e-3)
    q_end = regulation.q[-1]
    residual = armlab.gravity_torque(PRP, q_end) - armlab.gravity_torque(model, q_end)
    np.testing.assert_allclose(25.0 * regulation.signals["q_err"][-1],
                               np.linalg.solve(armlab.inertia_matrix(model, q_end), residual), atol=1e-8)


def test_pd_without_compensation_settles_where_kp_error_balances_gravity():
    runs = {mode: simulate(PRP, JointPDGravity(PRP, Constant(TARGET), KP, KD, mode), q0=[0, 0, 0],
                           t_final=15.0, dt=1e-3) for mode in ("online", "none", "desired")}
    np.testing.assert_allclose(runs["online"].signals["q_err"][-1], 0, atol=1e-6)
    np.testing.assert_allclose(runs["desired"].signals["q_err"][-1], 0, atol=1e-6)
    error = runs["none"].signals["q_err"][-1]
    assert abs(error[0]) < 1e-9 and abs(error[1]) > 1e-2 and abs(error[2]) > 1e-2
    # Equilibrium of (C1) with ĝ = 0: K_P q̃ = g(q).
    gravity = armlab.gravity_torque(PRP, runs["none"].q[-1])
    np.testing.assert_allclose(np.array(KP) * error, gravity, atol=1e-6)


def test_desired_compensation_has_a_worse_transient_than_online():
    online = simulate(PRP, JointPDGravity(PRP, Constant(TARGET), KP, KD, "online"), q0=[0, 0, 0],
                      t_final=3.0, dt=1e-3)
    desired = simulate(PRP, JointPDGravity(PRP, Constant(TARGET), KP, KD, "desired"), q0=[0, 0, 0],
                       t_final=3.0, dt=1e-3)
    iae = [np.abs(r.signals["q_err"][:, 2]).sum() for r in (online, desired)]
    assert iae[1] > iae[0]


def test_high_gain_saturation_slows_joint_1_only():
    controller = JointInverseDynamics.from_poles(PRP, Constant(TARGET), 30.0, 1.0)
    free = simulate(PRP, controller, q0=[0, 0, 0], t_final=2.0, dt=1e-3)
    clipped = simulate(PRP, controller, q0=[0, 0, 0], t_final=2.0, dt=1e-3, torque_limit=20.0)
    peak = np.abs(free.tau).max(axis=0)
    assert peak[0] > 100 and peak[1] < 20
    assert np.abs(clipped.tau).max() <= 20.0
    assert np.any(np.abs(clipped.tau[:, 0]) == 20.0)
    # Joint 1 reaches 95 % of its step later when clipped.
    def rise(result):
        return result.t[np.argmax(result.q[:, 0] >= 0.95 * TARGET[0])]
    assert rise(clipped) > rise(free) + 0.02
    np.testing.assert_allclose(clipped.signals["q_err"][-1], 0, atol=1e-6)


def test_gains_must_be_symmetric_positive_semidefinite():
    # Bad values are ValueErrors (a negative gain once raised a TypeError).
    with pytest.raises(ControllerSpecError, match="kp") as bad_gain:
        JointPDGravity(PRP, Constant(TARGET), [1, -1, 1], 1.0)
    assert isinstance(bad_gain.value, ValueError) and not isinstance(bad_gain.value, TypeError)
    with pytest.raises(ControllerSpecError, match="kp: a gain must be symmetric"):
        JointPDGravity(PRP, Constant(TARGET), [[1, 2, 0], [0, 1, 0], [0, 0, 1]], 1.0)
    with pytest.raises(ControllerSpecError, match="compensation"):
        JointPDGravity(PRP, Constant(TARGET), 1.0, 1.0, "sometimes")
    with pytest.raises(ProtocolError, match="reference"):
        JointInverseDynamics(PRP, Constant([0, 0]), 1.0, 1.0)


def test_computed_torque_with_diagonal_gains_skips_only_zero_terms():
    from armlab.control.joint_space import joint_inverse_dynamics_law

    controller = JointInverseDynamics.from_poles(PRP, Sinusoid([0.1, 1.0, 0.05], [0.05, 0.3, 0.02],
                                                              [2.0, 1.0, 3.0]), [3.0, 5.0, 7.0])
    params = controller.params()
    assert params.diagonal[0] == 1                               # from_poles: diagonal gains
    general = params._replace(diagonal=np.array([0]))
    rng = np.random.default_rng(3)
    for _ in range(20):
        q, qd = rng.normal(size=(2, 3))
        t = rng.uniform(0, 5)
        outs = []
        for p in (params, general):
            tau, signals = np.zeros(3), np.zeros(12)
            joint_inverse_dynamics_law(t, q, qd, np.zeros(0), np.zeros(6), p, tau, np.zeros(0), signals)
            outs.append((tau, signals))
        np.testing.assert_array_equal(outs[0][0], outs[1][0])
        np.testing.assert_array_equal(outs[0][1], outs[1][1])
    full = JointInverseDynamics(PRP, controller.reference, [[25, 1, 0], [1, 25, 0], [0, 0, 25]], 10.0)
    assert full.params().diagonal[0] == 0                        # coupled gains: the full sum


NUMERIC_RUN_PROGRAM = """
import numpy as np
import armlab
from armlab.control.joint_space import JointInverseDynamics
from armlab.kernels.dynamics import rnea_into
from armlab.kernels.plant import rnea_packed
from armlab.references.joint import Constant
from armlab.simulation import simulate
prp = armlab.load_robot("prp")
controller = JointInverseDynamics(prp, Constant([0.15, 0.5, 0.1]), 25.0, 10.0, dynamics="numeric")
simulate(prp, controller, q0=[0, 0, 0], t_final=0.01, dt=1e-3, dynamics="numeric")
armlab.inverse_dynamics(prp, [0.1, 0.2, 0.3], [0, 0, 0], [1, 2, 3])
armlab.inverse_dynamics(prp, [0.1, 0.2, 0.3], [0, 1, 0], [1, 2, 3], h_e=np.ones(6), gravity=False)
armlab.kinetic_energy(prp, [0.1, 0.2, 0.3], [1, 2, 3])
print(len(rnea_packed.signatures), len(rnea_into.signatures))
"""


def test_numeric_computed_torque_run_compiles_one_rnea_for_plant_and_law(tmp_path):
    # The law's B̂ y + n̂ is the plant's rnea_packed with a zero wrench (the compiled function
    # armlab.specialise.numeric_inverse_dynamics), and so are armlab.inverse_dynamics (with or
    # without a wrench and gravity) and the kinetic energy: a fresh process that runs (C2)
    # numerically and calls the public functions compiles rnea_packed for one signature and
    # not the RNEA of the m, ws kernels (rnea_into).
    import os
    import subprocess
    import sys

    # With empty caches (a cached function loaded from disk compiles nothing either way).
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    done = subprocess.run([sys.executable, "-c", NUMERIC_RUN_PROGRAM], capture_output=True,
                          text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["1", "0"]


QUIET_PROGRAM = """
import warnings
import armlab
with warnings.catch_warnings():          # as a Dask worker's first task may first import them
    warnings.simplefilter("ignore")
    from armlab.control.joint_space import JointInverseDynamics
    from armlab.references.joint import Constant
    from armlab.simulation import simulate
prp = armlab.load_robot("prp")
for dynamics in ("numeric", "auto"):
    controller = JointInverseDynamics(prp, Constant([0.15, 0.5, 0.1]), 25.0, 10.0, dynamics=dynamics)
    simulate(prp, controller, q0=[0, 0, 0], t_final=0.01, dt=1e-3)
"""


def test_a_compiled_function_in_a_law_prints_no_numba_warning_whenever_armlab_was_imported():
    # numba warns at every typing of a first-class function value; armlab's filter is set by
    # `import armlab`, so a module first imported inside a catch_warnings block cannot lose it.
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", QUIET_PROGRAM], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "First-class function" not in done.stderr, done.stderr
