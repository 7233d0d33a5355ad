"""Closed-loop simulation speed: armlab vs a Python loop over Pinocchio vs a hand-written numba
loop with the PRP's closed-form dynamics, side by side in one run.

* **A7 PRP scenario** (``a7_id_via_points``: computed torque, three-step quintic reference,
  10 s at 1 kHz, RK4): ``armlab.simulate`` (the whole loop compiled); the same RK4 loop in
  Python calling ``pinocchio.rnea`` (controller) and ``pinocchio.aba`` (plant); and a numba loop
  written by hand with B, C, g of ``docs/prp-dynamics.md`` (P1–P3) — the practical limit.
* **Puma560**: the same controller and loop on the 6-DoF arm (armlab vs Pinocchio).
* **Adaptive step** (context, no target): the A7 run on SciPy's RK45, armlab's
  ``method="adaptive"`` (SciPy steps, each right-hand side a call of the compiled loop from
  Python) against ``solve_ivp`` over the Pinocchio right-hand side, same solver and tolerances.
* **Gain sweep**: 1000 runs of the A7 scenario (shortened to 1 s) with different gains,
  ``simulate_batch`` on all cores (threads: the compiled loop releases the GIL) vs one core.

(The time of a fresh process to its first result: ``bench_startup.py``.)

Every side's trajectory is checked against armlab's before it is timed, and the sweep's
threaded results against its one-thread results (bit for bit: each run is the same compiled
code on the same inputs, whichever thread runs it); ``tests/test_benchmark_agreement.py`` runs
the same checks on short runs.  Single-run times are the best of several repeats of thread CPU
time (less sensitive to other processes on a shared machine): 20 of the compiled runs (a few ms
each), 3 of the Python loop over Pinocchio (a third of a second each); the sweep uses wall
time.  Targets (issue 14): armlab ≤ 2× the hand-written loop and ≥ 100× faster than the
Pinocchio loop for the PRP, ≥ 30× for the Puma.

Where the A7 run's time goes (Linux ``perf`` sampling of 600 runs on a 2-core AMD EPYC at
armlab 07e3c3f: 5.3 ms a run, the hand-written loop 1.87 ms; 40 000 right-hand sides):

* the law's generated entry, 1.6 ms (~40 ns a call): the reference, the PD sum, the four
  signals and the read of its parameter tuple (15 arrays) from the loop's stack;
* ``sin``/``cos``, 1.3 ms: the law's model and the plant each take them of q₂ on every
  right-hand side (the hand loop shares one pair between its B, C, g and its control law);
* the RK4 loop itself, 1.1 ms, of which logging 28 values a step (q, q̇, q̈, τ, τ_cmd, the law's
  four signals) is 0.4 ms — the hand loop logs q;
* the plant's generated forward dynamics 0.7 ms, the law's generated inverse dynamics 0.55 ms;
* ``simulate``'s set-up and result in Python, 0.4 ms (the RK4 step check 0.13 ms).

Tried and measured on the same machine (best of 30–40 runs, alternating): the law calling its model's
inverse dynamics in numba's own convention instead of through a ``cfunc``'s C wrapper, no
faster on the PRP (5.42 against 5.27–5.60 ms) but the Puma560's run 17.5 → 16.0 ms, so kept
(``armlab.kernels.boundary.NativeFunction``); the law's parameters without ``borrowed`` in
its entry, 7.1 ms; the model's generated kernel as a dispatcher the law calls directly,
4.34 ms, but then the law compiles per robot and misses numba's disk cache in every new
process; the traced kernels with constant multiples and sums of one value folded (τ₁ = q̈₁
instead of five operations), no faster on either robot; one length-checked inverse dynamics
returning a status for the law and for ``armlab.inverse_dynamics`` alike (two kernels fewer),
5.27–5.57 → 5.79–5.87 ms (numeric 16.9 → 17.8 ms), not kept.  What the calls between the
loop, the law and the kernels cost: a compiled call through an address with seven arrays
(numba passes each as seven machine words) takes 9.3 ns, with seven addresses 2.5 ns; a
right-hand side makes two such calls with six or seven arrays (the plant's forward dynamics,
the law's inverse dynamics): 80 000 calls, about 0.75 ms of the run (0.55 ms more than with
addresses), where the hand loop makes none.  The code at
77b07e2 (SymPy's closed forms, shorter than the traced ones of ``armlab.specialise``, and no
step check) ran 4.55 ms there, 2.43× the hand loop and 91× the Pinocchio loop (07e3c3f: 5.20 ms,
2.77× and 80× in ``make bench``), and the Puma560's run in 15.1 ms, 32× (07e3c3f: 17.3 ms, 28×).

Run: ``python benchmarks/bench_simulation.py`` or ``make bench``.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from numba import njit

import armlab
from agreement import OTHER_ALGORITHM, assert_close
from armlab.control.joint_space import JointInverseDynamics
from armlab.references.joint import ViaPoints
from armlab.scenarios import load_scenario
from armlab.simulation import simulate, simulate_batch

HERE = Path(__file__).resolve().parent
T_FINAL, DT = 10.0, 1e-3


def best_cpu(function, repeats=20):
    """Best process CPU time of ``function()`` over ``repeats`` calls [s] and its last value.

    The process's, not the calling thread's: ``armlab.simulate`` runs its compiled loop in a
    worker thread (so that Ctrl-C reaches the main thread), whose time a thread clock misses."""
    best, value = np.inf, None
    for _ in range(repeats):
        start = time.process_time()
        value = function()
        best = min(best, time.process_time() - start)
    return best, value


def quintic(t, times, values):
    """The (R2) via-point reference in plain Python (for the Pinocchio loop)."""
    if t <= times[0]:
        return values[0], 0.0 * values[0], 0.0 * values[0]
    if t >= times[-1]:
        return values[-1], 0.0 * values[0], 0.0 * values[0]
    j = np.searchsorted(times, t, side="right") - 1
    span = times[j + 1] - times[j]
    u = (t - times[j]) / span
    s = 10 * u**3 - 15 * u**4 + 6 * u**5
    sd = (30 * u**2 - 60 * u**3 + 30 * u**4) / span
    sdd = (60 * u - 180 * u**2 + 120 * u**3) / span**2
    delta = values[j + 1] - values[j]
    return values[j] + delta * s, delta * sd, delta * sdd


def pinocchio_rhs(robot, times, values, kp, kd):
    """ẋ = f(t, x) of the closed loop in Python: τ = rnea(q, q̇, y) (computed torque),
    q̈ = aba(q, q̇, τ)."""
    import pinocchio as pin

    sys.path.insert(0, str(HERE.parent / "tests"))
    from pinocchio_model import pinocchio_model

    model, data = pinocchio_model(robot)
    n = robot.n
    if model.nq != n or model.nv != n:
        raise RuntimeError("the Pinocchio loop assumes nq = nv = n")

    def f(t, x):
        q, qd = x[:n], x[n:]
        q_des, qd_des, qdd_des = quintic(t, times, values)
        y = qdd_des + kd * (qd_des - qd) + kp * (q_des - q)
        tau = pin.rnea(model, data, q, qd, y)
        return np.concatenate([qd, pin.aba(model, data, q, qd, tau)])

    return f


def pinocchio_loop(robot, times, values, kp, kd, q0, t_final=T_FINAL):
    """RK4 closed loop in Python over :func:`pinocchio_rhs`."""
    n, f = robot.n, pinocchio_rhs(robot, times, values, kp, kd)

    def run():
        x = np.concatenate([q0, np.zeros(n)])
        steps = int(round(t_final / DT))
        out = np.empty((steps + 1, n))
        out[0] = x[:n]
        for j in range(steps):
            t = j * DT
            k1 = f(t, x)
            k2 = f(t + DT / 2, x + DT / 2 * k1)
            k3 = f(t + DT / 2, x + DT / 2 * k2)
            k4 = f(t + DT, x + DT * k3)
            x = x + DT / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            out[j + 1] = x[:n]
        return out

    return run


@njit(cache=True)
def _quintic_scalar(t, times, values, i):
    """(R2) for joint i, without allocation: (q_des, q̇_des, q̈_des)."""
    count = times.shape[0]
    if t <= times[0]:
        return values[0, i], 0.0, 0.0
    if t >= times[count - 1]:
        return values[count - 1, i], 0.0, 0.0
    j = 0
    while t >= times[j + 1]:
        j += 1
    span = times[j + 1] - times[j]
    u = (t - times[j]) / span
    delta = values[j + 1, i] - values[j, i]
    return (values[j, i] + delta * u * u * u * (10.0 - 15.0 * u + 6.0 * u * u),
            delta * u * u * (30.0 - 60.0 * u + 30.0 * u * u) / span,
            delta * u * (60.0 - 180.0 * u + 120.0 * u * u) / (span * span))


@njit(cache=True)
def _prp_rhs(t, x, P, times, values, kp, kd, xdot):
    """Closed-form PRP (P1–P3) under computed torque; P = [M1, b22_0, m4, g]."""
    M1, b0, m4, g = P[0], P[1], P[2], P[3]
    d1, th, d3, v1, v2, v3 = x[0], x[1], x[2], x[3], x[4], x[5]
    r1, w1, a1 = _quintic_scalar(t, times, values, 0)
    r2, w2, a2 = _quintic_scalar(t, times, values, 1)
    r3, w3, a3 = _quintic_scalar(t, times, values, 2)
    c2, s2 = np.cos(th), np.sin(th)
    B1, B2, B3 = M1, b0 + m4 * d3 * d3, m4
    n2 = 2.0 * m4 * d3 * v3 * v2 - m4 * g * d3 * s2
    n3 = -m4 * d3 * v2 * v2 + m4 * g * c2
    y1 = a1 + kd * (w1 - v1) + kp * (r1 - d1)
    y2 = a2 + kd * (w2 - v2) + kp * (r2 - th)
    y3 = a3 + kd * (w3 - v3) + kp * (r3 - d3)
    tau1, tau2, tau3 = B1 * y1, B2 * y2 + n2, B3 * y3 + n3
    xdot[0], xdot[1], xdot[2] = v1, v2, v3
    xdot[3] = tau1 / B1
    xdot[4] = (tau2 - n2) / B2
    xdot[5] = (tau3 - n3) / B3


@njit(cache=True)
def prp_hand_loop(P, times, values, kp, kd, q0, steps, dt):
    x = np.zeros(6)
    x[:3] = q0
    out = np.empty((steps + 1, 3))
    out[0] = q0
    k1, k2, k3, k4, xt = np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    for j in range(steps):
        t = j * dt
        _prp_rhs(t, x, P, times, values, kp, kd, k1)
        for i in range(6):
            xt[i] = x[i] + 0.5 * dt * k1[i]
        _prp_rhs(t + 0.5 * dt, xt, P, times, values, kp, kd, k2)
        for i in range(6):
            xt[i] = x[i] + 0.5 * dt * k2[i]
        _prp_rhs(t + 0.5 * dt, xt, P, times, values, kp, kd, k3)
        for i in range(6):
            xt[i] = x[i] + dt * k3[i]
        _prp_rhs(t + dt, xt, P, times, values, kp, kd, k4)
        for i in range(6):
            x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        out[j + 1] = x[:3]
    return out


ARMLAB = "armlab.simulate, dynamics='closed_form' (compiled RK4 loop)"
NUMERIC = "armlab.simulate, dynamics='numeric'"
PINOCCHIO = "Python RK4 loop over pinocchio.rnea/aba"
HAND = "hand-written numba loop, closed-form B, C, g"


def verdict(met: bool) -> str:
    return "met" if met else "NOT met"


def sides(robot, controller, times, values, kp, kd, q0, t_final, hand=None):
    """label → a function running that side for ``t_final`` and returning its q samples; armlab
    first with its robot-specialised kernels (``dynamics="closed_form"``: the default "auto"
    uses them once they are on disk, and this request puts them there), then armlab's general
    kernels, Pinocchio, the hand loop."""
    specialised = replace(controller, dynamics="closed_form")
    out = {
        ARMLAB: lambda: simulate(robot, specialised, q0=q0, t_final=t_final, dt=DT, dynamics="closed_form").q,
        NUMERIC: lambda: simulate(robot, replace(controller, dynamics="numeric"), q0=q0, t_final=t_final,
                                  dt=DT, dynamics="numeric").q,
        PINOCCHIO: pinocchio_loop(robot, times, values, kp, kd, q0, t_final),
    }
    if hand is not None:
        steps = int(round(t_final / DT))
        out[HAND] = lambda: hand(steps)
    return out


def check_sides(runs, what):
    """Every side's trajectory against armlab's, to :data:`OTHER_ALGORITHM`; returns label → the
    largest difference."""
    reference = runs[ARMLAB]()
    return {label: assert_close(run(), reference, OTHER_ALGORITHM, f"{what}: {label} vs armlab")
            for label, run in runs.items()}


def prp_setup():
    """The A7 scenario and its sides' arguments (robot, controller, reference, gains, q0) and the
    hand-written loop."""
    scenario = load_scenario("a7_id_via_points")
    robot, controller = scenario.plant, scenario.controller
    reference = controller.reference
    times, values = np.asarray(reference.times, float), np.asarray(reference.values, float)
    kp, kd = float(controller.kp[0, 0]), float(controller.kd[0, 0])
    p = robot.parameters
    m2, m3, m4 = p["m_Link2"], p["m_Link3"], p["m_Link4"]
    P = np.array([m2 + m3 + m4, 0.5 * m3 * p["a3"] ** 2 + m4 * (p["b4"] ** 2 + p["L4"] ** 2) / 12, m4,
                  9.81])
    q0 = np.zeros(3)

    def hand(steps):
        return prp_hand_loop(P, times, values, kp, kd, q0, steps, DT)

    return scenario, (robot, controller, times, values, kp, kd, q0), hand


def puma_setup():
    """The Puma560 under the same controller (rigid body: Pinocchio has no motor or friction
    model): its sides' arguments, or None without its robot file."""
    if "puma560" not in armlab.bundled_robot_names():
        return None
    robot = armlab.load_robot("puma560")
    n = robot.n
    arrays = robot.arrays
    if np.any(arrays.rotor_inertia != 0) or np.any(arrays.viscous != 0) or np.any(arrays.coulomb != 0):
        joints = tuple(replace(j, motor=replace(j.motor, rotor_inertia=0.0),
                               friction=replace(j.friction, viscous=0.0, coulomb=0.0)) for j in robot.joints)
        robot = robot.replace(joints=joints)
    q0 = np.zeros(n)
    times = np.array([1.0, 2.0, 5.0, 6.0])
    goal = np.array([0.5, -0.4, 0.3, 0.2, -0.3, 0.4])[:n]
    values = np.stack([q0, goal, goal, 0.5 * goal])
    kp, kd = 25.0, 10.0
    controller = JointInverseDynamics(robot, ViaPoints(times, values), kp, kd)
    return robot, controller, times, values, kp, kd, q0


def check_prp(t_final):
    _, arguments, hand = prp_setup()
    return check_sides(sides(*arguments, t_final, hand), "PRP A7")


def check_puma(t_final):
    arguments = puma_setup()
    return None if arguments is None else check_sides(sides(*arguments, t_final), "Puma560")


def compare(name, arguments, hand=None):
    """Check, then time every side; print the table; return label → seconds."""
    robot, controller, *_, q0 = arguments
    kind = simulate(robot, replace(controller, dynamics="closed_form"), q0=q0, t_final=DT, dt=DT,
                    dynamics="closed_form").meta["dynamics"].replace("_", " ")
    runs = sides(*arguments, T_FINAL, hand)
    differences = check_sides(runs, name)
    seconds = {}
    for label, run in runs.items():
        run()                                                           # compile/load once
        seconds[label] = best_cpu(run, repeats=3 if label == PINOCCHIO else 20)[0]
    steps = int(round(T_FINAL / DT))
    print(f"\n{name}: computed torque, via points, {T_FINAL:g} s at {1 / DT:g} Hz, RK4 "
          f"({steps} steps, {4 * steps} dynamics evaluations)")
    print(f"  {'implementation':52s} {'time':>10s} {'armlab ÷ it':>12s} {'max |q − q_armlab|':>20s}")
    for label, t in seconds.items():
        shown = f"{label[:-1]}, {kind})" if label == ARMLAB else label
        print(f"  {shown:52s} {t * 1e3:8.2f} ms {seconds[ARMLAB] / t:12.3g} {differences[label]:20.2e}")
    return seconds


def prp_case():
    scenario, arguments, hand = prp_setup()
    t = compare("PRP (seed A7 scenario a7_id_via_points)", arguments, hand)
    hand_ratio, pin_ratio = t[ARMLAB] / t[HAND], t[PINOCCHIO] / t[ARMLAB]
    print(f"  targets: armlab ≤ 2× hand-written: {hand_ratio:.2f}× ({verdict(hand_ratio <= 2)}); "
          f"≥ 100× faster than Pinocchio loop: {pin_ratio:.0f}× ({verdict(pin_ratio >= 100)})")
    return scenario


def puma_case():
    arguments = puma_setup()
    if arguments is None:
        print("\npuma560: no robot file, skipped")
        return
    t = compare("Puma560 (same controller, 6 joints)", arguments)
    ratio = t[PINOCCHIO] / t[ARMLAB]
    print(f"  target: ≥ 30× faster than the Pinocchio loop: {ratio:.0f}× ({verdict(ratio >= 30)})")


ADAPTIVE = "armlab.simulate(method='adaptive')"
SCIPY_PINOCCHIO = "scipy's solver over pinocchio.rnea/aba"


def adaptive_sides(t_final, integrator="RK45", rtol=1e-8, atol=1e-10):
    """The A7 run on SciPy's adaptive ``integrator``, label → a function returning its q at the
    1 kHz grid: armlab (``method="adaptive"``: SciPy steps, the compiled loop evaluates each
    right-hand side, called from Python) and ``solve_ivp`` over the Pinocchio right-hand side,
    same solver class and tolerances."""
    from scipy.integrate import solve_ivp

    _, (robot, controller, times, values, kp, kd, q0), _ = prp_setup()
    n, f = robot.n, pinocchio_rhs(robot, times, values, kp, kd)
    grid = np.arange(int(round(t_final / DT)) + 1) * DT
    specialised = replace(controller, dynamics="closed_form")
    return {
        ADAPTIVE: lambda: simulate(robot, specialised, q0=q0, t_final=t_final, dt=DT, method="adaptive",
                                   integrator=integrator, rtol=rtol, atol=atol, dynamics="closed_form").q,
        SCIPY_PINOCCHIO: lambda: solve_ivp(f, (0.0, grid[-1]), np.concatenate([q0, np.zeros(n)]),
                                           method=integrator, t_eval=grid, rtol=rtol, atol=atol).y[:n].T,
    }


def check_adaptive(t_final):
    """Both adaptive sides agree to 1e-6 (two implementations of the dynamics under one error
    controller: their step sequences may part at round-off, each within its tolerance)."""
    runs = adaptive_sides(t_final)
    reference = runs[ADAPTIVE]()
    return assert_close(runs[SCIPY_PINOCCHIO](), reference, 1e-6,
                        "A7 adaptive: SciPy over Pinocchio vs armlab")


def adaptive_case():
    """Context, no target: the A7 run on SciPy's RK45 (rtol 1e-8, atol 1e-10), where armlab's
    compiled right-hand side is called from Python once per evaluation, so the cost of a call
    (the law's parameters crossing into compiled code) shows."""
    difference = check_adaptive(T_FINAL)
    runs = adaptive_sides(T_FINAL)
    seconds = {label: best_cpu(run, repeats=3)[0] for label, run in runs.items()}
    steps = simulate(*prp_setup()[1][:2], q0=np.zeros(3), t_final=T_FINAL, dt=DT, method="adaptive",
                     integrator="RK45", rtol=1e-8, atol=1e-10, dynamics="closed_form").meta["solver_steps"]
    print(f"\nPRP A7, {T_FINAL:g} s on SciPy's RK45 (rtol 1e-8, atol 1e-10; {steps} solver steps, "
          f"max |q difference| {difference:.1e})")
    for label, t in seconds.items():
        print(f"  {label:52s} {t * 1e3:8.1f} ms {seconds[SCIPY_PINOCCHIO] / t:8.1f}× faster than "
              f"SciPy over Pinocchio" if label == ADAPTIVE else f"  {label:52s} {t * 1e3:8.1f} ms")


def sweep_controllers(scenario, runs):
    base = scenario.controller
    gains = np.linspace(4.0, 12.0, runs)
    return [replace(base, kp=np.eye(3) * w**2, kd=np.eye(3) * 2 * w) for w in gains]


def check_sweep(runs=4, t_final=0.1):
    """``simulate_batch`` on all threads returns, bit for bit, what it returns on one."""
    scenario = load_scenario("a7_id_via_points")
    controllers = sweep_controllers(scenario, runs)
    kwargs = dict(q0=np.zeros(3), t_final=t_final, dt=DT, log_every=10)
    one = simulate_batch(scenario.plant, controllers, workers=1, **kwargs)
    many = simulate_batch(scenario.plant, controllers, **kwargs)
    for k, (a, b) in enumerate(zip(one, many, strict=True)):
        if not np.array_equal(a.q, b.q):
            raise AssertionError(f"sweep run {k}: threaded and one-thread results differ")


def sweep_case(scenario, runs=1000, t_final=1.0):
    check_sweep()
    controllers = sweep_controllers(scenario, runs)
    kwargs = dict(q0=np.zeros(3), t_final=t_final, dt=DT, log_every=100)
    simulate_batch(scenario.plant, controllers[:2], **kwargs)              # load once
    # The whole sweep on one thread and on all, alternately, twice: best wall time of each
    # (the machine's pace drifts; alternating exposes both to the same drift).
    single = parallel = np.inf
    for _ in range(2):
        start = time.perf_counter()
        one = simulate_batch(scenario.plant, controllers, workers=1, **kwargs)
        single = min(single, time.perf_counter() - start)
        start, cpu = time.perf_counter(), time.process_time()
        results = simulate_batch(scenario.plant, controllers, **kwargs)
        wall = time.perf_counter() - start
        if wall < parallel:
            parallel, cores = wall, (time.process_time() - cpu) / wall
    if not all(np.array_equal(a.q, b.q) for a, b in zip(one, results, strict=True)):
        raise AssertionError("gain sweep: threaded and one-thread results differ")
    gains = f"ω_n = {np.sqrt(controllers[0].kp[0, 0]):g} … {np.sqrt(controllers[-1].kp[0, 0]):g} rad/s"
    print(f"\nGain sweep: {runs} runs of a7_id_via_points shortened to {t_final:g} s ({gains})")
    print(f"  simulate_batch, 1 thread:               {single:7.2f} s wall (best of 2)")
    print(f"  simulate_batch, {os.cpu_count()} threads:              {parallel:7.2f} s wall "
          f"(speed-up {single / parallel:.2f}×; process CPU time / wall time = {cores:.2f} cores busy; "
          f"results identical to one thread)")
    rollout_case(runs, t_final)


def rollout_case(runs=1000, t_final=1.0):
    """The same gain sweep as one ``armlab.rollout`` batch (K_P = ω_n², K_D = 2ω_n per joint,
    the scenario's ζ = 1), with its metrics, on one thread and on all: per core against one
    thread (issue 27's target ≥ 0.9)."""
    omega = np.linspace(4.0, 12.0, runs)
    batch = {"controller.kp": omega**2, "controller.kd": 2 * omega, "simulation.t_final": t_final}
    armlab.rollout("a7_id_via_points", {key: value if np.ndim(value) == 0 else value[:4]
                                        for key, value in batch.items()})          # compiled once
    cores = os.cpu_count() or 1
    best = {}
    for _ in range(2):
        for threads in sorted({1, cores}):
            start = time.perf_counter()
            table = armlab.rollout("a7_id_via_points", batch, threads=threads)
            best[threads] = min(best.get(threads, np.inf), time.perf_counter() - start)
            assert table["status"].count("ok") == runs
    per_core = best[1] / best[cores] / cores
    print(f"  armlab.rollout, 1 thread:               {best[1]:7.2f} s wall (best of 2, with metrics)")
    print(f"  armlab.rollout, {cores} threads:              {best[cores]:7.2f} s wall "
          f"({per_core:.2f} per core; target ≥ 0.9: {verdict(per_core >= 0.9)})")


def main():
    scenario = prp_case()
    puma_case()
    adaptive_case()
    sweep_case(scenario)


if __name__ == "__main__":
    main()
