"""Closed-loop simulation: ``simulate(plant, controller, ...)`` → :class:`SimulationResult`.

The plant is the true :class:`~armlab.model.robot.Robot`; the controller carries its own model
(``armlab.control.base``).  The integrated system (notation table, S-tags):

    B(q) q̈ + C(q, q̇) q̇ + F_v q̇ + F_s sgn q̇ + g(q) = sat(τ) + τ_d(t, q, q̇) − Jᵀ(q) h_e      (S1)
    τ = h(t, q, q̇, z, h_e),   ż = f(t, q, q̇, z, h_e)                                       (C0)

with sat the per-joint clip at ``torque_limit`` and τ_d the disturbances of
``armlab.simulation.disturbances`` (S2).

Integrators
-----------
``method="rk4"``: fixed-step classical Runge–Kutta (Simulink's ode4, S3); the whole loop is one
compiled function (``armlab.simulation.loop``) that calls the controller's law, the
environment and the plant's dynamics through their machine addresses, so each is compiled once
and cached on disk: the first run of a new controller class compiles its law (seconds), later
runs and later processes load it.

``method="adaptive"``: SciPy's ``solve_ivp`` (DOP853 by default, error controlled by
``rtol``/``atol``) calling the *same* compiled right-hand side; the accuracy reference.
Signals are recomputed after integration on the output grid t_j = j·dt.

Logging: see ``armlab.simulation.loop`` — the RK4 loop writes row j while it integrates
(the stage-1 evaluation at (t_j, x_j)), without allocation; ``log_every`` thins the rows.

Sampled control: ``control_period`` T_c (a multiple of dt) runs the law every T_c with
zero-order hold of τ and the discrete update z ← z + T_c ż.

Divergence: a non-finite state, a joint beyond its limits by more than ``limit_margin`` × its
range, or kinetic energy above ``max_kinetic_energy`` stops the run; ``SimulationDiverged``
(with the result up to that point as ``.result``) is raised, or with
``on_divergence="return"`` the result is returned with ``status == "diverged"``.

Bounds, checked before a run starts (:data:`MAX_STEPS`, :data:`MAX_LOG_BYTES`): a run of more
than 10⁹ steps, or whose log would need more than 4 GiB, is refused with the count or the
size it would need.  The adaptive integrator takes at most ``max_steps`` solver steps
(default: :data:`ADAPTIVE_STEPS_PER_SECOND` per simulated second, at least
:data:`ADAPTIVE_MIN_STEPS`; a stiff closed loop — a huge gain — can need millions per
simulated second, minutes of wall time each): it then stops, with status ``"stopped"`` and
the data so far, as for a divergence.

Step check, before an RK4 run with continuous control: the joint-space laws' closed loop is
linearised at rest at q0 from their gains and B(q0) (``armlab.simulation.step_check``, S6);
a ``dt`` beyond RK4's reach for its fastest mode gets a ``StepSizeWarning`` naming the
largest stable step (the run would otherwise diverge in milliseconds as "joint limit exceeded").

Ctrl-C during a run stops it after the current step: ``SimulationInterrupted`` (a
``KeyboardInterrupt``) carries the result so far, ``status == "interrupted"``.  The compiled
RK4 loop runs in a worker thread and polls a flag the main thread sets (``armlab.simulation.loop``).
"""

from __future__ import annotations

import os
import time

import numpy as np

from armlab.caches import repaired
from armlab.control.base import Controller, Environment, ProtocolError, Signal
from armlab.control.entry import generated_entry
from armlab.control.function import arity, is_compiled
from armlab.errors import SimulationDiverged, SimulationError, SimulationInterrupted
from armlab.kernels.environment import FreeSpaceParams, free_space_law
from armlab.kernels.plant import make_data
from armlab.simulation import loop, loop_memory, python_loop
from armlab.simulation.disturbances import encode_disturbances
from armlab.simulation.joint_limits import _user_stacklevel, annotate, check_mode, joint_stop
from armlab.simulation.results import SimulationResult
from armlab.simulation.step_check import check_step
from armlab.simulation.stepping import BUDGET, INTERRUPTED, SOLVERS, run_interruptible, solve_stepwise
from armlab.specialise import ClosedFormUnavailable, choice_problem, closed_form_status, plant_kernels

STATUS = {1: "non-finite state", 2: "joint limit exceeded", 3: "runaway kinetic energy",
          4: "mass matrix not positive definite", 5: "interrupted", 6: "step budget exhausted"}

MAX_STEPS = 10**9
"""Most integration steps of one run (t_final / dt): about ten minutes of RK4 for a small robot."""
MAX_LOG_BYTES = 4 * 1024**3
"""Most memory of one run's log (rows × columns × 8 bytes): raise ``log_every`` beyond it."""
ADAPTIVE_STEPS_PER_SECOND, ADAPTIVE_MIN_STEPS = 10_000, 100_000
"""Default ``max_steps`` of the adaptive integrator: 10⁴ solver steps per simulated second, at
least 10⁵ (the bundled scenarios take 10–500 per second; a step costs ~0.1–1 ms of wall time)."""


# --------------------------------------------------------------------------- set-up helpers

def _per_joint(value, n: int, field: str, default: float) -> np.ndarray:
    if value is None:
        return np.full(n, default)
    array = np.atleast_1d(np.asarray(value, dtype=float))
    if array.shape not in ((1,), (n,)) or np.any(np.isnan(array)):
        raise SimulationError(f"{field}: expected a number or {n} numbers, got {value!r}")
    return np.broadcast_to(array, (n,)).astype(float)


def _divergence_limits(plant, limit_margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(q_lo, q_hi): the joint limits widened by ``limit_margin`` of their span (±∞ where a
    joint has none); new writeable arrays, the type the compiled loop was built for (~10 µs)."""
    arrays = plant.arrays
    span = arrays.q_max - arrays.q_min
    margin = np.where(np.isfinite(span), limit_margin * span, np.inf)
    return (np.where(np.isfinite(arrays.q_min), arrays.q_min - margin, -np.inf),
            np.where(np.isfinite(arrays.q_max), arrays.q_max + margin, np.inf))


def _check_start(plant, q0) -> None:
    """A start outside the joint limits is refused before the run (it would "diverge" at its
    first step): one line naming the joint, its value and its limits."""
    lo, hi = plant.arrays.q_min, plant.arrays.q_max
    outside = np.flatnonzero((q0 < lo) | (q0 > hi))
    if outside.size:
        i = int(outside[0])
        raise SimulationError(f"q0: joint {plant.joint_names[i]} = {q0[i]:g} is outside its limits "
                              f"[{lo[i]:g}, {hi[i]:g}]")


def _steps(span: float, dt: float, field: str) -> int:
    if not np.isfinite(span):
        raise SimulationError(f"{field}: must be a finite time, got {span!r}")
    if span / dt > MAX_STEPS:
        raise SimulationError(f"{field}: {span:g} s at dt = {dt:g} s is {span / dt:.3g} steps, more "
                              f"than the {MAX_STEPS:.0e} a run may take (armlab.simulation.MAX_STEPS)")
    count = int(round(span / dt))
    if count < 1 or abs(count * dt - span) > 1e-9 * max(1.0, span):
        raise SimulationError(f"{field}: {span:g} s is not a positive multiple of dt = {dt:g} s")
    return count


class _Setup:
    """Everything ``simulate`` hands to the compiled code, checked once."""

    def __init__(self, plant, controller, q0, qd0, t_final, dt, control_period, torque_limit,
                 disturbance, environment, log_every, limit_margin, max_kinetic_energy,
                 dynamics="auto", joint_limits="warn"):
        if not isinstance(controller, Controller):
            raise SimulationError(f"controller: {type(controller).__name__} is not an armlab Controller")
        n = plant.n
        if controller.n != n:
            raise SimulationError(f"controller: its model has {controller.n} joints, the plant {n}")
        self.plant, self.controller, self.environment, self.n = plant, controller, environment, n
        if not (np.isfinite(dt) and dt > 0):
            raise SimulationError(f"dt: must be a positive time step, got {dt!r}")
        self.dt = float(dt)
        self.n_steps = _steps(float(t_final), self.dt, "t_final")
        self.every = 1 if control_period is None else _steps(float(control_period), self.dt,
                                                             "control_period")
        self.sampled = control_period is not None
        if isinstance(log_every, bool) or not float(log_every).is_integer():
            raise SimulationError(f"log_every: must be a positive integer, got {log_every!r}")
        self.log_every = int(log_every)
        if self.log_every < 1:
            raise SimulationError(f"log_every: must be a positive integer, got {log_every!r}")
        q0 = _per_joint(q0, n, "q0", 0.0)
        qd0 = _per_joint(qd0, n, "qd0", 0.0)
        z0 = np.asarray(controller.initial_state(), dtype=float).ravel()
        self.x0 = np.concatenate([q0, qd0, z0])
        if not np.isfinite(self.x0).all():
            for name, part in (("q0", q0), ("qd0", qd0), ("controller initial state", z0)):
                if not np.isfinite(part).all():
                    raise SimulationError(f"{name}: must be finite, got {part.tolist()}")
        self.k = z0.shape[0]
        self.lim = _per_joint(torque_limit, n, "torque_limit", np.inf)
        if np.any(self.lim <= 0):
            raise SimulationError("torque_limit: must be positive")
        if not (np.isfinite(limit_margin) and limit_margin >= 0):
            raise SimulationError(f"limit_margin: must be a finite fraction ≥ 0, got {limit_margin!r}")
        self.q_lo, self.q_hi = _divergence_limits(plant, float(limit_margin))
        _check_start(plant, q0)
        self.ke_max = float(max_kinetic_energy)
        if not self.ke_max > 0:  # NaN would switch the divergence check off without a word
            raise SimulationError(f"max_kinetic_energy: must be positive [J], got {max_kinetic_energy!r}")
        # Joint stops (S4) act on the plant like a state-dependent disturbance term.
        self.joint_limits = check_mode(joint_limits)
        self.stop = joint_stop(plant, q0, self.dt) if self.joint_limits == "stop" else None
        terms = [] if disturbance is None else (
            [disturbance] if hasattr(disturbance, "encode") else list(disturbance))
        self.dist = encode_disturbances(terms + ([self.stop] if self.stop is not None else []), n)
        self.disturbance = disturbance
        if environment is not None and not isinstance(environment, Environment):
            raise SimulationError(f"environment: {type(environment).__name__} is not an armlab Environment")
        self.env_law = type(environment).law if environment is not None else free_space_law
        self.eparams = environment.params() if environment is not None else FreeSpaceParams()
        self.signals: tuple[Signal, ...] = tuple(controller.signals())
        self.sig_width = sum(s.width for s in self.signals)
        if choice_problem(dynamics):
            raise SimulationError(f"dynamics: {choice_problem(dynamics)}")
        try:
            self.dynamics, self.forward_dynamics, self.kinetic_energy = plant_kernels(plant, dynamics)
        except ClosedFormUnavailable as error:
            raise SimulationError(f"dynamics: {error}") from None
        # Why the numeric kernels run where a generated module was on disk (a damaged or
        # disagreeing module): recorded in the result, never silent.
        self.fallback = closed_form_status(plant) if self.dynamics == "numeric" != dynamics else ""
        law = controller.law_function()
        if arity(law, f"{type(controller).__name__}.law") != 9:
            raise ProtocolError(f"{type(controller).__name__}.law: a controller class's law takes "
                                "(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out)")
        # A law in plain Python runs in armlab.simulation.python_loop (same step, slower).
        self.python_law = None if is_compiled(law) else law
        self.law = None if self.python_law is not None else _compiled(law, f"{type(controller).__name__}.law")
        self.entry = None if self.python_law is not None else generated_entry(self.law)
        self.env_law = _compiled(self.env_law, f"{type(environment).__name__}.law")
        self.rows = self.n_steps // self.log_every + 1
        self.layout = loop_memory.log_layout([s.width for s in self.signals],
                                             cmd=bool(np.any(np.isfinite(self.lim))),
                                             dist=self.dist[0] > 0, h_e=environment is not None)

    def outputs(self, rows=None):
        """The flat log of ``rows`` rows (``loop_memory.log_views`` gives its blocks).  Every
        row the loop reports is written in full, so it need not be zeroed.  A log larger than
        :data:`MAX_LOG_BYTES` is refused with the size it would need."""
        rows = self.rows if rows is None else rows
        columns = loop_memory.log_columns(self.n, self.k, self.layout)["h_e"].stop
        size = rows * columns * 8
        if size > MAX_LOG_BYTES:
            raise SimulationError(f"log_every: the log of {rows} rows × {columns} columns would need "
                                  f"{size / 1024**3:.3g} GiB, more than {MAX_LOG_BYTES / 1024**3:g} GiB "
                                  "(armlab.simulation.MAX_LOG_BYTES): keep fewer rows (log_every; the "
                                  "adaptive method logs every dt before thinning), a larger dt or a "
                                  "shorter t_final")
        return np.empty(rows * columns)

    def views(self, out):
        return loop_memory.log_views(out, self.n, self.k, self.layout)

    def settings(self):
        fset = np.array([0.0, self.dt, self.ke_max, 0.0])  # [3]: the stop flag (Ctrl-C)
        iset = np.array([self.n, self.n_steps, self.every, self.log_every,
                         int(self.environment is not None), 10, int(self.sampled), self.sig_width,
                         *self.layout], dtype=np.int64)
        return fset, iset

    def result(self, views, rows, method, meta, status="ok", diagnosis=""):
        """The result of the first ``rows`` rows of the log blocks ``views`` (no copies: the
        arrays of the result are views of one log)."""
        o_t, o_q, o_qd, o_qdd, o_tau, o_z, o_cmd, o_dist, o_he = (
            views[name][:rows] for name in ("t", "q", "qd", "qdd", "tau", "z", "tau_cmd", "tau_dist", "h_e"))
        o_t = o_t[:, 0]
        plant, controller = self.plant, self.controller
        labels = {"q": tuple(plant.joint_names), "qd": tuple(plant.joint_names),
                  "qdd": tuple(plant.joint_names), "tau": tuple(plant.joint_names),
                  "z": _names(controller.state_labels(), self.k, "z")}
        units = {"q": Signal.joint("q", plant, "position").units,
                 "qd": Signal.joint("qd", plant, "velocity").units,
                 "qdd": Signal.joint("qdd", plant, "acceleration").units,
                 "tau": Signal.joint("tau", plant, "effort").units,
                 "z": _names(controller.state_units(), self.k, "")}
        signals = {}
        for signal, view in zip(self.signals, views["sig"], strict=True):
            signals[signal.name] = view[:rows]
            labels[signal.name], units[signal.name] = signal.labels, signal.units
        effort = Signal.joint("tau_cmd", plant, "effort")
        logged_cmd, logged_dist, logged_he = self.layout[:3]
        if logged_cmd:
            signals["tau_cmd"] = o_cmd
            labels["tau_cmd"], units["tau_cmd"] = effort.labels, effort.units
        if logged_dist:
            signals["tau_dist"] = o_dist
            labels["tau_dist"], units["tau_dist"] = effort.labels, effort.units
        if logged_he:
            signals["h_e"] = o_he
            labels["h_e"] = ("fx", "fy", "fz", "mx", "my", "mz")
            units["h_e"] = ("N",) * 3 + ("N·m",) * 3
        info = {"plant": plant.name, "controller": controller.describe(), "method": method,
                "dt": self.dt, "t_final": self.n_steps * self.dt, "dynamics": self.dynamics,
                "control_period": self.every * self.dt if self.sampled else None,
                "torque_limit": self.lim.tolist(), "log_every": self.log_every,
                "disturbance": _describe_terms(self.disturbance),
                "environment": self.environment.describe() if self.environment is not None else None}
        if self.fallback:
            info["dynamics_fallback"] = self.fallback
        info.update(meta or {})
        annotate(plant, self.joint_limits, o_t, o_q, signals, labels, units, info, self.stop, o_qd, o_tau)
        return SimulationResult(t=o_t, q=o_q, qd=o_qd, qdd=o_qdd,
                                tau=o_tau, z=o_z, signals=signals, labels=labels,
                                units=units, meta=info, status=status, diagnosis=diagnosis)

    def diagnosis(self, status, step, joint, t):
        what = STATUS.get(status, f"status {status}")
        if status == 2:
            what += (f" on joint {self.plant.joint_names[joint]} (beyond [{self.q_lo[joint]:.4g}, "
                     f"{self.q_hi[joint]:.4g}])")
        elif status == 1 and joint >= 0:
            what += f" on joint {self.plant.joint_names[joint]}"
        elif status == 3:
            what += f" (above {self.ke_max:g} J)"
        elif status == INTERRUPTED:
            return f"simulation interrupted at t = {t:.6g} s (step {step}): the data up to then is kept"
        elif status == BUDGET:
            return (f"simulation stopped at t = {t:.6g} s: {what} ({joint} solver steps; the closed "
                    "loop is stiff — smaller gains, the rk4 method, or a larger max_steps)")
        return f"simulation diverged at t = {t:.6g} s (step {step}): {what}"


def _compiled(law, what):
    """``law`` if it is a numba-compiled function (the loop calls it by address)."""
    if not (hasattr(law, "compile") and hasattr(law, "overloads")):
        raise ProtocolError(f"{what}: {law!r} is not a numba.njit function")
    return law



def _names(given, k: int, stem: str) -> tuple[str, ...]:
    """k labels (or units): the controller's if it gives k of them, else stem0, stem1, …"""
    given = tuple(given)
    if len(given) == k:
        return given
    return tuple(f"{stem}{i}" if stem else "" for i in range(k))


def _describe_terms(terms):
    if terms is None:
        return []
    terms = [terms] if hasattr(terms, "encode") else list(terms)
    return [t.describe() for t in terms]


def _finish(setup, result, status, step, joint, on_divergence):
    # Whatever the loop reported, a logged value that is not finite (NaN, ±inf) is no "ok"
    # run: it has diverged at that row, and its data stops before it.
    bad = result.first_nonfinite() if status == 0 else None
    if bad is not None:
        row, group, label = bad
        message = (f"simulation diverged at t = {float(result.t[row]):.6g} s (logged row {row}): non-finite "
                   f"{group}{'' if group == 't' else f' ({label})'}")
        result = result.head(row, status="diverged", diagnosis=message)
        if on_divergence == "return":
            return result
        raise SimulationDiverged(message, result)
    if status == 0:
        return result
    message = setup.diagnosis(status, step, joint, step * setup.dt)
    kind = {INTERRUPTED: "interrupted", BUDGET: "stopped"}.get(status, "diverged")
    result = SimulationResult(**{**vars(result), "status": kind, "diagnosis": message})
    if status == INTERRUPTED:
        raise SimulationInterrupted(message, result)      # whatever on_divergence: Ctrl-C stops
    if on_divergence == "return":
        return result
    raise SimulationDiverged(message, result)


# --------------------------------------------------------------------------- public API

def simulate(plant, controller, *, q0, qd0=None, t_final, dt, method="rk4", control_period=None,
             torque_limit=None, disturbance=None, environment=None, log_every=1,
             limit_margin=0.5, max_kinetic_energy=1e6, rtol=1e-10, atol=1e-12,
             integrator="DOP853", on_divergence="raise", dynamics="auto", joint_limits="warn",
             meta=None, max_steps=None) -> SimulationResult:
    """Simulate ``plant`` under ``controller`` from (q0, qd0) over [0, t_final].

    Parameters
    ----------
    plant : Robot — the true robot.
    controller : Controller — holds its own model of the plant (``armlab.control.base``).
    q0, qd0 : (n,) initial joint positions [m | rad] and velocities (default 0).
    t_final, dt : duration and step [s]; t_final must be a multiple of dt.
    method : "rk4" (compiled fixed step, S3) or "adaptive" (``solve_ivp`` with ``integrator``,
        ``rtol``, ``atol``; samples logged every dt).
    control_period : None (continuous control) or T_c [s], a multiple of dt (ZOH).
    torque_limit : None, a number or (n,) [N | N·m]: per-joint saturation of τ.
    disturbance : a ``TorqueDisturbance`` or a list of them (S2).
    environment : None (free space) or an ``Environment``; h_e in (S1).
    log_every : keep every m-th step in the result.
    limit_margin : a joint further than this fraction of its range outside its limits diverges.
    max_kinetic_energy : [J] bound of ½ q̇ᵀ B q̇ (checked every 10 steps).
    on_divergence : "raise" (``SimulationDiverged`` with ``.result``) or "return".
    dynamics : the plant's forward dynamics: "auto" (the robot's generated closed form if one
        is on disk already — made by an earlier "closed_form" request — else at once the
        RNEA/CRBA kernels), "closed_form" (made now if needed: Lagrange for up to 3 joints, the
        traced kernels beyond) or "numeric" (``armlab.specialise``).
    joint_limits : "warn" (default: a ``JointLimitWarning`` per joint that leaves its declared
        limits, the signal ``q_limit_excess`` and ``meta["joint_limits"]``), "stop" (the same,
        with joint stops: stiff damped unilateral springs, S4) or "ignore"
        (``armlab.simulation.joint_limits``).
    meta : extra JSON-able entries for ``result.meta`` (scenario name, …).
    max_steps : most solver steps of ``method="adaptive"`` (default: see the module); beyond
        them the run stops with ``status == "stopped"`` (raised as ``SimulationDiverged``
        unless ``on_divergence="return"``).

    Notes
    -----
    A run of more than :data:`MAX_STEPS` steps or with a log above :data:`MAX_LOG_BYTES` is
    refused before it starts.  Ctrl-C raises ``SimulationInterrupted`` with ``.result``.
    """
    if method not in ("rk4", "adaptive"):
        raise SimulationError(f"method: {method!r} is not 'rk4' or 'adaptive'")
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (np.isfinite(value) and value > 0):
            raise SimulationError(f"{name}: must be a positive tolerance, got {value!r}")
    if on_divergence not in ("raise", "return"):
        raise SimulationError(f"on_divergence: {on_divergence!r} is not 'raise' or 'return'")
    # A damaged compile cache met while setting up is discarded and rebuilt (armlab.caches).
    setup = repaired(_Setup, plant, controller, q0, qd0, t_final, dt, control_period, torque_limit,
                     disturbance, environment, log_every, limit_margin, max_kinetic_energy, dynamics,
                     joint_limits)
    if max_steps is not None and (isinstance(max_steps, bool) or not (
            isinstance(max_steps, (int, np.integer)) and max_steps >= 1)):
        raise SimulationError(f"max_steps: must be a positive integer, got {max_steps!r}")
    if method == "rk4" and not setup.sampled:
        check_step(plant, controller, setup.x0[:setup.n], setup.dt, stacklevel=_user_stacklevel(),
                   kinetic_energy=setup.kinetic_energy)
    if setup.python_law is not None:
        return _run_python(setup, meta, on_divergence, method, rtol, atol, integrator)
    if method == "rk4":
        return repaired(lambda: _run_rk4(setup, meta, on_divergence))
    if max_steps is None:
        max_steps = max(ADAPTIVE_MIN_STEPS, ADAPTIVE_STEPS_PER_SECOND * setup.n_steps * setup.dt)
    return repaired(lambda: _run_adaptive(setup, meta, on_divergence, rtol, atol, integrator,
                                          int(max_steps)))


def _run_python(setup, meta, on_divergence, method, rtol, atol, integrator):
    status, rows, step, joint, views, wall = python_loop.run(setup, setup.python_law,
                                                             setup.controller.params(),
                                                             (setup.plant.packed, make_data(setup.n)), method,
                                                             rtol=rtol, atol=atol, integrator=integrator)
    meta = {**(meta or {}), "wall_time": wall, "law": "python"}
    result = setup.result(views, rows, method, meta)
    return _finish(setup, result, status, step, joint, on_divergence)


def _run_rk4(setup, meta, on_divergence):
    fset, iset = setup.settings()
    out = setup.outputs()
    start = time.perf_counter()
    status, rows, step, joint = run_interruptible(lambda: _rk4(setup, fset, iset, out), fset,
                                                  joint_steps=setup.n_steps * setup.n)
    meta = {**(meta or {}), "wall_time": time.perf_counter() - start}
    result = setup.result(setup.views(out), rows, "rk4", meta)
    return _finish(setup, result, status, step, joint, on_divergence)


def _rk4(setup, fset, iset, out):
    fn, work, (cplain, cfunctions), (eplain, efunctions) = loop.bind(setup)
    return loop.rk4_run(loop.core_address("rk4"), fn, setup.plant.packed, cplain, cfunctions, eplain,
                        efunctions, setup.dist, setup.x0.copy(), work, fset, iset, setup.lim, setup.q_lo,
                        setup.q_hi, out)


def _run_adaptive(setup, meta, on_divergence, rtol, atol, integrator, max_steps):
    if integrator not in SOLVERS:
        raise SimulationError(f"integrator: {integrator!r} is not one of {', '.join(SOLVERS)}")
    n, width = setup.n, setup.sig_width
    fn, work, (cplain, cfunctions), (eplain, efunctions) = loop.bind(setup)
    # The parameters parked once (the addresses stay valid while these locals live).
    parked = loop.parked(cplain, cfunctions), loop.parked(eplain, efunctions)
    cp, ep = (buffer.ctypes.data for buffer in parked)
    pp = setup.plant.packed
    rhs_core, log_core = loop.core_address("rhs"), loop.core_address("log")
    has_env = setup.environment is not None
    xdot = np.zeros_like(setup.x0)
    out = setup.outputs(setup.n_steps + 1)        # first: it refuses a log that would not fit
    grid = np.arange(setup.n_steps + 1) * setup.dt
    start = time.perf_counter()

    def rhs(t, x, call_law, z_rate):
        # SciPy may hand a strided column (Radau's, BDF's numerical Jacobian); the loop
        # reads its state as contiguous float64.
        x = np.ascontiguousarray(x, dtype=float)
        loop.rhs(rhs_core, fn, float(t), x, pp, cp, ep, setup.dist, has_env, call_law, z_rate, setup.lim,
                 work, width, xdot)
        return xdot.copy()

    x = setup.x0.copy()
    rows, status, step, joint = 0, 0, 0, -1
    # Continuous control integrates [0, t_final] at once; sampled control integrates each
    # control period with τ held, after running the law at the sample.
    spans = [(0, setup.n_steps)] if not setup.sampled else [
        (i, min(i + setup.every, setup.n_steps)) for i in range(0, setup.n_steps, setup.every)]
    zdot_held = np.zeros(setup.k)
    steps_left = max_steps
    try:
        for first, last in spans:
            if setup.sampled:
                if first > 0:
                    x[2 * n:] += setup.every * setup.dt * zdot_held
                loop.rhs(rhs_core, fn, grid[first], x, pp, cp, ep, setup.dist, has_env, True, 0.0,
                         setup.lim, work, width, xdot)
                zdot_held = work[loop_memory.zdot_slice(n, setup.k)].copy()
            args = (not setup.sampled, 0.0 if setup.sampled else 1.0)
            xs, solved, used = solve_stepwise(rhs, grid[first], grid[last], x, integrator, rtol, atol,
                                      grid[first:last + 1], args, steps_left)
            steps_left -= used
            xs = np.ascontiguousarray(xs)
            # A finished span's last point is the next span's first; a stopped span keeps all.
            keep = xs.shape[0] if (last == setup.n_steps or solved != 0) else xs.shape[0] - 1
            bad, code, where = loop.check_rows(fn, pp, xs[:keep], setup.q_lo, setup.q_hi,
                                                      setup.ke_max, work)
            if bad >= 0:
                status, step, joint, keep = code, first + bad, where, bad
            loop.log_rows(log_core, fn, grid[first:first + keep],
                                 np.ascontiguousarray(xs[:keep]), pp, cplain, cfunctions, eplain, efunctions,
                                 setup.dist, has_env, not setup.sampled, setup.lim, work, setup.layout,
                                 out, rows)
            rows += keep
            if status == 0 and solved != 0:
                status, step = (1 if solved == -1 else solved), first + keep
                joint = max_steps if solved == BUDGET else -1      # the budget, for the diagnosis
            if status != 0:
                break
            x = xs[-1].copy()
    except KeyboardInterrupt:
        # Ctrl-C outside a solver step (the law at a sample, the checks, the logging): the
        # rows logged so far are kept.
        status, step, joint = INTERRUPTED, rows, -1

    def thin(view):
        return np.ascontiguousarray(view[0:rows:setup.log_every])

    thinned = {name: tuple(map(thin, view)) if name == "sig" else thin(view)
               for name, view in setup.views(out).items()}
    meta = {**(meta or {}), "wall_time": time.perf_counter() - start, "integrator": integrator,
            "rtol": rtol, "atol": atol, "solver_steps": max_steps - steps_left, "max_steps": max_steps}
    result = setup.result(thinned, thinned["t"].shape[0], "adaptive", meta)
    return _finish(setup, result, status, step, joint, on_divergence)


def simulate_batch(plant, controllers, *, q0, qd0=None, t_final, dt, torque_limit=None,
                   disturbance=None, environment=None, log_every=1, limit_margin=0.5,
                   max_kinetic_energy=1e6, workers=None, dynamics="auto", joint_limits="warn",
                   meta=None) -> list[SimulationResult]:
    """RK4 runs of many controllers (a gain sweep) in parallel on all cores.

    The compiled loop releases the GIL (``nogil``), so a thread pool of ``workers`` threads
    (default: the number of cores) runs it truly in parallel without copying anything between
    processes.  Returns one :class:`SimulationResult` per controller, in order; a diverged run
    has ``status == "diverged"`` (no exception).  Continuous control only.  The shared
    arguments are checked (with the first controller) before any run starts; a later
    controller that is not valid raises when its worker reaches it, and nothing is returned.
    """
    from concurrent.futures import ThreadPoolExecutor

    controllers = list(controllers)
    if not controllers:
        raise SimulationError("controllers: empty")

    def setup_of(controller):
        return _Setup(plant, controller, q0, qd0, t_final, dt, None, torque_limit, disturbance,
                      environment, log_every, limit_margin, max_kinetic_energy, dynamics, joint_limits)

    # The first set-up checks the shared arguments before any run starts; the others are made
    # by the workers, so that this Python work overlaps the other threads' compiled loops.
    first = setup_of(controllers[0])

    def one(index):
        setup = first if index == 0 else setup_of(controllers[index])
        fset, iset = setup.settings()
        out = setup.outputs()
        status, rows, step, joint = _rk4(setup, fset, iset, out)
        return _finish(setup, setup.result(setup.views(out), rows, "rk4", meta), status, step, joint,
                       "return")

    with ThreadPoolExecutor(max_workers=workers or os.cpu_count()) as pool:
        return list(pool.map(one, range(len(controllers))))
