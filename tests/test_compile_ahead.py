"""A second process compiles the loop's shared kernels on a cold machine
(armlab.simulation.compile_ahead): the first simulation loads them from numba's cache instead of
compiling them, gives the same result, and no process starts another when it need not."""

from __future__ import annotations

import fcntl
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import armlab
from armlab.simulation import compile_ahead, loop

# A short A7-like run: computed torque on the PRP, with a compile-event recorder (compiles
# only: numba loads from its disk cache without that event).
FIRST_RUN = """
import json, numpy as np
from numba.core import event
import armlab
from armlab.control.joint_space import JointInverseDynamics
from armlab.references.joint import ViaPoints
from armlab.simulation import compile_ahead
robot = armlab.load_robot("prp")
goal = np.array([0.2, 0.4, 0.1])
with event.install_recorder("numba:compile") as recorder:
    controller = JointInverseDynamics(robot, ViaPoints([0.0, 0.05], [np.zeros(3), goal]), 25.0, 10.0,
                                      dynamics="numeric")
    result = armlab.simulate(robot, controller, q0=np.zeros(3), t_final=0.05, dt=0.001, dynamics="numeric")
compiled = sorted({e.data["dispatcher"].py_func.__name__ for _, e in recorder.buffer if e.is_start})
print(json.dumps({"q": result.q[-1].tolist(), "compiled": compiled,
                  "marker": str(compile_ahead.marker_path())}))
"""


def _first_run(tmp_path, **env):
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
                   "ARMLAB_CACHE_DIR": str(tmp_path / "armlab"), **env}
    done = subprocess.run([sys.executable, "-c", FIRST_RUN], env=environment, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _same_run_here():
    from armlab.control.joint_space import JointInverseDynamics
    from armlab.references.joint import ViaPoints

    robot = armlab.load_robot("prp")
    controller = JointInverseDynamics(robot, ViaPoints([0.0, 0.05], [np.zeros(3), np.array([0.2, 0.4, 0.1])]),
                                      25.0, 10.0, dynamics="numeric")
    return armlab.simulate(robot, controller, q0=np.zeros(3), t_final=0.05, dt=0.001,
                           dynamics="numeric").q[-1]


@pytest.mark.slow
@pytest.mark.skipif(compile_ahead._usable_cpus() < 2, reason="a second process needs a second CPU")
def test_cold_machine_loads_the_loop_compiled_by_a_second_process(tmp_path):
    run = _first_run(tmp_path)
    # The run compiled its own kernels, not the shared ones: those came from the cache the
    # second process wrote, which then left its marker and released its lock.
    assert {"rnea_packed", "forward_dynamics_packed", "joint_inverse_dynamics_entry"} <= set(run["compiled"])
    assert "rk4_core" not in run["compiled"] and "kinetic_energy_packed" not in run["compiled"]
    marker = tmp_path / "armlab" / "compiled" / os.path.basename(run["marker"])
    assert marker.exists()
    with open(marker.with_suffix(".lock"), "w") as lock:   # released: the second process ended
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    # Kernels compiled in another process compute the same numbers, bit for bit.
    assert run["q"] == _same_run_here().tolist()


@pytest.mark.slow
def test_without_a_second_process_the_run_compiles_everything_itself(tmp_path):
    run = _first_run(tmp_path, ARMLAB_COMPILE_AHEAD="0")
    assert {"rk4_core", "kinetic_energy_packed", "rnea_packed"} <= set(run["compiled"])
    assert not (tmp_path / "armlab" / "compiled").exists()
    assert run["q"] == _same_run_here().tolist()


@pytest.fixture
def fresh(monkeypatch, tmp_path):
    """compile_ahead as in a new process, in an empty armlab cache, spawning nothing (a spawn
    fails the test)."""
    monkeypatch.setattr(compile_ahead, "_started", False)
    monkeypatch.setattr(compile_ahead, "_helper", None)
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("ARMLAB_COMPILE_AHEAD", raising=False)
    monkeypatch.setattr(compile_ahead, "_usable_cpus", lambda: 2)
    monkeypatch.setattr(compile_ahead, "in_numba_cache", lambda probe: False)
    spawned = []
    monkeypatch.setattr(compile_ahead.subprocess, "Popen", lambda *a, **k: spawned.append(a) or _Done())
    return spawned


class _Done:
    def wait(self, timeout=None):
        return 0


def test_a_second_process_is_spawned_once_per_process_and_holds_the_lock(fresh):
    assert compile_ahead.start(loop.rk4_core)
    program = ["armlab.precompile", "loop", str(compile_ahead.marker_path())]
    assert len(fresh) == 1 and fresh[0][0][-3:] == program
    assert not compile_ahead.start(loop.rk4_core)                 # once per process
    compile_ahead.wait()
    compile_ahead.wait()                             # nothing left to wait for
    assert len(fresh) == 1


@pytest.mark.parametrize("why", ["disabled", "one cpu", "marker", "in numba's cache", "locked"])
def test_no_second_process_when_it_is_not_needed(fresh, monkeypatch, why):
    holder = None
    if why == "disabled":
        monkeypatch.setenv("ARMLAB_COMPILE_AHEAD", "0")
    elif why == "one cpu":
        monkeypatch.setattr(compile_ahead, "_usable_cpus", lambda: 1)
    elif why == "marker":
        compile_ahead.marker_path().parent.mkdir(parents=True)
        compile_ahead.marker_path().touch()
    elif why == "in numba's cache":
        monkeypatch.setattr(compile_ahead, "in_numba_cache", lambda probe: True)
    else:                                            # another process is compiling them now
        compile_ahead.marker_path().parent.mkdir(parents=True)
        holder = open(compile_ahead.marker_path().with_suffix(".lock"), "w")   # noqa: SIM115
        fcntl.flock(holder, fcntl.LOCK_EX)
    try:
        assert not compile_ahead.start(loop.rk4_core)
    finally:
        if holder is not None:
            holder.close()
    assert fresh == []


def test_a_lock_file_nobody_holds_is_taken(fresh):
    # Left by a second process that died: its lock died with it, the file stays.
    lock = compile_ahead.marker_path().with_suffix(".lock")
    lock.parent.mkdir(parents=True)
    lock.touch()
    assert compile_ahead.start(loop.rk4_core) and len(fresh) == 1


def test_an_unwritable_cache_folder_spawns_nothing(fresh, monkeypatch, tmp_path):
    blocked = tmp_path / "blocked"
    blocked.write_text("a file where the cache folder would be")
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(blocked))
    assert not compile_ahead.start(loop.rk4_core)
    assert fresh == []


def test_the_marker_follows_numba_and_its_cache(monkeypatch):
    import numba

    here = compile_ahead.marker_path()
    monkeypatch.setattr(numba.config, "CACHE_DIR", "/elsewhere")
    assert compile_ahead.marker_path() != here


def test_the_second_process_program_refuses_other_arguments():
    done = subprocess.run([sys.executable, "-m", "armlab.precompile", "everything"], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 1 and done.stderr.strip() == "usage: python -m armlab.precompile loop <marker>"


def test_numba_s_index_is_looked_for_under_its_exact_name(monkeypatch, tmp_path):
    import numba

    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    function = loop.rk4_core.py_func
    version = f"py{sys.version_info[0]}{sys.version_info[1]}{getattr(sys, 'abiflags', '')}"
    folder = tmp_path / "simulation_0123abcd"
    folder.mkdir()
    stale = folder / f"loop.rk4_core-{function.__code__.co_firstlineno + 7}.{version}.nbi"
    stale.touch()                                    # the function has moved since: not it
    assert not compile_ahead.in_numba_cache(loop.rk4_core)
    (folder / f"loop.rk4_core-{function.__code__.co_firstlineno}.{version}.nbi").touch()
    assert compile_ahead.in_numba_cache(loop.rk4_core)
