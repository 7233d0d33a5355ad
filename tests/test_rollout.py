"""The batched rollout (``armlab.rollout``): every row equals the single-run path's row (a sweep's
``run_one``) to the last bit, on the bundled sweeps whose runs differ only in numbers; a bad value
makes its own run invalid with the single-run message; fields it cannot batch are named."""

from __future__ import annotations

import math
import sys
import warnings
from dataclasses import replace

import numpy as np
import pytest

import armlab
from armlab.errors import RolloutUnsupported, SweepFileError
from armlab.references.joint import Constant
from armlab.scenarios import ScenarioFileError, load_scenario, scenario_from_table
from armlab.sweep import bundled_sweep_names, load_sweep, run_one
from armlab.sweep.fields import _is_field, assign
from armlab.sweep.metrics import METRIC_NAMES
from armlab.sweep.rollout import SIGNALS, batch_problem, rollout, sweep_rows

FIRST_RUNS = 50
# Bundled sweeps the rollout refuses, by the field it names (none: the link-mass Monte Carlo
# sweeps reach their controllers through a computation, which the batch builds run by run).
NOT_BATCHED: dict[str, str] = {}


@pytest.fixture(autouse=True, scope="module")
def own_cache_folder(tmp_path_factory):
    """The comparisons here hold to the last bit only if every run of a test uses the same
    dynamics: with ``dynamics="auto"`` a run takes a robot's generated module if one is on
    disk.  In the suite another process may write the PRP's into the shared cache folder
    between a test's single runs and its batch (seen once: one row differed in its last digits).
    This file's runs therefore see a cache folder (and a temporary folder, where the private
    fallback folder lies) of their own, where modules appear only when its tests ask for them,
    and meet no module another test of this process made."""
    import tempfile

    from armlab.specialise import closed_form

    temporary = str(tmp_path_factory.mktemp("tmp"))
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("ARMLAB_CACHE_DIR", str(tmp_path_factory.mktemp("armlab_cache")))
        patch.setenv("TMPDIR", temporary)
        patch.setattr(tempfile, "tempdir", temporary)
        patch.setattr(closed_form, "_OUTCOMES", {})
        yield


def _batch(spec, runs):
    """The field columns of the sweep's first runs (its fixed fields and its axes)."""
    batch = {key: value for key, value in spec.fixed}
    rows = [spec.parameters(i) for i in runs]
    for key in rows[0]:
        if _is_field(key):
            batch[key] = np.array([row[key] for row in rows], dtype=float)
    return batch


def _same(a, b) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


@pytest.mark.parametrize("name", bundled_sweep_names())
def test_every_batched_row_is_the_single_run_row_to_the_last_bit(name):
    spec = load_sweep(name)
    runs = range(min(FIRST_RUNS, spec.n_runs))
    batch = _batch(spec, runs)
    if name in NOT_BATCHED:
        with pytest.raises(RolloutUnsupported) as raised:
            rollout(spec.scenario_file, batch, allow_outside=spec.allow_outside)
        assert NOT_BATCHED[name] in str(raised.value) and "computation" in str(raised.value)
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        single = [run_one(spec, i) for i in runs]
        batched = rollout(spec.scenario_file, batch, threads=2, allow_outside=spec.allow_outside)
    statuses = [row["status"] for row in single]
    assert batched["status"] == statuses
    assert batched["diagnosis"] == [row["diagnosis"] for row in single]
    for name_ in METRIC_NAMES:
        mine = batched[name_]
        for i, row in enumerate(single):
            assert _same(row[name_], float(mine[i])), (name, i, name_, row[name_], mine[i])
    assert "ok" in statuses      # the comparison saw measured runs


def test_a_bad_value_makes_only_its_own_run_invalid_with_the_single_run_message():
    spec = load_sweep("a11_stiffness")
    runs = range(6)
    batch = _batch(spec, runs)
    stiffness = batch["environment.stiffness[2]"]
    stiffness[3] = -5.0                                    # a spring of negative stiffness
    stiffness[4] = math.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = rollout(spec.scenario_file, batch, threads=1)
    assert out["status"][3] == out["status"][4] == "invalid"
    _, table = spec.table(3)
    assign(table, "environment.stiffness[2]", -5.0)
    with pytest.raises(ScenarioFileError) as single:
        scenario_from_table(table, spec.scenario_file)
    assert out["diagnosis"][3] == " ".join(str(single.value).split())
    assert "stiffness: must be positive semi-definite" in out["diagnosis"][3]
    assert "environment.stiffness[2]: nan is not a finite number" in out["diagnosis"][4]
    assert all(math.isnan(out[m][3]) for m in METRIC_NAMES)
    good = [0, 1, 2, 5]
    single = [run_one(spec, i) for i in good]
    assert [out["status"][i] for i in good] == [row["status"] for row in single] == ["ok"] * 4
    for i, row in zip(good, single, strict=True):
        assert all(_same(row[m], float(out[m][i])) for m in METRIC_NAMES)


def test_threads_change_nothing_and_results_are_kept_on_request():
    values = np.linspace(0.0, 1.5, 40)
    batch = {"controller.reference.value[1]": values, "simulation.t_final": 0.1}
    one = rollout("a6_pd_none", batch, threads=1)
    two = rollout("a6_pd_none", batch, threads=2, keep_results=True)
    for name in METRIC_NAMES:
        np.testing.assert_array_equal(one[name], two[name])
    result = two["results"][7]
    assert result.status == "ok" and result.signals["q_des"][-1, 1] == values[7]
    # The kept result is the run's own simulation (its scenario with that set point).
    scenario = load_scenario("a6_pd_none")
    reference = Constant([scenario.controller.reference.value[0], values[7],
                          scenario.controller.reference.value[2]])
    direct = armlab.simulate(scenario.plant, replace(scenario.controller, reference=reference),
                             **{**scenario.simulation, "t_final": 0.1})
    np.testing.assert_array_equal(direct.q, result.q)
    assert result.meta["controller"] == direct.meta["controller"]      # its own set point


def test_what_cannot_be_batched_is_named():
    with pytest.raises(RolloutUnsupported, match="simulation.t_final.*length"):
        rollout("a6_pd_none", {"simulation.t_final": [0.1, 0.2]})
    with pytest.raises(SweepFileError, match="has 3 values"):
        rollout("a6_pd_none", {"controller.kp": [1, 2], "controller.kd": [1, 2, 3]})


def test_link_masses_of_the_controllers_model_roll_out_as_their_single_runs(monkeypatch):
    """A controller's model mass reaches its parameters through a computation (the inertias
    about the joints, the RNEA's model): each run's controller is built from its file and its
    whole buffer written. A run whose model has a closed form on disk holds another compiled
    function, so it runs on its own, with the same row."""
    from armlab.specialise import closed_form_module

    # Run 2's model (the PRP's masses, as the scenario loader makes it) gets its closed form.
    closed_form_module(armlab.load_robot("prp").with_link_mass("link4", 0.2).with_link_mass("link2", 0.5))
    sweep_rollout = __import__("sys").modules["armlab.sweep.rollout"]
    alone = []
    run_alone = sweep_rollout._run_alone
    monkeypatch.setattr(sweep_rollout, "_run_alone",
                        lambda plan, i, keep: alone.append(i) or run_alone(plan, i, keep))
    link4 = np.array([0.15, 0.17, 0.2, 0.23, -0.1, 0.25])      # run 4: a negative mass
    link2 = np.array([0.45, 0.5, 0.5, 0.55, 0.5, 0.6])
    batch = {"controller.model_link_mass.link4": link4, "controller.model_link_mass.link2": link2,
             "controller.kd": np.full(6, 12.0), "simulation.t_final": 0.3}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = rollout("a7_id_via_points", batch, threads=2, keep_results=True)
    assert alone == [2]
    assert out["status"][4] == "invalid" and "model_link_mass.link4" in out["diagnosis"][4]
    table = armlab.scenarios.read_scenario_toml(armlab.scenarios.scenario_path("a7_id_via_points"))
    assign(table, "controller.model_link_mass.link4", -0.1)
    with pytest.raises(ScenarioFileError) as single:
        scenario_from_table(table, armlab.scenarios.scenario_path("a7_id_via_points"))
    assert out["diagnosis"][4] == " ".join(str(single.value).split())
    scenario = load_scenario("a7_id_via_points")
    for i in (0, 1, 2, 3, 5):
        model = scenario.plant.with_link_mass("link4", link4[i]).with_link_mass("link2", link2[i])
        direct = armlab.simulate(scenario.plant, replace(scenario.controller, model=model, kd=12.0),
                                 **{**scenario.simulation, "t_final": 0.3})
        assert out["status"][i] == "ok"
        np.testing.assert_array_equal(direct.q, out["results"][i].q)
        np.testing.assert_array_equal(direct.tau, out["results"][i].tau)


def test_masses_of_the_plant_roll_out_as_their_single_runs():
    """A plant mass reaches the plant's model through a computation: each run's plant is built
    from its file and its model written; the numeric kernels read it."""
    link4 = np.array([0.15, 0.18, 0.22, -1.0, 0.25])          # run 3: a negative mass
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = rollout("a7_id_via_points", {"plant_link_mass.link4": link4, "simulation.t_final": 0.3},
                      threads=2, keep_results=True)
    assert out["status"][3] == "invalid" and "plant_link_mass.link4" in out["diagnosis"][3]
    scenario = load_scenario("a7_id_via_points")
    for i in (0, 1, 2, 4):
        direct = armlab.simulate(scenario.plant.with_link_mass("link4", link4[i]), scenario.controller,
                                 **{**scenario.simulation, "t_final": 0.3})
        assert out["status"][i] == "ok"
        np.testing.assert_array_equal(direct.q, out["results"][i].q)
        np.testing.assert_array_equal(direct.tau, out["results"][i].tau)
    # The mass matters: the model mismatch it makes moves the trajectory.
    assert not np.array_equal(out["results"][0].q, out["results"][4].q)


def test_a_plant_mass_whose_first_plant_has_a_closed_form_is_named():
    from armlab.specialise import closed_form_module

    closed_form_module(armlab.load_robot("prp").with_link_mass("link4", 0.14))
    with pytest.raises(RolloutUnsupported, match="link4: the first run's plant runs a closed form"):
        rollout("a7_id_via_points", {"plant_link_mass.link4": [0.14, 0.2], "simulation.t_final": 0.05})


@pytest.mark.parametrize("name", bundled_sweep_names())
def test_a_sweep_chunk_runs_as_a_batch_with_the_rows_of_its_runs(name, monkeypatch):
    spec = load_sweep(name)
    runs = range(min(FIRST_RUNS, spec.n_runs))
    half = len(runs) // 2
    # Two chunks: the second shares the first's plan (or makes its own where a field took one
    # value in all of the first's runs).
    monkeypatch.setattr(sys.modules["armlab.sweep.rollout"], "_PLANS", {})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        first = sweep_rows(spec, runs[:half])
        batched = None if first is None else first + sweep_rows(spec, runs[half:])
        if name in NOT_BATCHED:
            assert batched is None
            assert NOT_BATCHED[name] in batch_problem(spec, runs)
            return
        single = [run_one(spec, i) for i in runs]
    assert batch_problem(spec, runs) == ""
    assert len(batched) == len(single)
    for mine, theirs in zip(batched, single, strict=True):
        assert mine.keys() == theirs.keys()
        for key, value in theirs.items():
            if key == SIGNALS:
                assert mine[key].keys() == value.keys()
                for column in value:
                    np.testing.assert_array_equal(mine[key][column], value[column])
            elif isinstance(value, float):
                assert _same(value, mine[key]), (name, theirs["run"], key)
            else:
                assert mine[key] == value, (name, theirs["run"], key)


def test_a_later_chunk_shares_the_first_chunks_plan_unless_a_field_was_not_located(tmp_path, monkeypatch):
    """Chunk 0 holds K_P = 20 alone, so where K_P lands is not found there: chunk 1 (K_P = 40)
    gets its own plan; chunk 2 shares chunk 1's. Every row is its run_one row."""
    from armlab.sweep import load_sweep_file

    sweep_rollout = sys.modules["armlab.sweep.rollout"]
    monkeypatch.setattr(sweep_rollout, "_PLANS", {})
    path = tmp_path / "gains.toml"
    path.write_text('scenario = "a6_pd_none"\nchunk_size = 2\n[set]\n"simulation.t_final" = 0.05\n'
                    '[zip]\n"controller.kp[0]" = { values = [20, 20, 40, 30, 50, 60] }\n'
                    '"controller.kd[0]" = { values = [5, 6, 7, 8, 9, 10] }\n')
    spec = load_sweep_file(path)
    plans = []
    for chunk in range(3):
        rows = sweep_rows(spec, spec.chunk_runs(chunk))
        plans.append(sweep_rollout._PLANS[spec.fingerprint()])
        for row in rows:
            single = run_one(spec, row["run"])
            assert row["status"] == single["status"] == "ok"
            assert all(_same(single[m], row[m]) for m in METRIC_NAMES), row["run"]
    assert plans[1] is not plans[0] and plans[2] is plans[1]


def test_the_checks_a_sweeps_chunks_share_stay_bounded(tmp_path, monkeypatch):
    """Drawn values are all distinct: the shared plan forgets its checks at CHECKED_VALUES, so a
    long sweep's driver does not grow with it, and a bad value is still refused after that."""
    from armlab.sweep import load_sweep_file

    sweep_rollout, plan_module = sys.modules["armlab.sweep.rollout"], sys.modules["armlab.sweep.plan"]
    monkeypatch.setattr(sweep_rollout, "_PLANS", {})
    monkeypatch.setattr(plan_module, "CHECKED_VALUES", 5)
    path = tmp_path / "drawn.toml"
    path.write_text('scenario = "a6_pd_none"\nchunk_size = 4\nruns = 24\nseed = 3\n[set]\n'
                    '"simulation.t_final" = 0.02\n[random]\n"controller.kp[0]" = { uniform = [-40, 200] }\n')
    spec = load_sweep_file(path)
    rows = [row for chunk in range(spec.n_chunks) for row in sweep_rows(spec, spec.chunk_runs(chunk))]
    plan = sweep_rollout._PLANS[spec.fingerprint()]
    assert 0 < len(plan._checked) <= 5
    invalid = [row for row in rows if row["status"] == "invalid"]
    assert invalid and all(row["controller.kp[0]"] < 0 for row in invalid)
    assert len(invalid) == sum(row["controller.kp[0]"] < 0 for row in rows)
    for row in rows[-4:]:
        single = run_one(spec, row["run"])
        assert (row["status"], row["diagnosis"]) == (single["status"], single["diagnosis"])
        assert all(_same(single[m], row[m]) for m in METRIC_NAMES), row["run"]


SMALL_SWEEPS = {
    "batched": """scenario = "a11_compliance"
[set]
"simulation.t_final" = 0.5
[grid]
"environment.stiffness[2]" = { values = [10, 100, 1000] }
""",
    "one by one": """scenario = "a7_id_mismatch"
[zip]
"simulation.t_final" = { values = [0.4, 0.5, 0.6] }
""",
}


@pytest.mark.parametrize("kind", SMALL_SWEEPS)
def test_armlab_sweep_says_in_one_line_how_its_runs_run(kind, tmp_path):
    import io

    path = tmp_path / f"{kind.replace(' ', '_')}.toml"
    path.write_text(SMALL_SWEEPS[kind])
    log = io.StringIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outcome = armlab.sweep(str(path), tmp_path / "out", threads=1, log=log)
    lines = [line for line in log.getvalue().splitlines() if "one batch" in line or "on its own" in line]
    assert len(lines) == 1, log.getvalue()
    if kind == "batched":
        assert "the runs of each chunk run as one batch" in lines[0]
    else:
        assert "each run set up on its own" in lines[0]
        assert "simulation.t_final" in lines[0] and "length" in lines[0]
    table = outcome.to_pandas()
    assert list(table["status"]) == ["ok"] * 3


def test_a_plant_and_a_controller_made_in_python_roll_out_as_their_single_runs():
    from armlab.control.joint_space import JointInverseDynamics
    from armlab.simulation import simulate
    from armlab.sweep.metrics import measure

    plant = armlab.load_robot("prp")
    model = plant.with_link_mass("link4", 0.16)             # the seed's A7 mismatch
    controller = JointInverseDynamics.from_poles(model, Constant([0.1, 1.0, 0.05]), 5.0)
    settings = {"q0": np.zeros(3), "t_final": 0.3, "dt": 1e-3}
    omega = np.array([3.0, 4.0, 5.0, 6.0])
    q0 = np.array([0.0, 0.1, 0.2, 0.3])
    kd = np.array([6.0, 8.0, -1.0, 12.0])                      # run 2: K_D not semi-definite
    table = rollout((plant, controller, settings), {"controller.kp[0][0]": omega ** 2,
                                                    "controller.kd[0][0]": kd, "simulation.q0[1]": q0},
                    keep_results=True)
    assert table["status"] == ["ok", "ok", "invalid", "ok"]
    assert "kd" in table["diagnosis"][2] and "\n" not in table["diagnosis"][2]
    for i in (0, 1, 3):
        kp, kd_i = controller.kp.copy(), controller.kd.copy()
        kp[0, 0], kd_i[0, 0] = omega[i] ** 2, kd[i]
        alone = simulate(plant, replace(controller, kp=kp, kd=kd_i),
                         **{**settings, "q0": np.array([0.0, q0[i], 0.0])})
        assert table["results"][i].q.tobytes() == alone.q.tobytes()
        for name, value in measure(alone).items():
            assert _same(float(table[name][i]), value), (i, name)


def test_a_wrong_path_of_the_python_objects_is_one_line():
    from armlab.control.joint_space import JointInverseDynamics

    plant = armlab.load_robot("prp")
    controller = JointInverseDynamics.from_poles(plant, Constant([0.1, 1.0, 0.05]), 5.0)
    for field, said in (("controller.gain", "no field 'gain'"), ("controller.kp[5]", "no such element"),
                        ("simulation.qd0[1]", "not among the settings"),
                        ("plant.mass", "controller.<field>")):
        with pytest.raises(SweepFileError, match=said) as raised:
            rollout((plant, controller, {"q0": np.zeros(3), "t_final": 0.1, "dt": 1e-3}),
                    {field: [1.0, 2.0]})
        assert "\n" not in str(raised.value) and field in str(raised.value)
    for settings, said in (({"q0": np.zeros(3), "t_final": 0.1}, "settings.dt"),
                           ({"q0": np.zeros(3), "t_final": 0.1, "dt": 1e-3, "step": 2}, "settings.step")):
        with pytest.raises(SweepFileError, match=said):
            rollout((plant, controller, settings), {"controller.kp[0][0]": [1.0, 2.0]})
