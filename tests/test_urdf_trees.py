"""URDF trees: side branches locked and lumped (checked by hand), stray tags, zero-range limits,
<mimic> on the chain, tip choice, and the export's gravity (every bundled robot round-trips
with the same B, C q̇ and g)."""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab.model.urdf_io import load_urdf, to_urdf
from test_urdf import HAND_URDF, _edit

# HAND_URDF plus a side branch on "upper": a revolute finger (about z, limits 0.2..1.0) carrying
# 1 kg at 0.1 m along its x axis, and a second finger that mimics it (q = −1 · q_finger + 0.1)
# carrying 0.5 kg at 0.2 m along its x axis.
BRANCH = (
    '<link name="finger_link"><inertial><origin xyz="0.1 0 0"/><mass value="1"/>'
    '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>'
    '<joint name="finger" type="revolute"><origin xyz="0.5 0 0"/><parent link="upper"/>'
    '<child link="finger_link"/><axis xyz="0 0 1"/>'
    '<limit lower="0.2" upper="1.0" effort="1" velocity="1"/></joint>'
    '<link name="twin_link"><inertial><origin xyz="0.2 0 0"/><mass value="0.5"/>'
    '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>'
    '<joint name="twin" type="revolute"><origin xyz="0.5 0 0"/><parent link="upper"/>'
    '<child link="twin_link"/><axis xyz="0 0 1"/><mimic joint="finger" multiplier="-1" offset="0.1"/>'
    '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
)


def _branched(tmp_path, text=None):
    path = tmp_path / "branched.urdf"
    path.write_text(text or _edit(HAND_URDF, '<link name="tool0"/>', '<link name="tool0"/>' + BRANCH))
    return path


def _expected_upper(finger):
    """Mass and COM of link "upper" (in its frame) with the branch locked at ``finger``:
    upper 2 kg at (0.25, 0, 0), sensor 0.5 kg at (0.5, 0, 0), finger 1 kg at
    (0.5, 0, 0) + Rz(finger)(0.1, 0, 0), twin 0.5 kg at (0.5, 0, 0) + Rz(0.1 − finger)(0.2, 0, 0)."""
    twin = 0.1 - finger
    parts = [(2.0, [0.25, 0, 0]), (0.5, [0.5, 0, 0]),
             (1.0, [0.5 + 0.1 * np.cos(finger), 0.1 * np.sin(finger), 0]),
             (0.5, [0.5 + 0.2 * np.cos(twin), 0.2 * np.sin(twin), 0])]
    mass = sum(m for m, _ in parts)
    return mass, sum(m * np.array(c) for m, c in parts) / mass


def test_side_branch_is_locked_and_lumped(tmp_path):
    path = _branched(tmp_path)
    robot = armlab.load_robot(path, tip="tool0")
    assert robot.joint_names == ["shoulder", "slide"]
    # 0 lies below the finger's limits: it is locked at its lower limit 0.2.
    mass, com = _expected_upper(0.2)
    assert robot.links[0].inertial.mass == pytest.approx(mass, rel=1e-15)
    np.testing.assert_allclose(robot.links[0].inertial.com, com, atol=1e-15)
    # Point masses m_k at c_k: I_C = Σ m_k (|r_k|² I − r_k r_kᵀ), r_k = c_k − c, plus the two
    # bodies' own tensors (upper's and the sensor's, diagonal).
    parts = [(2.0, [0.25, 0, 0]), (0.5, [0.5, 0, 0]),
             (1.0, [0.5 + 0.1 * np.cos(0.2), 0.1 * np.sin(0.2), 0]),
             (0.5, [0.5 + 0.2 * np.cos(-0.1), 0.2 * np.sin(-0.1), 0])]
    inertia = np.diag([0.01, 0.05, 0.05]) + 0.001 * np.eye(3)
    for m, c in parts:
        r = np.array(c) - com
        inertia += m * (r @ r * np.eye(3) - np.outer(r, r))
    np.testing.assert_allclose(robot.links[0].inertial.inertia, inertia, atol=1e-15)
    assert any("finger = 0.2" in note and "twin = -0.1" in note for note in robot.notes), robot.notes


def test_lock_gives_the_locked_value(tmp_path):
    robot = armlab.load_robot(_branched(tmp_path), tip="tool0", lock={"finger": 0.7})
    mass, com = _expected_upper(0.7)
    np.testing.assert_allclose(robot.links[0].inertial.com, com, atol=1e-15)
    with pytest.raises(armlab.RobotFileError, match=r"lock\[shoulder\]: is on the chain"):
        armlab.load_robot(_branched(tmp_path), tip="tool0", lock={"shoulder": 0.1})
    with pytest.raises(armlab.RobotFileError, match=r"lock\[nope\]: is not a moving joint off the chain"):
        armlab.load_robot(_branched(tmp_path), tip="tool0", lock={"nope": 0.1})


def test_several_tips_are_listed(tmp_path):
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot(_branched(tmp_path))
    text = str(info.value)
    assert "tip: the moving joints lie on several branches" in text
    assert "end in finger_link, tool0, twin_link" in text and "\n" not in text


def test_mimic_on_the_chain_is_refused_by_name(tmp_path):
    text = _edit(HAND_URDF, '<axis xyz="1 0 0"/>', '<axis xyz="1 0 0"/><mimic joint="shoulder"/>')
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot(_branched(tmp_path, text))
    assert "joint[slide].mimic: joint 'slide' of the chain follows joint 'shoulder'" in str(info.value)


def test_side_branch_following_the_chain_is_refused(tmp_path):
    text = _edit(HAND_URDF, '<link name="tool0"/>', '<link name="tool0"/>' + BRANCH)
    text = _edit(text, '<mimic joint="finger"', '<mimic joint="shoulder"')
    with pytest.raises(armlab.RobotFileError, match=r"joint\[twin\]\.mimic: follows joint 'shoulder' of "
                       "the chain"):
        armlab.load_robot(_branched(tmp_path, text), tip="tool0")


def test_stray_mimic_on_fixed_joint_and_zero_range_limits(tmp_path):
    text = _edit(HAND_URDF, '<origin xyz="0.5 0 0"/><parent link="upper"/><child link="sensor"/>',
                 '<origin xyz="0.5 0 0"/><parent link="upper"/><child link="sensor"/>'
                 '<mimic joint="shoulder"/>')
    text = _edit(text, 'lower="0" upper="0.3"', 'lower="0" upper="0"')
    robot = armlab.load_robot(_branched(tmp_path, text))
    plain = armlab.load_robot(_branched(tmp_path, HAND_URDF))
    assert robot.joints[1].limits == (-np.inf, np.inf)
    assert robot.notes == ("limits lower = upper read as no limit: slide",)
    q = [0.3, 0.1]
    np.testing.assert_array_equal(armlab.inertia_matrix(robot, q), armlab.inertia_matrix(plain, q))


def test_tip_on_commands_and_load_robot(tmp_path, capsys):
    from armlab.cli import main

    path = _branched(tmp_path)
    assert main(["robots", str(path), "--tip", "tool0"]) == 0
    out = capsys.readouterr().out
    assert "finger = 0.2" in out
    with pytest.raises(armlab.RobotFileError, match="tip: applies to URDF and MJCF files only"):
        armlab.load_robot("prp", tip="x")


@pytest.mark.parametrize("name", armlab.bundled_robot_names())
def test_bundled_robot_round_trips_with_the_same_dynamics(name, tmp_path):
    """Exported, read back with the file's own gravity (−z of its root), the same B, C q̇, g."""
    robot = armlab.load_robot(name)
    path = tmp_path / f"{name}.urdf"
    path.write_text(to_urdf(robot))
    loaded = load_urdf(path)
    rng = np.random.default_rng(2)
    m = robot.arrays
    # URDF has no rotors: compare with the robot's rotor inertias removed.
    from strategies import without_actuators

    rigid, loaded = without_actuators(robot), without_actuators(loaded)
    for _ in range(5):
        q = rng.uniform(np.maximum(m.q_min, -2), np.minimum(m.q_max, 2))
        qd = rng.uniform(-2, 2, robot.n)
        for f in (armlab.inertia_matrix, armlab.gravity_torque):
            a, b = f(loaded, q), f(rigid, q)
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * max(1.0, np.abs(b).max()))
        a, b = armlab.coriolis_matrix(loaded, q, qd) @ qd, armlab.coriolis_matrix(rigid, q, qd) @ qd
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * max(1.0, np.abs(b).max()))


def test_planar2r_export_keeps_gravity(tmp_path):
    """The issue's case: planar2r (g along −y of Σ_0) exported and read back has
    g(0) = [1030.05, 245.25] N·m, the value of its robot file."""
    robot = armlab.load_robot("planar2r")
    path = tmp_path / "planar2r.urdf"
    path.write_text(to_urdf(robot))
    np.testing.assert_allclose(armlab.gravity_torque(load_urdf(path), [0.0, 0.0]),
                               armlab.gravity_torque(robot, [0.0, 0.0]), rtol=1e-13)
    np.testing.assert_allclose(armlab.gravity_torque(robot, [0.0, 0.0]), [1030.05, 245.25], rtol=1e-12)


def test_scenario_plant_tip(tmp_path):
    """A scenario runs a branched URDF with ``plant_tip``; the controller's model follows it."""
    from armlab.scenarios import load_scenario

    _branched(tmp_path)
    scenario = tmp_path / "arm.toml"
    scenario.write_text('plant = "branched.urdf"\nplant_tip = "tool0"\n'
                        '[simulation]\nt_final = 0.1\ndt = 0.001\nq0 = [0.1, 0.05]\n'
                        '[controller]\ntype = "joint_pd_gravity"\nkp = [100, 100]\nkd = [20, 20]\n'
                        '[controller.reference]\ntype = "constant"\nvalue = [0.1, 0.05]\n')
    loaded = load_scenario(scenario)
    assert loaded.plant.joint_names == loaded.controller.model.joint_names == ["shoulder", "slide"]
    result = loaded.run()
    # PD + g at rest at its goal stays there.
    np.testing.assert_allclose(result.q[-1], [0.1, 0.05], atol=1e-9)
    scenario.write_text(scenario.read_text().replace('plant_tip = "tool0"\n', ""))
    from armlab.errors import ScenarioFileError

    with pytest.raises(ScenarioFileError, match="plant: .*tip: the moving joints lie on several branches"):
        load_scenario(scenario)


def test_pinocchio_reads_the_exported_gravity():
    """Pinocchio's default gravity (0, 0, −9.81) in the root of the exported file is the
    robot's gravity: g(0) of planar2r (g along −y of Σ_0) is [1030.05, 245.25] N·m."""
    pin = pytest.importorskip("pinocchio")
    for name in armlab.bundled_robot_names():
        robot = armlab.load_robot(name)
        model = pin.buildModelFromXML(to_urdf(robot))
        data = model.createData()
        from pinocchio_model import pinocchio_q, v_index

        q = np.full(robot.n, 0.3)
        g = pin.computeGeneralizedGravity(model, data, pinocchio_q(robot, model, q))[v_index(robot, model)]
        np.testing.assert_allclose(g, armlab.gravity_torque(robot, q), rtol=1e-12, atol=1e-12)


def test_course_of_a_branched_file_names_its_tip(tmp_path):
    """The course generated for a URDF loaded with a tip writes plant_tip, so its files load."""
    from armlab.course import write_course
    from armlab.robots import robot_reference
    from armlab.scenarios import ScenarioFileError, load_scenario

    robot = armlab.load_robot(_branched(tmp_path), tip="tool0")
    reference, tip = robot_reference(robot)
    assert reference == str((tmp_path / "branched.urdf").resolve()) and tip == "tool0"
    paths, _ = write_course(robot, reference, tmp_path / "course", tip=tip)
    assert paths and all('plant_tip = "tool0"' in p.read_text() for p in paths)
    # The robot file lies outside the course folder: read when allowed (docs/robot-files.md).
    assert load_scenario(paths[0], allow_outside=True).plant.joint_names == ["shoulder", "slide"]
    with pytest.raises(ScenarioFileError, match="lies outside the scenario"):
        load_scenario(paths[0])
    assert robot_reference(armlab.load_robot("prp")) == ("prp", None)
