"""The two halves of ``armlab.warmup`` cover the kernels simulations share: after them, a
joint-space and a task-space simulation add compiled versions only of what belongs to their
controller (whether numba compiles them or loads them from its disk cache)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

# What a controller type brings: its law's generated entry (the law inlined, armlab.control.entry)
# or its law and the trampoline that calls it, the loop's entry for its parameters, and kernels
# only that law calls.
CONTROLLER_OWN = {"entry", "joint_inverse_dynamics_law", "operational_pd_law",
                  "rk4_run", "law_trampoline", "log_pose_signals"}

# Run in a fresh process: one that ran other simulations before has their versions already.
PROGRAM = """
import json, sys
from numba.core.registry import CPUDispatcher
import armlab
from armlab import warmup
from armlab.scenarios import load_scenario

def versions():
    out = {}
    for module_name, module in list(sys.modules.items()):
        if module_name.startswith("armlab") and module is not None:
            for value in vars(module).values():
                if isinstance(value, CPUDispatcher):
                    out[(value.py_func.__module__, value.py_func.__name__)] = set(value.overloads)
    return out

prp = armlab.load_robot("prp")
warmup.dynamics_kernels([prp])
warmup.loop_and_task_kernels(prp)
scenarios = [load_scenario(name) for name in ("a7_id_via_points", "a09_pd_goal")]
before = versions()
status = [scenario.run(t_final=0.01).status for scenario in scenarios]
after = versions()
added = sorted({name for key, name in after if after[(key, name)] - before.get((key, name), set())})
print(json.dumps({"status": status, "added": added}))
"""


def test_after_both_halves_a_simulation_compiles_only_its_controller():
    done = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["status"] == ["ok", "ok"]
    added = set(report["added"])
    assert "rk4_run" in added  # the check sees what a run compiles
    assert added <= CONTROLLER_OWN, sorted(added - CONTROLLER_OWN)


# After `armlab warmup` in one process, another process's first A7-like run compiles none of
# the kernels every run shares (numba's compile events: a load from the disk cache has none).
FIRST_RUN = """
import json, numpy as np
from numba.core import event
import armlab
from armlab.control.joint_space import JointInverseDynamics
from armlab.references.joint import ViaPoints
robot = armlab.load_robot("prp")
with event.install_recorder("numba:compile") as recorder:
    controller = JointInverseDynamics(robot, ViaPoints([0.0, 0.05], [np.zeros(3), np.array([0.2, 0.4, 0.1])]),
                                      25.0, 10.0, dynamics="numeric")
    result = armlab.simulate(robot, controller, q0=np.zeros(3), t_final=0.05, dt=0.001, dynamics="numeric")
compiled = sorted({e.data["dispatcher"].py_func.__name__ for _, e in recorder.buffer if e.is_start})
print(json.dumps({"status": result.status, "compiled": compiled}))
"""

SHARED = {"rk4_core", "kinetic_energy_packed", "rnea_packed", "forward_dynamics_packed"}


def test_armlab_warmup_fills_the_cache_a_later_process_loads(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "ARMLAB_CACHE_DIR": str(tmp_path / "armlab")}
    done = subprocess.run([sys.executable, "-m", "armlab.cli", "warmup", "prp"], env=env,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stderr.strip().startswith("warmed up for prp (3 joints)")
    run = subprocess.run([sys.executable, "-c", FIRST_RUN], env=env, capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, run.stderr[-2000:]
    report = json.loads(run.stdout.strip().splitlines()[-1])
    assert report["status"] == "ok"
    assert not SHARED & set(report["compiled"]), report["compiled"]
    # Without the warmup the same run compiles them itself (the check sees compiles).
    cold = {**env, "NUMBA_CACHE_DIR": str(tmp_path / "cold")}
    run = subprocess.run([sys.executable, "-c", FIRST_RUN], env=cold, capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, run.stderr[-2000:]
    assert SHARED <= set(json.loads(run.stdout.strip().splitlines()[-1])["compiled"])


def test_armlab_warmup_of_an_unknown_robot_is_one_line():
    done = subprocess.run([sys.executable, "-m", "armlab.cli", "warmup", "no_such_robot"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1 and "no_such_robot" in done.stderr
