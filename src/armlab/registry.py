"""The names by which scenario files build armlab's classes (``type = "joint_pd_gravity"``).

Every class a scenario file can build declares its name where the class is defined::

    @scenario_type("joint_pd_gravity")
    @dataclass(frozen=True, eq=False)
    class JointPDGravity(Controller):
        model: Robot
        reference: JointReference
        kp: np.ndarray
        kd: np.ndarray
        compensation: Literal["online", "desired", "none"] = "online"

and the scenario loader (``armlab.scenarios``) reads each key of the file's table as the
annotation of the field of that name says (a ``Literal`` is a string among its choices, a
number may be an expression, a field annotated with a base class such as ``JointReference``
is a table whose ``type`` names one of its registered subclasses).  A new controller with a
string option therefore touches only its own file.

Names are looked up among the registered subclasses of the base a field (or the file's
``[controller]``, ``[environment]``, ``[[disturbance]]``) asks for, so a name must be unique
only among those: "constant" is both a joint reference and a disturbance.

``poses`` declares a key that the file writes as one pose or an array of poses
[x, y, z, φ, ϑ, ψ] [m, rad] (Euler angles of the table's ``euler`` convention, default ZYZ)
and that the class holds as two fields, positions and rotation matrices:
``poses={"rest_pose": ("rest_position", "rest_rotation")}``.

Classes of other packages
-------------------------
A package of one's own (a controller, an environment, a reference) is named in scenario files
the same way, once the package declares the module that defines it as an entry point of the
group ``armlab.scenario_types`` in its ``pyproject.toml``::

    [project.entry-points."armlab.scenario_types"]
    mylaws = "mypackage.laws"

When a file names a type that no loaded class declares, the loader imports every module so
declared (:func:`load_declared_modules`, once per process) and looks again.  A scenario file
therefore never names code to run: it chooses among the types that installed packages declare.

This module imports nothing of armlab, so every module that defines such a class can import it.
"""

from __future__ import annotations

import importlib
import threading
from dataclasses import dataclass, field, is_dataclass
from importlib.metadata import entry_points


@dataclass(frozen=True)
class ScenarioType:
    """A class as scenario files name it."""

    name: str
    cls: type
    poses: dict[str, tuple[str, str]] = field(default_factory=dict)


_DECLARED: dict[type, ScenarioType] = {}


def scenario_type(name: str, *, poses: dict[str, tuple[str, str]] | None = None):
    """Class decorator: scenario files build the class as ``type = name`` (see the module
    docstring for ``poses``)."""

    def register(cls: type) -> type:
        if not is_dataclass(cls):
            # The loader reads the dataclass fields: the decorator goes above @dataclass.
            raise TypeError(f"@scenario_type({name!r}): {cls.__qualname__} is not a dataclass "
                            "(put @scenario_type above @dataclass)")
        with _LOCK:
            _DECLARED[cls] = ScenarioType(name, cls, dict(poses or {}))
            _BY_BASE.clear()
        return cls

    return register


def declared(cls: type) -> ScenarioType | None:
    """The declaration of ``cls`` itself (None when it was not registered)."""
    return _DECLARED.get(cls)


_BY_BASE: dict[type, dict[str, ScenarioType]] = {}
"""scenario_types() per base class, until the next declaration (a scenario file asks for
them seven times)."""
_LOCK = threading.Lock()
"""Held while a class is declared and while scenario_types() reads the declarations."""


def scenario_types(base: type) -> dict[str, ScenarioType]:
    """The registered subclasses of ``base`` (``base`` included) by name, in the order they
    were declared."""
    found = _BY_BASE.get(base)
    if found is None:
        with _LOCK:
            found = _BY_BASE.get(base)
            if found is None:
                found = _BY_BASE[base] = _scenario_types(base)
    return dict(found)


def _scenario_types(base: type) -> dict[str, ScenarioType]:
    found: dict[str, ScenarioType] = {}
    for cls, declaration in _DECLARED.items():
        if not issubclass(cls, base):
            continue
        other = found.get(declaration.name)
        if other is not None:
            raise TypeError(f"two {base.__name__} classes are registered as {declaration.name!r}: "
                            f"{other.cls.__qualname__} and {cls.__qualname__}")
        found[declaration.name] = declaration
    return found


ENTRY_POINT_GROUP = "armlab.scenario_types"
"""The entry-point group of packages whose modules declare scenario types (module docstring)."""
_LOAD_PROBLEMS: list[str] = []
"""What :func:`load_declared_modules` found: each problem once; empty before the first call."""
_LOADED = threading.Event()
_LOAD_LOCK = threading.Lock()  # not _LOCK: the imported modules declare their classes under it


def load_declared_modules() -> list[str]:
    """Import every module that an installed package declares in :data:`ENTRY_POINT_GROUP`
    (once per process); returns one line per module that could not be imported (the rest are
    loaded all the same)."""
    if not _LOADED.is_set():
        with _LOAD_LOCK:
            if not _LOADED.is_set():
                for point in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda p: p.name):
                    try:
                        importlib.import_module(point.module)
                    except Exception as error:  # a broken plugin names itself, the rest load
                        first_line = (str(error).strip().splitlines() or [""])[0]
                        _LOAD_PROBLEMS.append(f"entry point {point.name} = {point.value!r} "
                                               f"({ENTRY_POINT_GROUP}) cannot be imported: "
                                               f"{type(error).__name__}: {first_line}")
                _LOADED.set()
    return list(_LOAD_PROBLEMS)
