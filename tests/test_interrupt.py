"""Ctrl-C, step budgets and run sizes: an interrupted run keeps exactly the data computed so
far (status "interrupted", CLI exit 130), the adaptive integrator stops at its step budget
with its data, and runs that could not finish or whose log would not fit are refused before
they start."""

from __future__ import annotations

import _thread
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import armlab
from armlab.control.joint_space import JointPDGravity
from armlab.errors import SimulationInterrupted
from armlab.references.joint import Sinusoid
from armlab.scenarios import scenario_path
from armlab.simulation import SimulationDiverged, SimulationError, simulate
from armlab.simulation.results import SimulationResult

PRP = armlab.load_robot("prp")
SRC = Path(__file__).resolve().parents[1] / "src"


@pytest.fixture(autouse=True)
def ctrl_c_raises():
    """Ctrl-C raises KeyboardInterrupt during each test, as in a terminal, also when the suite
    was started with SIGINT ignored (a background job of a non-interactive shell: Python then
    leaves it ignored, and ``_thread.interrupt_main`` does nothing); the commands these tests
    start then get the default too (exec resets a handled signal)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def controller(kp=(25.0, 0.5, 10.0)):
    reference = Sinusoid(center=[0.1, 0.5, 0.05], amplitude=[0.05, 0.3, 0.02], omega=[1.0, 2.0, 3.0])
    return JointPDGravity(PRP, reference, list(kp), [10.0, 0.08, 3.0], "online")


def _interrupted(run):
    """The SimulationInterrupted of ``run()`` (tens of seconds long, and bounded: it must end by
    itself) interrupted as by Ctrl-C.  Tried again later when the KeyboardInterrupt lands before
    the loop starts (a busy machine), or is lost (Python prints and drops one raised inside a
    finalizer that the garbage collector runs meanwhile): the run then ends by itself."""
    for delay in (1.0, 3.0, 8.0):
        timer = threading.Timer(delay, _thread.interrupt_main)    # what SIGINT does
        timer.start()
        try:
            run()
        except SimulationInterrupted as error:
            return error
        except KeyboardInterrupt:
            continue
        finally:
            timer.cancel()
    pytest.fail("no interruption reached the running loop")


def _same_prefix(partial, full, rtol=0.0):
    rows = len(partial.t)
    assert 0 < rows < len(full.t)
    np.testing.assert_array_equal(partial.t, full.t[:rows])
    for name, array in partial.groups().items():
        np.testing.assert_allclose(array, full.groups()[name][:rows], rtol=rtol, atol=rtol, err_msg=name)


def test_ctrl_c_stops_the_compiled_loop_and_keeps_exactly_the_data_so_far():
    kwargs = dict(q0=[0.1, 0.5, 0.05], dt=1e-3, log_every=100)
    simulate(PRP, controller(), t_final=0.1, **kwargs)            # compiled and cached first
    caught = _interrupted(lambda: simulate(PRP, controller(), t_final=20_000.0, **kwargs))   # ~25 s
    result = caught.result
    assert isinstance(caught, KeyboardInterrupt)
    assert result.status == "interrupted" and "interrupted at t =" in result.diagnosis
    # The same run, uninterrupted, up to a little after the interruption: the same numbers.
    full = simulate(PRP, controller(), t_final=round(result.t[-1] + 1.0, 1), **kwargs)
    _same_prefix(result, full)


def test_ctrl_c_stops_the_adaptive_integrator_with_its_points_so_far():
    kwargs = dict(q0=[0.1, 0.5, 0.05], dt=1e-2, method="adaptive")
    simulate(PRP, controller(), t_final=0.05, **kwargs)
    # 10⁵ solver steps (~20 s) if no interruption arrives: then the run ends by itself.
    caught = _interrupted(lambda: simulate(PRP, controller(), t_final=20_000.0, **kwargs, max_steps=10**5,
                                           on_divergence="return"))
    result = caught.result
    assert result.status == "interrupted"
    full = simulate(PRP, controller(), t_final=round(result.t[-1] + 0.5, 2), **kwargs)
    # Another t_final changes the solver's first and last steps (SciPy clips them to the
    # span): equal to the integration tolerance, not to the bit.
    _same_prefix(result, full, rtol=1e-8)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")    # SciPy's rejected trial steps overflow
def test_the_adaptive_step_budget_stops_a_stiff_run_with_its_data():
    # kp = 1e12: the closed loop's poles at ~1e6 rad/s force steps of ~20 ns (about 10⁷ per
    # simulated second: hours of wall time without a budget).
    stiff = controller(kp=(1e12, 1e12, 1e12))
    settings = dict(q0=[0.1, 0.5, 0.05], t_final=1e-3, dt=1e-6, method="adaptive", max_steps=3000)
    with pytest.raises(SimulationDiverged) as caught:
        simulate(PRP, stiff, **settings)
    result = caught.value.result
    assert result.status == "stopped" and "step budget exhausted (3000 solver steps" in result.diagnosis
    assert result.meta["solver_steps"] == 3000 and 0 < result.t[-1] < 1e-3
    assert np.isfinite(result.q).all()
    returned = simulate(PRP, stiff, **settings, on_divergence="return")
    np.testing.assert_array_equal(returned.q, result.q)
    # A run within its budget is the same run: the budget only stops, it never changes steps.
    budgeted = simulate(PRP, controller(), q0=[0.1, 0.5, 0.05], t_final=2.0, dt=1e-2, method="adaptive",
                        max_steps=40, on_divergence="return")
    full = simulate(PRP, controller(), q0=[0.1, 0.5, 0.05], t_final=2.0, dt=1e-2, method="adaptive")
    assert budgeted.status == "stopped"
    _same_prefix(budgeted, full)
    with pytest.raises(SimulationError, match="max_steps: must be a positive integer"):
        simulate(PRP, controller(), q0=[0, 0, 0], t_final=1.0, dt=1e-2, method="adaptive", max_steps=0)


def test_runs_that_cannot_finish_or_whose_log_would_not_fit_are_refused_before_they_start():
    with pytest.raises(SimulationError, match=r"t_final: 1 s at dt = 1e-300 s is 1e\+300 steps"):
        simulate(PRP, controller(), q0=[0, 0, 0], t_final=1.0, dt=1e-300)
    with pytest.raises(SimulationError, match=r"t_final: 1e\+09 s at dt = 0.001 s is 1e\+12 steps"):
        simulate(PRP, controller(), q0=[0, 0, 0], t_final=1e9, dt=1e-3)
    # 5·10⁸ steps are allowed, but not a log of every one of them (~100 GB).
    with pytest.raises(SimulationError, match=r"log_every: the log of 500000001 rows × \d+ columns would "
                                              r"need \d+ GiB, more than 4 GiB"):
        simulate(PRP, controller(), q0=[0, 0, 0], t_final=5e5, dt=1e-3)
    with pytest.raises(SimulationError, match="log_every: the log of 500000001 rows"):
        simulate(PRP, controller(), q0=[0, 0, 0], t_final=5e5, dt=1e-3, log_every=10**6, method="adaptive")


def test_sigint_to_armlab_run_saves_the_data_marked_interrupted_and_exits_130(tmp_path):
    text = scenario_path("a7_id_mismatch").read_text(encoding="utf-8")
    text = text.replace("t_final = 10.0", "t_final = 20000.0\nlog_every = 100")
    assert "log_every = 100" in text
    scenario = tmp_path / "long_a7.toml"
    scenario.write_text(text, encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    out = tmp_path / "out"
    command = [sys.executable, "-m", "armlab.cli", "run", str(scenario), "--out", str(out),
               "--format", "npz,csv"]
    warm = subprocess.run(command + ["--t-final", "0.1"], env=env, capture_output=True, text=True,
                          timeout=600)
    assert warm.returncode == 0, warm.stderr
    # SIGINT once the run is in its loop: the set-up (loading the compiled kernels) may take
    # seconds on a busy machine, and a Ctrl-C there stops the command before any data exists
    # (exit 130 too, nothing written); later delays until one lands in the loop.
    for delay in (2.0, 5.0, 10.0):
        process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                   text=True)
        assert process.stderr.readline().startswith("running long_a7")
        time.sleep(delay)
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=120)
        # 130, or killed by SIGINT (what a shell also reports as 130): CPython exits through
        # SIGINT when a Ctrl-C interrupted an import run by C code, even once it was handled.
        assert process.returncode in (130, -signal.SIGINT), stderr
        assert "Traceback" not in stderr
        last = stderr.strip().splitlines()[-1]
        if last == "armlab run: interrupted":
            assert SimulationResult.load(out / "long_a7.npz").status == "ok"   # the warm run's
            continue
        break
    assert last.startswith("armlab run: simulation interrupted at t ="), stderr
    loaded = [SimulationResult.load(out / f"long_a7.{fmt}") for fmt in ("npz", "csv")]
    for result in loaded:
        assert result.status == "interrupted" and 0 < result.t[-1] < 20000.0
    np.testing.assert_array_equal(loaded[0].q, loaded[1].q)
    assert "wrote" in stdout
