"""The course generated for arms other than the PRP: each experiment shows what its assignment
is about, checked against the theory of its law (armlab.theory) or a bound derived from it."""

from __future__ import annotations

import tomllib
import warnings

import numpy as np
import pytest

import armlab
from armlab.course import DEAD_BAND, OMEGA, course_scenarios, to_toml, write_course
from armlab.dynamics import gravity_torque, inertia_matrix
from armlab.robots import zoo
from armlab.scenarios import load_scenario_file
from armlab.theory import predictions

# The UR5 (6R, no joint friction): its self-motion is what the joint damping K_q is for.
needs_ur5 = pytest.mark.skipif(not zoo.installed(zoo.ZOO["ur5"]),
                               reason="example-robot-data is not installed (pip install example-robot-data)")

# Arms without friction settle on the equilibrium itself.  The generated gains make the slowest
# motion decay at ω_n/2 (course.py), e^(−ω_n/2 · 6 s) = 3·10⁻⁷ of the 5–30 cm from start to goal:
# 0.1 µm; the tolerances leave a factor ten.  A force of the A11 spring is K_P · 5 mm, so 10⁻⁴
# of it is 0.5 µm along the normal.
SETTLED = 1e-6              # [m]
FORCE_RTOL = 1e-4
AT_REST = 1e-4              # [rad/s | m/s] joint velocities at the end (0.15–0.4 rad/s without K_q)


@pytest.fixture(scope="module", params=["puma560", "prp", pytest.param("ur5", marks=needs_ur5)])
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
    # Coulomb friction holds the PD laws anywhere in its dead band; without it they settle.
    frictionless = not robot.arrays.coulomb.any()
    tolerance = SETTLED if frictionless else DEAD_BAND
    _, run = runs["a09_pd_goal"]
    assert np.abs(run.signals["x_err"][-1, :3]).max() <= tolerance
    _, run = runs["a10_id_via_poses"]
    assert np.abs(run.signals["x_err"][:, :3]).max() < 1e-6
    scenario, run = runs["a11_compliance"]
    position, force = predictions(scenario)
    np.testing.assert_allclose(run.signals["p"][-1], position.values, atol=tolerance)
    assert np.linalg.norm(force.values) > 0.1              # it does press on the surface
    if frictionless:
        np.testing.assert_allclose(run.signals["h_e"][-1, :3], force.values,
                                   atol=FORCE_RTOL * np.linalg.norm(force.values))
        for name in ("a09_pd_goal", "a11_compliance"):
            assert np.abs(runs[name][1].qd[-1]).max() < AT_REST, name
    scenario, run = runs["a12_impedance_regulation"]
    k_p = float(np.asarray(scenario.controller.kp).flat[0])
    assert abs(np.linalg.norm(run.signals["h_e"][-1, :3]) - k_p * 0.01) < 0.01 * k_p * 0.01
    for name in ("a14_force_inner_position", "a15_parallel_contact"):
        scenario, run = runs[name]
        h, f_d = run.signals["h_e"][-1, :3], run.signals["f_des"][-1]
        assert abs(np.linalg.norm(h) - 0.5) < 1e-3, name
        np.testing.assert_allclose(h, f_d, atol=1e-3)


def test_joint_damping_is_written_for_the_self_motion_only(course):
    """K_q on A9 and A11 when the arm has more joints than the 3 task components, nowhere else."""
    robot, runs, _ = course
    for name, (scenario, _) in runs.items():
        damping = getattr(scenario.controller, "joint_damping", 0.0)
        written = name in ("a09_pd_goal", "a11_compliance") and robot.n > 3
        assert np.any(np.asarray(damping) != 0.0) == written, name
        if written:   # the stated rule: ω_n/2 times the diagonal of B at the goal (A6's reference)
            q_g = runs["a06_pd_online"][0].controller.reference.value
            np.testing.assert_allclose(np.diag(scenario.controller.params().joint_damping),
                                       OMEGA / 2 * np.diag(inertia_matrix(robot, q_g)), rtol=1e-12)


@needs_ur5
def test_without_joint_damping_the_ur5_keeps_moving(tmp_path):
    """The UR5's A11 without K_q: the self-motion K_D does not see is still there at the end,
    and the arm is off its equilibrium (what K_q removes)."""
    files, _ = course_scenarios(armlab.load_robot("ur5"), "ur5")
    document = tomllib.loads(files["a11_compliance.toml"])
    del document["controller"]["joint_damping"]
    path = tmp_path / "undamped.toml"
    path.write_text(to_toml(document), encoding="utf-8")
    undamped = load_scenario_file(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = undamped.run()
    position, _ = predictions(undamped)
    assert np.abs(run.qd[-1]).max() > 100 * AT_REST
    assert np.abs(run.signals["p"][-1] - position.values).max() > 10 * SETTLED


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
