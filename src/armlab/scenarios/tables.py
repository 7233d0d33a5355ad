"""A scenario file's tables read into objects, each key as the annotation of its field says.

:func:`build` turns a table such as ``[controller]`` into an instance of the class its
``type`` names among the registered subclasses of a base (``armlab.registry``).  Each other
key is the field of that name, read by the field's annotation (``typing.get_type_hints``):

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
anything else                 numbers, arrays or nested arrays of them (expressions allowed)
============================  ===========================================================

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

import numpy as np

from armlab.errors import ArmlabError, ScenarioFileError
from armlab.model.robot import Robot
from armlab.model.toml_io import evaluate_expression
from armlab.registry import ScenarioType, declared, scenario_types
from armlab.spatial import euler_matrix


def number(value, file, where) -> float:
    """A number of the file: a TOML number or an arithmetic expression string (never ``eval``)."""
    if isinstance(value, bool):
        raise ScenarioFileError(file, where, "expected a number, got a boolean")
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str):
        try:
            return evaluate_expression(value, {})
        except Exception as error:  # any parse problem becomes the file's one-line error
            raise ScenarioFileError(file, where, f"cannot evaluate {value!r} ({error})") from None
    raise ScenarioFileError(file, where, f"expected a number, got {value!r}")


def numbers(value, file, where):
    """Numbers, lists and nested lists of numbers (expressions allowed) → floats/arrays."""
    if isinstance(value, list):
        return np.array([numbers(v, file, f"{where}[{i}]") for i, v in enumerate(value)])
    return number(value, file, where)


def integer(value, file, where) -> int:
    result = number(value, file, where)
    if not result.is_integer():
        raise ScenarioFileError(file, where, f"expected an integer, got {value!r}")
    return int(result)


def robot(name, overrides, file, where, tip=None) -> Robot:
    """The robot ``name`` (bundled name or file, relative to the scenario file) with its link
    masses overridden by ``overrides`` ({link: mass}, the ``<where>_link_mass`` key); ``tip``
    (the ``<where>_tip`` key) chooses the end-effector link of a URDF/MJCF tree."""
    from armlab.robots import load_robot

    if not isinstance(name, str):
        raise ScenarioFileError(file, where, f"expected a robot name or file, got {name!r}")
    if tip is not None and not isinstance(tip, str):
        raise ScenarioFileError(file, f"{where}_tip", f"expected a link name, got {tip!r}")
    path = Path(name)
    if path.suffix and not path.is_absolute():
        path = Path(file).parent / path
    try:
        loaded = load_robot(str(path) if path.suffix else name, tip=tip)
    except ArmlabError as error:
        raise ScenarioFileError(file, where, str(error)) from None
    if not isinstance(overrides, dict):
        raise ScenarioFileError(file, f"{where}_link_mass", "expected a table {link = mass}")
    links = [link.name for link in loaded.links]
    for link, mass in overrides.items():
        if link not in links:
            raise ScenarioFileError(file, f"{where}_link_mass.{link}",
                                    f"no such link in {loaded.name} ({', '.join(links)})")
        try:
            loaded = loaded.with_link_mass(link, number(mass, file, f"{where}_link_mass.{link}"))
        except ValueError as error:
            raise ScenarioFileError(file, f"{where}_link_mass.{link}", str(error)) from None
    return loaded


@functools.cache
def _fields(cls: type) -> dict[str, tuple[object, bool]]:
    """{field name: (annotation, required)} of the fields a constructor of ``cls`` takes."""
    hints = typing.get_type_hints(cls)
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
    if origin is typing.Literal:
        choices = typing.get_args(hint)
        if not any(type(value) is type(choice) and value == choice for choice in choices):
            raise ScenarioFileError(file, where, f"{value!r} is not one of "
                                                 f"{', '.join(str(c) for c in choices)}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ScenarioFileError(file, where, f"expected a string, got {value!r}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ScenarioFileError(file, where, f"expected true or false, got {value!r}")
        return value
    if hint is int:
        return integer(value, file, where)
    if origin is tuple and typing.get_args(hint) == (int, ...):
        if not isinstance(value, list):
            raise ScenarioFileError(file, where, f"expected an array of integers, got {value!r}")
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
    if kind not in kinds:
        raise ScenarioFileError(file, f"{where}.type", f"unknown type {kind!r} (use {', '.join(kinds)})")
    return kinds[kind]


def _split_poses(declaration: ScenarioType, table: dict, file, where) -> dict:
    """The position and rotation fields of the pose keys of ``table`` (declared ``poses``)."""
    arguments = {}
    euler = table.get("euler", "zyz")
    if not isinstance(euler, str):
        raise ScenarioFileError(file, f"{where}.euler", f"expected a string, got {euler!r}")
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


def build(base: type, table, file, where: str, plant: str | None = None, plant_tip: str | None = None):
    """An instance of the registered subclass of ``base`` that ``table`` describes.

    ``where`` names the table in messages ("controller"); ``plant`` is the plant's name (and
    ``plant_tip`` its tip), the default of a required ``Robot`` field (a controller's ``model``).
    """
    if not isinstance(table, dict):
        raise ScenarioFileError(file, where, "expected a table")
    declaration = _choose(base, table, file, where)
    fields = _fields(declaration.cls)
    arguments = _split_poses(declaration, table, file, where) if declaration.poses else {}
    # Keys read with another key rather than as a field of their own.
    companions = {f"{name}{suffix}" for name, (hint, _) in fields.items() if hint is Robot
                  for suffix in ("_link_mass", "_tip")}
    companions |= set(declaration.poses) | ({"euler"} if declaration.poses else set())
    for key, value in table.items():
        if key == "type" or key in companions - set(fields):
            continue
        if key not in fields:
            known = sorted(set(fields) | companions)
            raise ScenarioFileError(file, f"{where}.{key}", f"unknown key for {declaration.name} "
                                                            f"(use {', '.join(known)})")
        hint, _ = fields[key]
        if hint is not Robot:
            arguments[key] = read(hint, value, file, f"{where}.{key}", plant, plant_tip)
    for name, (hint, required) in fields.items():
        # An optional robot is built when named or when only its masses are overridden (it is
        # then the plant with those masses).
        given = name in table or f"{name}_link_mass" in table
        if hint is Robot and (given or (required and plant is not None)):
            tip = table.get(f"{name}_tip", None if name in table else plant_tip)
            arguments[name] = robot(table.get(name, plant), table.get(f"{name}_link_mass", {}),
                                    file, f"{where}.{name}", tip)
        if required and name not in arguments:
            raise ScenarioFileError(file, f"{where}.{name}", "missing")
    try:
        built = declaration.cls(**arguments)
        getattr(built, "data", None)  # joint references check their numbers when first asked
    except (ArmlabError, TypeError, ValueError) as error:
        raise ScenarioFileError(file, where, str(error)) from None
    return built
