"""The report's experiments (:class:`Experiment`), discovered from the scenario registry
(``armlab.scenarios``).

A scenario belongs to the report of robot R when its plant is R, a variant of R's file
(``prp_actuated`` for ``prp``), or one of R's companion robots: the seed's A8 studies a
1-DoF link, so ``link1`` scenarios belong to the PRP report.  New scenario files appear in the
next report by themselves.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from armlab.errors import ReportError
from armlab.model.robot import Robot
from armlab.scenarios import list_scenarios, load_scenario
from armlab.theory import predictions
from armlab.viz.drawing import Plane
from armlab.viz.metrics import Metric

COMPANIONS = {"prp": ("link1",)}
QUICK_T_FINAL = 2.0  # [s] length of every run in --quick mode
HIDDEN_KEYS = {"title", "assignment", "description"}
# The seed's order within each assignment (its option 1 before option 3, free motion before
# contact): the report lists an assignment's experiments so, then any others by name.
SEED_ORDER = (
    "a6_pd_online", "a6_pd_none", "a6_pd_desired", "a6_pd_desired_global", "a6_pd_desired_far",
    "a6_pd_sine", "a6_pd_ramp",
    "a6_pd_sine_disturbance", "a6_pd_sine_disturbance_stop", "a6_pd_ramp_disturbance",
    "a7_id_via_points", "a7_id_regulation", "a7_id_mismatch", "a7_id_mismatch_regulation",
    "a7_id_mismatch_whole_model", "a7_id_mismatch_whole_model_regulation",
    "a7_id_high_gain", "a7_id_high_gain_saturated", "a7_id_higher_gain", "a7_id_higher_gain_saturated",
    "a8_case1_sine", "a8_case1_wrong_plant1", "a8_case1_wrong_plant1_seed_form",
    "a8_case1_wrong_plant1_large_f2", "a8_case1_wrong_plant2",
    "a8_case2_square", "a8_case2_square_faster", "a8_case2_wrong_plant1", "a8_case2_wrong_plant2",
    "a09_pd_goal", "a09_pd_goal_joint_damping", "a09_pd_goal_rotation", "a09_pd_goal_rotation_joint_damping",
    "a09_pd_near_singular",
    "a10_id_regulation", "a10_id_via_poses", "a10_id_random_goals", "a10_id_rotation_damped",
    "a11_compliance", "a11_compliance_soft", "a11_compliance_push", "a11_compliance_diagonal",
    "a11_compliance_diagonal_push",
    "a12_impedance_regulation", "a12_impedance_regulation_push", "a12_impedance_regulation_damped",
    "a12_impedance_tracking", "a12_impedance_tracking_push",
    "a13_admittance_regulation", "a13_admittance_regulation_push", "a13_admittance_regulation_tuned",
    "a13_admittance_tracking", "a13_admittance_tracking_push",
    "a14_force_inner_position", "a14_force_inner_position_stop", "a14_force_inner_position_y_only",
    "a14_force_inner_velocity", "a14_force_inner_velocity_z",
    "a15_parallel_free_seed", "a15_parallel_free", "a15_parallel_contact", "a15_parallel_contact_wall",
    "a15_parallel_outside_image",
)
"""The seed's order of its experiments, each improved variant right after the seed's own."""


def seed_rank(name: str) -> tuple[int, str]:
    """Sort key of a scenario within its assignment: its place in :data:`SEED_ORDER`, then
    (scenarios not listed there) its name."""
    return (SEED_ORDER.index(name), "") if name in SEED_ORDER else (len(SEED_ORDER), name)


@dataclass
class Experiment:
    """One scenario run for the report: what it is, how it was set up, what it did."""

    name: str
    assignment: int
    title: str
    description: str
    parameters: list[tuple[str, str]]
    robot: Robot | None = None
    plane: Plane | None = None
    result: object | None = None
    error: str = ""
    seconds: float = 0.0
    metrics: list[Metric] = field(default_factory=list)
    figures: list[tuple[str, str, bytes]] = field(default_factory=list)
    runner: object = None
    scenario: str | None = None
    t_final: float | None = None
    kind: str = ""
    predicted: list = field(default_factory=list)   # rows of armlab.theory.predictions
    view: str = ""   # its 3-D view page, relative to the report's folder ("" for none)
    # () -> ``predicted``, called when the run is measured: a quick report runs a fifth of the
    # scenarios it discovers, and the theory of the others would cost it SciPy's solvers.
    predictor: object = None
    quick: bool = False  # draw the main scopes alone (armlab.viz.layout.main_scopes)
    diagram: bytes = b""  # PNG of its closed loop's block diagram (armlab.viz.loop_diagram)
    diagram_tags: tuple = ()  # the equation tags its blocks name (C2, E3 …)

    def run(self):
        """Run the scenario: ``runner()`` returns its SimulationResult."""
        if self.runner is None:
            raise ReportError(f"{self.name}: nothing to run")
        return self.runner()


def assignment_number(text: str) -> int | None:
    """The seed assignment named in ``text`` ("A7", "a07", "assignment 7", "A14b") or None."""
    match = re.search(r"(?:^|[^a-z0-9])(?:a|assignment\s*)0*(\d{1,2})(?![0-9])", text.lower())
    if match and 1 <= int(match.group(1)) <= 15:
        return int(match.group(1))
    return None


def _belongs(plant_name: str, robot_name: str) -> bool:
    return (plant_name == robot_name or plant_name.startswith(robot_name + "_")
            or plant_name in COMPANIONS.get(robot_name, ()))


def _flatten(table: dict, prefix: str = "") -> list[tuple[str, str]]:
    rows = []
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            rows += _flatten(value, name + ".")
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for i, item in enumerate(value):
                rows += _flatten(item, f"{name}[{i}].")
        else:
            rows.append((name, str(value).replace("'", "")))
    return rows


def scenario_parameters(source: str) -> list[tuple[str, str]]:
    """The set-up of a scenario file as (key, value) rows, as written in the file."""
    with open(source, "rb") as handle:
        data = tomllib.load(handle)
    return _flatten({k: v for k, v in data.items() if k not in HIDDEN_KEYS})


def environment_plane(environment) -> Plane | None:
    """The surface to draw for an environment: a wall's plane, or the plane through a spring's
    rest position normal to its stiffest translational direction; None in free space."""
    if environment is None:
        return None
    if hasattr(environment, "normal") and hasattr(environment, "point"):
        return Plane(tuple(environment.point), tuple(environment.normal))
    stiffness = getattr(environment, "stiffness", None)
    rest = getattr(environment, "rest_position", None)
    if stiffness is None or rest is None:
        return None
    K = np.asarray(stiffness, dtype=float)
    if K.shape != (6, 6) or np.abs(K[:3, :3]).max() == 0.0:
        return None
    values, vectors = np.linalg.eigh(K[:3, :3])
    R_r = np.asarray(getattr(environment, "rest_rotation", np.eye(3)), dtype=float)
    return Plane(tuple(rest), tuple(R_r @ vectors[:, int(np.argmax(values))]))


def experiment_from_scenario(scenario, t_final: float | None = None, *, quick: bool = False) -> Experiment:
    """The :class:`Experiment` of a registered scenario (a name or a loaded Scenario), run up to
    ``t_final`` [s] when given (shorter than the file's own t_final), else for its full length;
    ``quick`` draws its main scopes alone."""
    if isinstance(scenario, str):
        # A name, or a file the report chose or wrote (a course names the user's robot file).
        scenario = load_scenario(scenario, allow_outside=True)
    full = float(scenario.simulation["t_final"])
    short = t_final if t_final is not None and t_final < full else None

    def runner():
        return scenario.run(t_final=short, on_divergence="return")

    parameters = scenario_parameters(scenario.source) if scenario.source else []
    if short is not None:
        parameters.append(("report (quick)", f"run shortened to t_final = {short:g} s"))
    number = assignment_number(scenario.assignment) or assignment_number(scenario.name) or 0
    # The theory of the run as it is made: a shortened run is predicted at its own end (the A7
    # equilibrium (H1) is that of q_des at t_final).
    predicted = scenario if short is None else replace(scenario, simulation={**scenario.simulation,
                                                                              "t_final": short})
    return Experiment(name=scenario.name, assignment=number, title=scenario.title,
                      description=scenario.description, parameters=parameters, robot=scenario.plant,
                      plane=environment_plane(scenario.environment), runner=runner,
                      scenario=_reloadable(scenario), t_final=short, kind=type(scenario.controller).__name__,
                      predictor=lambda: predictions(predicted), quick=quick)


def _reloadable(scenario) -> str:
    """What a worker process loads the scenario by: its file (a generated course reuses the
    bundled names), or its name when it has none."""
    return str(scenario.source) if scenario.source else scenario.name


def discover(robot: Robot, *, quick: bool = False, course_dir=None) -> list[Experiment]:
    """Every registered scenario of ``robot`` as an :class:`Experiment` ready to run, by
    assignment and in the seed's order (:data:`SEED_ORDER`); ``quick`` shortens each run to
    :data:`QUICK_T_FINAL` and draws its main scopes alone (:func:`armlab.viz.layout.main_scopes`).
    A robot without bundled scenarios gets the course generated for it (:mod:`armlab.course`),
    written to ``course_dir`` (a temporary folder if None) so that each experiment's file can
    be rerun."""
    scenarios = [s for s in list_scenarios() if _belongs(s.plant.name, robot.name)]
    if not scenarios:
        scenarios = _course(robot, course_dir)
    experiments = [experiment_from_scenario(scenario, QUICK_T_FINAL if quick else None, quick=quick)
                   for scenario in scenarios]
    experiments.sort(key=lambda e: (e.assignment, *seed_rank(e.name)))
    return experiments


def _course(robot: Robot, folder) -> list:
    """The scenarios :mod:`armlab.course` generates for ``robot``, loaded from their files."""
    import tempfile

    from armlab.course import write_course
    from armlab.robots import robot_reference
    from armlab.scenarios import load_scenario_file

    reference, tip = robot_reference(robot)
    folder = Path(folder) if folder is not None else Path(tempfile.mkdtemp(prefix="armlab-course-"))
    paths, _ = write_course(robot, reference, folder, tip=tip)
    # Written here, naming the robot the user named (by its absolute path when it is a file):
    # that robot file may lie outside the course folder.
    return [load_scenario_file(path, allow_outside=True) for path in paths]
