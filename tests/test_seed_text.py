"""What armlab's text says about the seed's derivations, checked against the seed's own formulas
read in the seed's own notation, and against armlab's model."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import armlab
from armlab.dynamics import inertia_matrix
from armlab.model.inertia import box_inertia

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _seed_b22(p: dict, d3: float = 0.0) -> float:
    """The seed's B22 (A2), built from the seed's own formulas in its letters: a box's edge a
    along z (for link 4, a4 is the bar's length L4), b, c across; the cylinder of radius a3 and
    height h3 = L3; Steiner shifts of a/2 (h/2) along z; its T_Link3 with the shift subtracted."""
    m, a, b, c, h, r = sp.symbols("m a b c h r", positive=True)
    box = m / 12 * sp.diag(a**2 + b**2, a**2 + c**2, b**2 + c**2)            # seed's I_C of a box
    shift = sp.Matrix([0, 0, -a / 2])                                        # "along z"
    box_origin = box + m * ((shift.T * shift)[0] * sp.eye(3) - shift * shift.T)
    link4_moment = box_origin[0, 0]                                          # about x, ⊥ the bar
    assert sp.simplify(link4_moment - m * (a**2 / 3 + b**2 / 12)) == 0     # the seed's T_Link4 term
    cylinder_transverse = m * (r**2 / 4 + h**2 / 12)
    link3_moment = cylinder_transverse - m * h**2 / 4                        # the seed's T_Link3 term
    assert sp.simplify(link3_moment - m * (r**2 / 4 - h**2 / 6)) == 0      # the seed's B22 term
    value = (link3_moment.subs({m: p["m_Link3"], r: p["a3"], h: p["L3"]})
             + link4_moment.subs({m: p["m_Link4"], a: p["L4"], b: p["b4"]}) + p["m_Link4"] * d3**2)
    return float(value)


def test_seed_a2_b22_in_the_seeds_own_notation():
    """Read with a4 = the bar's length, the seed's B22(d3 = 0) is +8.7·10⁻³ kg·m², 3.1 times
    armlab's 2.78·10⁻³ — positive, not the −1.9·10⁻³ of a4 read as a cross-section — and its
    box I_C is right; the docs say so and keep the critiques that hold."""
    robot = armlab.load_robot("prp")
    p = robot.parameters
    seed = _seed_b22(p)
    ours = float(inertia_matrix(robot, np.zeros(3))[1, 1])
    assert seed == pytest.approx(8.73e-3, abs=5e-5)
    assert ours == pytest.approx(2.78e-3, abs=5e-6)
    assert seed / ours == pytest.approx(3.1, abs=0.05)
    # The seed's box with a along z, b along y, c along x is armlab's box of edges (c, b, a).
    for m, a, b, c in ((0.2, 0.4, 0.03, 0.03), (1.3, 0.7, 0.2, 0.05)):
        seed_box = m / 12 * np.diag([a * a + b * b, a * a + c * c, b * b + c * c])
        np.testing.assert_allclose(seed_box, box_inertia(m, (c, b, a)), rtol=1e-14)

    a2 = (DOCS / "A2-energies.md").read_text(encoding="utf-8")
    notes = a2[a2.index("## Where the seed's algebra differs"):]
    assert "−1.9·10⁻³" not in notes and "not positive" not in notes
    assert "swaps the x and z" not in notes
    assert f"{seed * 1e3:.1f}·10⁻³" in notes and f"{ours * 1e3:.2f}·10⁻³" in notes
    assert f"{seed / ours:.1f} times" in notes
    assert "Steiner proof" in notes and "counted twice" in notes and "½ m3 a3²" in notes
    prp = (DOCS / "prp-dynamics.md").read_text(encoding="utf-8")
    assert "absent from the seed's term" not in prp and f"{seed * 1e3:.1f}·10⁻³" in prp


def test_seed_a4_t43_is_the_inverse_of_t30():
    """The seed's A4 "T_4^3", rebuilt as the seed prints it, is (T_3^0)⁻¹ of armlab's DH (which
    is the seed's A1 T_3^0), not the Σ_3 → Σ_e transform (the identity on the PRP); its T_2^1,
    T_3^2 are armlab's; the A4 page and the report's seed note say so."""
    from armlab.kinematics import forward_kinematics
    from armlab.symbolic.kinematics import link_transforms, relative_transforms
    from armlab.symbolic.model import symbolic_robot
    from armlab.viz.report import _seed_note_html

    robot = armlab.load_robot("prp")
    sr = symbolic_robot(robot)
    T30 = link_transforms(sr)[-1]
    names = {str(s): s for s in T30.free_symbols}
    L2, L3, L4, d1, d3, th = (names[k] for k in ("L2", "L3", "L4", "d1", "d3", "theta2"))
    c, s = sp.cos(th), sp.sin(th)
    seed_T21 = sp.Matrix([[c, 0, -s, 0], [s, 0, c, 0], [0, -1, 0, L3], [0, 0, 0, 1]])
    seed_T32 = sp.Matrix([[0, -1, 0, 0], [-1, 0, 0, 0], [0, 0, -1, d3 - L4 / 2], [0, 0, 0, 1]])
    seed_T43 = sp.Matrix([[0, 0, 1, -L2 / 2 - L3 - d1], [-c, -s, 0, 0], [s, -c, 0, d3 - L4 / 2],
                          [0, 0, 0, 1]])
    seed_T30 = sp.Matrix([[0, -c, s, s * (L4 / 2 - d3)], [0, -s, -c, -c * (L4 / 2 - d3)],
                          [1, 0, 0, L2 / 2 + L3 + d1], [0, 0, 0, 1]])
    zero = sp.zeros(4)
    A = relative_transforms(sr)
    assert sp.simplify(A[1] - seed_T21) == zero and sp.simplify(A[2] - seed_T32) == zero
    assert sp.simplify(T30 - seed_T30) == zero
    assert sp.simplify(seed_T43 - T30.inv()) == zero
    assert sp.simplify(seed_T43 * T30) == sp.eye(4)
    assert sr.tool == sp.eye(4) and sp.simplify(seed_T43 - sr.tool) != zero
    # Numerically too, against the numeric kinematics at a pose that is not special.
    q = np.array([0.07, 0.9, 0.12])
    values = {d1: q[0], th: q[1], d3: q[2], **{names[k]: robot.parameters[k] for k in ("L2", "L3", "L4")}}
    numeric = np.array(seed_T43.subs(values).evalf(), dtype=float)
    np.testing.assert_allclose(numeric, np.linalg.inv(forward_kinematics(robot, q, frame="0")), atol=1e-12)

    a4 = (DOCS / "A4-newton-euler.md").read_text(encoding="utf-8")
    notes = " ".join(a4[a4.index("## Where the seed's algebra differs"):].split())
    assert "has no counterpart" not in notes
    assert "(T_3^0)⁻¹ = T_0^3" in notes and "base-to-Σ_3 transform" in notes
    assert "(−L2/2 − L3 − d1, 0, d3 − L4/2)" in notes and "R_4^3 = I" in notes
    report = " ".join(_seed_note_html(4).split())
    assert "(T_3^0)⁻¹ = T_0^3" in report and "has no counterpart" not in report


def test_seed_a7_mismatch_equilibrium_is_not_called_a_seed_figure():
    """The seed gives no value for its A7 mismatch's steady state: the scenarios, the A7 page
    and the report's A7 articles call (0, −0.113, 0.063) the equilibrium of the seed's
    experiment, never the seed's figure."""
    from armlab.viz.experiments import experiment_from_scenario
    from armlab.viz.report import _experiment_html, _seed_note_html

    old = re.compile(r"seed(?:'|’|&#x27;)s (?:own )?(?:figure|number)", re.IGNORECASE)
    for name in ("a7_id_mismatch", "a7_id_mismatch_regulation"):
        rendered = _experiment_html(experiment_from_scenario(name)).replace("&#x27;", "'")
        assert "(0, −0.113, 0.063), the equilibrium of the seed's experiment" in rendered
        assert not old.search(rendered)
    a7 = " ".join((DOCS / "A7-inverse-dynamics.md").read_text(encoding="utf-8").split())
    assert "(0, −0.113 rad, 0.063 m), the equilibrium of the seed's experiment" in a7
    assert not old.search(a7) and not old.search(_seed_note_html(7))
