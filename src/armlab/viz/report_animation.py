"""The report's runs in motion: the interactive 3-D view page of every run (plotly, pages of
their own that the report frames: :mod:`armlab.viz.view_pages`) and the GIF of one run, the
one whose joints travel furthest within their limits (:func:`animation_subject`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armlab.viz import html
from armlab.viz.animation import animate_robot, joint_spans, motion_window
from armlab.viz.experiments import Experiment
from armlab.viz.view_pages import write_assets, write_view_page

VIEW_FRAMES = 60  # animation frames of a run's 3-D view (as the GIF): ~0.3 MB a PRP page


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
