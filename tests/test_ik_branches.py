"""Inverse kinematics with every branch: 8 analytic solutions of the PUMA 560 (and of other 6R
arms with a spherical wrist) and of the UR5 (three parallel axes), distinct verified branches
by multi-start least squares."""

from __future__ import annotations

import numpy as np
import pytest

import armlab
from armlab import forward_kinematics
from armlab.inverse_kinematics import inverse_kinematics, parallel_axes_structure, spherical_wrist_structure
from armlab.inverse_kinematics.common import distance
from armlab.model.robot import DHRow, Inertial, Joint, Link, Robot
from armlab.spatial import euler_matrix, transform

RNG = np.random.default_rng(12)


def _dh_robot(name, rows):
    joints = [Joint.from_dh(f"q{i + 1}", "revolute", DHRow(*row)) for i, row in enumerate(rows)]
    return Robot(name=name, joints=joints, links=[Link(f"l{i + 1}", Inertial(mass=1.0)) for i in range(6)])


# Universal Robots UR5, standard DH (a, α, d, θ) as published by the manufacturer.
UR5_DH = _dh_robot("ur5_dh", [(0, np.pi / 2, 0.089159, 0), (-0.425, 0, 0, 0), (-0.39225, 0, 0, 0),
                              (0, np.pi / 2, 0.10915, 0), (0, -np.pi / 2, 0.09465, 0), (0, 0, 0.0823, 0)])


def _same(a, b):
    d = np.angle(np.exp(1j * (np.asarray(a) - b)))
    return np.abs(d).max() < 1e-7


def _check_branches(robot, q, solutions, tol=1e-9):
    T = forward_kinematics(robot, q)
    for s in solutions:
        assert np.abs(forward_kinematics(robot, s) - T).max() <= tol
    for i in range(len(solutions)):
        for j in range(i):
            assert not _same(solutions[i], solutions[j])
    assert any(_same(s, q) for s in solutions)


def test_puma560_has_eight_branches_at_a_generic_pose():
    puma = armlab.load_robot("puma560")
    assert spherical_wrist_structure(puma) is not None
    for _ in range(5):
        q = RNG.uniform(-1.2, 1.2, 6)
        solutions = inverse_kinematics(puma, forward_kinematics(puma, q), respect_limits=False)
        assert len(solutions) == 8
        _check_branches(puma, q, solutions)
        # Inside the joint limits: a subset, every one inside.
        limited = inverse_kinematics(puma, forward_kinematics(puma, np.clip(q, -0.7, 0.7)))
        assert 1 <= len(limited) <= 8
        assert np.all(limited >= puma.arrays.q_min) and np.all(limited <= puma.arrays.q_max)


def test_other_spherical_wrist_arms():
    """Random PUMA-like geometry (axes 1, 2 meet; axes 4, 5, 6 meet), with base and tool."""
    for _ in range(5):
        a2, a3, d2, d3, d4, d6 = RNG.uniform(0.05, 0.6, 6) * RNG.choice([-1, 1], 6)
        robot = _dh_robot("wrist6", [(0, np.pi / 2, 0.3, 0.2), (a2, 0, d2, 0.1), (a3, np.pi / 2, d3, 0),
                                     (0, -np.pi / 2, d4, 0), (0, np.pi / 2, 0, 0), (0, 0, d6, 0)])
        base = transform(euler_matrix((0.3, 0.2, 0.1), "zyz"), (0.1, 0, 0.2))
        robot = robot.replace(base=base, tool=transform(None, (0.02, 0.0, 0.05)))
        assert spherical_wrist_structure(robot) is not None
        q = RNG.uniform(-2, 2, 6)
        solutions = inverse_kinematics(robot, forward_kinematics(robot, q), respect_limits=False)
        assert 2 <= len(solutions) <= 8
        _check_branches(robot, q, solutions)


def test_ur5_returns_several_verified_branches_by_least_squares():
    assert spherical_wrist_structure(UR5_DH) is None  # consecutive parallel axes 2, 3, 4
    for _ in range(3):
        q = RNG.uniform(-2, 2, 6)
        solutions = inverse_kinematics(UR5_DH, forward_kinematics(UR5_DH, q), respect_limits=False,
                                       method="dls")
        assert len(solutions) >= 4
        _check_branches(UR5_DH, q, solutions)


@pytest.mark.parametrize("q5", [1e-7, -5e-8, 3e-8, 1e-5])
def test_puma560_keeps_every_branch_at_the_edge_of_its_wrist_singularity(q5):
    """|q5| ≈ 10⁻⁷: the two wrist branches nearly meet and round-off left ~10⁻⁷ of residual;
    all 8 branches stay, the target's own among them."""
    puma = armlab.load_robot("puma560")
    q = np.array([0.3, -0.4, 0.5, 0.6, q5, -0.2])
    solutions = inverse_kinematics(puma, forward_kinematics(puma, q), respect_limits=False)
    assert len(solutions) == 8
    _check_branches(puma, q, solutions)


def _ur5_poses():
    """Poses of the UR5 (DH) away from its singularities (elbow and wrist bent); some have
    eight real branches, some fewer (the other shoulder leaves the wrist out of reach)."""
    rng = np.random.default_rng(8)
    poses = []
    while len(poses) < 6:
        q = rng.uniform(-np.pi, np.pi, 6)
        q[2] = rng.uniform(0.5, 2.0) * rng.choice([-1, 1])
        q[4] = rng.uniform(0.4, 2.6) * rng.choice([-1, 1])
        poses.append(q)
    return poses


@pytest.mark.parametrize("q", _ur5_poses())
def test_ur5_closed_form_gives_all_eight_branches(q):
    """K13 against forward kinematics (every branch reaches the pose within 1e-9, the target's
    own among them) and against an independent search: 400 least-squares starts find no
    branch the closed form lacks.  Real branches come in wrist pairs: 2, 4, 6 or 8."""
    assert parallel_axes_structure(UR5_DH) is not None
    T = forward_kinematics(UR5_DH, q)
    solutions = inverse_kinematics(UR5_DH, T, respect_limits=False)
    _check_branches(UR5_DH, q, solutions)
    searched = inverse_kinematics(UR5_DH, T, respect_limits=False, method="dls", restarts=400)
    assert all(min(distance(UR5_DH, s, c) for c in solutions) < 1e-6 for s in searched)
    assert len(solutions) in (2, 4, 6, 8)


@pytest.mark.parametrize("q5", [1e-7, -1e-4, 1e-3])
def test_ur5_closed_form_near_its_wrist_singularity(q5):
    q = np.array([0.4, -1.1, 1.3, -0.6, q5, 0.9])
    solutions = inverse_kinematics(UR5_DH, forward_kinematics(UR5_DH, q), respect_limits=False)
    _check_branches(UR5_DH, q, solutions)


def test_multi_start_returns_each_branch_once_near_a_singularity():
    """UR5 at q5 = 10⁻⁴: the starts converge anywhere along an almost flat valley, 2–6·10⁻⁶ rad
    apart; each branch is returned once (no two solutions within 10⁻³ rad)."""
    for seed in range(3):
        q = np.random.default_rng(seed).uniform(-2, 2, 6)
        q[4] = 1e-4
        T = forward_kinematics(UR5_DH, q)
        solutions = inverse_kinematics(UR5_DH, T, respect_limits=False, method="dls")
        for i in range(len(solutions)):
            assert np.abs(forward_kinematics(UR5_DH, solutions[i]) - T).max() <= 1e-9
            for j in range(i):
                assert distance(UR5_DH, solutions[i], solutions[j]) > 1e-3
        assert len(solutions) <= len(inverse_kinematics(UR5_DH, T, respect_limits=False))


def test_zoo_ur5_branches_respect_its_limits():
    from armlab.robots import zoo

    if not zoo.installed(zoo.ZOO["ur5"]):
        pytest.skip("example-robot-data is not installed (pip install example-robot-data)")
    ur5 = armlab.load_robot("ur5")
    assert parallel_axes_structure(ur5) is not None
    q = np.array([0.3, -1.2, 1.4, -0.7, 1.1, 0.4])
    assert len(inverse_kinematics(ur5, forward_kinematics(ur5, q), respect_limits=False)) == 8
    solutions = inverse_kinematics(ur5, forward_kinematics(ur5, q))
    assert len(solutions) >= 3
    _check_branches(ur5, q, solutions)
    assert np.all(solutions >= ur5.arrays.q_min) and np.all(solutions <= ur5.arrays.q_max)


def test_redundant_arm_returns_one_solution():
    panda_like = _dh_robot("r6", [(0.1, 0.5, 0.2, 0), (0.3, -0.4, 0, 0), (0.2, 0.9, 0.1, 0),
                                  (0.1, -1.1, 0, 0), (0.05, 0.7, 0.1, 0), (0.1, 0, 0, 0)])
    q = RNG.uniform(-1, 1, 6)
    (s,) = inverse_kinematics(panda_like, forward_kinematics(panda_like, q)[:3, 3])  # 6 joints, 3 rows
    assert np.allclose(forward_kinematics(panda_like, s)[:3, 3], forward_kinematics(panda_like, q)[:3, 3],
                       atol=1e-9)
