"""URDF export checked by Pinocchio, and URDF import (round trip and a hand-written file)."""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab.model.toml_io import robot_from_dict
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
