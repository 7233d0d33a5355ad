"""Symbolic derivations A1–A5: closed forms typed from their sources, cross-checks between the
two symbolic routes (Lagrange, Newton–Euler) and against the numeric kernels.

The derivations are cached per symbolic robot (``functools.lru_cache`` in the modules), and
the robots are built once per module here, so each derivation runs once for the whole file.
"""

from functools import cache

import numpy as np
import pytest
import sympy as sp

import armlab
from armlab.model.toml_io import robot_from_dict
from armlab.spatial import euler_from_matrix
from armlab.symbolic import energy, kinematics, lagrange, newton_euler, operational
from armlab.symbolic.model import symbolic_robot
from armlab.symbolic.simplify import count_ops, is_zero

RNG = np.random.default_rng(20261121)

# A robot exercising what the DH robots do not: origin/axis joints (axes along x and y),
# modified DH, an RPY-rotated box, a motor mass, rotors and friction, a tool offset.
GENERIC = {
    "name": "generic",
    "dh_convention": "modified",
    "gravity": [0.0, 0.0, -9.81],
    "base": {"xyz": [0.1, 0.0, "h0"], "rpy": [0, 0, "pi/6"]},
    "tool": {"xyz": [0.0, 0.05, 0.1]},
    "parameters": {"h0": 0.3, "l1": 0.25, "m1": 1.2, "m2": 0.8, "m3": 0.5, "r": 0.04},
    "joints": [
        {"name": "q1", "type": "revolute", "dh": {"a": 0, "alpha": 0, "d": "h0/2", "theta": "pi/3"},
         "motor": {"gear_ratio": 30, "rotor_inertia": 2e-5},
         "friction": {"viscous": 0.1, "coulomb": 0.05},
         "link": {"mass": "m1", "com": [0.1, 0.02, 0.0],
                  "shape": {"type": "cylinder", "radius": "r", "length": "l1"}}},
        {"name": "q2", "type": "revolute", "origin": {"xyz": ["l1", 0, 0.05], "rpy": ["pi/6", 0, 0]},
         "axis": [0, 1, 0], "motor": {"gear_ratio": 20, "rotor_inertia": 1e-5, "mass": 0.4},
         "link": {"mass": "m2", "com": [0.15, 0.0, 0.01],
                  "shape": {"type": "box", "size": [0.3, 0.04, 0.05], "rpy": [0, "pi/2", 0]}}},
        {"name": "s3", "type": "prismatic", "origin": {"xyz": [0.3, 0, 0]}, "axis": [1, 0, 0],
         "motor": {"gear_ratio": 600, "rotor_inertia": 1e-6, "mass": 0.3},
         "link": {"mass": "m3", "com": [0.05, 0, 0], "inertia": [[1e-3, 0, 0], [0, 2e-3, 0], [0, 0, 2e-3]]}},
    ],
}


@cache
def robot(name):
    return robot_from_dict(GENERIC, "generic.toml") if name == "generic" else armlab.load_robot(name)


@cache
def sym(name, numeric=False):
    return symbolic_robot(robot(name), numeric=numeric)


def numeric_function(expr, sr, rates=False):
    """expr with the robot's values, as a function of (q) or (q, qd)."""
    values = sr.numeric_substitution()
    args = [list(sr.q), list(sr.qd)] if rates else [list(sr.q)]
    return sp.lambdify(args, sp.Matrix(expr).xreplace(values), "numpy")


def random_state(r):
    lo = np.where(np.isfinite(r.arrays.q_min), r.arrays.q_min, -np.pi)
    hi = np.where(np.isfinite(r.arrays.q_max), r.arrays.q_max, np.pi)
    return RNG.uniform(lo, hi), RNG.normal(size=r.n), RNG.normal(size=r.n)


# --------------------------------------------------------------------------- A1 kinematics


def test_prp_symbols_follow_the_robot_file():
    sr = sym("prp")
    assert [str(s) for s in sr.q] == ["d1", "theta2", "d3"]
    L0, L2, L3, L4 = sp.symbols("L0 L2 L3 L4", real=True)
    d1, theta2, d3 = sr.q
    table = kinematics.dh_table(sr, "base")
    expected = sp.Matrix([[0, sp.pi / 2, L0, sp.pi / 2], [0, 0, L2 / 2 + d1, 0],
                          [0, -sp.pi / 2, L3, theta2], [0, -sp.pi, d3 - L4 / 2, -sp.pi / 2]])
    assert table == expected
    # The seed's T_3^0 (A1) with its own sign of the (2, 4) entry: −cos θ2 (L4/2 − d3).
    T = kinematics.end_effector_pose(sr)
    c, s = sp.cos(theta2), sp.sin(theta2)
    seed = sp.Matrix([[0, -c, s, s * (L4 / 2 - d3)], [0, -s, -c, -c * (L4 / 2 - d3)],
                      [1, 0, 0, L2 / 2 + L3 + d1], [0, 0, 0, 1]])
    assert is_zero(T - seed)


@pytest.mark.parametrize("name", ["prp", "planar2r", "generic"])
@pytest.mark.parametrize("frame", ["0", "base"])
def test_symbolic_fk_and_jacobian_match_numeric_kernels(name, frame):
    r, sr = robot(name), sym(name)
    fk = numeric_function(kinematics.end_effector_pose(sr, frame), sr)
    jac = numeric_function(kinematics.geometric_jacobian(sr, frame), sr)
    for _ in range(5):
        q, _, _ = random_state(r)
        np.testing.assert_allclose(fk(q), armlab.forward_kinematics(r, q, frame), atol=1e-12)
        np.testing.assert_allclose(jac(q), armlab.geometric_jacobian(r, q, frame), atol=1e-12)


def test_numeric_option_substitutes_values():
    sr = sym("prp", numeric=True)
    assert not kinematics.end_effector_pose(sr).free_symbols - set(sr.q)
    assert energy.inertia_matrix(sr)[0, 0] == sp.Rational(1)  # 0.5 + 0.3 + 0.2 kg


def test_analytical_jacobian_is_the_derivative_of_zyz_angles():
    r, sr = robot("prp"), sym("prp")
    J_A, _ = kinematics.analytical_jacobian(sr, "0")
    f = numeric_function(J_A, sr)
    q = np.array([0.1, 0.7, 0.05])
    h = 1e-6
    columns = []
    for k in range(3):
        dq = np.zeros(3)
        dq[k] = h
        x = [np.concatenate([T[:3, 3], euler_from_matrix(T[:3, :3], "zyz")])
             for T in (armlab.forward_kinematics(r, q + dq, "0"), armlab.forward_kinematics(r, q - dq, "0"))]
        columns.append((x[0] - x[1]) / (2 * h))
    np.testing.assert_allclose(f(q), np.column_stack(columns), atol=1e-8)


@pytest.mark.parametrize("frame", ["0", "base"])
def test_prp_inverse_kinematics_gives_both_branches(frame):
    r, sr = robot("prp"), sym("prp")
    solutions = kinematics.position_inverse_kinematics(sr, frame)
    assert len(solutions) == 2
    px, py, pz = sp.symbols("p_x p_y p_z", real=True)
    values = sr.numeric_substitution()
    q_true = np.array([0.08, 0.9, 0.12])
    p = armlab.forward_kinematics(r, q_true, frame)[:3, 3]
    point = {px: p[0], py: p[1], pz: p[2]}
    found = []
    for branch in solutions:
        q = np.array([float(branch[s].xreplace(values).xreplace(point)) for s in sr.q])
        np.testing.assert_allclose(armlab.forward_kinematics(r, q, frame)[:3, 3], p, atol=1e-12)
        found.append(q)
    # Hand derivation: d3 − L4/2 = ∓ρ with ρ the distance from the d1 axis; θ2 differs by π.
    L4 = 0.4
    rho = np.hypot(*p[:2]) if frame == "0" else np.hypot(p[1], p[2] - 0.5)
    assert sorted(q[2] for q in found) == pytest.approx([L4 / 2 - rho, L4 / 2 + rho])
    assert abs(abs(found[0][1] - found[1][1]) - np.pi) < 1e-12
    assert any(np.allclose(q, q_true) for q in found)


# --------------------------------------------------------------------------- A2, A3: PRP by hand


def test_steiner_identity_holds_symbolically():
    _, _, difference = energy.steiner_identity()
    assert difference == sp.zeros(3, 3)


def prp_symbols(sr):
    names = "m_Link2 m_Link3 m_Link4 a3 b4 L4"
    return sp.symbols(names, real=True), sr.q, sr.qd


def test_prp_dynamics_equal_the_hand_derivation():
    """Cylinder (radius a3) turning about its own axis, box (a4, b4, L4) turning about its x
    axis at distance d3, both verified on prp.toml's geometry."""
    sr = sym("prp")
    (m2, m3, m4, a3, b4, L4), (d1, t2, d3), (d1d, t2d, d3d) = prp_symbols(sr)
    g = sp.Rational(981, 100)
    B = sp.diag(m2 + m3 + m4, m3 * a3**2 / 2 + m4 * (b4**2 + L4**2) / 12 + m4 * d3**2, m4)
    C = sp.Matrix([[0, 0, 0], [0, m4 * d3 * d3d, m4 * d3 * t2d], [0, -m4 * d3 * t2d, 0]])
    gv = sp.Matrix([0, -g * m4 * sp.sin(t2) * d3, g * m4 * sp.cos(t2)])
    assert sp.expand(energy.inertia_matrix(sr) - B) == sp.zeros(3, 3)
    assert sp.expand(lagrange.coriolis_matrix(sr) - C) == sp.zeros(3, 3)
    assert sp.expand(lagrange.gravity_vector(sr) - gv) == sp.zeros(3, 1)


def test_prp_results_are_compact():
    sr = sym("prp")
    terms = (energy.inertia_matrix, lagrange.coriolis_matrix, lagrange.gravity_vector)
    ops = [count_ops(f(sr)) for f in terms]
    assert sum(ops) <= 40, ops


def test_kinetic_energy_uses_the_com_velocity_and_the_com_inertia():
    """T of the cylinder link: no m r² shift (its COM lies on the θ2 axis), unlike the seed."""
    sr = sym("prp")
    (m2, m3, m4, a3, b4, L4), (d1, t2, d3), (d1d, t2d, d3d) = prp_symbols(sr)
    links, rotors = energy.kinetic_energies(sr)
    assert sp.expand(links[1] - (m3 * d1d**2 / 2 + m3 * a3**2 * t2d**2 / 4)) == 0
    assert rotors == (0, 0, 0)


# --------------------------------------------------------------------------- planar 2R (Siciliano)


def test_planar2r_equals_siciliano_closed_form():
    """Siciliano et al. (2009) §7.3.2, eqs. (7.82) and the c_ijk below them, with motors."""
    sr = sym("planar2r")
    a1, l1, l2, m_l1, m_l2, I_l1, I_l2, m_m2, I_m1, I_m2, k_r1, k_r2 = sp.symbols(
        "a1 l1 l2 m_l1 m_l2 I_l1 I_l2 m_m2 I_m1 I_m2 k_r1 k_r2", real=True)
    t1, t2 = sr.q
    t1d, t2d = sr.qd
    g = sp.Rational(981, 100)
    c1, c2, c12, s2 = sp.cos(t1), sp.cos(t2), sp.cos(t1 + t2), sp.sin(t2)
    b11 = (I_l1 + m_l1 * l1**2 + k_r1**2 * I_m1 + I_l2 + m_l2 * (a1**2 + l2**2 + 2 * a1 * l2 * c2)
           + I_m2 + m_m2 * a1**2)
    b12 = I_l2 + m_l2 * (l2**2 + a1 * l2 * c2) + k_r2 * I_m2
    b22 = I_l2 + m_l2 * l2**2 + k_r2**2 * I_m2
    h = -m_l2 * a1 * l2 * s2
    B = sp.Matrix([[b11, b12], [b12, b22]])
    C = sp.Matrix([[h * t2d, h * (t1d + t2d)], [-h * t1d, 0]])
    gv = sp.Matrix([(m_l1 * l1 + m_m2 * a1 + m_l2 * a1) * g * c1 + m_l2 * l2 * g * c12, m_l2 * l2 * g * c12])
    assert is_zero(energy.inertia_matrix(sr) - B, kinematics.angles(sr))
    assert is_zero(lagrange.coriolis_matrix(sr) - C, kinematics.angles(sr))
    assert is_zero(lagrange.gravity_vector(sr) - gv, kinematics.angles(sr))


# --------------------------------------------------------------------------- Lagrange ≡ Newton–Euler


@pytest.mark.parametrize("name", ["prp", "planar2r", "prp_actuated"])
def test_lagrange_equals_newton_euler(name):
    sr = sym(name)
    angles = kinematics.angles(sr)
    assert is_zero(newton_euler.inertia_matrix_ne(sr) - energy.inertia_matrix(sr), angles)
    assert is_zero(newton_euler.coriolis_vector_ne(sr) - lagrange.coriolis_matrix(sr) * sr.qd, angles)
    assert is_zero(newton_euler.gravity_vector_ne(sr) - lagrange.gravity_vector(sr), angles)
    assert is_zero(newton_euler.full_equations(sr).tau - lagrange.equations_of_motion(sr), angles)


@pytest.mark.parametrize("name", ["prp", "planar2r"])
def test_bdot_minus_2c_is_skew_symmetric(name):
    N, symmetric_part = lagrange.skew_check(sym(name))
    assert symmetric_part == sp.zeros(*N.shape)
    assert N != sp.zeros(*N.shape)  # the check is not vacuous


# --------------------------------------------------------------------------- against the kernels


@pytest.mark.parametrize("name", ["prp_actuated", "planar2r", "generic"])
def test_symbolic_dynamics_match_numeric_kernels(name):
    r, sr = robot(name), sym(name)
    B = numeric_function(energy.inertia_matrix(sr), sr)
    C = numeric_function(lagrange.coriolis_matrix(sr), sr, rates=True)
    g = numeric_function(lagrange.gravity_vector(sr), sr)
    T = numeric_function(sp.Matrix([energy.kinetic_energy(sr)]), sr, rates=True)
    # τ of the equations of motion with friction (the DH robots; the generic one's B, C, g
    # already cover its law and its τ would only add derivation time).
    tau = None
    if name != "generic":
        tau_expr = lagrange.equations_of_motion(sr).xreplace(sr.numeric_substitution())
        tau = sp.lambdify([list(sr.q), list(sr.qd), list(sr.qdd)], tau_expr, "numpy")
    for _ in range(4):
        q, qd, qdd = random_state(r)
        np.testing.assert_allclose(B(q), armlab.inertia_matrix(r, q), rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(C(q, qd), armlab.coriolis_matrix(r, q, qd), rtol=1e-9, atol=1e-11)
        np.testing.assert_allclose(g(q).ravel(), armlab.gravity_torque(r, q), rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(T(q, qd)[0, 0], armlab.kinetic_energy(r, q, qd), rtol=1e-10)
        if tau is not None:
            np.testing.assert_allclose(tau(q, qd, qdd).ravel(), armlab.inverse_dynamics(r, q, qd, qdd),
                                       rtol=1e-9, atol=1e-10)


def test_newton_euler_wrench_term_is_jacobian_transpose():
    r, sr = robot("generic"), sym("generic")
    h = sp.Matrix(sp.symbols("f_x f_y f_z mu_x mu_y mu_z", real=True))
    zero = sp.zeros(sr.n, 1)
    tau = newton_euler.newton_euler(sr, zero, zero, sp.zeros(3, 1), friction=False, h_e=h,
                                    simplify=False).tau
    f = sp.lambdify([list(sr.q), list(h)], tau.xreplace(sr.numeric_substitution()), "numpy")
    q, _, _ = random_state(r)
    h_e = RNG.normal(size=6)
    expected = armlab.geometric_jacobian(r, q, "0").T @ h_e
    np.testing.assert_allclose(f(q, h_e).ravel(), expected, atol=1e-12)


# --------------------------------------------------------------------------- A5


def test_prp_operational_space_model():
    r, sr = robot("prp"), sym("prp")
    model = operational.operational_model(sr, "0")
    assert model.rows == [0, 1, 2]
    assert model.T_A == sp.eye(3)
    B_A = numeric_function(model.B_A, sr)
    g_A = numeric_function(model.g_A, sr)
    Cx = numeric_function(model.C_A_xd, sr, rates=True)
    q, qd, _ = random_state(r)
    J = armlab.geometric_jacobian(r, q, "0")[:3]
    J_inv = np.linalg.inv(J)
    B = armlab.inertia_matrix(r, q)
    np.testing.assert_allclose(B_A(q), J_inv.T @ B @ J_inv, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(g_A(q).ravel(), J_inv.T @ armlab.gravity_torque(r, q), rtol=1e-10, atol=1e-12)
    h = 1e-6
    J_plus, J_minus = (armlab.geometric_jacobian(r, q + k * h * qd, "0")[:3] for k in (1, -1))
    J_dot = (J_plus - J_minus) / (2 * h)
    expected = J_inv.T @ armlab.coriolis_matrix(r, q, qd) @ qd - J_inv.T @ B @ J_inv @ J_dot @ qd
    np.testing.assert_allclose(Cx(q, qd).ravel(), expected, rtol=1e-6, atol=1e-8)


# --------------------------------------------------------------------------- the scalable route


@pytest.mark.parametrize("name", ["prp_actuated", "planar2r", "generic"])
def test_compact_dynamics_equal_the_lagrange_forms(name):
    from armlab.symbolic.compact import compact_dynamics

    sr = sym(name)
    result = compact_dynamics(sr)
    angles = kinematics.angles(sr)
    assert is_zero(result.B - energy.inertia_matrix(sr), angles)
    assert is_zero(result.C - lagrange.coriolis_matrix(sr), angles)
    assert is_zero(result.g - lagrange.gravity_vector(sr), angles)


def test_robot_without_a_spec_uses_its_numbers(tmp_path):
    """A robot read back from URDF has no robot-file expressions: its numbers are used."""
    r = armlab.load_urdf(armlab.save_urdf(robot("prp"), tmp_path / "prp.urdf"))
    sr = symbolic_robot(r)
    assert sr.numeric and not sr.parameters
    fk = numeric_function(kinematics.end_effector_pose(sr), sr)
    B = numeric_function(energy.inertia_matrix(sr), sr)
    q, _, _ = random_state(r)
    np.testing.assert_allclose(fk(q), armlab.forward_kinematics(r, q, "0"), atol=1e-12)
    np.testing.assert_allclose(B(q), armlab.inertia_matrix(r, q), rtol=1e-10, atol=1e-12)
