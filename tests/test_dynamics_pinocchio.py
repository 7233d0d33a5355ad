"""armlab's compiled dynamics vs Pinocchio (an independent implementation), built from armlab's
URDF export: RNEA, CRBA, gravity, C q̇ and ABA on the bundled robots and on random robots.

The kinetic energy (½ q̇ᵀ B q̇ with B q̇ from armlab's RNEA) against Pinocchio's
``computeKineticEnergy`` (a body-by-body sum).

URDF and Pinocchio have no motor rotors or friction, so those are removed here
(``without_actuators``); their terms are checked against closed forms in test_dynamics.py.
Pinocchio works in Σ_base; joint-space quantities do not depend on the frame.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings

import armlab
from armlab import (
    coriolis_matrix,
    forward_dynamics,
    gravity_torque,
    inertia_matrix,
    inverse_dynamics,
)
from pinocchio_model import armlab_v, pinocchio_model, pinocchio_q, pinocchio_v
from strategies import robots, states, without_actuators

RTOL = 1e-9


def assert_close(actual, expected, what, floor=1e-12):
    # Relative to the largest entry (norm-wise), with a floor for all-zero references only
    # (or, for a difference of two Pinocchio results, the size of what was subtracted).
    scale = max(float(np.abs(expected).max()), floor)
    error = float(np.abs(np.asarray(actual) - np.asarray(expected)).max())
    assert error <= RTOL * scale, f"{what}: max error {error:.3e} (scale {scale:.3e})"


def compare_with_pinocchio(robot, q, qd, qdd):
    rigid = without_actuators(robot)
    model, data = pinocchio_model(rigid)
    qp, vp, ap = pinocchio_q(rigid, model, q), pinocchio_v(rigid, model, qd), pinocchio_v(rigid, model, qdd)

    tau = inverse_dynamics(rigid, q, qd, qdd)
    assert_close(tau, armlab_v(rigid, model, pin.rnea(model, data, qp, vp, ap)), "rnea")

    B_pin = pin.crba(model, data, qp)
    B_pin = np.triu(B_pin) + np.triu(B_pin, 1).T
    v_idx = [int(i) for i in armlab_v(rigid, model, np.arange(model.nv, dtype=float))]
    B_pin = B_pin[np.ix_(v_idx, v_idx)]
    assert_close(inertia_matrix(rigid, q), B_pin, "crba")

    g_pin = armlab_v(rigid, model, pin.computeGeneralizedGravity(model, data, qp))
    assert_close(gravity_torque(rigid, q), g_pin, "gravity")

    nle = armlab_v(rigid, model, pin.nonLinearEffects(model, data, qp, vp))
    # C q̇ = nle − g: its rounding residue is relative to nle and g (e.g. one joint: C q̇ ≡ 0).
    assert_close(coriolis_matrix(rigid, q, qd) @ qd, nle - g_pin, "C q̇",
                 floor=max(float(np.abs(nle).max()), float(np.abs(g_pin).max()), 1e-12))

    energy = pin.computeKineticEnergy(model, data, qp, vp)
    assert_close(armlab.kinetic_energy(rigid, q, qd), energy, "kinetic energy")

    aba = armlab_v(rigid, model, pin.aba(model, data, qp, vp, pinocchio_v(rigid, model, tau)))
    assert_close(forward_dynamics(rigid, q, qd, tau), aba, "aba")


@pytest.mark.parametrize("name", armlab.bundled_robot_names())
def test_bundled_robots_match_pinocchio(name):
    robot = armlab.load_robot(name)
    rng = np.random.default_rng(7)
    lo = np.maximum(robot.arrays.q_min, -2.0)
    hi = np.minimum(robot.arrays.q_max, 2.0)
    for _ in range(5):
        q = rng.uniform(lo, hi)
        qd, qdd = rng.uniform(-2.0, 2.0, (2, robot.n))
        compare_with_pinocchio(robot, q, qd, qdd)


@settings(max_examples=30)
@given(data=robots(max_joints=7).flatmap(lambda r: states(r.n).map(lambda s: (r, s))))
def test_random_robots_match_pinocchio(data):
    robot, (q, qd, qdd) = data
    compare_with_pinocchio(robot, q, qd, qdd)
