"""A control law in plain Python against its ``numba.njit`` twin: the PRP under a joint PD,
10 s at 1 kHz (RK4, four law calls a step), in both the short form ``tau = law(t, q, qd)`` and
the full protocol form.  Prints the wall times and the slow-down factor quoted in
``docs/python-laws.md``.  The plant runs on its generated closed form (:data:`PLANT`) in
every case.

Then a small law declared at module level (``inlined_laws.py``), called from its generated
entry or compiled inside it (``njit(inline="always")``), with a parameter tuple of the four
arrays it reads and with the A7 law's fifteen: process CPU time of the 10 s run, best of 20,
the trajectories checked equal first (``docs/scenario-files.md`` quotes the figures)."""

from __future__ import annotations

import time
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from numba import njit

import armlab
from armlab import FunctionController
from armlab.scenarios import load_scenario
from inlined_laws import CalledPD, InlinedPD

ROBOT = armlab.load_robot("prp")
Q_DES = np.array([0.1, 1.0, 0.05])
KP, KD = np.array([25.0, 5.0, 10.0]), np.array([10.0, 1.0, 3.0])
# The plant's kernels, named: with "auto" a run takes the robot's generated module only once one
# is on disk, and these figures would then depend on what ran before (numeric kernels after an
# edit of the kernels or on a new machine: the compiled runs 3-4 times slower).
PLANT = "closed_form"


class Gains(NamedTuple):
    q_des: np.ndarray
    kp: np.ndarray
    kd: np.ndarray


def short(t, q, qd):
    return KP * (Q_DES - q) - KD * qd


def full(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
    q_des, kp, kd = params.q_des, params.kp, params.kd
    for i in range(q.shape[0]):
        tau_out[i] = kp[i] * (q_des[i] - q[i]) - kd[i] * qd[i]


def best_of(controller, repeats: int) -> float:
    armlab.simulate(ROBOT, controller, q0=np.zeros(3), t_final=0.01, dt=1e-3, dynamics=PLANT)  # warm up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        armlab.simulate(ROBOT, controller, q0=np.zeros(3), t_final=10.0, dt=1e-3, dynamics=PLANT)
        times.append(time.perf_counter() - start)
    return min(times)


def python_case() -> None:
    gains = Gains(Q_DES, KP, KD)
    print(f"{'law (PRP, 10 s at 1 kHz, RK4)':34s} {'Python [s]':>11s} {'njit [s]':>10s} {'factor':>8s}")
    cases = (("short form tau = law(t, q, qd)", short, ()), ("full protocol form", full, gains))
    for name, law, params in cases:
        python = best_of(FunctionController(ROBOT, law, parameters=params), 1)
        compiled = best_of(FunctionController(ROBOT, njit(law), parameters=params), 5)
        print(f"{name:34s} {python:11.3f} {compiled:10.4f} {python / compiled:8.0f}")


def inlined_sides(t_final: float = 10.0) -> dict:
    """label → a function running that side for ``t_final`` on the A7 scenario's reference
    (the PRP, 1 ms steps) and returning its result."""
    scenario = load_scenario("a7_id_via_points")
    robot, a7 = scenario.plant, scenario.controller
    a7_numeric = replace(a7, dynamics="numeric")

    def side(kind, wide):
        controller = kind(robot, a7.reference, a7_numeric if wide else None)
        return lambda: armlab.simulate(robot, controller, q0=np.zeros(3), t_final=t_final, dt=1e-3,
                                       dynamics=PLANT)

    return {(name, wide): side(kind, wide) for name, kind in (("called", CalledPD), ("inlined", InlinedPD))
            for wide in (False, True)}


def check_inlined(t_final: float = 0.2) -> None:
    """Called and inlined, narrow and wide parameters: the same trajectory, bit for bit."""
    runs = {label: run() for label, run in inlined_sides(t_final).items()}
    reference = runs[("called", False)]
    for label, result in runs.items():
        assert np.array_equal(result.q, reference.q) and np.array_equal(result.tau, reference.tau), label


def inlined_case() -> None:
    check_inlined()
    seconds = {}
    for label, run in inlined_sides().items():
        run()
        best = np.inf
        for _ in range(20):
            start = time.process_time()
            run()
            best = min(best, time.process_time() - start)
        seconds[label] = best
    print("\nA small law at module level (reference + PD, PRP, 10 s at 1 kHz), process CPU, best of 20")
    print(f"{'parameters':34s} {'called [ms]':>12s} {'inlined [ms]':>13s} {'ratio':>7s}")
    for wide, name in ((False, "the 4 arrays it reads"), (True, "the A7 law's 15 arrays")):
        called, inlined = seconds[("called", wide)], seconds[("inlined", wide)]
        print(f"{name:34s} {called * 1e3:12.2f} {inlined * 1e3:13.2f} {called / inlined:7.2f}")


def main() -> None:
    python_case()
    inlined_case()


if __name__ == "__main__":
    main()
