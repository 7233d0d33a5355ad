"""Sweeps: the sweep file, its runs, the metrics, the Parquet store and resumption.

The cluster executor is tested in ``test_sweep_cluster.py``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from armlab.cli import main
from armlab.errors import SweepFileError, SweepStoreError
from armlab.metrics import settling_time
from armlab.scenarios import load_scenario
from armlab.simulation import simulate
from armlab.sweep import bundled_sweep_names, load_sweep, load_sweep_file, read_results, run_one, sweep
from armlab.sweep.metrics import METRIC_NAMES, measure

pd = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")

SRC = Path(__file__).resolve().parents[1] / "src"

SMALL = """
title = "small"
scenario = "a7_id_high_gain"
seed = 3
{extra}
[set]
"simulation.t_final" = {t_final}
[grid]
omega_n = {{ values = [5, 10, 20] }}
"simulation.torque_limit" = {{ values = [20, 1e6] }}
[derived]
"controller.kp" = "omega_n**2"
"controller.kd" = "2*omega_n"
"""


def write(tmp_path, text, name="sweep.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def small(tmp_path, extra="", t_final=0.05, name="sweep.toml"):
    return load_sweep_file(write(tmp_path, SMALL.format(extra=extra, t_final=t_final), name))


def frame(folder):
    return read_results(folder).to_pandas()


# ---------------------------------------------------------------------------- the file

def test_grid_order_zip_and_derived_values(tmp_path):
    spec = load_sweep_file(write(tmp_path, """
scenario = "a7_id_high_gain"
[grid]
a = { values = [1, 2] }
b = { linspace = [0, 1, 3] }
[zip]
c = { values = [10, 20] }
d = { geomspace = [1, 100, 2] }
[derived]
"controller.kp" = "a*100 + b*10 + c"
"""))
    assert spec.n_runs == 2 * 3 * 2
    rows = [spec.parameters(i) for i in range(spec.n_runs)]
    # the grid's last axis varies fastest after the zip; the zip varies its axes together
    assert [(r["a"], r["b"], r["c"], r["d"]) for r in rows[:4]] == [
        (1.0, 0.0, 10.0, 1.0), (1.0, 0.0, 20.0, 100.0), (1.0, 0.5, 10.0, 1.0), (1.0, 0.5, 20.0, 100.0)]
    expected = {(a, b, c) for a in (1, 2) for b in (0, .5, 1) for c in (10, 20)}
    assert {(r["a"], r["b"], r["c"]) for r in rows} == expected
    assert all(r["controller.kp"] == r["a"] * 100 + r["b"] * 10 + r["c"] for r in rows)
    _, table = spec.table(5)
    assert table["controller"]["kp"] == rows[5]["controller.kp"]
    assert spec.scenario_table["controller"]["kp"] == 900.0  # the shared table is never written


def test_random_draws_depend_on_seed_and_run_only(tmp_path):
    text = """
scenario = "a7_id_high_gain"
seed = {seed}
runs = 400
[random]
u = {{ uniform = [-0.3, 0.3] }}
n = {{ normal = [1.0, 0.5] }}
l = {{ log_uniform = [1e2, 1e6] }}
"""
    spec = load_sweep_file(write(tmp_path, text.format(seed=7)))
    draws = np.array([[spec.parameters(i)[k] for k in "unl"] for i in range(spec.n_runs)])
    again = load_sweep_file(write(tmp_path, text.format(seed=7), "again.toml"))
    assert again.parameters(123) == spec.parameters(123)
    assert dataclasses.replace(spec, chunk_size=1).parameters(123) == spec.parameters(123)
    other = load_sweep_file(write(tmp_path, text.format(seed=8), "other.toml"))
    assert other.parameters(123)["u"] != spec.parameters(123)["u"]
    u, n, log_l = draws[:, 0], draws[:, 1], np.log10(draws[:, 2])
    assert -0.3 <= u.min() and u.max() < 0.3 and abs(u.mean()) < 0.03
    assert abs(n.mean() - 1.0) < 0.08 and abs(n.std() - 0.5) < 0.06
    assert 2 <= log_l.min() and log_l.max() <= 6 and abs(log_l.mean() - 4) < 0.2   # uniform in log


BAD = [
    ('scenario = "a7_id_high_gain"\nbogus = 1', "bogus", "unknown key"),
    ("[grid]\na = { values = [1] }", "scenario", "missing"),
    ('scenario = "no_such_scenario"', "scenario", "not a bundled scenario"),
    ('scenario = "a7_id_high_gain"\n[grid]\na = { range = [1, 2] }', "grid.a", "expected one of"),
    ('scenario = "a7_id_high_gain"\n[grid]\ncontroller.kp = { values = [1] }', "grid.controller",
     "write a field path in quotes"),
    ('scenario = "a7_id_high_gain"\n[grid]\n"controller.kpp" = { values = [1] }', "grid.controller.kpp",
     "no such field"),
    ('scenario = "a7_id_high_gain"\n[grid]\n"controller.kp[1]" = { values = [1] }', "grid.controller.kp[1]",
     "not an array"),
    ('scenario = "a7_id_high_gain"\n[grid]\n"simulation.q0[5]" = { values = [1] }', "grid.simulation.q0[5]",
     "3 elements"),
    ('scenario = "a7_id_high_gain"\n[grid]\n"controller.model_link_mass.link9" = { values = [1] }',
     "grid.controller.model_link_mass.link9", "no such field"),
    ('scenario = "a7_id_high_gain"\n[zip]\na = { values = [1, 2] }\nb = { values = [1] }', "zip",
     "one length"),
    ('scenario = "a7_id_high_gain"\n[random]\na = { uniform = [1, 0] }\n', "runs", "missing"),
    ('scenario = "a7_id_high_gain"\nruns = 3\n[random]\na = { uniform = [1, 0] }', "random.a.uniform",
     "a < b"),
    ('scenario = "a7_id_high_gain"\nruns = 3\n[random]\na = { log_uniform = [0, 1] }', "random.a.log_uniform",
     "0 < a"),
    ('scenario = "a7_id_high_gain"\nruns = 3', "runs", "[random]"),
    ('scenario = "a7_id_high_gain"\n[derived]\n"controller.kp" = "omega**2"', "derived.controller.kp",
     "unknown name"),
    ('scenario = "a7_id_high_gain"\n[grid]\na = { linspace = [0, 1, 0] }', "grid.a.linspace[2]", "integer"),
    ('scenario = "a7_id_high_gain"\nseed = -1', "seed", "integer"),
    ('scenario = "a7_id_high_gain"\n[grid]\na = { linspace = [0, 1, 10000000000] }', "grid.a.linspace[2]",
     "integer from 1 to 1000000"),
    ('scenario = "a7_id_high_gain"\n[grid]\n"a b" = { values = [1] }', "grid.a b", "field path"),
    ("scenario = [", "syntax", ""),
    ('scenario = "a7_id_high_gain"\n[cluster]\nnodes = 3', "cluster.nodes", "unknown key"),
    ('scenario = "a7_id_high_gain"\n[cluster]\nworkers = 0', "cluster.workers", "integer"),
]


@pytest.mark.parametrize(("text", "field", "reason"), BAD)
def test_bad_sweep_files_raise_one_line_naming_file_and_field(tmp_path, text, field, reason):
    path = write(tmp_path, text)
    with pytest.raises(SweepFileError) as caught:
        load_sweep_file(path)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"{path}: {field}: ") and reason in message


def test_cli_reports_a_bad_sweep_file_in_one_line(tmp_path, capsys):
    path = write(tmp_path, 'scenario = "a7_id_high_gain"\n[grid]\n"controller.kpp" = { values = [1] }')
    assert main(["sweep", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    error = capsys.readouterr().err.strip()
    assert error.count("\n") == 0 and "controller.kpp" in error and str(path) in error


@pytest.mark.parametrize("name", bundled_sweep_names())
def test_bundled_sweeps_load_and_their_plots_name_columns(name):
    from armlab.viz.sweeps import check_plots

    spec = load_sweep(name)
    assert spec.n_runs >= 10
    check_plots(spec)


# ---------------------------------------------------------------------------- the runs

def test_a_bad_value_is_an_invalid_row_not_a_failed_sweep(tmp_path):
    spec = load_sweep_file(write(tmp_path, """
scenario = "a7_id_high_gain"
[set]
"simulation.t_final" = 0.02
[grid]
"controller.kp" = { values = [-1, 100] }
"simulation.torque_limit" = { values = [-5, 20] }
"""))
    outcome = sweep(spec, tmp_path / "out", threads=1)
    table = outcome.to_pandas()
    assert list(table["status"]) == ["invalid", "invalid", "invalid", "ok"]
    assert outcome.counts == {"invalid": 3, "ok": 1}
    assert "controller: kp:" in table["diagnosis"][1] and "positive semi-definite" in table["diagnosis"][1]
    assert "simulation.torque_limit: must be positive" in table["diagnosis"][2]
    assert table["diagnosis"][0].count("\n") == 0 and table["diagnosis"][0]
    assert table[table["status"] == "invalid"][list(METRIC_NAMES)].isna().all().all()


def test_a_run_row_equals_the_same_run_built_in_python(tmp_path):
    """The controller's model mismatch, the plant's own mass, the reference element, and the
    gains reach the right objects: the row's metrics equal those of a run built directly."""
    spec = load_sweep_file(write(tmp_path, """
scenario = "a7_id_high_gain"
[set]
"simulation.t_final" = 0.3
"simulation.torque_limit" = 20.0
"controller.kd" = 12.0
[grid]
"controller.model_link_mass.link4" = { values = [0.15] }
"plant_link_mass.link4" = { values = [0.25] }
"controller.reference.value[1]" = { values = [0.4] }
"controller.kp" = { values = [36] }
"""))
    row = run_one(spec, 0)
    base = load_scenario("a7_id_high_gain")
    plant = base.plant.with_link_mass("link4", 0.25)
    reference = dataclasses.replace(base.controller.reference, value=np.array([0.15, 0.4, 0.1]))
    controller = dataclasses.replace(base.controller, model=base.plant.with_link_mass("link4", 0.15),
                                     kp=36.0, kd=12.0, reference=reference)
    result = simulate(plant, controller, q0=[0, 0, 0], t_final=0.3, dt=0.001, torque_limit=20.0)
    expected = measure(result)
    assert row["status"] == "ok"
    for name in METRIC_NAMES:
        assert row[name] == pytest.approx(expected[name], nan_ok=True, rel=1e-12, abs=1e-15), name
    # and the mismatch matters: without it the steady-state error differs
    matched = measure(simulate(plant, dataclasses.replace(controller, model=plant), q0=[0, 0, 0],
                               t_final=0.3, dt=0.001, torque_limit=20.0))
    assert abs(matched["steady_state_error"] - row["steady_state_error"]) > 1e-4


def test_diverged_runs_are_rows_with_their_diagnosis(tmp_path):
    spec = load_sweep_file(write(tmp_path, """
scenario = "a11_compliance"
[set]
"simulation.t_final" = 0.05
[grid]
"environment.stiffness[2]" = { values = [1e3, 1e8] }
"""))
    table = sweep(spec, tmp_path / "out", threads=1).to_pandas()
    assert list(table["status"]) == ["ok", "diverged"]
    assert table["diagnosis"][1].startswith("simulation diverged at t =")
    assert 0 < table["divergence_time"][1] < 0.05 and math.isnan(table["divergence_time"][0])
    assert math.isnan(table["steady_state_error"][1]) and table["peak_torque"][1] > 0


def test_table_is_identical_whatever_the_threads_processes_and_chunks(tmp_path):
    reference = frame(sweep(small(tmp_path, "chunk_size = 1"), tmp_path / "a", threads=1).folder)
    for executor, chunk in ((dict(threads=2), 1), (dict(threads=2), 4), (dict(threads=1), 6),
                            (dict(processes=2), 2)):
        name = f"{'-'.join(f'{k}{v}' for k, v in executor.items())}-{chunk}"
        spec = small(tmp_path, f"chunk_size = {chunk}", name=f"{name}.toml")
        other = frame(sweep(spec, tmp_path / name, **executor).folder)
        pd.testing.assert_frame_equal(other, reference, check_exact=True)
    assert list(reference["run"]) == list(range(6))


def test_unchosen_executor_batches_on_threads_large_sweeps_on_processes_short_runs_on_one_thread(
        monkeypatch, tmp_path):
    from armlab.sweep import runner

    spec = small(tmp_path, "chunk_size = 3")
    steps = runner.joint_steps(spec)
    from armlab.scenarios import load_scenario

    assert steps == 3 * round(0.05 / load_scenario("a7_id_high_gain").simulation["dt"])   # PRP, [set]
    monkeypatch.setattr(runner.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(runner, "PROCESS_RUNS", spec.n_runs)
    # Runs that run as batches: a thread per core, however many and however short.
    assert runner.batch_problem(spec, range(spec.n_runs)) == ""
    assert runner.default_executor(spec) == (2, None)
    # Runs set up one by one (as a link-mass sweep's are):
    monkeypatch.setattr(runner, "batch_problem", lambda spec, runs: "a field reaches the inputs computed")
    assert runner.default_executor(spec) == (2, 2)                       # processes
    monkeypatch.setattr(runner, "PROCESS_RUNS", spec.n_runs + 1)
    monkeypatch.setattr(runner, "THREAD_JOINT_STEPS", steps + 1)
    assert runner.default_executor(spec) == (1, None)                    # short runs: one thread
    monkeypatch.setattr(runner, "THREAD_JOINT_STEPS", steps)
    assert runner.default_executor(spec) == (2, None)                    # long runs: every core
    # What sweep() does with it.
    assert sweep(spec, tmp_path / "long").executor == "2 local threads"
    monkeypatch.setattr(runner, "THREAD_JOINT_STEPS", steps + 1)
    assert sweep(spec, tmp_path / "short").executor == "1 local thread"
    monkeypatch.setattr(runner.os, "cpu_count", lambda: 1)
    monkeypatch.setattr(runner, "PROCESS_RUNS", 1)
    assert runner.default_executor(spec) == (1, None)


# ---------------------------------------------------------------------------- the store

def test_resume_runs_only_missing_chunks_and_refuses_another_sweep(tmp_path):
    spec = small(tmp_path, "chunk_size = 2")
    out = tmp_path / "out"
    first = sweep(spec, out, threads=2)
    reference = frame(out)
    parts = sorted((out / "runs").glob("part-*.parquet"))
    assert len(parts) == 3 and first.counts == {"ok": 6}
    parts[1].unlink()
    (out / "runs" / ".part-000001.parquet.999.tmp").write_bytes(b"half a chunk")
    stamps = {p.name: p.stat().st_mtime_ns for p in (parts[0], parts[2])}
    again = sweep(spec, out, threads=2)
    assert again.counts == {"ok": 2, "resumed": 4}
    assert {p.name: p.stat().st_mtime_ns for p in (parts[0], parts[2])} == stamps
    assert not list((out / "runs").glob(".*.tmp"))
    pd.testing.assert_frame_equal(frame(out), reference, check_exact=True)
    finished = sweep(spec, out, workers=2)           # complete: no cluster is started
    assert finished.counts == {"resumed": 6} and finished.executor == "nothing left to run"
    edited = small(tmp_path, "chunk_size = 2", t_final=0.06, name="edited.toml")
    with pytest.raises(SweepStoreError, match="another sweep"):
        sweep(edited, out, threads=1)
    sweep(edited, out, threads=1, overwrite=True)
    assert not frame(out).equals(reference)


def chunks_written(out) -> int:
    """Chunks held by the files of ``out`` (a file holds the consecutive chunks of a task)."""
    from armlab.sweep.store import chunks_of

    return sum(len(chunks_of(path.name) or ()) for path in (out / "runs").glob("part-*.parquet"))


def test_a_file_holds_a_tasks_chunks_and_resume_reruns_only_missing_ones(tmp_path, monkeypatch):
    """Tasks of several chunks are written as one file named by its first and last chunk;
    a resumed sweep runs the chunks no file holds, in tasks that stop at a gap, and the table
    is the one-chunk-a-task table, bit for bit."""
    from armlab.sweep import runner
    from armlab.sweep.store import chunks_of, part_name

    assert part_name(range(5, 6)) == "part-000005.parquet"
    assert part_name(range(5, 10)) == "part-000005-000009.parquet"
    assert chunks_of("part-000005-000009.parquet") == range(5, 10)
    assert chunks_of("part-000005.parquet") == range(5, 6)
    assert chunks_of("part-000009-000005.parquet") is None and chunks_of("notes.txt") is None
    queue = [9, 8, 6, 5, 4, 1]                       # pending, the next last
    assert runner.next_task(queue, 2) == range(1, 2)  # a gap ends a task
    assert runner.next_task(queue, 2) == range(4, 6)
    assert runner.next_task(queue, 5) == range(6, 7)
    assert runner.next_task(queue, 5) == range(8, 10) and queue == []

    spec = small(tmp_path, "chunk_size = 1")
    with monkeypatch.context() as patch:
        patch.setattr(runner, "TASKS_PER_THREAD", spec.n_chunks)     # a chunk a task
        reference = frame(sweep(spec, tmp_path / "one", threads=1).folder)
    assert len(list((tmp_path / "one" / "runs").glob("part-*.parquet"))) == spec.n_chunks
    out = tmp_path / "out"
    sweep(spec, out, threads=1)
    files = sorted(path.name for path in (out / "runs").glob("part-*.parquet"))
    # One thread: two tasks of one chunk (no pace known yet), then half of the sweep's 6 chunks
    # a task (TASKS_PER_THREAD), the last the one chunk left.
    assert runner.TASKS_PER_THREAD == 2
    assert files == ["part-000000.parquet", "part-000001.parquet", "part-000002-000004.parquet",
                     "part-000005.parquet"], files
    (out / "runs" / "part-000002-000004.parquet").unlink()
    again = sweep(spec, out, threads=1)
    assert again.counts == {"ok": 3, "resumed": 3}
    assert chunks_written(out) == spec.n_chunks
    pd.testing.assert_frame_equal(frame(out), reference, check_exact=True)


def test_kill_9_of_the_driver_then_resume_runs_each_run_once(tmp_path):
    """A sweep process killed with SIGKILL mid-sweep leaves whole chunks; started again, it
    completes with every run exactly once and the table of an uninterrupted sweep."""
    path = write(tmp_path, SMALL.format(extra="chunk_size = 1", t_final=10.0)
                 .replace("values = [5, 10, 20]", "linspace = [5, 20, 8]"))
    spec = load_sweep_file(path)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    process = subprocess.Popen([sys.executable, "-m", "armlab.cli", "sweep", str(path), "--out", str(out),
                                "--threads", "1", "--quiet"], env=env, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 240
    while chunks_written(out) < 2 and time.monotonic() < deadline:
        assert process.poll() is None, "the sweep ended before it could be killed"
        time.sleep(0.02)
    process.send_signal(signal.SIGKILL)
    process.wait()
    done = chunks_written(out)
    assert 2 <= done < spec.n_chunks, "the kill did not land mid-sweep"
    resumed = sweep(spec, out, threads=2)
    assert resumed.counts["resumed"] == done
    table = frame(out)
    assert list(table["run"]) == list(range(spec.n_runs))
    reference = frame(sweep(spec, tmp_path / "reference", threads=1).folder)
    pd.testing.assert_frame_equal(table, reference, check_exact=True)


def test_cli_writes_table_and_plots(tmp_path, capsys):
    path = write(tmp_path, SMALL.format(extra="", t_final=0.05))
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--plot", "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "6 runs (6 ok)" in printed
    pngs = list((out / "plots").glob("*.png"))
    assert pngs and all(p.read_bytes()[:4] == b"\x89PNG" for p in pngs)
    assert len(frame(out)) == 6


# ---------------------------------------------------------------------------- the metrics

def fake_result(t, e, tau=None, limit=None, status="ok"):
    t = np.asarray(t, dtype=float)
    e = np.asarray(e, dtype=float).reshape(t.size, -1)
    tau = np.zeros((t.size, 1)) if tau is None else np.asarray(tau, dtype=float).reshape(t.size, -1)
    return SimulationResult_like(t=t, signals={"q_err": e}, tau=tau, n=tau.shape[1], z=np.zeros((t.size, 0)),
                                 meta={"torque_limit": limit}, status=status)


def SimulationResult_like(**fields):
    return SimpleNamespace(**fields)


def test_plot_of_a_sweep_whose_every_run_is_invalid_is_a_note_not_an_error(tmp_path, capsys):
    path = write(tmp_path, 'scenario = "a7_id_high_gain"\n[set]\n"simulation.t_final" = 0.01\n'
                           '"simulation.max_steps" = "x"\n')
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--plot", "--quiet"]) == 0
    captured = capsys.readouterr()
    assert "(1 invalid)" in captured.out and "internal error" not in captured.err
    last = captured.err.strip().splitlines()[-1]
    assert last == "armlab sweep: note: no plots: no run of sweep gave a metric"
    assert not list((out / "plots").glob("*.png"))


def test_settling_time_of_a_first_order_decay():
    # e = e^{-t/τ}: |e − e_∞| ≤ 2 % of its peak from t = τ ln 50 on (e_∞ ≈ 0 after 40 τ)
    tau_c, h = 0.2, 1e-4
    t = np.arange(0, 8.0 + h / 2, h)
    assert settling_time(t, np.exp(-t / tau_c)) == pytest.approx(tau_c * math.log(50), abs=2 * h)
    # a run that settles on a steady-state error settles too (relative to its final value)
    assert settling_time(t, 0.3 + np.exp(-t / tau_c)) == pytest.approx(tau_c * math.log(50), abs=2 * h)
    # a component constant up to round-off settles at once; one still moving at the end does not
    e = np.column_stack([np.exp(-t / tau_c), 1e-13 * np.sin(50 * t)])
    assert measure(fake_result(t, e))["settling_time"] == pytest.approx(tau_c * math.log(50), abs=2 * h)
    assert math.isnan(measure(fake_result(t, np.column_stack([np.exp(-t / tau_c), t])))["settling_time"])


def test_overshoot_of_an_underdamped_step_matches_the_textbook():
    zeta, wn, h = 0.3, 4.0, 1e-4
    wd, sigma = wn * math.sqrt(1 - zeta**2), zeta * wn
    t = np.arange(0, 10.0, h)
    e = 0.5 * np.exp(-sigma * t) * (np.cos(wd * t) + sigma / wd * np.sin(wd * t))  # step of 0.5
    values = measure(fake_result(t, e))
    assert values["overshoot"] == pytest.approx(100 * math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)),
                                                rel=1e-4)
    assert values["max_error"] == pytest.approx(0.5)
    assert values["rms_error"] == pytest.approx(math.sqrt(np.mean(e**2)))


def test_torque_metrics_count_time_at_the_limit():
    h = 0.01
    t = np.arange(0, 1.0, h)
    tau = np.column_stack([np.where(t < 0.25, 20.0, 1.0), np.where((t > 0.5) & (t < 0.6), -20.0, 0.0)])
    values = measure(fake_result(t, np.zeros(t.size), tau=tau, limit=20.0))
    assert values["peak_torque"] == 20.0
    assert values["saturation_time"] == pytest.approx(h * (25 + 9))
    assert measure(fake_result(t, np.zeros(t.size), tau=tau))["saturation_time"] == 0.0


def test_diverged_runs_keep_only_their_torque_and_divergence_time():
    t = np.arange(0, 0.5, 0.01)
    values = measure(fake_result(t, np.ones(t.size), tau=np.full(t.size, 3.0), status="diverged"))
    assert values["divergence_time"] == t[-1] and values["peak_torque"] == 3.0
    assert math.isnan(values["steady_state_error"]) and math.isnan(values["settling_time"])


def test_benchmark_executors_write_the_same_table():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import bench_sweep

    assert bench_sweep.check_agreement(runs=6, dask=False) == ["1 thread", "threads"]


def test_benchmark_mujoco_rollout_agrees_with_the_sweep_runs():
    pytest.importorskip("mujoco", reason="mujoco is not installed (the 'bench' extra)")
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import bench_sweep

    assert bench_sweep.check_mujoco(runs=2) < 1e-9


def test_report_page_of_a_sweep(tmp_path):
    from armlab.viz.sweeps import sweep_section

    spec = small(tmp_path)
    out = tmp_path / "out"
    sweep(spec, out, threads=1)
    assert not (out / "plots").exists()
    page = sweep_section(out, 3)
    pngs = list((out / "plots").glob("*.png"))          # drawn from the sweep file for the page
    assert pngs and page.count("<img") == len(pngs) and page.count("data:image/png;base64,") == len(pngs)
    assert 'id="sweep3"' in page and "Sweep — small" in page and "6 runs: 6 ok" in page
    assert "<td>peak_torque</td>" in page
    with pytest.raises(SweepStoreError, match="not an output folder"):
        sweep_section(tmp_path)


def test_report_command_takes_sweep_folders():
    from armlab.cli import build_parser

    args = build_parser().parse_args(["report", "--sweep", "a", "--sweep", "b"])
    assert args.sweep == ["a", "b"]


def test_decimated_signals_are_kept_per_chunk_and_equal_the_runs(tmp_path):
    from armlab.scenarios import scenario_from_table
    from armlab.sweep import read_signals

    spec = small(tmp_path, 'chunk_size = 4\n[signals]\nnames = ["q", "tau_cmd", "q_err"]\nevery = 7')
    out = tmp_path / "out"
    sweep(spec, out, threads=2)
    assert len(list((out / "signals").glob("part-*.parquet"))) == spec.n_chunks
    signals = read_signals(out).to_pandas()
    assert sorted(signals["run"].unique()) == list(range(spec.n_runs))
    for index in (0, 1, 5):
        result = scenario_from_table(spec.table(index)[1], spec.scenario_file).run()
        mine = signals[signals["run"] == index]
        np.testing.assert_array_equal(mine["t"], result.t[::7])
        np.testing.assert_array_equal(mine[["q.d1", "q.theta2", "q.d3"]].to_numpy(), result.q[::7])
        np.testing.assert_array_equal(mine["q_err.theta2"], result.signals["q_err"][::7, 1])
        if "tau_cmd" in result.signals:      # logged only with a finite torque limit
            np.testing.assert_array_equal(mine["tau_cmd.d1"], result.signals["tau_cmd"][::7, 0])
        else:
            assert mine["tau_cmd.d1"].isna().all()
    only = read_signals(out, runs=[2]).to_pandas()
    assert set(only["run"]) == {2}


def test_signals_table_is_checked(tmp_path):
    for text, field in (('[signals]\nnames = ["nope"]', "signals.names"),
                        ('[signals]\nnames = []', "signals.names"),
                        ('[signals]\nnames = ["q"]\nevery = 0', "signals.every"),
                        ('[signals]\nnames = ["q"]\nkeep = 1', "signals.keep")):
        path = write(tmp_path, f'scenario = "a7_id_high_gain"\n{text}')
        with pytest.raises(SweepFileError, match=f": {field}: "):
            load_sweep_file(path)
