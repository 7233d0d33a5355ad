"""Scenario files: one TOML file per seed experiment, loaded into a runnable :class:`Scenario`.

A scenario file (bundled ones live next to this module; ``armlab scenarios`` lists them)::

    title = "A6 — PD with online gravity compensation"
    assignment = "A6"
    description = "What the run shows."
    plant = "prp"                          # robot name or file; the true robot
    plant_link_mass = { link4 = 0.2 }      # optional overrides (Robot.with_link_mass)

    [simulation]                           # keyword arguments of armlab.simulate
    t_final = 10.0                         # [s]
    dt = 0.001                             # [s]
    q0 = [0, 0, 0]
    # qd0, method ("rk4" | "adaptive"), control_period, torque_limit, log_every,
    # dynamics ("auto" | "closed_form" | "numeric": the plant's forward dynamics)

    [controller]
    type = "joint_pd_gravity"              # see CONTROLLERS
    model = "prp"                          # optional: the controller's model (default: plant)
    model_link_mass = { link4 = 0.16 }     # optional: model mismatch
    kp = [25, 0.5, 10]                     # remaining keys: the controller's fields
    kd = [10, 0.08, 3]
    compensation = "online"

    [controller.reference]                 # see armlab.references.REFERENCE_TYPES
    type = "constant"
    value = [0.1, "pi/3", 0.05]

    [[disturbance]]                        # zero or more, see armlab.disturbances
    type = "sinusoidal"
    amplitude = [0, 0.05, 0.5]
    omega = 3.0

Any number may be an arithmetic expression string (``"pi/3"``).  A bad file raises
:class:`ScenarioFileError` whose message is one line, ``<file>: <field>: <what is wrong>``.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from armlab.control.adaptive import SlotineLi, SlotineLi1DoF
from armlab.control.joint_space import JointInverseDynamics, JointPDGravity
from armlab.disturbances import DISTURBANCE_TYPES
from armlab.errors import ArmlabError
from armlab.model.robot import Robot
from armlab.model.toml_io import evaluate_expression
from armlab.references import REFERENCE_TYPES
from armlab.specialise import choice_problem

CONTROLLERS = {"joint_pd_gravity": JointPDGravity, "joint_inverse_dynamics": JointInverseDynamics,
               "slotine_li_1dof": SlotineLi1DoF, "slotine_li": SlotineLi}
SIMULATION_KEYS = {"t_final", "dt", "q0", "qd0", "method", "control_period", "torque_limit",
                   "log_every", "limit_margin", "max_kinetic_energy", "rtol", "atol", "dynamics"}
TOP_KEYS = {"title", "assignment", "description", "plant", "plant_link_mass", "simulation",
            "controller", "disturbance"}


class ScenarioFileError(ArmlabError, ValueError):
    """A scenario file that cannot be run; ``str()`` is ``file: field: reason``."""

    def __init__(self, file, field: str, reason: str):
        self.file, self.field, self.reason = str(file), field, reason
        super().__init__(f"{self.file}: {field}: {reason}")


def _number(value, file, where):
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


def _numbers(value, file, where):
    """Numbers, lists and nested lists of numbers (expressions allowed) → floats/arrays."""
    if isinstance(value, list):
        return np.array([_numbers(v, file, f"{where}[{i}]") for i, v in enumerate(value)])
    return _number(value, file, where)


def _robot(name, overrides, file, where) -> Robot:
    from armlab.robots import load_robot

    if not isinstance(name, str):
        raise ScenarioFileError(file, where, f"expected a robot name or file, got {name!r}")
    path = Path(name)
    if path.suffix and not path.is_absolute():
        path = Path(file).parent / path
    try:
        robot = load_robot(str(path) if path.suffix else name)
    except ArmlabError as error:
        raise ScenarioFileError(file, where, str(error)) from None
    if not isinstance(overrides, dict):
        raise ScenarioFileError(file, f"{where}_link_mass", "expected a table {link = mass}")
    for link, mass in overrides.items():
        if link not in [lk.name for lk in robot.links]:
            raise ScenarioFileError(file, f"{where}_link_mass.{link}",
                                    f"no such link in {robot.name} "
                                    f"({', '.join(lk.name for lk in robot.links)})")
        try:
            robot = robot.with_link_mass(link, _number(mass, file, f"{where}_link_mass.{link}"))
        except ValueError as error:
            raise ScenarioFileError(file, f"{where}_link_mass.{link}", str(error)) from None
    return robot


def _build(kinds: dict, table, file, where, extra=None):
    """An object of ``kinds[table["type"]]`` from the table's other keys."""
    if not isinstance(table, dict):
        raise ScenarioFileError(file, where, "expected a table")
    kind = table.get("type")
    if kind not in kinds:
        raise ScenarioFileError(file, f"{where}.type", f"unknown type {kind!r} (use {', '.join(kinds)})")
    cls = kinds[kind]
    known = set(cls.__dataclass_fields__)
    arguments = dict(extra or {})
    for key, value in table.items():
        if key == "type" or key in arguments:
            continue
        if key not in known:
            raise ScenarioFileError(file, f"{where}.{key}",
                                    f"unknown key for {kind} "
                                    f"(use {', '.join(sorted(known - set(arguments)))})")
        arguments[key] = value if isinstance(value, str) and key in ("compensation", "form") \
            else _numbers(value, file, f"{where}.{key}")
    try:
        return cls(**arguments)
    except ArmlabError as error:
        raise ScenarioFileError(file, where, str(error)) from None
    except TypeError as error:
        raise ScenarioFileError(file, where, str(error)) from None


@dataclass(frozen=True)
class Scenario:
    """A runnable experiment: plant, controller, disturbances and simulation settings."""

    name: str
    title: str
    assignment: str
    description: str
    plant: Robot
    controller: object
    disturbance: tuple = ()
    simulation: dict = field(default_factory=dict)
    source: str = ""

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
        from armlab.simulation import simulate

        if isinstance(self.controller, SlotineLi1DoF):
            # What the seed plots but the controller cannot know: the plant's [I, F, G].
            from armlab.control.adaptive import link1_parameters

            meta["true_parameters"] = link1_parameters(self.plant).tolist()
        return simulate(self.plant, self.controller, disturbance=list(self.disturbance) or None,
                        meta=meta, **settings)


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


def plant_and_settings(data: dict, path) -> tuple[Robot, dict]:
    """The plant robot and the checked ``[simulation]`` keyword arguments of a scenario."""
    for key in ("plant", "simulation", "controller"):
        if key not in data:
            raise ScenarioFileError(path, key, "missing")
    plant = _robot(data["plant"], data.get("plant_link_mass", {}), path, "plant")
    simulation = data["simulation"]
    if not isinstance(simulation, dict):
        raise ScenarioFileError(path, "simulation", "expected a table")
    settings = {}
    for key, value in simulation.items():
        if key not in SIMULATION_KEYS:
            raise ScenarioFileError(path, f"simulation.{key}",
                                    f"unknown key (use {', '.join(sorted(SIMULATION_KEYS))})")
        if key == "dynamics" and choice_problem(value):
            raise ScenarioFileError(path, f"simulation.{key}", choice_problem(value))
        if key in ("method", "dynamics"):
            settings[key] = str(value)
        elif key == "log_every":
            settings[key] = int(_number(value, path, f"simulation.{key}"))
        else:
            settings[key] = _numbers(value, path, f"simulation.{key}")
    for key in ("t_final", "dt", "q0"):
        if key not in settings:
            raise ScenarioFileError(path, f"simulation.{key}", "missing")
    return plant, settings


def load_scenario_file(path) -> Scenario:
    """Read and check a scenario file (see the module docstring)."""
    path = Path(path)
    data = read_scenario_toml(path)
    if _is_extension(data):
        from armlab.interaction_scenarios import load_interaction_scenario

        return load_interaction_scenario(path, data)
    unknown = set(data) - TOP_KEYS
    if unknown:
        raise ScenarioFileError(path, sorted(unknown)[0], f"unknown key (use {', '.join(sorted(TOP_KEYS))})")
    plant, settings = plant_and_settings(data, path)
    table = dict(data["controller"])
    model = _robot(table.pop("model", data["plant"]), table.pop("model_link_mass", {}), path,
                   "controller.model")
    if "reference" not in table:
        raise ScenarioFileError(path, "controller.reference", "missing")
    reference = _build(REFERENCE_TYPES, table.pop("reference"), path, "controller.reference")
    try:
        reference.data  # noqa: B018 — validates the reference's numbers now, naming the field
    except ArmlabError as error:
        raise ScenarioFileError(path, "controller.reference", str(error)) from None
    controller = _build(CONTROLLERS, table, path, "controller", {"model": model, "reference": reference})
    terms = data.get("disturbance", [])
    if not isinstance(terms, list):
        raise ScenarioFileError(path, "disturbance", "expected an array of tables [[disturbance]]")
    disturbance = tuple(_build(DISTURBANCE_TYPES, t, path, f"disturbance[{i}]") for i, t in enumerate(terms))
    for i, term in enumerate(disturbance):
        try:
            term.encode(plant.n)
        except ArmlabError as error:
            raise ScenarioFileError(path, f"disturbance[{i}]", str(error)) from None
    return Scenario(name=path.stem, title=str(data.get("title", path.stem)),
                    assignment=str(data.get("assignment", "")), description=str(data.get("description", "")),
                    plant=plant, controller=controller, disturbance=disturbance, simulation=settings,
                    source=str(path))


def _is_extension(data: dict) -> bool:
    """True for a task-space/interaction scenario (A9–A15), read by ``armlab.interaction_scenarios``."""
    controller = data.get("controller", {})
    if "environment" not in data and not (isinstance(controller, dict) and controller.get("type")
                                          and controller.get("type") not in CONTROLLERS):
        return False
    try:
        from armlab.interaction_scenarios import is_interaction_scenario
    except ImportError:
        return False
    return is_interaction_scenario(data)


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
