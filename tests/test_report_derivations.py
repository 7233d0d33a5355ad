"""The report's A1–A5 derivations: what each section shows, and that the expressions it prints
are the robot's kinematics and dynamics.  The printed SymPy objects (the very ones the page
renders, checked to be on it) are evaluated with the robot's numbers and compared with
independent numeric computations: finite differences of the numeric forward kinematics for
the Jacobians, the numeric forward kinematics for the inverse kinematics, the numeric
Newton–Euler recursion (with and without its friction) and the composite-rigid-body B(q) for
the dynamics."""

import numpy as np
import sympy as sp

import armlab
from armlab.symbolic.render import to_mathml
from armlab.viz import html
from armlab.viz import report_derivations as report

RNG = np.random.default_rng(20260507)
BUDGET = report.DERIVATION_BUDGET[False]
H = 1e-6  # central-difference step [m | rad]


def _random_q(robot):
    return RNG.uniform(robot.arrays.q_min, robot.arrays.q_max)


def _shown(derivation, robot) -> tuple[dict, str]:
    """The derivation's items by label, and its HTML in the report of ``robot``; every item's
    formula is checked to be on the page as rendered from that very expression."""
    page = report.derivation_html(derivation, robot)
    items = {item.label: item for item in derivation.section.items}
    for label, item in items.items():
        assert html.math_block(label, to_mathml(item.expr)) in page, label
    return items, page


def _function(expr, sr, *rates):
    """``expr`` with the robot's parameter values, as a numpy function of (q, *rates)."""
    args = [list(sr.q)] + [list(getattr(sr, rate)) for rate in rates]
    f = sp.lambdify(args, sp.Matrix(expr).xreplace(sr.numeric_substitution()), "numpy")
    return lambda *values: np.array(f(*values), dtype=float)


def _zyz(R):
    """ZYZ angles of R on the branch sin ϑ > 0 (Siciliano (2.19))."""
    return np.array([np.arctan2(R[1, 2], R[0, 2]), np.arctan2(np.hypot(R[0, 2], R[1, 2]), R[2, 2]),
                     np.arctan2(R[2, 1], -R[2, 0])])


def _finite_difference_jacobians(robot, q, frame):
    """Geometric and ZYZ analytical Jacobians of Σ_e in Σ_``frame`` by central differences of
    the numeric forward kinematics: J_P = ∂p/∂q, J_O from Ṙ Rᵀ = S(ω), J_A's angle rows ∂φ/∂q."""
    J, J_A = np.zeros((6, robot.n)), np.zeros((6, robot.n))
    R = armlab.forward_kinematics(robot, q, frame)[:3, :3]
    for i in range(robot.n):
        step = np.eye(robot.n)[i] * H
        plus, minus = (armlab.forward_kinematics(robot, q + s, frame) for s in (step, -step))
        J[:3, i] = J_A[:3, i] = (plus[:3, 3] - minus[:3, 3]) / (2 * H)
        S = (plus[:3, :3] - minus[:3, :3]) / (2 * H) @ R.T
        J[3:, i] = (S[2, 1], S[0, 2], S[1, 0])
        J_A[3:, i] = np.angle(np.exp(1j * (_zyz(plus[:3, :3]) - _zyz(minus[:3, :3])))) / (2 * H)
    return J, J_A


def test_a1_shows_inverse_kinematics_and_jacobians_in_both_frames():
    """The seed computes A1 from Σ_base and from Σ_0 and uses Σ_0's in every later assignment:
    the report shows both, each labelled, neither in place of the other, each the derivative
    of the robot's forward kinematics in its frame."""
    robot = armlab.load_robot("prp")
    (derivation,) = report.derivations(robot, BUDGET, only=("A1",))
    assert derivation.section.complete and derivation.robot is robot
    items, page = _shown(derivation, robot)
    for frame in ("0", "base"):
        for label in (f"IK branch 1 (p_e = (p_x, p_y, p_z) in Σ_{frame})",
                      f"IK branch 2 (p_e = (p_x, p_y, p_z) in Σ_{frame})",
                      f"J (geometric, Σ_{frame})", f"J_A (analytical, ZYZ, Σ_{frame})"):
            assert label in items and html.escape(label) in page, label
    sr = derivation.symbolic
    J = {f: _function(items[f"J (geometric, Σ_{f})"].expr, sr) for f in ("0", "base")}
    J_A = {f: _function(items[f"J_A (analytical, ZYZ, Σ_{f})"].expr, sr) for f in ("0", "base")}
    p = sp.symbols("p_x p_y p_z", real=True)
    ik = {f: [sp.lambdify([p], sp.Matrix(items[f"IK branch {k} (p_e = (p_x, p_y, p_z) in Σ_{f})"]
                                         .expr.rhs).xreplace(sr.numeric_substitution()), "numpy")
              for k in (1, 2)] for f in ("0", "base")}
    checked = set()
    for _ in range(8):
        q = _random_q(robot)
        for f in ("0", "base"):
            J_fd, J_A_fd = _finite_difference_jacobians(robot, q, f)
            np.testing.assert_allclose(J[f](q), J_fd, rtol=0, atol=1e-8, err_msg=f)
            if f == "0" or np.sin(q[1]) > 0.1:
                # J_A^base is printed for the branch sin ϑ > 0 of R_e^base, θ2 ∈ (0, π)
                # (docs/A1-kinematics.md); from Σ_0 the ZYZ angles are regular everywhere.
                np.testing.assert_allclose(J_A[f](q), J_A_fd, rtol=0, atol=1e-7, err_msg=f)
                checked.add(f)
            p_e = armlab.forward_kinematics(robot, q, f)[:3, 3]
            branches = [np.ravel(branch(p_e)).astype(float) for branch in ik[f]]
            for q_ik in branches:
                np.testing.assert_allclose(armlab.forward_kinematics(robot, q_ik, f)[:3, 3], p_e, atol=1e-12)
            wrapped = [np.r_[b[0], np.angle(np.exp(1j * (b[1] - q[1]))) + q[1], b[2]] for b in branches]
            assert min(np.abs(b - q).max() for b in wrapped) < 1e-9, f
        # Σ_0 is turned against Σ_base: the two Jacobians differ, not one of them shown twice.
        assert np.abs(J["0"](q) - J["base"](q)).max() > 0.1
    assert checked == {"0", "base"}


def test_a4_is_derived_for_the_actuated_prp_with_its_motors_and_friction():
    """The seed's A4 is Newton–Euler with motor and friction terms: the PRP report derives it
    for prp_actuated (the PRP plus motors and friction), the rest for the PRP itself.  The
    printed τ, B, C q̇ and g are the numeric dynamics of prp_actuated (recursive Newton–Euler,
    composite-rigid-body B, Christoffel C, rotors and friction included) to 1e-12, and
    τ − B q̈ − C q̇ − g is the friction F_v q̇ + F_s sgn q̇ of its file."""
    robot, actuated = armlab.load_robot("prp"), armlab.load_robot("prp_actuated")
    robots = report.derivation_robots(robot)
    assert robots["A4"].name == "prp_actuated"
    assert all(robots[key] is robot for key in ("A1", "A2", "A3", "A5"))
    (derivation,) = report.derivations(robot, BUDGET, only=("A4",))
    assert derivation.section.complete and derivation.robot.name == "prp_actuated"
    items, page = _shown(derivation, robot)
    assert "Derivation for prp_actuated:" in page
    sr = derivation.symbolic
    assert sr.has_motors and sr.has_friction
    tau = _function(items["τ = NE(q, q̇, q̈; g₀)"].expr, sr, "qd", "qdd")
    B = _function(items["B = [NE(q, 0, e_i; 0)]"].expr, sr)
    Cqd = _function(items["C q̇ = NE(q, q̇, 0; 0)"].expr, sr, "qd")
    g = _function(items["g = NE(q, 0, 0; g₀)"].expr, sr)
    for label in ("B_NE − B_Lagrange", "(C q̇)_NE − C_Christoffel q̇", "g_NE − g_Lagrange",
                  "τ_NE − τ_Lagrange"):
        assert items[label].expr.is_zero_matrix, label
    F_v = np.array([j.friction.viscous for j in actuated.joints])
    F_s = np.array([j.friction.coulomb for j in actuated.joints])
    assert (F_v > 0).all() and (F_s > 0).all()
    for _ in range(8):
        q = _random_q(actuated)
        qd, qdd = RNG.uniform(-2, 2, size=(2, actuated.n))
        B_q = armlab.inertia_matrix(actuated, q)
        np.testing.assert_allclose(B(q), B_q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(Cqd(q, qd).ravel(), armlab.coriolis_matrix(actuated, q, qd) @ qd,
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(g(q).ravel(), armlab.gravity_torque(actuated, q), rtol=0, atol=1e-12)
        tau_q = tau(q, qd, qdd).ravel()
        np.testing.assert_allclose(tau_q, armlab.inverse_dynamics(actuated, q, qd, qdd), rtol=0, atol=1e-12)
        friction = tau_q - B(q) @ qdd - Cqd(q, qd).ravel() - g(q).ravel()
        np.testing.assert_allclose(friction, F_v * qd + F_s * np.sign(qd), rtol=0, atol=1e-12)
        # The rotors' reflected inertias and the motors' masses are in B: not the PRP's B.
        assert np.abs(np.diag(B_q - armlab.inertia_matrix(robot, q))).min() > 1e-3


def test_only_the_same_arm_without_motors_takes_the_actuated_variant():
    """A robot that already has motors, or whose arm differs from the bundled variant's (here
    a heavier link 4), derives A4 for itself."""
    from dataclasses import replace

    prp = armlab.load_robot("prp")
    assert report.actuated_variant(prp).name == "prp_actuated"
    assert report.actuated_variant(armlab.load_robot("prp_actuated")) is None
    assert report.actuated_variant(armlab.load_robot("planar2r")) is None
    last = prp.links[-1]
    heavier = prp.replace(links=(*prp.links[:-1], replace(last, inertial=replace(last.inertial, mass=0.3))))
    assert report.actuated_variant(heavier) is None
    assert report.derivation_robots(heavier)["A4"] is heavier
