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

Why the wrappers look the way they do (one call costs a few tenths of a microsecond, so the
Python side matters as much as the arithmetic):

* the robot travels as **one** float64 array (its packed model, a scratch workspace and a zero
  wrench, see :func:`_pack`), kept in the robot's instance dictionary: unboxing an array
  argument costs ~25 ns, and the robot and workspace hold 35 arrays;
* each compiled entry has **one** signature (C-contiguous float64 vectors) and may not compile
  another.  The common call skips numba's dispatcher and calls that signature's machine code
  directly (:func:`_direct`, ~0.1 µs less).  What the dispatcher's type check guaranteed is
  then checked in two halves: here, that every vector the caller passed is an ndarray (exactly:
  a subclass could report another ndim or dtype than its memory has), 1-D and float64 (what
  unboxing needs to stay inside its own memory and to read the right numbers); inside the
  entry, the length, the stride of 8 bytes (any, for one item) and the alignment (it returns
  a status instead of touching memory).  Any other input — a list, a pandas Series, another
  dtype, a strided or misaligned array — is converted (with a one-line error naming the field
  when it cannot be) and tried again.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from armlab.errors import ArmlabError
from armlab.kernels.dynamics import (
    FASTMATH,
    coriolis_matrix_into,
    forward_dynamics_into,
    gravity_into,
    mass_matrix_inline,
    rnea_inline,
)
from armlab.kernels.energy import potential_energy_kernel
from armlab.kernels.indirect import COMPILE_LOCK
from armlab.kernels.plant import (
    kinetic_energy_packed,
    pack_plant,
    unpack_plant,
)
from armlab.model.robot import Robot

_CACHE_KEY = "_dynamics_packed"


class SingularInertiaError(ArmlabError):
    """B(q) is not positive definite (a link without mass moved by a joint)."""


def _pack(robot: Robot):
    """(packed, n, (n, n), generated, zero wrench) of ``robot`` (``armlab.kernels.plant``;
    ``generated`` keeps the entries of its generated modules, see :func:`_closed_form`; the zero
    wrench is packed's own, a view), made once and kept in
    the robot's instance dictionary next to ``robot.arrays`` (a weak-key dictionary costs more
    than the dynamics of a small arm); the wrappers keep the last robot's at hand (``_LAST``).
    The model part depends only on the immutable robot; every kernel writes the scratch it
    reads first, so sharing the workspace between calls (serialised by the GIL, which the
    kernels keep) cannot change a result."""
    cached = robot.__dict__.get(_CACHE_KEY)
    if cached is None:
        packed = pack_plant(robot.arrays)
        n = int(packed[0])
        cached = robot.__dict__[_CACHE_KEY] = (packed, n, (n, n), _Generated(), packed[1 + n:7 + n])
    return cached


# The robot of the last wrapper call with its _pack tuple, all in one tuple so that
# threads always read a consistent pair: comparing against it costs ~10 ns, the robot's own
# lookup (an attribute of its instance dictionary) ~40 ns, a tenth of a PRP call.  It keeps
# that one robot alive.
_LAST = (None, None, 0, (0, 0), None, None)


def _use(robot: Robot):
    """``_pack(robot)``, remembered as the last robot used."""
    global _LAST
    cached = _pack(robot)
    _LAST = (robot, *cached)
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
        dispatcher = function if hasattr(function, "py_func") else njit(
            cache=True, _nrt=False, fastmath=FASTMATH)(function)
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


@njit(cache=True, _nrt=False, inline="always")
def _plain(v, n):
    """``v`` has n items 8 bytes apart (any stride for one item, whose first is all the code
    reads) from an 8-byte aligned address: what the entries' one signature (C-contiguous
    float64) assumes and a direct call (:func:`_direct`) has not yet checked."""
    return v.shape[0] == n and (v.strides[0] == 8 or n == 1) and v.ctypes.data % 8 == 0


# The entries return a status: 0 done, 1 an input is not a plain n-vector (nothing written).
@_entry(_V, _V, _V, _V, types.float64, _V, _V)
def _rnea_entry(packed, q, qd, qdd, gravity_scale, h_e, out):
    """Every inverse dynamics call (h_e = the packed zero wrench for free motion): the RNEA is
    inlined once, here (each inlined copy costs seconds of compile)."""
    n, m, ws, _ = _unpack(packed)
    if not (_plain(q, n) and _plain(qd, n) and _plain(qdd, n) and _plain(h_e, 6)):
        return 1
    rnea_inline(m, ws, q, qd, qdd, gravity_scale, h_e, out)
    return 0


@_entry(_V, _V, _M)
def _mass_matrix_entry(packed, q, out):
    n, m, ws, _ = _unpack(packed)
    if not _plain(q, n):
        return 1
    mass_matrix_inline(m, ws, q, out)
    return 0


@_entry(_V, _V, _V)
def _gravity_entry(packed, q, out):
    n, m, ws, _ = _unpack(packed)
    if not _plain(q, n):
        return 1
    gravity_into(m, ws, q, out)
    return 0


@_entry(_V, _V, _V, _M)
def _coriolis_entry(packed, q, qd, out):
    n, m, ws, _ = _unpack(packed)
    if not (_plain(q, n) and _plain(qd, n)):
        return 1
    coriolis_matrix_into(m, ws, q, qd, out)
    return 0


@_entry(_V, _V, _V, _V, _V, _V)
def _forward_entry(packed, q, qd, tau, h_e, qdd_out):
    """Every numeric forward dynamics call (h_e = the packed zero wrench for free motion);
    2: B is not positive definite."""
    n, m, ws, _ = _unpack(packed)
    if not (_plain(q, n) and _plain(qd, n) and _plain(tau, n) and _plain(h_e, 6)):
        return 1
    return 0 if forward_dynamics_into(m, ws, q, qd, tau, h_e, qdd_out) else 2


_kinetic_entry = _entry(_V, _V, _V)(kinetic_energy_packed)


@_entry(_V, _V)
def _potential_entry(packed, q):
    """U, or NaN when q is not a plain n-vector (told apart by the caller)."""
    n, m, ws, _ = _unpack(packed)
    if not _plain(q, n):
        return np.nan
    return potential_energy_kernel(m, ws, q)


def _machine_code(dispatcher):
    """The machine code of an entry's one signature (compiled or loaded from the disk cache
    first): what numba's dispatcher runs once its type check has picked the signature.  It
    unboxes its arguments without checking their types; see the module docstring for what
    the callers check instead."""
    _ready(dispatcher)
    return dispatcher.overloads[dispatcher.signature].entry_point


def _direct(name: str, dispatcher):
    """A stand-in for ``_machine_code(dispatcher)`` under the module-level ``name``: its first
    call compiles the entry, puts the machine code in its own place (the wrappers look the
    name up at each call) and runs it, so importing armlab compiles nothing."""
    def first_call(*args):
        code = _machine_code(dispatcher)
        globals()[name] = code
        return code(*args)
    return first_call


_rnea_code = _direct("_rnea_code", _rnea_entry)
_mass_matrix_code = _direct("_mass_matrix_code", _mass_matrix_entry)
_gravity_code = _direct("_gravity_code", _gravity_entry)
_coriolis_code = _direct("_coriolis_code", _coriolis_entry)
_forward_code = _direct("_forward_code", _forward_entry)
_potential_code = _direct("_potential_code", _potential_entry)
_empty = np.empty
_ND = np.ndarray
_F64 = np.dtype(np.float64)


NUMERIC = "numeric"
_GENERATED_CHOICES = ("auto", "closed_form")


class _Generated(dict):
    """A robot's entries of its generated modules by ``dynamics`` choice (False: the numeric
    kernels), valid in this process only (machine code does not survive a pickle): a pickled
    robot carries an empty one and finds the entries again when it needs them.  (The packed
    robot around it stays a plain tuple: unpacking a tuple subclass costs 27 ns more.)"""

    def __reduce__(self):
        return (type(self), ())


def _closed_form(robot: Robot, dynamics: str):
    """(inverse, mass, forward) of the module ``dynamics`` ("auto" or
    "closed_form") chooses for ``robot`` (``armlab.closed_form``: generated, compiled and
    checked on first use): the machine code of its Python-only ``checked_inverse_dynamics``
    and ``mass_matrix`` (called as the numeric entries are, statuses alike), the dispatcher of
    its ``forward_dynamics`` (shared with compiled callers, so without the stride checks a
    direct call needs); False when the choice runs the numeric kernels.
    Kept with the packed robot."""
    if isinstance(dynamics, str):
        dynamics = str(dynamics)               # a str subclass (np.str_) names the same choice
    if type(dynamics) is str and dynamics == NUMERIC:
        return False
    if not (type(dynamics) is str and dynamics in _GENERATED_CHOICES):
        from armlab.specialise import DYNAMICS_CHOICES

        raise ValueError(f"dynamics: {dynamics!r} is not one of {', '.join(DYNAMICS_CHOICES)}")
    generated = _pack(robot)[3]
    entries = generated.get(dynamics)
    if entries is None:
        from armlab.specialise import chosen_module

        module = chosen_module(robot, dynamics)
        entries = False if module is None else ((
            _machine_code(_python_entry(module.checked_inverse_dynamics, (_V,) * 5)),
            _machine_code(_python_entry(module.mass_matrix, (_V, _V, _M))),
            _python_entry(module.forward_dynamics, (_V,) * 6)))
        generated[dynamics] = entries
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
    if not (type(value) is np.ndarray and value.dtype == np.float64 and value.strides == (8,)
            and value.flags.writeable and value.flags.aligned):
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


# Each public function is a fast path and a general one.  The fast path is written out inline
# (a helper call costs a tenth of a call) and taken when
#   * the robot is the last one used (_LAST holds its packed array),
#   * every vector passed is an ndarray (not a subclass, whose ndim and dtype could be
#     properties misreporting its memory), 1-D and float64,
#   * and the entry's machine code then returns status 0 (length, stride and alignment right).
# Everything else — another robot, a list, another dtype, a strided array, a wrench, a
# generated module not made yet, a bad choice — takes the general path (the function with a
# leading underscore): it finds or makes the robot's packed array (_use), converts the inputs
# (_vectors raises the one-line error naming the field) and calls the entry again.  The
# generated entries of dynamics="closed_form"/"auto" are kept with the packed robot;
# _closed_form makes them, and checks the choice, the first time.

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
    last, packed, n, _, generated, zero_wrench = _LAST
    tau = _empty(n)
    if (last is robot and h_e is None and gravity and type(q) is type(qd) is type(qdd) is _ND
            and q.ndim == qd.ndim == qdd.ndim == 1 and q.dtype is qd.dtype is qdd.dtype is _F64):
        if dynamics is NUMERIC:
            if not _rnea_code(packed, q, qd, qdd, 1.0, zero_wrench, tau):
                return tau
        else:
            try:
                call = generated[dynamics][0]
            except (KeyError, TypeError):       # not made yet, the numeric kernels, no choice
                call = None
            if call is not None and not call(packed, q, qd, qdd, tau):
                return tau
    return _inverse_dynamics(robot, q, qd, qdd, h_e, gravity, dynamics)


def _inverse_dynamics(robot: Robot, q, qd, qdd, h_e, gravity, dynamics) -> np.ndarray:
    packed, n, _, _, zero_wrench = _use(robot)
    tau = _empty(n)
    entries = False if dynamics is NUMERIC else _closed_form(robot, dynamics)
    if entries and h_e is None and gravity:     # the generated module serves free motion
        entries[0](packed, *_vectors(robot, q=q, qd=qd, qdd=qdd), tau)
        return tau
    h = zero_wrench if h_e is None else h_e
    q, qd, qdd, h = _vectors(robot, q=q, qd=qd, qdd=qdd, h_e=h)
    _rnea_code(packed, q, qd, qdd, 1.0 if gravity else 0.0, h, tau)
    return tau


def inertia_matrix(robot: Robot, q, dynamics: str = NUMERIC) -> np.ndarray:
    """Joint-space inertia matrix B(q), (n, n), symmetric positive definite, rotors included
    (D2, D3), by the composite-rigid-body algorithm (``dynamics`` as in
    :func:`inverse_dynamics`).  Units kg | kg·m | kg·m²."""
    last, packed, _, square, generated, _ = _LAST
    B = _empty(square)
    if last is robot and type(q) is _ND and q.ndim == 1 and q.dtype is _F64:
        if dynamics is NUMERIC:
            if not _mass_matrix_code(packed, q, B):
                return B
        else:
            try:
                call = generated[dynamics][1]
            except (KeyError, TypeError):       # not made yet, the numeric kernels, no choice
                call = None
            if call is not None and not call(packed, q, B):
                return B
    return _inertia_matrix(robot, q, dynamics)


def _inertia_matrix(robot: Robot, q, dynamics) -> np.ndarray:
    packed, _, square, _, _ = _use(robot)
    B = _empty(square)
    entries = False if dynamics is NUMERIC else _closed_form(robot, dynamics)
    (entries[1] if entries else _mass_matrix_code)(packed, _vector(robot, q, "q"), B)
    return B


def coriolis_matrix(robot: Robot, q, qd) -> np.ndarray:
    """Coriolis/centrifugal matrix C(q, q̇), (n, n), from the Christoffel symbols of B:

        C_ij = Σ_k ½(∂B_ij/∂q_k + ∂B_ik/∂q_j − ∂B_jk/∂q_i) q̇_k                            (D4)

    so that Ḃ − 2C is skew-symmetric (Siciliano et al. (7.49)).
    """
    last, packed, _, square, _, _ = _LAST
    C = _empty(square)
    if (last is robot and type(q) is type(qd) is _ND and q.ndim == qd.ndim == 1
            and q.dtype is qd.dtype is _F64 and not _coriolis_code(packed, q, qd, C)):
        return C
    packed, _, square, _, _ = _use(robot)
    C = _empty(square)
    _coriolis_code(packed, *_vectors(robot, q=q, qd=qd), C)
    return C


def gravity_torque(robot: Robot, q) -> np.ndarray:
    """Gravity torques g(q) = (∂U/∂q)ᵀ, (n,) [N | N·m], with U of (D7)."""
    last, packed, n, _, _, _ = _LAST
    g = _empty(n)
    if (last is robot and type(q) is _ND and q.ndim == 1 and q.dtype is _F64
            and not _gravity_code(packed, q, g)):
        return g
    packed, n, _, _, _ = _use(robot)
    g = _empty(n)
    _gravity_code(packed, _vector(robot, q, "q"), g)
    return g


def forward_dynamics(robot: Robot, q, qd, tau, h_e=None, dynamics: str = NUMERIC) -> np.ndarray:
    """Joint accelerations q̈ (n,) of (D1) under the joint forces τ (n,) [N | N·m]:

        B(q) q̈ = τ − C q̇ − F_v q̇ − F_s sgn(q̇) − g(q) − Jᵀ h_e                            (D5)

    solved by Cholesky factorisation of B (never an inverse).  ``h_e`` as in
    :func:`inverse_dynamics`, and ``dynamics`` (a generated module serves every call).  Raises
    :class:`SingularInertiaError` if B is not positive definite.
    """
    last, packed, n, _, generated, zero_wrench = _LAST
    qdd = _empty(n)
    if (last is robot and h_e is None and type(q) is type(qd) is type(tau) is _ND
            and q.ndim == qd.ndim == tau.ndim == 1 and q.dtype is qd.dtype is tau.dtype is _F64):
        if dynamics is NUMERIC:
            if not _forward_code(packed, q, qd, tau, zero_wrench, qdd):
                return qdd
        else:
            # The generated forward dynamics is shared with compiled callers and has no stride
            # checks: its dispatcher's type check refuses a strided vector (TypeError).
            try:
                if not generated[dynamics][2](packed, q, qd, tau, zero_wrench, qdd):
                    return qdd
            except (KeyError, TypeError):       # not made yet, numeric, no choice, strided
                pass
    return _forward_dynamics(robot, q, qd, tau, h_e, dynamics)


def _forward_dynamics(robot: Robot, q, qd, tau, h_e, dynamics) -> np.ndarray:
    packed, n, _, _, zero_wrench = _use(robot)
    qdd = _empty(n)
    entries = False if dynamics is NUMERIC else _closed_form(robot, dynamics)
    q, qd, tau, h = _vectors(robot, q=q, qd=qd, tau=tau, h_e=zero_wrench if h_e is None else h_e)
    # The generated forward dynamics is shared with compiled callers and has no stride checks:
    # it is called through its dispatcher, on the converted vectors.
    status = (entries[2] if entries else _forward_code)(packed, q, qd, tau, h, qdd)
    if status == 2:
        raise SingularInertiaError(f"robot {robot.name!r}: inertia matrix B(q) is not positive definite")
    return qdd


def kinetic_energy(robot: Robot, q, qd) -> float:
    """Kinetic energy T = ½ q̇ᵀ B(q) q̇ [J] of links and motor rotors, summed body by body:

        T = Σ_i ½ m_i ‖ṗ_Ci‖² + ½ ω_iᵀ I_Ci ω_i + ½ I_mi (z_miᵀ ω_{i−1} + k_ri q̇_i)²       (D6)
    """
    packed = _pack(robot)[0]
    _ready(_kinetic_entry)
    q, qd = _vectors(robot, q=q, qd=qd)
    return float(_kinetic_entry(packed, q, qd))


def potential_energy(robot: Robot, q) -> float:
    """Gravitational potential energy U = −Σ_i m_i g_0ᵀ p_Ci [J], zero at Σ_0's origin (D7).

    Rotor masses are part of the link inertials, so this is the whole potential energy.
    """
    packed = _pack(robot)[0]
    return float(_potential_code(packed, _vector(robot, q, "q")))
