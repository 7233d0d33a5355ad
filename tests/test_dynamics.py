"""Joint-space dynamics: closed forms (PRP hand derivation, Siciliano's two-link arm with motors),
cross-checks between the kernels and physical invariants on random robots with motors and
friction."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from numba import njit
from scipy.integrate import solve_ivp

import armlab
from armlab import (
    coriolis_matrix,
    forward_dynamics,
    geometric_jacobian,
    gravity_torque,
    inertia_matrix,
    inverse_dynamics,
    kinetic_energy,
    potential_energy,
)
from armlab.dynamics import SingularInertiaError
from armlab.kernels.dynamics import forward_dynamics_into, make_workspace, rnea_into
from armlab.kernels.kinematics import joint_frames_into
from armlab.model.robot import Friction, Inertial, Joint, Link, Motor, Robot
from strategies import robots, states

G0 = 9.81


def robot_with_state():
    return robots(max_joints=6, motors=None, friction=None).flatmap(
        lambda r: states(r.n).map(lambda s: (r, s)))


# --- PRP: the hand derivation of docs/prp-dynamics.md -------------------------------------

def prp_hand_model(p, q, qd, motors=None):
    """B, C, g of docs/prp-dynamics.md (P1–P4); ``motors`` = (k_r, I_m, m_m) arrays or None."""
    _, theta2, d3 = q
    _, dtheta2, dd3 = qd
    m2, m3, m4 = p["m_Link2"], p["m_Link3"], p["m_Link4"]
    b11 = m2 + m3 + m4
    b22 = 0.5 * m3 * p["a3"] ** 2 + m4 * (p["b4"] ** 2 + p["L4"] ** 2) / 12 + m4 * d3 ** 2
    b33 = m4
    if motors is not None:
        k_r, I_m, m_m = motors
        b11 += m_m[1] + m_m[2] + k_r[0] ** 2 * I_m[0]
        b22 += k_r[1] ** 2 * I_m[1]
        b33 += k_r[2] ** 2 * I_m[2]
    B = np.diag([b11, b22, b33])
    C = np.array([[0.0, 0.0, 0.0],
                  [0.0, m4 * d3 * dd3, m4 * d3 * dtheta2],
                  [0.0, -m4 * d3 * dtheta2, 0.0]])
    g = np.array([0.0, -m4 * G0 * np.sin(theta2) * d3, m4 * G0 * np.cos(theta2)])
    return B, C, g


def test_prp_matches_hand_derivation():
    robot = armlab.load_robot("prp")
    rng = np.random.default_rng(1)
    for _ in range(5):
        q = rng.uniform([-0.15, -3.0, -0.15], [0.35, 3.0, 0.35])
        qd, qdd = rng.uniform(-1.0, 1.0, (2, 3))
        B, C, g = prp_hand_model(robot.parameters, q, qd)
        np.testing.assert_allclose(inertia_matrix(robot, q), B, rtol=0, atol=1e-14)
        np.testing.assert_allclose(coriolis_matrix(robot, q, qd), C, rtol=0, atol=1e-14)
        np.testing.assert_allclose(gravity_torque(robot, q), g, rtol=0, atol=1e-13)
        np.testing.assert_allclose(inverse_dynamics(robot, q, qd, qdd), B @ qdd + C @ qd + g,
                                   rtol=0, atol=1e-13)


def test_prp_seed_link3_term_is_negative_and_ours_is_not():
    # docs/prp-dynamics.md: the seed's m_Link3 (a²/4 − h²/6) is negative for the cylinder
    # of the robot file; the inertia about its own axis, ½ m a², is what B_22 needs.
    p = armlab.load_robot("prp").parameters
    assert p["m_Link3"] * (p["a3"] ** 2 / 4 - p["L3"] ** 2 / 6) < 0
    B = inertia_matrix(armlab.load_robot("prp"), np.zeros(3))
    assert B[1, 1] == pytest.approx(0.5 * p["m_Link3"] * p["a3"] ** 2
                                    + p["m_Link4"] * (p["b4"] ** 2 + p["L4"] ** 2) / 12, rel=1e-12)


def test_prp_actuated_matches_hand_derivation_with_motors_and_friction():
    robot = armlab.load_robot("prp_actuated")
    m = robot.arrays
    p = robot.parameters
    motors = (np.array(m.gear_ratio), np.array(m.rotor_inertia), np.array([p["m_m1"], p["m_m2"], p["m_m3"]]))
    rng = np.random.default_rng(2)
    for _ in range(5):
        q = rng.uniform([-0.15, -3.0, -0.15], [0.35, 3.0, 0.35])
        qd, qdd = rng.uniform(-1.0, 1.0, (2, 3))
        B, C, g = prp_hand_model(p, q, qd, motors)
        friction = m.viscous * qd + m.coulomb * np.sign(qd)
        np.testing.assert_allclose(inertia_matrix(robot, q), B, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(coriolis_matrix(robot, q, qd), C, rtol=0, atol=1e-14)
        np.testing.assert_allclose(inverse_dynamics(robot, q, qd, qdd), B @ qdd + C @ qd + g + friction,
                                   rtol=0, atol=1e-12)


# --- Siciliano's two-link planar arm with motors (§7.3.2) ----------------------------------

def test_planar2r_matches_siciliano_closed_form_with_motors():
    robot = armlab.load_robot("planar2r")
    p = robot.parameters
    a1, l1, l2 = p["a1"], p["l1"], p["l2"]
    ml1, ml2, Il1, Il2 = p["m_l1"], p["m_l2"], p["I_l1"], p["I_l2"]
    mm2, Im1, Im2, kr1, kr2 = p["m_m2"], p["I_m1"], p["I_m2"], p["k_r1"], p["k_r2"]
    rng = np.random.default_rng(3)
    for _ in range(5):
        q1, q2 = q = rng.uniform(-3.0, 3.0, 2)
        qd = rng.uniform(-2.0, 2.0, 2)
        c2, s2 = np.cos(q2), np.sin(q2)
        # Siciliano et al. (7.82)–(7.84)
        b11 = (Il1 + ml1 * l1 ** 2 + kr1 ** 2 * Im1 + Il2 + ml2 * (a1 ** 2 + l2 ** 2 + 2 * a1 * l2 * c2)
               + Im2 + mm2 * a1 ** 2)
        b12 = Il2 + ml2 * (l2 ** 2 + a1 * l2 * c2) + kr2 * Im2
        b22 = Il2 + ml2 * l2 ** 2 + kr2 ** 2 * Im2
        h = -ml2 * a1 * l2 * s2
        C = np.array([[h * qd[1], h * (qd[0] + qd[1])], [-h * qd[0], 0.0]])
        g1 = (ml1 * l1 + mm2 * a1 + ml2 * a1) * G0 * np.cos(q1) + ml2 * l2 * G0 * np.cos(q1 + q2)
        g2 = ml2 * l2 * G0 * np.cos(q1 + q2)
        np.testing.assert_allclose(inertia_matrix(robot, q), [[b11, b12], [b12, b22]], rtol=1e-13)
        np.testing.assert_allclose(coriolis_matrix(robot, q, qd), C, rtol=0, atol=1e-11)
        np.testing.assert_allclose(gravity_torque(robot, q), [g1, g2], rtol=1e-13, atol=1e-11)


# --- the rotor model (D3) against its kinetic energy, on random robots ---------------------

@settings(max_examples=25)
@given(data=robots(max_joints=6, motors=True).flatmap(lambda r: states(r.n).map(lambda s: (r, s))))
def test_rotor_terms_of_B_equal_the_rotor_kinetic_energy(data):
    # T_mi = ½ I_mi (z_iᵀ ω_{i−1} + k_ri q̇_i)² = ½ I_mi (a_iᵀ q̇)², a_ij = z_iᵀ z_j (j < i,
    # revolute), a_ii = k_ri: B − B_without_rotors = Σ I_mi a_i a_iᵀ, with z from the kinematics.
    robot, (q, _, _) = data
    m = robot.arrays
    n = robot.n
    R, p = np.empty((n, 3, 3)), np.empty((n, 3))
    joint_frames_into(m, q, R, p)
    z = R[:, :, 2]
    expected = np.zeros((n, n))
    for i in range(n):
        a = np.zeros(n)
        for j in range(i):
            if robot.joints[j].kind == "revolute":
                a[j] = z[i] @ z[j]
        a[i] = m.gear_ratio[i]
        expected += m.rotor_inertia[i] * np.outer(a, a)
    bare = robot.replace(joints=tuple(replace(j, motor=Motor(j.motor.gear_ratio, 0.0, j.motor.mass))
                                      for j in robot.joints))
    np.testing.assert_allclose(inertia_matrix(robot, q) - inertia_matrix(bare, q), expected,
                               rtol=1e-9, atol=1e-12)


# --- cross-checks and invariants on random robots (motors and friction included) -----------

@settings(max_examples=25)
@given(data=robot_with_state())
def test_inverse_dynamics_is_B_qdd_plus_C_qd_plus_g_plus_friction_plus_JT_h(data):
    robot, (q, qd, qdd) = data
    m = robot.arrays
    h_e = np.random.default_rng(int(abs(q[0]) * 1e6)).normal(size=6)
    J = geometric_jacobian(robot, q, frame="0")
    expected = (inertia_matrix(robot, q) @ qdd + coriolis_matrix(robot, q, qd) @ qd + gravity_torque(robot, q)
                + m.viscous * qd + m.coulomb * np.sign(qd) + J.T @ h_e)
    tau = inverse_dynamics(robot, q, qd, qdd, h_e=h_e)
    np.testing.assert_allclose(tau, expected, rtol=1e-9, atol=1e-9 * max(1.0, np.abs(expected).max()))


@settings(max_examples=25)
@given(data=robot_with_state())
def test_forward_dynamics_inverts_inverse_dynamics(data):
    robot, (q, qd, qdd) = data
    h_e = np.linspace(-1.0, 1.0, 6)
    tau = inverse_dynamics(robot, q, qd, qdd, h_e=h_e)
    np.testing.assert_allclose(forward_dynamics(robot, q, qd, tau, h_e=h_e), qdd, rtol=1e-8, atol=1e-8)


@settings(max_examples=25)
@given(data=robot_with_state())
def test_wrench_enters_as_J_transpose_h(data):
    robot, (q, qd, qdd) = data
    h_e = np.array([3.0, -1.0, 2.0, 0.5, -0.7, 0.2])
    J = geometric_jacobian(robot, q, frame="0")
    difference = inverse_dynamics(robot, q, qd, qdd, h_e=h_e) - inverse_dynamics(robot, q, qd, qdd)
    np.testing.assert_allclose(difference, J.T @ h_e, rtol=1e-9, atol=1e-10)


@settings(max_examples=25)
@given(data=robot_with_state())
def test_B_is_symmetric_positive_definite(data):
    robot, (q, _, _) = data
    B = inertia_matrix(robot, q)
    np.testing.assert_allclose(B, B.T, rtol=0, atol=1e-12 * np.abs(B).max())
    assert np.linalg.eigvalsh(B).min() > 0


@settings(max_examples=25)
@given(data=robot_with_state())
def test_Bdot_minus_2C_is_skew_symmetric(data):
    robot, (q, qd, _) = data
    eps = 1e-6
    # Ḃ = Σ_k ∂B/∂q_k q̇_k by a central difference along q̇
    B_dot = (inertia_matrix(robot, q + eps * qd) - inertia_matrix(robot, q - eps * qd)) / (2 * eps)
    N = B_dot - 2 * coriolis_matrix(robot, q, qd)
    scale = max(1.0, np.abs(B_dot).max())
    np.testing.assert_allclose(N + N.T, 0.0, atol=1e-6 * scale)


@settings(max_examples=25)
@given(data=robot_with_state())
def test_energies_match_B_and_g(data):
    robot, (q, qd, _) = data
    B = inertia_matrix(robot, q)
    assert kinetic_energy(robot, q, qd) == pytest.approx(0.5 * qd @ B @ qd, rel=1e-10, abs=1e-12)
    eps = 1e-6
    grad = np.array([(potential_energy(robot, q + eps * e) - potential_energy(robot, q - eps * e)) / (2 * eps)
                     for e in np.eye(robot.n)])
    np.testing.assert_allclose(gravity_torque(robot, q), grad, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("name", ["prp_actuated", "puma560"])
def test_energy_is_conserved_without_torque_and_friction(name):
    loaded = armlab.load_robot(name)
    robot = loaded.replace(joints=tuple(replace(j, friction=Friction()) for j in loaded.joints))
    n = robot.n
    zero = np.zeros(n)

    def rhs(_, x):
        return np.concatenate((x[n:], forward_dynamics(robot, x[:n], x[n:], zero)))

    x0 = np.concatenate((np.full(n, 0.1), np.linspace(0.5, -0.5, n)))
    solution = solve_ivp(rhs, (0.0, 1.5), x0, method="DOP853", rtol=1e-11, atol=1e-12, dense_output=False)
    assert solution.success
    energy = [kinetic_energy(robot, x[:n], x[n:]) + potential_energy(robot, x[:n]) for x in solution.y.T]
    kinetic0 = kinetic_energy(robot, x0[:n], x0[n:])
    assert np.ptp(energy) < 1e-7 * max(1.0, kinetic0)
    # the motion is not trivial: energy moves between kinetic and potential
    kinetic = [kinetic_energy(robot, x[:n], x[n:]) for x in solution.y.T]
    assert np.ptp(kinetic) > 1e-3 * kinetic0


# --- errors --------------------------------------------------------------------------------

def test_wrong_shapes_name_the_argument():
    robot = armlab.load_robot("prp")
    with pytest.raises(ValueError, match="qd"):
        inverse_dynamics(robot, np.zeros(3), np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="h_e"):
        forward_dynamics(robot, np.zeros(3), np.zeros(3), np.zeros(3), h_e=np.zeros(3))


def test_massless_prismatic_tip_is_reported_as_singular():
    tip = Joint(name="slide", kind="prismatic", before=np.eye(4), after=np.eye(4))
    robot = Robot(name="massless", joints=(tip,), links=(Link(name="l", inertial=Inertial()),))
    with pytest.raises(SingularInertiaError, match="not positive definite"):
        forward_dynamics(robot, np.zeros(1), np.zeros(1), np.ones(1))


# --- use from compiled code ------------------------------------------------------------------

@njit(cache=True)
def _roundtrip_in_compiled_code(m, Q, QD, QDD, out):
    ws = make_workspace(Q.shape[1])
    h_e = np.zeros(6)
    tau = np.empty(Q.shape[1])
    for k in range(Q.shape[0]):
        rnea_into(m, ws, Q[k], QD[k], QDD[k], 1.0, h_e, tau)
        forward_dynamics_into(m, ws, Q[k], QD[k], tau, h_e, out[k])


def test_kernels_run_inside_compiled_code_with_one_workspace():
    robot = armlab.load_robot("prp_actuated")
    rng = np.random.default_rng(5)
    Q, QD, QDD = rng.uniform(-0.1, 0.1, (3, 50, robot.n))
    out = np.empty_like(Q)
    _roundtrip_in_compiled_code(robot.arrays, Q, QD, QDD, out)
    np.testing.assert_allclose(out, QDD, rtol=1e-9, atol=1e-12)


def test_an_asymmetric_inertia_built_in_code_gives_one_robot_to_every_kernel():
    """The CRBA reads one triangle of a link inertia, the RNEA all of it: the robot's arrays
    keep the symmetric part, so B equals the RNEA's columns whatever the tensor given."""
    robot = armlab.load_robot("puma560")
    links = list(robot.links)
    I = np.array(links[2].inertial.inertia, dtype=float)
    I[0, 1] += 0.01                      # not a physical tensor: I ≠ Iᵀ
    links[2] = replace(links[2], inertial=replace(links[2].inertial, inertia=I))
    odd = robot.replace(links=tuple(links))
    q = np.linspace(-0.4, 0.5, odd.n)
    z = np.zeros(odd.n)
    g = inverse_dynamics(odd, q, z, z)
    columns = np.column_stack([inverse_dynamics(odd, q, z, e) - g for e in np.eye(odd.n)])
    np.testing.assert_allclose(inertia_matrix(odd, q), columns, rtol=1e-12, atol=1e-12)
