"""Declared joint limits in the simulator: warned about, logged, flagged in the result, and —
with ``joint_limits="stop"`` — enforced by stiff damped unilateral springs (S4)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import armlab
from armlab.control.joint_space import JointPDGravity
from armlab.errors import ScenarioFileError
from armlab.references.joint import Constant
from armlab.scenarios import load_scenario
from armlab.simulation import SimulationError, simulate
from armlab.simulation.joint_limits import STOP_FREQUENCY_STEPS, JointLimitWarning

PRP = armlab.load_robot("prp")
DT = 1e-3


def _run(mode, method="rk4", t_final=2.0):
    """PD + g driving d1 to 0.5 m, beyond its upper limit 0.35 m."""
    controller = JointPDGravity(model=PRP, reference=Constant(value=[0.5, 0.3, 0.1]),
                                kp=[400, 50, 100], kd=[80, 10, 20])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = simulate(PRP, controller, q0=[0.0, 0.3, 0.1], t_final=t_final, dt=DT,
                          joint_limits=mode, method=method)
    return result, [w for w in caught if issubclass(w.category, JointLimitWarning)]


def test_crossing_a_limit_warns_with_joint_and_time():
    result, caught = _run("warn")
    assert len(caught) == 1
    message = str(caught[0].message)
    first = result.t[np.argmax(result.q[:, 0] > 0.35)]
    assert message.startswith(f"joint d1 of prp left its limits [-0.15, 0.35] m at t = {first:.4g} s")
    assert result.q[-1, 0] == pytest.approx(0.5, abs=1e-4)  # nothing stops it
    np.testing.assert_array_equal(result.signals["q_limit_excess"][:, 0],
                                  np.maximum(result.q[:, 0] - 0.35, 0.0))
    assert not result.signals["q_limit_excess"][:, 1:].any()
    crossed = result.meta["joint_limits"]["crossed"]
    assert list(crossed) == ["d1"] and crossed["d1"]["first"] == first
    assert crossed["d1"]["worst"] == pytest.approx(result.q[:, 0].max() - 0.35)


def test_crossings_are_found_whatever_else_the_log_holds():
    from armlab.simulation.joint_limits import crossings

    t = np.arange(6) * DT
    inside = np.tile([0.1, 0.3, 0.1], (6, 1))
    assert crossings(PRP, t, inside) == {}
    assert crossings(PRP, t[:0], inside[:0]) == {}
    below = inside.copy()
    below[3, 2] = -0.2                                   # d3 under its lower limit −0.15 m
    found = crossings(PRP, t, below)
    assert list(found) == ["d3"] and found["d3"]["worst"] == pytest.approx(-0.05)
    below[5] = np.nan                                    # a NaN sample hides no crossing
    assert list(crossings(PRP, t, below)) == ["d3"]
    assert crossings(PRP, t, np.where(np.isnan(below), np.nan, inside)) == {}


def test_the_warning_points_at_the_users_line_whichever_way_in():
    """simulate() and a scenario's run() reach the warning through different armlab frames;
    either way it names the caller's file, not a line of armlab's."""
    _, caught = _run("warn")
    assert caught[0].filename == __file__
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_scenario("a14_force_inner_position").run()
    limits = [w for w in caught if issubclass(w.category, JointLimitWarning)]
    assert limits and all(w.filename == __file__ for w in limits)


def test_ignore_says_nothing():
    result, caught = _run("ignore")
    assert not caught and result.meta["joint_limits"] == {"mode": "ignore"}
    assert "q_limit_excess" not in result.signals


@pytest.mark.parametrize("method", ["rk4", "adaptive"])
def test_stop_holds_the_joint_at_its_limit(method):
    result, caught = _run("stop", method=method, t_final=1.5)
    assert len(caught) == 1 and "met its stop at 0.35 m" in str(caught[0].message)
    record = result.meta["joint_limits"]
    K, D = record["stop_stiffness"][0], record["stop_damping"][0]
    omega = STOP_FREQUENCY_STEPS / DT
    # (S4): K = m ω², D = 2 m ω with m = 1/(B⁻¹(q))_11 where the stop acts; the PRP's d1
    # carries the whole arm whatever θ2 and d3, so that is its value at q0.
    m = 1.0 / np.linalg.inv(armlab.inertia_matrix(PRP, [0.0, 0.3, 0.1]))[0, 0]
    assert K == pytest.approx(m * omega ** 2, rel=1e-12) and D == pytest.approx(2 * m * omega, rel=1e-12)
    # At rest on the stop the joint's balance is τ_1 − g_1(q) + τ_stop = 0 with τ_stop = −K δ:
    # the final penetration is δ = (τ_1 − g_1) / K.
    q_end = result.q[-1]
    push = result.tau[-1, 0] - armlab.gravity_torque(PRP, q_end)[0]
    assert q_end[0] - 0.35 == pytest.approx(push / K, rel=1e-3)
    assert result.signals["tau_dist"][-1, 0] == pytest.approx(-push, rel=1e-3)
    # Any time: a critically damped contact entered at speed v overshoots by at most
    # v / (e ω) beyond the static penetration of the largest push.
    pushes = np.abs(result.tau[:, 0] - np.array([armlab.gravity_torque(PRP, q)[0] for q in result.q]))
    bound = pushes.max() / K + np.abs(result.qd[:, 0]).max() / (np.e * omega)
    assert 0 < result.q[:, 0].max() - 0.35 <= bound
    assert bound < 5e-3  # millimetres, where the free run went 150 mm past


def test_joint_limits_setting_is_checked(tmp_path):
    with pytest.raises(SimulationError, match="joint_limits: 'halt' is not one of 'ignore', 'warn', 'stop'"):
        _run("halt")
    path = tmp_path / "bad.toml"
    text = load_scenario("a6_pd_online").source
    path.write_text(open(text, encoding="utf-8").read().replace(
        "dt = 0.001", 'dt = 0.001\njoint_limits = "halt"'))
    with pytest.raises(ScenarioFileError, match="simulation.joint_limits: 'halt' is not one of"):
        load_scenario(path).run(t_final=0.01)


def test_seed_scenario_that_leaves_the_limits_says_so_and_its_stop_variant_stays():
    seed = load_scenario("a6_pd_sine_disturbance")
    assert "beyond" in seed.description and "a6_pd_sine_disturbance_stop" in seed.description
    with pytest.warns(JointLimitWarning, match="joint d3 of prp left its limits"):
        free = seed.run()
    assert free.q[:, 2].min() < -0.3
    with pytest.warns(JointLimitWarning, match="joint d3 of prp met its stop at -0.15 m"):
        stopped = load_scenario("a6_pd_sine_disturbance_stop").run()
    assert -0.15 - 1e-3 < stopped.q[:, 2].min() < -0.15


def _folding_2r():
    """A horizontal-axis 2R arm whose elbow folds: a light upper arm (1 m) and a heavy, compact
    forearm.  Joint 1's effective inertia with the elbow free, 1/(B⁻¹)₁₁, is ~20 kg·m² at
    q2 = π/2 and ~0.33 kg·m² at q2 = 0: 60× less."""
    from armlab.model.toml_io import robot_from_dict

    def link(mass, com, inertia):
        return {"mass": mass, "com": [com, 0, 0],
                "inertia": [[inertia / 10, 0, 0], [0, inertia, 0], [0, 0, inertia]]}

    return robot_from_dict({"name": "folding2r", "gravity": [0, 0, -9.81], "joints": [
        {"name": "q1", "type": "revolute", "dh": {"a": 1.0, "alpha": 0, "d": 0, "theta": 0},
         "limits": [-0.5, 0.5], "link": link(0.5, -0.5, 0.01)},
        {"name": "q2", "type": "revolute", "dh": {"a": 0.2, "alpha": 0, "d": 0, "theta": 0},
         "limits": [-3.1, 3.1], "link": link(20.0, -0.1, 0.002)}]}, "folding2r.toml")


def _energy(robot, result):
    """T + U [J] per logged sample, from the public dynamics functions."""
    return np.array([armlab.kinetic_energy(robot, q, qd) + armlab.potential_energy(robot, q)
                     for q, qd in zip(result.q, result.qd, strict=True)])


def _coast(robot, **options):
    """No torque (PD with zero gains), the arm swinging into joint 1's stop at 1 ms while its
    elbow turns; every warning kept."""
    controller = JointPDGravity(model=robot, reference=Constant(np.zeros(2)), kp=0.0, kd=0.0,
                                compensation="none")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = simulate(robot, controller, q0=[0.0, np.pi / 2], qd0=[2.0, 8.0], t_final=3.0, dt=1e-3,
                          on_divergence="return", **options)
    return result, caught


def test_a_stop_sized_at_q0_pumps_energy_into_a_folding_arm():
    """The old sizing (K from the inertia at q0) as an explicit disturbance: RK4 at contact is
    unstable, T + U of an unforced arm grows (50 J to beyond 10⁵ J)."""
    from armlab.simulation.disturbances import JointStop

    robot = _folding_2r()
    m0 = 1.0 / np.diag(np.linalg.inv(armlab.inertia_matrix(robot, [0.0, np.pi / 2])))
    omega = STOP_FREQUENCY_STEPS / 1e-3
    old = JointStop(lower=robot.arrays.q_min, upper=robot.arrays.q_max, stiffness=m0 * omega ** 2,
                    damping=2 * m0 * omega)
    result, _ = _coast(robot, disturbance=old, joint_limits="ignore")
    energy = _energy(robot, result)
    assert np.nanmax(energy) > 100 * energy[0]


def test_stops_sized_where_they_act_keep_the_folding_arm_passive():
    robot = _folding_2r()
    result, caught = _coast(robot, joint_limits="stop")
    assert result.status == "ok"
    assert any(issubclass(w.category, JointLimitWarning) for w in caught)  # it did reach its stop
    energy = _energy(robot, result)
    # Unforced, with damped stops: the energy never rises above its start (to round-off).
    assert energy.max() <= energy[0] * (1 + 1e-6)
    assert energy[-1] < energy[0]
    assert "energy_gain" not in result.meta["joint_limits"]
    # K of joint 1 from its lightest contact configuration, found here on a fine grid of q2.
    lightest = min(1.0 / np.linalg.inv(armlab.inertia_matrix(robot, [0.5, q2]))[0, 0]
                   for q2 in np.linspace(-3.1, 3.1, 621))
    K = result.meta["joint_limits"]["stop_stiffness"][0]
    assert K <= lightest * (STOP_FREQUENCY_STEPS / 1e-3) ** 2 * 1.02


def test_a_run_whose_passive_energy_grows_is_flagged(monkeypatch):
    """With the stops sized at q0 again (the old code), the run's energy check fires."""
    from armlab.simulation import joint_limits
    from armlab.simulation.joint_limits import StopEnergyWarning

    def at_q0(plant, q0, i, at):
        return float(1.0 / np.linalg.inv(armlab.inertia_matrix(plant, np.asarray(q0, dtype=float)))[i, i])

    monkeypatch.setattr(joint_limits, "contact_inertia", at_q0)
    result, caught = _coast(_folding_2r(), joint_limits="stop")
    flagged = [w for w in caught if issubclass(w.category, StopEnergyWarning)]
    assert len(flagged) == 1 and "passive energy grew" in str(flagged[0].message)
    assert result.meta["joint_limits"]["energy_gain"] > 1e3
