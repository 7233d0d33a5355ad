"""``armlab report``: one self-contained HTML document reproducing the seed project.

The document has one section per seed assignment that armlab can run for the chosen robot:

* A1–A5 from :func:`armlab.symbolic.sections.derive` (DH tables, transforms, Jacobians, energies,
  Lagrange and Newton–Euler dynamics, operational-space model) as presentation MathML, with
  the robot drawn with its frames in Σ_base and Σ_0 (the seed's plotTransforms check);
* A6–A15 from the scenario registry: for every bundled scenario of the robot its description,
  parameters, scope plots and the measured numbers of :mod:`armlab.viz.metrics`, and one
  animation.

Sections appear as their code does: a scenario added to the registry shows up in the next
report without changes here; an assignment with nothing runnable is listed as missing, never
filled with made-up content.  Images are inlined, so the file can be mailed or opened offline.
"""

from __future__ import annotations

import os
import re
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from armlab.errors import ArmlabError  # noqa: E402
from armlab.model.robot import Robot  # noqa: E402
from armlab.robots import load_robot  # noqa: E402
from armlab.viz import html  # noqa: E402
from armlab.viz.animation import animate_robot  # noqa: E402
from armlab.viz.drawing import Plane, draw_robot  # noqa: E402
from armlab.viz.metrics import Metric, measure  # noqa: E402
from armlab.viz.progress import Progress  # noqa: E402
from armlab.viz.scopes import render_scope, scope_layout  # noqa: E402

ASSIGNMENTS = {
    1: "Kinematics: DH tables, direct and inverse kinematics, Jacobians",
    2: "Inertia tensors, kinetic and potential energy",
    3: "Lagrange equations of motion",
    4: "Recursive Newton–Euler formulation",
    5: "Dynamic model in the operational space",
    6: "Joint-space PD control with gravity compensation",
    7: "Joint-space inverse dynamics control",
    8: "Adaptive control (Slotine–Li)",
    9: "Operational-space PD control with gravity compensation",
    10: "Operational-space inverse dynamics control",
    11: "Compliance control",
    12: "Impedance control",
    13: "Admittance control",
    14: "Force control with inner position / velocity loop",
    15: "Parallel force/position control",
}
SEED_POSES = {"prp": np.array([0.1, np.pi / 3, 0.1])}  # the seed's A1 pose


class ReportError(ArmlabError, ValueError):
    """A report that cannot be built (unknown robot, unwritable output)."""


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


def seed_pose(robot: Robot) -> np.ndarray:
    """The configuration the A1 section draws: the seed's pose for the PRP, else mid-range."""
    if robot.name in SEED_POSES and robot.n == SEED_POSES[robot.name].size:
        return SEED_POSES[robot.name]
    q = np.zeros(robot.n)
    for i, joint in enumerate(robot.joints):
        low, high = joint.limits
        if np.isfinite(low) and np.isfinite(high):
            q[i] = low + 0.6 * (high - low)
        elif joint.kind == "revolute":
            q[i] = 0.5
    return q


# ----------------------------------------------------------------------------- A1–A5


def _drawings(robot: Robot) -> str:
    pose = seed_pose(robot)
    parts = []
    for frame, q, tag in (("base", pose, "pose"), ("0", pose, "pose"), ("base", np.zeros(robot.n), "rest")):
        fig = draw_robot(robot, q, frame=frame)
        try:
            data = html.figure_png(fig, dpi=80, tight=True)
        finally:
            plt.close(fig)
        where = "Σ_base" if frame == "base" else "Σ_0"
        values = ", ".join(f"{j.name} = {v:.3g}" for j, v in zip(robot.joints, q, strict=True))
        caption = (f"{robot.name} at {'rest' if tag == 'rest' else values} drawn in {where}: links with "
                   "their inertia shapes, frames Σ_base, Σ_0 … Σ_e as x/y/z = red/green/blue triads "
                   "placed by forward kinematics (the seed's plotTransforms check).")
        parts.append(html.figure(html.png_data_uri(data), caption, kind="drawing",
                                 ident=f"fig-robot-{tag}-{frame}"))
    return '<div class="figures">' + "".join(parts) + "</div>"


def _symbolic_sections(robot: Robot, progress: Progress) -> dict[int, str]:
    """HTML of the A1–A5 derivations by assignment number.

    A1 is derived in both Σ_0 and Σ_base (as the seed does), A2–A5 in Σ_0; one symbolic robot
    serves all five, so later sections reuse B, C, g.
    """
    from armlab.symbolic import symbolic_robot
    from armlab.symbolic.render import to_mathml
    from armlab.symbolic.sections import ASSIGNMENTS as DERIVED
    from armlab.symbolic.sections import derive

    sr = symbolic_robot(robot)
    out: dict[int, str] = {}
    for key in DERIVED:
        progress.step(f"deriving {key}")
        (section,) = derive(sr, frame="base" if key == "A1" else "0", only=key)
        blocks = [f"<h3>Derivation: {html.escape(section.title)}</h3>"]
        for item in section.items:
            blocks.append(html.math_block(item.label, to_mathml(item.expr)))
        blocks += [f'<p class="note">{html.escape(note)}</p>' for note in section.notes]
        out[int(key[1:])] = "".join(blocks)
        progress.advance()
    return out


# ----------------------------------------------------------------------------- A6–A15


def metric_table(metrics: list[Metric]) -> tuple[list[str], list[list[str]]]:
    """Metrics as one row per quantity and one column per component ("value unit" cells)."""
    components: list[str] = []
    cells: dict[str, dict[str, str]] = {}
    for m in metrics:
        if m.component not in components:
            components.append(m.component)
        text = f"{m.formatted()} {m.unit}".strip()
        cells.setdefault(m.quantity, {})[m.component] = text
    headers = ["measured", *[c or "value" for c in components]]
    rows = [[quantity, *[row.get(c, "") for c in components]] for quantity, row in cells.items()]
    return headers, rows


def _experiment_html(exp: Experiment) -> str:
    name = html.escape(exp.name)
    parts = [f'<article class="experiment" id="exp-{name}" data-experiment="{name}">',
             f"<h3>{html.escape(exp.title)} <code>{html.escape(exp.name)}</code></h3>",
             f'<p class="description">{html.escape(exp.description)}</p>']
    tables = []
    if exp.parameters:
        tables.append(html.table(["parameter", "value"], [list(p) for p in exp.parameters],
                                 caption="set-up"))
    if exp.metrics:
        headers, rows = metric_table(exp.metrics)
        tables.append(html.table(headers, rows, numeric=set(range(1, len(headers))),
                                 caption=f"measured on the run (simulated in {exp.seconds:.1f} s wall time, "
                                         "compilation included)"))
    parts.append('<div class="tables">' + "".join(tables) + "</div>")
    result = exp.result
    if exp.error:
        parts.append(f'<p class="diverged">{html.escape(exp.error)}</p>')
    elif result is not None and getattr(result, "status", "ok") != "ok":
        parts.append(f'<p class="diverged">{html.escape(result.diagnosis)}</p>')
    if exp.figures:
        items = [html.figure(html.png_data_uri(data), caption, kind="scope", ident=f"fig-{exp.name}-{scope}")
                 for scope, caption, data in exp.figures]
        parts.append('<div class="figures">' + "".join(items) + "</div>")
    parts.append("</article>")
    return "".join(parts)


def _scope_figures(exp: Experiment) -> list[tuple[str, str, bytes]]:
    result = exp.result
    figures = []
    diagnosis = result.diagnosis if result.status != "ok" else ""
    for scope in scope_layout(result):
        fig = render_scope(scope, title_prefix=exp.name, diagnosis=diagnosis)
        try:
            figures.append((scope.name, f"{exp.name}: {scope.title}", html.figure_png(fig, dpi=80)))
        finally:
            plt.close(fig)
    return figures


def evaluate(exp: Experiment) -> Experiment:
    """Run ``exp`` and measure it: result, metrics and scope figures (PNG), filled in place.

    A scenario that fails is kept with its error message (and its partial result, if the
    simulator kept one) instead of stopping the report.
    """
    started = time.perf_counter()
    if exp.result is None and not exp.error:
        try:
            exp.result = exp.run()
        except ArmlabError as error:
            exp.error = f"{type(error).__name__}: {error}"
            exp.result = getattr(error, "result", None)
        except Exception as error:  # the report lists a broken scenario instead of dying
            exp.error = f"{type(error).__name__}: {error}"
            traceback.print_exc()
        exp.seconds = time.perf_counter() - started
    if exp.result is not None and len(exp.result.t) >= 2:
        exp.metrics = measure(exp.result)
        exp.figures = _scope_figures(exp)
    exp.runner = None  # closures do not cross process boundaries
    return exp


def _evaluate_scenario(name: str, t_final: float | None) -> Experiment:
    """Worker-process job: build the experiment of a registered scenario and evaluate it."""
    from armlab.viz.experiments import experiment_from_scenario

    return evaluate(experiment_from_scenario(name, t_final))


def _schedule(planned: list[Experiment]) -> list[Experiment]:
    """Registry scenarios ordered so that the first run of every controller type comes first,
    joint-space (A6–A8) and task-space (A9–A15) kinds alternating: two workers then compile
    different code at the same time (the joint-space dynamics and loop in one, the task-space
    kernels in the other) instead of the same kernels twice."""
    seen, joint, task, rest = set(), [], [], []
    for exp in planned:
        if exp.kind in seen:
            rest.append(exp)
        else:
            (joint if exp.assignment <= 8 else task).append(exp)
        seen.add(exp.kind)
    first = [e for pair in zip(joint, task, strict=False) for e in pair]
    first += joint[len(task):] + task[len(joint):]
    return first + rest


def _run_all(planned: list[Experiment], progress: Progress, workers: int, main_job) -> dict:
    """Evaluate every experiment (registry ones in ``workers`` processes) while ``main_job()``
    runs here; returns main_job's value."""
    pooled = [e for e in planned if e.scenario is not None and e.result is None] if workers > 1 else []
    local = [e for e in planned if e not in pooled]
    if not pooled:
        value = main_job()
        for exp in local:
            progress.step(f"running {exp.name}")
            evaluate(exp)
            progress.advance()
        return value
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    context = multiprocessing.get_context("spawn")  # no fork of a process that holds threads
    by_name = {e.name: e for e in pooled}
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = {pool.submit(_evaluate_scenario, e.scenario, e.t_final): e.name for e in _schedule(pooled)}
        value = main_job()
        for exp in local:
            progress.step(f"running {exp.name}")
            evaluate(exp)
            progress.advance()
        progress.step(f"running {len(pooled)} scenarios in {workers} processes (first runs compile)")
        for future in as_completed(futures):
            done = future.result()
            target = by_name[futures[future]]
            for key in ("result", "error", "seconds", "metrics", "figures", "robot", "plane"):
                setattr(target, key, getattr(done, key))
            progress.step(f"ran {done.name} ({done.seconds:.1f} s)")
            progress.advance()
    return value


def build_report(robot: str | Robot = "prp", out_dir: str | Path = "report", *, quick: bool = False,
                 show_progress: bool = True, experiments=None, animation: bool = True,
                 jobs: int | None = None) -> Path:
    """Write ``<out_dir>/report.html`` for ``robot`` and return its path.

    Parameters
    ----------
    robot : name of a bundled robot, a robot file, or a Robot
    quick : shorten every run (the registry's quick settings) for a fast preview and tests
    experiments : optional list of :class:`Experiment` to run instead of the registry's
        scenarios of the robot (used by tests)
    animation : add a GIF of one run
    jobs : processes that run the registry's scenarios (default: up to 2, one per core)
    """
    started = time.perf_counter()
    if not isinstance(robot, Robot):
        robot = load_robot(robot)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    from armlab.viz.experiments import discover

    planned = list(experiments) if experiments is not None else discover(robot, quick=quick)
    progress = Progress(len(planned) + 7, enabled=show_progress)

    def here():
        progress.step("robot drawings")
        drawn = _drawings(robot)
        progress.advance()
        try:
            derived = _symbolic_sections(robot, progress)
        except Exception as error:  # a robot SymPy cannot derive still gets its experiments
            derived = {1: f'<p class="diverged">Symbolic derivation failed: {html.escape(error)}</p>'}
        return drawn, derived

    workers = max(1, min(2, os.cpu_count() or 1)) if jobs is None else jobs
    drawings, derivations = _run_all(planned, progress, workers, here)
    bodies: dict[int, list[str]] = {}
    for exp in planned:
        bodies.setdefault(exp.assignment, []).append(_experiment_html(exp))

    movie = ""
    if animation:
        progress.step("animation")
        movie = _animation(planned, out_dir, robot.name)
        progress.advance()

    sections, nav, missing = [], [], []
    for number, title in ASSIGNMENTS.items():
        content = ""
        if number == 1:
            content += _drawings_block(drawings)
        content += derivations.get(number, "")
        content += "".join(bodies.get(number, []))
        if not content:
            missing.append(f"A{number}")
            continue
        sections.append(f'<section class="assignment" id="A{number}" data-assignment="A{number}">'
                        f"<h2>A{number} — {html.escape(title)}</h2>{content}</section>")
        nav.append((f"A{number}", f"A{number}"))
    unnumbered = [b for k, v in bodies.items() if k not in ASSIGNMENTS for b in v]
    if unnumbered:
        sections.append('<section class="assignment" id="other" data-assignment="other">'
                        f"<h2>Other scenarios</h2>{''.join(unnumbered)}</section>")
        nav.append(("other", "other"))
    if movie:
        sections.insert(0, movie)
        nav.insert(0, ("animation", "animation"))
    if missing:
        sections.append('<section id="missing"><h2>Not in this build</h2><p class="missing">'
                        f"No runnable derivation or scenario for {robot.name} yet: {', '.join(missing)}."
                        "</p></section>")
    elapsed = time.perf_counter() - started
    subtitle = [f"robot {robot.name}: {robot.description}" if robot.description else f"robot {robot.name}",
                f"{len(planned)} scenario runs{' (quick settings)' if quick else ''}; "
                f"built in {elapsed:.0f} s by armlab report"]
    page = html.document(f"armlab report — {robot.name}", subtitle, nav, "".join(sections))
    path = out_dir / "report.html"
    path.write_text(page, encoding="utf-8")
    progress.close(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return path


def _drawings_block(drawings: str) -> str:
    return "<h3>The robot and its frames</h3>" + drawings


def _animation(planned: list[Experiment], out_dir: Path, robot_name: str) -> str:
    """A GIF of the most telling run of the report's robot (other robots if it has none): among
    the runs that did not diverge and have an environment plane (else all), the one whose
    joints travel furthest relative to their ranges."""
    runs = [e for e in planned if e.result is not None and e.robot is not None and len(e.result.t) >= 2]
    runs = [e for e in runs if e.robot.name == robot_name] or runs
    runs = [e for e in runs if e.result.status == "ok"] or runs
    if not runs:
        return ""

    def motion(e):
        # Joint travel relative to each joint's range: the run where the arm moves most.
        spans = np.array([(hi - lo) if np.isfinite(hi - lo) else 1.0 for lo, hi in
                          (j.limits for j in e.robot.joints)])
        return float(np.sum(np.ptp(e.result.q, axis=0) / spans))

    with_plane = [e for e in runs if e.plane is not None]
    exp = max(with_plane or runs, key=motion)
    path = animate_robot(exp.robot, exp.result.t, exp.result.q, out_dir / f"{exp.name}.gif",
                         plane=exp.plane, max_frames=60, fps=12, dpi=80, title=exp.name)
    uri = html.gif_data_uri(path.read_bytes())
    caption = f"Animation of {exp.name} ({exp.title}), resampled to 60 frames."
    return ('<section class="assignment" id="animation" data-assignment="animation"><h2>Animation</h2>'
            f'<div class="figures">{html.figure(uri, caption, kind="drawing", ident="fig-animation")}</div>'
            "</section>")
