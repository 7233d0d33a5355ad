"""MJCF through MuJoCo's compiler: armlab's B(q), C q̇ + g, forward kinematics and forward
dynamics agree with MuJoCo's own ``mj_fullM``, ``qfrc_bias``, body poses and ``qacc`` to 1e-12
relative at random states.  Skipped, with the reason, when ``mujoco`` is not installed."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import armlab
from armlab.model.mjcf_io import load_mjcf

mujoco = pytest.importorskip("mujoco", reason="MJCF is read by mujoco (pip install 'armlab[mjcf]')")

# Every placement MuJoCo offers: a rotated mount (quat), euler angles, an oblique hinge with an
# anchor off the body origin and a reference angle, two hinges in one body, a slide with a
# reference, inertials from <inertial> (quat, fullinertia) and from geoms, a side branch
# (a finger, locked at its qpos0) and a massless tool body; gravity not along −z.
ARM = """<mujoco model="testarm">
  <compiler angle="radian"/>
  <option gravity="0.5 -2 -9.6"/>
  <worldbody>
    <body name="mount" pos="0.1 0.2 0.3" quat="0.9 0.1 0.3 -0.2">
      <geom type="box" size="0.1 0.1 0.05" mass="3"/>
      <body name="upper" pos="0 0 0.1" euler="0.2 -0.3 0.4">
        <joint name="shoulder" type="hinge" axis="0.2 1 0.1" pos="0.01 0.02 -0.03" range="-2 2"
               damping="0.3" ref="0.2"/>
        <inertial pos="0.2 0.01 0" quat="0.8 0.2 0.1 0.4" mass="2" diaginertia="0.01 0.05 0.04"/>
        <body name="fore" pos="0.4 0 0">
          <joint name="elbow_a" type="hinge" axis="0 0 1" pos="0.02 0 0"/>
          <joint name="elbow_b" type="hinge" axis="1 0 0.3" pos="0 0.01 0" ref="-0.4"/>
          <inertial pos="0.15 0 0.02" mass="1.2" fullinertia="0.01 0.02 0.025 0.001 -0.002 0.003"/>
          <body name="slider" pos="0.3 0 0">
            <joint name="slide" type="slide" axis="1 0.1 0" range="-0.1 0.2" ref="0.05"/>
            <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.02" mass="0.5"/>
            <body name="hand" pos="0.12 0 0">
              <geom type="sphere" size="0.03" mass="0.3"/>
              FINGER
              <body name="tool" pos="0.08 0 0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
FINGER = """<body name="finger" pos="0.02 0.03 0">
                <joint name="finger_joint" type="hinge" axis="0 0 1" range="-0.5 0.5" ref="0.1"/>
                <geom type="box" size="0.03 0.005 0.005" pos="0.03 0 0" mass="0.05"/>
              </body>"""


def _write(tmp_path, text, name="arm.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _mujoco_state(m, d, robot, q, qd):
    """MuJoCo's data at armlab's (q, q̇) (armlab's q is qpos); other joints at qpos0, at rest."""
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in robot.joint_names]
    dofs = [int(m.jnt_dofadr[j]) for j in ids]
    d.qpos[:] = m.qpos0
    d.qvel[:] = 0.0
    d.qpos[[int(m.jnt_qposadr[j]) for j in ids]] = q
    d.qvel[dofs] = qd
    return dofs


def _relative(actual, expected):
    return float(np.abs(np.asarray(actual) - expected).max() / max(np.abs(expected).max(), 1e-300))


@pytest.mark.parametrize("finger", [True, False])
def test_mjcf_arm_matches_mujoco(tmp_path, finger):
    path = _write(tmp_path, ARM.replace("FINGER", FINGER if finger else ""))
    robot = armlab.load_robot(path, tip="tool")
    assert robot.joint_names == ["shoulder", "elbow_a", "elbow_b", "slide"]
    assert [link.name for link in robot.links] == ["upper", "fore:elbow_a", "fore", "slider"]
    assert robot.joints[0].limits == (-2.0, 2.0) and robot.joints[0].friction.viscous == 0.3
    if finger:
        assert "finger_joint = 0.1" in robot.notes[0]
    m = mujoco.MjModel.from_xml_path(str(path))
    # No contacts or joint-limit forces: the equations of motion alone.
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    d = mujoco.MjData(m)
    tool = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "tool")
    rng = np.random.default_rng(4)
    for _ in range(5):
        q = rng.uniform([-2, -3, -3, -0.1], [2, 3, 3, 0.2])
        qd = rng.uniform(-2, 2, robot.n)
        dofs = _mujoco_state(m, d, robot, q, qd)
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        M = M[np.ix_(dofs, dofs)]
        assert _relative(armlab.inertia_matrix(robot, q), M) < 1e-12
        bias = d.qfrc_bias[dofs]
        h = armlab.coriolis_matrix(robot, q, qd) @ qd + armlab.gravity_torque(robot, q)
        assert _relative(h, bias) < 1e-12
        T = armlab.forward_kinematics(robot, q)
        assert _relative(T[:3, 3], d.xpos[tool]) < 1e-12
        np.testing.assert_allclose(T[:3, :3], d.xmat[tool].reshape(3, 3), rtol=0, atol=1e-14)
        if not finger:
            # Forward dynamics with MuJoCo's damping (armlab's viscous friction F_v q̇).
            tau = rng.uniform(-3, 3, robot.n)
            d.qfrc_applied[:] = 0.0
            d.qfrc_applied[dofs] = tau
            mujoco.mj_forward(m, d)
            assert _relative(armlab.forward_dynamics(robot, q, qd, tau), d.qacc[dofs]) < 1e-12


def test_mjcf_errors_are_one_line(tmp_path, monkeypatch):
    free = _write(tmp_path, ARM.replace('<joint name="shoulder" type="hinge"',
                                        '<joint name="shoulder" type="ball"').replace(' range="-2 2"', ''))
    with pytest.raises(armlab.RobotFileError,
                       match=r"joint\[shoulder\]\.type: ball joints are not supported"):
        armlab.load_robot(free, tip="tool")
    broken = _write(tmp_path, "<mujoco><worldbody><body><joint type='hing'/></body></worldbody></mujoco>",
                    "broken.xml")
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot(broken)
    assert str(info.value).startswith(f"{broken}: mjcf: ") and "\n" not in str(info.value)
    coupled = _write(tmp_path, ARM.replace("FINGER", "").replace(
        "</worldbody>", '</worldbody><equality><joint joint1="elbow_a" joint2="elbow_b"/></equality>'),
        "coupled.xml")
    with pytest.raises(armlab.RobotFileError, match=r"equality\[0\]: constrains the chain"):
        armlab.load_robot(coupled, tip="tool")
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(armlab.RobotFileError, match="mujoco package, which is not installed"):
        load_mjcf(free)


def test_mjcf_armature_is_named(tmp_path):
    path = _write(tmp_path, ARM.replace("FINGER", "").replace('damping="0.3"',
                                                              'damping="0.3" armature="0.2"'))
    robot = armlab.load_robot(path)
    assert any(note.startswith("armature not modelled") and "shoulder = 0.2" in note for note in robot.notes)


def test_unnamed_joints_load_under_the_names_armlab_gives_them(tmp_path):
    """MJCF joints need no name: armlab calls joint j "joint<j>", in the robot and in its notes
    (the armature note once looked joints up by MuJoCo's empty name and failed)."""
    text = (ARM.replace("FINGER", "").replace('name="elbow_a" ', "")
            .replace('name="elbow_b" ', 'armature="0.1" '))
    robot = armlab.load_robot(_write(tmp_path, text))
    assert list(robot.joint_names) == ["shoulder", "joint1", "joint2", "slide"]
    assert any(note.startswith("armature not modelled") and "joint2 = 0.1" in note for note in robot.notes)
