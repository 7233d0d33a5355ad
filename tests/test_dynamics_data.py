"""The explicit data object of the dynamics functions (``armlab.dynamics.DynamicsData``), the
per-process default data, and robots that nothing writes into.

Reference results come from the published kernels (``armlab.kernels.dynamics``) called with the
robot's own arrays and a fresh workspace, never from the wrappers under test.
"""

from __future__ import annotations

import gc
import pickle
import weakref

import numpy as np
import pytest

import armlab
from armlab.dynamics import DynamicsData
from armlab.kernels.dynamics import (
    coriolis_matrix_into,
    forward_dynamics_into,
    gravity_into,
    make_workspace,
    mass_matrix_into,
    rnea_into,
)


def _kernels(robot, q, qd, qdd, h_e):
    """Every quantity of the public functions, from the kernels (fresh workspace each)."""
    n, m = robot.n, robot.arrays
    out = {"tau": np.empty(n), "tau_h": np.empty(n), "B": np.empty((n, n)), "C": np.empty((n, n)),
           "g": np.empty(n), "qdd": np.empty(n)}
    rnea_into(m, make_workspace(n), q, qd, qdd, 1.0, np.zeros(6), out["tau"])
    rnea_into(m, make_workspace(n), q, qd, qdd, 1.0, h_e, out["tau_h"])
    mass_matrix_into(m, make_workspace(n), q, out["B"])
    coriolis_matrix_into(m, make_workspace(n), q, qd, out["C"])
    gravity_into(m, make_workspace(n), q, out["g"])
    forward_dynamics_into(m, make_workspace(n), q, qd, qdd, h_e, out["qdd"])
    return out


def _public(robot, q, qd, qdd, h_e, **data):
    return {"tau": armlab.inverse_dynamics(robot, q, qd, qdd, **data),
            "tau_h": armlab.inverse_dynamics(robot, q, qd, qdd, h_e=h_e, **data),
            "B": armlab.inertia_matrix(robot, q, **data),
            "C": armlab.coriolis_matrix(robot, q, qd, **data),
            "g": armlab.gravity_torque(robot, q, **data),
            "qdd": armlab.forward_dynamics(robot, q, qd, qdd, h_e=h_e, **data)}


@pytest.mark.parametrize("name", ["prp_actuated", "puma560"])
def test_calls_with_and_without_data_agree_with_the_kernels(name):
    robot = armlab.load_robot(name)
    data = DynamicsData(robot)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q, qd, qdd = rng.uniform(-1.0, 1.0, (3, robot.n))
        h_e = rng.normal(size=6)
        expected = _kernels(robot, q, qd, qdd, h_e)
        with_data, without = _public(robot, q, qd, qdd, h_e, data=data), _public(robot, q, qd, qdd, h_e)
        for key, value in expected.items():
            np.testing.assert_allclose(with_data[key], value, rtol=1e-12, atol=1e-12, err_msg=key)
            np.testing.assert_array_equal(with_data[key], without[key], err_msg=key)
        T = armlab.kinetic_energy(robot, q, qd, data=data)
        assert T == pytest.approx(0.5 * qd @ expected["B"] @ qd, rel=1e-12)
        assert armlab.potential_energy(robot, q, data=data) == armlab.potential_energy(robot, q)


def test_data_of_another_robot_is_refused_by_name():
    prp, puma = armlab.load_robot("prp"), armlab.load_robot("puma560")
    z = np.zeros(3)
    for call in (lambda d: armlab.inverse_dynamics(prp, z, z, z, data=d),
                 lambda d: armlab.inertia_matrix(prp, z, data=d),
                 lambda d: armlab.gravity_torque(prp, z, data=d),
                 lambda d: armlab.coriolis_matrix(prp, z, z, data=d),
                 lambda d: armlab.forward_dynamics(prp, z, z, z, data=d),
                 lambda d: armlab.kinetic_energy(prp, z, z, data=d),
                 lambda d: armlab.potential_energy(prp, z, data=d)):
        with pytest.raises(ValueError, match="data: DynamicsData of 'puma560', not of robot 'prp'"):
            call(DynamicsData(puma))
        with pytest.raises(ValueError, match="data: DynamicsData of a dict"):
            call({})
    # Another robot object with the same numbers is another robot.
    with pytest.raises(ValueError, match="data:"):
        armlab.inertia_matrix(prp, z, data=DynamicsData(armlab.load_robot("prp")))
    with pytest.raises(TypeError, match="robot"):
        DynamicsData("prp")


def test_data_pickles_and_serves_its_robot_after():
    robot = armlab.load_robot("prp")
    q = np.array([0.2, -0.4, 0.3])
    data = DynamicsData(robot)
    B = armlab.inertia_matrix(robot, q, data=data)
    copy = pickle.loads(pickle.dumps((robot, data)))
    np.testing.assert_array_equal(armlab.inertia_matrix(copy[0], q, data=copy[1]), B)


def test_a_call_without_data_keeps_nothing_and_equals_a_call_with_data():
    robot = armlab.load_robot("prp").replace(name="short-lived")
    q, qd = np.array([0.1, 0.5, 0.2]), np.array([0.3, -0.2, 0.4])
    data = DynamicsData(robot)
    for dynamics_choice in ("numeric", "closed_form", "auto"):
        np.testing.assert_array_equal(armlab.inverse_dynamics(robot, q, qd, q, dynamics=dynamics_choice),
                                      armlab.inverse_dynamics(robot, q, qd, q, dynamics=dynamics_choice,
                                                              data=data))
    np.testing.assert_array_equal(armlab.inertia_matrix(robot, q), armlab.inertia_matrix(robot, q, data=data))
    np.testing.assert_array_equal(armlab.forward_dynamics(robot, q, qd, q),
                                  armlab.forward_dynamics(robot, q, qd, q, data=data))
    assert armlab.kinetic_energy(robot, q, qd) == armlab.kinetic_energy(robot, q, qd, data=data)
    # Nothing in armlab holds the robot once its caller lets it go (no map keyed by robots).
    alive = weakref.ref(robot)
    del robot, data
    gc.collect()
    assert alive() is None


def test_nothing_is_written_into_a_robot():
    from armlab.control.base import Signal
    from armlab.control.joint_space import JointInverseDynamics
    from armlab.references.joint import Constant
    from armlab.simulation import simulate
    from armlab.specialise import closed_form_module

    robot = armlab.load_robot("prp")
    before = dict(robot.__dict__)
    z = np.zeros(3)
    for dynamics_choice in ("numeric", "closed_form", "auto"):
        armlab.inverse_dynamics(robot, z, z, z, dynamics=dynamics_choice)
        armlab.forward_dynamics(robot, z, z, z, dynamics=dynamics_choice)
    armlab.coriolis_matrix(robot, z, z)
    armlab.kinetic_energy(robot, z, z)
    closed_form_module(robot)
    Signal.joint("q", robot, "position")
    simulate(robot, JointInverseDynamics(robot, Constant(z), 25.0, 10.0), q0=z, t_final=0.01, dt=1e-3)
    assert robot.__dict__.keys() == before.keys()
    assert all(robot.__dict__[key] is value for key, value in before.items())
