"""An interactive 3-D view of a robot and its recorded motion (plotly), offline and self-contained.

:func:`view3d` returns a ``plotly.graph_objects.Figure`` (a notebook shows it as it is: turn
it with the mouse, zoom, hover); :func:`write_view3d` writes it as one HTML file that carries
plotly.js inside (``include_plotlyjs=True``), so it opens without a network.

The scene is the one :mod:`armlab.viz.drawing` draws, in Σ_base (``frame="base"``) or Σ_0:
each link as the visual shapes of its robot file where it has some (URDF ``<visual>`` meshes,
boxes, cylinders and spheres; the geoms of an MJCF file that MuJoCo shows; thinned to a vertex
budget by :mod:`armlab.viz.meshes`; parts fixed to the ground drawn still), else
as the primitive shape its inertia was computed from (box, cylinder, sphere at the centre of
mass), else as a segment between frame origins; the kinematic chain; every frame Σ_base,
Σ_0 … Σ_e as an x/y/z = red/green/blue triad with its name; the environment's surface (a
wall, or the plane of a spring) as a translucent square.  A
:class:`~armlab.simulation.results.SimulationResult` adds its motion as animation frames with
play/pause buttons and a time slider.

:func:`view3d_spec` builds the same figure as plain data (plotly's figure schema, coordinates
as NumPy arrays) without importing plotly: the report serialises it for pages that load
plotly.js from a file of their own (:mod:`armlab.viz.view_pages`).

Needs the optional extra ``viewer`` (``pip install 'armlab[viewer]'``: plotly).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armlab.kinematics import link_frames
from armlab.model.shapes import triangulate
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
from armlab.viz.meshes import MAX_VERTICES, body_meshes

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


class _Scene:
    """The traces of one robot, and their coordinates at a configuration q."""

    def __init__(self, robot, frame: str, show_frames: bool, max_vertices: int | None):
        if frame not in FRAMES:
            raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
        self.robot, self.frame, self.show_frames = robot, frame, show_frames
        files = body_meshes(robot, max_vertices) if robot.visuals else {}
        solids = link_solids(robot)
        # Link i: its file's meshes (in Σ_{i+1}), else its inertia shape, else None (a segment).
        self.meshes = [files[i + 1] if i + 1 in files else None if solid is None else triangulate(solid.faces)
                       for i, solid in enumerate(solids)]
        self.from_file = [i + 1 in files for i in range(robot.n)]
        self.axis_length = 0.15 * characteristic_length(robot)
        self.T_view_0 = robot.base if frame == "base" else np.eye(4)
        self.ground = None if 0 not in files else (_transform_points(self.T_view_0, files[0][0]), files[0][1])

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

    def traces(self, q) -> list[dict]:
        """The moving traces at q (plotly trace dicts), in the order of :meth:`moving`."""
        coordinates = self.moving(q)
        traces = [dict(type="scatter3d", **coordinates[0], mode="lines", name="chain", hoverinfo="skip",
                       line=dict(color="#595959", width=3, dash="dash"))]
        for i, (mesh, link) in enumerate(zip(self.meshes, self.robot.links, strict=True)):
            colour = LINK_COLOURS[i % len(LINK_COLOURS)]
            if mesh is None:
                traces.append(dict(type="scatter3d", **coordinates[1 + i], mode="lines", name=link.name,
                                   line=dict(color=colour, width=10)))
            else:
                traces.append(_mesh_trace(coordinates[1 + i], mesh[1], colour, link.name,
                                          from_file=self.from_file[i]))
        if self.show_frames:
            names = list(frame_poses(self.robot, q, self.frame))
            for k, (axis, colour) in enumerate(zip("xyz", AXIS_COLOURS, strict=True)):
                traces.append(dict(type="scatter3d", **coordinates[1 + len(self.meshes) + k], mode="lines",
                                   name=f"{axis} axes", hoverinfo="skip", line=dict(color=colour, width=5)))
            labels = ["Σ_" + " = Σ_".join(name.split("=")) for name in names]
            traces.append(dict(type="scatter3d", **coordinates[-1], mode="text", text=labels, name="frames",
                               textposition="bottom center", hoverinfo="text"))
        return traces

    def still(self) -> list[dict]:
        """The traces that never move: the file's meshes of parts fixed to the ground."""
        if self.ground is None:
            return []
        points, triangles = self.ground
        return [_mesh_trace(dict(x=points[:, 0], y=points[:, 1], z=points[:, 2]), triangles, "#b4b4b4",
                            "ground parts", from_file=True)]

    def extent(self, qs) -> tuple[np.ndarray, np.ndarray]:
        points = [] if self.ground is None else [self.ground[0]]
        for q in qs:
            for trace in self.moving(q):
                points.append(np.column_stack([trace["x"], trace["y"], trace["z"]]))
        points = np.vstack(points)
        points = points[np.all(np.isfinite(points), axis=1)]
        return points.min(axis=0), points.max(axis=0)


def _mesh_trace(coordinates: dict, triangles: np.ndarray, colour: str, name: str, *, from_file: bool) -> dict:
    """A Mesh3d trace: a file's mesh opaque and smoothly lit (its facets are many and small),
    an inertia shape translucent with flat facets (the frames inside it stay visible)."""
    return dict(type="mesh3d", **coordinates, i=triangles[:, 0], j=triangles[:, 1], k=triangles[:, 2],
                color=colour, opacity=1.0 if from_file else 0.75, flatshading=not from_file, name=name,
                hovertext=name, hoverinfo="text", showlegend=True)


def _plane_trace(plane: Plane, T_view_0) -> dict:
    u, v = plane_axes(plane)
    s = plane.half_size
    signs = ((-1, -1), (1, -1), (1, 1), (-1, 1))
    corners = np.array([np.asarray(plane.point) + s * (a * u + b * v) for a, b in signs])
    corners = _transform_points(T_view_0, corners)
    return dict(type="mesh3d", x=corners[:, 0], y=corners[:, 1], z=corners[:, 2], i=[0, 0], j=[1, 2],
                k=[2, 3], color="#8c8c8c", opacity=0.3, name="environment", hoverinfo="name")


def view3d(subject, q=None, *, robot=None, frame: str = "base", plane: Plane | None = None,
           show_frames: bool = True, max_frames: int = MAX_FRAMES, max_vertices: int | None = MAX_VERTICES,
           title: str | None = None):
    """An interactive 3-D figure of a robot at ``q`` (``subject`` a Robot) or of a recorded
    run with play/pause and a time slider (``subject`` a SimulationResult; its robot is
    ``robot`` or, by default, the bundled robot its ``meta["plant"]`` names).

    ``plane`` (given in Σ_0) is drawn as the environment's surface; for a result it defaults
    to the surface of the run's environment, as the report draws it.  The meshes of the
    robot's file keep at most ``max_vertices`` vertices together (None: every vertex).
    Returns a ``plotly.graph_objects.Figure`` (displayed in a notebook with plotly.js inline:
    offline).
    """
    go = _plotly()
    spec = view3d_spec(subject, q, robot=robot, frame=frame, plane=plane, show_frames=show_frames,
                       max_frames=max_frames, max_vertices=max_vertices, title=title)
    return _figure_class(go)(data=spec["data"], layout=spec["layout"], frames=spec["frames"])


def view3d_spec(subject, q=None, *, robot=None, frame: str = "base", plane: Plane | None = None,
                show_frames: bool = True, max_frames: int = MAX_FRAMES,
                max_vertices: int | None = MAX_VERTICES, title: str | None = None) -> dict:
    """The figure of :func:`view3d` as plain data: ``{"data": [...], "layout": {...},
    "frames": [...]}`` in plotly's figure schema, coordinates as NumPy arrays; no plotly needed.

    A run's samples where t or q is not finite (the tail of a run that diverged) are left out;
    a ``ValueError`` says so when none is left.
    """
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
        finite = np.all(np.isfinite(result.q), axis=1) & np.isfinite(result.t)
        if not finite.any():
            raise ValueError("result: no sample with finite time and joint values to draw")
        times, qs = resample(result.t[finite], result.q[finite], min(max_frames, int(finite.sum())))
        if plane is None:
            plane = _result_plane(result)
    scene = _Scene(robot, frame, show_frames, max_vertices)
    traces = scene.traces(qs[0])
    moving = list(range(len(traces)))
    traces += scene.still()
    low, high = scene.extent(qs)
    if plane is not None:
        tips = np.array([link_frames(robot, qk, frame="0")[-1][:3, 3] for qk in qs])
        corners = _plane_trace(plane_covering(plane, tips), scene.T_view_0)
        traces.append(corners)
        points = np.column_stack([corners["x"], corners["y"], corners["z"]])
        low, high = np.minimum(low, points.min(axis=0)), np.maximum(high, points.max(axis=0))
    centre, half = (low + high) / 2.0, max(float(np.max(high - low)) / 2.0, 1e-3) * 1.1
    axis = {"base": "base", "0": "0"}[frame]
    scene_layout = dict(aspectmode="cube", camera=dict(eye=dict(x=1.5, y=-1.3, z=0.9)), **{
        f"{name}axis": dict(range=[centre[k] - half, centre[k] + half], title=dict(text=f"{name}_{axis} [m]"))
        for k, name in enumerate("xyz")})
    joint_text = ", ".join(j.name for j in robot.joints)
    heading = title or f"{robot.name} in Σ_{axis}" + (" — recorded motion" if result else "")
    # A run's buttons and time slider sit under the scene, in its bottom margin.
    layout = dict(title=dict(text=heading), scene=scene_layout,
                  margin=dict(l=0, r=0, t=40, b=110 if result else 0),
                  showlegend=True, legend=dict(itemsizing="constant"))
    spec = {"data": traces, "layout": layout, "frames": []}
    if result is None:
        return spec
    for k, (time, qk) in enumerate(zip(times, qs, strict=True)):
        # The moving traces only (ground parts and plane stay): ``moving`` names their indices.
        data = [dict(type=traces[index]["type"], **coordinates)
                for index, coordinates in zip(moving, scene.moving(qk), strict=True)]
        values = ", ".join(f"{v:.3g}" for v in qk)
        caption = f"{robot.name}: t = {time:.2f} s  ({joint_text}) = ({values})"
        spec["frames"].append(dict(data=data, traces=moving, name=str(k),
                                   layout=dict(title=dict(text=caption))))
    step = 1000.0 * float(times[-1] - times[0]) / max(len(times) - 1, 1)   # real time [ms]
    play = dict(frame=dict(duration=step, redraw=True), fromcurrent=True, transition=dict(duration=0),
                mode="immediate")
    pause = dict(frame=dict(duration=0, redraw=False), mode="immediate", transition=dict(duration=0))
    layout.update(
        updatemenus=[dict(type="buttons", direction="left", x=0.0, y=0.0, xanchor="left", yanchor="top",
                          pad=dict(t=30, r=10), showactive=False,
                          buttons=[dict(label="▶ play", method="animate", args=[None, play]),
                                   dict(label="❚❚ pause", method="animate", args=[[None], pause])])],
        sliders=[dict(active=0, x=0.24, y=0.0, len=0.74, xanchor="left", yanchor="top", pad=dict(t=20),
                      currentvalue=dict(prefix="t = ", suffix=" s"),
                      steps=[dict(label=f"{time:.2f}", method="animate",
                                  args=[[str(k)], dict(frame=dict(duration=0, redraw=True), mode="immediate",
                                                       transition=dict(duration=0))])
                             for k, time in enumerate(times)])])
    return spec


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
    with plotly.js inside: it opens offline, no network request.  Written atomically
    (:mod:`armlab.files`): a failed write keeps the previous file."""
    from armlab.files import write_text

    go = _plotly()
    figure = subject if isinstance(subject, go.Figure) else view3d(subject, **options)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, figure.to_html(include_plotlyjs=True, full_html=True, auto_play=False,
                                    config={"displaylogo": False}))
    return path
