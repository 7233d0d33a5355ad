"""The course's joint-space experiments generated for arms without scenarios of their own:
poses inside the limits away from singularities, and each run shows its assignment's behaviour
(A6: PD + gravity converges; A7: computed torque tracks), measured as the report measures it."""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab.scenarios import load_scenario
from armlab.scenarios.generate import CONDITION, course_poses, generated_scenarios
from armlab.viz.metrics import measure


def _arms():
    from armlab.robots import zoo

    names = ["puma560"]
    if zoo.installed(zoo.ZOO["ur5"]):
        names.append("ur5")
    return names


@pytest.mark.parametrize("name", _arms())
def test_generated_a6_a7_show_their_behaviour(name, tmp_path):
    robot = armlab.load_robot(name)
    q_a, q_b = course_poses(robot)
    for q in (q_a, q_b):
        assert np.all(q > robot.arrays.q_min) and np.all(q < robot.arrays.q_max)
        sigma = np.linalg.svd(armlab.geometric_jacobian(robot, q), compute_uv=False)
        assert sigma[-1] >= CONDITION * sigma[0]
    paths = generated_scenarios(robot, name, tmp_path)
    assert [p.name.split("_")[0] for p in paths] == ["a6", "a7", "a9", "a10"]
    pd_path, ct_path, opd_path, oid_path = paths
    pd = load_scenario(pd_path)
    assert pd.plant.name == name and pd.simulation["q0"].tolist() == q_a.tolist()
    result = pd.run()
    assert result.status == "ok" and not result.meta["joint_limits"]["crossed"]
    # A6: zero steady-state error up to Coulomb friction's dead zone F_s/K_P (≤ 1 % of the step).
    kp = np.diag(pd.controller.kp)
    dead_zone = robot.arrays.coulomb / kp
    error = np.abs(result.signals["q_err"][-1])
    assert np.all(error <= dead_zone + 1e-6) and error.max() <= 0.01 * np.abs(q_b - q_a).max()
    steady = [m for m in measure(result) if m.quantity.startswith("steady-state")]
    assert steady and all(abs(m.value) <= 0.01 * 0.3 for m in steady if isinstance(m.value, float))
    # A7: an exact model tracks the quintic to round-off.
    ct = load_scenario(ct_path).run()
    assert ct.status == "ok" and np.abs(ct.signals["q_err"]).max() < 1e-9
    # A9 (PD + g in operational space) and A10 (operational inverse dynamics) reach the goal
    # pose x(q_b): the final pose error, measured by forward kinematics, vanishes.
    goal = armlab.forward_kinematics(robot, q_b, "0")
    for path, tol in ((opd_path, 1e-4), (oid_path, 1e-9)):
        run = load_scenario(path).run()
        assert run.status == "ok" and not run.meta["joint_limits"]["crossed"]
        reached = armlab.forward_kinematics(robot, run.q[-1], "0")
        assert np.abs(reached - goal).max() < tol, path.name
        assert run.signals["jacobian_sv"].min() > 0.05
