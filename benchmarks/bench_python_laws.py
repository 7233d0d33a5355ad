"""A control law in plain Python against its ``numba.njit`` twin: the PRP under a joint PD,
10 s at 1 kHz (RK4, four law calls a step), in both the short form ``tau = law(t, q, qd)`` and
the full protocol form.  Prints the wall times and the slow-down factor quoted in
``docs/python-laws.md``."""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np
from numba import njit

import armlab
from armlab import FunctionController

ROBOT = armlab.load_robot("prp")
Q_DES = np.array([0.1, 1.0, 0.05])
KP, KD = np.array([25.0, 5.0, 10.0]), np.array([10.0, 1.0, 3.0])


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
    armlab.simulate(ROBOT, controller, q0=np.zeros(3), t_final=0.01, dt=1e-3)  # compile / warm up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        armlab.simulate(ROBOT, controller, q0=np.zeros(3), t_final=10.0, dt=1e-3)
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    gains = Gains(Q_DES, KP, KD)
    print(f"{'law (PRP, 10 s at 1 kHz, RK4)':34s} {'Python [s]':>11s} {'njit [s]':>10s} {'factor':>8s}")
    cases = (("short form tau = law(t, q, qd)", short, ()), ("full protocol form", full, gains))
    for name, law, params in cases:
        python = best_of(FunctionController(ROBOT, law, parameters=params), 1)
        compiled = best_of(FunctionController(ROBOT, njit(law), parameters=params), 5)
        print(f"{name:34s} {python:11.3f} {compiled:10.4f} {python / compiled:8.0f}")


if __name__ == "__main__":
    main()
