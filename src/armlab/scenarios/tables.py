"""A scenario file read into objects, each key as the annotation of its field says.

:func:`scenario_from_table` reads a whole file (its top-level keys, ``[simulation]`` and
the tables below) into a :class:`~armlab.scenarios.scenario.Scenario`.  :func:`build` turns
a table such as ``[controller]`` into an instance of the class its ``type`` names among the
registered subclasses of a base (``armlab.registry``).  Each other key is the field of that
name, read by the field's annotation (``typing.get_type_hints``):

============================  ===========================================================
annotation                    what the file writes
============================  ===========================================================
``Literal["a", "b"]``         one of the strings a, b
``str``                       a string
``bool``                      true or false
``int``                       an integer (or an expression of one)
``tuple[int, ...]``           an array of integers
``float``                     a number or an expression string (``"pi/3"``)
``Robot``                     a robot name or file; ``<field>_link_mass = {link = mass}``
                              overrides masses; a required one, or one given only by its
                              masses, defaults to the plant
a class with registered       a table: ``type`` picks the subclass (a registered class
subclasses                    itself needs no ``type``)
``Annotated[T, Condition]``    T, which must also meet the condition (``"positive"``)
anything else                 numbers, arrays or nested arrays of them (expressions allowed)
============================  ===========================================================

Every number is finite (NaN and ±inf are refused, so are booleans where a number is
expected); nested arrays are rectangular and at most :data:`MAX_NESTING` deep; integers are
at most 2⁵³ in magnitude.

Keys declared as ``poses`` by the class are poses [x, y, z, φ, ϑ, ψ] (Euler angles of the
table's ``euler``, default ZYZ) split into its position and rotation-matrix fields.  Every
problem raises :class:`ScenarioFileError`, one line ``<file>: <field>: <what is wrong>``.
"""

from __future__ import annotations

import dataclasses
import functools
import types
import typing
from pathlib import Path
from typing import Annotated, Literal

import numpy as np

from armlab.control.base import Controller, Environment
from armlab.errors import ArmlabError, ScenarioFileError
from armlab.inputs import read_input_toml
from armlab.model.robot import Robot, nonfinite_part
from armlab.model.toml_io import MAX_MAGNITUDE, evaluate_expression
from armlab.registry import ScenarioType, declared, load_declared_modules, scenario_types
from armlab.scenarios.scenario import Scenario
from armlab.simulation.disturbances import TorqueDisturbance
from armlab.spatial import euler_matrix
from armlab.specialise import DYNAMICS_CHOICES

MAX_NESTING = 4
"""Deepest nesting of arrays a field may have (poses are arrays of arrays: 2)."""

MAX_INTEGER = 2**53
"""Largest |integer| of a scenario field (every integer up to it is exact as a float)."""


def _shorten(value, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}…"


def number(value, file, where) -> float:
    """A finite number of the file: a TOML number or an arithmetic expression string (never
    ``eval``).  Booleans, NaN, ±inf and integers beyond the float range are refused."""
    if isinstance(value, bool):
        raise ScenarioFileError(file, where, "expected a number, got a boolean")
    if isinstance(value, (int, float)):
        try:
            result = float(value)
        except OverflowError:
            raise ScenarioFileError(file, where,
                                    f"is beyond the range of a float ({_shorten(value)})") from None
    elif isinstance(value, str):
        try:
            result = evaluate_expression(value, {})
        except (ValueError, ArithmeticError) as error:
            raise ScenarioFileError(file, where, f"cannot evaluate {_shorten(value)} ({error})") from None
    else:
        raise ScenarioFileError(file, where, f"expected a number, got {_shorten(value)}")
    if not np.isfinite(result):
        raise ScenarioFileError(file, where, f"must be finite, got {_shorten(value)}")
    return result


def numbers(value, file, where, depth: int = 0):
    """Numbers, lists and nested lists of numbers (expressions allowed) → floats/arrays.

    Nested lists must be rectangular (rows of one length) and at most :data:`MAX_NESTING` deep.
    """
    if not isinstance(value, list):
        return number(value, file, where)
    if depth >= MAX_NESTING:
        raise ScenarioFileError(file, where, f"arrays nested more than {MAX_NESTING} deep")
    items = [numbers(v, file, f"{where}[{i}]", depth + 1) for i, v in enumerate(value)]
    shapes = {np.shape(item) for item in items}
    if len(shapes) > 1:
        raise ScenarioFileError(file, where, "expected rows of one length, got shapes "
                                             f"{', '.join(str(s) for s in sorted(shapes))}")
    return np.array(items, dtype=float)


def integer(value, file, where) -> int:
    """An integer of the file (a number or expression with an integer value), |i| ≤ 2⁵³."""
    result = number(value, file, where)
    if not result.is_integer():
        raise ScenarioFileError(file, where, f"expected an integer, got {_shorten(value)}")
    if abs(result) > MAX_INTEGER:
        raise ScenarioFileError(file, where, f"integer {result:g} is beyond ±2**53")
    return int(result)


class Condition(typing.NamedTuple):
    """A condition on a field's value, written in its annotation as
    ``Annotated[float, Condition("positive", lambda v: v > 0)]``; arrays must meet it in every
    entry.  ``text`` completes "must be …" in the error."""

    text: str
    test: typing.Callable


@functools.lru_cache(maxsize=64)
def _robot_of_file(text: str, tip, identity: tuple, allow_outside: bool = False) -> Robot:
    """The robot of ``text`` (its ``tip`` link chosen) read once per version of its file
    (``identity``: the file's absolute path, modification time and size), since a sweep builds
    thousands of scenarios from the same robot files; a Robot is frozen, so the copies it hands
    out are one object."""
    from armlab.robots import load_robot

    return load_robot(text, tip=tip, allow_outside=allow_outside)


@functools.cache
def _bundled_robots() -> dict[str, Path]:
    """{name: file} of the robots shipped in the package (fixed while it is installed)."""
    from armlab.robots import bundled_robot_names, bundled_robot_path

    return {name: bundled_robot_path(name) for name in bundled_robot_names()}


def _load_robot(text: str, tip=None, allow_outside: bool = False) -> Robot:
    from armlab.robots import load_robot

    path = Path(text) if Path(text).suffix else _bundled_robots().get(text)
    try:
        stat = path.stat()
    except (OSError, AttributeError):
        # Says what is wrong with the name or file (or loads a zoo arm).
        return load_robot(text, tip=tip, allow_outside=allow_outside)
    return _robot_of_file(text, tip, (str(path.absolute()), stat.st_mtime_ns, stat.st_size), allow_outside)


def robot(name, overrides, file, where, tip=None, allow_outside: bool = False) -> Robot:
    """The robot ``name`` (bundled name or file, relative to the scenario file) with its link
    masses overridden by ``overrides`` ({link: mass}, the ``<where>_link_mass`` key); ``tip``
    (the ``<where>_tip`` key) chooses the end-effector link of a URDF/MJCF tree.  A robot file
    must lie under the scenario file's folder unless ``allow_outside`` (which also lets the
    robot file name files outside its own folder, :mod:`armlab.model.references`)."""
    from armlab.model.references import is_under

    if not isinstance(name, str):
        raise ScenarioFileError(file, where, f"expected a robot name or file, got {_shorten(name)}")
    if tip is not None and not isinstance(tip, str):
        raise ScenarioFileError(file, f"{where}_tip", f"expected a link name, got {_shorten(tip)}")
    path = Path(name)
    if path.suffix and not path.is_absolute():
        path = Path(file).parent / path
    if path.suffix and not allow_outside and not is_under(path, Path(file).absolute().parent.resolve()):
        raise ScenarioFileError(file, where, f"the robot file {_shorten(name)} lies outside the scenario "
                                             "file's folder (allow_outside=True or --allow-outside reads it)")
    try:
        loaded = _load_robot(str(path) if path.suffix else name, tip, allow_outside)
    except ArmlabError as error:
        raise ScenarioFileError(file, where, str(error)) from None
    if not isinstance(overrides, dict):
        raise ScenarioFileError(file, f"{where}_link_mass", "expected a table {link = mass}")
    links = [link.name for link in loaded.links]
    for link, mass in overrides.items():
        if link not in links:
            raise ScenarioFileError(file, f"{where}_link_mass.{link}",
                                    f"no such link in {loaded.name} ({', '.join(links)})")
        field = f"{where}_link_mass.{link}"
        value = number(mass, file, field)
        if not 0 <= value <= MAX_MAGNITUDE:
            raise ScenarioFileError(file, field, f"must be a mass from 0 to {MAX_MAGNITUDE:g} kg, "
                                                 f"got {value:g}")
        with np.errstate(all="ignore"):  # overflow is reported below, as the robot's
            loaded = loaded.with_link_mass(link, value)
        part = nonfinite_part(loaded)
        if part is not None:
            raise ScenarioFileError(file, field, f"the {part[0]} values of {loaded.name} overflow")
    return loaded


@functools.cache
@functools.lru_cache(maxsize=256)
def _fields(cls: type) -> dict[str, tuple[object, bool]]:
    """{field name: (annotation, required)} of the fields a constructor of ``cls`` takes
    (remembered per class: ``typing.get_type_hints`` costs more than the rest of a build;
    callers only read it)."""
    hints = typing.get_type_hints(cls, include_extras=True)  # keeps Annotated conditions
    return {f.name: (_without_none(hints[f.name]), f.default is dataclasses.MISSING
                     and f.default_factory is dataclasses.MISSING)
            for f in dataclasses.fields(cls) if f.init}


def _without_none(hint):
    """``X | None`` → X (a field that may be left out reads like its type)."""
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        rest = [arg for arg in typing.get_args(hint) if arg is not type(None)]
        if len(rest) == 1:
            return rest[0]
    return hint


def read(hint, value, file, where, plant=None, plant_tip=None):
    """``value`` of the file as the annotation ``hint`` says (see the module docstring)."""
    origin = typing.get_origin(hint)
    if origin is typing.Annotated:
        base, *conditions = typing.get_args(hint)
        result = read(base, value, file, where, plant, plant_tip)
        for condition in conditions:
            if isinstance(condition, Condition) and not np.all(condition.test(result)):
                raise ScenarioFileError(file, where, f"must be {condition.text}, got {_shorten(value)}")
        return result
    if origin is typing.Literal:
        choices = typing.get_args(hint)
        if not any(type(value) is type(choice) and value == choice for choice in choices):
            raise ScenarioFileError(file, where, f"{_shorten(value)} is not one of "
                                                 f"{', '.join(str(c) for c in choices)}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ScenarioFileError(file, where, f"expected a string, got {_shorten(value)}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ScenarioFileError(file, where, f"expected true or false, got {_shorten(value)}")
        return value
    if hint is int:
        return integer(value, file, where)
    if origin is tuple and typing.get_args(hint) == (int, ...):
        if not isinstance(value, list):
            raise ScenarioFileError(file, where, f"expected an array of integers, got {_shorten(value)}")
        return tuple(integer(v, file, f"{where}[{i}]") for i, v in enumerate(value))
    if hint is float:
        return number(value, file, where)
    if isinstance(hint, type) and hint is not object and scenario_types(hint):
        return build(hint, value, file, where, plant, plant_tip)
    return numbers(value, file, where)


def _choose(base: type, table: dict, file, where) -> ScenarioType:
    """The declaration ``table["type"]`` names among the registered subclasses of ``base``;
    a registered ``base`` is itself the default."""
    if "type" not in table and declared(base) is not None:
        return declared(base)
    kinds = scenario_types(base)
    kind = table.get("type")
    problems = []
    if isinstance(kind, str) and kind not in kinds:
        # Perhaps an installed package's type (armlab.registry): its modules load only now.
        problems = load_declared_modules()
        kinds = scenario_types(base)
    if not isinstance(kind, str) or kind not in kinds:
        also = f"; {problems[0]}" if problems else ""
        raise ScenarioFileError(file, f"{where}.type",
                                f"unknown type {_shorten(kind)} (use {', '.join(kinds)}){also}")
    return kinds[kind]


def _split_poses(declaration: ScenarioType, table: dict, file, where) -> dict:
    """The position and rotation fields of the pose keys of ``table`` (declared ``poses``)."""
    arguments = {}
    euler = table.get("euler", "zyz")
    if not isinstance(euler, str):
        raise ScenarioFileError(file, f"{where}.euler", f"expected a string, got {_shorten(euler)}")
    for key, (position, rotation) in declaration.poses.items():
        if key not in table:
            continue
        if position in table or rotation in table:
            raise ScenarioFileError(file, f"{where}.{key}", f"replaces {position} and {rotation}: "
                                                            "give one or the other")
        pose = np.asarray(numbers(table[key], file, f"{where}.{key}"), dtype=float)
        if pose.ndim == 0 or pose.shape[-1] != 6:
            raise ScenarioFileError(file, f"{where}.{key}", f"expected poses [x, y, z, φ, ϑ, ψ], "
                                                            f"got shape {pose.shape}")
        try:
            rotations = [euler_matrix(angles, euler) for angles in pose[..., 3:].reshape(-1, 3)]
        except ValueError as error:
            raise ScenarioFileError(file, f"{where}.euler", str(error)) from None
        arguments[position] = pose[..., :3]
        arguments[rotation] = np.reshape(rotations, pose.shape[:-1] + (3, 3))
    return arguments


def build(base: type, table, file, where: str, plant: str | None = None, plant_tip: str | None = None,
          allow_outside: bool = False):
    """An instance of the registered subclass of ``base`` that ``table`` describes.

    ``where`` names the table in messages ("controller"); ``plant`` is the plant's name (and
    ``plant_tip`` its tip), the default of a required ``Robot`` field (a controller's ``model``);
    ``allow_outside`` as for :func:`robot`.
    """
    declaration = _declaration(base, table, file, where)
    return construct(declaration, arguments(declaration, table, file, where, plant, plant_tip, allow_outside),
                     file, where)


def _declaration(base: type, table, file, where: str) -> ScenarioType:
    if not isinstance(table, dict):
        raise ScenarioFileError(file, where, "expected a table")
    return _choose(base, table, file, where)


def arguments(declaration: ScenarioType, table: dict, file, where: str, plant: str | None = None,
              plant_tip: str | None = None, allow_outside: bool = False, skip: str | None = None) -> dict:
    """{field: value} of the constructor of ``declaration`` that ``table`` describes (as
    :func:`build` reads them), without the field ``skip`` (which a caller reads itself)."""
    fields = _fields(declaration.cls)
    result = _split_poses(declaration, table, file, where) if declaration.poses else {}
    # Keys read with another key rather than as a field of their own.
    companions = {f"{name}{suffix}" for name, (hint, _) in fields.items() if hint is Robot
                  for suffix in ("_link_mass", "_tip")}
    companions |= set(declaration.poses) | ({"euler"} if declaration.poses else set())
    for key, value in table.items():
        if key == "type" or key == skip or key in companions - set(fields):
            continue
        if key not in fields:
            known = sorted(set(fields) | companions)
            raise ScenarioFileError(file, f"{where}.{key}", f"unknown key for {declaration.name} "
                                                            f"(use {', '.join(known)})")
        hint, _ = fields[key]
        if hint is not Robot:
            result[key] = read(hint, value, file, f"{where}.{key}", plant, plant_tip)
    for name, (hint, required) in fields.items():
        # An optional robot is built when named or when only its masses are overridden (it is
        # then the plant with those masses).
        given = name in table or f"{name}_link_mass" in table
        if hint is Robot and (given or (required and plant is not None)):
            tip = table.get(f"{name}_tip", None if name in table else plant_tip)
            result[name] = robot(table.get(name, plant), table.get(f"{name}_link_mass", {}),
                                 file, f"{where}.{name}", tip, allow_outside)
        if required and name not in result and name != skip:
            raise ScenarioFileError(file, f"{where}.{name}", "missing")
    return result


def construct(declaration: ScenarioType, arguments: dict, file, where: str):
    """``declaration``'s class built from ``arguments``: its own checks, in one line."""
    try:
        built = declaration.cls(**arguments)
        getattr(built, "data", None)  # joint references check their numbers when first asked
    except (ArmlabError, TypeError, ValueError, ArithmeticError) as error:
        raise ScenarioFileError(file, where, str(error)) from None
    return built


# --------------------------------------------------------------------------- the whole file

_POSITIVE = Condition("positive", lambda value: value > 0)
_Positive = Annotated[float, _POSITIVE]
SIMULATION_FIELDS = {
    "t_final": _Positive, "dt": _Positive, "q0": np.ndarray, "qd0": np.ndarray,
    "method": Literal["rk4", "adaptive"], "control_period": _Positive,
    "torque_limit": Annotated[np.ndarray, _POSITIVE], "log_every": Annotated[int, _POSITIVE],
    "limit_margin": Annotated[float, Condition("≥ 0", lambda value: value >= 0)],
    "max_kinetic_energy": _Positive, "rtol": _Positive, "atol": _Positive,
    "dynamics": Literal[DYNAMICS_CHOICES], "joint_limits": Literal["ignore", "warn", "stop"],
    "max_steps": Annotated[int, _POSITIVE],
}
"""The ``[simulation]`` keys (keyword arguments of ``armlab.simulate``), read as annotated."""
SIMULATION_KEYS = set(SIMULATION_FIELDS)
PER_JOINT = ("q0", "qd0", "torque_limit")
"""Simulation keys holding a number (every joint) or one number per joint."""
TOP_KEYS = {"title", "assignment", "description", "plant", "plant_link_mass", "plant_tip", "simulation",
            "controller", "disturbance", "environment", "expect"}


def read_scenario_toml(path: Path) -> dict:
    """The parsed TOML of a scenario file (a regular file of at most
    ``armlab.inputs.TOML_LIMIT`` bytes); unreadable or malformed files raise one line."""
    return read_input_toml(path, ScenarioFileError)


def _settings(simulation, path, n: int) -> dict:
    """The checked ``[simulation]`` keyword arguments of ``armlab.simulate`` for a plant of
    ``n`` joints: each key read by its annotation in :data:`SIMULATION_FIELDS`, per-joint
    values of length 1 or n, and dt ≤ control_period ≤ t_final."""
    if not isinstance(simulation, dict):
        raise ScenarioFileError(path, "simulation", "expected a table")
    settings = {}
    for key, value in simulation.items():
        if key not in SIMULATION_FIELDS:
            raise ScenarioFileError(path, f"simulation.{key}",
                                    f"unknown key (use {', '.join(sorted(SIMULATION_KEYS))})")
        settings[key] = read(SIMULATION_FIELDS[key], value, path, f"simulation.{key}")
        if key in PER_JOINT and np.ndim(settings[key]) > 0 and np.shape(settings[key]) != (n,):
            raise ScenarioFileError(path, f"simulation.{key}", f"expected a number or {n} numbers "
                                    f"(one per joint), got shape {np.shape(settings[key])}")
    for key in ("t_final", "dt", "q0"):
        if key not in settings:
            raise ScenarioFileError(path, f"simulation.{key}", "missing")
    t_final, dt = settings["t_final"], settings["dt"]
    if dt > t_final:
        raise ScenarioFileError(path, "simulation.dt", f"{dt:g} s is longer than t_final = {t_final:g} s")
    period = settings.get("control_period")
    if period is not None and not dt <= period <= t_final:
        raise ScenarioFileError(path, "simulation.control_period", f"{period:g} s must lie between "
                                f"dt = {dt:g} s and t_final = {t_final:g} s")
    return settings


def _disturbance(terms, plant: Robot, path) -> tuple:
    """The ``[[disturbance]]`` terms, checked against the plant's joints."""
    if not isinstance(terms, list):
        raise ScenarioFileError(path, "disturbance", "expected an array of tables [[disturbance]]")
    disturbance = tuple(build(TorqueDisturbance, term, path, f"disturbance[{i}]")
                        for i, term in enumerate(terms))
    for i, term in enumerate(disturbance):
        try:
            term.encode(plant.n)
        except ArmlabError as error:
            raise ScenarioFileError(path, f"disturbance[{i}]", str(error)) from None
    return disturbance


def scenario_from_table(data: dict, path, *, allow_outside: bool = False) -> Scenario:
    """The scenario the parsed TOML ``data`` describes; ``path`` names it in messages and
    anchors relative robot files (a sweep builds each run's scenario from edited tables).
    Robot files must lie under the folder of ``path`` unless ``allow_outside``."""
    path = Path(path)
    if not isinstance(data, dict):
        raise ScenarioFileError(path, "file", "expected a table")
    unknown = set(data) - TOP_KEYS
    if unknown:
        raise ScenarioFileError(path, sorted(unknown)[0], f"unknown key (use {', '.join(sorted(TOP_KEYS))})")
    for key in ("plant", "simulation", "controller"):
        if key not in data:
            raise ScenarioFileError(path, key, "missing")
    plant = robot(data["plant"], data.get("plant_link_mass", {}), path, "plant", data.get("plant_tip"),
                  allow_outside)
    settings = _settings(data["simulation"], path, plant.n)
    controller = build(Controller, data["controller"], path, "controller", plant=data["plant"],
                       plant_tip=data.get("plant_tip"), allow_outside=allow_outside)
    disturbance = _disturbance(data.get("disturbance", []), plant, path)
    environment = None
    if "environment" in data:
        environment = build(Environment, data["environment"], path, "environment")
    texts = {key: read(str, data.get(key, default), path, key)
             for key, default in (("title", path.stem), ("assignment", ""), ("description", ""))}
    expect = "ok"
    if "expect" in data:
        expect = read(typing.get_type_hints(Scenario)["expect"], data["expect"], path, "expect")
    return Scenario(name=path.stem, **texts, expect=expect, plant=plant, controller=controller,
                    disturbance=disturbance, simulation=settings, source=str(path),
                    environment=environment)
