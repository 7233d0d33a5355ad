"""The closed-loop simulator: integrator order, energy, ZOH, saturation, disturbances,
divergence, determinism, results I/O."""

import dataclasses

import numpy as np
import pytest
from numba import njit

import armlab
from armlab.control.adaptive import SlotineLi1DoF
from armlab.control.entry import generated_entry
from armlab.control.joint_space import JointInverseDynamics, JointPDGravity
from armlab.references.joint import Constant, Sinusoid
from armlab.simulation import SimulationDiverged, SimulationError, loop, simulate, simulate_batch, simulator
from armlab.simulation.disturbances import ConstantTorque, QuadraticFriction, SinusoidalTorque, StepTorque
from armlab.simulation.results import SimulationResult

PRP = armlab.load_robot("prp")
LINK1 = armlab.load_robot("link1")


def free(robot):
    """τ = 0: a PD with zero gains and no compensation."""
    return JointPDGravity(robot, Constant(np.zeros(robot.n)), 0.0, 0.0, "none")


def pd(robot, kp, kd, target, compensation="online"):
    return JointPDGravity(robot, Constant(target), kp, kd, compensation)


def test_rk4_error_shrinks_sixteenfold_when_the_step_halves():
    # Free motion of the PRP (τ = 0) over 1 s; the reference is the error-controlled DOP853.
    kwargs = dict(q0=[0.0, 0.3, 0.05], qd0=[0.1, 2.0, 0.3], t_final=1.0, limit_margin=1e9)
    exact = simulate(PRP, free(PRP), dt=0.01, method="adaptive", rtol=1e-13, atol=1e-13, **kwargs)
    errors = []
    for dt in (0.01, 0.005, 0.0025):
        result = simulate(PRP, free(PRP), dt=dt, **kwargs)
        errors.append(np.abs(result.q[-1] - exact.q[-1]).max())
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 13) & (ratios < 19)), (errors, ratios)


def test_energy_is_conserved_without_torque_or_friction():
    # T = ½ q̇ᵀ(B q̇) and U (D6, D7) from armlab.dynamics, evaluated on the logged states: the
    # RNEA gives B q̇ here and the bias in the plant, but B of the plant's q̈ comes from the
    # CRBA, and the drift measures the integrator (T is checked against Pinocchio elsewhere).
    result = simulate(PRP, free(PRP), q0=[0.0, 0.3, 0.05], qd0=[0.1, 0.5, 0.0], t_final=10.0,
                      dt=5e-4, limit_margin=1e9)
    T = np.array([armlab.kinetic_energy(PRP, q, qd) for q, qd in zip(result.q[::200], result.qd[::200])])
    U = np.array([armlab.potential_energy(PRP, q) for q in result.q[::200]])
    E = T + U
    scale = max(np.abs(T).max(), np.abs(U).max())
    assert np.abs(E - E[0]).max() / scale < 1e-8
    assert T.max() > 100 * T[0]          # the run did exchange energy (joint 3 falls)


def test_adaptive_and_rk4_agree_in_closed_loop_and_log_the_same_signals():
    controller = pd(PRP, [25, 0.5, 10], [10, 0.08, 3], [0.1, 1.0, 0.05])
    fixed = simulate(PRP, controller, q0=[0, 0, 0], t_final=1.0, dt=1e-3)
    reference = simulate(PRP, controller, q0=[0, 0, 0], t_final=1.0, dt=1e-3, method="adaptive")
    assert fixed.q.shape == reference.q.shape
    np.testing.assert_allclose(fixed.q, reference.q, atol=1e-9)
    np.testing.assert_allclose(fixed.signals["q_err"], reference.signals["q_err"], atol=1e-9)
    np.testing.assert_allclose(fixed.tau, reference.tau, atol=1e-7)


def test_implicit_integrators_see_the_same_right_hand_side():
    # Radau's numerical Jacobian evaluates ẋ on strided columns of SciPy's arrays.
    controller = pd(PRP, [25, 0.5, 10], [10, 0.08, 3], [0.1, 1.0, 0.05])
    kwargs = dict(q0=[0, 0, 0], t_final=0.5, dt=1e-3, method="adaptive", rtol=1e-9, atol=1e-11)
    explicit = simulate(PRP, controller, **kwargs)
    implicit = simulate(PRP, controller, integrator="Radau", **kwargs)
    np.testing.assert_allclose(implicit.q, explicit.q, atol=1e-7)


def test_sampled_control_holds_the_torque_for_one_period():
    controller = pd(PRP, [25, 0.5, 10], [10, 0.08, 3], [0.1, 1.0, 0.05])
    result = simulate(PRP, controller, q0=[0, 0, 0], t_final=0.2, dt=1e-3, control_period=0.01)
    blocks = result.tau[:200].reshape(20, 10, 3)
    assert np.all(blocks == blocks[:, :1, :])
    assert not np.all(blocks[1:, 0] == blocks[:-1, 0])
    continuous = simulate(PRP, controller, q0=[0, 0, 0], t_final=0.2, dt=1e-3)
    assert 1e-6 < np.abs(continuous.q - result.q).max() < 0.1
    with pytest.raises(SimulationError, match="control_period"):
        simulate(PRP, controller, q0=[0, 0, 0], t_final=0.2, dt=1e-3, control_period=0.0015)


def test_saturation_clips_the_applied_torque_and_logs_the_command():
    controller = pd(PRP, [900, 5, 100], [60, 0.1, 10], [0.15, 0.5, 0.1])
    free_run = simulate(PRP, controller, q0=[0, 0, 0], t_final=0.5, dt=1e-3)
    clipped = simulate(PRP, controller, q0=[0, 0, 0], t_final=0.5, dt=1e-3, torque_limit=20.0)
    assert np.abs(free_run.tau[:, 0]).max() > 100
    assert np.abs(clipped.tau).max() <= 20.0
    assert np.abs(clipped.signals["tau_cmd"][:, 0]).max() > 20.0
    assert np.abs(clipped.q[:, 0] - free_run.q[:, 0]).max() > 1e-2


def test_disturbances_enter_the_plant_as_torques():
    # link1 at rest upright (q = 0, g(0) = 0) under τ = 0 and a constant disturbance: q̈ = c / I.
    result = simulate(LINK1, free(LINK1), q0=[0.0], t_final=0.01, dt=1e-3,
                      disturbance=[ConstantTorque(0.3), StepTorque(0.005, 0.2)])
    np.testing.assert_allclose(result.qdd[0], 0.3 / 0.1, rtol=1e-12)
    np.testing.assert_allclose(result.signals["tau_dist"][:, 0],
                               np.where(result.t >= 0.005, 0.5, 0.3))
    sine = SinusoidalTorque(0.4, 3.0, 0.2)
    result = simulate(LINK1, free(LINK1), q0=[0.0], qd0=[1.5], t_final=0.05, dt=1e-3,
                      disturbance=[sine, QuadraticFriction(2.0)])
    expected = 0.4 * np.sin(3.0 * result.t + 0.2) - 2.0 * result.qd[:, 0] * np.abs(result.qd[:, 0])
    np.testing.assert_allclose(result.signals["tau_dist"][:, 0], expected, rtol=1e-12)


def test_divergence_stops_the_run_keeps_the_data_and_says_what_and_when():
    # A stiff PD on the light joint 2 with a far too large step: RK4 is unstable.
    controller = pd(PRP, [25, 0.5, 10], [10, 2.0, 3], [0.1, 1.0, 0.05])
    with pytest.raises(SimulationDiverged) as caught:
        simulate(PRP, controller, q0=[0, 0, 0], t_final=5.0, dt=0.01)
    result = caught.value.result
    assert result.status == "diverged"
    assert "theta2" in str(caught.value) and "t = " in str(caught.value)
    assert 1 < len(result.t) < 501
    assert np.all(np.isfinite(result.q))
    returned = simulate(PRP, controller, q0=[0, 0, 0], t_final=5.0, dt=0.01, on_divergence="return")
    np.testing.assert_array_equal(returned.q, result.q)


def test_same_run_twice_is_bit_identical():
    controller = pd(PRP, [25, 0.5, 10], [10, 0.08, 3], [0.1, 1.0, 0.05], "desired")
    kwargs = dict(q0=[0, 0, 0], t_final=0.5, dt=1e-3, disturbance=SinusoidalTorque(0.1, 2.0))
    first = simulate(PRP, controller, **kwargs)
    second = simulate(PRP, controller, **kwargs)
    for name, array in first.groups().items():
        assert array.tobytes() == second.groups()[name].tobytes(), name


@pytest.mark.parametrize("method", ["rk4", "adaptive"])
def test_a_law_entry_gives_the_results_of_the_law_called_by_address(method, monkeypatch):
    entries = []
    addresses = loop.addresses

    def spy(*args, **kwargs):
        entries.append(args[6] if len(args) > 6 else kwargs.get("entry"))
        return addresses(*args, **kwargs)

    monkeypatch.setattr(loop, "addresses", spy)
    cases = [(PRP, pd(PRP, [25, 0.5, 10], [10, 0.08, 3], [0.1, 1.0, 0.05], "desired")),
             (PRP, JointInverseDynamics.from_poles(PRP.with_link_mass("link4", 0.16),
                                                   Constant([0.1, 1.0, 0.05]), 5.0)),
             (LINK1, SlotineLi1DoF(LINK1, Sinusoid([0.0], [0.5], [1.0]), 1.0, 1.0, [1.0, 1.0, 1.0]))]
    for plant, controller in cases:
        kwargs = dict(q0=np.zeros(plant.n), t_final=0.3, dt=1e-3, method=method)
        entries.clear()
        with_entry = simulate(plant, controller, **kwargs)
        # The path of a law that has no entry (one that cannot be imported by name).
        with monkeypatch.context() as patched:
            patched.setattr(simulator, "generated_entry", lambda law: None)
            by_address = simulate(plant, controller, **kwargs)
        assert entries == [generated_entry(type(controller).law), None] and entries[0] is not None
        assert np.abs(with_entry.q[-1] - with_entry.q[0]).max() > 1e-3   # the arm moved
        for name, array in with_entry.groups().items():
            assert array.tobytes() == by_address.groups()[name].tobytes(), (type(controller), name)


@pytest.mark.parametrize("name", ["a09_pd_goal", "a14_force_inner_position"])
def test_task_space_and_interaction_laws_run_through_their_entries_as_by_address(name, monkeypatch):
    from armlab.scenarios import load_scenario

    scenario = load_scenario(name)
    assert generated_entry(type(scenario.controller).law) is not None
    with_entry = scenario.run(t_final=0.3)
    with monkeypatch.context() as patched:
        patched.setattr(simulator, "generated_entry", lambda law: None)
        by_address = scenario.run(t_final=0.3)
    assert np.abs(with_entry.q[-1] - with_entry.q[0]).max() > 1e-4   # the arm moved
    for group, array in with_entry.groups().items():
        assert array.tobytes() == by_address.groups()[group].tobytes(), (name, group)


def test_an_entry_runs_only_the_law_it_was_generated_for(monkeypatch):
    @njit(cache=False)
    def no_torque(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
        for i in range(q.shape[0]):
            tau_out[i] = 0.0
        for i in range(signals_out.shape[0]):
            signals_out[i] = 0.0

    controller = pd(PRP, [25, 0.5, 10], [10, 0.08, 3], [0.1, 1.0, 0.05])
    kwargs = dict(q0=[0, 0, 0], t_final=0.2, dt=1e-3)
    # A law made inside a function cannot be imported by name: no entry, called by address.
    assert generated_entry(no_torque) is None
    # A subclass with another law runs that law, not its parent's entry.
    other = dataclasses.make_dataclass("NoTorque", [], bases=(JointPDGravity,), frozen=True, eq=False,
                                       namespace={"law": no_torque})
    moved = simulate(PRP, controller, **kwargs)
    assert np.abs(moved.tau).max() > 0.0
    fields = {f.name: getattr(controller, f.name) for f in dataclasses.fields(controller)}
    still = simulate(PRP, other(**fields), **kwargs)
    assert np.abs(still.tau).max() == 0.0
    # Nor when the law is replaced on the class itself.
    monkeypatch.setattr(JointPDGravity, "law", no_torque)
    result = simulate(PRP, controller, **kwargs)
    assert np.abs(result.tau).max() == 0.0


@pytest.mark.parametrize("method", ["rk4", "adaptive"])
def test_every_signal_is_its_own_contiguous_block_of_the_log(method):
    # Computed torque logs q_des, q_err, qd_err and y: each must hold its own values (not a
    # neighbour's columns) and be a C-contiguous (N, w) view, not a copy, of the run's log.
    reference = Sinusoid([0.1, 1.0, 0.05], [0.05, 0.3, 0.02], [2.0, 1.0, 3.0])
    controller = JointInverseDynamics.from_poles(PRP.with_link_mass("link4", 0.16), reference, 5.0)
    result = simulate(PRP, controller, q0=[0, 0, 0], t_final=0.5, dt=1e-3, method=method, log_every=5)
    sig = result.signals
    assert list(sig) == ["q_des", "q_err", "qd_err", "y"]
    np.testing.assert_array_equal(sig["q_err"], sig["q_des"] - result.q)
    t = result.t[:, None]
    q_des = np.array([0.1, 1.0, 0.05]) + np.array([0.05, 0.3, 0.02]) * np.sin(np.array([2.0, 1.0, 3.0]) * t)
    np.testing.assert_allclose(sig["q_des"], q_des, rtol=0, atol=1e-15)
    for name, array in sig.items():
        assert array.shape == (len(result.t), 3) and array.flags.c_contiguous, name
        if method == "rk4":
            assert np.shares_memory(array, result.q.base if result.q.base is not None else result.q), name


def test_batch_runs_match_single_runs():
    controllers = [pd(PRP, [k, 0.5, 10], [10, 0.08, 3], [0.1, 1.0, 0.05]) for k in (10.0, 25.0, 40.0)]
    batch = simulate_batch(PRP, controllers, q0=[0, 0, 0], t_final=0.3, dt=1e-3, log_every=10)
    for controller, result in zip(controllers, batch):
        single = simulate(PRP, controller, q0=[0, 0, 0], t_final=0.3, dt=1e-3, log_every=10)
        assert len(single.t) == 31
        np.testing.assert_array_equal(result.q, single.q)


@pytest.mark.parametrize("suffix", [".npz", ".csv", ".parquet"])
def test_results_round_trip_through_every_format(tmp_path, suffix):
    controller = pd(PRP, [25, 0.5, 10], [10, 0.08, 3], [0.1, 1.0, 0.05])
    result = simulate(PRP, controller, q0=[0, 0, 0], t_final=0.05, dt=1e-3, torque_limit=5.0)
    loaded = SimulationResult.load(result.save(tmp_path / f"run{suffix}"))
    for name, array in result.groups().items():
        np.testing.assert_array_equal(loaded.groups()[name], array)
    assert loaded.labels == result.labels and loaded.units == result.units
    assert loaded.meta["controller"]["compensation"] == "online"
    frame = result.to_dataframe()
    assert list(frame.columns[:4]) == ["t", "q.d1", "q.theta2", "q.d3"]
    assert frame.shape == (51, 1 + 3 * 4 + 3 * 3 + 3)


def test_bad_arguments_name_the_field():
    controller = pd(PRP, 1.0, 1.0, [0, 0, 0])
    with pytest.raises(SimulationError, match="t_final"):
        simulate(PRP, controller, q0=[0, 0, 0], t_final=0.0105, dt=1e-3)
    with pytest.raises(SimulationError, match="q0"):
        simulate(PRP, controller, q0=[0, 0], t_final=0.01, dt=1e-3)
    with pytest.raises(SimulationError, match="controller"):
        simulate(LINK1, controller, q0=[0], t_final=0.01, dt=1e-3)
    with pytest.raises(SimulationError, match="method"):
        simulate(PRP, controller, q0=[0, 0, 0], t_final=0.01, dt=1e-3, method="euler")
    for margin in (float("nan"), -0.1):
        with pytest.raises(SimulationError, match="limit_margin"):
            simulate(PRP, controller, q0=[0, 0, 0], t_final=0.01, dt=1e-3, limit_margin=margin)


def test_a_saturated_contact_run_logs_command_and_wrench_where_they_belong():
    # Saturation and an environment without a disturbance: τ_cmd and h_e are logged, τ_d is
    # not (the log's layout (1, 0, 1)); each must hold its own values.
    from armlab.scenarios import load_scenario

    scenario = load_scenario("a11_compliance")
    limit = 1.0
    result = scenario.run(t_final=0.3, torque_limit=limit)
    assert "tau_cmd" in result.signals and "h_e" in result.signals and "tau_dist" not in result.signals
    assert np.abs(result.signals["tau_cmd"]).max() > limit          # the limit did clip
    np.testing.assert_array_equal(result.tau, np.clip(result.signals["tau_cmd"], -limit, limit))
    plant, environment = scenario.plant, scenario.environment
    assert np.abs(result.signals["h_e"]).max() > 0.1                 # in contact
    for k in range(0, len(result.t), 37):
        q, qd = result.q[k], result.qd[k]
        v_e = armlab.geometric_jacobian(plant, q, frame="0") @ qd
        expected = environment.wrench(armlab.forward_kinematics(plant, q, frame="0"), v_e)
        np.testing.assert_allclose(result.signals["h_e"][k], expected, rtol=1e-9, atol=1e-12)
