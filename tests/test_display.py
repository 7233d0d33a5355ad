"""Notebook display: robots, controllers, results and derivations render as HTML tables and
figures, never as an object dump, with every text from a file escaped."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

import armlab
from armlab.scenarios import load_scenario

PAYLOAD = '<script>alert("x")</script>&'


def hostile_robot():
    """The PRP with markup in every name a robot file can carry."""
    robot = armlab.load_robot("prp")
    joints = tuple(replace(j, name=f"{j.name}{PAYLOAD}") for j in robot.joints)
    links = tuple(replace(lk, name=f"{lk.name}{PAYLOAD}") for lk in robot.links)
    return robot.replace(name=f"arm{PAYLOAD}", description=f"about{PAYLOAD}", joints=joints, links=links,
                         parameters={f"L{PAYLOAD}": 0.5}, spec={"provenance": f"from{PAYLOAD}"})


def assert_no_dump(page: str):
    assert "object at 0x" not in page
    assert "Robot(name=" not in page and "RobotArrays(" not in page
    assert "<script" not in page


def test_a_robot_shows_its_joint_table_parameters_and_provenance():
    robot = armlab.load_robot("prp")
    page = robot._repr_html_()
    assert_no_dump(page)
    rows = re.findall(r"<tr>(.*?)</tr>", page)
    joint_rows = [row for row in rows if row.startswith("<td>d1<") or row.startswith("<td>theta2<")
                  or row.startswith("<td>d3<")]
    assert len(joint_rows) == 3
    assert "prismatic" in joint_rows[0] and "revolute" in joint_rows[1]
    # The values of the robot file are in the table, as written there.
    for name, value in robot.parameters.items():
        assert f"<td>{name}</td><td class=\"num\">{value:.6g}</td>" in page
    assert robot.spec["provenance"].split(";")[0] in page
    assert "Gravity" in page


def test_every_name_from_a_file_is_escaped():
    robot = hostile_robot()
    page = robot._repr_html_()
    assert_no_dump(page)
    assert PAYLOAD not in page
    escaped = "&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;&amp;"
    # robot name, description, provenance, 3 joints, 3 links, 1 parameter
    assert page.count(escaped) == 1 + 1 + 1 + 3 + 3 + 1


def test_a_controller_shows_its_law_and_gains():
    controller = load_scenario("a6_pd_online").controller
    page = controller._repr_html_()
    assert_no_dump(page)
    assert "τ = ĝ(q_g) + K_P (q_des − q) − K_D q̇" in page
    assert "joint_pd_gravity_law" in page
    kp = np.diag(controller.kp)
    assert re.search(rf"<td>kp</td><td>\[{kp[0]:.4g}, 0, 0\]", page)
    assert "Robot prp" in page


def test_a_controller_built_on_a_hostile_robot_escapes_its_name():
    from armlab.control.joint_space import JointPDGravity
    from armlab.references.joint import Constant

    robot = hostile_robot()
    controller = JointPDGravity(robot, Constant(np.zeros(3)), kp=np.ones(3), kd=np.ones(3))
    page = controller._repr_html_()
    assert PAYLOAD not in page and "Robot arm&lt;script&gt;" in page


def test_a_result_shows_a_summary_and_its_main_scope():
    result = load_scenario("a6_pd_online").run(t_final=0.2)
    page = result._repr_html_()
    assert_no_dump(page)
    assert "<td>status</td><td>ok</td>" in page
    assert f"<td>samples</td><td>{len(result)}</td>" in page
    images = re.findall(r'<img alt="([^"]*)" src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    assert len(images) == 1
    import base64

    assert base64.b64decode(images[0][1]).startswith(b"\x89PNG")
    assert "q_des" in images[0][0]


def test_a_derivation_section_shows_mathml_and_latex():
    from armlab.symbolic import derive

    (section,) = derive(armlab.load_robot("prp"), only="A1")
    page = section._repr_html_()
    assert_no_dump(page)
    assert page.count('<math display="block">') == len(section.items)
    assert "<mi>θ</mi>" in page or "θ" in page
    latex = section._repr_latex_()
    assert latex.startswith("$$\\begin{aligned}") and latex.endswith("\\end{aligned}$$")
    assert latex.count("\\\\ ") >= len(section.items) - 1


@pytest.mark.parametrize("name", ["robot", "controller"])
def test_repr_html_is_what_ipython_displays(name):
    ipython = pytest.importorskip("IPython.core.formatters", reason="IPython is not installed")
    formatter = ipython.HTMLFormatter()
    obj = armlab.load_robot("prp") if name == "robot" else load_scenario("a6_pd_online").controller
    assert formatter(obj) == obj._repr_html_()


def test_the_plain_text_forms_are_one_line_not_a_dump():
    robot = armlab.load_robot("prp")
    assert repr(robot).startswith("Robot('prp', 3 joints PRP, source=") and "\n" not in repr(robot)
    result = load_scenario("a6_pd_online").run(t_final=0.01)
    assert repr(result) == ("SimulationResult(11 samples, t = 0 … 0.01 s, 3 joints, status='ok', "
                            "signals=['q_des', 'q_err', 'g_comp'])")
