"""URDF export checked by Pinocchio, and URDF import (round trip and a hand-written file)."""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab.model.toml_io import robot_from_dict
from armlab.model.urdf_io import load_urdf, world_rotation
from pinocchio_model import pinocchio_frames, pinocchio_model

# A robot exercising every placement: modified DH, URDF-style origin/axis with oblique axes,
# an unlimited revolute joint (URDF "continuous"), joint offsets, base and tool transforms.
MIXED = {
    "name": "mixed",
    "dh_convention": "modified",
    "gravity": [0.3, -9.0, 1.2],
    "base": {"xyz": [0.1, -0.2, 0.3], "rpy": [0.4, -0.5, 0.6]},
    "tool": {"xyz": [0.0, 0.05, 0.12], "rpy": [0.1, 0.2, -0.3]},
    "joints": [
        {"type": "revolute", "dh": {"a": 0.1, "alpha": 0.3, "d": 0.2, "theta": 0.7},
         "link": {"mass": 1.5, "com": [0.1, 0.02, -0.03],
                  "shape": {"type": "box", "size": [0.3, 0.1, 0.05], "rpy": [0.2, 0.1, 0]}}},
        {"type": "prismatic", "dh": {"a": 0.2, "alpha": -1.2, "d": 0.1, "theta": -0.4},
         "limits": [-0.5, 0.5],
         "link": {"mass": 0.7, "com": [0.0, 0.1, 0.2],
                  "shape": {"type": "cylinder", "radius": 0.04, "length": 0.3, "rpy": [0.5, -0.3, 0.2]}}},
        {"type": "revolute", "origin": {"xyz": [0.1, 0.2, -0.1], "rpy": [0.3, -0.8, 1.1]},
         "axis": [0.2, -0.5, 0.7], "limits": [-2, 2],
         "link": {"mass": 0.4, "com": [0.05, 0, 0.01],
                  "shape": {"type": "sphere", "radius": 0.05}}},
        {"type": "prismatic", "origin": {"xyz": [0.0, 0.3, 0.0]}, "axis": [1, 0, 0],
         "link": {"mass": 0.2, "com": [0.02, 0.03, 0.04],
                  "inertia": [[0.01, 0.001, -0.003], [0.001, 0.02, 0.002], [-0.003, 0.002, 0.015]]}},
    ],
}

ROBOTS = [*armlab.bundled_robot_names(), "mixed"]


def _robot(name):
    return robot_from_dict(MIXED, "mixed") if name == "mixed" else armlab.load_robot(name)


def _random_q(robot, rng):
    lo = np.maximum(robot.arrays.q_min, -np.pi)
    hi = np.minimum(robot.arrays.q_max, np.pi)
    return rng.uniform(lo, hi)


@pytest.mark.parametrize("name", ROBOTS)
def test_pinocchio_frames_of_urdf_export_equal_link_frames(name):
    """The seed's URDF-vs-DH check: every frame Σ_0 … Σ_e of Pinocchio's model (loaded from
    armlab's URDF) equals armlab's DH/joint-placement frames, at random q."""
    robot = _robot(name)
    model, data = pinocchio_model(robot)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = _random_q(robot, rng)
        np.testing.assert_allclose(pinocchio_frames(robot, model, data, q),
                                   armlab.link_frames(robot, q), atol=1e-12)


@pytest.mark.parametrize("name", ROBOTS)
def test_pinocchio_inertials_and_gravity_match(name):
    """Total mass, gravity torque at rest and kinetic energy agree with Pinocchio, which ties
    the exported inertials (mass, COM, inertia in J_i) and the gravity rotation into Σ_base to
    armlab's description without using armlab's dynamics."""
    import pinocchio as pin

    from pinocchio_model import pinocchio_q, pinocchio_v

    robot = _robot(name)
    model, data = pinocchio_model(robot)
    m = robot.arrays
    assert sum(model.inertias[j].mass for j in range(model.njoints)) == pytest.approx(m.mass.sum())
    rng = np.random.default_rng(3)
    q = _random_q(robot, rng)
    qd = rng.normal(size=robot.n)
    frames = armlab.link_frames(robot, q, frame="0")
    # Potential energy U = −Σ m_i g_0ᵀ p_Ci and kinetic energy from link COM velocities,
    # computed here from armlab's frames and finite differences of them.
    potential = 0.0
    kinetic = 0.0
    eps = 1e-6
    later = armlab.link_frames(robot, q + eps * qd, frame="0")
    earlier = armlab.link_frames(robot, q - eps * qd, frame="0")
    for i, joint in enumerate(robot.joints):
        J_now = frames[i + 1] @ np.linalg.inv(joint.after)
        J_next = later[i + 1] @ np.linalg.inv(joint.after)
        J_prev = earlier[i + 1] @ np.linalg.inv(joint.after)
        p_c = J_now[:3, :3] @ m.com[i] + J_now[:3, 3]
        p_next = J_next[:3, :3] @ m.com[i] + J_next[:3, 3]
        p_prev = J_prev[:3, :3] @ m.com[i] + J_prev[:3, 3]
        v_c = (p_next - p_prev) / (2 * eps)
        R_dot = (J_next[:3, :3] - J_prev[:3, :3]) / (2 * eps)
        omega_skew = R_dot @ J_now[:3, :3].T
        omega = np.array([omega_skew[2, 1], omega_skew[0, 2], omega_skew[1, 0]])
        I_world = J_now[:3, :3] @ m.inertia[i] @ J_now[:3, :3].T
        potential -= m.mass[i] * m.gravity @ p_c
        kinetic += 0.5 * m.mass[i] * v_c @ v_c + 0.5 * omega @ I_world @ omega
    q_pin, v_pin = pinocchio_q(robot, model, q), pinocchio_v(robot, model, qd)
    assert pin.computePotentialEnergy(model, data, q_pin) == pytest.approx(
        potential + _potential_offset(robot, model, data), abs=1e-9)
    assert pin.computeKineticEnergy(model, data, q_pin, v_pin) == pytest.approx(kinetic, rel=1e-6)


def _potential_offset(robot, model, data):
    """Pinocchio measures heights from Σ_base, armlab's sum above from Σ_0: the difference is
    −M g_baseᵀ p_base0, constant."""
    m = robot.arrays
    return -m.mass.sum() * (robot.base[:3, :3] @ m.gravity) @ robot.base[:3, 3]


def _line_error(path, field, text):
    """The one-line ``file: field: reason`` message of a RobotFileError."""
    assert "\n" not in text
    assert text.startswith(f"{path}: {field}: "), text


@pytest.mark.parametrize("name", ROBOTS)
def test_urdf_round_trip_keeps_kinematics_and_inertials(name, tmp_path):
    robot = _robot(name)
    path = armlab.save_urdf(robot, tmp_path / f"{name}.urdf")
    # The export's world link makes g point along −z; mixed's |g| is not 9.81, so it is given.
    loaded = load_urdf(path, gravity=robot.gravity) if name == "mixed" else armlab.load_robot(path)
    assert loaded.n == robot.n
    assert [j.kind for j in loaded.joints] == [j.kind for j in robot.joints]
    assert loaded.joint_names == robot.joint_names
    # Σ_base of the file read back is the export's world frame: T_world,base · T_base0.
    world = np.eye(4)
    world[:3, :3] = world_rotation(robot)
    np.testing.assert_allclose(loaded.base, world @ robot.base, atol=1e-14)
    np.testing.assert_allclose(loaded.gravity, robot.gravity, atol=1e-14)
    a, b = loaded.arrays, robot.arrays
    for field in ("mass", "com", "inertia", "viscous", "coulomb"):
        np.testing.assert_allclose(getattr(a, field), getattr(b, field), atol=1e-14, err_msg=field)
    # URDF demands finite limits on a prismatic joint: an unlimited one is written as ±1 km.
    prismatic = b.joint_type == 1
    np.testing.assert_array_equal(a.q_min, np.where(prismatic, np.maximum(b.q_min, -1e3), b.q_min))
    np.testing.assert_array_equal(a.q_max, np.where(prismatic, np.minimum(b.q_max, 1e3), b.q_max))
    rng = np.random.default_rng(11)
    for _ in range(3):
        q = _random_q(robot, rng)
        for frame in ("base", "0"):
            expected = armlab.forward_kinematics(robot, q, frame)
            if frame == "base":
                expected = world @ expected
            np.testing.assert_allclose(armlab.forward_kinematics(loaded, q, frame), expected, atol=1e-12)


HAND_URDF = """<?xml version="1.0"?>
<robot name="hand">
  <link name="world"/>
  <link name="base_link">
    <inertial><mass value="5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
  </link>
  <joint name="mount" type="fixed">
    <origin xyz="0 0 0.1"/><parent link="world"/><child link="base_link"/>
  </joint>
  <link name="upper">
    <inertial><origin xyz="0.25 0 0"/><mass value="2"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <origin xyz="0 0 0.2"/><parent link="base_link"/><child link="upper"/><axis xyz="0 1 0"/>
    <limit lower="-1.5" upper="1.5" effort="10" velocity="1"/>
    <dynamics damping="0.3" friction="0.1"/>
  </joint>
  <link name="sensor">
    <inertial><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
  </link>
  <joint name="sensor_mount" type="fixed">
    <origin xyz="0.5 0 0"/><parent link="upper"/><child link="sensor"/>
  </joint>
  <link name="slider">
    <inertial><origin xyz="0.1 0 0"/><mass value="1"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.003"/></inertial>
  </link>
  <joint name="slide" type="prismatic">
    <parent link="sensor"/><child link="slider"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.3" effort="10" velocity="1"/>
  </joint>
  <link name="tool0"/>
  <joint name="flange" type="fixed">
    <origin xyz="0.2 0 0"/><parent link="slider"/><child link="tool0"/>
  </joint>
</robot>
"""


def test_hand_written_urdf_matches_hand_computation(tmp_path):
    path = tmp_path / "hand.urdf"
    path.write_text(HAND_URDF)
    robot = armlab.load_robot(path)
    assert robot.joint_names == ["shoulder", "slide"]
    assert [j.kind for j in robot.joints] == ["revolute", "prismatic"]
    assert robot.joints[0].limits == (-1.5, 1.5) and robot.joints[1].limits == (0.0, 0.3)
    assert robot.joints[0].friction.viscous == 0.3 and robot.joints[0].friction.coulomb == 0.1
    np.testing.assert_allclose(robot.base[:3, 3], [0, 0, 0.1])  # Σ_0 = base_link
    np.testing.assert_allclose(robot.gravity, [0, 0, -9.81])
    # Tip: (0, 0, 0.3) + Ry(θ) (0.7 + d, 0, 0) = (x cos θ, 0, 0.3 − x sin θ) in Σ_base.
    theta, d = 0.4, 0.12
    x = 0.5 + d + 0.2
    T = armlab.forward_kinematics(robot, [theta, d])
    np.testing.assert_allclose(T[:3, 3], [x * np.cos(theta), 0, 0.3 - x * np.sin(theta)], atol=1e-12)
    # upper (2 kg at 0.25) + sensor (0.5 kg at 0.5): COM 0.3; Steiner offsets −0.05 and +0.2:
    # I_yy = I_zz = 0.05 + 2·0.05² + 0.001 + 0.5·0.2² = 0.076, I_xx = 0.011.
    upper, slider = robot.links[0].inertial, robot.links[1].inertial
    assert upper.mass == pytest.approx(2.5)
    np.testing.assert_allclose(upper.com, [0.3, 0, 0], atol=1e-15)
    np.testing.assert_allclose(upper.inertia, np.diag([0.011, 0.076, 0.076]), atol=1e-15)
    assert slider.mass == 1.0
    np.testing.assert_allclose(slider.com, [0.1, 0, 0])
    np.testing.assert_allclose(slider.inertia, np.diag([0.002, 0.003, 0.003]))
    np.testing.assert_allclose(robot.tool[:3, 3], [0.2, 0, 0])


def _edit(text, old, new):
    assert old in text
    return text.replace(old, new, 1)


MALFORMED_URDF = {
    "floating": (('type="revolute"', 'type="floating"'), "joint[shoulder].type", "not supported"),
    "planar": (('type="prismatic"', 'type="planar"'), "joint[slide].type", "not supported"),
    "mimic": (('<axis xyz="1 0 0"/>', '<axis xyz="1 0 0"/><mimic joint="shoulder"/>'),
              "joint[slide].mimic", "not supported"),
    "missing link": (('<child link="tool0"/>', '<child link="tool9"/>'),
                     "joint[flange].child", "no link named 'tool9'"),
    "reversed limits": (('lower="0" upper="0.3"', 'lower="0.3" upper="0"'),
                        "joint[slide].limit", "must be below"),
    "negative mass": (('<mass value="1"/>', '<mass value="-1"/>'),
                      "link[slider].inertial.mass", "non-negative"),
    "inertia not PSD": (('ixx="0.002"', 'ixx="-0.002"'), "link[slider].inertial.inertia",
                        "positive semi-definite"),
    "triangle inequality": (('ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.003"',
                             'ixx="0.01" ixy="0" ixz="0" iyy="0.003" iyz="0" izz="0.003"'),
                            "link[slider].inertial.inertia", "triangle inequality"),
    "zero axis": (('<axis xyz="1 0 0"/>', '<axis xyz="0 0 0"/>'), "joint[slide].axis", "non-zero"),
    "branching": (('<link name="tool0"/>', '<link name="tool0"/><link name="arm2"/><joint name="j2" '
                   'type="revolute"><parent link="upper"/><child link="arm2"/>'
                   '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'),
                  "tip", "several branches; the longest chains (2 joints) end in arm2, tool0"),
    "ambiguous tip": (('<link name="tool0"/>', '<link name="tool0"/><link name="cam"/><joint name="j2" '
                       'type="fixed"><parent link="slider"/><child link="cam"/></joint>'),
                      "tip", "several links (cam, tool0)"),
    "not XML": (("</robot>", "</robot"), "xml", "not well-formed"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED_URDF))
def test_malformed_urdf_gives_one_line_error(case, tmp_path):
    (old, new), field, reason = MALFORMED_URDF[case]
    path = tmp_path / "bad.urdf"
    path.write_text(_edit(HAND_URDF, old, new))
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot(path)
    _line_error(path, field, str(info.value))
    assert reason in str(info.value)


def test_tip_option_picks_the_chain_and_lumps_the_rest(tmp_path):
    path = tmp_path / "two_tips.urdf"
    path.write_text(_edit(HAND_URDF, '<link name="tool0"/>',
                          '<link name="tool0"/><link name="cam"><inertial><mass value="0.2"/>'
                          '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>'
                          '<joint name="j2" type="fixed"><origin xyz="0 0 0.1"/><parent link="slider"/>'
                          '<child link="cam"/></joint>'))
    robot = load_urdf(path, tip="tool0")
    np.testing.assert_allclose(robot.tool[:3, 3], [0.2, 0, 0])
    # The camera (0.2 kg at (0, 0, 0.1)) stays on the slider: COM (1·0.1, 0, 0.2·0.1)/1.2.
    np.testing.assert_allclose(robot.links[1].inertial.com, [0.1 / 1.2, 0, 0.02 / 1.2])
    assert robot.links[1].inertial.mass == pytest.approx(1.2)
    with pytest.raises(armlab.RobotFileError, match="tip: no link named 'nowhere'"):
        load_urdf(path, tip="nowhere")


def test_unreadable_urdf(tmp_path):
    path = tmp_path / "missing.urdf"
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot(path)
    _line_error(path, "file", str(info.value))
