"""Joint-space dynamics of a serial robot (public API over the compiled kernels).

The plant, with every term of the robot description (``docs/notation.md``, section Dynamics):

    B(q) q̈ + C(q, q̇) q̇ + F_v q̇ + F_s sgn(q̇) + g(q) = τ − Jᵀ(q) h_e                     (D1)

B includes the motor rotors (reflected inertia k_r² I_m and their coupling with the link that
carries them, Siciliano et al. §7.2), C is the Christoffel-symbol matrix (Ḃ − 2C is
skew-symmetric), h_e = [f_e; μ_e] is the wrench the end effector exerts on the environment,
in Σ_0, with μ_e about Σ_e's origin.  Units SI; q̇ [m/s | rad/s], τ [N | N·m].

Each function is a plain wrapper: it converts its inputs when it must and calls a compiled
entry over the robot's model and a data (``armlab.kernels.plant``).  Every call returns a new
array.

The model and the data of a robot
---------------------------------
The model is ``robot.packed``, the robot's numbers in one array, made with the robot and never
written.  What a call needs besides the model and the state is scratch memory, a
:class:`DynamicsData` (the role of Pinocchio's ``Data`` or MuJoCo's ``MjData``)::

    data = DynamicsData(robot)          # scratch workspace, the dynamics choices met
    for q, qd, qdd in states:           # a hot Python loop
        tau = inverse_dynamics(robot, q, qd, qdd, data=data)

A call without ``data=`` uses its thread's own scratch for the robot, made by the engine at
the robot's first call in that thread and kept in a weak map of the thread, so it goes with
the robot; nothing is written into the robot.  The results are the same either way: every
kernel writes the scratch it reads first.  A data serves one thread at a time.

Inputs
------
The compiled entries have one signature each (C-contiguous float64 vectors), so numba refuses
anything else instead of compiling another version for it.  A wrapper passes an exact ndarray
of native float64 straight on (numba reads its rank, layout, alignment and write flag from its
memory) and converts everything else first — a list, a pandas Series, another dtype or byte
order, an ndarray subclass, or an array numba refused (strided, read-only, misaligned) — or
raises a one-line ``ValueError`` naming the field.
"""

from __future__ import annotations

import functools
import threading
import weakref

import numpy as np
from numba import njit, types

from armlab.errors import SingularInertiaError
from armlab.kernels.dynamics import FASTMATH, coriolis_matrix_into, mass_matrix_inline
from armlab.kernels.energy import potential_energy_kernel
from armlab.kernels.plant import (
    forward_dynamics_packed,
    kinetic_energy_packed,
    make_data,
    rnea_packed,
    unpack_plant,
)
from armlab.kernels.workspace import no_wrench_of
from armlab.model.robot import Robot
from armlab.specialise import DYNAMICS_CHOICES, chosen_module

NUMERIC = "numeric"


class _Scratch:
    """What a call needs besides the model: the kernels' workspace, zero velocities and the
    compiled entries of each ``dynamics=`` choice met so far (what "auto" picks is decided at
    its first use).  It holds no robot, so that a thread's own (below) dies with its robot."""

    __slots__ = ("n", "square", "workspace", "rest", "entries")

    def __init__(self, robot: Robot):
        if not isinstance(robot, Robot):
            raise TypeError(f"robot: expected an armlab Robot, got {type(robot).__name__}")
        n = self.n = robot.n
        self.square = (n, n)
        self.workspace = make_data(n)
        self.rest = np.zeros(n)                   # q̇ = q̈ = 0 (never written)
        self.entries: dict = {NUMERIC: _ENTRIES}


class DynamicsData(_Scratch):
    """The scratch of ``robot``'s dynamics calls (``workspace``: the kernels' workspace, see
    ``armlab.kernels.plant``; ``entries``: the compiled entries of the ``dynamics=`` choices
    met so far).

    Reusable by any sequence of calls for that robot, by one thread at a time.
    """

    __slots__ = ("robot",)

    def __init__(self, robot: Robot):
        super().__init__(robot)
        self.robot = robot

    def __reduce__(self):
        # The generated entries belong to this process; another one finds them again.
        return (type(self), (self.robot,))

    def __repr__(self):
        return f"DynamicsData({self.robot.name!r})"


# Each thread's own scratch per robot, for calls without ``data=``: made on a robot's first
# call in the thread, gone with the robot (a weak map; a robot hashes by identity).
_THREAD = threading.local()


def _data_of(robot: Robot, data) -> _Scratch:
    """``data`` if it is ``robot``'s, this thread's own scratch for ``robot`` if it is None,
    else the one-line error."""
    if data is None:
        try:
            return _THREAD.scratch[robot]
        except (AttributeError, KeyError, TypeError):
            return _thread_scratch(robot)
    if type(data) is not DynamicsData or data.robot is not robot:
        owner = repr(data.robot.name) if isinstance(data, DynamicsData) else f"a {type(data).__name__}"
        raise ValueError(f"data: DynamicsData of {owner}, not of robot {getattr(robot, 'name', robot)!r}")
    return data


def _thread_scratch(robot: Robot) -> _Scratch:
    scratch = _Scratch(robot)
    if not hasattr(_THREAD, "scratch"):
        _THREAD.scratch = weakref.WeakKeyDictionary()
    _THREAD.scratch[robot] = scratch
    return scratch


# ---------------------------------------------------------------------------- compiled entries
# Each returns a status: 0 done, 1 a vector of the wrong length (nothing written).  They call
# the plant kernels the simulator compiles too (one compile serves both) and inline only the
# CRBA, whose call the inertia matrix of a small arm would feel.

def _free_motion_entry(model, data, q, qd, qdd, tau_out):
    """The common call, with gravity and without a wrench (also g(q) = τ(q, 0, 0)): the
    plant's ``rnea_packed`` with the workspace's zero wrench (skipped at run time), the one
    compiled RNEA that also serves the simulation's plant and a law's model."""
    n = int(model[0])
    if q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n:
        return 1
    rnea_packed(model, data, q, qd, qdd, 1.0, no_wrench_of(data, n), tau_out)
    return 0


def _inverse_dynamics_entry(model, data, q, qd, qdd, gravity_scale, h_e, tau_out):
    """Every other call (a wrench, or gravity off): the same ``rnea_packed``."""
    n = int(model[0])
    if q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or h_e.shape[0] != 6:
        return 1
    rnea_packed(model, data, q, qd, qdd, gravity_scale, h_e, tau_out)
    return 0


def _mass_matrix_entry(model, data, q, B_out):
    n, m, ws = unpack_plant(model, data)
    if q.shape[0] != n:
        return 1
    mass_matrix_inline(m, ws, q, B_out)
    return 0


def _coriolis_entry(model, data, q, qd, C_out):
    n, m, ws = unpack_plant(model, data)
    if q.shape[0] != n or qd.shape[0] != n:
        return 1
    coriolis_matrix_into(m, ws, q, qd, C_out)
    return 0


def _potential_energy_entry(model, data, q):
    """U, or NaN for a vector of the wrong length."""
    n, m, ws = unpack_plant(model, data)
    if q.shape[0] != n:
        return np.nan
    return potential_energy_kernel(m, ws, q)


_V = types.float64[::1]
_M = types.float64[:, ::1]


def _one_signature(function, *argtypes):
    """``function`` (a Python function, or a dispatcher whose options are kept) compiled for
    exactly ``argtypes``, or loaded from numba's disk cache: a dispatcher given its signature
    refuses other argument types (TypeError) instead of compiling a version for them."""
    options = dict(getattr(function, "targetoptions", {"fastmath": FASTMATH}))
    options.pop("nopython", None)            # implied by njit
    return njit(argtypes, cache=True, **options)(getattr(function, "py_func", function))


class _Entries:
    """The numeric kernels' entries, each made at its first use (a dispatcher with a signature
    compiles at once; importing armlab compiles nothing).  The forward dynamics and kinetic
    energy are the plant kernels themselves (they check lengths already)."""

    @functools.cached_property
    def free_motion(self):
        return _one_signature(_free_motion_entry, _V, _V, _V, _V, _V, _V)

    @functools.cached_property
    def inverse_dynamics(self):
        return _one_signature(_inverse_dynamics_entry, _V, _V, _V, _V, _V, types.float64, _V, _V)

    @functools.cached_property
    def mass_matrix(self):
        return _one_signature(_mass_matrix_entry, _V, _V, _V, _M)

    @functools.cached_property
    def coriolis(self):
        return _one_signature(_coriolis_entry, _V, _V, _V, _V, _M)

    @functools.cached_property
    def forward_dynamics(self):
        return _one_signature(forward_dynamics_packed, _V, _V, _V, _V, _V, _V, _V)

    @functools.cached_property
    def kinetic_energy(self):
        return _one_signature(kinetic_energy_packed, _V, _V, _V, _V)

    @functools.cached_property
    def potential_energy(self):
        return _one_signature(_potential_energy_entry, _V, _V, _V)


_ENTRIES = _Entries()


class _GeneratedEntries:
    """A generated module's kernels for calls from Python, under the names of the numeric
    entries that do the same, each of one signature as those are (numba's disk cache beside
    the module holds that compiled version already)."""

    def __init__(self, module):
        self.free_motion = _one_signature(module.checked_inverse_dynamics, _V, _V, _V, _V, _V, _V)
        self.mass_matrix = _one_signature(module.mass_matrix, _V, _V, _V, _M)
        self.forward_dynamics = _one_signature(module.forward_dynamics, _V, _V, _V, _V, _V, _V, _V)


@functools.cache
def _generated_entries(module) -> _GeneratedEntries:
    return _GeneratedEntries(module)


def _entries_for(robot: Robot, data: _Scratch, dynamics):
    """The entries ``dynamics`` picks for ``robot``: the numeric ones, or those of the
    generated module ``armlab.specialise`` chooses ("auto": one on disk already; "closed_form":
    made now if needed); kept in ``data``."""
    if not (isinstance(dynamics, str) and str(dynamics) in DYNAMICS_CHOICES):
        raise ValueError(f"dynamics: {dynamics!r} is not one of {', '.join(DYNAMICS_CHOICES)}")
    dynamics = str(dynamics)
    entries = data.entries.get(dynamics)
    if entries is None:
        module = chosen_module(robot, dynamics)
        entries = data.entries[dynamics] = _ENTRIES if module is None else _generated_entries(module)
        if module is not None:
            data.entries["auto"] = entries          # "auto" takes a module once there is one
    return entries


# Numba's dispatcher types an exact ndarray by its memory (rank, layout, write flag), but may
# take a subclass's word for its dtype and rank (Python attributes that can misreport the
# memory) and has been seen to pass a byte-swapped array for a native one: the fast path of
# each function passes it exact ndarrays of native float64 only; everything else, and every
# array it refuses, takes the function's general path (a leading underscore), which converts.
_ND = np.ndarray
_NO_WRENCH = np.zeros(6)          # h_e of a call without contact (the kernels only read it)
_F64 = np.dtype(np.float64)
_empty = np.empty
# What the fast path may meet: a refused argument (TypeError, ValueError), a choice not yet
# decided for the data (KeyError) or not hashable (TypeError).
_FALLBACK = (TypeError, ValueError, KeyError)


def _vector(robot: Robot, value, name: str, size: int | None = None) -> np.ndarray:
    """``value`` as a C-contiguous, aligned, writeable float64 vector of the expected length
    (copied unless it already is one), or a one-line ValueError naming the field."""
    size = robot.n if size is None else size
    if not (type(value) is _ND and value.dtype is _F64 and value.ndim == 1 and value.flags.carray):
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


# ------------------------------------------------------------------------------ the functions

def inverse_dynamics(robot: Robot, q, qd, qdd, h_e=None, gravity: bool = True,
                     dynamics: str = NUMERIC, data: DynamicsData | None = None) -> np.ndarray:
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
        module, ``armlab.specialise``: made once per robot and machine, several times faster
        per call) or "auto" (the generated module if one is on disk for the robot already, else
        the numeric kernels).  The generated module serves calls without h_e and with
        gravity; others run the kernels.
    data : the robot's :class:`DynamicsData` (see the module docstring), or None.
    """
    data = _data_of(robot, data)
    tau = _empty(data.n)
    if (h_e is None and gravity and type(q) is type(qd) is type(qdd) is _ND
            and q.dtype is qd.dtype is qdd.dtype is _F64):
        try:
            if not data.entries[dynamics].free_motion(robot.packed, data.workspace, q, qd, qdd, tau):
                return tau
        except _FALLBACK:
            pass
    return _inverse_dynamics(robot, q, qd, qdd, h_e, gravity, dynamics, data, tau)


def _inverse_dynamics(robot, q, qd, qdd, h_e, gravity, dynamics, data, tau):
    entries = _entries_for(robot, data, dynamics)
    q, qd, qdd, h = _vectors(robot, q=q, qd=qd, qdd=qdd, h_e=_NO_WRENCH if h_e is None else h_e)
    if h_e is None and gravity:
        entries.free_motion(robot.packed, data.workspace, q, qd, qdd, tau)
    else:
        _ENTRIES.inverse_dynamics(robot.packed, data.workspace, q, qd, qdd, 1.0 if gravity else 0.0, h, tau)
    return tau


def inertia_matrix(robot: Robot, q, dynamics: str = NUMERIC,
                   data: DynamicsData | None = None) -> np.ndarray:
    """Joint-space inertia matrix B(q), (n, n), symmetric positive definite, rotors included
    (D2, D3), by the composite-rigid-body algorithm (``dynamics`` and ``data`` as in
    :func:`inverse_dynamics`).  Units kg | kg·m | kg·m²."""
    data = _data_of(robot, data)
    B = _empty(data.square)
    if type(q) is _ND and q.dtype is _F64:
        try:
            if not data.entries[dynamics].mass_matrix(robot.packed, data.workspace, q, B):
                return B
        except _FALLBACK:
            pass
    _entries_for(robot, data, dynamics).mass_matrix(robot.packed, data.workspace, _vector(robot, q, "q"), B)
    return B


def coriolis_matrix(robot: Robot, q, qd, data: DynamicsData | None = None) -> np.ndarray:
    """Coriolis/centrifugal matrix C(q, q̇), (n, n), from the Christoffel symbols of B:

        C_ij = Σ_k ½(∂B_ij/∂q_k + ∂B_ik/∂q_j − ∂B_jk/∂q_i) q̇_k                            (D4)

    so that Ḃ − 2C is skew-symmetric (Siciliano et al. (7.49)).
    """
    data = _data_of(robot, data)
    C = _empty(data.square)
    if type(q) is type(qd) is _ND and q.dtype is qd.dtype is _F64:
        try:
            if not _ENTRIES.coriolis(robot.packed, data.workspace, q, qd, C):
                return C
        except _FALLBACK:
            pass
    _ENTRIES.coriolis(robot.packed, data.workspace, *_vectors(robot, q=q, qd=qd), C)
    return C


def gravity_torque(robot: Robot, q, data: DynamicsData | None = None) -> np.ndarray:
    """Gravity torques g(q) = (∂U/∂q)ᵀ, (n,) [N | N·m], with U of (D7)."""
    data = _data_of(robot, data)
    g = _empty(data.n)
    rest = data.rest                          # g(q) = τ(q, q̇ = 0, q̈ = 0)
    if type(q) is _ND and q.dtype is _F64:
        try:
            if not _ENTRIES.free_motion(robot.packed, data.workspace, q, rest, rest, g):
                return g
        except _FALLBACK:
            pass
    _ENTRIES.free_motion(robot.packed, data.workspace, _vector(robot, q, "q"), rest, rest, g)
    return g


def forward_dynamics(robot: Robot, q, qd, tau, h_e=None, dynamics: str = NUMERIC,
                     data: DynamicsData | None = None) -> np.ndarray:
    """Joint accelerations q̈ (n,) of (D1) under the joint forces τ (n,) [N | N·m]:

        B(q) q̈ = τ − C q̇ − F_v q̇ − F_s sgn(q̇) − g(q) − Jᵀ h_e                            (D5)

    solved by Cholesky factorisation of B (never an inverse).  ``h_e``, ``dynamics`` (a
    generated module serves every call) and ``data`` as in :func:`inverse_dynamics`.  Raises
    :class:`SingularInertiaError` if B is not positive definite.
    """
    data = _data_of(robot, data)
    qdd = _empty(data.n)
    status = 1
    if h_e is None and type(q) is type(qd) is type(tau) is _ND and q.dtype is qd.dtype is tau.dtype is _F64:
        try:
            status = data.entries[dynamics].forward_dynamics(robot.packed, data.workspace, q, qd, tau,
                                                             _NO_WRENCH, qdd)
        except _FALLBACK:
            pass
    if status == 1:
        h = _NO_WRENCH if h_e is None else h_e
        status = _entries_for(robot, data, dynamics).forward_dynamics(
            robot.packed, data.workspace, *_vectors(robot, q=q, qd=qd, tau=tau, h_e=h), qdd)
    if status == 2:
        raise SingularInertiaError(f"robot {robot.name!r}: inertia matrix B(q) is not positive definite")
    return qdd


def kinetic_energy(robot: Robot, q, qd, data: DynamicsData | None = None) -> float:
    """Kinetic energy of links and motor rotors [J] (D6):

        T = Σ_i ½ m_i ‖ṗ_Ci‖² + ½ ω_iᵀ I_Ci ω_i + ½ I_mi (z_miᵀ ω_{i−1} + k_ri q̇_i)² = ½ q̇ᵀ B(q) q̇

    computed as ½ q̇ᵀ (B q̇), B q̇ being the RNEA's τ at q̈ = q̇ with zero velocity, no gravity
    and no wrench (``armlab.kernels.plant.kinetic_energy_packed``).
    """
    data = _data_of(robot, data)
    return float(_ENTRIES.kinetic_energy(robot.packed, data.workspace, *_vectors(robot, q=q, qd=qd)))


def potential_energy(robot: Robot, q, data: DynamicsData | None = None) -> float:
    """Gravitational potential energy U = −Σ_i m_i g_0ᵀ p_Ci [J], zero at Σ_0's origin (D7).

    Rotor masses are part of the link inertials, so this is the whole potential energy.
    """
    data = _data_of(robot, data)
    return float(_ENTRIES.potential_energy(robot.packed, data.workspace, _vector(robot, q, "q")))
