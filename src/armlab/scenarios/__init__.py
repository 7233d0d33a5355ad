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
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from armlab.control.adaptive import SlotineLi1DoF
from armlab.control.base import Controller, Environment
from armlab.errors import ArmlabError
from armlab.model.robot import Robot
from armlab.scenarios.tables import ScenarioFileError, build, integer, numbers, robot
from armlab.simulation.disturbances import TorqueDisturbance
from armlab.specialise import choice_problem

# The modules whose classes scenario files name: each registers its own (armlab.registry).
DECLARING_MODULES = ("armlab.control.joint_space", "armlab.control.adaptive", "armlab.control.task_space",
                     "armlab.control.interaction", "armlab.simulation.environment", "armlab.references",
                     "armlab.references.task", "armlab.simulation.disturbances")
for _module in DECLARING_MODULES:
    importlib.import_module(_module)

SIMULATION_KEYS = {"t_final", "dt", "q0", "qd0", "method", "control_period", "torque_limit",
                   "log_every", "limit_margin", "max_kinetic_energy", "rtol", "atol", "dynamics",
                   "joint_limits"}
TOP_KEYS = {"title", "assignment", "description", "plant", "plant_link_mass", "plant_tip", "simulation",
            "controller", "disturbance", "environment"}

__all__ = ["Scenario", "ScenarioFileError", "bundled_scenario_names", "list_scenarios",
           "load_scenario", "load_scenario_file", "scenario_path"]


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
                "description": self.description, "source": self.source}
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
    """The parsed TOML of a scenario file; unreadable or malformed files raise one line."""
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ScenarioFileError(path, "file", "no such file") from None
    except UnicodeDecodeError:
        raise ScenarioFileError(path, "file", "is not UTF-8 text") from None
    except OSError as error:
        raise ScenarioFileError(path, "file", f"cannot be read ({error.strerror})") from None
    except tomllib.TOMLDecodeError as error:
        raise ScenarioFileError(path, "toml", str(error)) from None


def _settings(simulation, path) -> dict:
    """The checked ``[simulation]`` keyword arguments of ``armlab.simulate``."""
    if not isinstance(simulation, dict):
        raise ScenarioFileError(path, "simulation", "expected a table")
    settings = {}
    for key, value in simulation.items():
        if key not in SIMULATION_KEYS:
            raise ScenarioFileError(path, f"simulation.{key}",
                                    f"unknown key (use {', '.join(sorted(SIMULATION_KEYS))})")
        if key == "dynamics" and choice_problem(value):
            raise ScenarioFileError(path, f"simulation.{key}", choice_problem(value))
        if key in ("method", "dynamics", "joint_limits"):
            settings[key] = str(value)
        elif key == "log_every":
            settings[key] = integer(value, path, f"simulation.{key}")
        else:
            settings[key] = numbers(value, path, f"simulation.{key}")
    for key in ("t_final", "dt", "q0"):
        if key not in settings:
            raise ScenarioFileError(path, f"simulation.{key}", "missing")
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


def load_scenario_file(path) -> Scenario:
    """Read and check a scenario file (see the module docstring)."""
    path = Path(path)
    data = read_scenario_toml(path)
    unknown = set(data) - TOP_KEYS
    if unknown:
        raise ScenarioFileError(path, sorted(unknown)[0], f"unknown key (use {', '.join(sorted(TOP_KEYS))})")
    for key in ("plant", "simulation", "controller"):
        if key not in data:
            raise ScenarioFileError(path, key, "missing")
    plant = robot(data["plant"], data.get("plant_link_mass", {}), path, "plant", data.get("plant_tip"))
    settings = _settings(data["simulation"], path)
    controller = build(Controller, data["controller"], path, "controller", plant=data["plant"],
                       plant_tip=data.get("plant_tip"))
    disturbance = _disturbance(data.get("disturbance", []), plant, path)
    environment = None
    if "environment" in data:
        environment = build(Environment, data["environment"], path, "environment")
    return Scenario(name=path.stem, title=str(data.get("title", path.stem)),
                    assignment=str(data.get("assignment", "")), description=str(data.get("description", "")),
                    plant=plant, controller=controller, disturbance=disturbance, simulation=settings,
                    source=str(path), environment=environment)


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


def load_scenario(name_or_path) -> Scenario:
    """A bundled scenario by name (``"a7_id_via_points"``) or a scenario file."""
    return load_scenario_file(scenario_path(name_or_path))


def list_scenarios() -> list[Scenario]:
    """Every bundled scenario, loaded."""
    return [load_scenario(name) for name in bundled_scenario_names()]
