"""The controller and environment protocols of the compiled simulator.

A controller is a small dynamical system (python-control's ``nlsys`` shape) with output and
state equations

    τ = h(t, y, z),    ż = f(t, y, z),    y = (q, q̇, h_e)                               (C0)

where ``z`` (k,) is the controller's internal state (adaptive estimates, integral of an error,
a compliant frame …).  The simulator owns ``z``: it stores ``z(0) = initial_state()``,
integrates ``ż`` together with the plant (or, under sampled control, updates it once per
control period, see ``armlab.simulation``) and logs it as ``SimulationResult.z``.

Writing a controller
--------------------
A controller is a **frozen dataclass** subclassing :class:`Controller`.  It holds

* ``model`` — its own :class:`~armlab.model.robot.Robot`, the controller's belief about the
  plant.  Model mismatch is "build the controller with a different robot"
  (``plant.with_link_mass("link4", 0.16)``); the plant passed to ``simulate`` is the truth;
* its parameters (gains, reference, options) as ordinary fields.

It points at its compiled law through the class attribute ``law``: a ``numba.njit``
function (module-level with ``cache=True``, so that its compile is kept on disk; the
simulator's loop calls it through its machine address, ``armlab.simulation.loop``) with
the signature

    law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out) -> None

(A law in plain Python runs too, about 60 times slower: ``armlab.simulate`` then integrates
in Python, ``armlab.simulation.python_loop``; ``armlab.control.function.FunctionController``
takes a law given as a function, also the short form ``tau = law(t, q, qd)``.)

===============  ========  ==================================================================
argument         shape     meaning
===============  ========  ==================================================================
``t``            float     time [s]
``q, qd``        (n,)      measured joint positions / velocities [m | rad], [m/s | rad/s]
``z``            (k,)      controller state (read only)
``h_e``          (6,)      measured end-effector wrench [f; μ] in Σ_0 [N, N·m] that the
                           end effector exerts on the environment (zeros in free space)
``params``       —         ``Controller.params()``, a NamedTuple of plain arrays (see below)
``tau_out``      (n,)      write the commanded joint torque/force τ [N·m | N]
``zdot_out``     (k,)      write ż (k may be 0)
``signals_out``  (s,)      write the logged signals, concatenated in ``signals()`` order
===============  ========  ==================================================================

The law must not allocate: every temporary lives in an array of ``params`` (for example a
workspace from ``armlab.kernels.dynamics.make_workspace``).  It must write every entry of its
three outputs on every call.  It is called from compiled code only (the RK4 loop, the
right-hand side used by the adaptive integrator, tests), so it may call any other compiled
kernel: ``armlab.kernels.dynamics`` on ``model.arrays``, ``armlab.kernels.kinematics``,
``armlab.references.reference_into`` on a reference's ``data``.

``params()`` returns an instance of a ``typing.NamedTuple`` class written next to the law, one
field per quantity the law reads (NumPy arrays, numbers, :class:`~armlab.model.robot.RobotArrays`,
workspaces and NamedTuples of those; the field types fixed per class), built by keyword; the
law reads its fields by name.  The class is defined at module level: numba types a NamedTuple
by its class, and a class made inside a function is never found again in numba's disk cache
(the law would compile anew in every process).  A field the law reads but the class lacks (a
misspelt name) fails when the law compiles, naming the attribute.  Bind the
fields to locals once, at the top of the law (``kp, kd = params.kp, params.kd``): a field read
inside a call's arguments, ``f(params.x)``, made numba emit twice the reference-counting calls
in a law compiled on its own (279 instead of 151 in ``operational_pd_law``, 8–13 % of a
task-space run).  ``params()`` is called once per simulation; the simulator gives every
parallel run its own copy, so workspaces inside may be scratch memory.

``initial_state()`` returns z(0) (k,), ``state_labels()`` / ``state_units()`` its k component
names and units, and
``signals()`` the :class:`Signal` list describing ``signals_out`` (name, component labels,
units) — the seed's "scopes".  The simulator adds ``q_des`` etc. only if the controller logs
them: a controller should log what a user wants to see (references, errors, estimates).

The loop calls every module-level law through its generated *entry* (``armlab.control.entry``):
the law compiled inlined into the loop's call, which then passes the loop's scratch array and
three sizes instead of seven arrays and the parameter tuple by value.  That pays where the law
is small against the call: 1.3–1.5 times faster whole runs for the joint-space laws (A6, A7,
A8); the task-space and interaction laws run at the same speed (±3 %) and their first run
compiles 1.1–1.4 s longer (once per machine: the entry is cached on disk).  ``borrowed``
(``armlab.kernels.boundary``), which the entry applies to the scratch and the parameters,
tells numba that those arrays need no reference counting (the simulation keeps them alive).

Minimal example (a joint PD, τ = K_P (q_des − q) − K_D q̇, no state)::

    from dataclasses import dataclass
    from typing import NamedTuple
    import numpy as np
    from numba import njit
    from armlab.control.base import Controller, Signal

    class PDParams(NamedTuple):           # module level, next to its law
        q_des: np.ndarray                 # (n,) target joint positions [m | rad]
        kp: np.ndarray                    # (n,) K_P [N/m | N·m/rad]
        kd: np.ndarray                    # (n,) K_D [N·s/m | N·m·s/rad]

    @njit(cache=True)
    def pd_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
        q_des, kp, kd = params.q_des, params.kp, params.kd
        for i in range(q.shape[0]):
            tau_out[i] = kp[i] * (q_des[i] - q[i]) - kd[i] * qd[i]
            signals_out[i] = q_des[i] - q[i]

    @dataclass(frozen=True)
    class PD(Controller):
        model: Robot
        q_des: np.ndarray
        kp: np.ndarray
        kd: np.ndarray
        law = pd_law                      # a class attribute, not a dataclass field

        def params(self):
            return PDParams(q_des=np.asarray(self.q_des, float), kp=np.asarray(self.kp, float),
                            kd=np.asarray(self.kd, float))

        def signals(self):
            return (Signal.joint("q_err", self.model, "error"),)

    result = armlab.simulate(plant, PD(plant, q_des, kp, kd), q0=..., t_final=2.0, dt=1e-3)

Environments
------------
An environment (free space, a spring, a wall) maps the end-effector motion to the wrench
h_e the end effector exerts on it.  It is a frozen dataclass subclassing
:class:`Environment` whose class attribute ``law`` is an njit function, like a controller's

    law(t, R_0e, p_0e, v_e, params, h_e_out) -> None

with ``R_0e`` (3, 3) and ``p_0e`` (3,) [m] the end-effector pose of the *plant* in Σ_0,
``v_e`` (6,) its twist [ṗ; ω] in Σ_0 [m/s, rad/s], ``params`` = ``Environment.params()``
(a NamedTuple, same rules as a controller's) and ``h_e_out`` (6,) the wrench [f; μ] in Σ_0 [N, N·m].  The
simulator evaluates it at every right-hand-side evaluation, feeds h_e into the plant
(B q̈ + C q̇ + F_v q̇ + F_s sgn q̇ + g = τ − J_eᵀ h_e) and passes it to the controller as its
measurement.
"""

from __future__ import annotations

import abc
import functools
from dataclasses import dataclass

import numpy as np

from armlab.errors import ProtocolError

_JOINT_UNITS = {"position": ("m", "rad"), "error": ("m", "rad"), "velocity": ("m/s", "rad/s"),
                "acceleration": ("m/s²", "rad/s²"), "effort": ("N", "N·m")}


@dataclass(frozen=True)
class Signal:
    """A named, logged signal: ``labels`` (one per component) and ``units`` (one per component)."""

    name: str
    labels: tuple[str, ...]
    units: tuple[str, ...]

    def __post_init__(self):
        object.__setattr__(self, "labels", tuple(self.labels))
        object.__setattr__(self, "units", tuple(self.units))
        if len(self.labels) != len(self.units):
            raise ProtocolError(f"signal {self.name}: {len(self.labels)} labels but "
                                f"{len(self.units)} units")

    @property
    def width(self) -> int:
        return len(self.labels)

    @classmethod
    def joint(cls, name: str, robot, kind: str) -> Signal:
        """One component per joint of ``robot``, units by joint type.

        ``kind``: "position" / "error" (m | rad), "velocity" (m/s | rad/s), "acceleration"
        (m/s² | rad/s²) or "effort" (N | N·m).
        """
        return _joint_signal(cls, name, tuple([(j.name, j.kind) for j in robot.joints]), kind)


# Signals are immutable and every simulation asks for a dozen (~5 µs each to build): kept by
# what they are made of, the joints' names and kinds.
@functools.lru_cache(maxsize=1024)
def _joint_signal(cls, name: str, joints: tuple, kind: str) -> Signal:
    if kind not in _JOINT_UNITS:
        raise ProtocolError(f"signal {name}: unknown kind {kind!r} (use {', '.join(_JOINT_UNITS)})")
    prismatic, revolute = _JOINT_UNITS[kind]
    return cls(name, tuple([label for label, _ in joints]),
               tuple([prismatic if joint_kind == "prismatic" else revolute for _, joint_kind in joints]))


@dataclass(frozen=True)
class Controller(abc.ABC):
    """Base of every controller: see the module docstring for the protocol (C0)."""

    @property
    def n(self) -> int:
        """Number of joints of the controller's model."""
        return self.model.n

    @abc.abstractmethod
    def params(self) -> tuple:
        """The NamedTuple of plain arrays passed to ``law`` as ``params`` (module docstring)."""

    def law_function(self):
        """The law the simulator runs: the class's ``law`` (a controller holding its law as a
        field, ``armlab.control.function.FunctionController``, returns that one)."""
        return type(self).law

    def initial_state(self) -> np.ndarray:
        """z(0), (k,); stateless controllers have k = 0."""
        return np.zeros(0)

    def state_labels(self) -> tuple[str, ...]:
        """Names of the k components of z."""
        return ()

    def state_units(self) -> tuple[str, ...]:
        """Units of the k components of z ("" when unspecified)."""
        return ("",) * len(self.state_labels())

    def signals(self) -> tuple[Signal, ...]:
        """The logged signals written into ``signals_out``, in order."""
        return ()

    def _repr_html_(self) -> str:
        """The controller in a notebook: its law, gains, model and signals."""
        from armlab.display import controller_html

        return controller_html(self)

    def describe(self) -> dict:
        """Plain, JSON-able description of the controller (stored in ``SimulationResult.meta``)."""
        out = {"type": type(self).__name__}
        for key, value in vars(self).items():
            if key == "model":
                out[key] = value.name
            elif isinstance(value, np.ndarray):
                out[key] = value.tolist()
            elif isinstance(value, (int, float, str, bool)) or value is None:
                out[key] = value
            elif hasattr(value, "describe"):
                out[key] = value.describe()
            else:
                out[key] = repr(value)
        return out


@dataclass(frozen=True)
class Environment(abc.ABC):
    """Base of every environment: see the module docstring for the protocol."""

    @abc.abstractmethod
    def params(self) -> tuple:
        """The NamedTuple of plain arrays passed to ``law`` as ``params`` (module docstring)."""

    def describe(self) -> dict:
        out = {"type": type(self).__name__}
        for key, value in vars(self).items():
            out[key] = value.tolist() if isinstance(value, np.ndarray) else value
        return out
