"""The two halves of ``armlab.precompile`` cover the kernels simulations share: after them, a
joint-space and a task-space simulation add compiled versions only of what belongs to their
controller (whether numba compiles them or loads them from its disk cache)."""

from __future__ import annotations

import sys

from numba.core.registry import CPUDispatcher

import armlab
from armlab import precompile
from armlab.scenarios import load_scenario

# What a controller type brings: its law, the law's entry and trampoline, and kernels only
# that law calls.
CONTROLLER_OWN = {"joint_inverse_dynamics_law", "operational_pd_law", "rk4_run", "law_trampoline",
                  "log_pose_signals"}


def _versions() -> dict:
    """(module, name) → the signatures compiled so far, for every kernel of armlab."""
    out = {}
    for module_name, module in list(sys.modules.items()):
        if module_name.startswith("armlab") and module is not None:
            for name, value in vars(module).items():
                if isinstance(value, CPUDispatcher):
                    out[(value.py_func.__module__, value.py_func.__name__)] = set(value.overloads)
    return out


def test_after_both_halves_a_simulation_compiles_only_its_controller():
    prp = armlab.load_robot("prp")
    precompile.dynamics_kernels([prp])
    precompile.loop_and_task_kernels(prp)
    scenarios = [load_scenario(name) for name in ("a7_id_via_points", "a09_pd_goal")]
    before = _versions()
    for scenario in scenarios:
        assert scenario.run(t_final=0.01).status == "ok"
    after = _versions()
    added = {name for key, name in after if after[(key, name)] - before.get((key, name), set())}
    assert "rk4_run" in added  # the check sees what a run compiles
    assert added <= CONTROLLER_OWN, sorted(added - CONTROLLER_OWN)
