"""Fuzzing the file readers: every input gives one of exactly two outcomes.

Robot TOML files, URDF files and scenario files are mutated as a hostile or careless author
would (``strategies.mutated_tables``, ``mutated_urdf``, ``damaged_text``: values of the wrong
type, NaN, ±inf, huge numbers, expressions that break naive evaluators, deleted, added and
repeated keys, duplicated names, DTDs with entities, FIFOs and devices named as files …).  Each
mutant must give

* a valid robot or scenario whose numbers are all finite (checked here, independently of the
  readers' own checks), or
* the file's error class with one printable line that starts with the file's name,

and, when the mutation put a value that no field can hold (NaN, ±inf, an integer beyond the
float range, a duplicated name, a DTD …), always the second.  Through ``armlab.cli.main`` the
same files never give a traceback.  Examples are derandomized: every run tries the same files.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import math
import os
import tomllib
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import armlab
from armlab.cli import main
from armlab.errors import RobotFileError, ScenarioFileError
from armlab.model.robot import Robot
from armlab.model.toml_io import robot_from_dict
from armlab.model.urdf_io import load_urdf, to_urdf
from armlab.robots import bundled_robot_names, bundled_robot_path
from armlab.scenarios import Scenario, bundled_scenario_names, load_scenario_file, scenario_path
from strategies import (
    damaged_text,
    is_poison,
    mutated_tables,
    mutated_urdf,
    toml_dumps,
)

ROBOTS = bundled_robot_names()
SCENARIOS = bundled_scenario_names()
FUZZ = dict(derandomize=True, database=None, deadline=None,
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def _parsed(path: Path) -> dict:
    return tomllib.loads(path.read_text(encoding="utf-8"))


ROBOT_DATA = {name: _parsed(bundled_robot_path(name)) for name in ROBOTS}
SCENARIO_DATA = {name: _parsed(scenario_path(name)) for name in SCENARIOS}
HAND_URDF = (Path(__file__).parent / "test_urdf.py").read_text(encoding="utf-8")
HAND_URDF = HAND_URDF[HAND_URDF.index('<?xml version="1.0"?>\n<robot name="hand">'):]
HAND_URDF = HAND_URDF[:HAND_URDF.index("</robot>") + len("</robot>")] + "\n"


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A folder with the traps a mutated file may name: a FIFO, a link to /dev/zero, a folder."""
    folder = tmp_path_factory.mktemp("fuzz")
    os.mkfifo(folder / "fifo.toml")
    (folder / "zero.toml").symlink_to("/dev/zero")
    (folder / "directory.toml").mkdir()
    return folder


# ------------------------------------------------------------------ the two outcomes
def _one_line(error: Exception, file) -> None:
    message = str(error)
    assert message.startswith(f"{file}: "), message
    assert message.isprintable(), message  # one line: no line break, no control character


def _finite(value) -> bool:
    """Every number in ``value`` (float, array, tuple, dataclass fields) is finite."""
    if isinstance(value, Robot):
        return _finite_robot(value)
    if isinstance(value, (bool, str, type(None))):
        return True
    if isinstance(value, (int, float, np.ndarray, np.number)):
        array = np.asarray(value)
        return not np.issubdtype(array.dtype, np.number) or bool(np.all(np.isfinite(array)))
    if isinstance(value, (tuple, list)):
        return all(_finite(v) for v in value)
    if isinstance(value, dict):
        return all(_finite(v) for v in value.values())
    if dataclasses.is_dataclass(value):
        return all(_finite(getattr(value, f.name)) for f in dataclasses.fields(value)
                   if hasattr(value, f.name))
    return True


def _finite_robot(robot: Robot) -> bool:
    m = robot.arrays
    limits = np.concatenate([m.q_min, m.q_max])
    arrays = [getattr(m, name) for name in m._fields if name not in ("q_min", "q_max")]
    return (isinstance(robot.name, str) and robot.n >= 1 and not np.isnan(limits).any()
            and np.all(m.q_min < m.q_max) and all(np.all(np.isfinite(a)) for a in arrays)
            and all(np.all(np.isfinite(a)) for a in (robot.base, robot.tool, robot.gravity)))


def _robot_outcome(load, file, poisoned: bool) -> None:
    try:
        robot = load()
    except RobotFileError as error:
        _one_line(error, file)
        return
    assert not poisoned, "a value no field can hold was accepted"
    assert _finite_robot(robot)


def _scenario_outcome(path: Path, poisoned: bool) -> None:
    try:
        scenario = load_scenario_file(path)
    except ScenarioFileError as error:
        _one_line(error, path)
        return
    assert not poisoned, "a value no field can hold was accepted"
    assert _finite_robot(scenario.plant)
    assert _finite(scenario.simulation) and _finite(scenario.controller)
    assert _finite(scenario.disturbance) and _finite(scenario.environment)
    settings_ = scenario.simulation
    assert 0 < settings_["dt"] <= settings_["t_final"]


# ------------------------------------------------------------------ robot TOML
@settings(max_examples=800, **FUZZ)
@given(data=st.data())
def test_mutated_robot_tables(data):
    name = data.draw(st.sampled_from(ROBOTS))
    mutant = data.draw(mutated_tables(ROBOT_DATA[name]))
    _robot_outcome(lambda: robot_from_dict(mutant, "fuzz.toml"), "fuzz.toml",
                   is_poison(mutant, booleans=True))


@settings(max_examples=60, **FUZZ)
@given(data=st.data())
def test_damaged_robot_files(folder, data):
    name = data.draw(st.sampled_from(ROBOTS))
    text = data.draw(damaged_text(bundled_robot_path(name).read_text(encoding="utf-8")))
    path = folder / "damaged.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    _robot_outcome(lambda: armlab.load_robot(path), path, False)


def _set(data: dict, where: str, value) -> dict:
    """A copy of ``data`` with the value at ``where`` ("joints.1.link.mass") replaced."""
    import copy

    data = copy.deepcopy(data)
    *path, last = [int(k) if k.isdigit() else k for k in where.split(".")]
    target = data
    for key in path:
        target = target[key]
    target[last] = value
    return data


@pytest.mark.parametrize("where, value, field, reason", [
    ("joints.2.link.mass", "(-1)**0.5", "joints[2].link.mass", "is not a real number"),
    ("joints.2.link.mass", "True", "joints[2].link.mass", "unsupported expression element 'True'"),
    ("joints.2.link.mass", True, "joints[2].link.mass", "expected a number, got True"),
    ("joints.2.link.mass", 10**400, "joints[2].link.mass", "is beyond the range of a float"),
    ("joints.2.link.mass", "+1" * 1000, "joints[2].link.mass", "longer than the 1000 allowed"),
    ("joints.2.link.mass", "1" + "+1" * 400, "joints[2].link.mass", "nested more than 100 levels"),
    ("joints.2.link.mass", "-" * 900 + "1", "joints[2].link.mass", "nested more than 100 levels"),
    ("joints.2.link.mass", "10**10**10", "joints[2].link.mass", "exponent 1e+10 is beyond ±100"),
    ("joints.2.link.mass", "1e308*10", "joints[2].link.mass", "is not finite"),
    ("joints.2.link.shape.size", [1e308, 0.1, 0.1], "joints[2].link.shape.size[0]", "beyond ±1e+12"),
    ("joints.2.link.com", [0, "1e200*1e200", 0], "joints[2].link.com[1]", "is not finite"),
    ("name", 12, "name", "expected a non-empty string, got 12"),
    ("name", "x" * 1001, "name", "is longer than 1000 characters"),
    ("name", ["prp"], "name", "expected a non-empty string"),
    ("name", {"a": 1}, "name", "expected a non-empty string"),
    ("description", 3.5, "description", "expected a string, got float"),
    ("provenance", [], "provenance", "expected a string, got list"),
    ("joints.1.name", "d1", "joints[1].name", "joint name 'd1' is used twice"),
    ("joints.1.link.name", "link2", "joints[1].link.name", "link name 'link2' is used twice"),
])
def test_robot_values_the_issue_found_accepted_or_crashing(where, value, field, reason):
    with pytest.raises(RobotFileError) as caught:
        robot_from_dict(_set(ROBOT_DATA["prp"], where, value), "prp.toml")
    _one_line(caught.value, "prp.toml")
    assert str(caught.value).startswith(f"prp.toml: {field}: ") and reason in str(caught.value)


def test_integers_beyond_pythons_digit_limit_are_a_syntax_error(folder):
    path = folder / "digits.toml"
    text = bundled_robot_path("prp").read_text(encoding="utf-8")
    path.write_text(text.replace("m_Link2 = 0.5", "m_Link2 = " + "1" * 5000), encoding="utf-8")
    with pytest.raises(RobotFileError) as caught:
        armlab.load_robot(path)
    assert str(caught.value).startswith(f"{path}: syntax: Exceeds the limit (4300 digits)")


def test_derived_arrays_that_overflow_name_the_link(monkeypatch):
    """Numbers finite one by one can overflow together; with the magnitude bound lifted, a
    diagonal inertia of 1e308 rotated into the joint frame is caught by the final check."""
    import armlab.model.toml_io as toml_io

    monkeypatch.setattr(toml_io, "MAX_MAGNITUDE", math.inf)
    data = _set(ROBOT_DATA["prp"], "joints.2.link.inertia",
                [[1e308, 0, 0], [0, 1e308, 0], [0, 0, 1e308]])
    data["joints"][2]["link"].pop("shape")
    with pytest.raises(RobotFileError) as caught:
        robot_from_dict(data, "prp.toml")
    assert str(caught.value).startswith("prp.toml: joints[2].link: its values overflow")


@pytest.mark.parametrize("trap", ["fifo.toml", "zero.toml", "directory.toml", "missing.toml"])
def test_robot_files_that_are_not_regular_files(folder, trap):
    with pytest.raises(RobotFileError) as caught:
        armlab.load_robot(folder / trap)
    _one_line(caught.value, folder / trap)


def test_toml_writer_gives_back_the_bundled_files():
    """The fuzz tests write mutants with ``strategies.toml_dumps``: it must be faithful."""
    for data in (*ROBOT_DATA.values(), *SCENARIO_DATA.values()):
        assert tomllib.loads(toml_dumps(data)) == data


# ------------------------------------------------------------------ URDF
URDF_SOURCES = {"hand": HAND_URDF, "prp": None, "puma560": None}


def _urdf_source(name: str) -> str:
    if URDF_SOURCES[name] is None:
        URDF_SOURCES[name] = to_urdf(armlab.load_robot(name))
    return URDF_SOURCES[name]


@settings(max_examples=150, **FUZZ)
@given(data=st.data())
def test_mutated_urdf(folder, data):
    name = data.draw(st.sampled_from(sorted(URDF_SOURCES)))
    text, poisoned = data.draw(mutated_urdf(_urdf_source(name)))
    path = folder / "fuzz.urdf"
    path.write_text(text, encoding="utf-8")
    _robot_outcome(lambda: load_urdf(path), path, poisoned)


@settings(max_examples=40, **FUZZ)
@given(data=st.data())
def test_damaged_urdf(folder, data):
    path = folder / "damaged.urdf"
    path.write_text(data.draw(damaged_text(HAND_URDF)), encoding="utf-8")
    _robot_outcome(lambda: load_urdf(path), path, False)


# ------------------------------------------------------------------ scenario TOML
@settings(max_examples=400, **FUZZ)
@given(data=st.data())
def test_mutated_scenarios(folder, data):
    name = data.draw(st.sampled_from(SCENARIOS))
    mutant = data.draw(mutated_tables(SCENARIO_DATA[name]))
    path = folder / "fuzz.toml"
    path.write_text(toml_dumps(mutant), encoding="utf-8")
    _scenario_outcome(path, is_poison(mutant, booleans=False))


@pytest.mark.parametrize("change, field", [
    (("dt", [0.001]), "simulation.dt"), (("t_final", [1.0]), "simulation.t_final"),
    (("dt", -0.001), "simulation.dt"), (("dt", 0), "simulation.dt"),
    (("t_final", math.inf), "simulation.t_final"), (("max_kinetic_energy", math.nan),
                                                    "simulation.max_kinetic_energy"),
    (("control_period", 1e9), "simulation.control_period"), (("log_every", 0.5), "simulation.log_every"),
    (("log_every", 10**30), "simulation.log_every"), (("q0", [0, 0]), "simulation.q0"),
    (("torque_limit", [1, -1, 1]), "simulation.torque_limit"), (("method", ["rk4"]), "simulation.method"),
])
def test_simulation_settings_the_issue_found_accepted_or_crashing(folder, change, field):
    data = SCENARIO_DATA["a6_pd_online"]
    key, value = change
    mutant = {**data, "simulation": {**data["simulation"], key: value}}
    path = folder / "settings.toml"
    path.write_text(toml_dumps(mutant), encoding="utf-8")
    with pytest.raises(ScenarioFileError) as caught:
        load_scenario_file(path)
    _one_line(caught.value, path)
    assert str(caught.value).startswith(f"{path}: {field}: ")


@pytest.mark.parametrize("mass, reason", [(-1, "must be a mass from 0 to 1e+12 kg, got -1"),
                                          (1e13, "must be a mass from 0 to 1e+12 kg, got 1e+13"),
                                          ("nan", "cannot evaluate 'nan' (unknown name 'nan')"),
                                          (True, "expected a number, got a boolean")])
def test_link_mass_overrides_are_checked(folder, mass, reason):
    data = SCENARIO_DATA["a6_pd_online"]
    path = folder / "override.toml"
    path.write_text(toml_dumps({**data, "plant_link_mass": {"link4": mass}}), encoding="utf-8")
    with pytest.raises(ScenarioFileError) as caught:
        load_scenario_file(path)
    assert str(caught.value) == f"{path}: plant_link_mass.link4: {reason}"


# ------------------------------------------------------------------ the command line
class _Loaded(Exception):
    """Raised instead of simulating: the scenario file was read and checked."""


def _cli(argv: list[str]) -> tuple[int | None, str]:
    """(exit code, stderr) of ``armlab ARGV`` in this process; None when a scenario loaded."""
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out), \
            mock.patch.object(Scenario, "run", side_effect=_Loaded):
        try:
            code = main(argv)
        except _Loaded:
            code = None
    return code, err.getvalue()


def _clean(code, err: str, command: str) -> None:
    assert "Traceback" not in err
    if code not in (0, None):
        assert code == 2 and err.count("\n") == 1 and err.startswith(f"armlab {command}: error: "), err


@settings(max_examples=250, **FUZZ)
@given(data=st.data())
def test_cli_never_prints_a_traceback(folder, data):
    kind = data.draw(st.sampled_from(["robot", "urdf", "scenario"]))
    if kind == "robot":
        path = folder / "cli.toml"
        mutant = data.draw(mutated_tables(ROBOT_DATA[data.draw(st.sampled_from(ROBOTS))]))
        path.write_text(toml_dumps(mutant), encoding="utf-8")
        argv = ["robots", str(path)]
    elif kind == "urdf":
        path = folder / "cli.urdf"
        path.write_text(data.draw(mutated_urdf(HAND_URDF))[0], encoding="utf-8")
        argv = ["robots", str(path)]
    else:
        path = folder / "cli_scenario.toml"
        mutant = data.draw(mutated_tables(SCENARIO_DATA[data.draw(st.sampled_from(SCENARIOS))]))
        path.write_text(toml_dumps(mutant), encoding="utf-8")
        argv = ["run", str(path), "--out", str(folder / "runs")]
    code, err = _cli(argv)
    _clean(code, err, argv[0])


@pytest.mark.parametrize("trap", ["fifo.toml", "zero.toml", "directory.toml"])
def test_cli_refuses_files_that_are_not_regular_before_reading(folder, trap):
    for argv in (["robots", str(folder / trap)], ["run", str(folder / trap), "--out", str(folder / "runs")]):
        code, err = _cli(argv)
        _clean(code, err, argv[0])
        assert code == 2 and "not a regular file" in err
