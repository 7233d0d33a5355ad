"""Joint-space dynamics of a serial robot (public API over the compiled kernels).

The plant, with every term of the robot description (``docs/notation.md``, section Dynamics):

    B(q) q̈ + C(q, q̇) q̇ + F_v q̇ + F_s sgn(q̇) + g(q) = τ − Jᵀ(q) h_e                     (D1)

B includes the motor rotors (reflected inertia k_r² I_m and their coupling with the link that
carries them, Siciliano et al. §7.2), C is the Christoffel-symbol matrix (Ḃ − 2C is
skew-symmetric), h_e = [f_e; μ_e] is the wrench the end effector exerts on the environment,
in Σ_0, with μ_e about Σ_e's origin.  Units SI; q̇ [m/s | rad/s], τ [N | N·m].

Each function is a thin, checked wrapper of a compiled kernel of
:mod:`armlab.kernels.dynamics`; compiled code calls those kernels directly, or through their
addresses over a packed robot (``armlab.kernels.plant``, the simulation loop).
Every call returns a new array (never one shared with another call).

Why the wrappers look the way they do (one call costs about a microsecond, so the Python side
matters as much as the arithmetic):

* the robot travels as **one** float64 array (its packed model, a scratch workspace and a zero
  wrench, see :func:`_pack`), kept in the robot's instance dictionary: unboxing an array
  argument costs ~0.1 µs, and the robot and workspace hold 35 arrays;
* each compiled entry has **one** signature (writeable, C-contiguous float64 vectors) and may
  not compile another: the numba dispatcher's type check is then the whole input check of
  the common call, and any other input (a list, another dtype or layout, a read-only array)
  raises ``TypeError`` there, is converted (with a one-line error naming the field when it
  cannot be) and tried again.  Wrong lengths are caught inside the entry, which returns a
  status instead of touching memory.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from armlab.errors import ArmlabError
from armlab.kernels.dynamics import (
    coriolis_matrix_into,
    forward_dynamics_into,
    gravity_into,
    mass_matrix_into,
    rnea_into,
)
from armlab.kernels.energy import potential_energy_kernel
from armlab.kernels.indirect import COMPILE_LOCK
from armlab.kernels.plant import (
    forward_dynamics_packed,
    kinetic_energy_packed,
    pack_plant,
    unpack_plant,
)
from armlab.model.robot import Robot

_CACHE_KEY = "_dynamics_packed"


class SingularInertiaError(ArmlabError):
    """B(q) is not positive definite (a link without mass moved by a joint)."""


def _pack(robot: Robot):
    """(packed, n) of ``robot`` (``armlab.kernels.plant``), made once and kept in the robot's
    instance dictionary next to ``robot.arrays`` (a plain attribute lookup; a weak-key
    dictionary costs more than the dynamics of a small arm).  The model part depends only on
    the immutable robot; every kernel writes the scratch it reads first, so sharing the
    workspace between calls (serialised by the GIL, which the kernels keep) cannot change a
    result."""
    cached = robot.__dict__.get(_CACHE_KEY)
    if cached is None:
        packed = pack_plant(robot.arrays)
        cached = robot.__dict__[_CACHE_KEY] = (packed, int(packed[0]))
    return cached


def packed_copy(robot: Robot) -> np.ndarray:
    """A private copy of ``robot``'s packed array (``armlab.kernels.plant``), for compiled code
    that uses its workspace, e.g. one simulation of a parallel sweep."""
    return _pack(robot)[0].copy()


_unpack = unpack_plant


_V = types.float64[::1]
_M = types.float64[:, ::1]


def _entry(*argtypes):
    """A compiled Python entry point with exactly one signature, compiled (or loaded from the
    disk cache) at its first call; see the module docstring."""
    def wrap(function):
        # A kernel shared with compiled callers (armlab.kernels.plant) is used as it is.
        dispatcher = function if hasattr(function, "py_func") else njit(cache=True, _nrt=False)(function)
        # What disable_compile() sets; it refuses a dispatcher without a signature yet.
        with COMPILE_LOCK:
            dispatcher._can_compile = False
            dispatcher.signature = argtypes
        return dispatcher
    return wrap


def _ready(dispatcher) -> None:
    """Compile an entry's one signature (once; other signatures compiled for compiled callers
    do not count).  Under the lock ``kernel_address`` takes to lift the same compile ban:
    threads of a sweep may meet here."""
    if dispatcher.signature not in dispatcher.overloads:
        with COMPILE_LOCK:
            if dispatcher.signature not in dispatcher.overloads:
                dispatcher.disable_compile(False)
                dispatcher.compile(dispatcher.signature)
                dispatcher.disable_compile()


@_entry(_V, _V, _V, _V, _V)
def _rnea_fast(packed, q, qd, qdd, out):
    n, m, ws, zero_wrench = _unpack(packed)
    if q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n:
        return False
    rnea_into(m, ws, q, qd, qdd, 1.0, zero_wrench, out)
    return True


@_entry(_V, _V, _V, _V, types.float64, _V, _V)
def _rnea_full(packed, q, qd, qdd, gravity_scale, h_e, out):
    n, m, ws, _ = _unpack(packed)
    if (q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or h_e.shape[0] != 6
            or out.shape[0] != n):
        return False
    rnea_into(m, ws, q, qd, qdd, gravity_scale, h_e, out)
    return True


@_entry(_V, _V, _M)
def _mass_matrix_entry(packed, q, out):
    n, m, ws, _ = _unpack(packed)
    if q.shape[0] != n or out.shape[0] != n or out.shape[1] != n:
        return False
    mass_matrix_into(m, ws, q, out)
    return True


@_entry(_V, _V, _V)
def _gravity_entry(packed, q, out):
    n, m, ws, _ = _unpack(packed)
    if q.shape[0] != n or out.shape[0] != n:
        return False
    gravity_into(m, ws, q, out)
    return True


@_entry(_V, _V, _V, _M)
def _coriolis_entry(packed, q, qd, out):
    n, m, ws, _ = _unpack(packed)
    if q.shape[0] != n or qd.shape[0] != n or out.shape[0] != n or out.shape[1] != n:
        return False
    coriolis_matrix_into(m, ws, q, qd, out)
    return True


_forward_entry = _entry(_V, _V, _V, _V, _V, _V)(forward_dynamics_packed)


@_entry(_V, _V, _V, _V, _V)
def _forward_free(packed, q, qd, tau, qdd_out):
    """Forward dynamics without a wrench (the packed zero wrench: slicing it out of ``packed``
    in Python cost a fifth of a PRP call); statuses of ``forward_dynamics_packed``, whose
    entry may not compile (so it is not called here)."""
    n, m, ws, zero_wrench = _unpack(packed)
    if q.shape[0] != n or qd.shape[0] != n or tau.shape[0] != n or qdd_out.shape[0] != n:
        return 1
    return 0 if forward_dynamics_into(m, ws, q, qd, tau, zero_wrench, qdd_out) else 2


_kinetic_entry = _entry(_V, _V, _V)(kinetic_energy_packed)


@_entry(_V, _V)
def _potential_entry(packed, q):
    """U, or NaN for a wrong length (told apart by the caller)."""
    n, m, ws, _ = _unpack(packed)
    if q.shape[0] != n:
        return np.nan
    return potential_energy_kernel(m, ws, q)


NUMERIC = "numeric"
# Where a robot keeps the Python entries of its generated module, per ``dynamics`` choice.
_CLOSED_FORM_KEYS = {"auto": "_dynamics_entries_auto", "closed_form": "_dynamics_entries_closed_form"}


class _ProcessLocal(tuple):
    """Compiled entries kept on a robot, valid in this process only: a pickled robot carries
    None in their place and finds them again when it needs them."""

    def __reduce__(self):
        return (type(None), ())


def _closed_form(robot: Robot, dynamics: str):
    """(inverse, mass, forward, zero wrench): Python entries of the module ``dynamics`` ("auto"
    or "closed_form") chooses for ``robot`` (``armlab.closed_form``: generated, compiled and
    checked on first use) and a wrench of zeros; False when the choice runs the numeric
    kernels.  Kept in the robot's instance dictionary, like the packed robot."""
    if type(dynamics) is str and dynamics == NUMERIC:
        return False
    key = _CLOSED_FORM_KEYS.get(dynamics) if type(dynamics) is str else None
    if key is None:
        from armlab.closed_form import DYNAMICS_CHOICES

        raise ValueError(f"dynamics: {dynamics!r} is not one of {', '.join(DYNAMICS_CHOICES)}")
    entries = robot.__dict__.get(key)
    if entries is None:
        from armlab.closed_form import chosen_module

        module = chosen_module(robot, dynamics)
        entries = False if module is None else _ProcessLocal((
            _python_entry(module.checked_inverse_dynamics, (_V,) * 5),
            _python_entry(module.mass_matrix, (_V, _V, _M)),
            _python_entry(module.forward_dynamics, (_V,) * 6), np.zeros(6)))
        robot.__dict__[key] = entries
    return entries


def _python_entry(dispatcher, argtypes):
    """A generated kernel as a Python entry point of one signature (:func:`_entry`), compiled
    now; compiled callers keep theirs (``kernel_address`` compiles what they need)."""
    entry = _entry(*argtypes)(dispatcher)
    _ready(entry)
    return entry


def _vector(robot: Robot, value, name: str, size: int | None = None) -> np.ndarray:
    """``value`` as a writeable C-contiguous float64 vector of the expected length (copied
    unless it already is one), or a one-line ValueError naming the field."""
    size = robot.n if size is None else size
    if not (type(value) is np.ndarray and value.dtype == np.float64 and value.flags.c_contiguous
            and value.flags.writeable):
        try:
            value = np.array(value, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise ValueError(f"{name} must be a vector of {size} numbers: {error}") from None
    if value.shape != (size,):
        what = "= [f_e; μ_e]" if name == "h_e" else f"for robot {robot.name!r}"
        raise ValueError(f"{name} must have shape ({size},) {what}, got {value.shape}")
    return value


def _vectors(robot: Robot, **named) -> list[np.ndarray]:
    return [_vector(robot, value, name, 6 if name == "h_e" else None) for name, value in named.items()]


def inverse_dynamics(robot: Robot, q, qd, qdd, h_e=None, gravity: bool = True,
                     dynamics: str = NUMERIC) -> np.ndarray:
    """Joint forces τ (n,) [N | N·m] that produce q̈ at (q, q̇) under (D1), by recursive
    Newton–Euler (Siciliano et al. §7.5), motors and friction included.

        τ = B(q) q̈ + C(q, q̇) q̇ + F_v q̇ + F_s sgn(q̇) + g(q) + Jᵀ(q) h_e                   (D1)

    Parameters
    ----------
    q, qd, qdd : (n,) joint positions, velocities, accelerations [m | rad, /s, /s²].
    h_e : (6,) or None, wrench [f_e; μ_e] the end effector exerts on the environment, in Σ_0
        [N, N·m], μ_e about Σ_e's origin; None for free motion.
    gravity : include g(q) (False: g_0 = 0).
    dynamics : "numeric" (the general compiled kernels), "closed_form" (the robot's generated
        module, ``armlab.closed_form``: made once per robot and machine, several times faster
        per call) or "auto" (the generated module up to ``AUTO_MAX_JOINTS`` joints).  The
        generated module serves calls without h_e and with gravity; others run the kernels.
    """
    packed, n = robot.__dict__.get(_CACHE_KEY) or _pack(robot)
    tau = np.empty(n)
    # The robot's kept entries looked up inline (a helper call costs a tenth of a call);
    # _closed_form makes them, and checks the choice, the first time.
    entries = False if dynamics is NUMERIC else (
        type(dynamics) is str and robot.__dict__.get(_CLOSED_FORM_KEYS.get(dynamics))
        or _closed_form(robot, dynamics))
    if entries and h_e is None and gravity:
        try:
            status = entries[0](packed, q, qd, qdd, tau)
        except TypeError:
            status = entries[0](packed, *_vectors(robot, q=q, qd=qd, qdd=qdd), tau)
        if status:
            _vectors(robot, q=q, qd=qd, qdd=qdd)
        return tau
    if h_e is None and gravity:
        try:
            ok = _rnea_fast(packed, q, qd, qdd, tau)
        except TypeError:
            _ready(_rnea_fast)
            ok = _rnea_fast(packed, *_vectors(robot, q=q, qd=qd, qdd=qdd), tau)
    else:
        h = packed[1 + n:7 + n] if h_e is None else h_e
        scale = 1.0 if gravity else 0.0
        try:
            ok = _rnea_full(packed, q, qd, qdd, scale, h, tau)
        except TypeError:
            _ready(_rnea_full)
            q, qd, qdd, h = _vectors(robot, q=q, qd=qd, qdd=qdd, h_e=h)
            ok = _rnea_full(packed, q, qd, qdd, scale, h, tau)
    if not ok:
        _vectors(robot, q=q, qd=qd, qdd=qdd, h_e=np.zeros(6) if h_e is None else h_e)
    return tau


def inertia_matrix(robot: Robot, q, dynamics: str = NUMERIC) -> np.ndarray:
    """Joint-space inertia matrix B(q), (n, n), symmetric positive definite, rotors included
    (D2, D3), by the composite-rigid-body algorithm (``dynamics`` as in
    :func:`inverse_dynamics`).  Units kg | kg·m | kg·m²."""
    packed, n = robot.__dict__.get(_CACHE_KEY) or _pack(robot)
    B = np.empty((n, n))
    entries = False if dynamics is NUMERIC else (
        type(dynamics) is str and robot.__dict__.get(_CLOSED_FORM_KEYS.get(dynamics))
        or _closed_form(robot, dynamics))
    if entries:
        try:
            status = entries[1](packed, q, B)
        except TypeError:
            status = entries[1](packed, _vector(robot, q, "q"), B)
        if status:
            _vector(robot, q, "q")
        return B
    try:
        ok = _mass_matrix_entry(packed, q, B)
    except TypeError:
        _ready(_mass_matrix_entry)
        ok = _mass_matrix_entry(packed, _vector(robot, q, "q"), B)
    if not ok:
        _vector(robot, q, "q")
    return B


def coriolis_matrix(robot: Robot, q, qd) -> np.ndarray:
    """Coriolis/centrifugal matrix C(q, q̇), (n, n), from the Christoffel symbols of B:

        C_ij = Σ_k ½(∂B_ij/∂q_k + ∂B_ik/∂q_j − ∂B_jk/∂q_i) q̇_k                            (D4)

    so that Ḃ − 2C is skew-symmetric (Siciliano et al. (7.49)).
    """
    packed, n = robot.__dict__.get(_CACHE_KEY) or _pack(robot)
    C = np.empty((n, n))
    try:
        ok = _coriolis_entry(packed, q, qd, C)
    except TypeError:
        _ready(_coriolis_entry)
        ok = _coriolis_entry(packed, *_vectors(robot, q=q, qd=qd), C)
    if not ok:
        _vectors(robot, q=q, qd=qd)
    return C


def gravity_torque(robot: Robot, q) -> np.ndarray:
    """Gravity torques g(q) = (∂U/∂q)ᵀ, (n,) [N | N·m], with U of (D7)."""
    packed, n = robot.__dict__.get(_CACHE_KEY) or _pack(robot)
    g = np.empty(n)
    try:
        ok = _gravity_entry(packed, q, g)
    except TypeError:
        _ready(_gravity_entry)
        ok = _gravity_entry(packed, _vector(robot, q, "q"), g)
    if not ok:
        _vector(robot, q, "q")
    return g


def forward_dynamics(robot: Robot, q, qd, tau, h_e=None, dynamics: str = NUMERIC) -> np.ndarray:
    """Joint accelerations q̈ (n,) of (D1) under the joint forces τ (n,) [N | N·m]:

        B(q) q̈ = τ − C q̇ − F_v q̇ − F_s sgn(q̇) − g(q) − Jᵀ h_e                            (D5)

    solved by Cholesky factorisation of B (never an inverse).  ``h_e`` as in
    :func:`inverse_dynamics`, and ``dynamics`` (a generated module serves every call).  Raises
    :class:`SingularInertiaError` if B is not positive definite.
    """
    packed, n = robot.__dict__.get(_CACHE_KEY) or _pack(robot)
    qdd = np.empty(n)
    entries = False if dynamics is NUMERIC else (
        type(dynamics) is str and robot.__dict__.get(_CLOSED_FORM_KEYS.get(dynamics))
        or _closed_form(robot, dynamics))
    if entries:
        h = entries[3] if h_e is None else h_e
        try:
            status = entries[2](packed, q, qd, tau, h, qdd)
        except TypeError:
            q, qd, tau, h = _vectors(robot, q=q, qd=qd, tau=tau, h_e=h)
            status = entries[2](packed, q, qd, tau, h, qdd)
    elif h_e is None:
        try:
            status = _forward_free(packed, q, qd, tau, qdd)
        except TypeError:
            _ready(_forward_free)
            q, qd, tau = _vectors(robot, q=q, qd=qd, tau=tau)
            status = _forward_free(packed, q, qd, tau, qdd)
    else:
        h = h_e
        try:
            status = _forward_entry(packed, q, qd, tau, h, qdd)
        except TypeError:
            _ready(_forward_entry)
            q, qd, tau, h = _vectors(robot, q=q, qd=qd, tau=tau, h_e=h)
            status = _forward_entry(packed, q, qd, tau, h, qdd)
    if status == 1:
        _vectors(robot, q=q, qd=qd, tau=tau, h_e=np.zeros(6) if h_e is None else h_e)
    if status == 2:
        raise SingularInertiaError(f"robot {robot.name!r}: inertia matrix B(q) is not positive definite")
    return qdd


def kinetic_energy(robot: Robot, q, qd) -> float:
    """Kinetic energy T = ½ q̇ᵀ B(q) q̇ [J] of links and motor rotors, summed body by body:

        T = Σ_i ½ m_i ‖ṗ_Ci‖² + ½ ω_iᵀ I_Ci ω_i + ½ I_mi (z_miᵀ ω_{i−1} + k_ri q̇_i)²       (D6)
    """
    packed, _ = robot.__dict__.get(_CACHE_KEY) or _pack(robot)
    _ready(_kinetic_entry)
    q, qd = _vectors(robot, q=q, qd=qd)
    return float(_kinetic_entry(packed, q, qd))


def potential_energy(robot: Robot, q) -> float:
    """Gravitational potential energy U = −Σ_i m_i g_0ᵀ p_Ci [J], zero at Σ_0's origin (D7).

    Rotor masses are part of the link inertials, so this is the whole potential energy.
    """
    packed, _ = robot.__dict__.get(_CACHE_KEY) or _pack(robot)
    _ready(_potential_entry)
    return float(_potential_entry(packed, _vector(robot, q, "q")))
