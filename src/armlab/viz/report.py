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
"""

from __future__ import annotations

import os
import re
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import matplotlib.pyplot as plt
import numpy as np
from tqdm import tqdm

from armlab.files import write_text
from armlab.model.robot import Robot
from armlab.progress import finish, progress_bar
from armlab.robots import load_robot
from armlab.simulation.joint_limits import describe_crossing
from armlab.viz import html
from armlab.viz.animation import animate_robot, joint_spans, motion_window
from armlab.viz.comparisons import COMPARISONS, comparison_scope
from armlab.viz.drawing import draw_robot
from armlab.viz.experiments import (  # noqa: F401 — ReportError, assignment_number: public here too
    Experiment,
    ReportError,
    assignment_number,
    discover,
    experiment_from_scenario,
)
from armlab.viz.metrics import Metric
from armlab.viz.notes import anchored, markdown_html, metric_definitions, seed_notes, source_name
from armlab.viz.report_runs import run_all
from armlab.viz.scopes import SCOPE_DPI, scope_png
from armlab.viz.tags import legend_html
from armlab.viz.view_pages import plotly_js, view_iframe, write_assets, write_view_page

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
VIEW_FRAMES = 60  # animation frames of a run's 3-D view (as the GIF): ~0.3 MB a PRP page
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


def _derivation_cache(robot: Robot) -> Path:
    """The file that keeps the HTML of ``robot``'s A1–A5 derivations: named by a hash of the
    numbers and expressions of the robots they are derived for (:func:`derivation_robots`),
    of every source the HTML depends on (the symbolic model, its rendering, this page's
    pieces) and of SymPy's version, so that any change derives anew."""
    import hashlib
    from importlib.metadata import version

    from armlab.specialise.closed_form import cache_dir, robot_key

    package = Path(__file__).resolve().parents[1]
    # SymPy's version from its metadata: importing SymPy costs seconds a cached report saves.
    digest = hashlib.sha256(version("sympy").encode())
    for subject in {id(r): r for r in derivation_robots(robot).values()}.values():
        digest.update(robot_key(subject).encode())
    for path in [*sorted((package / "symbolic").glob("*.py")), package / "viz" / "html.py", Path(__file__)]:
        digest.update(path.read_bytes())
    return cache_dir() / "report" / f"derivations_{digest.hexdigest()[:24]}.json"


DERIVATION_BUDGET = {False: 120.0, True: 30.0}
"""Seconds each of A1–A5 may take in a full (False) and in a ``--quick`` (True) report; an
assignment past it keeps what it derived and says what it skipped (``symbolic.derive``)."""


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


def actuated_variant(robot: Robot) -> Robot | None:
    """The bundled robot ``<name>_actuated`` when it is ``robot`` with motors and friction
    added (:func:`same_arm`: ``prp_actuated`` for ``prp``) and ``robot`` itself has neither;
    else None."""
    from armlab.model.robot import Friction, Motor
    from armlab.robots import bundled_robot_names

    name = f"{robot.name}_actuated"
    if name not in bundled_robot_names() or any(
            j.motor != Motor() or j.friction != Friction() for j in robot.joints):
        return None
    variant = load_robot(name)
    return variant if same_arm(robot, variant) else None


def same_arm(a: Robot, b: Robot) -> bool:
    """Whether ``a`` and ``b`` have the same joints (kinds, P_i, S_i, offsets), links (masses,
    centres of mass, inertia tensors), gravity, base and tool: differ at most in their motors,
    friction, limits and parameters."""
    frames = ("gravity", "base", "tool")
    if a.n != b.n or not all(np.array_equal(getattr(a, f), getattr(b, f)) for f in frames):
        return False
    for i, j in zip(a.joints, b.joints, strict=True):
        if ((i.name, i.kind, i.offset, i.dh) != (j.name, j.kind, j.offset, j.dh)
                or not (np.array_equal(i.before, j.before) and np.array_equal(i.after, j.after))):
            return False
    return all(k.inertial.mass == m.inertial.mass and np.array_equal(k.inertial.com, m.inertial.com)
               and np.array_equal(k.inertial.inertia, m.inertial.inertia)
               for k, m in zip(a.links, b.links, strict=True))


def derivation_robots(robot: Robot) -> dict[str, Robot]:
    """The robot each of A1–A5 is derived for: ``robot``, except A4 for its actuated variant
    (:func:`actuated_variant`) when it has one.  The seed's A4 asks for the Newton–Euler
    equations with the motor and friction terms,

        τ_i = zᵀ μ_i | zᵀ f_i + k_rᵢ I_mᵢ ṡ_i + F_vᵢ q̇_i + F_sᵢ sgn q̇_i                   (N1)

    (``armlab.symbolic.newton_euler``), which a robot without motors and friction reduces to
    its rigid-body part."""
    from armlab.symbolic.sections import ASSIGNMENTS as DERIVED

    robots = dict.fromkeys(DERIVED, robot)
    variant = actuated_variant(robot)
    if variant is not None:
        robots["A4"] = variant
    return robots


class Derivation(NamedTuple):
    """One assignment's symbolic results as the report shows them: the ``section``
    (``symbolic.derive``) of ``robot``, the report's robot or its actuated variant (A4), and
    the symbolic robot ``symbolic`` its expressions are written in."""

    key: str
    robot: Robot
    symbolic: object
    section: object


def derivations(robot: Robot, budget: float | None = None, only=None,
                progress: tqdm | None = None) -> list[Derivation]:
    """The report's A1–A5 (or the keys in ``only``) of ``robot``: A1 in both Σ_0 and Σ_base (as
    the seed does: its transforms, inverse kinematics and Jacobians in each), A2–A5 in Σ_0.
    One symbolic robot serves the assignments of each robot, so later ones reuse B, C, g."""
    from armlab.symbolic import symbolic_robot
    from armlab.symbolic.sections import derive

    robots = derivation_robots(robot)
    symbolic: dict[int, object] = {}
    out = []
    for key, subject in robots.items():
        if only is not None and key not in only:
            continue
        if progress is not None:
            progress.set_postfix_str(f"deriving {key}" + ("" if subject is robot else f" for {subject.name}"))
        if id(subject) not in symbolic:
            symbolic[id(subject)] = symbolic_robot(subject)
        sr = symbolic[id(subject)]
        (section,) = derive(sr, frame="base" if key == "A1" else "0", only=key, budget=budget)
        out.append(Derivation(key, subject, sr, section))
        if progress is not None:
            progress.update()
    return out


def derivation_html(derivation: Derivation, robot: Robot) -> str:
    """HTML of one derivation in the report of ``robot``: its heading (naming the robot it is
    derived for when that is not ``robot``), each result as presentation MathML, its notes."""
    from armlab.symbolic.render import to_mathml

    section, subject = derivation.section, derivation.robot
    where = "" if subject is robot else f" for {subject.name}"
    blocks = [f"<h3>Derivation{html.escape(where)}: {html.escape(section.title)}</h3>"]
    for item in section.items:
        blocks.append(html.math_block(item.label, to_mathml(item.expr)))
    blocks += [f'<p class="note">{html.escape(note)}</p>' for note in section.notes]
    return "".join(blocks)


def _symbolic_sections(robot: Robot, progress: tqdm,
                       budget: float | None = None) -> tuple[dict[int, str], bool]:
    """HTML of the A1–A5 derivations by assignment number (:func:`derivations`), and whether
    every one finished within ``budget`` seconds (``armlab.symbolic.derive``)."""
    derived = derivations(robot, budget, progress=progress)
    out = {int(d.key[1:]): derivation_html(d, robot) for d in derived}
    return out, all(d.section.complete for d in derived)


# ----------------------------------------------------------------------------- A6–A15


# Components printed side by side, in this order, where the first of them comes: a wrench's
# fy measured by h_e and its fx, fz predicted by the theory are one group of columns.
COLUMN_GROUPS = (("x", "y", "z"), ("φ1", "φ2", "φ3"), ("fx", "fy", "fz", "mx", "my", "mz"))


def column_order(components: list[str]) -> list[str]:
    """``components`` in order of first appearance, those of a :data:`COLUMN_GROUPS` group
    together and in the group's order, at the place of the group's first."""
    ordered: list[str] = []
    for component in components:
        if component in ordered:
            continue
        group = next((g for g in COLUMN_GROUPS if component in g), (component,))
        ordered += [c for c in group if c in components and c not in ordered]
    return ordered


def metric_table(metrics: list[Metric]) -> tuple[list[str], list[list[str]]]:
    """Metrics as one row per quantity and one column per component ("value unit" cells),
    the components of a group (fx, fy, fz …) side by side (:func:`column_order`)."""
    components: list[str] = []
    cells: dict[str, dict[str, str]] = {}
    for m in metrics:
        if m.component not in components:
            components.append(m.component)
        text = f"{m.formatted()} {m.unit}".strip()
        cells.setdefault(m.quantity, {})[m.component] = text
    components = column_order(components)
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
        tables.append(html.table(headers, rows, numeric=set(range(1, len(headers))), kind="metrics",
                                 caption=f"measured on the run (simulated in {_seconds(exp.seconds)} wall "
                                         "time, compilation included; definitions at the end of the report)"))
    parts.append('<div class="tables">' + "".join(tables) + "</div>")
    result = exp.result
    if exp.error:
        parts.append(f'<p class="diverged">{html.escape(exp.error)}</p>')
    elif result is not None and getattr(result, "status", "ok") != "ok":
        parts.append(f'<p class="diverged">{html.escape(result.diagnosis)}</p>')
    limits = (getattr(result, "meta", None) or {}).get("joint_limits") or {}
    for name, crossing in (limits.get("crossed") or {}).items():
        # A declared joint limit left (or a stop met) is part of what the run shows.
        line = describe_crossing(exp.robot, name, crossing, limits.get("mode", "warn"))
        parts.append(f'<p class="diverged">{html.escape(line)}</p>')
    if exp.diagram:
        caption = (f"{exp.name}: the closed loop as simulated, drawn from the scenario's objects "
                   "(controller, gains, saturation, disturbance, environment, sensors); under the row, "
                   "the measured signals fed back."
                   + (f" Its blocks' equations: {', '.join(exp.diagram_tags)}." if exp.diagram_tags else ""))
        parts.append('<div class="figures">' + html.figure(html.png_data_uri(exp.diagram), caption,
                                                            kind="diagram", ident=f"fig-{exp.name}-loop")
                     + "</div>")
    if exp.figures:
        items = [html.figure(html.png_data_uri(data), caption, kind="scope", ident=f"fig-{exp.name}-{scope}")
                 for scope, caption, data in exp.figures]
        parts.append('<div class="figures">' + "".join(items) + "</div>")
    if exp.view:
        caption = (f"{exp.name} in 3-D: drag to turn, scroll to zoom, ▶ play or move the time slider "
                   f"(the run resampled to at most {VIEW_FRAMES} frames). The page {exp.view} next to "
                   "this file draws it with plotly.js from that folder: no network.")
        parts.append('<div class="figures">' + view_iframe(exp.view, exp.name, caption) + "</div>")
    parts.append(_tags_html(exp, "".join(parts)))
    parts.append("</article>")
    return "".join(parts)


def _tags_html(exp: Experiment, text: str) -> str:
    """The legend of the equation tags the article's text names (:mod:`armlab.viz.tags`)."""
    return legend_html(re.sub(r"<[^>]+>|data:[^\"]+", " ", text))


def _comparisons_html(planned: list[Experiment]) -> dict[int, list[str]]:
    """The figures of :data:`armlab.viz.comparisons.COMPARISONS` whose two runs the report
    has, as HTML blocks by assignment."""
    runs = {e.name: e.result for e in planned if e.result is not None and len(e.result.t) >= 2}
    blocks: dict[int, list[str]] = {}
    for comparison in COMPARISONS:
        if not all(name in runs for name in comparison.runs):
            continue
        scope = comparison_scope(comparison, *(runs[name] for name in comparison.runs))
        # The caption is the article's text above the figure, not repeated under its axes.
        data = scope_png(replace(scope, caption=""), title_prefix=f"A{comparison.assignment}", dpi=SCOPE_DPI)
        ident = f"cmp-{comparison.name}"
        caption = f"{' and '.join(comparison.runs)}: {scope.title}"
        blocks.setdefault(comparison.assignment, []).append(
            f'<article class="experiment" id="{ident}" data-comparison="{ident}">'
            f"<h3>Comparison: {html.escape(scope.title)}</h3>"
            f'<p class="description">{html.escape(scope.caption)}</p><div class="figures">'
            f'{html.figure(html.png_data_uri(data), caption, kind="scope", ident=f"fig-{ident}")}'
            "</div></article>")
    return blocks


def _write_views(planned: list[Experiment], out_dir: Path, script: tuple[str, str]) -> None:
    """Write the 3-D view page of every run that has a robot and two samples or more, and
    plotly.js once (:mod:`armlab.viz.view_pages`); ``exp.view`` names its page."""
    from armlab.viz.view3d import view3d_spec

    write_assets(out_dir, script)
    for exp in planned:
        if exp.robot is None or exp.result is None or len(exp.result.t) < 2:
            continue
        try:
            spec = view3d_spec(exp.result, robot=exp.robot, plane=exp.plane, max_frames=VIEW_FRAMES,
                               title=f"{exp.name}: {exp.robot.name} in Σ_base")
        except ValueError:  # a run with no finite sample has nothing to draw
            continue
        exp.view = write_view_page(out_dir, exp.name, spec, f"{exp.name} — 3-D view", script[0])


def _seconds(seconds: float) -> str:
    """A wall time as a reader wants it: 3.2 s, 0.21 s, 4 ms (a 10 s run takes milliseconds
    once compiled: "0.0 s" would say nothing)."""
    return f"{seconds:.1f} s" if seconds >= 1 else (f"{seconds:.2g} s" if seconds >= 0.01
                                                    else f"{1e3 * seconds:.2g} ms")


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


def _motion(exp: Experiment) -> float:
    """Joint travel relative to each joint's range: the run where the arm moves most."""
    return float(np.sum(np.ptp(exp.result.q, axis=0) / joint_spans(exp.robot)))


def animation_subject(planned: list[Experiment], robot_name: str, *, final: bool = True):
    """The run the report animates: among the runs of ``robot_name`` (other robots if it has
    none) that did not diverge and kept their joints within their limits (else all) and have an
    environment plane (else all), the one whose joints travel furthest relative to their
    ranges; None if there is none.

    With ``final=False`` some runs may still be unfinished: the subject is returned only if
    no unfinished run could change it (it is a finished plane run of the robot that did not
    diverge, and no unfinished run of the robot has a plane), else None."""
    runs = [e for e in planned if e.result is not None and e.robot is not None and len(e.result.t) >= 2]
    if not final:
        pending = [e for e in planned if e.result is None and not e.error]
        if any(e.plane is not None and e.robot is not None and e.robot.name == robot_name for e in pending):
            return None
    runs = [e for e in runs if e.robot.name == robot_name] or runs
    runs = [e for e in runs if e.result.status == "ok"] or runs
    runs = [e for e in runs if not _left_limits(e)] or runs
    if not runs:
        return None
    with_plane = [e for e in runs if e.plane is not None]
    subject = max(with_plane or runs, key=_motion)
    if not final and not (subject.plane is not None and subject.robot.name == robot_name
                          and subject.result.status == "ok"):
        return None
    return subject


def _left_limits(exp: Experiment) -> bool:
    """True when the run took a joint past its declared limits (or into its stop): animated,
    the arm would slide through its end stop, not show its course."""
    limits = (getattr(exp.result, "meta", None) or {}).get("joint_limits") or {}
    return bool(limits.get("crossed"))


def _animation(exp: Experiment | None, out_dir: Path) -> str:
    """The report's animation section for the run ``exp`` ('' for None)."""
    if exp is None:
        return ""
    t, q = exp.result.t, exp.result.q
    # The frames where the arm moves: a run that comes to rest early would fill most of the
    # GIF with one picture.
    stop = motion_window(t, q, joint_spans(exp.robot))
    moving = t <= stop
    path = animate_robot(exp.robot, t[moving], q[moving], out_dir / f"{exp.name}.gif",
                         plane=exp.plane, max_frames=60, fps=12, dpi=80, title=exp.name)
    uri = html.gif_data_uri(path.read_bytes())
    span = (f"its first {stop - t[0]:.3g} s (the arm is at rest for the remaining {t[-1] - stop:.3g} s)"
            if stop < t[-1] else f"the whole run ({t[-1] - t[0]:.3g} s)")
    caption = f"Animation of {exp.name} ({exp.title}): {span}, resampled to 60 frames."
    return ('<section class="assignment" id="animation" data-assignment="animation"><h2>Animation</h2>'
            f'<div class="figures">{html.figure(uri, caption, kind="drawing", ident="fig-animation")}</div>'
            "</section>")
