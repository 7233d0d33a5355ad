"""Every bundled scenario runs (shortened); bad scenario files give one-line errors; CLI."""

import numpy as np
import pytest

from armlab.cli import main
from armlab.results import SimulationResult
from armlab.scenarios import ScenarioFileError, bundled_scenario_names, load_scenario, load_scenario_file

NAMES = bundled_scenario_names()
JOINT_SPACE = [n for n in NAMES if n[:3] in ("a6_", "a7_", "a8_")]


def test_every_seed_experiment_has_a_scenario():
    assert len([n for n in NAMES if n.startswith("a6_")]) == 7
    assert {"a7_id_via_points", "a7_id_mismatch", "a7_id_high_gain_saturated"} <= set(NAMES)
    assert {"a8_case1_sine", "a8_case2_square", "a8_case1_wrong_plant1",
            "a8_case1_wrong_plant2"} <= set(NAMES)
    mismatch = load_scenario("a7_id_mismatch")
    assert mismatch.controller.model.links[2].inertial.mass == 0.16
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
    (("dt = 0.001", "dt = 0.001\nwhat"), "toml"),
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
