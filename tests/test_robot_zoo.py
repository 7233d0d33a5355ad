"""Real robot files: the arms of ``example-robot-data`` loaded by armlab agree with Pinocchio.

Pinocchio reads the same URDF file; the joints armlab locks (side branches: fingers, grippers,
heads, other arms) are locked in Pinocchio's model too, by ``buildReducedModel`` at
Pinocchio's neutral configuration (q = 0, which lies inside every such joint's limits here),
the configuration armlab's loader states in its note.  Inverse dynamics, mass matrix, gravity,
C q̇ and forward dynamics must agree to 1e-12 relative at random states.  The tests are
skipped, with the reason, when ``example-robot-data`` is not installed.
"""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab.robots import zoo
from strategies import without_actuators

pin = pytest.importorskip("pinocchio", reason="Pinocchio is the reference (pip install pin)")

RTOL = 1e-12
NAMES = zoo.zoo_names()
needs_package = pytest.mark.skipif(
    not any(zoo.installed(zoo.ZOO[n]) for n in NAMES),
    reason="example-robot-data is not installed (pip install example-robot-data)")


def reduced_pinocchio_model(robot, path):
    """Pinocchio's model of ``path`` with every joint not in ``robot`` locked at neutral."""
    full = pin.buildModelFromUrdf(str(path))
    keep = set(robot.joint_names)
    locked = [j for j in range(1, full.njoints) if full.names[j] not in keep]
    model = pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full
    assert [model.names[j] for j in range(1, model.njoints)] == robot.joint_names
    return model, model.createData()


def to_pin_q(model, q):
    out = pin.neutral(model)
    for i in range(1, model.njoints):
        joint = model.joints[i]
        if joint.nq == 2:  # a continuous joint: (cos q, sin q)
            out[joint.idx_q:joint.idx_q + 2] = np.cos(q[i - 1]), np.sin(q[i - 1])
        else:
            out[joint.idx_q] = q[i - 1]
    return out


def assert_close(actual, expected, what, floor=1e-12):
    scale = max(float(np.abs(expected).max()), floor)
    error = float(np.abs(np.asarray(actual) - np.asarray(expected)).max())
    assert error <= RTOL * scale, f"{what}: max error {error:.3e} (scale {scale:.3e})"


@needs_package
@pytest.mark.parametrize("name", NAMES)
def test_zoo_arm_matches_pinocchio(name):
    if not zoo.installed(zoo.ZOO[name]):
        pytest.skip(f"{zoo.ZOO[name].file} is not in the installed example-robot-data")
    robot = armlab.load_robot(name)
    # URDF damping/friction become armlab friction; Pinocchio's dynamics leave them out.
    rigid = without_actuators(robot)
    model, data = reduced_pinocchio_model(robot, zoo.zoo_path(name))
    rng = np.random.default_rng(5)
    lo = np.maximum(robot.arrays.q_min, -np.pi)
    hi = np.minimum(robot.arrays.q_max, np.pi)
    for _ in range(5):
        q = rng.uniform(lo, hi)
        qd, qdd = rng.uniform(-2.0, 2.0, (2, robot.n))
        qp = to_pin_q(model, q)
        tau_pin = pin.rnea(model, data, qp, qd, qdd)
        assert_close(armlab.inverse_dynamics(rigid, q, qd, qdd), tau_pin, "rnea")
        B = pin.crba(model, data, qp)
        B = np.triu(B) + np.triu(B, 1).T
        assert_close(armlab.inertia_matrix(robot, q), B, "crba")
        g = pin.computeGeneralizedGravity(model, data, qp)
        assert_close(armlab.gravity_torque(robot, q), g, "gravity")
        nle = pin.nonLinearEffects(model, data, qp, qd)
        assert_close(armlab.coriolis_matrix(robot, q, qd) @ qd, nle - g, "C q̇",
                     floor=max(float(np.abs(nle).max()), float(np.abs(g).max())))
        aba = pin.aba(model, data, qp, qd, tau_pin)
        assert_close(armlab.forward_dynamics(rigid, q, qd, tau_pin), aba, "aba")


def test_zoo_name_without_its_package_says_what_to_install(monkeypatch, capsys):
    from armlab.cli import main

    monkeypatch.setattr(zoo, "_package_root", lambda package: None)
    with pytest.raises(armlab.RobotFileError) as info:
        armlab.load_robot("ur5")
    assert str(info.value) == ("ur5: name: is a robot of the package 'example-robot-data', which is "
                               "not installed (pip install example-robot-data)")
    assert main(["robots", "--zoo"]) == 0
    out = capsys.readouterr().out
    assert f"{len(NAMES)} arms of example-robot-data, which is not installed" in out


@needs_package
def test_zoo_listing_and_provenance(capsys):
    from armlab.cli import main

    assert main(["robots", "--zoo"]) == 0
    listing = capsys.readouterr().out
    assert "ur5" in listing and "RRRRRR" in listing
    assert main(["robots", "panda"]) == 0
    out = capsys.readouterr().out
    assert "note: from example-robot-data" in out and "panda_finger_joint1 = 0" in out
