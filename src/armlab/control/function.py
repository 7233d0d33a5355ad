"""A controller made of one function: prototype a law in plain Python, make it fast later.

    controller = FunctionController(robot, law)

``law`` is either the short form

    tau = law(t, q, qd)                                     τ (n,) from time and measured state

or the full law protocol of ``armlab.control.base`` (C0)

    law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out) -> None

with ``params`` the controller's ``parameters`` (a tuple or NamedTuple of arrays and numbers),
``z0`` the initial controller state (k,) and ``logged`` the :class:`~armlab.control.base.Signal`
list it writes into ``signals_out``.

A plain Python function runs as it is: ``armlab.simulate`` then integrates with the same RK4
step, saturation, disturbances, environment and logging in Python (``armlab.simulation.
python_loop``), one Python call of the law per stage — about a hundred times slower than the
compiled loop (the measured factor is in ``docs/python-laws.md``).  To make it fast, decorate
the *same* function with ``numba.njit`` (full form: write into the output arrays; short form:
return an array): it then runs inside the compiled loop unchanged.

A law that breaks the protocol is refused with one line naming what is wrong (its number of
arguments, a ``params`` that the compiled loop cannot take, a τ of the wrong shape).
"""

from __future__ import annotations

import functools
import inspect
import types
from dataclasses import dataclass, field

import numpy as np

from armlab.control.base import Controller, Signal
from armlab.control.entry import check_params
from armlab.errors import ProtocolError

FULL = ("t", "q", "qd", "z", "h_e", "params", "tau_out", "zdot_out", "signals_out")
SHORT = ("t", "q", "qd")


def is_compiled(function) -> bool:
    """Whether ``function`` is a numba-compiled (``njit``) function."""
    return hasattr(function, "compile") and hasattr(function, "overloads") and hasattr(function, "py_func")


def arity(function, what: str = "law") -> int:
    """3 (short form) or 9 (full form): the number of positional arguments of ``function``;
    anything else is a :class:`ProtocolError`."""
    python = getattr(function, "py_func", function)
    if not callable(python):
        raise ProtocolError(f"{what}: {python!r} is not a function")
    try:
        count = _required_positional(python)
    except (TypeError, ValueError):
        raise ProtocolError(f"{what}: its signature cannot be read; write it as def law(t, q, qd)") from None
    if count not in (3, 9):
        raise ProtocolError(f"{what}: takes {count} arguments; a law takes ({', '.join(SHORT)}) or "
                            f"({', '.join(FULL)})")
    return count


def _required_positional(python) -> int:
    """How many positional arguments without a default ``python`` takes.  A plain function's
    code says it at once (``inspect.signature`` costs ~14 µs, a tenth of a short run's set-up);
    anything else — a method, a callable object, a function that declares another signature
    (``__wrapped__``, ``__signature__``) — is read by ``inspect``."""
    if (type(python) is types.FunctionType and not hasattr(python, "__wrapped__")
            and not hasattr(python, "__signature__")):
        return python.__code__.co_argcount - len(python.__defaults__ or ())
    parameters = inspect.signature(python).parameters.values()
    return sum(1 for p in parameters if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
               and p.default is p.empty)


def short_law_tau(function, n: int, t, q, qd) -> np.ndarray:
    """τ of a short-form law, checked: a float array of shape (n,)."""
    tau = function(t, q, qd)
    try:
        array = np.asarray(tau, dtype=float)
    except (TypeError, ValueError):
        raise ProtocolError(f"law: returned {type(tau).__name__}, expected {n} joint torques") from None
    if array.shape != (n,):
        raise ProtocolError(f"law: returned shape {array.shape}, expected ({n},) joint torques")
    return array


@functools.cache
def _compiled_short(function):
    """The full-form compiled law around a compiled short-form one (its τ copied out)."""
    from numba import njit

    @njit
    def law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
        tau = function(t, q, qd)
        for i in range(tau_out.shape[0]):
            tau_out[i] = tau[i]

    return law


@dataclass(frozen=True, eq=False)
class FunctionController(Controller):
    """A controller whose law is the function ``law`` (module docstring): short form
    ``tau = law(t, q, qd)`` or the full protocol; plain Python or ``numba.njit``.

    ``model`` the controller's robot; ``parameters`` what the full form receives as ``params``;
    ``z0`` (k,) the initial controller state and ``state_names`` its k labels; ``logged`` the
    signals the full form writes (short form: none).
    """

    model: object
    law: object
    parameters: tuple = ()
    z0: np.ndarray = field(default_factory=lambda: np.zeros(0))
    state_names: tuple = ()
    logged: tuple = ()

    def __post_init__(self):
        count = arity(self.law)
        z0 = np.atleast_1d(np.asarray(self.z0, dtype=float))
        if z0.ndim != 1:
            raise ProtocolError(f"z0: must be a vector, got shape {z0.shape}")
        object.__setattr__(self, "z0", z0)
        if count == 3 and (z0.size or self.logged):
            raise ProtocolError("law: the short form tau = law(t, q, qd) has no state and logs no "
                                "signals; write the full form for z0 and logged")
        if not all(isinstance(signal, Signal) for signal in self.logged):
            raise ProtocolError("logged: must be armlab Signal objects")
        if is_compiled(self.law) and count == 9:
            check_params(self.parameters)

    @property
    def short(self) -> bool:
        return arity(self.law) == 3

    def law_function(self):
        """The full-form law the simulator runs: ``law`` itself, or, for the short form, a
        wrapper (compiled when ``law`` is)."""
        if not self.short:
            return self.law
        if is_compiled(self.law):
            return _compiled_short(self.law)
        function, n = self.law, self.model.n

        def law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
            tau_out[:] = short_law_tau(function, n, t, q, qd)

        return law

    def params(self):
        return self.parameters if not self.short else ()

    def initial_state(self) -> np.ndarray:
        return self.z0.copy()

    def state_labels(self) -> tuple[str, ...]:
        return tuple(self.state_names)

    def signals(self) -> tuple[Signal, ...]:
        return tuple(self.logged)

    def describe(self) -> dict:
        python = getattr(self.law, "py_func", self.law)
        return {"type": "FunctionController", "model": self.model.name,
                "law": getattr(python, "__qualname__", repr(python)), "compiled": is_compiled(self.law)}
