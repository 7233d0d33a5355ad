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
    assert "<mi>&#952;&#775;</mi>" in to_mathml(dict(section.pairs())["C(q, q̇)"])  # θ̇


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
