"""Joint-space dynamics: armlab's compiled kernels vs Pinocchio, side by side in one run.

* **Per call from Python, one state**: ``armlab.inverse_dynamics`` / ``inertia_matrix`` /
  ``forward_dynamics`` vs ``pinocchio.rnea`` / ``crba`` / ``aba``.
* **Batched**: many states in one call — armlab's kernels in a compiled loop (what a
  simulation does) vs Pinocchio called in a Python loop (its Python API has no batch call).
* **PRP inverse dynamics inside compiled code**: nanoseconds per evaluation of ``rnea_into``
  in a compiled loop over many states (target ≤ 100 ns).
* **Compile caching**: time to import armlab and make the first dynamics calls in a fresh
  process with an empty numba cache, then in a second process that loads the cache.

Both libraries get the same rigid-body model (motor rotors and friction removed: Pinocchio has
no motor model), Pinocchio's from armlab's URDF export.  Times are the best of several
repeats of thread CPU time, so other processes on a shared machine inflate them less; ratios
are armlab / Pinocchio (below 1: armlab faster).

Run: ``python benchmarks/bench_dynamics.py`` or ``make bench``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from numba import njit

import armlab
from armlab.kernels.dynamics import forward_dynamics_into, make_workspace, mass_matrix_into, rnea_into
from armlab.model.robot import Friction, Motor

ROBOTS = ("prp", "puma560")
REPEATS = 5


def _rigid(robot):
    joints = tuple(replace(j, motor=Motor(j.motor.gear_ratio, 0.0, j.motor.mass), friction=Friction())
                   for j in robot.joints)
    return robot.replace(joints=joints)


def _best(f, calls):
    f()
    best = np.inf
    for _ in range(REPEATS):
        start = time.thread_time()
        for _ in range(calls):
            f()
        best = min(best, time.thread_time() - start)
    return best / calls


def _best_batch(f, states):
    f()
    best = np.inf
    for _ in range(REPEATS):
        start = time.thread_time()
        f()
        best = min(best, time.thread_time() - start)
    return best / states


@njit(cache=True)
def _rnea_batch(m, ws, Q, QD, QDD, h_e, out):
    for k in range(Q.shape[0]):
        rnea_into(m, ws, Q[k], QD[k], QDD[k], 1.0, h_e, out[k])


@njit(cache=True)
def _crba_batch(m, ws, Q, out):
    for k in range(Q.shape[0]):
        mass_matrix_into(m, ws, Q[k], out[k])


@njit(cache=True)
def _aba_batch(m, ws, Q, QD, TAU, h_e, out):
    for k in range(Q.shape[0]):
        forward_dynamics_into(m, ws, Q[k], QD[k], TAU[k], h_e, out[k])


def _pinocchio(robot):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from pinocchio_model import pinocchio_model, pinocchio_q

    model, data = pinocchio_model(robot)
    return model, data, (lambda q: pinocchio_q(robot, model, q))


def _states(robot, count, seed=0):
    rng = np.random.default_rng(seed)
    lo = np.maximum(robot.arrays.q_min, -1.5)
    hi = np.minimum(robot.arrays.q_max, 1.5)
    return rng.uniform(lo, hi, (count, robot.n)), rng.uniform(-1, 1, (count, robot.n)), \
        rng.uniform(-1, 1, (count, robot.n))


def _single_pairs(pin, robot, model, data, q, qd, qdd, qp, tau):
    return {
        "rnea": (lambda: armlab.inverse_dynamics(robot, q, qd, qdd),
                 lambda: pin.rnea(model, data, qp, qd, qdd)),
        "crba": (lambda: armlab.inertia_matrix(robot, q), lambda: pin.crba(model, data, qp)),
        "aba": (lambda: armlab.forward_dynamics(robot, q, qd, tau),
                lambda: pin.aba(model, data, qp, qd, tau)),
    }


def _batch_pairs(pin, m, ws, h_e, model, data, Q, QD, QDD, QP, TAU, B, QDD_OUT):
    states = Q.shape[0]

    def pin_loop(f):
        return lambda: [f(k) for k in range(states)]

    return {
        "rnea": (lambda: _rnea_batch(m, ws, Q, QD, QDD, h_e, TAU),
                 pin_loop(lambda k: pin.rnea(model, data, QP[k], QD[k], QDD[k]))),
        "crba": (lambda: _crba_batch(m, ws, Q, B), pin_loop(lambda k: pin.crba(model, data, QP[k]))),
        "aba": (lambda: _aba_batch(m, ws, Q, QD, TAU, h_e, QDD_OUT),
                pin_loop(lambda k: pin.aba(model, data, QP[k], QD[k], TAU[k]))),
    }


def per_call_rows():
    import pinocchio as pin

    rows = []
    for name in ROBOTS:
        robot = _rigid(armlab.load_robot(name))
        model, data, to_pin = _pinocchio(robot)
        Q, QD, QDD = _states(robot, 1)
        q, qd, qdd = Q[0], QD[0], QDD[0]
        if model.nq != robot.n:
            continue
        qp = to_pin(q)
        tau = armlab.inverse_dynamics(robot, q, qd, qdd)
        for algorithm, (ours, theirs) in _single_pairs(pin, robot, model, data, q, qd, qdd, qp, tau).items():
            a, p = _best(ours, 20000), _best(theirs, 20000)
            rows.append((name, algorithm, a * 1e6, p * 1e6, a / p))
    return rows


def batch_rows(states=20000):
    import pinocchio as pin

    rows = []
    for name in ROBOTS:
        robot = _rigid(armlab.load_robot(name))
        model, data, to_pin = _pinocchio(robot)
        if model.nq != robot.n:
            continue
        m, ws, h_e = robot.arrays, make_workspace(robot.n), np.zeros(6)
        Q, QD, QDD = _states(robot, states)
        TAU, B = np.empty_like(Q), np.empty((states, robot.n, robot.n))
        QDD_OUT = np.empty_like(Q)
        _rnea_batch(m, ws, Q, QD, QDD, h_e, TAU)
        QP = [to_pin(q) for q in Q]
        pairs = _batch_pairs(pin, m, ws, h_e, model, data, Q, QD, QDD, QP, TAU, B, QDD_OUT)
        for algorithm, (ours, theirs) in pairs.items():
            a, p = _best_batch(ours, states), _best_batch(theirs, states)
            rows.append((name, algorithm, a * 1e9, p * 1e9, a / p))
    return rows


def prp_compiled_inverse_dynamics_ns(states=200000):
    """ns per PRP inverse-dynamics evaluation (rnea_into, all terms) inside a compiled loop."""
    robot = armlab.load_robot("prp_actuated")
    m, ws, h_e = robot.arrays, make_workspace(robot.n), np.zeros(6)
    Q, QD, QDD = _states(robot, states)
    TAU = np.empty_like(Q)
    return _best_batch(lambda: _rnea_batch(m, ws, Q, QD, QDD, h_e, TAU), states) * 1e9


@njit(cache=True)
def _reference_flops(X, out):
    for k in range(X.shape[0]):
        a, b, c = X[k, 0], X[k, 1], X[k, 2]
        for _ in range(50):
            a, b, c = a * 0.999 + b * 0.001, b * 0.999 + c * 0.001, c * 0.999 + a * 0.001
        out[k] = a + b + c


def reference_ns(states=200000):
    """ns for 300 floating-point operations (50 × 6) in a compiled loop: the machine's pace."""
    X = np.random.default_rng(0).uniform(size=(states, 3))
    out = np.empty(states)
    return _best_batch(lambda: _reference_flops(X, out), states) * 1e9


_FIRST_CALLS = """
import time
start = time.perf_counter()
import numpy as np
import armlab
robot = armlab.load_robot("prp")
q = np.zeros(3)
armlab.inverse_dynamics(robot, q, q, q); armlab.inertia_matrix(robot, q)
armlab.coriolis_matrix(robot, q, q); armlab.gravity_torque(robot, q)
armlab.forward_dynamics(robot, q, q, q)
print(time.perf_counter() - start)
"""


def compile_times():
    """(cold, warm) seconds: import + first calls with an empty cache, then from the cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        times = []
        for _ in range(2):
            out = subprocess.run([sys.executable, "-c", _FIRST_CALLS], env=env, capture_output=True,
                                 text=True, check=True)
            times.append(float(out.stdout.strip().splitlines()[-1]))
    return times


def main():
    print("== Dynamics: armlab vs Pinocchio (rigid-body model, thread CPU time, best of "
          f"{REPEATS}) ==")
    print("\nPer call from Python, one state [µs]")
    print(f"{'robot':10s} {'algorithm':9s} {'armlab':>9s} {'pinocchio':>10s} {'ratio':>7s}")
    for name, algorithm, a, p, r in per_call_rows():
        print(f"{name:10s} {algorithm:9s} {a:9.2f} {p:10.2f} {r:7.2f}")
    print("\nBatched, 20000 states per call [ns per state] "
          "(armlab: compiled loop; Pinocchio: Python loop)")
    print(f"{'robot':10s} {'algorithm':9s} {'armlab':>9s} {'pinocchio':>10s} {'ratio':>7s}")
    for name, algorithm, a, p, r in batch_rows():
        print(f"{name:10s} {algorithm:9s} {a:9.0f} {p:10.0f} {r:7.3f}")
    ns = prp_compiled_inverse_dynamics_ns()
    print(f"\nPRP inverse dynamics (prp_actuated: motors, friction) inside compiled code: {ns:.0f} ns "
          "per evaluation (target ≤ 100 ns)")
    print(f"Machine pace for reference: 300 floating-point operations take {reference_ns():.0f} ns "
          "in a compiled loop")
    cold, warm = compile_times()
    print(f"Import + first dynamics calls: {cold:.1f} s with an empty numba cache, "
          f"{warm:.1f} s in a second process (cache on disk)")


if __name__ == "__main__":
    main()
