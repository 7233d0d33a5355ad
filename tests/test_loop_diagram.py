"""The block diagram of every scenario's closed loop (armlab.viz.loop_diagram), its drawing
and ``armlab run --diagram``.  Expected values are read from the scenario files themselves."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from armlab.scenarios import bundled_scenario_names, load_scenario, scenario_from_table, scenario_path
from armlab.viz.diagram_drawing import draw_loop_diagram
from armlab.viz.loop_diagram import QD, H, Q, X, gain, loop_diagram

# What each controller family reads back, from its law's definition (docs/notation.md C1–C15):
# the force-feedback laws read h_e, the task-space ones the direct kinematics.
READS_FORCE = {"ImpedanceControl", "AdmittanceControl", "ForceControl", "ParallelForcePosition"}
JOINT_SPACE = {"JointPDGravity", "JointInverseDynamics", "SlotineLi1DoF", "SlotineLi"}


def _file(name: str) -> dict:
    with open(scenario_path(name), "rb") as handle:
        return tomllib.load(handle)


def _text(block) -> str:
    return "\n".join([block.title, *block.lines])


@pytest.mark.parametrize("name", bundled_scenario_names())
def test_every_scenario_has_its_loop_from_reference_to_sensors(name):
    scenario = load_scenario(name)
    data = _file(name)
    diagram = loop_diagram(scenario)
    kinds = [b.kind for b in diagram.blocks]
    assert kinds[0] == "reference" and kinds[-2:] == ["plant", "sensors"]
    assert kinds.count("law") >= 1
    assert ("saturation" in kinds) == ("torque_limit" in data["simulation"])
    assert ("hold" in kinds) == ("control_period" in data["simulation"])
    disturbed = [b for b in diagram.blocks if b.above is not None and b.above.kind == "disturbance"]
    stops = data["simulation"].get("joint_limits") == "stop"   # the simulator's joint stops (S4)
    assert len(disturbed) == (1 if data.get("disturbance") or stops else 0)
    if disturbed:
        assert len(disturbed[0].above.lines) == len(data.get("disturbance", [])) + stops
    plant = diagram.blocks[-2]
    environment = data.get("environment", {}).get("type", "free_space")
    assert (plant.above is not None) == (environment != "free_space")
    kind = type(scenario.controller).__name__
    assert (H in diagram.signals) == (kind in READS_FORCE)
    assert (X in diagram.signals or "ẋ_e = J(q) q̇" in diagram.signals) == (kind not in JOINT_SPACE)
    assert {Q, QD} <= set(diagram.signals)
    # Every lane has a reader and every read signal a lane.
    read = {s for b in diagram.blocks for s in b.reads}
    assert read == set(diagram.signals)


def test_gains_limits_and_terms_are_the_files_numbers():
    saturated = loop_diagram(load_scenario("a7_id_high_gain_saturated"))
    text = "\n".join(_text(b) for b in saturated.blocks)
    data = _file("a7_id_high_gain_saturated")
    assert f"K_P = {data['controller']['kp']:g} I₃" in text
    assert f"K_D = {data['controller']['kd']:g} I₃" in text
    assert f"|τ_i| ≤ {data['simulation']['torque_limit']:g}" in text
    pd = loop_diagram(load_scenario("a6_pd_online"))
    kp = _file("a6_pd_online")["controller"]["kp"]
    assert f"K_P = diag({', '.join(f'{v:g}' for v in kp)})" in "\n".join(_text(b) for b in pd.blocks)
    assert "ĝ(q)" in pd.blocks[2].title  # online compensation: gravity at the measured q
    mismatch = loop_diagram(load_scenario("a7_id_mismatch"))
    inner = "\n".join(_text(b) for b in mismatch.blocks)
    assert "n̂: model: link4 0.16 kg (plant 0.2)" in inner and "B̂: model = plant" in inner
    wall = loop_diagram(load_scenario("a15_parallel_contact_wall")).blocks[-2].above
    stiffness = _file("a15_parallel_contact_wall")["environment"]["stiffness"]
    assert "pushes only" in wall.title and f"k = {stiffness:g} N/m" in _text(wall)


def test_sampled_control_gets_a_zero_order_hold_before_the_saturation():
    data = _file("a7_id_high_gain_saturated")
    data["simulation"]["control_period"] = 0.005
    diagram = loop_diagram(scenario_from_table(data, scenario_path("a7_id_high_gain_saturated")))
    kinds = [b.kind for b in diagram.blocks]
    assert kinds.index("hold") + 1 == kinds.index("saturation")
    assert "T_c = 0.005 s" in diagram.blocks[kinds.index("hold")].lines


def test_gain_text_tells_scalar_diagonal_and_full_apart():
    assert gain("K", 5.0) == "K = 5"
    assert gain("K", np.eye(2) * 3) == "K = 3 I₂"
    assert gain("K", np.diag([1.0, 2.5])) == "K = diag(1, 2.5)"
    assert gain("K", [[1.0, 0.5], [0.5, 1.0]]) == "K: 2 × 2 full"


def test_an_unknown_controller_is_one_generic_block():
    from dataclasses import replace

    from armlab.control.function import FunctionController

    scenario = load_scenario("a6_pd_online")
    law = FunctionController(scenario.plant, lambda t, q, qd: -qd)
    diagram = loop_diagram(replace(scenario, controller=law))
    assert [b.kind for b in diagram.blocks] == ["law", "plant", "sensors"]
    assert "FunctionController" in diagram.blocks[0].title


@pytest.mark.parametrize("name", ["a6_pd_sine_disturbance", "a8_case1_sine", "a12_impedance_regulation",
                                  "a15_parallel_contact"])
def test_drawing_keeps_every_text_inside_the_figure_and_blocks_apart(name):
    fig = draw_loop_diagram(loop_diagram(load_scenario(name)))
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    frame = fig.bbox
    (ax,) = fig.axes
    texts = [t for t in ax.texts if t.get_text()]
    assert len(texts) > 10
    for text in texts:
        box = text.get_window_extent(renderer)
        assert frame.x0 - 0.5 <= box.x0 and box.x1 <= frame.x1 + 0.5, text.get_text()
        assert frame.y0 - 0.5 <= box.y0 and box.y1 <= frame.y1 + 0.5, text.get_text()
    boxes = [p.get_window_extent(renderer) for p in ax.patches]
    for i, one in enumerate(boxes):
        for other in boxes[i + 1:]:
            assert not one.overlaps(other), name


def test_run_diagram_writes_the_figure(tmp_path):
    from PIL import Image

    from armlab.cli import OK, main

    assert main(["run", "a6_pd_online", "--t-final", "0.01", "--diagram", "--format", "npz",
                 "--out", str(tmp_path), "--quiet"]) == OK
    with Image.open(tmp_path / "a6_pd_online_loop.png") as image:
        assert image.width > 600 and image.height > 150


def test_the_tags_an_arrow_names_reach_the_article_s_legend():
    """a11_compliance's error arrow reads "x̃ in Σ_d (T1–T4)": the figure's tags include the
    notation's task-space T1 to T4 (the theory's predictions are H tags), and so does the
    caption that lists them."""
    from armlab.viz.loop_diagram import diagram_text
    from armlab.viz.report_runs import loop_figure
    from armlab.viz.tags import notation_tags

    diagram = loop_diagram(load_scenario("a11_compliance"))
    assert "x̃ in Σ_d (T1–T4)" in diagram_text(diagram)
    png, tags = loop_figure("a11_compliance")
    assert png and {"C11", "T1", "T2", "T3", "T4", "E2"} <= set(tags) and set(tags) <= set(notation_tags())
