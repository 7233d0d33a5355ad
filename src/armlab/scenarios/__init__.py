"""Scenario files: one TOML file per experiment, loaded into a runnable :class:`Scenario`.

A scenario file (bundled ones live next to this module and in ``interaction/``; ``armlab
scenarios`` lists them)::

    title = "A6 — PD with online gravity compensation"
    assignment = "A6"
    description = "What the run shows."
    plant = "prp"                          # robot name or file; the true robot
    plant_link_mass = { link4 = 0.2 }      # optional overrides (Robot.with_link_mass)
    plant_tip = "tool0"                    # optional: end-effector link of a URDF/MJCF tree

    [simulation]                           # keyword arguments of armlab.simulate
    t_final = 10.0                         # [s]
    dt = 0.001                             # [s]
    q0 = [0, 0, 0]
    # qd0, method ("rk4" | "adaptive"), control_period, torque_limit, log_every,
    # dynamics ("auto" | "closed_form" | "numeric": the plant's forward dynamics),
    # joint_limits ("warn" | "stop" | "ignore": declared limits reported or enforced by stops)

    [controller]
    type = "joint_pd_gravity"              # a registered controller (armlab.registry)
    model = "prp"                          # optional: the controller's model (default: plant)
    model_link_mass = { link4 = 0.16 }     # optional: model mismatch
    kp = [25, 0.5, 10]                     # remaining keys: the controller's fields
    kd = [10, 0.08, 3]
    compensation = "online"

    [controller.reference]                 # a JointReference: its type and fields
    type = "constant"
    value = [0.1, "pi/3", 0.05]

    [[disturbance]]                        # zero or more TorqueDisturbance terms
    type = "sinusoidal"
    amplitude = [0, 0.05, 0.5]
    omega = 3.0

    [environment]                          # optional (default: free space)
    type = "spring"
    stiffness = [0, 0, 1e4, 10, 0, 0]
    rest_pose = [0, -0.2, 0.5, "pi/2", "-pi/2", 0]   # rest_position and rest_rotation (ZYZ)

The task-space controllers read their ``reference`` as via-poses (``times``, ``poses``
[x, y, z, φ, ϑ, ψ], ``euler``) and the force controllers a ``[controller.force]`` table.

Every class a file names declares its name and the types of its fields where it is defined
(``@scenario_type("joint_pd_gravity")``, ``compensation: Literal["online", "desired",
"none"]``); each key is read as its field's annotation says (``armlab.scenarios.tables``).
Any number may be an arithmetic expression string (``"pi/3"``).  A bad file raises
:class:`ScenarioFileError` whose message is one line, ``<file>: <field>: <what is wrong>``.
The format and how to add a controller: ``docs/scenario-files.md``.
"""

from __future__ import annotations

import importlib
import re
import typing
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Annotated, Literal

import numpy as np

from armlab.control.adaptive import SlotineLi1DoF
from armlab.control.base import Controller, Environment
from armlab.errors import ArmlabError
from armlab.inputs import read_input_toml
from armlab.model.robot import Robot
from armlab.scenarios.tables import Condition, ScenarioFileError, build, read, robot
from armlab.simulation.disturbances import TorqueDisturbance
from armlab.specialise import DYNAMICS_CHOICES

# The modules whose classes scenario files name: each registers its own (armlab.registry).
DECLARING_MODULES = ("armlab.control.joint_space", "armlab.control.adaptive", "armlab.control.task_space",
                     "armlab.control.interaction", "armlab.simulation.environment", "armlab.references",
                     "armlab.references.task", "armlab.simulation.disturbances")
for _module in DECLARING_MODULES:
    importlib.import_module(_module)

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

__all__ = ["Scenario", "ScenarioFileError", "bundled_scenario_names", "list_scenarios",
           "load_scenario", "load_scenario_file", "scenario_from_table", "scenario_path"]


@dataclass(frozen=True)
class Scenario:
    """A runnable experiment: plant, controller, disturbances, environment and simulation
    settings."""

    name: str
    title: str
    assignment: str
    description: str
    plant: Robot
    controller: Controller
    disturbance: tuple = ()
    simulation: dict = field(default_factory=dict)
    source: str = ""
    environment: Environment | None = None
    expect: Literal["ok", "diverged"] = "ok"
    """How the run should end: "ok" (to t_final) or "diverged" (an experiment whose point is
    the divergence); ``armlab run`` exits with 0 when it does (``result.meta["expect"]``)."""

    def run(self, *, t_final: float | None = None, method: str | None = None, **overrides):
        """Simulate this scenario (``armlab.simulate``); ``t_final``/``method`` shorten or switch it."""
        from armlab.simulation import SimulationError

        settings = dict(self.simulation)
        if t_final is not None:
            settings["t_final"] = float(t_final)
        if method is not None:
            settings["method"] = method
        settings.update(overrides)
        meta = {"scenario": self.name, "title": self.title, "assignment": self.assignment,
                "description": self.description, "source": self.source, "expect": self.expect}
        try:
            return self._simulate(settings, meta)
        except SimulationError as error:
            # simulate names the argument ("q0: …"); the user wrote it in [simulation].
            field, _, reason = str(error).partition(": ")
            raise ScenarioFileError(self.source or self.name, f"simulation.{field}", reason) from None

    def _simulate(self, settings: dict, meta: dict):
        """Simulate; a controller with a ``check`` of its run (the task-space controllers warn
        of a near-singular task Jacobian) checks it afterwards, also a diverged run."""
        from armlab.simulation import SimulationDiverged, simulate

        if isinstance(self.controller, SlotineLi1DoF):
            # What the seed plots but the controller cannot know: the plant's [I, F, G].
            from armlab.control.adaptive import link1_parameters

            meta["true_parameters"] = link1_parameters(self.plant).tolist()
        check = getattr(self.controller, "check", None)
        try:
            result = simulate(self.plant, self.controller, disturbance=list(self.disturbance) or None,
                              environment=self.environment, meta=meta, **settings)
        except SimulationDiverged as error:
            if check is not None:
                check(error.result)
            raise
        if check is not None:
            check(result)
        return result


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


def load_scenario_file(path, *, allow_outside: bool = False) -> Scenario:
    """Read and check a scenario file (see the module docstring)."""
    path = Path(path)
    return scenario_from_table(read_scenario_toml(path), path, allow_outside=allow_outside)


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


def _bundled_files() -> dict[str, Path]:
    """Bundled scenario files by name: this folder and its subfolders (``interaction/``)."""
    folder = Path(str(resources.files(__name__)))
    files = {}
    for path in sorted(folder.glob("*.toml")) + sorted(folder.glob("*/*.toml")):
        files.setdefault(path.stem, path)
    return files


def bundled_scenario_names() -> list[str]:
    """Names of the scenarios shipped with armlab, in assignment order (a6 before a10)."""
    return sorted(_bundled_files(), key=lambda name: [int(part) if part.isdigit() else part
                                                     for part in re.split(r"(\d+)", name)])


def scenario_path(name_or_path) -> Path:
    text = str(name_or_path)
    bundled = _bundled_files()
    if text in bundled:
        return bundled[text]
    path = Path(text)
    if path.suffix.lower() != ".toml":
        raise ScenarioFileError(text, "name",
                                "not a bundled scenario (see `armlab scenarios`) nor a .toml file")
    return path


def load_scenario(name_or_path, *, allow_outside: bool = False) -> Scenario:
    """A bundled scenario by name (``"a7_id_via_points"``) or a scenario file; the robot files
    a scenario file names must lie under its folder unless ``allow_outside``."""
    return load_scenario_file(scenario_path(name_or_path), allow_outside=allow_outside)


def list_scenarios() -> list[Scenario]:
    """Every bundled scenario, loaded."""
    return [load_scenario(name) for name in bundled_scenario_names()]
