"""Scenario files of the task-space and interaction experiments (seed A9–A15).

They extend the scenario format of ``armlab.scenarios`` (same ``title``, ``plant``,
``[simulation]`` …) with task-space controllers, pose/force references and an environment::

    [controller]
    type = "compliance"          # see TASK_CONTROLLERS
    kp = [20, 10, 20, 50, 50, 50]
    kd = [10, 10, 10, 5, 5, 5]
    frame = "desired"            # string keys: frame, euler, inner
    task = [0, 1, 2]             # components of [x, y, z, φ1, φ2, φ3] controlled

    [controller.reference]       # Σ_d(t): via-poses x = [p; φ] (Euler angles ``euler``)
    times = [0, 5]
    poses = [[0, -0.2, 0.5, "pi/2", "-pi/2", 0], [0, -0.1, 0.4, "pi/2", "-pi/2", 0]]
    euler = "zyz"

    [controller.force]           # f_d(t) of the force controllers (ForceReference fields)
    final = [0, -0.5, 0]
    duration = 0.5

    [environment]                # see ENVIRONMENT_TYPES
    type = "spring"
    stiffness = [0, 0, 1e4, 10, 0, 0]
    rest_pose = [0, -0.2, 0.5, "pi/2", "-pi/2", 0]

:func:`load_interaction_scenario` reads such a file into an :class:`InteractionScenario`,
which runs with its environment and warns when the task Jacobian neared a singularity.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from armlab.control.interaction import (
    AdmittanceControl,
    ComplianceControl,
    ForceControl,
    ImpedanceControl,
    ParallelForcePosition,
)
from armlab.control.task_space import OperationalInverseDynamics, OperationalPD
from armlab.environment import FreeSpace, PlanarWall, Spring
from armlab.errors import ArmlabError
from armlab.scenarios import (
    TOP_KEYS,
    Scenario,
    ScenarioFileError,
    _number,
    _numbers,
    _robot,
    plant_and_settings,
    read_scenario_toml,
)
from armlab.spatial import euler_matrix
from armlab.task_references import ForceReference, PoseReference

TASK_CONTROLLERS = {
    "operational_pd": OperationalPD, "operational_inverse_dynamics": OperationalInverseDynamics,
    "compliance": ComplianceControl, "impedance": ImpedanceControl, "admittance": AdmittanceControl,
    "force": ForceControl, "parallel_force_position": ParallelForcePosition,
}
ENVIRONMENT_TYPES = {"free_space": FreeSpace, "spring": Spring, "planar_wall": PlanarWall}
STRING_KEYS = {"frame", "euler", "inner"}


def is_interaction_scenario(data: dict) -> bool:
    """True for a parsed scenario file that needs this module (environment or task controller)."""
    controller = data.get("controller", {})
    return "environment" in data or (isinstance(controller, dict)
                                     and controller.get("type") in TASK_CONTROLLERS)


@dataclass(frozen=True)
class InteractionScenario(Scenario):
    """A :class:`~armlab.scenarios.Scenario` with an environment (None: free space)."""

    environment: object = None

    def _simulate(self, settings: dict, meta: dict):
        """Simulate with the environment; the controller's singularity check runs afterwards."""
        from armlab.simulation import SimulationDiverged, simulate

        try:
            result = simulate(self.plant, self.controller, environment=self.environment, meta=meta,
                              **settings)
        except SimulationDiverged as error:
            self.controller.check(error.result)
            raise
        self.controller.check(result)
        return result


def _pose_reference(table, file, where) -> PoseReference:
    if not isinstance(table, dict):
        raise ScenarioFileError(file, where, "expected a table (times, poses, euler)")
    unknown = set(table) - {"times", "poses", "euler"}
    if unknown:
        raise ScenarioFileError(file, f"{where}.{sorted(unknown)[0]}",
                                "unknown key (use times, poses, euler)")
    for key in ("times", "poses"):
        if key not in table:
            raise ScenarioFileError(file, f"{where}.{key}", "missing")
    try:
        return PoseReference.from_pose_vectors(_numbers(table["times"], file, f"{where}.times"),
                                               _numbers(table["poses"], file, f"{where}.poses"),
                                               str(table.get("euler", "zyz")))
    except (ArmlabError, ValueError) as error:
        raise ScenarioFileError(file, where, str(error)) from None


def _arguments(cls, table, file, where, skip=()) -> dict:
    known = set(cls.__dataclass_fields__) - {"_derived"}
    arguments = {}
    for key, value in table.items():
        if key in skip:
            continue
        if key not in known:
            raise ScenarioFileError(file, f"{where}.{key}", f"unknown key (use {', '.join(sorted(known))})")
        if key in STRING_KEYS:
            arguments[key] = str(value)
        elif key == "task":
            arguments[key] = tuple(int(_number(v, file, f"{where}.task")) for v in value)
        else:
            arguments[key] = _numbers(value, file, f"{where}.{key}")
    return arguments


def _construct(cls, arguments, file, where):
    try:
        return cls(**arguments)
    except (ArmlabError, TypeError, ValueError) as error:
        raise ScenarioFileError(file, where, str(error)) from None


def _controller(table, plant_name, file):
    table = dict(table)
    kind = table.pop("type", None)
    if kind not in TASK_CONTROLLERS:
        raise ScenarioFileError(file, "controller.type",
                                f"unknown type {kind!r} (use {', '.join(TASK_CONTROLLERS)})")
    cls = TASK_CONTROLLERS[kind]
    model = _robot(table.pop("model", plant_name), table.pop("model_link_mass", {}), file, "controller.model")
    arguments = {"model": model}
    if "reference" in table:
        arguments["reference"] = _pose_reference(table.pop("reference"), file, "controller.reference")
    elif "reference" in cls.__dataclass_fields__ and cls is not ParallelForcePosition:
        raise ScenarioFileError(file, "controller.reference", "missing")
    if "force" in table:
        force = table.pop("force")
        if not isinstance(force, dict):
            raise ScenarioFileError(file, "controller.force", "expected a table (ForceReference fields)")
        fields = _arguments(ForceReference, force, file, "controller.force")
        arguments["force"] = _construct(ForceReference, fields, file, "controller.force")
    arguments.update(_arguments(cls, table, file, "controller"))
    return _construct(cls, arguments, file, "controller")


def _environment(table, file):
    if not isinstance(table, dict):
        raise ScenarioFileError(file, "environment", "expected a table")
    table = dict(table)
    kind = table.pop("type", None)
    if kind not in ENVIRONMENT_TYPES:
        raise ScenarioFileError(file, "environment.type",
                                f"unknown type {kind!r} (use {', '.join(ENVIRONMENT_TYPES)})")
    if kind == "spring" and "rest_pose" in table:
        pose = _numbers(table.pop("rest_pose"), file, "environment.rest_pose")
        if np.shape(pose) != (6,):
            raise ScenarioFileError(file, "environment.rest_pose", "expected [x, y, z, φ, ϑ, ψ]")
        euler = str(table.pop("euler", "zyz"))
        try:
            table["rest_rotation"] = euler_matrix(pose[3:], euler)
        except ValueError as error:
            raise ScenarioFileError(file, "environment.euler", str(error)) from None
        table["rest_position"] = pose[:3]
    arguments = {key: value if isinstance(value, np.ndarray) else _numbers(value, file, f"environment.{key}")
                 for key, value in table.items()}
    known = set(ENVIRONMENT_TYPES[kind].__dataclass_fields__)
    for key in arguments:
        if key not in known:
            raise ScenarioFileError(file, f"environment.{key}",
                                    f"unknown key (use {', '.join(sorted(known))})")
    return _construct(ENVIRONMENT_TYPES[kind], arguments, file, "environment")


FOLDER = "interaction"


def interaction_scenario_names() -> list[str]:
    """Names of the bundled A9–A15 scenarios (``armlab/scenarios/interaction/*.toml``), sorted."""
    folder = resources.files("armlab.scenarios").joinpath(FOLDER)
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_interaction_scenario(path, data: dict | None = None) -> InteractionScenario:
    """Read a task-space/interaction scenario: a bundled name (``"a11_compliance"``) or a
    file (see the module docstring)."""
    if str(path) in interaction_scenario_names():
        path = resources.files("armlab.scenarios").joinpath(FOLDER, f"{path}.toml")
    path = Path(str(path))
    if data is None:
        data = read_scenario_toml(path)
    unknown = (set(data) - (TOP_KEYS | {"environment"})) | ({"disturbance"} & set(data))
    if unknown:
        raise ScenarioFileError(path, sorted(unknown)[0], "unknown key for a task-space scenario")
    plant, settings = plant_and_settings(data, path)
    controller = _controller(data["controller"], data["plant"], path)
    environment = _environment(data["environment"], path) if "environment" in data else None
    return InteractionScenario(name=path.stem, title=str(data.get("title", path.stem)),
                               assignment=str(data.get("assignment", "")),
                               description=str(data.get("description", "")), plant=plant,
                               controller=controller, simulation=settings, source=str(path),
                               environment=environment)
