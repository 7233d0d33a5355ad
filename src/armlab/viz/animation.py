"""Animation of a joint trajectory: GIF through Pillow, MP4 through ffmpeg when it is installed.

The scene (links with their shapes, frame triads, an optional environment plane) is built
once by :class:`armlab.viz.drawing.RobotArtist` and moved frame by frame, so a 100-frame GIF
renders in a few seconds.  The trajectory is resampled at the animation's frame times by
linear interpolation of each joint.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import animation  # noqa: E402

from armlab.errors import ArmlabError  # noqa: E402
from armlab.model.robot import Robot  # noqa: E402
from armlab.viz.drawing import Plane, RobotArtist, frame_label, set_equal_limits, style_axes  # noqa: E402


class AnimationError(ArmlabError, ValueError):
    """An animation that cannot be written (bad trajectory, missing encoder)."""


def resample(t: np.ndarray, q: np.ndarray, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Times (frames,) [s] evenly spread over ``t`` and the joint values (frames, n) there."""
    times = np.linspace(t[0], t[-1], frames)
    return times, np.column_stack([np.interp(times, t, q[:, j]) for j in range(q.shape[1])])


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
        The environment surface (in Σ_0) to draw, e.g. the wall of an interaction scenario.
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
        writer = animation.PillowWriter(fps=fps)
    elif suffix == ".mp4":
        if not animation.writers.is_available("ffmpeg"):
            raise AnimationError(f"{path}: MP4 needs ffmpeg, which is not installed; write a .gif instead")
        writer = animation.FFMpegWriter(fps=fps, bitrate=1200)
    else:
        raise AnimationError(f"{path}: unknown animation format {suffix!r} (use .gif or .mp4)")

    times, qs = resample(t, q, min(max_frames, t.size))
    fig = plt.figure(figsize=(4.8, 4.6), dpi=dpi)
    fig.subplots_adjust(left=0.0, right=0.96, bottom=0.02, top=0.9)
    ax = fig.add_subplot(projection="3d")
    artist = RobotArtist(ax, robot, frame=frame, show_frames=show_frames, plane=plane)
    set_equal_limits(ax, *artist.extent(qs))
    style_axes(ax, frame)
    ax.view_init(elev=view[0], azim=view[1])
    ax.set_title(title or f"{robot.name} in {frame_label(frame)}", fontsize=10)
    clock = fig.text(0.03, 0.03, "", fontsize=9, family="monospace")

    path.parent.mkdir(parents=True, exist_ok=True)
    # Frames are grabbed by hand: FuncAnimation would render every frame twice.
    try:
        with writer.saving(fig, str(path), dpi):
            for time, q_frame in zip(times, qs, strict=True):
                artist.update(q_frame)
                clock.set_text(f"t = {time:6.2f} s")
                writer.grab_frame()
    finally:
        plt.close(fig)
    return path
