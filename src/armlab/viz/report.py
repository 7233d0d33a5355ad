"""``armlab report``: one HTML document reproducing the seed project, offline.

The document has one section per seed assignment that armlab can run for the chosen robot:

* A1–A5 from :func:`armlab.symbolic.sections.derive` (DH tables, transforms, Jacobians, energies,
  Lagrange and Newton–Euler dynamics, operational-space model) as presentation MathML, A4 for
  the robot's actuated variant when it has one (``prp_actuated`` for the PRP), with
  the robot drawn with its frames in Σ_base and Σ_0 (the seed's plotTransforms check);
* A6–A15 from the scenario registry: for every bundled scenario of the robot its description,
  parameters, scope plots and the measured numbers of :mod:`armlab.viz.metrics`, an
  interactive 3-D view of its run, and one animation.

Sections appear as their code does: a scenario added to the registry shows up in the next
report without changes here; an assignment with nothing runnable is listed as missing, never
filled with made-up content.  Images are inlined, so the file can be mailed or opened offline.
The 3-D views (plotly, the optional extra ``viewer``) are pages of their own in ``view3d/``
next to it, framed by the report (:mod:`armlab.viz.view_pages`): the report itself runs no
script; without plotly it has no views and says so in one line.

This module assembles the document and keeps its A1–A5 HTML on disk; the parts are built by
:mod:`armlab.viz.report_derivations` (A1–A5), :mod:`armlab.viz.report_experiments` (the articles
of A6–A15), :mod:`armlab.viz.report_animation` (the 3-D views and the animation) and
:mod:`armlab.viz.report_runs` (the runs, in worker processes).
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from tqdm import tqdm

from armlab.files import write_text
from armlab.model.robot import Robot
from armlab.progress import finish, progress_bar
from armlab.robots import load_robot
from armlab.viz import html
from armlab.viz.drawing import draw_robot
from armlab.viz.experiments import (  # noqa: F401 — ReportError, assignment_number: public here too
    Experiment,
    ReportError,
    assignment_number,
    discover,
    experiment_from_scenario,
)
from armlab.viz.notes import anchored, markdown_html, metric_definitions, seed_notes, source_name
from armlab.viz.report_animation import _animation, _write_views, animation_subject
from armlab.viz.report_derivations import DERIVATION_BUDGET, _derivation_cache, _symbolic_sections
from armlab.viz.report_experiments import (  # noqa: F401 — metric_table: public here too
    _comparisons_html,
    _experiment_html,
    metric_table,
)
from armlab.viz.report_runs import run_all
from armlab.viz.tags import legend_html
from armlab.viz.view_pages import plotly_js

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
DRAWING_DPI = 130  # the A1 robot drawings (frame labels legible at the page's 400 px)
NO_VIEWS = "The interactive 3-D views are left out: plotly is not installed (pip install 'armlab[viewer]')."


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
            data = html.figure_png(fig, dpi=DRAWING_DPI, tight=True)
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


def _cached_symbolic_sections(robot: Robot, progress: tqdm, budget: float | None = None) -> dict[int, str]:
    """:func:`_symbolic_sections`, kept on disk (ARMLAB_CACHE_DIR) after the first report:
    SymPy spends tens of seconds on them, the rest of a ``--quick`` report a few.  A cache
    that cannot be read or written is derived around, never trusted half-written; a
    derivation cut short by its ``budget`` is not kept (a later, idle run may finish it)."""
    import json

    path = _derivation_cache(robot)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if isinstance(data, dict) and all(isinstance(v, str) for v in data.values()):
            progress.set_postfix_str("derivations A1–A5 (cached)")
            progress.update(len(data))
            return {int(k): v for k, v in data.items()}
    except (OSError, ValueError):
        pass
    sections, complete = _symbolic_sections(robot, progress, budget)
    if not complete:
        return sections
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, json.dumps({str(k): v for k, v in sections.items()}))  # whole or not at all
    except OSError:
        pass  # a cache that cannot be written only costs the next report its derivation
    return sections


# ----------------------------------------------------------------------------- the document


def build_report(robot: str | Robot = "prp", out_dir: str | Path = "report", *, quick: bool = False,
                 show_progress: bool = True, experiments=None, animation: bool = True,
                 jobs: int | None = None, first=None, sweeps=(), views: bool = True) -> Path:
    """Write ``<out_dir>/report.html`` for ``robot`` and return its path.

    Parameters
    ----------
    robot : name of a bundled robot, a robot file, or a Robot
    quick : a fast preview: the first scenario of each assignment (seed order), each run
        shortened to the registry's quick length and drawn with its main scopes alone
    experiments : optional list of :class:`Experiment` to run instead of the registry's
        scenarios of the robot (used by tests)
    animation : add a GIF of one run
    jobs : processes that run the registry's scenarios (default: up to 2, one per core; 1 for
        ``quick``, whose short runs cost less than starting a worker)
    first : optional callable run here first, once the worker processes are starting (the
        demo prints its A1 tables meanwhile)
    sweeps : output folders of ``armlab sweep`` runs, each added as a page of its own
    views : an interactive 3-D view of every run, a page of its own in ``<out_dir>/view3d``
        framed by the report (needs plotly; without it the report says they are left out)
    """
    started = time.perf_counter()
    if not isinstance(robot, Robot):
        robot = load_robot(robot)
    out_dir = Path(out_dir)
    # The sweeps' pages first: a folder that is not a sweep's stops the report before its runs.
    from armlab.viz.sweeps import SEED_SWEEPS, seed_sweep_pages, sweep_section

    sweep_pages = [(folder, sweep_section(folder, k)) for k, folder in enumerate(sweeps)]
    out_dir.mkdir(parents=True, exist_ok=True)
    seed_sweeps = [] if quick or experiments is not None or robot.name != "prp" else SEED_SWEEPS
    sweep_pages += seed_sweep_pages(seed_sweeps, out_dir, len(sweep_pages))
    planned = (list(experiments) if experiments is not None
               else discover(robot, quick=quick, course_dir=out_dir / "course"))
    if quick and experiments is None:
        planned = first_of_each_assignment(planned)
    script = plotly_js() if views else None
    progress = progress_bar(len(planned) + 7 + (script is not None), enabled=show_progress, unit="step")

    def here():
        if first is not None:
            first()
        progress.set_postfix_str("robot drawings")
        drawn = _drawings(robot)
        progress.update()
        try:
            derived = _cached_symbolic_sections(robot, progress, DERIVATION_BUDGET[quick])
        except Exception as error:  # a robot SymPy cannot derive still gets its experiments
            derived = {1: f'<p class="diverged">Symbolic derivation failed: {html.escape(error)}</p>'}
        return drawn, derived

    # The animation is drawn here while the workers still run, as soon as no unfinished run
    # can change its subject (the GIF takes seconds; the workers' last runs overlap it).
    animator: dict = {}

    def animate(subject):
        try:
            animator["html"] = _animation(subject, out_dir)
        except BaseException as error:  # re-raised in the main thread below
            animator["error"] = error

    def start_animation():
        if animation and "thread" not in animator:
            subject = animation_subject(planned, robot.name, final=False)
            if subject is not None:
                animator["thread"] = threading.Thread(target=animate, args=(subject,), daemon=True)
                animator["thread"].start()

    # A quick report runs its few short scenarios in this process: starting a worker (its
    # imports and kernels, ~10 s) would cost more than the runs it takes over.
    workers = (1 if quick else max(1, min(2, os.cpu_count() or 1))) if jobs is None else jobs
    drawings, derivations = run_all(planned, progress, workers, here, start_animation)
    if script is not None:
        progress.set_postfix_str("3-D views")
        _write_views(planned, out_dir, script)
        progress.update()
    bodies: dict[int, list[str]] = {}
    for exp in planned:
        bodies.setdefault(exp.assignment, []).append(_experiment_html(exp))
    for number, blocks in _comparisons_html(planned).items():
        bodies.setdefault(number, []).extend(blocks)

    movie = ""
    if animation:
        progress.set_postfix_str("animation")
        if "thread" in animator:
            animator["thread"].join()
            if "error" in animator:
                raise animator["error"]
            movie = animator["html"]
        else:
            movie = _animation(animation_subject(planned, robot.name), out_dir)
        progress.update()

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
                        f"<h2>A{number} — {html.escape(title)}</h2>{_seed_note_html(number)}{content}"
                        "</section>")
        nav.append((f"A{number}", f"A{number}"))
    if any(exp.metrics for exp in planned):
        sections.append('<section class="assignment" id="metrics" data-assignment="metrics">'
                        "<h2>How the measured numbers are defined</h2>"
                        f'<div class="seed-note">{metric_definitions()}'
                        '<p class="note">From the docstrings of armlab.metrics and armlab.viz.metrics, which '
                        'compute them.</p>'
                        "</div></section>")
        nav.append(("metrics", "metrics"))
    unnumbered = [b for k, v in bodies.items() if k not in ASSIGNMENTS for b in v]
    if unnumbered:
        sections.append('<section class="assignment" id="other" data-assignment="other">'
                        f"<h2>Other scenarios</h2>{''.join(unnumbered)}</section>")
        nav.append(("other", "other"))
    for k, (folder, page) in enumerate(sweep_pages):
        sections.append(page)
        nav.append((f"sweep{k}", f"sweep {Path(folder).name}"))
    if movie:
        sections.insert(0, movie)
        nav.insert(0, ("animation", "animation"))
    if missing:
        sections.append('<section id="missing"><h2>Not in this build</h2><p class="missing">'
                        f"No runnable derivation or scenario for {html.escape(robot.name)} yet: "
                        f"{', '.join(missing)}.</p></section>")
    elapsed = time.perf_counter() - started
    subtitle = [f"robot {robot.name}: {robot.description}" if robot.description else f"robot {robot.name}",
                f"{len(planned)} scenario runs{' (quick settings)' if quick else ''}; "
                f"built in {elapsed:.0f} s by armlab report"]
    if views and script is None:
        subtitle.append(NO_VIEWS)
    page = html.document(f"armlab report — {robot.name}", subtitle, nav, "".join(sections),
                         frames=any(exp.view for exp in planned))
    path = out_dir / "report.html"
    write_text(path, page)  # atomic: a killed or failed build keeps the previous report
    finish(progress, f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return path


def _seed_note_html(number: int) -> str:
    """Assignment ``number``'s notes on the seed, read from its docs page now (one source for
    the docs and the report); a line saying they are missing when the page is not there."""
    page = source_name(number)
    notes = [(heading, anchored(text, page)) for heading, text in seed_notes(number)]
    if not notes:
        return ""
    parts = ['<aside class="seed-note"><h3>The seed and armlab</h3>']
    for heading, text in notes:
        parts.append(f"<h4>{html.escape(heading)}</h4>{markdown_html(text)}")
    parts.append(legend_html(" ".join(text for _, text in notes)))
    parts.append(f'<p class="note">From {html.escape(source_name(number))}.</p></aside>')
    return "".join(parts)


def first_of_each_assignment(planned: list[Experiment]) -> list[Experiment]:
    """The first experiment of every assignment, in order (what ``--quick`` runs)."""
    seen: set[int] = set()
    return [e for e in planned if not (e.assignment in seen or seen.add(e.assignment))]


def _drawings_block(drawings: str) -> str:
    return "<h3>The robot and its frames</h3>" + drawings
