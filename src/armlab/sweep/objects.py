"""The batch of a plant and a controller made in Python: ``armlab.rollout((plant, controller,
settings), batch)``.

A field path here names what the objects hold, as a scenario file's path names its tables:

    controller.kp, controller.kp[1][1]        a field of the controller (an element of its array)
    controller.reference.value[1]             a field of an object the controller holds
    simulation.q0[1], simulation.t_final      a keyword argument of ``armlab.simulate`` (settings)

Each run's controller is the given one with the field replaced (``dataclasses.replace``, so
the class's own checks judge the value) and its settings those given with the value written
in; everything else of :class:`~armlab.sweep.plan.BatchPlan` — probing, checks per distinct
value, the runs — is the file's.
"""

from __future__ import annotations

import dataclasses
import inspect
from pathlib import Path

import numpy as np

from armlab.errors import FieldPathError, SweepFileError
from armlab.sweep.fields import _PATH, _segments
from armlab.sweep.plan import BatchPlan

ROOTS = ("controller", "simulation")


def _replaced(holder, parts: list, value: float, where: str, dry: bool = False):
    """``holder`` (a frozen dataclass) with the field at ``parts`` set to ``value``: the objects
    on the way are replaced, never written; an array element is set in a copy of the array.
    ``dry``: only check that the path exists (a :class:`FieldPathError` if not)."""
    name, rest = parts[0], list(parts[1:])
    if not (dataclasses.is_dataclass(holder) and isinstance(name, str)
            and name in {f.name for f in dataclasses.fields(holder) if f.init}):
        raise FieldPathError(f"{where}: {type(holder).__name__} has no field {name!r}")
    current = getattr(holder, name)
    indices = []
    while rest and isinstance(rest[0], int):
        indices.append(rest.pop(0))
    if rest:
        new = _replaced(current, rest, value, f"{where}.{name}", dry)
    elif indices:
        new = _element_set(current, indices, value, f"{where}.{name}")
    else:
        new = value
    return holder if dry else dataclasses.replace(holder, **{name: new})


def _element_set(current, indices: list, value: float, where: str) -> np.ndarray:
    """A copy of the array ``current`` with the element at ``indices`` set to ``value``."""
    array = np.array(current, dtype=float)
    if len(indices) > array.ndim or any(i >= size for i, size in zip(indices, array.shape, strict=False)):
        raise FieldPathError(f"{where}{''.join(f'[{i}]' for i in indices)}: no such element "
                             f"(the array has shape {array.shape})")
    array[tuple(indices)] = value
    return array


def _with_setting(settings: dict, parts: list, value: float, where: str) -> dict:
    """``settings`` (simulate's keyword arguments) with ``value`` at ``parts``, in a copy."""
    name, indices = parts[0], list(parts[1:])
    if not isinstance(name, str) or any(not isinstance(i, int) for i in indices):
        raise FieldPathError(f"{where}: a keyword argument of simulate, with [i] for an element")
    settings = dict(settings)
    if indices and name not in settings:
        raise FieldPathError(f"{where}.{name}: not among the settings, so it has no elements")
    settings[name] = _element_set(settings[name], indices, value, f"{where}.{name}") if indices else value
    return settings


class ObjectPlan(BatchPlan):
    """:class:`BatchPlan` over a plant, a controller and the settings of ``simulate``."""

    def __init__(self, plant, controller, settings: dict, fields: list[str], columns: np.ndarray):
        from armlab.control.base import Controller
        from armlab.model.robot import Robot

        label = f"({getattr(plant, 'name', 'plant')}, {type(controller).__name__})"
        if not isinstance(plant, Robot) or not isinstance(controller, Controller):
            raise SweepFileError(label, "scenario", "expected (plant: Robot, controller: Controller"
                                 "[, settings: dict of simulate's keyword arguments])")
        if not isinstance(settings, dict):
            raise SweepFileError(label, "settings", "expected a dict of simulate's keyword arguments")
        arguments = _simulate_keywords()
        unknown = sorted(set(settings) - set(arguments))
        missing = [name for name, required in arguments.items() if required and name not in settings]
        if unknown or missing:
            name = (unknown or missing)[0]
            raise SweepFileError(label, f"settings.{name}", "not a keyword argument of simulate" if unknown
                                 else "simulate needs it (q0, t_final and dt have no default)")
        self.objects = (plant, controller, dict(settings))
        self._paths = []
        for field in fields:
            parts = _segments(field) if _PATH.match(field) else []
            if len(parts) < 2 or parts[0] not in ROOTS:
                raise SweepFileError(label, field, "expected controller.<field>… or simulation.<argument>…")
            self._paths.append(parts)
        # Each path is tried once with the given objects' own value, so a wrong path is one line
        # before anything runs.
        for field, parts in zip(fields, self._paths, strict=True):
            try:
                self._apply(controller, self.objects[2], parts, 0.0, dry=True)
            except FieldPathError as error:
                raise SweepFileError(label, field, str(error)) from None
        super().__init__(Path(label), {}, fields, columns, allow_outside=False)

    @staticmethod
    def _apply(controller, settings, parts, value, dry=False):
        if parts[0] == "controller":
            return _replaced(controller, list(parts[1:]), value, "controller", dry), settings
        return controller, _with_setting(settings, list(parts[1:]), value, "simulation")

    def scenario_of(self, values):
        from armlab.scenarios import Scenario

        plant, controller, settings = self.objects
        for parts, value in zip(self._paths, values, strict=True):
            controller, settings = self._apply(controller, settings, parts, float(value))
        settings = dict(settings)
        environment, disturbance = settings.pop("environment", None), settings.pop("disturbance", None)
        return Scenario(name=str(self.source), title="", assignment="", description="", plant=plant,
                        controller=controller, simulation=settings, source=str(self.source),
                        environment=environment, disturbance=tuple(disturbance or ()))

    def _holder(self, j: int):
        """The controller built with field ``j`` at a value (its own checks), or None for a
        setting (the whole set-up checks it)."""
        parts = self._paths[j]
        if parts[0] != "controller":
            return None
        controller = self.objects[1]
        return lambda value: _replaced(controller, list(parts[1:]), value, "controller")


def _simulate_keywords() -> dict[str, bool]:
    """{keyword argument of ``armlab.simulate``: whether it is required}, but those a batch sets
    itself (``meta``, ``on_divergence``)."""
    from armlab.simulation import simulate

    return {name: p.default is inspect.Parameter.empty
            for name, p in inspect.signature(simulate).parameters.items()
            if p.kind is inspect.Parameter.KEYWORD_ONLY and name not in ("meta", "on_divergence")}


__all__ = ["ObjectPlan"]
