"""The two halves of ``armlab.precompile`` cover the kernels simulations share: after them, a
joint-space and a task-space simulation add compiled versions only of what belongs to their
controller (whether numba compiles them or loads them from its disk cache)."""

from __future__ import annotations

import json
import subprocess
import sys

# What a controller type brings: its own law entry (the law inlined) or its law and the
# trampoline that calls it, the loop's entry for its parameters, and kernels only that law calls.
CONTROLLER_OWN = {"joint_inverse_dynamics_entry", "joint_inverse_dynamics_law", "operational_pd_law",
                  "rk4_run", "law_trampoline", "log_pose_signals"}

# Run in a fresh process: one that ran other simulations before has their versions already.
PROGRAM = """
import json, sys
from numba.core.registry import CPUDispatcher
import armlab
from armlab import precompile
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
precompile.dynamics_kernels([prp])
precompile.loop_and_task_kernels(prp)
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
