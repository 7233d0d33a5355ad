"""Task-space kernels and operational-space control (seed A9, A10)."""

import numpy as np
import pytest

from armlab.kernels.task_space import (
    ABSOLUTE,
    RELATIVE,
    measure_into,
    task_error_into,
    task_workspace,
)
from armlab.model.robot import DHRow, Inertial, Joint, Link, Robot
from armlab.references.task import PoseReference, path_singular_values
from armlab.robots import load_robot
from armlab.spatial import ZYZ, euler_matrix, rot_x, rot_z


def six_dof_arm() -> Robot:
    """An anthropomorphic 6R arm with a spherical wrist (Siciliano Table 2.3-like, test-only)."""
    rows = [DHRow(0, np.pi / 2, 0.3, 0), DHRow(0.5, 0, 0, 0), DHRow(0, np.pi / 2, 0, 0),
            DHRow(0, -np.pi / 2, 0.45, 0), DHRow(0, np.pi / 2, 0, 0), DHRow(0, 0, 0.1, 0)]
    joints = [Joint.from_dh(f"j{i + 1}", "revolute", row) for i, row in enumerate(rows)]
    links = [Link(f"l{i + 1}", Inertial(mass=1.0 + 0.2 * i, com=[0.01, 0.02, -0.03],
                                         inertia=np.diag([0.02, 0.03, 0.025])))
             for i in range(6)]
    return Robot("arm6", tuple(joints), tuple(links), gravity=np.array([0, 0, -9.81]))


def _error_at(robot, mode, reference, q, qd, t, angle_reference):
    ws = task_workspace(robot.n, 6)
    frame = reference.evaluate(t)
    measure_into(robot.arrays, q, qd, ws)
    task_error_into(mode, frame, ZYZ, angle_reference, qd, ws)
    return ws.x_err.copy(), ws.x_err_dot.copy(), ws.c.copy(), ws.JA.copy()


@pytest.mark.parametrize("mode", [RELATIVE, ABSOLUTE])
def test_error_rates_match_finite_differences_with_moving_target(mode):
    """x̃̇ = d/dt x̃ and x̃̈ = −J_A q̈ + c (T2–T4, T6), checked by central differences along a
    joint motion q(t) while the target frame itself moves (rotates and accelerates)."""
    robot = six_dof_arm()
    R0 = rot_z(0.4) @ rot_x(2.0)
    reference = PoseReference([0.0, 2.0], [[0.4, 0.1, 0.5], [0.2, 0.3, 0.6]],
                              [R0, rot_z(0.9) @ R0 @ rot_x(0.5)])
    q0 = np.array([0.2, 0.5, -0.4, 0.3, 0.9, -0.2])
    a, w = np.array([0.3, -0.2, 0.25, 0.4, -0.3, 0.2]), np.array([1.0, 1.3, 0.7, 1.1, 0.9, 1.7])

    def joint(t):
        return q0 + a * np.sin(w * t), a * w * np.cos(w * t), -a * w * w * np.sin(w * t)

    angle_reference = np.array([0.3, 1.0, -0.5])
    t, eps = 0.8, 1e-5
    q, qd, qdd = joint(t)
    x, xd, c, JA = _error_at(robot, mode, reference, q, qd, t, angle_reference)
    xp, xdp, _, _ = _error_at(robot, mode, reference, *joint(t + eps)[:2], t + eps, angle_reference)
    xm, xdm, _, _ = _error_at(robot, mode, reference, *joint(t - eps)[:2], t - eps, angle_reference)
    np.testing.assert_allclose(xd, (xp - xm) / (2 * eps), atol=1e-7)
    np.testing.assert_allclose(-JA @ qdd + c, (xdp - xdm) / (2 * eps), atol=2e-6)
    assert np.abs(x).max() > 0.05 and np.abs(c).max() > 0.05     # not a trivial configuration


def test_relative_error_is_zero_on_target_and_small_angles_are_axis_rotations():
    robot = load_robot("prp")
    q = np.array([0.1, 0.3, 0.05])
    ws = task_workspace(3, 6)
    measure_into(robot.arrays, q, np.zeros(3), ws)
    R_e, p_e = ws.R_e.copy(), ws.p_e.copy()
    for R_d, expected in ((R_e, 0.0), (R_e @ rot_x(-1e-6), 1e-6)):
        frame = PoseReference.constant(p_e - R_d[:, 1] * 0.01, R_d).evaluate(0.0)
        task_error_into(RELATIVE, frame, ZYZ, np.zeros(3), np.zeros(3), ws)
        # Σ_d displaced by −0.01 along its own y axis: x̃ = −o^d_{d,e} = −(0, 0.01, 0)
        np.testing.assert_allclose(ws.x_err[:3], [0.0, -0.01, 0.0], atol=1e-12)
        np.testing.assert_allclose(ws.x_err[3:], [-expected, 0.0, 0.0], atol=1e-12)


def test_via_pose_reference_is_smooth_and_uses_the_geodesic():
    R0 = euler_matrix([np.pi / 2, -np.pi / 2, 0.0], "zyz")
    R1 = rot_z(1.2) @ R0
    reference = PoseReference([1.0, 3.0], [[0, -0.2, 0.5], [0, -0.1, 0.4]], [R0, R1])
    start, end = reference.evaluate(0.5), reference.evaluate(3.5)
    np.testing.assert_allclose(start[12:], 0.0)
    np.testing.assert_allclose(end[:3], [0, -0.1, 0.4])
    np.testing.assert_allclose(end[3:12].reshape(3, 3), R1, atol=1e-12)
    # halfway: half the rotation about the fixed axis z_0, ω along z_0 only
    mid = reference.evaluate(2.0)
    np.testing.assert_allclose(mid[3:12].reshape(3, 3), rot_z(0.6) @ R0, atol=1e-12)
    np.testing.assert_allclose(mid[15:17], 0.0, atol=1e-15)
    eps = 1e-6
    for t in (1.3, 2.0, 2.7):
        d = (reference.evaluate(t + eps) - reference.evaluate(t - eps)) / (2 * eps)
        f = reference.evaluate(t)
        np.testing.assert_allclose(d[:3], f[12:15], atol=1e-8)      # ȯ_d
        np.testing.assert_allclose(d[12:15], f[18:21], atol=1e-6)   # ö_d
        np.testing.assert_allclose(d[15:18], f[21:24], atol=1e-6)   # ω̇_d
        Rdot = d[3:12].reshape(3, 3)
        R = f[3:12].reshape(3, 3)
        w = f[15:18]
        skew = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        np.testing.assert_allclose(Rdot, skew @ R, atol=1e-8)       # Ṙ = S(ω) R


def test_path_check_flags_a_segment_through_the_prp_singular_axis():
    """The seed's A10 goals keep the PRP's radius ≥ 0.1 m (σ_min bounded away from 0), while a
    straight segment between two poses on opposite sides of the z_0 axis crosses its singular
    set: interpolation cannot see that, the path check does."""
    robot = load_robot("prp")
    R0 = euler_matrix([np.pi / 2, -np.pi / 2, 0.0], "zyz")
    seed_path = PoseReference([0, 5, 10], [[0, -0.2, 0.5], [0, -0.1, 0.5], [0, -0.1, 0.4]], [R0] * 3)
    _, sigma = path_singular_values(robot, seed_path, [0.1, 0.0, 0.0], samples=60)
    assert sigma.min() > 0.09
    crossing = PoseReference([0, 5], [[0.05, -0.15, 0.5], [-0.05, 0.15, 0.5]], [R0, R0])
    _, sigma = path_singular_values(robot, crossing, [0.1, -0.3, 0.04], samples=61)
    assert sigma.min() < 1e-3


# ------------------------------------------------------------------ A9, A10 closed loops

SEED_ANGLES = [np.pi / 2, -np.pi / 2, 0.0]      # x0's ZYZ angles, negative branch (ϑ = −π/2)


def test_operational_pd_with_the_full_6d_task_regulates_to_the_goal():
    """A9: τ = g + J_Aᵀ(K_P x̃ − K_D J_A q̇) on all six ZYZ components (no inverse needed, so the
    PRP can take the seed's 6-D x); the consistent goal pose is reached, the error vanishes."""
    from armlab.control.task_space import OperationalPD
    from armlab.simulation import simulate

    robot = load_robot("prp")
    goal = PoseReference.from_pose_vectors([0.0], [[0.0, -0.1, 0.4, *SEED_ANGLES]])
    controller = OperationalPD(robot, goal, kp=[100, 100, 100, 10, 10, 10], kd=[30, 30, 30, 3, 3, 3],
                               task=(0, 1, 2, 3, 4, 5), angle_reference=SEED_ANGLES)
    result = simulate(robot, controller, q0=[0.1, 0.0, 0.0], t_final=6.0, dt=1e-3)
    np.testing.assert_allclose(result.q[-1], [0.0, 0.0, 0.1], atol=1e-6)
    np.testing.assert_allclose(result.signals["x"][-1], [0.0, -0.1, 0.4, *SEED_ANGLES], atol=1e-6)
    assert np.abs(result.signals["x_err"][0]).max() == pytest.approx(0.1)
    assert controller.check(result) == []


def test_operational_inverse_dynamics_error_follows_the_designed_second_order_system():
    """A10 with the exact model: x̃̈ + K_D x̃̇ + K_P x̃ = 0, so from an initial offset (and a
    reference at rest at t = 0) each component is (x̃₀ + 5 x̃₀ t) e^{−5t} for K_P = 25, K_D = 10,
    while the reference moves through the seed's goals."""
    from armlab.control.task_space import OperationalInverseDynamics
    from armlab.simulation import simulate

    robot = load_robot("prp")
    R0 = euler_matrix(SEED_ANGLES, "zyz")
    reference = PoseReference([0.0, 2.0, 3.0, 5.0], [[0, -0.2, 0.5], [0, -0.1, 0.5], [0, -0.1, 0.5],
                                                     [0, -0.1, 0.4]], [R0] * 4)
    controller = OperationalInverseDynamics(robot, reference, kp=25.0, kd=10.0,
                                            angle_reference=SEED_ANGLES)
    result = simulate(robot, controller, q0=[0.12, 0.05, -0.02], t_final=6.0, dt=1e-3)
    t = result.t[:, None]
    x_err = result.signals["x_err"][:, :3]
    expected = (x_err[0] + 5.0 * x_err[0] * t) * np.exp(-5.0 * t)
    np.testing.assert_allclose(x_err, expected, atol=1e-7)
    assert np.abs(x_err[0]).min() > 0.005


def test_near_singular_goal_is_logged_and_warned():
    """The seed's 'almost singular goal': the PRP's tip near the z_0 axis (radius 1 cm) makes
    σ_min(J_P) = radius; the run logs it (and the seed's det J_P) and check() warns."""
    from armlab.control.task_space import OperationalPD, SingularityWarning
    from armlab.simulation import simulate

    robot = load_robot("prp")
    goal = PoseReference.from_pose_vectors([0.0], [[0.0, -0.01, 0.4, *SEED_ANGLES]])
    controller = OperationalPD(robot, goal, kp=100.0, kd=30.0, angle_reference=SEED_ANGLES)
    result = simulate(robot, controller, q0=[0.1, 0.0, 0.0], t_final=4.0, dt=1e-3)
    assert result.signals["jacobian_sv"][-1, -1] == pytest.approx(0.01, abs=1e-4)
    assert abs(result.signals["det_JP"][-1, 0]) == pytest.approx(0.01, abs=1e-4)
    with pytest.warns(SingularityWarning, match="near singular"):
        controller.check(result)


def test_det_jp_is_in_metres_per_revolute_joint():
    from armlab.control.task_space import jacobian_signals

    sv, det = jacobian_signals(load_robot("prp"))      # P R P: one revolute column in J_P
    assert det.units == ("m",) and sv.width == 3
    assert jacobian_signals(load_robot("planar2r"))[1].units == ("m^2",)


# ------------------------------------------------------------------ joint damping K_q of (C9), (C11)


def test_joint_damping_dissipates_what_the_lyapunov_rate_says():
    """τ = g + J_Pᵀ(K_P p̃ − K_D J_P q̇) − K_q q̇ on a 6R arm with a 3-D position task: along the
    run, V = ½ q̇ᵀB q̇ + ½ p̃ᵀK_P p̃ falls at V̇ = −q̇ᵀ(J_PᵀK_D J_P + K_q) q̇ (V̇ from the logged states
    by finite differences, B and J_P from armlab's model functions).  Without K_q a self-motion
    started in the wrist keeps its speed (V̇ = 0 there); with K_q it dies out."""
    from armlab.control.task_space import OperationalPD
    from armlab.dynamics import inertia_matrix
    from armlab.kinematics import forward_kinematics, geometric_jacobian
    from armlab.simulation import simulate

    robot = six_dof_arm()
    q0 = np.array([0.2, 0.5, -0.4, 0.3, 0.9, -0.2])
    start = forward_kinematics(robot, q0)
    p_d = start[:3, 3] + np.array([0.05, -0.05, -0.08])
    goal = PoseReference.constant(p_d, start[:3, :3])
    kp, kd = 100.0, 20.0
    final_speed = {}
    for name, kq in (("plain", 0.0), ("damped", np.array([2.0, 2.0, 1.0, 0.1, 0.1, 0.05]))):
        controller = OperationalPD(robot, goal, kp=kp, kd=kd, joint_damping=kq)
        result = simulate(robot, controller, q0=q0, qd0=[0.0, 0.0, 0.0, 1.0, -1.0, 1.0], t_final=4.0,
                          dt=1e-3)
        K_q = np.diag(np.broadcast_to(kq, (6,)))
        energy, power = [], []
        for q, qd in zip(result.q, result.qd):
            J_P = geometric_jacobian(robot, q)[:3]
            p_err = p_d - forward_kinematics(robot, q)[:3, 3]
            energy.append(0.5 * qd @ inertia_matrix(robot, q) @ qd + 0.5 * kp * p_err @ p_err)
            power.append(qd @ (kd * J_P.T @ J_P + K_q) @ qd)
        rate, power = np.gradient(np.array(energy), result.t)[2:-2], np.array(power)[2:-2]
        assert np.abs(rate + power).max() < 1e-4 * power.max(), name
        final_speed[name] = np.abs(result.qd[-1]).max()
    assert final_speed["plain"] > 1.0 and final_speed["damped"] < 0.1


@pytest.mark.parametrize("name", ["a09_pd_goal", "a11_compliance"])
def test_zero_joint_damping_is_the_plain_law_bit_for_bit(name, tmp_path):
    """K_q = 0 however written (number, diagonal, matrix) gives the run of the file without the
    field, array for array; a nonzero K_q does change it (the field is read)."""
    from armlab.scenarios import load_scenario, load_scenario_file

    scenario = load_scenario(name)
    before = scenario.run(t_final=2.0).groups()
    text = open(scenario.source, encoding="utf-8").read()
    assert "joint_damping" not in text
    for value, same in (("0.0", True), ("[0, 0, 0]", True), ("[[0, 0, 0], [0, 0, 0], [0, 0, 0]]", True),
                        ("[0, 0.5, 0]", False)):
        path = tmp_path / "with_field.toml"
        path.write_text(text.replace("[controller]\n", f"[controller]\njoint_damping = {value}\n"),
                        encoding="utf-8")
        after = load_scenario_file(path).run(t_final=2.0).groups()
        assert before.keys() == after.keys()
        identical = all(before[key].tobytes() == after[key].tobytes() for key in before)
        assert identical == same, value


NOT_PSD = "controller: joint_damping: a gain must be positive semi-definite (smallest eigenvalue"


@pytest.mark.parametrize("value, message", [
    ("-1.0", f"{NOT_PSD} -1)"),
    ("[1, -2, 3]", f"{NOT_PSD} -2)"),
    ("[1, 2]", "controller: joint_damping: expected a number, 3 numbers or a 3×3 matrix, got shape (2,)"),
    ("1e400", "controller.joint_damping: must be finite, got inf"),
    ('"x"', "controller.joint_damping: cannot evaluate 'x'"),
])
def test_a_bad_joint_damping_is_a_one_line_error_naming_the_field(value, message, tmp_path):
    from armlab.scenarios import ScenarioFileError, load_scenario, load_scenario_file

    text = open(load_scenario("a09_pd_near_singular").source, encoding="utf-8").read()
    path = tmp_path / "bad.toml"
    path.write_text(text.replace("[controller]\n", f"[controller]\njoint_damping = {value}\n"),
                    encoding="utf-8")
    with pytest.raises(ScenarioFileError) as caught:
        load_scenario_file(path)
    assert str(caught.value).startswith(f"{path}: {message}") and "\n" not in str(caught.value)


def test_joint_damping_from_python_is_checked_too():
    from armlab.control.interaction import ComplianceControl
    from armlab.errors import ControllerSpecError

    goal = PoseReference.constant([0.0, -0.1, 0.4], euler_matrix(SEED_ANGLES, "zyz"))
    with pytest.raises(ControllerSpecError, match=r"^joint_damping: must be finite$"):
        ComplianceControl(load_robot("prp"), goal, kp=10.0, kd=5.0, joint_damping=[1.0, np.nan, 1.0])
