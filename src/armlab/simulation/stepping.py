"""How a run is stepped so that it can be stopped: Ctrl-C and step budgets.

* :func:`run_interruptible` runs a long compiled RK4 loop (which releases the GIL) in a worker
  thread; Ctrl-C reaches the main thread, which sets the loop's stop flag (``fset[3]``,
  ``armlab.simulation.loop``): the loop returns after its current step with status
  :data:`INTERRUPTED` and the rows logged so far.  A short run (:data:`SHORT_RUN`) runs in the
  calling thread: it ends before a Ctrl-C would be noticed, and the thread's start and wake-up
  cost more than the run itself (0.2 ms on an idle machine, milliseconds on a busy one; most
  of a 100-step run of a sweep).
* :func:`solve_stepwise` is ``scipy.integrate.solve_ivp``'s loop for the adaptive method, step
  for step the same (SciPy's solver classes and their dense output), but it stops after a
  budget of solver steps (:data:`BUDGET`) or at Ctrl-C (:data:`INTERRUPTED`) with the output
  points reached so far.
"""

from __future__ import annotations

import threading

import numpy as np

INTERRUPTED, BUDGET = 5, 6
"""Status codes beside the loop's divergence codes 1–4 (``simulator.STATUS``)."""

SOLVERS = ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA")


def solve_stepwise(rhs, t0, t1, x0, integrator, rtol, atol, t_eval, args, budget):
    """``solve_ivp(rhs, (t0, t1), x0, method=integrator, t_eval=t_eval, args=args)``, step
    for step the same loop (SciPy's solver class, its dense output at the points of ``t_eval``
    each step passes), but stopping after ``budget`` solver steps or at Ctrl-C with the points
    reached so far.  Returns (xs (K, m), status, steps): status 0 done, −1 the solver failed,
    ``BUDGET`` or ``INTERRUPTED``."""
    import scipy.integrate

    def fun(t, x):
        return rhs(t, x, *args)

    solver = getattr(scipy.integrate, integrator)(fun, float(t0), np.asarray(x0), float(t1),
                                                  rtol=rtol, atol=atol)
    points, done, steps, status = [], 0, 0, None
    try:
        while status is None:
            if steps >= budget:
                status = BUDGET
                break
            solver.step()
            steps += 1
            if solver.status == "finished":
                status = 0
            elif solver.status == "failed":
                status = -1
                break
            # The points of t_eval up to and including the solver's time, from its interpolant.
            upto = int(np.searchsorted(t_eval, solver.t, side="right"))
            if upto > done:
                points.append(solver.dense_output()(t_eval[done:upto]).T)
                done = upto
    except KeyboardInterrupt:
        status = INTERRUPTED            # the points appended so far are complete
    xs = np.vstack(points) if points else np.zeros((0, np.asarray(x0).shape[0]))
    return xs, status, steps



SHORT_RUN = 60_000
"""Joint-steps (steps × joints) up to which a run is not worth a worker thread: tens of
milliseconds at most (0.4 µs a step for the PRP, about 2 µs for a 6-joint arm)."""


def run_interruptible(run, fset, joint_steps=None):
    """``run()`` (the compiled loop, which releases the GIL) in a worker thread, so that the
    main thread can take Ctrl-C meanwhile: it then sets the loop's stop flag ``fset[3]``,
    and the loop returns after its current step (status 5).  A second Ctrl-C is taken as
    usual (a KeyboardInterrupt while waiting).  In the calling thread instead when that is not
    the main thread (signals go to the main thread: nothing to take there) or when the run is
    short, ``joint_steps`` ≤ :data:`SHORT_RUN`."""
    if threading.current_thread() is not threading.main_thread() or (
            joint_steps is not None and joint_steps <= SHORT_RUN):
        return run()
    outcome, done = [], threading.Event()

    def target():
        try:
            outcome.append((True, run()))
        except BaseException as error:  # noqa: BLE001 — re-raised in the caller's thread
            outcome.append((False, error))
        finally:
            done.set()

    # Waited for with an Event, not Thread.join: a join interrupted by Ctrl-C may mark a running
    # thread as finished (CPython 3.11).
    threading.Thread(target=target, name="armlab-simulation", daemon=True).start()
    try:
        while not done.wait(0.1):
            pass
    except KeyboardInterrupt:
        fset[3] = 1.0
        done.wait()
    ok, value = outcome[0]
    if not ok:
        raise value
    return value
