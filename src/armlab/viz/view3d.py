"""An interactive 3-D view of a robot and its recorded motion (plotly), offline and self-contained.

:func:`view3d` returns a ``plotly.graph_objects.Figure`` (a notebook shows it as it is: turn
it with the mouse, zoom, hover); :func:`write_view3d` writes it as one HTML file that carries
plotly.js inside (``include_plotlyjs=True``), so it opens without a network.

The scene is the one :mod:`armlab.viz.drawing` draws, in Σ_base (``frame="base"``) or Σ_0:
each link as the primitive shape its inertia was computed from (box, cylinder, sphere at the
centre of mass), or a segment between frame origins where it has none; the kinematic chain;
every frame Σ_base, Σ_0 … Σ_e as an x/y/z = red/green/blue triad with its name; the
environment's surface (a wall, or the plane of a spring) as a translucent square.  A
:class:`~armlab.simulation.results.SimulationResult` adds its motion as animation frames with
play/pause buttons and a time slider.

Needs the optional extra ``viewer`` (``pip install 'armlab[viewer]'``: plotly).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armlab.kinematics import link_frames
from armlab.robots import load_robot
from armlab.viz.animation import resample
from armlab.viz.drawing import (
    AXIS_COLOURS,
    FRAMES,
    LINK_COLOURS,
    Plane,
    _transform_points,
    characteristic_length,
    frame_poses,
    link_solids,
    plane_axes,
    plane_covering,
)

MAX_FRAMES = 120
"""Animation frames of a recorded run (resampled evenly in time): enough for a smooth slider,
few enough that the file stays a few megabytes."""


def _plotly():
    try:
        import plotly.graph_objects as go
    except ImportError:
        raise ImportError("the 3-D view needs plotly: pip install 'armlab[viewer]'") from None
    return go


_FIGURE_CLASS = []


def _figure_class(go):
    """``plotly.graph_objects.Figure`` whose notebook display is self-contained: plotly.js
    inline and no MathJax (plotly's own notebook output loads MathJax from a CDN), so the view
    works without a network, in Jupyter and in the HTML nbconvert writes."""
    if not _FIGURE_CLASS:
        class View3D(go.Figure):
            def _repr_mimebundle_(self, include=None, exclude=None, **kwargs):
                html = self.to_html(include_plotlyjs=True, include_mathjax=False, full_html=False,
                                    auto_play=False, default_height=560, config={"displaylogo": False})
                return {"text/html": html}

            def _ipython_display_(self):
                # plotly's own hook would show the figure through its renderers (MathJax from
                # a CDN, or a JSON mimetype that exported HTML cannot show).
                from IPython.display import display

                display(self._repr_mimebundle_(), raw=True)

        _FIGURE_CLASS.append(View3D)
    return _FIGURE_CLASS[0]


def _triangles(faces) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (T, 3) of polygons ``faces`` (each (k, 3), convex): each
    face as a fan from its first vertex."""
    vertices, triangles, start = [], [], 0
    for face in faces:
        k = face.shape[0]
        vertices.append(face)
        triangles += [(start, start + a, start + a + 1) for a in range(1, k - 1)]
        start += k
    return np.vstack(vertices), np.array(triangles, dtype=int)


class _Scene:
    """The traces of one robot, and their coordinates at a configuration q."""

    def __init__(self, robot, frame: str, show_frames: bool):
        if frame not in FRAMES:
            raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
        self.robot, self.frame, self.show_frames = robot, frame, show_frames
        self.solids = link_solids(robot)
        self.meshes = [None if solid is None else _triangles(solid.faces) for solid in self.solids]
        self.axis_length = 0.15 * characteristic_length(robot)
        self.T_view_0 = robot.base if frame == "base" else np.eye(4)

    def moving(self, q) -> list[dict]:
        """Coordinates of every moving trace at q, in trace order: chain, links, x/y/z triads,
        frame labels."""
        frames = link_frames(self.robot, q, frame=self.frame)
        start = (np.linalg.inv(self.robot.base)[:3, 3] if self.frame == "0" else np.zeros(3))
        origins = np.vstack(([start], frames[:, :3, 3]))
        out = [dict(x=origins[:, 0], y=origins[:, 1], z=origins[:, 2])]
        for i, mesh in enumerate(self.meshes):
            if mesh is None:
                segment = origins[i + 1:i + 3]
                out.append(dict(x=segment[:, 0], y=segment[:, 1], z=segment[:, 2]))
            else:
                points = _transform_points(frames[i + 1], mesh[0])
                out.append(dict(x=points[:, 0], y=points[:, 1], z=points[:, 2]))
        if self.show_frames:
            poses = frame_poses(self.robot, q, self.frame)
            for k in range(3):
                segments = []
                for pose in poses.values():
                    origin = pose[:3, 3]
                    segments += [origin, origin + self.axis_length * pose[:3, k], [np.nan] * 3]
                segments = np.array(segments)
                out.append(dict(x=segments[:, 0], y=segments[:, 1], z=segments[:, 2]))
            origins = np.array([pose[:3, 3] for pose in poses.values()])
            out.append(dict(x=origins[:, 0], y=origins[:, 1], z=origins[:, 2]))
        return out

    def traces(self, q, go) -> list:
        coordinates = self.moving(q)
        traces = [go.Scatter3d(**coordinates[0], mode="lines", name="chain", hoverinfo="skip",
                               line=dict(color="#595959", width=3, dash="dash"))]
        for i, (mesh, link) in enumerate(zip(self.meshes, self.robot.links, strict=True)):
            colour = LINK_COLOURS[i % len(LINK_COLOURS)]
            if mesh is None:
                traces.append(go.Scatter3d(**coordinates[1 + i], mode="lines", name=link.name,
                                           line=dict(color=colour, width=10)))
            else:
                triangles = mesh[1]
                traces.append(go.Mesh3d(**coordinates[1 + i], i=triangles[:, 0], j=triangles[:, 1],
                                        k=triangles[:, 2], color=colour, opacity=0.75, name=link.name,
                                        flatshading=True, hovertext=link.name, hoverinfo="text",
                                        showlegend=True))
        if self.show_frames:
            names = list(frame_poses(self.robot, q, self.frame))
            for k, (axis, colour) in enumerate(zip("xyz", AXIS_COLOURS, strict=True)):
                traces.append(go.Scatter3d(**coordinates[1 + len(self.meshes) + k], mode="lines",
                                           name=f"{axis} axes", hoverinfo="skip",
                                           line=dict(color=colour, width=5)))
            labels = ["Σ_" + " = Σ_".join(name.split("=")) for name in names]
            traces.append(go.Scatter3d(**coordinates[-1], mode="text", text=labels, name="frames",
                                       textposition="bottom center", hoverinfo="text"))
        return traces

    def extent(self, qs) -> tuple[np.ndarray, np.ndarray]:
        points = []
        for q in qs:
            for trace in self.moving(q):
                points.append(np.column_stack([trace["x"], trace["y"], trace["z"]]))
        points = np.vstack(points)
        points = points[np.all(np.isfinite(points), axis=1)]
        return points.min(axis=0), points.max(axis=0)


def _plane_trace(plane: Plane, T_view_0, go):
    u, v = plane_axes(plane)
    s = plane.half_size
    signs = ((-1, -1), (1, -1), (1, 1), (-1, 1))
    corners = np.array([np.asarray(plane.point) + s * (a * u + b * v) for a, b in signs])
    corners = _transform_points(T_view_0, corners)
    return go.Mesh3d(x=corners[:, 0], y=corners[:, 1], z=corners[:, 2], i=[0, 0], j=[1, 2], k=[2, 3],
                     color="#8c8c8c", opacity=0.3, name="environment", hoverinfo="name")


def view3d(subject, q=None, *, robot=None, frame: str = "base", plane: Plane | None = None,
           show_frames: bool = True, max_frames: int = MAX_FRAMES, title: str | None = None):
    """An interactive 3-D figure of a robot at ``q`` (``subject`` a Robot) or of a recorded
    run with play/pause and a time slider (``subject`` a SimulationResult; its robot is
    ``robot`` or, by default, the bundled robot its ``meta["plant"]`` names).

    ``plane`` (given in Σ_0) is drawn as the environment's surface; for a result it defaults
    to the surface of the run's environment, as the report draws it.  Returns a
    ``plotly.graph_objects.Figure`` (displayed in a notebook with plotly.js inline: offline).
    """
    go = _plotly()
    result = None
    if hasattr(subject, "joints"):
        robot = subject
        qs, times = np.atleast_2d(np.zeros(robot.n) if q is None else np.asarray(q, dtype=float)), None
    else:
        result = subject
        if robot is None:
            robot = load_robot(str(result.meta.get("plant", "")))
        if result.q.shape[1] != robot.n:
            raise ValueError(f"robot: {robot.name} has {robot.n} joints, the result {result.q.shape[1]}")
        times, qs = resample(result.t, result.q, min(max_frames, len(result)))
        if plane is None:
            plane = _result_plane(result)
    scene = _Scene(robot, frame, show_frames)
    traces = scene.traces(qs[0], go)
    moving = list(range(len(traces)))
    if plane is not None:
        tips = np.array([link_frames(robot, qk, frame="0")[-1][:3, 3] for qk in qs])
        traces.append(_plane_trace(plane_covering(plane, tips), scene.T_view_0, go))
    low, high = scene.extent(qs)
    if plane is not None:
        corners = traces[-1]
        points = np.column_stack([corners.x, corners.y, corners.z])
        low, high = np.minimum(low, points.min(axis=0)), np.maximum(high, points.max(axis=0))
    centre, half = (low + high) / 2.0, max(float(np.max(high - low)) / 2.0, 1e-3) * 1.1
    axis = {"base": "base", "0": "0"}[frame]
    scene_layout = dict(aspectmode="cube", **{
        f"{name}axis": dict(range=[centre[k] - half, centre[k] + half], title=f"{name}_{axis} [m]")
        for k, name in enumerate("xyz")})
    figure = _figure_class(go)(data=traces)
    joint_text = ", ".join(j.name for j in robot.joints)
    heading = title or f"{robot.name} in Σ_{axis}" + (" — recorded motion" if result else "")
    figure.update_layout(title=heading, scene=scene_layout, margin=dict(l=0, r=0, t=40, b=0), showlegend=True,
                         legend=dict(itemsizing="constant"),
                         scene_camera=dict(eye=dict(x=1.5, y=-1.3, z=0.9)))
    if result is None:
        return figure
    frames = []
    for k, (time, qk) in enumerate(zip(times, qs, strict=True)):
        # The moving traces only (the plane, last, stays): ``traces`` names their indices.
        data = [dict(type=figure.data[index].type, **coordinates)
                for index, coordinates in zip(moving, scene.moving(qk), strict=True)]
        values = ", ".join(f"{v:.3g}" for v in qk)
        caption = f"{robot.name}: t = {time:.2f} s  ({joint_text}) = ({values})"
        frames.append(go.Frame(data=data, traces=moving, name=str(k), layout=dict(title=caption)))
    figure.frames = frames
    step = 1000.0 * float(times[-1] - times[0]) / max(len(times) - 1, 1)   # real time [ms]
    play = dict(frame=dict(duration=step, redraw=True), fromcurrent=True, transition=dict(duration=0),
                mode="immediate")
    pause = dict(frame=dict(duration=0, redraw=False), mode="immediate", transition=dict(duration=0))
    figure.update_layout(
        updatemenus=[dict(type="buttons", direction="left", x=0.0, y=0.0, xanchor="left", yanchor="top",
                          pad=dict(t=30, r=10), showactive=False,
                          buttons=[dict(label="▶ play", method="animate", args=[None, play]),
                                   dict(label="❚❚ pause", method="animate", args=[[None], pause])])],
        sliders=[dict(active=0, x=0.18, y=0.0, len=0.8, xanchor="left", yanchor="top", pad=dict(t=20),
                      currentvalue=dict(prefix="t = ", suffix=" s"),
                      steps=[dict(label=f"{time:.2f}", method="animate",
                                  args=[[str(k)], dict(frame=dict(duration=0, redraw=True), mode="immediate",
                                                       transition=dict(duration=0))])
                             for k, time in enumerate(times)])])
    return figure


def _result_plane(result) -> Plane | None:
    """The environment surface of a run, from its description in ``meta`` (a wall, or a
    spring's plane as the report draws it)."""
    from types import SimpleNamespace

    from armlab.viz.experiments import environment_plane

    described = result.meta.get("environment") if isinstance(result.meta, dict) else None
    if not isinstance(described, dict):
        return None
    environment = SimpleNamespace(**{key: np.asarray(value, dtype=float) if isinstance(value, list) else value
                                     for key, value in described.items()})
    try:
        return environment_plane(environment)
    except (TypeError, ValueError):
        return None


def write_view3d(subject, path, **options) -> Path:
    """Write :func:`view3d` of ``subject`` (or a Figure it made) to ``path`` as one HTML file
    with plotly.js inside: it opens offline, no network request."""
    go = _plotly()
    figure = subject if isinstance(subject, go.Figure) else view3d(subject, **options)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.write_html(path, include_plotlyjs=True, full_html=True, auto_play=False,
                      config={"displaylogo": False})
    return path
