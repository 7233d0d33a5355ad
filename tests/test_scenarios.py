"""Every bundled scenario runs (shortened); bad scenario files give one-line errors; a new
controller is declared in its own file only; CLI."""

import subprocess
import sys
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
import pytest

from armlab.cli import main
from armlab.control.joint_space import JointPDGravity
from armlab.registry import scenario_type, scenario_types
from armlab.scenarios import (
    ScenarioFileError,
    bundled_scenario_names,
    load_scenario,
    load_scenario_file,
    scenario_path,
)
from armlab.scenarios.tables import Condition
from armlab.simulation.results import SimulationResult

NAMES = bundled_scenario_names()
JOINT_SPACE = [n for n in NAMES if n[:3] in ("a6_", "a7_", "a8_")]
INTERACTION = [n for n in NAMES if scenario_path(n).parent.name == "interaction"]   # A9–A15


def test_every_seed_experiment_has_a_scenario():
    # The seed's seven, option 3 with the gain condition of its proof met and from a far start,
    # and one with joint stops.
    assert len([n for n in NAMES if n.startswith("a6_")]) == 10
    assert {"a7_id_via_points", "a7_id_mismatch", "a7_id_mismatch_whole_model",
            "a7_id_high_gain_saturated"} <= set(NAMES)
    assert {"a8_case1_sine", "a8_case2_square", "a8_case1_wrong_plant1",
            "a8_case1_wrong_plant2"} <= set(NAMES)
    mismatch = load_scenario("a7_id_mismatch")
    assert mismatch.controller.bias_model.links[2].inertial.mass == 0.16   # the seed's Ĉ, ĝ
    assert mismatch.controller.model.links[2].inertial.mass == 0.2         # and exact B̂
    assert mismatch.plant.links[2].inertial.mass == 0.2
    assert load_scenario("a8_case1_sine").simulation["t_final"] == 50.0
    truth = load_scenario("a8_case1_sine").run(t_final=0.1).meta["true_parameters"]
    np.testing.assert_allclose(truth, [0.1, 0.05, -0.981], atol=1e-12)


@pytest.mark.parametrize("name", JOINT_SPACE)
def test_scenario_runs_shortened(name):
    result = load_scenario(name).run(t_final=0.2)
    assert result.status == "ok"
    assert len(result.t) == 201 and np.all(np.isfinite(result.q))
    assert result.meta["scenario"] == name


def test_same_scenario_twice_is_bit_identical():
    first = load_scenario("a7_id_mismatch").run(t_final=1.0)
    second = load_scenario("a7_id_mismatch").run(t_final=1.0)
    for name, array in first.groups().items():
        assert array.tobytes() == second.groups()[name].tobytes(), name


GOOD = """
plant = "prp"
[simulation]
t_final = 1.0
dt = 0.001
q0 = [0, 0, 0]
[controller]
type = "joint_pd_gravity"
kp = 1.0
kd = 1.0
[controller.reference]
type = "constant"
value = [0, "pi/3", 0]
"""


@pytest.mark.parametrize("change, field", [
    (("t_final = 1.0\n", ""), "simulation.t_final"),
    (('type = "joint_pd_gravity"', 'type = "fuzzy"'), "controller.type"),
    (("kp = 1.0", "kp = [1, 2]"), "controller"),
    (("kd = 1.0", "kd = 1.0\nki = 2.0"), "controller.ki"),
    (('"pi/3"', '"pi/"'), "controller.reference.value[1]"),
    (('plant = "prp"', 'plant = "nonesuch"'), "plant"),
    (("[simulation]", "[simulation]\nspeed = 2"), "simulation.speed"),
    (("dt = 0.001", "dt = 0.001\nwhat"), "syntax"),
])
def test_bad_scenario_file_names_file_and_field(tmp_path, change, field):
    path = tmp_path / "bad.toml"
    path.write_text(GOOD.replace(*change))
    with pytest.raises(ScenarioFileError) as caught:
        load_scenario_file(path)
    message = str(caught.value)
    assert message.startswith(f"{path}: {field}") and "\n" not in message


def test_cli_lists_and_runs_scenarios(tmp_path, capsys):
    assert main(["scenarios"]) == 0
    listing = capsys.readouterr().out
    assert all(name in listing for name in NAMES)
    assert main(["run", "a7_id_regulation", "--out", str(tmp_path), "--t-final", "0.1",
                 "--format", "npz,csv,parquet"]) == 0
    for suffix in ("npz", "csv", "parquet"):
        result = SimulationResult.load(tmp_path / f"a7_id_regulation.{suffix}")
        assert result.meta["scenario"] == "a7_id_regulation" and len(result.t) == 101
    bad = tmp_path / "bad.toml"
    bad.write_text(GOOD.replace("q0 = [0, 0, 0]", "q0 = [0, 0]"))
    assert main(["run", str(bad), "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err
    assert "q0" in error and "Traceback" not in error


def test_the_plant_dynamics_is_a_simulation_setting(tmp_path, capsys):
    path = tmp_path / "numeric.toml"
    path.write_text(GOOD.replace("dt = 0.001", 'dt = 0.001\ndynamics = "numeric"'))
    assert load_scenario_file(path).run(t_final=0.01).meta["dynamics"] == "numeric"
    bad = tmp_path / "fast.toml"
    bad.write_text(GOOD.replace("dt = 0.001", 'dt = 0.001\ndynamics = "fast"'))
    assert main(["run", str(bad), "--out", str(tmp_path), "--t-final", "0.01"]) == 2
    error = capsys.readouterr().err.strip()
    assert error.endswith("fast.toml: simulation.dynamics: 'fast' is not one of auto, closed_form, numeric")
    assert "\n" not in error


# ------------------------------------------------------------------ bundled A9–A15 scenarios


def test_every_assignment_from_a9_to_a15_has_scenarios():
    names = INTERACTION
    for prefix in ("a09_", "a10_", "a11_", "a12_", "a13_", "a14_", "a15_"):
        assert any(name.startswith(prefix) for name in names), prefix


@pytest.mark.parametrize("name", INTERACTION)
def test_bundled_interaction_scenario_runs_shortened(name):
    scenario = load_scenario(name)
    assert scenario.assignment.startswith("A") and scenario.description
    result = scenario.run(t_final=0.2)
    assert result.status == "ok" and result.t[-1] == pytest.approx(0.2)
    assert np.all(np.isfinite(result.q)) and np.all(np.isfinite(result.tau))
    assert result.meta["scenario"] == name


def test_scenario_file_errors_name_the_field(tmp_path):
    source = load_scenario("a11_compliance").source
    text = open(source, encoding="utf-8").read()
    for old, new, field in (('type = "spring"', 'type = "sponge"', "environment.type"),
                            ("kp = [20, 10, 20, 50, 50, 50]", "kp = [20, 10]", "controller"),
                            ("stiffness = [0, 0, 1e4, 10, 0, 0]", "stiffness = [0, 0, -1e4, 10, 0, 0]",
                             "environment")):
        path = tmp_path / "bad.toml"
        path.write_text(text.replace(old, new), encoding="utf-8")
        with pytest.raises(ScenarioFileError, match=f"bad.toml: {field}"):
            load_scenario_file(path)


# ------------------------------------------------------------------ fields read by their annotations


@scenario_type("test_labelled_pd")
@dataclass(frozen=True, eq=False)
class LabelledPD(JointPDGravity):
    """A controller new to armlab with a string option, declared here and nowhere else."""

    tuning: Literal["seed", "retuned"] = "seed"


def test_a_new_controller_with_a_string_option_is_declared_in_its_own_file(tmp_path):
    path = tmp_path / "labelled.toml"
    path.write_text(GOOD.replace('type = "joint_pd_gravity"',
                                 'type = "test_labelled_pd"\ntuning = "retuned"'))
    scenario = load_scenario_file(path)
    assert type(scenario.controller) is LabelledPD and scenario.controller.tuning == "retuned"
    result = scenario.run(t_final=0.01)
    assert result.status == "ok" and result.meta["controller"]["tuning"] == "retuned"
    bad = tmp_path / "clamp.toml"
    bad.write_text(path.read_text().replace('"retuned"', '"clamp"'))
    with pytest.raises(ScenarioFileError) as caught:
        load_scenario_file(bad)
    assert str(caught.value) == f"{bad}: controller.tuning: 'clamp' is not one of seed, retuned"


@scenario_type("test_bounded_pd")
@dataclass(frozen=True, eq=False)
class BoundedPD(JointPDGravity):
    """A controller whose new field carries a condition in its annotation."""

    softness: Annotated[float, Condition("in [0, 1]", lambda value: 0 <= value <= 1)] = 0.5


def test_a_condition_in_a_fields_annotation_is_checked_where_the_file_is_read(tmp_path):
    path = tmp_path / "bounded.toml"
    path.write_text(GOOD.replace('type = "joint_pd_gravity"', 'type = "test_bounded_pd"\nsoftness = "1/4"'))
    assert load_scenario_file(path).controller.softness == 0.25
    bad = tmp_path / "too_soft.toml"
    bad.write_text(path.read_text().replace('"1/4"', "2"))
    with pytest.raises(ScenarioFileError) as caught:
        load_scenario_file(bad)
    assert str(caught.value) == f"{bad}: controller.softness: must be in [0, 1], got 2"


@pytest.mark.parametrize("change, message", [
    (("kd = 1.0", 'kd = 1.0\ncompensation = "x"'),
     "controller.compensation: 'x' is not one of online, desired, none"),
    (("kd = 1.0", "kd = 1.0\ncompensation = 2"),
     "controller.compensation: 2 is not one of online, desired, none"),
    (('type = "joint_pd_gravity"', 'type = "joint_inverse_dynamics"\ndynamics = "fast"'),
     "controller.dynamics: 'fast' is not one of auto, closed_form, numeric"),
    (('[controller.reference]\ntype = "constant"\nvalue = [0, "pi/3", 0]', "reference = 3"),
     "controller.reference: expected a table"),
    (('type = "constant"\nvalue = [0, "pi/3", 0]', 'type = "ramp"\nstart = [0, 0, 0]\nslope = [0, 1, 0]'),
     "controller.reference.end: missing"),
    (("t_final = 1.0", "t_final = 1.0\nlog_every = 2.5"), "simulation.log_every: expected an integer"),
    (("[simulation]", '[[disturbance]]\ntype = "quadratic_friction"\ncoefficient = 1\nform = "wet"\n'
                      "[simulation]"), "disturbance[0].form: 'wet' is not one of drag, seed"),
])
def test_each_field_is_read_as_its_annotation_says(tmp_path, change, message):
    path = tmp_path / "bad.toml"
    path.write_text(GOOD.replace(*change))
    with pytest.raises(ScenarioFileError) as caught:
        load_scenario_file(path)
    assert str(caught.value).startswith(f"{path}: {message}") and "\n" not in str(caught.value)


def test_string_options_of_every_kind_of_table_load(tmp_path):
    text = GOOD.replace('type = "joint_pd_gravity"', 'type = "joint_inverse_dynamics"\ndynamics = "numeric"')
    text = text.replace("[simulation]", '[[disturbance]]\ntype = "quadratic_friction"\ncoefficient = 0.1\n'
                                         'form = "seed"\n[simulation]')
    path = tmp_path / "options.toml"
    path.write_text(text)
    scenario = load_scenario_file(path)
    assert scenario.controller.dynamics == "numeric" and scenario.disturbance[0].form == "seed"
    source = load_scenario("a14_force_inner_velocity").source
    force = load_scenario_file(source)
    assert force.controller.inner == "velocity" and force.controller.force.duration == 0.5
    poses = load_scenario("a11_compliance")
    np.testing.assert_allclose(poses.environment.rest_position, [0, -0.2, 0.5])
    np.testing.assert_allclose(poses.environment.rest_rotation @ [1, 0, 0], [0, 0, 1], atol=1e-15)


def test_names_are_looked_up_among_the_subclasses_of_the_base_a_table_asks_for():
    from armlab.references.joint import Constant, JointReference
    from armlab.simulation.disturbances import ConstantTorque, TorqueDisturbance

    assert scenario_types(JointReference)["constant"].cls is Constant
    assert scenario_types(TorqueDisturbance)["constant"].cls is ConstantTorque

    @dataclass(frozen=True)
    class Base:
        pass

    for name in ("First", "Second"):
        scenario_type("same")(dataclass(frozen=True)(type(name, (Base,), {})))
    with pytest.raises(TypeError, match="two Base classes are registered as 'same'"):
        scenario_types(Base)
    with pytest.raises(TypeError, match="above @dataclass"):
        scenario_type("plain")(type("Plain", (), {}))


def test_the_scenario_loader_imports_no_edge_module():
    code = ("import sys, armlab.scenarios as s; s.load_scenario('a11_compliance'); "
            "edges = ('armlab.viz', 'armlab.commands', 'armlab.cli'); "
            "print([m for m in sys.modules if m.startswith(edges)]); "
            "import armlab.viz.experiments; print('armlab.viz.report' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split("\n")[:2] == ["[]", "False"]
