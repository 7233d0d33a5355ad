"""Joint-space dynamics: armlab's compiled kernels vs Pinocchio, side by side in one run.

* **Per call from Python, one state**: ``armlab.inverse_dynamics`` / ``inertia_matrix`` /
  ``forward_dynamics`` vs ``pinocchio.rnea`` / ``crba`` / ``aba``; armlab twice, with its
  general kernels (the default) and with the robot's generated module
  (``dynamics="closed_form"``, ``armlab.specialise``), each checked against Pinocchio first;
  each side passes its own data (armlab's ``DynamicsData``, Pinocchio's ``Data``).
* **Batched**: many states in one call — armlab's kernels inlined into a compiled loop (what
  a simulation does) vs Pinocchio called in a Python loop (its Python API has no batch call).
* **PRP inverse dynamics inside compiled code**: nanoseconds per evaluation in a compiled loop
  over many states (target ≤ 100 ns), for the general RNEA (inlined into the loop, as the
  simulation's entries call it, and behind a call), the closed form generated
  by ``armlab.symbolic`` and a hand-written closed form (the practical limit, ratio 1).
* **Compile caching**: time to import armlab and make the first dynamics calls in a fresh
  process with empty caches (numba's and armlab's), then in a second process that loads them.

Before anything is timed, each side is checked against the other (the ``check_*`` functions,
which ``tests/test_benchmark_agreement.py`` runs on a few states; tolerances in
``agreement.py``).  The compiled loops here are compiled with armlab's own kernel options
(``armlab.kernels.dynamics.kernel``): code inlined into a function is compiled with that
function's options, so the kernels run in these loops as they run in armlab's compiled entries.

Both libraries get the same rigid-body model (motor rotors and friction removed: Pinocchio has
no motor model), Pinocchio's from armlab's URDF export.  Times are the best of several
repeats of thread CPU time, so other processes on a shared machine inflate them less; per-call
times are taken in turns (armlab, its closed form, Pinocchio, again), so that the machine's
drifting pace reaches all three alike.  Ratios are armlab / Pinocchio (below 1: armlab faster).

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
from agreement import OTHER_ALGORITHM, SAME_ALGORITHM, assert_close
from armlab.kernels.dynamics import (
    forward_dynamics_inline,
    make_workspace,
    mass_matrix_inline,
    rnea_inline,
    rnea_into,
)
from armlab.kernels.dynamics import kernel as compiled_loop
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


def _best_interleaved(functions, calls=2000, rounds=40):
    """Best time per call of each function, the functions taking turns (``rounds`` rounds of
    ``calls`` calls each): the machine's pace drifts by 10–20 % within minutes, and timing
    one function after another would hand that drift to the ratios."""
    for f in functions:
        f()
    best = [np.inf] * len(functions)
    for _ in range(rounds):
        for k, f in enumerate(functions):
            start = time.thread_time()
            for _ in range(calls):
                f()
            best[k] = min(best[k], time.thread_time() - start)
    return [b / calls for b in best]


def _best_batch(f, states):
    f()
    best = np.inf
    for _ in range(REPEATS):
        start = time.thread_time()
        f()
        best = min(best, time.thread_time() - start)
    return best / states


@compiled_loop
def _rnea_batch(m, ws, Q, QD, QDD, h_e, out):
    for k in range(Q.shape[0]):
        rnea_inline(m, ws, Q[k], QD[k], QDD[k], 1.0, h_e, out[k])


@compiled_loop
def _rnea_call_batch(m, ws, Q, QD, QDD, h_e, out):
    for k in range(Q.shape[0]):
        rnea_into(m, ws, Q[k], QD[k], QDD[k], 1.0, h_e, out[k])


@compiled_loop
def _crba_batch(m, ws, Q, out):
    for k in range(Q.shape[0]):
        mass_matrix_inline(m, ws, Q[k], out[k])


@compiled_loop
def _aba_batch(m, ws, Q, QD, TAU, h_e, out):
    for k in range(Q.shape[0]):
        forward_dynamics_inline(m, ws, Q[k], QD[k], TAU[k], h_e, out[k])


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


def _single_calls(pin, robot, model, data, q, qd, qdd, qp, tau):
    """Per algorithm: (armlab's general kernels, armlab's generated module, Pinocchio); each
    side passes its own data, as a hot loop does (armlab's ``DynamicsData``, Pinocchio's
    ``Data``)."""
    cf, ours = "closed_form", armlab.DynamicsData(robot)
    return {
        "rnea": (lambda: armlab.inverse_dynamics(robot, q, qd, qdd, data=ours),
                 lambda: armlab.inverse_dynamics(robot, q, qd, qdd, dynamics=cf, data=ours),
                 lambda: pin.rnea(model, data, qp, qd, qdd)),
        "crba": (lambda: armlab.inertia_matrix(robot, q, data=ours),
                 lambda: armlab.inertia_matrix(robot, q, dynamics=cf, data=ours),
                 lambda: pin.crba(model, data, qp)),
        "aba": (lambda: armlab.forward_dynamics(robot, q, qd, tau, data=ours),
                lambda: armlab.forward_dynamics(robot, q, qd, tau, dynamics=cf, data=ours),
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


@njit(cache=True)
def _touch(model, data, q, out):
    out[0, 0] = model[0] + data[0] + q[0]
    return 0


def call_floor_us():
    """µs of the bare mechanics of an ``inertia_matrix`` call on the PRP: a Python function that
    allocates the (3, 3) output and calls, through numba's dispatcher, a compiled function that
    does nothing with the wrapper's four arrays (the robot's model and data, q, output)."""
    model, data, q = np.zeros(500), np.zeros(150), np.zeros(3)

    def wrapper(q):
        out = np.empty((3, 3))
        _touch(model, data, q, out)
        return out

    return _best(lambda: wrapper(q), 20000) * 1e6


# ------------------------------------------------------------------------- agreement checks
def check_per_call(name, closed_form=True):
    """armlab's ``inverse_dynamics`` / ``inertia_matrix`` / ``forward_dynamics`` (general kernels
    and, with ``closed_form``, the generated module) against Pinocchio at one state."""
    import pinocchio as pin

    robot = _rigid(armlab.load_robot(name))
    model, data, to_pin = _pinocchio(robot)
    if model.nq != robot.n:
        return
    Q, QD, QDD = _states(robot, 1)
    q, qd, qdd = Q[0], QD[0], QDD[0]
    tau = armlab.inverse_dynamics(robot, q, qd, qdd)
    calls = _single_calls(pin, robot, model, data, q, qd, qdd, to_pin(q), tau)
    for algorithm, (general, generated, theirs) in calls.items():
        reference = theirs()
        assert_close(general(), reference, OTHER_ALGORITHM, f"{name} {algorithm}: armlab vs Pinocchio")
        if closed_form:
            assert_close(generated(), reference, OTHER_ALGORITHM,
                         f"{name} {algorithm}: armlab's closed form vs Pinocchio")


def _batched(robot, Q, QD, QDD):
    """τ, B and q̈ = FD(q, q̇, τ) at every state, each by armlab's kernels in one compiled loop."""
    m, ws, h_e = robot.arrays, make_workspace(robot.n), np.zeros(6)
    TAU, B, QDD_OUT = np.empty_like(Q), np.empty((Q.shape[0], robot.n, robot.n)), np.empty_like(Q)
    _rnea_batch(m, ws, Q, QD, QDD, h_e, TAU)
    _crba_batch(m, ws, Q, B)
    _aba_batch(m, ws, Q, QD, TAU, h_e, QDD_OUT)
    return TAU, B, QDD_OUT


def check_batched(name, states):
    """The compiled batch loops against Pinocchio, state by state (q̈ of the forward dynamics
    must also return the q̈ the inverse dynamics started from)."""
    import pinocchio as pin

    robot = _rigid(armlab.load_robot(name))
    model, data, to_pin = _pinocchio(robot)
    if model.nq != robot.n:
        return
    Q, QD, QDD = _states(robot, states)
    TAU, B, QDD_OUT = _batched(robot, Q, QD, QDD)
    for k in range(states):
        qp = to_pin(Q[k])
        assert_close(TAU[k], pin.rnea(model, data, qp, QD[k], QDD[k]), OTHER_ALGORITHM,
                     f"{name} batched rnea, state {k}")
        assert_close(B[k], pin.crba(model, data, qp), OTHER_ALGORITHM, f"{name} batched crba, state {k}")
        assert_close(QDD_OUT[k], pin.aba(model, data, qp, QD[k], TAU[k]), OTHER_ALGORITHM,
                     f"{name} batched aba, state {k}")
    assert_close(QDD_OUT, QDD, OTHER_ALGORITHM, f"{name} batched aba(rnea(q̈)) = q̈")


def _prp_routes(robot, states, generated, symbolic):
    """τ of every compiled PRP route at the same ``states`` random states."""
    m, ws, h_e = robot.arrays, make_workspace(robot.n), np.zeros(6)
    Q, QD, QDD = _states(robot, states)
    k = _prp_constants(robot)
    out = {route: np.empty_like(Q) for route in ("rnea_inline", "rnea_into", "generated", "symbolic",
                                                  "hand-written")}
    _rnea_batch(m, ws, Q, QD, QDD, h_e, out["rnea_inline"])
    _rnea_call_batch(m, ws, Q, QD, QDD, h_e, out["rnea_into"])
    generated(m, ws, Q, QD, QDD, h_e, out["generated"])
    symbolic(Q, QD, QDD, out["symbolic"])
    _prp_closed_form_batch(k, Q, QD, QDD, out["hand-written"])
    return (Q, QD, QDD), out


def check_prp_routes(states, routes=None):
    """Every compiled PRP inverse-dynamics route against ``armlab.inverse_dynamics`` (the public
    function) at each state: the RNEA inlined and behind a call to :data:`SAME_ALGORITHM`, the
    generated, symbolic and hand-written closed forms to :data:`OTHER_ALGORITHM`."""
    robot = armlab.load_robot("prp_actuated")
    if routes is None:
        from armlab.symbolic import closed_form_kernels

        routes = (_loop_over(closed_form_kernels(robot).rnea_into), _symbolic_tau_loop(robot))
    (Q, QD, QDD), out = _prp_routes(robot, states, *routes)
    reference = np.array([armlab.inverse_dynamics(robot, Q[k], QD[k], QDD[k]) for k in range(states)])
    for route, tau in out.items():
        rtol = SAME_ALGORITHM if route.startswith("rnea") else OTHER_ALGORITHM
        assert_close(tau, reference, rtol, f"PRP {route} vs armlab.inverse_dynamics")


# ----------------------------------------------------------------------------------- timings
def per_call_rows():
    import pinocchio as pin

    rows = []
    for name in ROBOTS:
        check_per_call(name)
        robot = _rigid(armlab.load_robot(name))
        model, data, to_pin = _pinocchio(robot)
        if model.nq != robot.n:
            continue
        Q, QD, QDD = _states(robot, 1)
        q, qd, qdd = Q[0], QD[0], QDD[0]
        tau = armlab.inverse_dynamics(robot, q, qd, qdd)
        calls = _single_calls(pin, robot, model, data, q, qd, qdd, to_pin(q), tau)
        for algorithm, (general, generated, theirs) in calls.items():
            a, c, p = _best_interleaved((general, generated, theirs))
            rows.append((name, algorithm, a * 1e6, c * 1e6, p * 1e6, a / p, c / p))
    return rows


def batch_rows(states=20000):
    import pinocchio as pin

    rows = []
    for name in ROBOTS:
        check_batched(name, 200)
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


@compiled_loop
def _prp_closed_form_batch(k, Q, QD, QDD, out):
    """Hand-written closed-form PRP inverse dynamics, the practical limit for one evaluation:

        τ1 = b1 q̈1 + F_v1 q̇1 + F_s1 sgn q̇1
        τ2 = (b2 + β q3²) q̈2 + 2β q3 q̇3 q̇2 − γ q3 sin q2 + F_v2 q̇2 + F_s2 sgn q̇2
        τ3 = b3 q̈3 − β q3 q̇2² + γ cos q2 + F_v3 q̇3 + F_s3 sgn q̇3

    (B diagonal, the Christoffel C of B22(q3), g from link 4's weight; the constants k =
    [b1, b2, b3, β, γ, F_v1..3, F_s1..3] come from :func:`_prp_constants`)."""
    b1, b2, b3, beta, gamma = k[0], k[1], k[2], k[3], k[4]
    for i in range(Q.shape[0]):
        q2, q3 = Q[i, 1], Q[i, 2]
        v1, v2, v3 = QD[i, 0], QD[i, 1], QD[i, 2]
        s, c = np.sin(q2), np.cos(q2)
        out[i, 0] = b1 * QDD[i, 0] + k[5] * v1 + k[8] * np.sign(v1)
        out[i, 1] = ((b2 + beta * q3 * q3) * QDD[i, 1] + 2.0 * beta * q3 * v3 * v2 - gamma * q3 * s
                     + k[6] * v2 + k[9] * np.sign(v2))
        out[i, 2] = b3 * QDD[i, 2] - beta * q3 * v2 * v2 + gamma * c + k[7] * v3 + k[10] * np.sign(v3)


def _prp_constants(robot):
    """The constants of :func:`_prp_closed_form_batch`, read from armlab's B and g at two
    points (the closed form's structure is then checked on random states by the caller)."""
    z = np.zeros(3)
    B0 = armlab.inertia_matrix(robot, z)
    beta = armlab.inertia_matrix(robot, np.array([0.0, 0.0, 1.0]))[1, 1] - B0[1, 1]
    gamma = armlab.gravity_torque(robot, z)[2]
    m = robot.arrays
    return np.concatenate([[B0[0, 0], B0[1, 1], B0[2, 2], beta, gamma], m.viscous, m.coulomb])


def _loop_over(rnea):
    """A compiled loop calling ``rnea`` (a generated kernel, bound at compile time)."""
    @compiled_loop
    def generated_loop(m, ws, Q, QD, QDD, h_e, out):
        for k in range(Q.shape[0]):
            rnea(m, ws, Q[k], QD[k], QDD[k], 1.0, h_e, out[k])
    return generated_loop


def _symbolic_tau_loop(robot):
    """``armlab.symbolic.closed_form_torque``: τ = B q̈ + C q̇ + g + friction as one compiled
    formula, called in a compiled loop."""
    from armlab.symbolic import closed_form_torque

    tau_into = closed_form_torque(robot)

    @compiled_loop
    def symbolic_loop(Q, QD, QDD, out):
        for k in range(Q.shape[0]):
            tau_into(Q[k], QD[k], QDD[k], out[k])
    return symbolic_loop


def prp_compiled_rows(states=200000):
    """ns per PRP inverse-dynamics evaluation (prp_actuated: motors, friction) in a compiled
    loop: armlab's general RNEA, inlined (``rnea_inline``) and behind a call (``rnea_into``,
    which passes the robot and workspace flattened); the generated closed-form kernels
    (``armlab.symbolic.closed_form_kernels(...).rnea_into``: B, C, g written into matrices, then
    multiplied); armlab.symbolic's B q̈ + C q̇ + g as one compiled expression; and the
    hand-written closed form (the practical limit).  Checked first on 2000 states."""
    from armlab.symbolic import closed_form_kernels

    robot = armlab.load_robot("prp_actuated")
    routes = (_loop_over(closed_form_kernels(robot).rnea_into), _symbolic_tau_loop(robot))
    check_prp_routes(2000, routes)
    m, ws, h_e = robot.arrays, make_workspace(robot.n), np.zeros(6)
    (Q, QD, QDD), out = _prp_routes(robot, states, *routes)
    generated, symbolic = routes
    k = _prp_constants(robot)
    return [
        ("rnea_inline (general RNEA)", _best_batch(
            lambda: _rnea_batch(m, ws, Q, QD, QDD, h_e, out["rnea_inline"]), states)),
        ("rnea_into (the same, one call)", _best_batch(
            lambda: _rnea_call_batch(m, ws, Q, QD, QDD, h_e, out["rnea_into"]), states)),
        ("closed_form_kernels", _best_batch(lambda: generated(m, ws, Q, QD, QDD, h_e, out["generated"]),
                                            states)),
        ("closed_form_torque", _best_batch(lambda: symbolic(Q, QD, QDD, out["symbolic"]), states)),
        ("hand-written closed form", _best_batch(
            lambda: _prp_closed_form_batch(k, Q, QD, QDD, out["hand-written"]), states)),
    ]


@compiled_loop
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
    """(cold, warm) seconds: import + first calls with empty caches (numba's compiled kernels,
    armlab's generated modules), then from those caches."""
    with tempfile.TemporaryDirectory() as numba_cache, tempfile.TemporaryDirectory() as armlab_cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=numba_cache, ARMLAB_CACHE_DIR=armlab_cache)
        times = []
        for _ in range(2):
            out = subprocess.run([sys.executable, "-c", _FIRST_CALLS], env=env, capture_output=True,
                                 text=True, check=True)
            times.append(float(out.stdout.strip().splitlines()[-1]))
    return times


def main():
    print("== Dynamics: armlab vs Pinocchio (rigid-body model, thread CPU time, best of "
          f"{REPEATS}) ==")
    print("\nPer call from Python, one state [µs]: armlab's general kernels (default) and its "
          "generated module (dynamics='closed_form')")
    print(f"{'robot':10s} {'algorithm':9s} {'armlab':>9s} {'closed form':>12s} {'pinocchio':>10s} "
          f"{'ratio':>7s} {'ratio cf':>9s}")
    for name, algorithm, a, c, p, r, rc in per_call_rows():
        print(f"{name:10s} {algorithm:9s} {a:9.2f} {c:12.2f} {p:10.2f} {r:7.2f} {rc:9.2f}")
    print(f"(floor: a Python function allocating a (3, 3) output and calling, through numba's "
          f"dispatcher, a compiled function that does nothing with the PRP crba wrapper's four "
          f"arrays: {call_floor_us():.2f} µs)")
    print("\nBatched, 20000 states per call [ns per state] "
          "(armlab: compiled loop; Pinocchio: Python loop)")
    print(f"{'robot':10s} {'algorithm':9s} {'armlab':>9s} {'pinocchio':>10s} {'ratio':>7s}")
    for name, algorithm, a, p, r in batch_rows():
        print(f"{name:10s} {algorithm:9s} {a:9.0f} {p:10.0f} {r:7.3f}")
    rows = prp_compiled_rows()
    limit = rows[-1][1]
    print("\nPRP inverse dynamics inside compiled code (prp_actuated: motors, friction), "
          "200000 states [ns per evaluation] (target ≤ 100 ns)")
    print(f"{'route':32s} {'ns':>7s} {'/ hand-written':>15s}")
    for route, seconds in rows:
        print(f"{route:32s} {seconds * 1e9:7.0f} {seconds / limit:15.2f}")
    print(f"Machine pace for reference: 300 floating-point operations take {reference_ns():.0f} ns "
          "in a compiled loop")
    cold, warm = compile_times()
    print(f"Import + first dynamics calls: {cold:.1f} s with empty caches (numba, armlab), "
          f"{warm:.1f} s in a second process (caches on disk)")


if __name__ == "__main__":
    main()
