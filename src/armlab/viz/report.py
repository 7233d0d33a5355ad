"""``armlab report``: one self-contained HTML document reproducing the seed project.

The document has one section per seed assignment that armlab can run for the chosen robot:

* A1–A5 from :func:`armlab.symbolic.derive` (DH tables, transforms, Jacobians, energies,
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
    runner: object = None

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
    """HTML of the A1–A5 derivations by assignment number ({} when derivations are missing)."""
    try:
        import armlab.symbolic as symbolic
    except ImportError:
        return {}
    derive = getattr(symbolic, "derive", None)
    if derive is None:
        return {}
    progress.step("symbolic derivations A1–A5")
    sections = derive(robot)
    progress.advance()
    from sympy import Symbol

    out: dict[int, list[str]] = {}
    for order, section in enumerate(sections, start=1):
        title = str(getattr(section, "title", section[0] if isinstance(section, tuple) else ""))
        items = getattr(section, "items", section[1] if isinstance(section, tuple) else [])
        number = getattr(section, "assignment", None) or assignment_number(title) or min(order, 5)
        blocks = [f"<h3>{html.escape(title)}</h3>"]
        for label, expr in items:
            blocks.append(html.math_block(str(label), expr, label_expr=None if _is_sentence(label)
                                          else Symbol(str(label))))
        out.setdefault(int(number), []).append("".join(blocks))
    return {k: "".join(v) for k, v in out.items()}


def _is_sentence(label) -> bool:
    """Labels with spaces are descriptions, not symbols to put on the left of an equation."""
    return " " in str(label) or len(str(label)) > 24


# ----------------------------------------------------------------------------- A6–A15


def _experiment_html(exp: Experiment, figures: list[tuple[str, bytes]]) -> str:
    name = html.escape(exp.name)
    parts = [f'<article class="experiment" id="exp-{name}" data-experiment="{name}">',
             f"<h3>{html.escape(exp.title)} <code>{html.escape(exp.name)}</code></h3>",
             f'<p class="description">{html.escape(exp.description)}</p>']
    tables = []
    if exp.parameters:
        tables.append(html.table(["parameter", "value"], [list(p) for p in exp.parameters],
                                 caption="set-up"))
    if exp.metrics:
        rows = [[m.quantity, m.component, m.formatted(), m.unit] for m in exp.metrics]
        tables.append(html.table(["measured", "component", "value", "unit"], rows, numeric={2},
                                 caption=f"measured on the run ({exp.seconds:.1f} s wall time)"))
    parts.append('<div class="tables">' + "".join(tables) + "</div>")
    result = exp.result
    if exp.error:
        parts.append(f'<p class="diverged">{html.escape(exp.error)}</p>')
    elif result is not None and getattr(result, "status", "ok") != "ok":
        parts.append(f'<p class="diverged">{html.escape(result.diagnosis)}</p>')
    if figures:
        items = [html.figure(html.png_data_uri(data), caption, kind="scope", ident=f"fig-{exp.name}-{scope}")
                 for scope, (caption, data) in figures]
        parts.append('<div class="figures">' + "".join(items) + "</div>")
    parts.append("</article>")
    return "".join(parts)


def _scope_figures(exp: Experiment) -> list[tuple[str, tuple[str, bytes]]]:
    result = exp.result
    figures = []
    diagnosis = result.diagnosis if result.status != "ok" else ""
    for scope in scope_layout(result):
        fig = render_scope(scope, title_prefix=exp.name, diagnosis=diagnosis)
        try:
            figures.append((scope.name, (f"{exp.name}: {scope.title}", html.figure_png(fig, dpi=80))))
        finally:
            plt.close(fig)
    return figures


def build_report(robot: str | Robot = "prp", out_dir: str | Path = "report", *, quick: bool = False,
                 show_progress: bool = True, experiments=None, animation: bool = True) -> Path:
    """Write ``<out_dir>/report.html`` for ``robot`` and return its path.

    Parameters
    ----------
    robot : name of a bundled robot, a robot file, or a Robot
    quick : shorten every run (the registry's quick settings) for a fast preview and tests
    experiments : optional list of :class:`Experiment` to run instead of the registry's
        scenarios of the robot (used by tests)
    animation : add a GIF of one run
    """
    started = time.perf_counter()
    if not isinstance(robot, Robot):
        robot = load_robot(robot)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    from armlab.viz.experiments import discover

    planned = list(experiments) if experiments is not None else discover(robot, quick=quick)
    progress = Progress(len(planned) + 3, enabled=show_progress)

    progress.step("robot drawings")
    drawings = _drawings(robot)
    progress.advance()
    derivations = _symbolic_sections(robot, progress)

    bodies: dict[int, list[str]] = {}
    for exp in planned:
        progress.step(f"running {exp.name}")
        exp_started = time.perf_counter()
        if exp.result is None and not exp.error:
            try:
                exp.result = exp.run()
            except ArmlabError as error:
                exp.error = f"{type(error).__name__}: {error}"
                exp.result = getattr(error, "result", None)
            except Exception as error:  # the report lists a broken scenario instead of dying
                exp.error = f"{type(error).__name__}: {error}"
                traceback.print_exc()
        exp.seconds = time.perf_counter() - exp_started
        figures = []
        if exp.result is not None and len(exp.result.t) >= 2:
            exp.metrics = measure(exp.result)
            figures = _scope_figures(exp)
        bodies.setdefault(exp.assignment, []).append(_experiment_html(exp, figures))
        progress.advance()

    movie = ""
    if animation:
        progress.step("animation")
        movie = _animation(planned, out_dir)
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


def _animation(planned: list[Experiment], out_dir: Path) -> str:
    """A GIF of the most telling run: one with an environment plane if any, else the first."""
    runs = [e for e in planned if e.result is not None and e.robot is not None and len(e.result.t) >= 2]
    if not runs:
        return ""
    exp = next((e for e in runs if e.plane is not None), runs[0])
    path = animate_robot(exp.robot, exp.result.t, exp.result.q, out_dir / f"{exp.name}.gif",
                         plane=exp.plane, max_frames=60, fps=12, dpi=64, title=exp.name)
    uri = html.gif_data_uri(path.read_bytes())
    caption = f"Animation of {exp.name} ({exp.title}), resampled to 60 frames."
    return ('<section class="assignment" id="animation" data-assignment="animation"><h2>Animation</h2>'
            f'<div class="figures">{html.figure(uri, caption, kind="drawing", ident="fig-animation")}</div>'
            "</section>")
