"""The simulator: ``simulate(plant, controller, ...)`` and everything a run is made of.

* :mod:`~armlab.simulation.simulator` — ``simulate``, ``simulate_batch``, the checked settings;
* :mod:`~armlab.simulation.loop` — the compiled closed loop (RK4, the adaptive integrator's
  right-hand side, logging), calling the law, environment and plant by address;
* :mod:`~armlab.simulation.results` — ``SimulationResult``, time-major logs, NPZ/CSV/Parquet;
* :mod:`~armlab.simulation.environment` — free space, springs, walls (h_e of the plant);
* :mod:`~armlab.simulation.disturbances` — torque disturbances τ_d(t, q, q̇).
"""

from armlab.simulation.results import SimulationResult
from armlab.simulation.simulator import (
    STATUS,
    SimulationDiverged,
    SimulationError,
    simulate,
    simulate_batch,
)

__all__ = ["STATUS", "SimulationDiverged", "SimulationError", "SimulationResult", "simulate",
           "simulate_batch"]
