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
from importlib import resources
from pathlib import Path

from armlab.scenarios.scenario import Scenario
from armlab.scenarios.tables import ScenarioFileError, read_scenario_toml, scenario_from_table

# The modules whose classes scenario files name: each registers its own (armlab.registry).
DECLARING_MODULES = ("armlab.control.joint_space", "armlab.control.adaptive", "armlab.control.task_space",
                     "armlab.control.interaction", "armlab.simulation.environment", "armlab.references",
                     "armlab.references.task", "armlab.simulation.disturbances")
for _module in DECLARING_MODULES:
    importlib.import_module(_module)

__all__ = ["Scenario", "ScenarioFileError", "bundled_scenario_names", "list_scenarios",
           "load_scenario", "load_scenario_file", "read_scenario_toml", "scenario_from_table",
           "scenario_path"]


def load_scenario_file(path, *, allow_outside: bool = False) -> Scenario:
    """Read and check a scenario file (see the module docstring)."""
    path = Path(path)
    return scenario_from_table(read_scenario_toml(path), path, allow_outside=allow_outside)


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
