"""No text of a robot file ever becomes code.

Every text field of a robot file (name, description, provenance, joint and link names,
parameter names, expression strings) is filled with payloads that would create a marker file
if any of it were pasted into source and run, or evaluated.  Each path that writes or evaluates
code sees them: the generated closed-form and traced modules (written, then imported), the
symbolic derivation and its three renderings, and the expression reader.  The marker must never
appear.
"""

from __future__ import annotations

import importlib.util
import sys
import tomllib
from pathlib import Path

import pytest

from armlab.errors import RobotFileError
from armlab.model.toml_io import robot_from_dict
from armlab.robots import bundled_robot_path

PAYLOADS = (
    'x"""; __import__("pathlib").Path({marker!r}).touch(); """',
    "x'''; __import__('pathlib').Path({marker!r}).touch(); '''",
    'x"\n__import__("pathlib").Path({marker!r}).touch()\n#',
    "x}}{{__import__('pathlib').Path({marker!r}).touch()}}",
    "</script><script>x</script>$(touch {marker})`touch {marker}`",
)


def _hostile_prp(payload: str) -> dict:
    """prp with ``payload`` in every text field; names are single lines (a name with a line
    break is refused, see below), so they carry the payload with its line breaks as spaces."""
    data = tomllib.loads(bundled_robot_path("prp").read_text(encoding="utf-8"))
    name = payload.replace("\n", " ")
    data["description"] = data["provenance"] = payload
    data["name"] = name
    for i, joint in enumerate(data["joints"]):
        joint["name"] = f"{name}{i}"
        joint["link"]["name"] = f"{name}link{i}"
    return data


@pytest.mark.parametrize("field", ["name", "joints.name", "link.name"])
@pytest.mark.parametrize("text", ["x\ny", "x\ry", "x\x1b[2Jy", "x\u2028y"])
def test_names_with_line_breaks_or_control_characters_are_refused(field, text):
    data = tomllib.loads(bundled_robot_path("prp").read_text(encoding="utf-8"))
    if field == "name":
        data["name"] = text
    elif field == "joints.name":
        data["joints"][1]["name"] = text
    else:
        data["joints"][1]["link"]["name"] = text
    with pytest.raises(RobotFileError) as caught:
        robot_from_dict(data, "hostile.toml")
    message = str(caught.value)
    assert message.startswith("hostile.toml: ") and "printable" in message
    assert message.isprintable()


@pytest.fixture(params=range(len(PAYLOADS)), ids=lambda i: f"payload{i}")
def hostile(request, tmp_path):
    marker = tmp_path / "pwned"
    payload = PAYLOADS[request.param].format(marker=str(marker))
    return payload, marker


def _import_source(source: str, path: Path):
    """Write and import a generated module as armlab does (its top level runs on import)."""
    path.write_text(source, encoding="utf-8")
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(path.stem, None)
    return module


def test_generated_modules_contain_no_file_text(hostile, tmp_path):
    from armlab.specialise.traced import traced_source

    payload, marker = hostile
    robot = robot_from_dict(_hostile_prp(payload), "hostile.toml")
    sources = {"traced": traced_source(robot, key="0123abcd")}
    for generator, source in sources.items():
        for piece in ("pathlib", "touch", robot.joints[0].name, robot.links[0].name):
            assert piece not in source, (generator, piece)
        module = _import_source(source, tmp_path / f"generated_{generator}.py")
        assert hasattr(module, "inverse_dynamics")
    assert not marker.exists()


def test_derivation_renders_names_as_text(hostile):
    from armlab.symbolic import derive, render

    payload, marker = hostile
    robot = robot_from_dict(_hostile_prp(payload), "hostile.toml")
    sections = derive(robot, only="A1")
    for fmt in ("text", "latex", "markdown"):
        render(sections, fmt, heading=robot.name)
    assert not marker.exists()


@pytest.mark.parametrize("field", ["parameters.m_Link2", "mass"])
def test_expressions_are_never_evaluated_as_python(hostile, field):
    payload, marker = hostile
    data = _hostile_prp("prp")
    code = f"__import__('pathlib').Path({str(marker)!r}).touch() or 1"
    if field == "mass":
        data["joints"][0]["link"]["mass"] = code
    else:
        data["parameters"]["m_Link2"] = code
    with pytest.raises(RobotFileError) as caught:
        robot_from_dict(data, "hostile.toml")
    assert "hostile.toml" in str(caught.value) and "\n" not in str(caught.value)
    assert not marker.exists()


def test_report_page_escapes_the_robot_text(hostile, tmp_path, monkeypatch):
    """The HTML report writes the robot's name and description into the page (title, header,
    the list of what is missing): always escaped.  The drawings and derivations (tens of
    seconds, escaped where they are made) are left out here."""
    from armlab.viz import report

    payload, marker = hostile
    robot = robot_from_dict(_hostile_prp(payload), "hostile.toml")
    monkeypatch.setattr(report, "_symbolic_sections", lambda robot, progress, budget: ({}, True))
    monkeypatch.setattr(report, "_drawings", lambda robot: "")
    path = report.build_report(robot, tmp_path / "report", experiments=[], animation=False,
                               show_progress=False, jobs=1)
    page = path.read_text(encoding="utf-8")
    assert "No runnable derivation or scenario" in page  # the section that names the robot
    for text in (payload, robot.name, robot.joints[0].name):
        assert text not in page
    assert "<script" not in page
    assert not marker.exists()
