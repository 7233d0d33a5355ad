"""The simulator: ``simulate(plant, controller, ...)`` and everything a run is made of.

* :mod:`~armlab.simulation.simulator` — ``simulate``, ``simulate_batch``, the checked settings;
* :mod:`~armlab.simulation.loop` — the compiled closed loop (RK4, the adaptive integrator's
  right-hand side, logging), calling the law, environment and plant by address;
* :mod:`~armlab.simulation.results` — ``SimulationResult``, time-major logs, NPZ/CSV/Parquet;
* :mod:`~armlab.simulation.environment` — free space, springs, walls (h_e of the plant);
* :mod:`~armlab.simulation.disturbances` — torque disturbances τ_d(t, q, q̇).
"""

from __future__ import annotations

import importlib

_HOMES = {"SimulationResult": "armlab.simulation.results", "STATUS": "armlab.simulation.simulator",
          "SimulationDiverged": "armlab.simulation.simulator",
          "SimulationInterrupted": "armlab.simulation.simulator", "MAX_STEPS": "armlab.simulation.simulator",
          "MAX_LOG_BYTES": "armlab.simulation.simulator",
          "ADAPTIVE_STEPS_PER_SECOND": "armlab.simulation.simulator",
          "ADAPTIVE_MIN_STEPS": "armlab.simulation.simulator",
          "SimulationError": "armlab.simulation.simulator", "simulate": "armlab.simulation.simulator",
          "simulate_batch": "armlab.simulation.simulator"}

__all__ = sorted(_HOMES)


def __getattr__(name: str):
    """The public names, imported on first use: reading a result file (``results``) needs
    neither numba nor the compiled loop (as ``armlab`` itself, see its ``__getattr__``)."""
    if name not in _HOMES:
        raise AttributeError(f"module 'armlab.simulation' has no attribute {name!r}")
    value = getattr(importlib.import_module(_HOMES[name]), name)
    globals()[name] = value
    return value
