"""The course generated for arms other than the PRP: each experiment shows what its assignment
is about, checked against the theory of its law (armlab.theory) or a bound derived from it."""

from __future__ import annotations

import tomllib
import warnings

import numpy as np
import pytest

import armlab
from armlab.course import DEAD_BAND, course_scenarios, write_course
from armlab.dynamics import gravity_torque
from armlab.scenarios import load_scenario_file
from armlab.theory import predictions


@pytest.fixture(scope="module", params=["puma560", "prp"])
def course(request, tmp_path_factory):
    robot = armlab.load_robot(request.param)
    paths, skipped = write_course(robot, request.param, tmp_path_factory.mktemp(request.param))
    runs = {}
    for path in paths:
        scenario = load_scenario_file(path)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            runs[path.stem] = (scenario, scenario.run())
    return robot, runs, skipped


def test_every_experiment_runs(course):
    robot, runs, skipped = course
    assert {"a06_pd_online", "a07_id_via_points", "a09_pd_goal", "a10_id_via_poses", "a11_compliance",
            "a12_impedance_regulation", "a14_force_inner_position", "a15_parallel_contact"} <= set(runs)
    assert all(run.status == "ok" for _, run in runs.values())
    assert all(skip.split(":")[0] in ("A8", "A13") for skip in skipped)


def test_joint_space_experiments(course):
    robot, runs, _ = course
    coulomb = robot.arrays.coulomb
    for name in ("a06_pd_online", "a06_pd_desired"):
        scenario, run = runs[name]
        kp = np.diag(scenario.controller.kp)
        # At rest K_P q̃ balances at most the static friction: |q̃_i| ≤ F_s,i / K_P,i.
        assert np.all(np.abs(run.signals["q_err"][-1]) <= coulomb / kp + 1e-5), name
    scenario, run = runs["a06_pd_none"]
    q = run.q[-1]
    residual = np.diag(scenario.controller.kp) * run.signals["q_err"][-1] - gravity_torque(robot, q)
    assert np.all(np.abs(residual) <= coulomb + 1e-3)     # K_P q̃ = g(q), up to friction
    _, run = runs["a07_id_via_points"]
    assert np.abs(run.signals["q_err"]).max() < 1e-8      # exact cancellation tracks exactly
    scenario, run = runs["a07_id_mismatch"]
    (equilibrium,) = predictions(scenario)
    np.testing.assert_allclose(run.signals["q_err"][-1], equilibrium.values, atol=1e-5)
    assert np.abs(equilibrium.values).max() > 1e-4        # the mismatch does show


def test_task_space_experiments(course):
    robot, runs, _ = course
    _, run = runs["a09_pd_goal"]
    assert np.abs(run.signals["x_err"][-1, :3]).max() <= DEAD_BAND
    _, run = runs["a10_id_via_poses"]
    assert np.abs(run.signals["x_err"][:, :3]).max() < 1e-6
    scenario, run = runs["a11_compliance"]
    position, force = predictions(scenario)
    np.testing.assert_allclose(run.signals["p"][-1], position.values, atol=DEAD_BAND)
    assert np.linalg.norm(force.values) > 0.1              # it does press on the surface
    scenario, run = runs["a12_impedance_regulation"]
    k_p = float(np.asarray(scenario.controller.kp).flat[0])
    assert abs(np.linalg.norm(run.signals["h_e"][-1, :3]) - k_p * 0.01) < 0.01 * k_p * 0.01
    for name in ("a14_force_inner_position", "a15_parallel_contact"):
        scenario, run = runs[name]
        h, f_d = run.signals["h_e"][-1, :3], run.signals["f_des"][-1]
        assert abs(np.linalg.norm(h) - 0.5) < 1e-3, name
        np.testing.assert_allclose(h, f_d, atol=1e-3)


def test_a_two_joint_arm_gets_joint_space_experiments_and_reasons():
    files, skipped = course_scenarios(armlab.load_robot("planar2r"), "planar2r")
    assert sorted(files)[:5] == ["a06_pd_desired.toml", "a06_pd_none.toml", "a06_pd_online.toml",
                                 "a07_id_mismatch.toml", "a07_id_via_points.toml"]
    assert not any(name.startswith(("a09", "a1")) for name in files)
    assert any(reason.startswith("A9–A15") for reason in skipped)
    for text in files.values():
        tomllib.loads(text)                                  # every file is valid TOML


def test_names_from_the_robot_file_are_quoted_not_pasted():
    robot = armlab.load_robot("prp")
    files, _ = course_scenarios(robot, 'x"\n[controller]\ntype = "evil')
    for text in files.values():
        assert tomllib.loads(text)["plant"] == 'x"\n[controller]\ntype = "evil'


def test_report_workers_reload_a_generated_experiment_from_its_file(tmp_path):
    """A course reuses the bundled names (a11_compliance …): a worker must load the file."""
    from armlab.viz.experiments import discover, experiment_from_scenario

    puma = armlab.load_robot("puma560")
    experiments = discover(puma, course_dir=tmp_path)
    compliance = next(e for e in experiments if e.name == "a11_compliance")
    assert compliance.scenario == str(tmp_path / "a11_compliance.toml")
    assert experiment_from_scenario(compliance.scenario).robot.name == "puma560"
