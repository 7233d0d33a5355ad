"""``armlab derive`` and the rendering of derivation sections."""

import sympy as sp

import armlab
from armlab.cli import main
from armlab.symbolic import derive, render, to_mathml


def test_derive_sections_are_label_expression_pairs():
    (section,) = derive(armlab.load_robot("prp"), only="A3")
    assert section.key == "A3" and section.assignment == 3
    labels = [label for label, expr in section.items]
    assert "C(q, q̇)" in labels and "g(q)" in labels
    assert all(isinstance(expr, sp.Basic) for _, expr in section.items)
    assert all(item.tex for item in section.items)
    assert THETA_DOT in to_mathml(dict(section.pairs())["C(q, q̇)"])


# θ̇ and ḋ as the letter under a spacing dot (U+02D9), never a combining one (U+0307).
THETA_DOT = '<mover accent="false"><mi>&#952;</mi><mo>&#729;</mo></mover>'
D_DOT = '<mover accent="false"><mi>d</mi><mo>&#729;</mo></mover>'


def _mathml_tree(text: str):
    """The MathML as an element tree (entities of the printer resolved), to read it back."""
    import xml.etree.ElementTree as ET

    return ET.fromstring(f"<math>{text.replace('&InvisibleTimes;', '&#8290;')}</math>")


def test_mathml_of_the_energies_dots_every_rate_and_uses_true_minus_signs():
    (section,) = derive(armlab.load_robot("prp"), only="A2")
    pairs = dict(section.pairs())
    kinetic = to_mathml(pairs["T_ℓ₂"])
    assert THETA_DOT in kinetic and D_DOT in kinetic
    assert "&#775;" not in kinetic  # no combining dot left anywhere
    everything = "".join(to_mathml(expr) for _, expr in section.items)
    tree = _mathml_tree(everything)
    operators = [e.text for e in tree.iter("mo")]
    assert "-" not in operators and "\u2212" in operators
    assert not any((e.text or "").startswith("-") for e in tree.iter("mn"))
    # Every rate symbol of the section is drawn with a dot over its letter.
    rates = {s for _, expr in section.items for s in expr.free_symbols if "dot" in s.name}
    assert len(rates) == 3
    for rate in rates:
        shown = to_mathml(rate)
        assert shown.startswith("<msub><mover") and shown in everything


def test_mathml_of_the_euler_rate_map_shows_greek_letters():
    (section,) = derive(armlab.load_robot("prp"), only="A5")
    text = "".join(to_mathml(expr) for _, expr in section.items)
    assert "varphi" not in text and "vartheta" not in text
    letters = {e.text for e in _mathml_tree(text).iter("mi")}
    assert {"\u03c6", "\u03d1"} <= letters  # φ and ϑ


def test_mathml_keeps_the_parentheses_of_a_negated_sum_and_breaks_wide_sums():
    x, y = sp.symbols("x y")
    negated = sp.Mul(-1, x + y, evaluate=False)
    tree = _mathml_tree(to_mathml(negated))
    assert [e.text for e in tree.iter("mo")] == ["\u2212", "(", "+", ")"]
    # A sum far wider than a line: one table row per line, every term kept once, in order.
    names = [f"v{chr(97 + k % 26)}{chr(97 + k // 26)}" for k in range(40)]
    wide = to_mathml(sp.Matrix([sp.Add(*(x * sp.Symbol(n) for n in names)), y]))
    tree = _mathml_tree(wide)
    inner = [t for t in tree.iter("mtable") if t.get("columnalign") == "left"]
    assert len(inner) == 1 and len(inner[0].findall("mtr")) > 2
    shown = [e.text for e in inner[0].iter("mi") if e.text.startswith("v")]
    assert sorted(shown) == sorted(names)
    assert [e.text for e in tree.iter("mi")][-1] == "y"  # the next entry follows the broken one


def test_cli_derive_prints_markdown_with_latex(capsys):
    assert main(["derive", "prp", "--only", "A3", "--format", "markdown"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("# prp: symbolic model")
    assert r"C(q, \dot q) = \left(\begin{matrix}" in out
    assert r"9.81 d_{3} m_{Link4} \sin{\left(\theta_{2} \right)}" in out


def test_cli_derive_numeric_text_and_latex(capsys):
    assert main(["derive", "prp", "--only", "A1", "--numeric", "--frame", "base"]) == 0
    text = capsys.readouterr().out
    assert "T₃^base" in text and "L₄" not in text
    (section,) = derive(armlab.load_robot("prp"), only="A1", numeric=True)
    latex = render([section], "latex", numeric=True)
    assert r"\subsection*{A1" in latex and "0.2" in latex


def test_cli_derive_unknown_robot_is_one_line_error(capsys):
    assert main(["derive", "no_such_robot"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no_such_robot" in err


def test_derive_takes_the_recursive_route_beyond_three_joints():
    import numpy as np

    from armlab.model.toml_io import robot_from_dict

    link = {"mass": 1.0, "com": [-0.1, 0, 0], "inertia": [[0.001, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]}
    robot = robot_from_dict({"name": "planar4r", "gravity": [0, -9.81, 0], "joints": [
        {"name": f"q{i}", "type": "revolute", "dh": {"a": 0.2, "alpha": 0, "d": 0, "theta": 0},
         "link": link} for i in range(1, 5)]}, "planar4r.toml")
    (a3,) = derive(robot, only="A3")
    items = dict(a3.pairs())
    assert "ℒ = T − U" not in items and any("polynomial ring" in note for note in a3.notes)
    q, qd = np.array([0.3, -0.7, 1.1, 0.2]), np.array([0.5, -1.0, 0.8, 0.3])
    symbols = sorted(items["C(q, q̇)"].free_symbols, key=str)
    values = {s: (qd if "dot" in s.name else q)[int(s.name[-1]) - 1] for s in symbols}
    C = np.array(items["C(q, q̇)"].xreplace(values).evalf(), dtype=float)
    np.testing.assert_allclose(C, armlab.coriolis_matrix(robot, q, qd), atol=1e-12)
