"""Running the report's experiments: each one measured (result, metrics, scope figures), the
registry's in a pool of worker processes that first compile the shared kernels in two halves
(``armlab.warmup``), the rest here while the derivations are made.

A worker is a spawned interpreter: it draws into files only (matplotlib's file backend), and
it leaves by itself when the report that started it is killed outright.
"""

from __future__ import annotations

import os
import threading
import time
import traceback
import warnings
from typing import TYPE_CHECKING

from armlab.errors import ArmlabError
from armlab.model.robot import Robot
from armlab.simulation.joint_limits import JointLimitWarning
from armlab.viz.comparisons import impedance_scope
from armlab.viz.experiments import Experiment, experiment_from_scenario
from armlab.viz.metrics import measure
from armlab.viz.scopes import SCOPE_DPI, main_scopes, scope_layout, scope_png

if TYPE_CHECKING:
    from tqdm import tqdm


def scope_figures(exp: Experiment) -> list[tuple[str, str, bytes]]:
    result = exp.result
    figures = []
    diagnosis = result.diagnosis if result.status != "ok" else ""
    # A quick report draws each run's main figures alone: the scopes are most of its time.
    scopes = main_scopes(result) if exp.quick else [*scope_layout(result), *_theory_scopes(exp)]
    for scope in scopes:
        caption = f"{exp.name}: {scope.title}" + (f". {scope.caption}" if scope.caption else "")
        data = scope_png(scope, title_prefix=exp.name, diagnosis=diagnosis, dpi=SCOPE_DPI)
        figures.append((scope.name, caption, data))
    return figures


def loop_figure(scenario: str) -> tuple[bytes, tuple[str, ...]]:
    """The PNG of the block diagram of the scenario named (or filed) ``scenario`` and the
    equation tags its drawing names (blocks and arrows); empty when the scenario no longer
    loads (its run's error says why)."""
    from armlab.scenarios import load_scenario
    from armlab.viz.diagram_drawing import draw_loop_diagram
    from armlab.viz.html import figure_png
    from armlab.viz.loop_diagram import diagram_text, loop_diagram
    from armlab.viz.tags import used_tags

    try:
        diagram = loop_diagram(load_scenario(scenario))
    except ArmlabError:
        return b"", ()
    return figure_png(draw_loop_diagram(diagram)), tuple(used_tags(diagram_text(diagram)))


def _theory_scopes(exp: Experiment) -> list:
    """The linear system an impedance run is designed to follow, over the run (A12); the
    controller's M_d and Σ_d are read from its scenario, which the result does not log."""
    controller = exp.result.meta.get("controller")
    impedance = isinstance(controller, dict) and controller.get("type") == "ImpedanceControl"
    if exp.scenario is None or not impedance:
        return []
    from armlab.scenarios import load_scenario

    # The file this report loaded or generated already (a course names the user's robot file).
    law = load_scenario(exp.scenario, allow_outside=True).controller
    scope = impedance_scope(exp.result, law.mass, law.reference)
    return [] if scope is None else [scope]


def evaluate(exp: Experiment) -> Experiment:
    """Run ``exp`` and measure it: result, metrics and scope figures (PNG), filled in place.

    A scenario that fails is kept with its error message (and its partial result, if the
    simulator kept one) instead of stopping the report.
    """
    started = time.perf_counter()
    if exp.result is None and not exp.error:
        try:
            with warnings.catch_warnings():
                # Shown in the report itself, next to the run.
                warnings.simplefilter("ignore", JointLimitWarning)
                exp.result = exp.run()
        except ArmlabError as error:
            exp.error = f"{type(error).__name__}: {error}"
            exp.result = getattr(error, "result", None)
        except Exception as error:  # the report lists a broken scenario instead of dying
            exp.error = f"{type(error).__name__}: {error}"
            traceback.print_exc()
        exp.seconds = time.perf_counter() - started
    if exp.result is not None and len(exp.result.t) >= 2:
        if exp.predictor is not None:
            exp.predicted = exp.predictor()
        exp.metrics = measure(exp.result, exp.predicted)
        exp.figures = scope_figures(exp)
    if exp.scenario is not None and not exp.diagram:
        exp.diagram, exp.diagram_tags = loop_figure(exp.scenario)
    exp.runner = exp.predictor = None  # closures do not cross process boundaries
    return exp


_PREPARED: tuple = ()  # a worker's events "this half of the shared kernels is compiled"
PREPARE_TIMEOUT = 600.0  # [s] a worker waits this long at most for the other's half


def _init_worker(events, parent: int) -> None:
    global _PREPARED
    _PREPARED = tuple(events)
    # The report's own worker processes draw into files only: the file backend, whatever the
    # user's default (the library never chooses one for the user's process).
    import matplotlib

    matplotlib.use("Agg")
    # A report killed outright (kill -9) cannot shut its pool down: each worker leaves by
    # itself once its parent is gone (it is then re-parented), instead of running on.
    threading.Thread(target=_leave_when_orphaned, args=(parent,), daemon=True).start()


def _leave_when_orphaned(parent: int, period: float = 1.0) -> None:
    while os.getppid() == parent:
        time.sleep(period)
    os._exit(1)


def _prepare(half: str, robots: list[Robot], index: int) -> None:
    """Worker-process job: compile one half of the kernels all scenarios share
    (``armlab.warmup``), then say so (also after a failure, which is printed: the
    scenarios then compile what they miss themselves)."""
    from armlab import warmup

    try:
        if half == "dynamics":
            warmup.dynamics_kernels(robots)
        else:
            warmup.loop_and_task_kernels(robots[0])
    except Exception:  # the scenarios compile what is missing; say what went wrong
        traceback.print_exc()
    finally:
        _PREPARED[index].set()


def _evaluate_scenario(name: str, t_final: float | None, quick: bool) -> Experiment:
    """Worker-process job: build the experiment of a registered scenario and evaluate it
    (once both halves of the shared kernels are compiled, so that no two workers compile
    the same kernel)."""
    for event in _PREPARED:
        event.wait(PREPARE_TIMEOUT)
    return evaluate(experiment_from_scenario(name, t_final, quick=quick))


def _schedule(planned: list[Experiment]) -> list[Experiment]:
    """Registry scenarios ordered so that the first run of every controller type comes first,
    joint-space (A6–A8) and task-space (A9–A15) kinds alternating: each first run compiles its
    controller's law, and two workers then compile different laws at the same time."""
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


# What :func:`evaluate` fills in, brought back from a worker process onto the planned
# experiment; ``predicted`` among them: the report prints the theory's rows and names their
# tags' source (armlab.viz.tags) from it.
EVALUATED = ("result", "error", "seconds", "predicted", "metrics", "figures", "robot", "plane", "diagram",
             "diagram_tags")


def take_back(target: Experiment, done: Experiment) -> None:
    """Copy onto ``target`` what a worker's :func:`evaluate` of the same experiment filled in."""
    for key in EVALUATED:
        setattr(target, key, getattr(done, key))


def run_all(planned: list[Experiment], progress: tqdm, workers: int, main_job, on_result=None) -> dict:
    """Evaluate every experiment (registry ones in ``workers`` processes) while ``main_job()``
    runs here; ``on_result()`` is called here after each pooled experiment comes back.
    Returns main_job's value."""
    pooled = [e for e in planned if e.scenario is not None and e.result is None] if workers > 1 else []
    local = [e for e in planned if e not in pooled]
    if not pooled:
        value = main_job()
        for exp in local:
            progress.set_postfix_str(f"running {exp.name}")
            evaluate(exp)
            progress.update()
        return value
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    context = multiprocessing.get_context("spawn")  # no fork of a process that holds threads
    by_name = {e.name: e for e in pooled}
    robots = list({e.robot.name: e.robot for e in pooled if e.robot is not None}.values())
    halves = ("dynamics", "loop") if robots else ()
    events = [context.Event() for _ in halves]
    with ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_init_worker,
                             initargs=(events, os.getpid())) as pool:
        # The two halves of the shared kernels first, one per worker; every scenario waits
        # for both (the cold compile of a report, ~2× faster than each worker compiling all).
        for index, half in enumerate(halves):
            pool.submit(_prepare, half, robots, index)
        futures = {pool.submit(_evaluate_scenario, e.scenario, e.t_final, e.quick): e.name
                   for e in _schedule(pooled)}
        value = main_job()
        for exp in local:
            progress.set_postfix_str(f"running {exp.name}")
            evaluate(exp)
            progress.update()
        progress.set_postfix_str(f"running {len(pooled)} scenarios in {workers} processes "
                                 "(first runs compile)")
        for future in as_completed(futures):
            done = future.result()
            target = by_name[futures[future]]
            take_back(target, done)
            progress.set_postfix_str(f"ran {done.name} ({done.seconds:.1f} s)")
            progress.update()
            if on_result is not None:
                on_result()
    return value
