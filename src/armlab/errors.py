"""Every exception armlab raises on purpose, in one tree; the CLI prints their one-line message,
never a traceback.

Each class is also the builtin a Python programmer would catch for the same fault, so
``except ValueError`` keeps working around armlab calls:

    ArmlabError
    ├── InputError (ValueError)            a value armlab cannot use; the message names the field
    │   ├── FileFieldError                 … read from a file: ``file: field: reason``
    │   │   ├── RobotFileError             robot TOML / URDF files
    │   │   ├── ScenarioFileError          scenario TOML files
    │   │   └── SweepFileError             sweep TOML files
    │   ├── SweepStoreError                a sweep's output folder (``folder: reason``)
    │   ├── SchedulerAddressError          a Dask scheduler address that cannot be used
    │   ├── FieldPathError                 a sweep's field path that does not fit its scenario
    │   ├── ResultFileError                result files (``file: reason``)
    │   ├── SpecError                      parameters that cannot define the thing asked for
    │   │   ├── ControllerSpecError        gains, options, models of a controller
    │   │   ├── EnvironmentSpecError       springs, walls
    │   │   ├── ReferenceSpecError         joint references
    │   │   ├── TaskReferenceError         pose and force references
    │   │   ├── DisturbanceSpecError       torque disturbances
    │   │   ├── TaskSelectionError         task components of a robot
    │   │   └── SimulationError            settings of ``simulate``
    │   ├── UnreachableTargetError         inverse kinematics without a solution
    │   ├── RepresentationSingularityError Euler angles at their singularity
    │   ├── SingularInertiaError           B(q) not positive definite (a massless moving link)
    │   └── ReportError, ScopeError, AnimationError   what a report, plot or animation needs
    ├── ProtocolError (TypeError)          an object that does not follow a protocol (a law that
    │   └── IndirectCallError              is not compiled, a callee with the wrong return type)
    ├── ClosedFormUnavailable (RuntimeError)   no usable generated dynamics for a robot (says why)
    ├── SimulationDiverged (RuntimeError)  the closed loop diverged (or was stopped by its step
    │                                      budget); ``.result`` keeps the data
    └── CommandError                       a command-line argument armlab cannot use

    SimulationInterrupted (KeyboardInterrupt)  Ctrl-C during a run; ``.result`` keeps the data
                                           (not an ArmlabError: ``except Exception`` must not stop
                                           a Ctrl-C)
    CacheWarning (UserWarning)             a damaged or unusable cache entry was discarded
"""

from __future__ import annotations


class ArmlabError(Exception):
    """Base class of every error armlab reports to a user (bad input, divergence, …)."""


class InputError(ArmlabError, ValueError):
    """A value armlab cannot use; the message names the field and says what is wrong."""


# Line breaks and other control characters that a file name, a TOML key or a quoted value may
# carry into a message; escaped so that the message stays one line.
_CONTROL = {code: f"\\x{code:02x}" for code in (*range(32), 127, 0x85)}
_CONTROL |= {ord("\n"): "\\n", ord("\r"): "\\r", ord("\t"): "\\t",
             0x2028: "\\u2028", 0x2029: "\\u2029"}


def one_line(text) -> str:
    """``str(text)`` with line breaks and control characters escaped (``\\n``, ``\\x1b``)."""
    return str(text).translate(_CONTROL)


class FileFieldError(InputError):
    """A file field that cannot be used; ``str()`` is ``file: field: reason``, one line."""

    def __init__(self, file, field: str, reason: str):
        self.file, self.field, self.reason = one_line(file), one_line(field), one_line(reason)
        super().__init__(f"{self.file}: {self.field}: {self.reason}")

    def __reduce__(self):
        # Rebuilt from its three parts (not from the message) when it crosses to another process.
        return type(self), (self.file, self.field, self.reason)


class RobotFileError(FileFieldError):
    """A robot file that cannot describe a robot."""


class ScenarioFileError(FileFieldError):
    """A scenario file that cannot be run."""


class SweepFileError(FileFieldError):
    """A sweep file that cannot define a sweep (its scenario, axes, paths or settings)."""


class RolloutUnsupported(SweepFileError):
    """A batch whose runs differ in more than numbers the compiled loop reads (the message
    names the field and why): run it run by run (``armlab sweep`` does)."""


class FieldPathError(InputError):
    """A sweep's field path that does not fit its scenario's tables (the message says why)."""


class SweepStoreError(InputError):
    """A sweep's output folder that cannot be written or resumed; the message names it."""


class SchedulerAddressError(InputError):
    """A Dask scheduler address that is malformed, of an unsupported kind or unreachable;
    ``reason`` says which (the message is ``scheduler: reason``)."""

    def __init__(self, reason: str):
        self.reason = one_line(reason)
        super().__init__(f"scheduler: {self.reason}")

    def __reduce__(self):
        return type(self), (self.reason,)


class ResultFileError(InputError):
    """A result file that cannot be written or read; the message is ``file: reason``."""


class SpecError(InputError):
    """Parameters that cannot define what was asked for (names the field)."""


class ControllerSpecError(SpecError):
    """Controller parameters that cannot define the law: gains, options, models."""


class EnvironmentSpecError(SpecError):
    """Environment parameters that do not describe a physical environment."""


class ReferenceSpecError(SpecError):
    """A joint reference whose numbers cannot describe a trajectory."""


class TaskReferenceError(SpecError):
    """A pose or force reference that cannot be evaluated."""


class DisturbanceSpecError(SpecError):
    """A torque disturbance that cannot be evaluated."""


class TaskSelectionError(SpecError):
    """Task components a robot cannot control."""


class SimulationError(SpecError):
    """Bad simulation settings (names the argument)."""


class UnreachableTargetError(InputError):
    """No joint configuration (inside the joint limits, if respected) reaches the target.

    Attributes: ``reason`` (``"out of reach"``, ``"joint limits"`` or ``"orientation"``),
    ``best_q`` (n,) the best attempt, ``position_error`` [m] and ``orientation_error`` [rad]
    of that attempt.
    """

    def __init__(self, message: str, *, reason: str, best_q=None, position_error=float("nan"),
                 orientation_error=float("nan")):
        import numpy as np  # here: importing the error tree stays free of numpy

        super().__init__(message)
        self.reason = reason
        self.best_q = None if best_q is None else np.asarray(best_q, dtype=float)
        self.position_error = float(position_error)
        self.orientation_error = float(orientation_error)

    def __reduce__(self):
        return _rebuild, (type(self), self.args, {"reason": self.reason, "best_q": self.best_q,
                                                  "position_error": self.position_error,
                                                  "orientation_error": self.orientation_error})


class RepresentationSingularityError(InputError):
    """Euler angles asked for at their representation singularity."""


class SingularInertiaError(InputError):
    """B(q) is not positive definite (a link without mass moved by a joint)."""


class ReportError(InputError):
    """A report that cannot be made from what it was given."""


class ScopeError(InputError):
    """A scope figure that cannot be drawn from a result."""


class AnimationError(InputError):
    """An animation that cannot be made from a result."""


class ProtocolError(ArmlabError, TypeError):
    """A controller, environment or law that does not follow the protocol of
    :mod:`armlab.control.base` (a law with the wrong arguments, params that are not a tuple, a
    compiled law that does not compile, an environment law that is not compiled, an object of the wrong
    kind where a reference or controller is expected)."""


class IndirectCallError(ProtocolError):
    """A compiled function does not return what its indirect caller expects."""


class ClosedFormUnavailable(ArmlabError, RuntimeError):
    """The closed form of a robot cannot be used (says why)."""


class SimulationDiverged(ArmlabError, RuntimeError):
    """The closed loop diverged; ``result`` holds the data up to the last good step."""

    def __init__(self, message: str, result):
        super().__init__(message)
        self.result = result

    def __reduce__(self):
        return type(self), (self.args[0], self.result)


def _rebuild(cls, args, keywords):
    """An exception rebuilt in another process from its arguments (``__reduce__``)."""
    return cls(*args, **keywords)


class SimulationInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a run; ``result`` holds the data up to the last complete step (status
    ``"interrupted"``).  A KeyboardInterrupt, so that a script stops as it would anyway."""

    def __init__(self, message: str, result):
        super().__init__(message)
        self.result = result


class CacheWarning(UserWarning):
    """A cache entry (a compiled kernel, a generated module) was damaged or could not be
    written; it was discarded and rebuilt, or the work is done without the cache."""


class CommandError(ArmlabError):
    """A command-line argument that armlab cannot use; printed as one line."""
