"""Small ``SimulationResult`` objects made from seeded random numbers, without a simulation
(tests of result files need data, not physics, and subprocesses that start in a second)."""

from __future__ import annotations

import numpy as np

from armlab.simulation.results import SimulationResult


def synthetic_result(seed: int, rows: int = 200, status: str = "ok") -> SimulationResult:
    """A 3-joint result with a 2-column controller state and a 3-column signal; every number
    depends on ``seed`` (so two seeds give results that differ everywhere)."""
    rng = np.random.default_rng(seed)
    t = np.arange(rows) * 1e-3
    joints = ("d1", "theta2", "d3")
    arrays = {name: rng.normal(size=(rows, 3)) for name in ("q", "qd", "qdd", "tau")}
    z = rng.normal(size=(rows, 2))
    err = rng.normal(size=(rows, 3))
    labels = {**{name: joints for name in arrays}, "z": ("z0", "z1"), "q_err": joints}
    units = {**{name: ("m", "rad", "m") for name in arrays}, "z": ("", ""), "q_err": ("m", "rad", "m")}
    return SimulationResult(t=t, **arrays, z=z, signals={"q_err": err}, labels=labels, units=units,
                            meta={"scenario": f"synthetic{seed}", "seed": seed, "dt": 1e-3},
                            status=status, diagnosis="" if status == "ok" else f"{status} at t = 0.1 s")


def assert_same(a: SimulationResult, b: SimulationResult) -> None:
    """Equal data (bit for bit), labels, units, metadata and status."""
    assert a.groups().keys() == b.groups().keys()
    np.testing.assert_array_equal(a.t, b.t)
    for name, array in a.groups().items():
        np.testing.assert_array_equal(array, b.groups()[name], err_msg=name)
    assert (a.labels, a.units, a.meta, a.status, a.diagnosis) == (b.labels, b.units, b.meta, b.status,
                                                                    b.diagnosis)
