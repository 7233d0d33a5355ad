"""Inverse kinematics: PRP closed form on both branches (K7) and damped least squares (K8).

The PRP reference formulas are derived by hand from T_3^0 / T_3^base (docs/notation.md) and
written out here; DLS solutions are checked by forward kinematics, never by the solver itself.
"""

from dataclasses import replace

import numpy as np
import pytest

from armlab.inverse_kinematics import UnreachableTargetError, cylindrical_prp_structure, inverse_kinematics
from armlab.kinematics import forward_kinematics, pose_vector
from armlab.model import DHRow, Inertial, Link, Robot
from armlab.model.robot import Joint
from armlab.robots import load_robot
from armlab.spatial import euler_matrix, transform

PRP = load_robot("prp")
L0, L2, L3, L4 = (PRP.parameters[k] for k in ("L0", "L2", "L3", "L4"))
RNG = np.random.default_rng(3)


def prp_ik_sigma_0(p):
    """Both PRP solutions from Σ_0 (ρ = L4/2 − d3 = ±r): the seed's A1 with its slips fixed."""
    px, py, pz = p
    r = np.hypot(px, py)
    d1 = pz - L2 / 2 - L3
    return [np.array([d1, np.arctan2(px, -py), L4 / 2 - r]),     # ρ = +r
            np.array([d1, np.arctan2(-px, py), L4 / 2 + r])]     # ρ = −r


def prp_ik_sigma_base(p):
    """Both PRP solutions from Σ_base: x_b = L2/2 + L3 + d1, y_b = s2 ρ, z_b = L0 − c2 ρ."""
    xb, yb, zb = p
    r = np.hypot(yb, zb - L0)
    d1 = xb - L2 / 2 - L3
    return [np.array([d1, np.arctan2(yb, L0 - zb), L4 / 2 - r]),
            np.array([d1, np.arctan2(-yb, zb - L0), L4 / 2 + r])]


def same_configuration(q, other, revolute=(1,)):
    diff = np.asarray(q, float) - np.asarray(other, float)
    for i in revolute:
        diff[i] = np.angle(np.exp(1j * diff[i]))
    return np.allclose(diff, 0.0, atol=1e-9)


def contains(solutions, q, revolute=(1,)):
    return any(same_configuration(s, q, revolute) for s in solutions)


def test_prp_is_recognised_as_cylindrical():
    assert cylindrical_prp_structure(PRP) is not None
    assert cylindrical_prp_structure(load_robot("planar2r")) is None


@pytest.mark.parametrize(("frame", "hand"), [("0", prp_ik_sigma_0), ("base", prp_ik_sigma_base)])
def test_prp_closed_form_matches_the_hand_formulas(frame, hand):
    for _ in range(20):
        q = np.array([RNG.uniform(-0.15, 0.35), RNG.uniform(-np.pi, np.pi), RNG.uniform(-0.15, 0.35)])
        p = forward_kinematics(PRP, q, frame)[:3, 3]
        solutions = inverse_kinematics(PRP, p, frame=frame, respect_limits=False)
        assert solutions.shape == (2, 3)
        expected = hand(p)
        assert contains(expected, q)
        for s in expected:
            assert contains(solutions, s)
        # the first solution is the branch ρ = L4/2 − d3 ≥ 0
        assert same_configuration(solutions[0], expected[0])


def test_ik_of_fk_recovers_q_on_both_prp_branches():
    for _ in range(20):
        q = np.array([RNG.uniform(-0.15, 0.35), RNG.uniform(-3.0, 3.0), RNG.uniform(-0.15, 0.35)])
        other = np.array([q[0], q[1] + np.pi, L4 - q[2]])      # ρ → −ρ, θ2 → θ2 + π
        for frame in ("0", "base"):
            for q_true in (q, other):
                T = forward_kinematics(PRP, q_true, frame)
                solutions = inverse_kinematics(PRP, T[:3, 3], frame=frame, respect_limits=False)
                assert contains(solutions, q_true)
                for s in solutions:
                    assert np.allclose(forward_kinematics(PRP, s, frame)[:3, 3], T[:3, 3], atol=1e-12)
                # the full pose fixes θ2, hence the branch: exactly q_true
                (only,) = inverse_kinematics(PRP, T, frame=frame, respect_limits=False)
                assert same_configuration(only, q_true)


def test_q0_orders_the_branches_and_picks_the_revolute_turn():
    p = forward_kinematics(PRP, [0.1, 0.4, 0.0], "0")[:3, 3]
    near_second = inverse_kinematics(PRP, p, q0=[0.1, 0.4 + np.pi, 0.4], frame="0", respect_limits=False)
    # nearest on the circle first; 0.4 + π lies beyond θ2's limit 3.5 rad, so its turn 0.4 − π
    assert np.allclose(near_second, [[0.1, 0.4 - np.pi, 0.4], [0.1, 0.4, 0.0]])


def test_seed_poses_are_reachable_inside_the_limits():
    for p, q_expected in (([0, -0.2, 0.5], [0.1, 0, 0]), ([0, -0.1, 0.5], [0.1, 0, 0.1]),
                          ([0, -0.1, 0.4], [0.0, 0, 0.1])):
        solutions = inverse_kinematics(PRP, p, frame="0")
        assert np.allclose(solutions[0], q_expected, atol=1e-12)
        for q in solutions:
            assert np.all(q >= PRP.arrays.q_min) and np.all(q <= PRP.arrays.q_max)
            assert np.allclose(forward_kinematics(PRP, q, "0")[:3, 3], p, atol=1e-12)
    # x0's other branch needs d3 = 0.4 m, beyond the 0.35 m limit: it is dropped
    assert len(inverse_kinematics(PRP, [0, -0.2, 0.5], frame="0")) == 1
    x0 = [0, -0.2, 0.5, np.pi / 2, -np.pi / 2, 0]              # ZYZ, negative branch
    assert np.allclose(inverse_kinematics(PRP, x0, frame="0", euler="zyz"), [[0.1, 0, 0]], atol=1e-12)


def test_prp_limits_and_orientation_errors_are_explained():
    with pytest.raises(UnreachableTargetError, match=r"only outside its joint limits.*d3 = -0.7 m") as info:
        inverse_kinematics(PRP, [0, -0.9, 0.5], frame="0")
    assert info.value.reason == "joint limits"
    with pytest.raises(UnreachableTargetError, match="orientation not attainable") as info:
        inverse_kinematics(PRP, [0, -0.2, 0.5, 1.0, 1.0, 1.0], frame="0")
    assert info.value.reason == "orientation" and info.value.orientation_error > 0.1


def other_cylindrical_prp():
    """A P-R-P with other lengths, an offset a on joint 2, base and tool: not the seed's numbers."""
    rows = [("prismatic", DHRow(a=0.0, alpha=0.0, d=0.3, theta=0.4)),
            ("revolute", DHRow(a=0.12, alpha=-np.pi / 2, d=0.25, theta=0.0)),
            ("prismatic", DHRow(a=0.05, alpha=0.3, d=-0.1, theta=-np.pi / 2))]
    joints = [Joint.from_dh(f"j{i}", kind, row) for i, (kind, row) in enumerate(rows)]
    links = [Link(f"l{i}", Inertial(mass=1.0)) for i in range(3)]
    return Robot(name="prp2", joints=joints, links=links,
                 base=transform(euler_matrix((0.3, 1.0, -0.5), "zyz"), (0.1, -0.2, 0.4)),
                 tool=transform(euler_matrix((0.2, 0.1, 0.0), "rpy"), (0.04, -0.03, 0.07)))


def test_closed_form_covers_other_cylindrical_prp_arms():
    robot = other_cylindrical_prp()
    assert cylindrical_prp_structure(robot) is not None
    for _ in range(10):
        q = RNG.uniform(-0.5, 0.5, 3) * [1, 6, 1]
        p = forward_kinematics(robot, q)[:3, 3]
        solutions = inverse_kinematics(robot, p, respect_limits=False)
        assert len(solutions) == 2 and contains(solutions, q)
        for s in solutions:
            assert np.allclose(forward_kinematics(robot, s)[:3, 3], p, atol=1e-12)


def test_dls_on_the_prp_and_puma560():
    q = np.array([0.05, 1.0, 0.1])
    T = forward_kinematics(PRP, q)
    (s,) = inverse_kinematics(PRP, T, method="dls")
    assert np.allclose(s, q, atol=1e-8)
    puma = load_robot("puma560")
    for _ in range(3):
        q = RNG.uniform(-1, 1, 6)
        T = forward_kinematics(puma, q)
        for s in inverse_kinematics(puma, T, q0=q + RNG.uniform(-0.3, 0.3, 6), method="dls"):
            assert np.allclose(forward_kinematics(puma, s), T, atol=1e-8)
        for s in inverse_kinematics(puma, pose_vector(puma, q, "rpy"), euler="rpy", method="dls"):
            assert np.allclose(forward_kinematics(puma, s), T, atol=1e-8)
            assert np.all(s >= puma.arrays.q_min) and np.all(s <= puma.arrays.q_max)


def test_dls_position_only_on_a_redundant_random_robot():
    rng = np.random.default_rng(4)
    joints = [Joint.from_dh(f"j{i}", "revolute", DHRow(a=rng.uniform(0.1, 0.4), alpha=rng.uniform(-2, 2),
                                                        d=rng.uniform(-0.2, 0.2), theta=0.0))
              for i in range(4)]
    robot = Robot(name="r4", joints=joints, links=[Link(f"l{i}", Inertial(mass=1.0)) for i in range(4)])
    for _ in range(3):
        p = forward_kinematics(robot, rng.uniform(-2, 2, 4))[:3, 3]
        (s,) = inverse_kinematics(robot, p)
        assert np.allclose(forward_kinematics(robot, s)[:3, 3], p, atol=1e-8)


def test_out_of_reach_reports_the_distance():
    planar = load_robot("planar2r")         # two 1 m links: reach 2 m
    with pytest.raises(UnreachableTargetError, match="out of reach.* stays 1 m away") as info:
        inverse_kinematics(planar, [3.0, 0.0, 0.0])
    assert info.value.reason == "out of reach"
    assert info.value.position_error == pytest.approx(1.0, abs=1e-6)


def test_dls_explains_joint_limits():
    planar = load_robot("planar2r")
    limited = planar.replace(joints=tuple(replace(j, limits=(-0.5, 0.5)) for j in planar.joints))
    target = forward_kinematics(planar, [2.0, 0.3])[:3, 3]
    with pytest.raises(UnreachableTargetError, match="within its joint limits") as info:
        inverse_kinematics(limited, target)
    assert info.value.reason == "joint limits"
    for free in inverse_kinematics(limited, target, respect_limits=False):  # elbow up and down
        assert np.allclose(forward_kinematics(planar, free)[:3, 3], target, atol=1e-8)


def test_bad_requests_name_the_field():
    with pytest.raises(ValueError, match="target"):
        inverse_kinematics(PRP, [1.0, 2.0])
    with pytest.raises(ValueError, match="method"):
        inverse_kinematics(load_robot("planar2r"), [1.0, 0.0, 0.0], method="closed_form")
    with pytest.raises(ValueError, match="q0"):
        inverse_kinematics(PRP, [0, -0.2, 0.5], q0=[0.0])


def test_revolute_turns_are_reported_inside_the_limits():
    planar = load_robot("planar2r")
    shifted = planar.replace(joints=(replace(planar.joints[0], limits=(14.0, 16.0)), planar.joints[1]))
    target = forward_kinematics(planar, [15.0, 0.3])[:3, 3]
    for q0 in (None, [0.0, 0.0]):
        for q in inverse_kinematics(shifted, target, q0=q0):
            assert 14.0 <= q[0] <= 16.0
            assert np.allclose(forward_kinematics(planar, q)[:3, 3], target, atol=1e-8)
