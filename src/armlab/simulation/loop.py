"""Compiled closed-loop integrators: one cached loop that calls the law, the environment and the
plant through machine addresses (``armlab.kernels.boundary``).

The whole closed loop — plant forward dynamics, environment, control law (with its reference),
saturation, disturbance and the RK4 update — runs without returning to the interpreter.  The
loops (``rk4_core``, ``rhs_core``, ``log_core``) are compiled once for every controller and
robot and cached on disk like every kernel: they call the law, the environment and the
plant's kernels through their addresses, and receive the controller's and environment's
parameter tuples as stack addresses that small trampolines, compiled per tuple type, read
back.  A new controller therefore costs the compile of its own law, a trampoline and an entry
that unboxes its parameters (``rk4_run`` …), and the plant's dynamics can be any kernel with
the signature of ``armlab.kernels.plant.forward_dynamics_packed`` (the general one, or a
robot's closed form).

:func:`bind` makes the arguments of one run from the simulator's checked inputs: the
addresses, the scratch memory and the parameters as they cross, asking the controller for
its own: the simulator never touches them.

A module-level law is called through its generated entry (``armlab.control.entry``): the law
compiled inlined into a function that receives the loop's scratch array and three sizes
instead of seven arrays and the parameter tuple by value (1.3–1.5 times faster A6–A8 runs).
A law without one (not importable by name) is called by ``law_trampoline`` (of
``armlab.control.entry``) through its address.

The parameters cross into the shared functions as plain tuples (``plain_params`` of
``armlab.control.entry``), each compiled function in them beside its tuple (``crossing``, put
back by ``with_functions``: numba types a tuple holding a function item by item in Python,
0.1 ms a call); the adaptive integrator's right-hand side takes them parked once
(:func:`parked`).  numba's
disk cache keeps every signature a cached function was compiled for in one index, which it
unpickles whole on every load: one signature naming a class that another process cannot import
(the NamedTuple of a controller written in a script or a test module) would make every later
process fail to load the loop.  So the entries (``rk4_run`` …) and the two trampolines see
plain tuples, and only the law, the environment's law and a law's generated entry, cached in
their own modules, are compiled for the NamedTuple itself.  A NamedTuple and the plain tuple of
its fields have the same numba data model (memory layout and calling convention): both read
the same stack copy and take the same call.

The plant's model travels as its packed array ``pp`` (``Robot.packed``, never written) and its
data ``pd`` (the kernels' workspace) is the last block of the scratch array ``work``: arguments
made of many arrays cost compile time in every function that receives them.  ``fn`` (int64
array) holds the addresses, in this order (``FN_*``):

    law_entry(cp, law, t, work, n, k, s)       the law on the scratch views of ``work``
    law(t, q, qd, z, h_e, cparams, tau_out, zdot_out, signals_out)     (0 with an entry)
    env_trampoline(ep, env, t, R_0e, p_0e, v_e, h_e_out)
    env(t, R_0e, p_0e, v_e, eparams, h_e_out)
    forward_dynamics(pp, pd, q, qd, tau, h_e, qdd_out) -> 0 ok | 1 bad length | 2 B not PD
    kinetic_energy(pp, pd, q, qd) -> T
    measure(pp, q, qd, work, R_0e, p_0e, v_e)
    disturbance(dist, t, q, qd, tau_d_out)               (``armlab.simulation.disturbances``)

The scratch memory is one flat array ``work`` and the log one flat array ``out`` of R rows,
laid out by ``armlab.simulation.loop_memory``.

State x = [q (n); q̇ (n); z (k)].  One right-hand-side evaluation (``stage``):

    h_e = env(t, T_0e(q), J(q) q̇)                      (plant kinematics; 0 without environment)
    τ, ż = law(t, q, q̇, z, h_e)                        (held between samples under sampled control)
    τ_a = sat(τ) = clip(τ, −τ_max, τ_max)
    q̈ = B⁻¹(q) (τ_a + τ_d(t, q, q̇) − C q̇ − F_v q̇ − F_s sgn q̇ − g − Jᵀ h_e)           (S1, S2)
    ẋ = [q̇; q̈; ż]   (ż replaced by 0 under sampled control)

Fixed-step RK4 (Simulink's ode4): x_{j+1} = x_j + dt/6 (k₁ + 2k₂ + 2k₃ + k₄)              (S3)

Logging: row j of the outputs holds x_j and the quantities of stage k₁ at (t_j, x_j) — the
applied torque, q̈, the controller's signals — written straight into preallocated arrays
(no allocation, no second pass).  ``log_every`` keeps every m-th step.

Sampled control (period T_c = ``every`` · dt): at t_j = i T_c the law runs once on the
measured state; τ and the logged signals are held (zero-order hold) until the next sample,
and the controller state follows the discrete update z_{i+1} = z_i + T_c ż_i (forward Euler,
applied at the next sample).

Divergence checks after every step: a non-finite state (status 1), a joint beyond its
limits by more than its margin (2), kinetic energy ½ q̇ᵀ B q̇ above a bound (3, checked every
``energy_every`` steps), a mass matrix that is not positive definite (4).  The loop stops at
the first failure and reports the step and the joint.

Stopping from outside (Ctrl-C): the loop reads ``fset[3]`` after every step and stops with
status 5 once it is not 0.  The simulator runs the loop in a worker thread (it releases the
GIL) and sets that entry when the main thread receives SIGINT; the data up to the last step
is then kept as for a diverged run.  The flag is read through the same pointer as the other
settings after calls through function addresses, which the compiler cannot see into, so the
read is never hoisted out of the loop; it costs one load and compare per step.
"""

from __future__ import annotations

import numpy as np
from numba import TypingError, njit, typeof, types

from armlab.control.entry import (
    check_params,
    compile_problem,
    crossing,
    is_compiled_function,
    law_entry_types,
    law_trampoline,
    plain_params,
)
from armlab.errors import ProtocolError
from armlab.kernels.boundary import (
    borrowed,
    buffer_view,
    call_float,
    call_int,
    call_none,
    call_status,
    kernel_address,
    park,
    stack_address,
    with_functions,
)
from armlab.kernels.environment import FreeSpaceParams, free_space_law
from armlab.kernels.plant import forward_dynamics_packed, kinetic_energy_packed, measure_packed
from armlab.simulation.disturbances import disturbance_into
from armlab.simulation.loop_memory import log_offsets, log_row, plant_data, scratch_views, work_size

(FN_LAW_ENTRY, FN_LAW, FN_ENV_TRAMPOLINE, FN_ENV, FN_FORWARD_DYNAMICS, FN_KINETIC_ENERGY,
 FN_MEASURE, FN_DISTURBANCE) = range(8)

loop_kernel = njit(cache=True, nogil=True)


_VEC = types.float64[::1]
_MAT = types.float64[:, ::1]
_F64 = types.float64
_I64 = types.int64
_IVEC = types.int64[::1]


@njit(cache=True)
def env_trampoline(ep, env, t, R_0e, p_0e, v_e, h_e_out):
    """The environment law at ``env`` called with the parameter tuple at ``ep``."""
    R_0e, p_0e, v_e, h_e_out = borrowed((R_0e, p_0e, v_e, h_e_out))
    call_none(env, (t, R_0e, p_0e, v_e, borrowed(ep[0]), h_e_out))


def _type_key(value):
    """A cheap stand-in for ``numba.typeof(value)`` of a parameter tuple (which costs ~0.1 ms):
    equal keys mean equal numba types.  Arrays, (named) tuples, floats, bools and int64-range
    ints are keyed by what decides their numba type, a compiled function by itself (the key
    keeps it alive, so its identity is never reused); anything else by ``typeof`` itself."""
    kind = type(value)
    if kind is np.ndarray:
        return (value.dtype, value.ndim, value.flags.c_contiguous, value.flags.f_contiguous,
                value.flags.writeable, value.flags.aligned)
    if isinstance(value, tuple):
        return (kind, tuple(_type_key(v) for v in value))
    if kind is float or kind is bool or (kind is int and -2**63 <= value < 2**63):
        return kind
    if is_compiled_function(value):
        return (kind, value)    # one function, one type (typeof: ~8 µs a function)
    return typeof(value)


_FN: dict = {}


def addresses(law, env_law, cparams, eparams, forward_dynamics=None, kinetic_energy=None, entry=None,
              has_env=True, has_dist=True):
    """The ``fn`` array for a loop with these parameters (compiles what is missing; remembered
    per law, entry, environment, plant kernels and parameter types).

    The argument types are those ``stage`` passes; ``forward_dynamics`` and ``kinetic_energy``
    default to the general kernels of ``armlab.kernels.plant``; ``entry`` is the law's
    generated entry (the law inlined, see the module docstring), None for ``law_trampoline``.
    A loop run without an environment (``has_env`` False) or without disturbances
    (``has_dist`` False) never calls the kinematics and the environment's law, or the
    disturbance kernel: their slots hold 0 and they are not compiled (several seconds with
    empty caches)."""
    key = (law, entry, env_law, forward_dynamics, kinetic_energy, _type_key(cparams),
           _type_key(eparams), bool(has_env), bool(has_dist))
    fn = _FN.get(key)
    if fn is None:
        fn = _FN[key] = _addresses(law, env_law, cparams, eparams, forward_dynamics, kinetic_energy,
                                   entry, bool(has_env), bool(has_dist))
    return fn


def bind(setup, cparams=None, eparams=None):
    """``(fn, work, (cplain, cfunctions), (eplain, efunctions))``: what the loop's entries take
    for one run of ``setup`` (the checked inputs of ``armlab.simulate``) besides its model and
    settings: the addresses (:func:`addresses`), fresh scratch memory (``loop_memory.work_size``) and
    the controller's and the environment's parameters as they cross (``crossing`` of
    ``armlab.control.entry``).  ``cparams`` and ``eparams`` default to the controller's
    ``params()`` and the environment's; a batch passes its thread's own copies.  Parameters
    the compiled loop cannot take, or a law that does not compile for them, raise a
    :class:`~armlab.errors.ProtocolError` of one line."""
    name = type(setup.controller).__name__
    if setup.python_law is not None:
        raise ProtocolError(f"{name}.law: a Python law runs with simulate; simulate_batch needs it "
                            "compiled (numba.njit)")
    cparams = setup.controller.params() if cparams is None else cparams
    eparams = setup.eparams if eparams is None else eparams
    check_params(cparams, f"{name}.params()")
    try:
        fn = addresses(setup.law, setup.env_law, cparams, eparams, setup.forward_dynamics,
                       setup.kinetic_energy, setup.entry, has_env=setup.environment is not None,
                       has_dist=bool(setup.dist[0] > 0))
    except TypingError as error:
        raise ProtocolError(compile_problem(name, error)) from None
    work = np.zeros(work_size(setup.n, setup.k, setup.sig_width))
    return fn, work, crossing(cparams), crossing(eparams)


def compile_shared() -> None:
    """Compile what every loop shares, whatever the controller: the three loops, the plant's
    kinematics (``measure_packed``), the disturbances and the general plant kernels (a process
    that starts many simulations can build these while another builds the dynamics,
    ``armlab.warmup``)."""
    for name in _CORES:
        core_address(name)
    kernel_address(measure_packed, (_VEC, _VEC, _VEC, _VEC, _MAT, _VEC, _VEC), types.none)
    kernel_address(disturbance_into, (_VEC, _F64, _VEC, _VEC, _VEC), types.none)
    # A run without an environment: FreeSpace's law and (empty) parameters.
    free = FreeSpaceParams()
    kernel_address(env_trampoline, (types.CPointer(typeof(plain_params(free))), _I64, _F64, _MAT, _VEC,
                                    _VEC, _VEC), types.none)
    kernel_address(free_space_law, (_F64, _MAT, _VEC, _VEC, typeof(free), _VEC), types.none)


def _addresses(law, env_law, cparams, eparams, forward_dynamics, kinetic_energy, entry, has_env,
               has_dist):
    vec, mat, f64, none = _VEC, _MAT, _F64, types.none
    ctype, etype = typeof(cparams), typeof(eparams)
    cplain, eplain = typeof(plain_params(cparams)), typeof(plain_params(eparams))
    fd = forward_dynamics_packed if forward_dynamics is None else forward_dynamics
    ke = kinetic_energy_packed if kinetic_energy is None else kinetic_energy
    # An entry has the law inlined: the law itself is then never called by address.
    own = entry is not None
    fn = np.zeros(8, dtype=np.int64)
    fn[FN_LAW_ENTRY] = (kernel_address(entry, law_entry_types(ctype), none) if own else
                        kernel_address(law_trampoline, law_entry_types(cplain), none))
    fn[FN_LAW] = 0 if own else kernel_address(law, (f64, vec, vec, vec, vec, ctype, vec, vec, vec), none)
    fn[FN_FORWARD_DYNAMICS] = kernel_address(fd, (vec,) * 7, _I64)
    if has_env:
        fn[FN_ENV_TRAMPOLINE] = kernel_address(env_trampoline, (types.CPointer(eplain), _I64, f64, mat, vec,
                                                                vec, vec), none)
        fn[FN_ENV] = kernel_address(env_law, (f64, mat, vec, vec, etype, vec), none)
        fn[FN_MEASURE] = kernel_address(measure_packed, (vec, vec, vec, vec, mat, vec, vec), none)
    if has_dist:
        fn[FN_DISTURBANCE] = kernel_address(disturbance_into, (vec, f64, vec, vec, vec), none)
    fn[FN_KINETIC_ENERGY] = kernel_address(ke, (vec,) * 4, f64)
    return fn


@njit(cache=True, inline="always")
def stage(fn, t, x, n, pp, cp, ep, dist, has_env, call_law, z_rate, lim, sc, xdot, work):
    """ẋ at (t, x) (S1, S2); returns the forward-dynamics status (0 ok, 2 B not PD)."""
    q, qd, z, tau_c, tau_a, tau_d, tau_p, h_e, zdot, sig, Re, pe, ve, qdd = sc[:14]
    k = z.shape[0]
    for i in range(n):
        q[i] = x[i]
        qd[i] = x[n + i]
    for i in range(k):
        z[i] = x[2 * n + i]
    if has_env:
        call_none(fn[FN_MEASURE], (pp, q, qd, sc[16], Re, pe, ve))
        call_none(fn[FN_ENV_TRAMPOLINE], (ep, fn[FN_ENV], t, Re, pe, ve, h_e))
    if call_law:
        call_none(fn[FN_LAW_ENTRY], (cp, fn[FN_LAW], t, work, n, k, sig.shape[0]))
    # Few, fused loops: with n read at run time each loop of a few joints costs a few ns, and
    # this runs four times per step.  τ_d is not written without disturbances (nor logged).
    has_dist = dist[0] > 0.0
    if has_dist:
        call_none(fn[FN_DISTURBANCE], (dist, t, q, qd, tau_d))
    for i in range(n):
        value = tau_c[i]
        if value > lim[i]:
            value = lim[i]
        elif value < -lim[i]:
            value = -lim[i]
        tau_a[i] = value
        tau_p[i] = value + tau_d[i] if has_dist else value
    status = call_int(fn[FN_FORWARD_DYNAMICS], (pp, sc[17], q, qd, tau_p, h_e, qdd))
    for i in range(n):
        xdot[i] = x[n + i]
        xdot[n + i] = qdd[i]
    for i in range(k):
        xdot[2 * n + i] = z_rate * zdot[i]
    return status


@njit(cache=True, inline="always")
def check_state(fn, pp, pd, x, n, q_lo, q_hi, ke_max, check_energy, q, qd):
    """(status, joint) of the divergence checks on x (0 when fine); q, qd scratch, pd the
    plant's data."""
    for i in range(x.shape[0]):
        if not np.isfinite(x[i]):
            return 1, (i % n if i < 2 * n else -1)
    for i in range(n):
        if x[i] < q_lo[i] or x[i] > q_hi[i]:
            return 2, i
    if check_energy:
        for i in range(n):
            q[i] = x[i]
            qd[i] = x[n + i]
        if call_float(fn[FN_KINETIC_ENERGY], (pp, pd, q, qd)) > ke_max:
            return 3, -1
    return 0, -1


@loop_kernel
def rk4_core(fn, pp, cp, ep, dist, x, work, fset, iset, lim, q_lo, q_hi, out):
    """Fixed-step RK4 closed loop (S3).  Returns (status, rows written, step, joint).

    cp, ep: stack addresses of the controller's and environment's parameter tuples;
    fset = [t0, dt, ke_max, stop] (stop ≠ 0: return status 5 after the current step, see the
    module); iset = [n, n_steps, every, log_every, has_env, energy_every,
    sampled, signal columns, then the log's layout (``loop_memory.log_row``)]; x (m,) the initial
    state (overwritten); ``work`` scratch.
    """
    fn, pp, dist, x, work, fset, iset, lim, q_lo, q_hi, out = borrowed(
        (fn, pp, dist, x, work, fset, iset, lim, q_lo, q_hi, out))
    t0, dt, ke_max = fset[0], fset[1], fset[2]
    n, n_steps, every, log_every = iset[0], iset[1], iset[2], iset[3]
    has_env, energy_every, sampled = iset[4] != 0, iset[5], iset[6] != 0
    m = x.shape[0]
    k = m - 2 * n
    sc = scratch_views(work, n, k, iset[7])
    layout = iset[8:]
    at = log_offsets(n, k, iset[7], out, layout)
    zdot, xt, K = sc[8], sc[14], sc[15]
    z_rate = 0.0 if sampled else 1.0
    period = every * dt
    rows = 0
    for j in range(n_steps + 1):
        t = t0 + j * dt
        sample = (not sampled) or (j % every == 0)
        if sampled and sample and j > 0:
            for i in range(k):
                x[2 * n + i] += period * zdot[i]
        # One call site of ``stage`` for the four RK4 stages keeps the compiled code small.
        for s in range(4):
            if s == 0:
                h = 0.0
            elif s == 3:
                h = dt
            else:
                h = 0.5 * dt
            for i in range(m):
                xt[i] = x[i] + h * K[s - 1, i] if s > 0 else x[i]
            status = stage(fn, t + h, xt, n, pp, cp, ep, dist, has_env,
                           sample if s == 0 else not sampled, z_rate, lim, sc, K[s], work)
            if s == 0:
                if j % log_every == 0:
                    log_row(rows, t, x, n, sc, out, layout, at)
                    rows += 1
                if status != 0:
                    return 4, rows, j, -1
                if j == n_steps:
                    return 0, rows, n_steps, -1
        for i in range(m):
            x[i] += dt / 6.0 * (K[0, i] + 2.0 * K[1, i] + 2.0 * K[2, i] + K[3, i])
        status, joint = check_state(fn, pp, sc[17], x, n, q_lo, q_hi, ke_max,
                                    (j + 1) % energy_every == 0, sc[0], sc[1])
        if status != 0:
            return status, rows, j + 1, joint
        if fset[3] != 0.0:
            return 5, rows, j + 1, -1
    return 0, rows, n_steps, -1


@loop_kernel
def rhs_core(fn, t, x, pp, cp, ep, dist, has_env, call_law, z_rate, lim, work, sig_width, xdot):
    """ẋ for the adaptive integrator: the same ``stage`` as the RK4 loop; returns its status.
    ż of the last call is left in ``work`` (``loop_memory.zdot_slice``)."""
    fn, x, pp, dist, lim, work, xdot = borrowed((fn, x, pp, dist, lim, work, xdot))
    n = int(pp[0])
    sc = scratch_views(work, n, x.shape[0] - 2 * n, sig_width)
    return stage(fn, t, x, n, pp, cp, ep, dist, has_env, call_law, z_rate, lim, sc, xdot, work)


@loop_kernel
def check_rows(fn, pp, xs, q_lo, q_hi, ke_max, work):
    """(row, status, joint) of the first row of xs failing the divergence checks (row −1 if none)."""
    fn, pp, xs, q_lo, q_hi, work = borrowed((fn, pp, xs, q_lo, q_hi, work))
    n = int(pp[0])
    q = buffer_view(work, 0, n, np.float64)
    qd = buffer_view(work, n, n, np.float64)
    pd = plant_data(work, n)
    for r in range(xs.shape[0]):
        status, joint = check_state(fn, pp, pd, xs[r], n, q_lo, q_hi, ke_max, True, q, qd)
        if status != 0:
            return r, status, joint
    return -1, 0, -1


@loop_kernel
def log_core(fn, ts, xs, pp, cp, ep, dist, has_env, call_law, lim, work, layout, out, start):
    """Stage k₁ at every (ts[r], xs[r]) logged into rows start + r (used after solve_ivp);
    ``layout`` of the log as in ``loop_memory.log_row``."""
    fn, ts, xs, pp, dist, lim, work, layout, out = borrowed(
        (fn, ts, xs, pp, dist, lim, work, layout, out))
    n = int(pp[0])
    k = xs.shape[1] - 2 * n
    s = layout[3:].sum()
    sc = scratch_views(work, n, k, s)
    at = log_offsets(n, k, s, out, layout)
    xdot = sc[15][0]
    for r in range(ts.shape[0]):
        stage(fn, ts[r], xs[r], n, pp, cp, ep, dist, has_env, call_law, 1.0, lim, sc, xdot, work)
        log_row(start + r, ts[r], xs[r], n, sc, out, layout, at)


_CORE_TYPES = {
    "rk4": (_IVEC, _VEC, _I64, _I64, _VEC, _VEC, _VEC, _VEC,
            _IVEC, _VEC, _VEC, _VEC, _VEC),
    "rhs": (_IVEC, _F64, _VEC, _VEC, _I64, _I64, _VEC, types.boolean,
            types.boolean, _F64, _VEC, _VEC, _I64, _VEC),
    "log": (_IVEC, _VEC, _MAT, _VEC, _I64, _I64, _VEC, types.boolean,
            types.boolean, _VEC, _VEC, _IVEC, _VEC, _I64),
}
_CORES = {"rk4": rk4_core, "rhs": rhs_core, "log": log_core}
_CORE_RETURNS = {"rk4": types.UniTuple(types.int64, 4), "rhs": types.int64, "log": types.none}


def core_address(name: str) -> int:
    """Address of the loop ``name`` ("rk4", "rhs" or "log"), for the entries below."""
    return kernel_address(_CORES[name], _CORE_TYPES[name], _CORE_RETURNS[name])  # same tuples: fast


# Entries: compiled per (controller, environment) parameter types, they only unbox the
# parameters, put them on the stack and call the shared loop.  ``nogil`` lets gain sweeps run
# on all cores.  Everything the loop receives is ``borrowed``: the caller (Python) keeps the
# arrays alive for the whole call, so the loop, the laws and the kernels handle them without
# numba's reference counting (an atomic increment and decrement for every array taken out of
# a tuple or passed on: five times the run time of a small robot).
@loop_kernel
def rk4_run(core, fn, pp, cparams, cfunctions, eparams, efunctions, dist, x, work, fset, iset, lim, q_lo,
            q_hi, out):
    """:func:`rk4_core` on these parameters (each tuple with its functions beside it,
    ``armlab.control.entry.crossing``): (status, rows written, step, joint)."""
    cp = stack_address(with_functions(borrowed(cparams), cfunctions))
    ep = stack_address(with_functions(borrowed(eparams), efunctions))
    return call_status(core, borrowed((fn, pp, cp, ep, dist, x, work, fset, iset, lim, q_lo, q_hi, out)))


@loop_kernel
def park_params(params, functions, buffer):
    """``boundary.park`` of the parameter tuple as the law sees it (as :func:`rk4_run` takes
    ``params`` and ``functions``) into ``buffer``: the bytes it takes."""
    return park(with_functions(borrowed(params), functions), buffer)


def parked(params, functions) -> np.ndarray:
    """The bytes of the parameter tuple as the law sees it (:func:`park_params`), whose address
    :func:`rhs` takes; valid while ``params`` and ``functions`` live."""
    buffer = np.empty(park_params(params, functions, np.empty(0, dtype=np.uint8)), dtype=np.uint8)
    park_params(params, functions, buffer)
    return buffer


@loop_kernel
def rhs(core, fn, t, x, pp, cp, ep, dist, has_env, call_law, z_rate, lim, work, sig_width, xdot):
    """:func:`rhs_core` with the controller's and environment's parameters at the addresses
    ``cp`` and ``ep`` (:func:`parked`): the adaptive integrator calls it from Python at every
    stage, and numba types and unboxes only numbers and arrays (one compiled version for every
    law; with the parameters and their functions passed, 42 µs a call of the A7 law's)."""
    return call_int(core, borrowed((fn, t, x, pp, cp, ep, dist, has_env, call_law, z_rate, lim, work,
                                    sig_width, xdot)))


@loop_kernel
def log_rows(core, fn, ts, xs, pp, cparams, cfunctions, eparams, efunctions, dist, has_env, call_law, lim,
             work, layout, out, start):
    """:func:`log_core` on these parameters (as :func:`rk4_run` takes them)."""
    cp = stack_address(with_functions(borrowed(cparams), cfunctions))
    ep = stack_address(with_functions(borrowed(eparams), efunctions))
    call_none(core, borrowed((fn, ts, xs, pp, cp, ep, dist, has_env, call_law, lim, work, layout, out,
                              start)))


@loop_kernel
def rk4_batch(core, fn, cparams, cfunctions, eparams, efunctions, targets, bases, work, fset, iset, q_lo,
              q_hi, x, patch_target, patch_offset, patch_column, values, logs, ends):
    """:func:`rk4_core` once per row r of ``values`` (``armlab.sweep.rollout``): the flat inputs
    ``targets`` = (controller parameters, environment parameters, the plant's model, x(0), torque
    limits, disturbance) restored from ``bases``, run r's numbers written into them
    (``targets[patch_target[p]][patch_offset[p]] = values[r, patch_column[p]]``; the parameter
    tuples view the first two), the scratch zeroed, then the loop logged into ``logs[r]``;
    ``ends[r]`` = (status, rows written, step, joint).  One call for a chunk of runs, the GIL
    released throughout."""
    cp = stack_address(with_functions(borrowed(cparams), cfunctions))
    ep = stack_address(with_functions(borrowed(eparams), efunctions))
    for r in range(values.shape[0]):
        for b in range(len(targets)):
            target, base = targets[b], bases[b]
            for i in range(target.shape[0]):
                target[i] = base[i]
        for p in range(patch_target.shape[0]):
            targets[patch_target[p]][patch_offset[p]] = values[r, patch_column[p]]
        for i in range(work.shape[0]):
            work[i] = 0.0
        x0 = targets[3]
        for i in range(x.shape[0]):
            x[i] = x0[i]
        status = call_status(core, borrowed((fn, targets[2], cp, ep, targets[5], x, work, fset, iset,
                                             targets[4], q_lo, q_hi, logs[r])))
        for i in range(4):
            ends[r, i] = status[i]
