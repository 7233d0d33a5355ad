"""Animation of a joint trajectory: GIF through Pillow, MP4 through ffmpeg when it is installed.

The scene (links with their shapes, frame triads, an optional environment plane) is built
once by :class:`armlab.viz.drawing.RobotArtist` and moved frame by frame; a GIF frame redraws
only the scene over the axes drawn once, so a 100-frame GIF renders in a few seconds.  The
trajectory is resampled at the animation's frame times by linear interpolation of each joint.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib import animation
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from PIL import Image

from armlab.errors import AnimationError
from armlab.files import replacing
from armlab.kinematics import link_frames
from armlab.model.robot import Robot
from armlab.viz.drawing import (
    Plane,
    RobotArtist,
    frame_label,
    plane_covering,
    set_equal_limits,
    style_axes,
)

MOTION_SHARE = 0.999  # the arm's motion is over once this share of its joint travel is done


def resample(t: np.ndarray, q: np.ndarray, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Times (frames,) [s] evenly spread over ``t`` and the joint values (frames, n) there."""
    times = np.linspace(t[0], t[-1], frames)
    return times, np.column_stack([np.interp(times, t, q[:, j]) for j in range(q.shape[1])])


def joint_spans(robot: Robot) -> np.ndarray:
    """The range of each joint (n,) [m | rad], 1 where it is unlimited: the scale of its travel."""
    return np.array([(high - low) if np.isfinite(high - low) else 1.0 for low, high in
                     (joint.limits for joint in robot.joints)])


def motion_window(t, q, spans=None, *, margin: float = 0.25, least: float = 0.5) -> float:
    """The time [s] up to which a run is worth animating: when :data:`MOTION_SHARE` of the
    joints' travel (Σ_i |Δq_i| / span_i, ``spans`` (n,) default 1) is done, plus ``margin`` of
    the time to get there and at least ``least`` [s] to show the arm at rest; ``t[-1]`` for a
    run that moves to its end (or not at all)."""
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    spans = np.ones(q.shape[1]) if spans is None else np.asarray(spans, dtype=float)
    steps = np.sum(np.abs(np.diff(q, axis=0)) / spans, axis=1)
    travel = np.concatenate([[0.0], np.cumsum(np.where(np.isfinite(steps), steps, 0.0))])
    if travel[-1] <= 0.0:
        return float(t[-1])
    done = float(t[min(int(np.searchsorted(travel, MOTION_SHARE * travel[-1])), t.size - 1)])
    return float(min(t[-1], done + max(margin * (done - t[0]), least)))


def animate_robot(robot: Robot, t, q, path, *, frame: str = "base", plane: Plane | None = None,
                  fps: int = 15, max_frames: int = 90, dpi: int = 72, show_frames: bool = True,
                  title: str | None = None, view=(22.0, -58.0)) -> Path:
    """Write an animation of ``robot`` following ``q`` (N, n) [m | rad] at times ``t`` (N,) [s].

    Parameters
    ----------
    path : str or Path
        ``*.gif`` (Pillow, always available) or ``*.mp4`` (needs ffmpeg on the PATH).
    frame : {"base", "0"}
        The frame the scene is drawn in.
    plane : Plane, optional
        The environment surface (in Σ_0) to draw, e.g. the wall of an interaction scenario;
        drawn large enough to hold the end effector's path on it.
    fps, max_frames : int
        Playback rate and the number of frames the run is resampled to; the animation plays
        the whole run in max_frames / fps seconds (not in real time for long runs).

    Returns
    -------
    Path of the written file.
    """
    path = Path(path)
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    if t.ndim != 1 or q.ndim != 2 or q.shape != (t.size, robot.n):
        raise AnimationError(f"q must have shape (len(t), {robot.n}) = ({t.size}, {robot.n}), got {q.shape}")
    if t.size < 2:
        raise AnimationError("a trajectory needs at least two samples to animate")
    if not np.all(np.isfinite(q)):
        finite = np.all(np.isfinite(q), axis=1)
        last = int(np.argmin(finite)) if not finite.all() else t.size
        t, q = t[:last], q[:last]
        if t.size < 2:
            raise AnimationError("q is not finite from the start; nothing to animate")
    suffix = path.suffix.lower()
    if suffix == ".gif":
        writer = None  # frames drawn here (see _frames) and written by Pillow
    elif suffix == ".mp4":
        if not animation.writers.is_available("ffmpeg"):
            raise AnimationError(f"{path}: MP4 needs ffmpeg, which is not installed; write a .gif instead")
        writer = animation.FFMpegWriter(fps=fps, bitrate=1200)
    else:
        raise AnimationError(f"{path}: unknown animation format {suffix!r} (use .gif or .mp4)")

    times, qs = resample(t, q, min(max_frames, t.size))
    if plane is not None:
        # The surface as large as the end effector's path on it: it may slide along a wall.
        tip = np.array([link_frames(robot, q_frame, frame="0")[-1][:3, 3] for q_frame in qs])
        plane = plane_covering(plane, tip)
    # A figure of its own on the Agg canvas, outside pyplot: frames are grabbed from Agg's
    # pixel buffer whatever backend the user chose, and no window ever opens.
    fig = Figure(figsize=(4.8, 4.6), dpi=dpi)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=0.0, right=0.96, bottom=0.02, top=0.9)
    ax = fig.add_subplot(projection="3d")
    ax.view_init(elev=view[0], azim=view[1])  # first: the frame labels are placed for the view
    artist = RobotArtist(ax, robot, frame=frame, show_frames=show_frames, plane=plane)
    set_equal_limits(ax, *artist.extent(qs))
    style_axes(ax, frame)
    ax.set_title(title or f"{robot.name} in {frame_label(frame)}", fontsize=10)
    clock = fig.text(0.03, 0.03, "", fontsize=9, family="monospace")

    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as temporary:  # atomic: complete or not at all
        if suffix == ".gif":
            frames = list(_frames(fig, ax, artist, clock, times, qs))
            frames[0].save(temporary, format="GIF", save_all=True, append_images=frames[1:],
                           duration=int(1000 / fps), loop=0)
        else:
            # Frames are grabbed by hand: FuncAnimation would render every frame twice.
            with writer.saving(fig, str(temporary), dpi):
                for time, q_frame in zip(times, qs, strict=True):
                    artist.update(q_frame)
                    clock.set_text(_clock(time))
                    writer.grab_frame()
    return path


def _clock(time: float) -> str:
    return f"t = {time:6.2f} s"


def _frames(fig, ax, artist: RobotArtist, clock, times, qs):
    """The frames (Pillow images) of ``artist`` following ``qs``.

    What stays put (panes, grid, ticks, axis labels, title) is drawn once; every frame
    restores that picture and draws over it only the scene (in the depth order matplotlib
    gives it) and the clock: the picture of a whole draw for a third of its cost.
    """
    scene = artist.artists()
    for item in [*scene, clock]:
        item.set_visible(False)
    fig.canvas.draw()
    still = fig.canvas.copy_from_bbox(fig.bbox)
    # Drawing the axes now paints only the scene: no background patch, title or axes (an empty
    # title rather than a hidden one, which matplotlib would place again at every draw).
    ax.patch.set_visible(False)
    ax.title.set_text("")
    ax.set_axis_off()
    for item in [*scene, clock]:
        item.set_visible(True)
    renderer = fig.canvas.get_renderer()
    for time, q_frame in zip(times, qs, strict=True):
        artist.update(q_frame)
        clock.set_text(_clock(time))
        fig.canvas.restore_region(still)
        ax.draw(renderer)
        clock.draw(renderer)
        frame = Image.fromarray(np.array(fig.canvas.buffer_rgba()))
        # An opaque frame in RGB, as matplotlib's PillowWriter keeps it: Pillow's GIF palette
        # comes out better than from RGBA.
        yield frame if frame.getextrema()[3][0] < 255 else frame.convert("RGB")
