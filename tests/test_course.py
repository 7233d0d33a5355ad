"""The course generated for arms other than the PRP: each experiment shows what its assignment
is about, checked against the theory of its law (armlab.theory) or a bound derived from it."""

from __future__ import annotations

import tomllib
import warnings

import numpy as np
import pytest

import armlab
from armlab.course import (
    DEAD_BAND,
    OMEGA,
    PUSH,
    RK4_REACH,
    course_scenarios,
    euler_convention,
    fastest_mode,
    time_step,
    to_toml,
    write_course,
)
from armlab.dynamics import gravity_torque, inertia_matrix
from armlab.kinematics import forward_kinematics
from armlab.robots import zoo
from armlab.scenarios import load_scenario_file
from armlab.simulation import SimulationDiverged
from armlab.spatial import euler_from_matrix, rot_x, rot_y, rot_z
from armlab.theory import predictions


def needs(name):
    """Skip, saying why, when the installed example-robot-data lacks the zoo arm ``name``."""
    return pytest.mark.skipif(not zoo.installed(zoo.ZOO[name]),
                              reason=f"example-robot-data with {name} is not installed "
                                     "(pip install example-robot-data)")


# Every zoo arm's course runs here.  These three add no case the others lack (6–7 joints without
# Coulomb friction, dt = 1 ms): marked slow, they still run in the full suite.
SLOW_ZOO = {"baxter_left_arm", "kinova", "ur3"}
ZOO_ARMS = [pytest.param(name, marks=[needs(name), *([pytest.mark.slow] if name in SLOW_ZOO else [])])
            for name in zoo.zoo_names()]

# Arms without friction settle on the equilibrium itself.  A9 and A11 run 10 s, their slowest
# task mode decays at about ω_n/2 (1.9–2.5 1/s measured): the 5–30 cm from start to goal come
# down to 5·10⁻⁹ m or less on every zoo arm; the tolerance leaves a factor 200.  A force of the
# A11 spring is K_P · 5 mm, so 10⁻⁴ of it is 0.5 µm along the normal.
SETTLED = 1e-6              # [m]
FORCE_RTOL = 1e-4
AT_REST = 1e-4              # [rad/s | m/s] joint velocities at the end (0.15–0.4 rad/s without K_q)
JOINT_SPACE = {"a06_pd_online", "a06_pd_none", "a06_pd_desired", "a07_id_via_points", "a07_id_mismatch"}
TASK_SPACE = {"a09_pd_goal", "a10_id_via_poses", "a11_compliance", "a12_impedance_regulation",
              "a14_force_inner_position", "a15_parallel_contact"}


@pytest.fixture(scope="module", params=["puma560", "prp", *ZOO_ARMS])
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
    assert JOINT_SPACE <= set(runs)
    assert (TASK_SPACE <= set(runs)) == (robot.n >= 3)
    assert all(run.status == "ok" for _, run in runs.values())
    assert all(skip.split(":")[0] in ("A8", "A13", "A9–A15") for skip in skipped)
    if robot.n < 3:
        assert any(skip.startswith("A9–A15") for skip in skipped)


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


def test_adaptive_control_starts_from_a_wrong_model_and_its_error_falls(course):
    """A8 as the seed's: π̂(0) from links of 0.8 their mass (and inertia), so the law has
    something to adapt; the tracking error's peak over the last 2 s is at most half the first
    2 s' (with π̂(0) = π it sat at 10⁻¹² from the start and showed nothing)."""
    robot, runs, skipped = course
    if "a08_adaptive_sine" not in runs:
        assert any(skip.startswith("A8:") for skip in skipped)
        return
    scenario, run = runs["a08_adaptive_sine"]
    for true, believed in zip(robot.links, scenario.controller.model.links, strict=True):
        assert believed.inertial.mass == pytest.approx(0.8 * true.inertial.mass, rel=1e-12)
    error = np.abs(run.signals["q_err"]).max(axis=1)
    first, last = error[run.t < 2.0].max(), error[run.t >= run.t[-1] - 2.0].max()
    assert first > 1e-4 and last <= 0.5 * first


def test_task_space_experiments(course):
    robot, runs, _ = course
    if robot.n < 3:
        pytest.skip(f"{robot.name} has {robot.n} joints: no task-space experiments are generated")
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
    # It does press: 1 cm inside a surface as stiff as the controller, half-way is K_P · 5 mm.
    k_p = float(np.asarray(scenario.controller.kp).flat[0])
    assert np.linalg.norm(force.values) > 0.25 * k_p * PUSH
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


def test_the_poses_carry_the_goal_orientation_in_a_regular_convention(course):
    """The orientation written with the A9 goal (Euler angles of the file's convention) is the
    end effector's at q_g, and that convention is not singular there."""
    robot, runs, _ = course
    if robot.n < 3:
        pytest.skip(f"{robot.name} has {robot.n} joints: no task-space experiments are generated")
    scenario, _ = runs["a09_pd_goal"]
    q_g = runs["a06_pd_online"][0].controller.reference.value
    R_g = forward_kinematics(robot, q_g, frame="0")[:3, :3]
    np.testing.assert_allclose(scenario.controller.reference.rotations[0], R_g, atol=1e-12)
    singular = {"zyz": np.hypot(R_g[0, 2], R_g[1, 2]), "rpy": np.hypot(R_g[0, 0], R_g[1, 0])}
    assert singular[scenario.controller.euler] > 0.1


def _fastest(robot, q, K, D):
    """max |λ| of B δq̈ + (F_v + D) δq̇ + K δq = 0 at q, from the first-order form's eigenvalues."""
    n, B = robot.n, inertia_matrix(robot, q)
    A = np.block([[np.zeros((n, n)), np.eye(n)],
                  [-np.linalg.solve(B, K), -np.linalg.solve(B, np.diag(robot.arrays.viscous) + D)]])
    return np.abs(np.linalg.eigvals(A)).max()


def test_a_pd_step_keeps_its_fastest_mode_inside_rk4(course):
    """Each PD experiment's step times the fastest mode of its loop, linearised at the start and
    at the goal from the gains the file holds, stays within RK4_REACH; the laws that cancel the
    dynamics (friction included) keep 1 ms."""
    robot, runs, _ = course
    q_s, q_g = runs["a06_pd_online"][0].simulation["q0"], runs["a06_pd_online"][0].controller.reference.value
    for name, (scenario, _) in runs.items():
        c, dt = scenario.controller, scenario.simulation["dt"]
        if name.startswith("a06"):
            loops = [(c.kp, c.kd)] * 2
        elif name in ("a09_pd_goal", "a11_compliance"):
            p = c.params()
            env = scenario.environment
            spring = 0.0 if env is None else env.stiffness * np.outer(env.normal, env.normal)
            loops = []
            for q in (q_s, q_g):
                J = armlab.geometric_jacobian(robot, q, frame="0")[:3]
                loops.append((J.T @ (p.kp + spring) @ J, J.T @ p.kd @ J + p.joint_damping))
        else:
            assert dt == 1e-3, name
            continue
        fastest = max(_fastest(robot, q, K, D) for q, (K, D) in zip((q_s, q_g), loops, strict=True))
        assert fastest * dt <= RK4_REACH, name


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


@needs("ur5")
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


def test_euler_convention_is_the_one_farther_from_its_singularity():
    """ZYZ is singular where the tool's z axis is vertical (R = I), RPY where its x axis is
    (R = Ry(∓π/2)); over a path the worse end decides."""
    assert euler_convention([np.eye(3)]) == "rpy"
    assert euler_convention([rot_y(np.pi / 2)]) == "zyz"
    assert euler_convention([rot_z(0.3) @ rot_y(-np.pi / 2)]) == "zyz"
    # ZYZ: sin ϑ = sin 0.1 at the first; RPY: cos ϑ = cos 1.4 = 0.17 at the second.
    assert euler_convention([rot_x(0.1), rot_y(1.4)]) == "rpy"
    assert euler_convention([rot_x(0.2), rot_y(1.4)]) == "zyz"     # sin 0.2 = 0.199 > 0.17
    for R in (np.eye(3), rot_y(np.pi / 2), rot_x(0.1) @ rot_y(1.4)):
        euler_from_matrix(R, euler_convention([R]))                 # supported, and regular there


def test_fastest_mode_of_one_link_is_the_root_of_its_characteristic_polynomial():
    """link1 (I = 0.1 kg·m², F_v = 0.05 N·m·s/rad): I s² + (F_v + D) s + K = 0 by hand."""
    link = armlab.load_robot("link1")
    q = [np.array([0.3])]
    # Complex pair: |s|² = K / I.
    assert fastest_mode(link, q, lambda q: (np.array([[1e4]]), np.zeros((1, 1)))) == pytest.approx(
        np.sqrt(1e4 / 0.1), rel=1e-12)
    # Real roots: (−10.05 ± √(10.05² − 100)) / 0.2, the larger in size 55.256…
    expected = (10.05 + np.sqrt(10.05**2 - 4 * 0.1 * 250.0)) / 0.2
    assert fastest_mode(link, q, lambda q: (np.array([[250.0]]), np.array([[10.0]]))) == pytest.approx(
        expected, rel=1e-12)


def test_time_step_is_a_short_decimal_fraction_of_a_millisecond_inside_rk4():
    assert time_step(0.0) == time_step(RK4_REACH / 1e-3) == 1e-3
    for fastest, dt in ((1001.0, 5e-4), (2001.0, 2.5e-4), (4001.0, 2e-4), (19437.0, 5e-5)):
        assert time_step(fastest) == pytest.approx(dt, rel=1e-15)
        assert fastest * time_step(fastest) <= RK4_REACH
        assert 6.0 / time_step(fastest) == pytest.approx(round(6.0 / dt), abs=1e-6)


@needs("xarm7")
def test_the_xarm7_pd_laws_diverge_at_one_millisecond(tmp_path):
    """Why the PD experiments of the xArm7 step at 50 µs: its wrist (B_77 = 1.4·10⁻⁴ kg·m²,
    F_v = 2 N·m·s/rad) has a pole near −2·10⁴ 1/s, far outside RK4's reach at dt = 1 ms."""
    files, _ = course_scenarios(armlab.load_robot("xarm7"), "xarm7")
    document = tomllib.loads(files["a06_pd_online.toml"])
    assert document["simulation"]["dt"] < 1e-4
    document["simulation"]["dt"] = 1e-3
    path = tmp_path / "coarse.toml"
    path.write_text(to_toml(document), encoding="utf-8")
    with warnings.catch_warnings(), pytest.raises(SimulationDiverged):
        warnings.simplefilter("ignore")
        load_scenario_file(path).run(t_final=0.1)


@needs("so100")
def test_without_joint_stops_the_so100_jaw_leaves_its_range(tmp_path):
    """The so100's jaw (20 g; its axis through the end point, so all self-motion) swings on the
    reaction torques of A11's transient: without the stops it runs past its limit by more than
    0.1 rad (what "warn" reports); with them, as generated, it stays within 5 mrad of it."""
    robot = armlab.load_robot("so100")
    files, _ = course_scenarios(robot, "so100")
    document = tomllib.loads(files["a11_compliance.toml"])
    assert document["simulation"]["joint_limits"] == "stop"
    lo, hi = (np.array([j.limits[k] for j in robot.joints]) for k in (0, 1))
    excess = {}
    for stops in (True, False):
        if not stops:
            del document["simulation"]["joint_limits"]
        path = tmp_path / f"stops-{stops}.toml"
        path.write_text(to_toml(document), encoding="utf-8")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            q = load_scenario_file(path).run().q
        excess[stops] = np.maximum(q - hi, lo - q).max()
    assert excess[True] < 5e-3 and excess[False] > 0.1, excess


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
