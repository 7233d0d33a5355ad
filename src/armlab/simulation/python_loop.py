"""The closed loop for a control law written in plain Python (not compiled).

The compiled loop (``armlab.simulation.loop``) calls the law through its machine address,
which a Python function does not have.  This module runs the same closed loop in Python,
calling the compiled pieces it can (the plant's forward dynamics and kinetic energy, the
end-effector measurement, the environment's law, the disturbances) and the user's law once
per stage:

    h_e = env(t, T_0e(q), J(q) q̇);  τ, ż = law(t, q, q̇, z, h_e);  τ_a = clip(τ, ±τ_max)
    q̈ = FD(q, q̇, τ_a + τ_d(t, q, q̇), h_e);  ẋ = [q̇; q̈; ż]                            (S1, S2)

with the RK4 step of (S3) written in the same order as the compiled loop's, the same
sampled-control rule (law at the samples, τ held, z ← z + T_c ż), the same divergence checks
and the same log (row j: x_j and stage k₁ at t_j).  A law that is the ``njit`` twin of a
Python law therefore gives the same trajectory up to rounding.  ``method="adaptive"``
integrates this right-hand side with SciPy's ``solve_ivp`` (continuous control only).

It is slower by the cost of the interpreter (the factor is measured in
``docs/python-laws.md``); decorating the law with ``numba.njit`` moves it into the
compiled loop.
"""

from __future__ import annotations

import time

import numpy as np

from armlab.errors import SimulationError
from armlab.kernels.plant import measure_packed
from armlab.simulation.disturbances import disturbance_into


class _Stage:
    """ẋ = f(t, x) of the closed loop with a Python law; the scratch of the last call (τ_c,
    τ_a, τ_d, h_e, q̈, ż, signals) is kept for logging and the zero-order hold."""

    def __init__(self, setup, law, params, plant):
        n, k = setup.n, setup.k
        self.setup, self.law, self.params, self.plant = setup, law, params, plant
        self.n, self.k = n, k
        self.tau_c, self.tau_a, self.tau_d = np.zeros(n), np.zeros(n), np.zeros(n)
        self.h_e, self.qdd, self.zdot = np.zeros(6), np.zeros(n), np.zeros(k)
        self.sig = np.zeros(setup.sig_width)
        self.R_0e, self.p_0e, self.v_e = np.zeros((3, 3)), np.zeros(3), np.zeros(6)
        self.meas = np.zeros(18 * n)
        self.has_env = setup.environment is not None
        self.has_dist = setup.dist[0] > 0

    def __call__(self, t, x, call_law, z_rate, xdot):
        n, setup = self.n, self.setup
        q, qd, z = x[:n].copy(), x[n:2 * n].copy(), x[2 * n:].copy()
        if self.has_env:
            measure_packed(self.plant[0], q, qd, self.meas, self.R_0e, self.p_0e, self.v_e)
            setup.env_law(t, self.R_0e, self.p_0e, self.v_e, setup.eparams, self.h_e)
        if call_law:
            self.law(t, q, qd, z, self.h_e.copy(), self.params, self.tau_c, self.zdot, self.sig)
        if self.has_dist:
            disturbance_into(setup.dist, t, q, qd, self.tau_d)
        np.clip(self.tau_c, -setup.lim, setup.lim, out=self.tau_a)
        tau_p = self.tau_a + self.tau_d if self.has_dist else self.tau_a.copy()
        status = setup.forward_dynamics(*self.plant, q, qd, tau_p, self.h_e, self.qdd)
        xdot[:n] = x[n:2 * n]
        xdot[n:2 * n] = self.qdd
        xdot[2 * n:] = z_rate * self.zdot
        return status


def _log(views, row, t, x, stage, n, k):
    views["t"][row, 0] = t
    views["q"][row] = x[:n]
    views["qd"][row] = x[n:2 * n]
    views["qdd"][row] = stage.qdd
    views["tau"][row] = stage.tau_a
    views["z"][row] = x[2 * n:]
    if views["tau_cmd"].shape[1]:
        views["tau_cmd"][row] = stage.tau_c
    if views["tau_dist"].shape[1]:
        views["tau_dist"][row] = stage.tau_d
    if views["h_e"].shape[1]:
        views["h_e"][row] = stage.h_e
    start = 0
    for view in views["sig"]:
        width = view.shape[1]
        view[row] = stage.sig[start:start + width]
        start += width


def _check(setup, plant, x, energy):
    """(status, joint) of the divergence checks of the compiled loop (``check_state``)."""
    n = setup.n
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        return 1, (int(bad[0]) % n if bad[0] < 2 * n else -1)
    outside = np.flatnonzero((x[:n] < setup.q_lo) | (x[:n] > setup.q_hi))
    if outside.size:
        return 2, int(outside[0])
    if energy and setup.kinetic_energy(*plant, x[:n].copy(), x[n:2 * n].copy()) > setup.ke_max:
        return 3, -1
    return 0, -1


def run(setup, law, params, plant, method: str, *, rtol: float, atol: float, integrator: str):
    """(status, rows, step, joint, views, wall time) of a run with the Python ``law``."""
    if method == "adaptive" and setup.sampled:
        raise SimulationError("control_period: sampled control with a Python law runs with "
                              "method='rk4' (or compile the law with numba.njit)")
    stage = _Stage(setup, law, params, plant)
    out = setup.outputs()
    views = setup.views(out)
    start = time.perf_counter()
    if method == "rk4":
        status, rows, step, joint = _rk4(setup, stage, plant, views)
    else:
        status, rows, step, joint = _adaptive(setup, stage, plant, views, rtol, atol, integrator)
    return status, rows, step, joint, views, time.perf_counter() - start


def _rk4(setup, stage, plant, views):
    n, k, dt, m = setup.n, setup.k, setup.dt, setup.x0.size
    x = setup.x0.copy()
    K = np.zeros((4, m))
    z_rate = 0.0 if setup.sampled else 1.0
    period = setup.every * dt
    rows = 0
    for j in range(setup.n_steps + 1):
        t = 0.0 + j * dt
        sample = (not setup.sampled) or (j % setup.every == 0)
        if setup.sampled and sample and j > 0:
            x[2 * n:] += period * stage.zdot
        for s in range(4):
            h = 0.0 if s == 0 else (dt if s == 3 else 0.5 * dt)
            xt = x + h * K[s - 1] if s > 0 else x.copy()
            status = stage(t + h, xt, sample if s == 0 else not setup.sampled, z_rate, K[s])
            if s == 0:
                if j % setup.log_every == 0:
                    _log(views, rows, t, x, stage, n, k)
                    rows += 1
                if status != 0:
                    return 4, rows, j, -1
                if j == setup.n_steps:
                    return 0, rows, setup.n_steps, -1
        x += dt / 6.0 * (K[0] + 2.0 * K[1] + 2.0 * K[2] + K[3])
        status, joint = _check(setup, plant, x, (j + 1) % 10 == 0)
        if status != 0:
            return status, rows, j + 1, joint
    return 0, rows, setup.n_steps, -1


def _adaptive(setup, stage, plant, views, rtol, atol, integrator):
    from scipy.integrate import solve_ivp

    xdot = np.zeros_like(setup.x0)
    grid = np.arange(setup.n_steps + 1) * setup.dt

    def rhs(t, x):
        stage(float(t), np.ascontiguousarray(x, dtype=float), True, 1.0, xdot)
        return xdot.copy()

    solution = solve_ivp(rhs, (0.0, grid[-1]), setup.x0.copy(), method=integrator, rtol=rtol, atol=atol,
                         t_eval=grid)
    xs = solution.y.T
    rows, status, step, joint = 0, 0, 0, -1
    for j, (t, x) in enumerate(zip(solution.t, xs, strict=True)):
        bad, where = _check(setup, plant, x, True)
        if bad:
            status, step, joint = bad, j, where
            break
        stage(float(t), np.ascontiguousarray(x), True, 1.0, xdot)
        if j % setup.log_every == 0:
            _log(views, rows, t, x, stage, setup.n, setup.k)
            rows += 1
    if status == 0 and solution.status != 0:
        status, step = 1, xs.shape[0]
    return status, rows, step, joint
