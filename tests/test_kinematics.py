"""Forward kinematics, geometric/analytic Jacobians and J̇q̇ (K2–K6 of docs/notation.md).

References: the PRP's T_3^0 and T_3^base multiplied out by hand from the DH rows of
``robots/prp.toml`` (written below, not computed by armlab), and central finite differences of
forward kinematics for every Jacobian on the PRP and on randomly built robots.
"""

import numpy as np
import pytest

from armlab.kernels.kinematics import (
    analytic_jacobian_dot_qd_kernel,
    analytic_jacobian_kernel,
    jacobian_dot_qd_kernel,
    kinematics_workspace,
    pose_vector_into,
)
from armlab.kinematics import (
    analytic_jacobian,
    forward_kinematics,
    geometric_jacobian,
    jacobian_dot_qd,
    link_frames,
    pose_vector,
)
from armlab.model import DHRow, Inertial, Link, Robot
from armlab.model.robot import Joint
from armlab.robots import load_robot
from armlab.spatial import RPY, ZYZ, RepresentationSingularityError, euler_matrix, rot_x, rot_z, transform

RNG = np.random.default_rng(20261121)
PRP = load_robot("prp")
L0, L2, L3, L4 = (PRP.parameters[k] for k in ("L0", "L2", "L3", "L4"))


def prp_T30(d1, t2, d3):
    """T_3^0 of the PRP, multiplied out by hand from A1 A2 A3 of prp.toml's DH rows."""
    c2, s2 = np.cos(t2), np.sin(t2)
    rho = L4 / 2 - d3
    return np.array([[0, -c2, s2, s2 * rho],
                     [0, -s2, -c2, -c2 * rho],
                     [1, 0, 0, L2 / 2 + L3 + d1],
                     [0, 0, 0, 1]])


def prp_T3base(d1, t2, d3):
    """T_3^base = A_0^base T_3^0 with A_0^base = [[0,0,1,0],[1,0,0,0],[0,1,0,L0]] (by hand)."""
    c2, s2 = np.cos(t2), np.sin(t2)
    rho = L4 / 2 - d3
    return np.array([[1, 0, 0, L2 / 2 + L3 + d1],
                     [0, -c2, s2, s2 * rho],
                     [0, -s2, -c2, L0 - c2 * rho],
                     [0, 0, 0, 1]])


def prp_jacobian_0(d1, t2, d3):
    """Geometric Jacobian of the PRP in Σ_0 by differentiating prp_T30's position by hand."""
    c2, s2 = np.cos(t2), np.sin(t2)
    rho = L4 / 2 - d3
    return np.array([[0, c2 * rho, -s2], [0, s2 * rho, c2], [1, 0, 0],
                     [0, 0, 0], [0, 0, 0], [0, 1, 0]], dtype=float)


def random_prp_q():
    return np.array([RNG.uniform(-0.15, 0.35), RNG.uniform(-3.5, 3.5), RNG.uniform(-0.15, 0.35)])


def random_robot(n, rng, modified=False, urdf_joint=None):
    """A serial robot with random DH rows (mixed joint kinds), base and tool transforms."""
    joints, links = [], []
    for i in range(n):
        kind = "prismatic" if (i % 3 == 1) else "revolute"
        row = DHRow(a=rng.uniform(-0.5, 0.5), alpha=rng.uniform(-np.pi, np.pi), d=rng.uniform(-0.5, 0.5),
                    theta=rng.uniform(-np.pi, np.pi), convention="modified" if modified else "standard")
        joints.append(Joint.from_dh(f"j{i + 1}", kind, row))
        links.append(Link(f"l{i + 1}", Inertial(mass=1.0)))
    if urdf_joint is not None:
        # a URDF-style placement (origin + arbitrary axis) in the middle of the chain
        axis = rng.normal(size=3)
        z = axis / np.linalg.norm(axis)
        x = np.cross([1.0, 0, 0] if abs(z[0]) < 0.9 else [0, 1.0, 0], z)
        x /= np.linalg.norm(x)
        align = transform(np.column_stack((x, np.cross(z, x), z)))
        origin = transform(euler_matrix(rng.uniform(-3, 3, 3), "zyz"), rng.uniform(-0.3, 0.3, 3))
        joints[urdf_joint] = Joint(name="u", kind="revolute", before=origin @ align,
                                   after=np.linalg.inv(align))
    base = transform(euler_matrix(rng.uniform(-3, 3, 3), "rpy"), rng.uniform(-1, 1, 3))
    tool = transform(rot_x(rng.uniform(-3, 3)) @ rot_z(rng.uniform(-3, 3)), rng.uniform(-0.2, 0.2, 3))
    return Robot(name=f"random{n}", joints=joints, links=links, base=base, tool=tool)


RANDOM_ROBOTS = [random_robot(6, np.random.default_rng(1)),
                 random_robot(4, np.random.default_rng(2), modified=True),
                 random_robot(5, np.random.default_rng(3), urdf_joint=2)]


def fd_geometric_jacobian(robot, q, frame, h=1e-6):
    """[ṗ; ω] columns by central differences: ω from S(ω) = Ṙ Rᵀ."""
    J = np.zeros((6, robot.n))
    R = forward_kinematics(robot, q, frame)[:3, :3]
    for i in range(robot.n):
        dq = np.zeros(robot.n)
        dq[i] = h
        Tp, Tm = forward_kinematics(robot, q + dq, frame), forward_kinematics(robot, q - dq, frame)
        J[:3, i] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        W = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ R.T
        J[3:, i] = [W[2, 1], W[0, 2], W[1, 0]]
    return J


def test_prp_fk_matches_closed_form_from_sigma_0_and_base():
    for _ in range(20):
        q = random_prp_q()
        assert np.allclose(forward_kinematics(PRP, q, frame="0"), prp_T30(*q), atol=1e-12)
        assert np.allclose(forward_kinematics(PRP, q, frame="base"), prp_T3base(*q), atol=1e-12)
        assert np.allclose(geometric_jacobian(PRP, q, frame="0"), prp_jacobian_0(*q), atol=1e-12)


def test_link_frames_end_at_the_end_effector():
    q = random_prp_q()
    frames = link_frames(PRP, q)
    assert frames.shape == (PRP.n + 2, 4, 4)
    assert np.allclose(frames[-1], forward_kinematics(PRP, q))
    assert np.allclose(frames[0], PRP.base)


def test_seed_x0_is_the_prp_pose_on_the_negative_zyz_branch():
    x = pose_vector(PRP, [0.1, 0.0, 0.0], euler="zyz", frame="0", branch=-1)
    assert np.allclose(x, [0, -0.2, 0.5, np.pi / 2, -np.pi / 2, 0], atol=1e-12)
    # on that branch φ = θ2 + π/2, ϑ = −π/2, ψ = 0 for every θ2 (mod 2π); on the positive one
    # φ = θ2 − π/2, ϑ = π/2, ψ = π
    for t2 in RNG.uniform(-3, 3, 5):
        x = pose_vector(PRP, [0.0, t2, 0.1], frame="0", branch=-1)
        assert np.allclose(np.angle(np.exp(1j * (x[3:] - [t2 + np.pi / 2, -np.pi / 2, 0]))), 0, atol=1e-12)
        x = pose_vector(PRP, [0.0, t2, 0.1], frame="0", branch=1)
        assert np.allclose(np.angle(np.exp(1j * (x[3:] - [t2 - np.pi / 2, np.pi / 2, np.pi]))), 0, atol=1e-12)


@pytest.mark.parametrize("frame", ["0", "base"])
@pytest.mark.parametrize("robot", [PRP, *RANDOM_ROBOTS], ids=lambda r: getattr(r, "name", ""))
def test_geometric_jacobian_equals_finite_differences(robot, frame):
    rng = np.random.default_rng(7)
    for _ in range(3):
        q = rng.uniform(-1, 1, robot.n) * 0.3
        assert np.allclose(geometric_jacobian(robot, q, frame), fd_geometric_jacobian(robot, q, frame),
                           atol=1e-8)


def fd_analytic_jacobian(robot, q, euler, frame, h=1e-6):
    x = pose_vector(robot, q, euler, frame)
    J = np.zeros((6, robot.n))
    for i in range(robot.n):
        dq = np.zeros(robot.n)
        dq[i] = h
        # angles nearest to x's: no 2π jumps between the two samples
        xp = pose_vector(robot, q + dq, euler, frame, branch=x[3:])
        xm = pose_vector(robot, q - dq, euler, frame, branch=x[3:])
        J[:, i] = (xp - xm) / (2 * h)
    return J


@pytest.mark.parametrize("euler", ["zyz", "rpy"])
@pytest.mark.parametrize("robot", RANDOM_ROBOTS, ids=lambda r: r.name)
def test_analytic_jacobian_equals_finite_differences(robot, euler):
    rng = np.random.default_rng(11)
    for frame in ("0", "base"):
        q = rng.uniform(-1, 1, robot.n)
        expected = fd_analytic_jacobian(robot, q, euler, frame)
        assert np.allclose(analytic_jacobian(robot, q, euler, frame), expected, atol=1e-7)


def test_prp_analytic_jacobian_zyz_in_sigma_0_both_branches():
    for _ in range(5):
        q = random_prp_q()
        for branch in (1, -1):
            x = pose_vector(PRP, q, "zyz", "0", branch)
            J_A = analytic_jacobian(PRP, q, "zyz", "0", branch)
            J_fd = np.zeros((6, 3))
            for i in range(3):
                dq = np.zeros(3)
                dq[i] = 1e-6
                J_fd[:, i] = (pose_vector(PRP, q + dq, "zyz", "0", x[3:])
                              - pose_vector(PRP, q - dq, "zyz", "0", x[3:])) / 2e-6
            assert np.allclose(J_A, J_fd, atol=1e-8)
            # position rows equal the geometric ones; φ = θ2 ∓ π/2 on the ± branch, so φ̇ = θ̇2
            assert np.allclose(J_A[:3], prp_jacobian_0(*q)[:3], atol=1e-12)
            assert np.allclose(J_A[3:], [[0, 1, 0], [0, 0, 0], [0, 0, 0]], atol=1e-12)


def test_representation_singularities_of_the_prp_raise():
    # Σ_0: R_e's third row is (1, 0, 0), so RPY's pitch is always −π/2 (singular)
    with pytest.raises(RepresentationSingularityError, match="RPY"):
        analytic_jacobian(PRP, random_prp_q(), "rpy", "0")
    # Σ_base: R_e[2, 2] = −cos θ2, so ZYZ is singular at θ2 = 0 (the seed's x0 configuration)
    with pytest.raises(RepresentationSingularityError, match="ZYZ"):
        analytic_jacobian(PRP, [0.1, 0.0, 0.0], "zyz", "base")
    with pytest.raises(RepresentationSingularityError):
        jacobian_dot_qd(PRP, [0.1, 0.0, 0.0], [0.1, 0.2, 0.3], frame="base", euler="zyz")
    assert np.all(np.isfinite(analytic_jacobian(PRP, [0.1, 0.0, 0.0], "rpy", "base")))
    # RPY in Σ_base: R_e = [[1, 0, 0], [0, −c2, s2], [0, −s2, −c2]] gives (0, 0, θ2 + π)
    for t2 in RNG.uniform(-3, 3, 5):
        angles = pose_vector(PRP, [0.0, t2, 0.0], "rpy", "base")[3:]
        assert np.allclose(np.angle(np.exp(1j * (angles - [0, 0, t2 + np.pi]))), 0, atol=1e-12)


def fd_jdot_qd(jacobian, q, qd, h=1e-6):
    return (jacobian(q + h * qd) - jacobian(q - h * qd)) / (2 * h) @ qd


@pytest.mark.parametrize("robot", [PRP, *RANDOM_ROBOTS], ids=lambda r: r.name)
def test_jacobian_dot_qd_equals_finite_differences_of_j(robot):
    rng = np.random.default_rng(5)
    for frame in ("0", "base"):
        q, qd = rng.uniform(-1, 1, robot.n) * 0.3, rng.uniform(-2, 2, robot.n)
        expected = fd_jdot_qd(lambda s, f=frame: geometric_jacobian(robot, s, f), q, qd)
        assert np.allclose(jacobian_dot_qd(robot, q, qd, frame), expected, atol=1e-6)


@pytest.mark.parametrize("euler", ["zyz", "rpy"])
@pytest.mark.parametrize("robot", RANDOM_ROBOTS[:2], ids=lambda r: r.name)
def test_analytic_jacobian_dot_qd_equals_finite_differences_of_j_a(robot, euler):
    rng = np.random.default_rng(9)
    for frame in ("0", "base"):
        q, qd = rng.uniform(-1, 1, robot.n), rng.uniform(-2, 2, robot.n)
        reference = pose_vector(robot, q, euler, frame)[3:]
        expected = fd_jdot_qd(lambda s, f=frame: analytic_jacobian(robot, s, euler, f, reference), q, qd)
        assert np.allclose(jacobian_dot_qd(robot, q, qd, frame, euler=euler), expected, atol=1e-6)


def test_prp_jacobian_dot_qd_by_hand():
    # differentiating prp_jacobian_0 along q̇: J̇q̇ = [−s2 ρ θ̇2² − 2 c2 θ̇2 ḋ3, c2 ρ θ̇2² − 2 s2 θ̇2 ḋ3, 0; 0, 0, 0]
    q, qd = random_prp_q(), np.array([0.3, -1.2, 0.4])
    d1, t2, d3 = q
    rho = L4 / 2 - d3
    expected = [-np.sin(t2) * rho * qd[1] ** 2 - 2 * np.cos(t2) * qd[1] * qd[2],
                np.cos(t2) * rho * qd[1] ** 2 - 2 * np.sin(t2) * qd[1] * qd[2], 0, 0, 0, 0]
    assert np.allclose(jacobian_dot_qd(PRP, q, qd, frame="0"), expected, atol=1e-12)


def test_compiled_workspace_kernels_agree_with_the_public_functions():
    robot = RANDOM_ROBOTS[0]
    q, qd = np.linspace(-0.5, 0.7, 6), np.linspace(1.0, -1.0, 6)
    ws = kinematics_workspace(robot.n)
    x, J_A, a = np.empty(6), np.empty((6, robot.n)), np.empty(6)
    for code, name in ((ZYZ, "zyz"), (RPY, "rpy")):
        for in_base, frame in ((False, "0"), (True, "base")):
            pose_vector_into(robot.arrays, q, code, -1, np.zeros(3), in_base, ws, x)
            assert np.allclose(x, pose_vector(robot, q, name, frame, -1))
            analytic_jacobian_kernel(robot.arrays, q, code, 1, np.zeros(3), in_base, ws, J_A)
            assert np.allclose(J_A, analytic_jacobian(robot, q, name, frame))
            analytic_jacobian_dot_qd_kernel(robot.arrays, q, qd, code, 1, np.zeros(3), in_base, ws, a)
            assert np.allclose(a, jacobian_dot_qd(robot, q, qd, frame, euler=name))
            jacobian_dot_qd_kernel(robot.arrays, q, qd, in_base, ws, a)
            assert np.allclose(a, jacobian_dot_qd(robot, q, qd, frame))


def test_bad_shapes_and_names_are_reported():
    with pytest.raises(ValueError, match="q must have shape"):
        forward_kinematics(PRP, [0.0, 0.0])
    with pytest.raises(ValueError, match="qd must have shape"):
        jacobian_dot_qd(PRP, [0.0, 0.0, 0.0], [0.0])
    with pytest.raises(ValueError, match="frame"):
        analytic_jacobian(PRP, [0.0, 0.0, 0.0], frame="world")
    with pytest.raises(ValueError, match="euler"):
        pose_vector(PRP, [0.0, 0.0, 0.0], euler="xyz")


@pytest.mark.parametrize("name", ["planar2r", "puma560"])
def test_bundled_robots_jacobians_equal_finite_differences(name):
    robot = load_robot(name)
    q = np.linspace(0.2, -0.4, robot.n)
    assert np.allclose(geometric_jacobian(robot, q), fd_geometric_jacobian(robot, q, "base"), atol=1e-8)


def test_compiled_kernels_allocate_nothing_per_call():
    from numba import njit
    from numba.core.runtime import _nrt_python, rtsys

    @njit
    def loop(m, q, qd, ref, ws, out, J, reps):
        for _ in range(reps):
            analytic_jacobian_dot_qd_kernel(m, q, qd, ZYZ, 0, ref, True, ws, out)
            jacobian_dot_qd_kernel(m, q, qd, False, ws, out)
            analytic_jacobian_kernel(m, q, RPY, 1, ref, False, ws, J)
            pose_vector_into(m, q, ZYZ, -1, ref, True, ws, out)

    robot = RANDOM_ROBOTS[0]
    args = (robot.arrays, np.linspace(0.1, 0.6, 6), np.ones(6), np.zeros(3), kinematics_workspace(6),
            np.empty(6), np.empty((6, 6)))
    loop(*args, 1)
    _nrt_python.memsys_enable_stats()
    try:
        counts = []
        for reps in (1, 200):
            before = rtsys.get_allocation_stats().alloc
            loop(*args, reps)
            counts.append(rtsys.get_allocation_stats().alloc - before)
    finally:
        _nrt_python.memsys_disable_stats()
    # only the boxing of the arguments allocates, once per call from Python
    assert counts[0] == counts[1]


@pytest.mark.parametrize("robot", [PRP, load_robot("puma560"), RANDOM_ROBOTS[1]], ids=lambda r: r.name)
def test_jacobian_and_jdot_qd_agree_with_pinocchio(robot):
    """Pinocchio (an independent implementation) on armlab's URDF export, in Σ_base."""
    import pinocchio as pin

    from armlab.model.urdf_io import world_rotation
    from pinocchio_model import pinocchio_model, pinocchio_q, pinocchio_v, v_index

    model, data = pinocchio_model(robot)
    frame_id = model.getFrameId("sigma_e", pin.BODY)
    columns = v_index(robot, model)
    to_base = np.kron(np.eye(2), world_rotation(robot).T)
    rng = np.random.default_rng(12)
    for _ in range(3):
        q, qd = rng.uniform(-1, 1, robot.n) * 0.3, rng.uniform(-2, 2, robot.n)
        q_pin, v_pin = pinocchio_q(robot, model, q), pinocchio_v(robot, model, qd)
        pin.computeJointJacobians(model, data, q_pin)
        pin.updateFramePlacements(model, data)
        J_pin = pin.getFrameJacobian(model, data, frame_id, pin.LOCAL_WORLD_ALIGNED)[:, columns]
        J_pin = to_base @ J_pin  # Pinocchio's world is the export's root (see pinocchio_model)
        assert np.allclose(geometric_jacobian(robot, q, "base"), J_pin, atol=1e-10)
        pin.forwardKinematics(model, data, q_pin, v_pin, np.zeros(model.nv))
        pin.updateFramePlacements(model, data)
        acc = pin.getFrameClassicalAcceleration(model, data, frame_id, pin.LOCAL_WORLD_ALIGNED)
        acc_base = to_base @ np.concatenate([acc.linear, acc.angular])
        assert np.allclose(jacobian_dot_qd(robot, q, qd, "base"), acc_base, atol=1e-10)
