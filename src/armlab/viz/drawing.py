"""Drawing a robot in 3-D: links with their shapes and every frame as an RGB triad.

This is the seed's ``plotTransforms`` check (A1): the frames Σ_base, Σ_0, Σ_1 … Σ_n, Σ_e are
drawn at the poses computed by :func:`armlab.link_frames`, with x, y, z axes in red, green and
blue, either in Σ_base (``frame="base"``) or in Σ_0 (``frame="0"``).  Links are drawn with the
primitive shape their inertia was computed from (``robot.links[i].inertial.shape``: box,
cylinder or sphere centred at the centre of mass, turned by the shape's ``rpy``); a link without
a shape is drawn as a segment between consecutive frame origins.

:class:`RobotArtist` creates the matplotlib artists once and moves them with
:meth:`RobotArtist.update`, so an animation does not rebuild the scene every frame.  Every
triad line carries the matplotlib ``gid`` ``"frame:<name>:<axis>"`` and every link solid
``"link:<name>"``, so a test can read back what was drawn.
"""

from __future__ import annotations

from dataclasses import dataclass

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from armlab.kinematics import link_frames
from armlab.model.robot import Robot
from armlab.model.shapes import box_faces, cylinder_faces, sphere_faces
from armlab.model.toml_io import evaluate_expression
from armlab.spatial import inverse_transform, rpy_matrix

AXIS_COLOURS = ("#d62728", "#2ca02c", "#1f5fd6")  # x red, y green, z blue
LINK_COLOURS = ("#f0a030", "#8fb8de", "#9ad28a", "#d9a3d6", "#e8d36a", "#a0d8d0", "#f4a6a6")
FRAMES = ("base", "0")
LABEL_ZORDER = 1000  # frame labels over every link solid
# Frame labels: candidate offsets from the origin on the screen (right, up), in triad
# lengths: below it first, then above, then to the sides, further out; the estimated width of
# one "Σ_i" and the height of a label, in triad lengths.
LABEL_OFFSETS = ((0.0, -0.5), (0.0, 0.55), (0.9, -0.5), (-0.9, -0.5), (0.9, 0.55), (-0.9, 0.55),
                 (0.0, -1.1), (0.0, 1.15), (1.4, 0.0), (-1.4, 0.0))
LABEL_WIDTH, LABEL_HEIGHT = 0.8, 0.6


@dataclass(frozen=True)
class Plane:
    """A planar environment surface for drawing: a point on it and its normal, both in Σ_0 [m].

    ``half_size`` [m] is half the side of the square drawn around ``point``.
    """

    point: tuple[float, float, float]
    normal: tuple[float, float, float]
    half_size: float = 0.25


@dataclass(frozen=True)
class Solid:
    """A link's shape as polygons in the link frame Σ_i: ``faces`` is a list of (k, 3) arrays [m]."""

    link: str
    faces: tuple[np.ndarray, ...]


def plane_axes(plane: Plane) -> tuple[np.ndarray, np.ndarray]:
    """Two orthonormal directions (3,) spanning ``plane``: the sides of its drawn square."""
    normal = np.asarray(plane.normal, dtype=float)
    normal = normal / np.linalg.norm(normal)
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def plane_covering(plane: Plane, points, margin: float = 0.1) -> Plane:
    """``plane``, or where it does not hold ``points`` (k, 3) [m, in Σ_0] projected onto it
    with ``margin`` [m] around them (an end-effector path that slides along a wall), the same
    surface drawn as the square around them."""
    points = np.atleast_2d(np.asarray(points, dtype=float))
    u, v = plane_axes(plane)
    point = np.asarray(plane.point, dtype=float)
    a, b = (points - point) @ u, (points - point) @ v
    if max(np.abs(a).max(), np.abs(b).max()) + margin <= plane.half_size:
        return plane
    centre_a, centre_b = (a.max() + a.min()) / 2.0, (b.max() + b.min()) / 2.0
    half = max(np.ptp(a), np.ptp(b)) / 2.0 + margin
    return Plane(tuple(point + centre_a * u + centre_b * v), tuple(plane.normal), float(half))


def frame_names(robot: Robot) -> list[str]:
    """Names of the frames returned by ``link_frames`` plus Σ_base: base, 0, 1 … n, e."""
    return ["base", "0", *[str(i) for i in range(1, robot.n + 1)], "e"]


def frame_label(name: str) -> str:
    """Mathtext label of a frame name ("base" → Σ_base, "3=e" → Σ_3 = Σ_e)."""
    parts = [rf"\Sigma_{{\mathrm{{{p}}}}}" if p.isalpha() else rf"\Sigma_{{{p}}}" for p in name.split("=")]
    return "$" + " = ".join(parts) + "$"


def frame_poses(robot: Robot, q, frame: str = "base") -> dict[str, np.ndarray]:
    """Every frame to draw as ``{name: (4, 4) pose in Σ_base or Σ_0}``.

    Names are "base", "0", "1" … "n", "e"; when the tool is the identity Σ_n and Σ_e are one
    frame named "n=e".  Poses come from :func:`armlab.link_frames`.
    """
    if frame not in FRAMES:
        raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
    frames = link_frames(robot, q, frame=frame)
    base = np.eye(4) if frame == "base" else inverse_transform(robot.base)
    poses = {"base": base}
    for name, pose in zip(frame_names(robot)[1:], frames, strict=True):
        poses[name] = pose
    if np.allclose(robot.tool, np.eye(4)):
        last = str(robot.n)
        poses[f"{last}=e"] = poses.pop(last)
        del poses["e"]
    return poses


def _value(value, robot: Robot) -> float:
    return evaluate_expression(value, robot.parameters) if isinstance(value, str) else float(value)


def link_solids(robot: Robot) -> list[Solid | None]:
    """The drawable shape of each link in its frame Σ_i, or None where the link has no shape.

    The shape's own frame has its origin at the link's centre of mass ``inertial.com`` and is
    turned by the shape's ``rpy`` (the same placement the inertia tensor was computed with).
    """
    solids: list[Solid | None] = []
    for link in robot.links:
        shape = link.inertial.shape
        if not shape or shape.get("type") not in ("box", "cylinder", "sphere"):
            solids.append(None)
            continue
        kind = shape["type"]
        if kind == "box":
            local = box_faces([_value(v, robot) for v in shape["size"]])
        elif kind == "cylinder":
            local = cylinder_faces(_value(shape["radius"], robot), _value(shape["length"], robot))
        else:
            local = sphere_faces(_value(shape["radius"], robot))
        R = rpy_matrix([_value(v, robot) for v in shape.get("rpy", [0, 0, 0])])
        com = np.asarray(link.inertial.com, dtype=float)
        solids.append(Solid(link.name, tuple(face @ R.T + com for face in local)))
    return solids


def _transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ T[:3, :3].T + T[:3, 3]


def characteristic_length(robot: Robot) -> float:
    """A length [m] that sets the size of triads and labels: the reach of the chain at q = 0,
    limited joint strokes included, never below 0.1 m."""
    q = np.zeros(robot.n)
    for i, joint in enumerate(robot.joints):
        if joint.kind == "prismatic" and np.isfinite(joint.limits[1]):
            q[i] = joint.limits[1]
    origins = link_frames(robot, q, frame="0")[:, :3, 3]
    return max(0.1, float(np.ptp(origins, axis=0).max()), float(np.linalg.norm(origins[-1])))


def _screen_axes(elev: float, azim: float) -> tuple[np.ndarray, np.ndarray]:
    """The unit vectors of the scene that point right and up on the screen for a view from
    elevation ``elev`` and azimuth ``azim`` [deg] (matplotlib's view_init angles)."""
    e, a = np.radians(elev), np.radians(azim)
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    up = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
    return right, up


def label_positions(poses: dict[str, np.ndarray], axis_length: float, elev: float,
                    azim: float) -> dict[str, np.ndarray]:
    """Where the frame labels go (3-D points [m]), one per frame of ``poses``.

    Each label sits next to its frame's origin, at the first of :data:`LABEL_OFFSETS` (screen
    directions in triad lengths) where it does not overlap a label placed before, so frames
    whose origins are close on the screen (Σ_2 and Σ_3 of the PRP) get labels apart.  Sizes are
    estimated from the text length in triad lengths, which sets the scene's scale.
    """
    right, up = _screen_axes(elev, azim)
    placed: list[tuple[float, float, float]] = []  # (x, y, half width) on the screen [m]
    out = {}
    for name, pose in poses.items():
        origin = pose[:3, 3]
        parts = name.split("=")
        half = 0.5 * axis_length * (LABEL_WIDTH * sum(0.75 + 0.25 * len(p) for p in parts)
                                    + 0.5 * (len(parts) - 1))
        height = LABEL_HEIGHT * axis_length
        x0, y0 = float(origin @ right), float(origin @ up)
        for dx, dy in LABEL_OFFSETS:
            x, y = x0 + dx * axis_length, y0 + dy * axis_length
            if all(abs(x - px) >= half + ph or abs(y - py) >= height for px, py, ph in placed):
                break
        placed.append((x, y, half))
        out[name] = origin + (x - x0) * right + (y - y0) * up
    return out


class RobotArtist:
    """The matplotlib artists of one robot on a 3-D axes, movable with :meth:`update`.

    Parameters
    ----------
    ax : mpl_toolkits.mplot3d.Axes3D
    robot : Robot
    frame : {"base", "0"}
        The frame the scene is expressed in.
    axis_length : float, optional
        Length of the triad axes [m]; by default 0.15 × :func:`characteristic_length`.
    show_frames : bool
        Draw Σ_base … Σ_e as triads with labels.
    plane : Plane, optional
        An environment surface (given in Σ_0) drawn as a translucent square.
    """

    def __init__(self, ax, robot: Robot, *, frame: str = "base", axis_length: float | None = None,
                 show_frames: bool = True, plane: Plane | None = None):
        self.ax, self.robot, self.frame = ax, robot, frame
        self.axis_length = axis_length or 0.15 * characteristic_length(robot)
        self.show_frames = show_frames
        self.solids = link_solids(robot)
        self.T_view_0 = robot.base if frame == "base" else np.eye(4)
        q0 = np.zeros(robot.n)
        self.chain = ax.plot([0], [0], [0], color="0.35", lw=1.6, ls="--", gid="chain")[0]
        self.bodies: list = []
        self.link_vertices: dict[str, np.ndarray] = {}
        for i, solid in enumerate(self.solids):
            colour = LINK_COLOURS[i % len(LINK_COLOURS)]
            if solid is None:
                gid = f"link:{robot.links[i].name}"
                self.bodies.append(ax.plot([0], [0], [0], color=colour, lw=5, gid=gid)[0])
            else:
                # Added empty, the faces come with update(q0): matplotlib pads faces of unequal
                # length (a cylinder's caps and sides) with uninitialised memory, which the data
                # limits of add_collection3d then read, now and then as NaN or inf.
                body = Poly3DCollection([], facecolor=colour, edgecolor="0.25", linewidths=0.3,
                                        alpha=0.55, gid=f"link:{solid.link}")
                ax.add_collection3d(body)
                self.bodies.append(body)
        self.triads: dict[str, list] = {}
        self.labels: dict[str, object] = {}
        self.plane = None
        if show_frames:
            for name in frame_poses(robot, q0, frame):
                self.triads[name] = [ax.plot([0], [0], [0], color=c, lw=2.0, gid=f"frame:{name}:{a}")[0]
                                     for c, a in zip(AXIS_COLOURS, "xyz", strict=True)]
                # Over the links (mplot3d gives the solids z-orders by depth, from a few up),
                # on a white box so a label stays legible where it crosses a link or an axis.
                self.labels[name] = ax.text(0, 0, 0, frame_label(name), fontsize=9, color="0.1", ha="center",
                                            va="center", zorder=LABEL_ZORDER,
                                            bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="0.75",
                                                      lw=0.5, alpha=0.85))
        if plane is not None:
            self._draw_plane(plane)
        self.update(q0)

    def _draw_plane(self, plane: Plane):
        u, v = plane_axes(plane)
        s = plane.half_size
        signs = ((-1, -1), (1, -1), (1, 1), (-1, 1))
        corners = np.array([plane.point + s * (a * u + b * v) for a, b in signs])
        corners = _transform_points(self.T_view_0, corners)
        self.plane_points = corners
        self.plane = Poly3DCollection([corners], facecolor="0.55", edgecolor="0.3", alpha=0.25,
                                      gid="environment:plane")
        self.ax.add_collection3d(self.plane)

    def artists(self) -> list:
        """Every artist of the scene: chain, links, triads with their labels, the plane.

        The plane does not move, but it is drawn in depth order with the links, so it goes
        with them when an animation redraws only what moves.
        """
        triads = [line for lines in self.triads.values() for line in lines]
        plane = [self.plane] if self.plane is not None else []
        return [self.chain, *self.bodies, *triads, *self.labels.values(), *plane]

    def update(self, q) -> None:
        """Move every artist to configuration ``q`` (n,) [m | rad]."""
        frames = link_frames(self.robot, q, frame=self.frame)
        origins = np.vstack(([inverse_transform(self.robot.base)[:3, 3]] if self.frame == "0"
                             else [np.zeros(3)], frames[:, :3, 3]))
        self.chain.set_data_3d(origins[:, 0], origins[:, 1], origins[:, 2])
        for i, (solid, body) in enumerate(zip(self.solids, self.bodies, strict=True)):
            T = frames[i + 1]
            if solid is None:
                segment = origins[i + 1:i + 3]
                body.set_data_3d(segment[:, 0], segment[:, 1], segment[:, 2])
            else:
                faces = [_transform_points(T, face) for face in solid.faces]
                body.set_verts(faces)
                self.link_vertices[solid.link] = np.vstack(faces)
        if self.show_frames:
            L = self.axis_length
            poses = frame_poses(self.robot, q, self.frame)
            for name, pose in poses.items():
                origin = pose[:3, 3]
                for k, line in enumerate(self.triads[name]):
                    tip = origin + L * pose[:3, k]
                    line.set_data_3d([origin[0], tip[0]], [origin[1], tip[1]], [origin[2], tip[2]])
            for name, position in label_positions(poses, L, self.ax.elev, self.ax.azim).items():
                self.labels[name].set_position_3d(position)

    def extent(self, qs) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corners (3,) [m] of everything drawn over the configurations ``qs``."""
        points = []
        for q in np.atleast_2d(qs):
            frames = link_frames(self.robot, q, frame=self.frame)
            points.append(frames[:, :3, 3])
            for solid, T in zip(self.solids, frames[1:-1], strict=True):
                if solid is not None:
                    points.append(_transform_points(T, np.vstack(solid.faces)))
        points.append(np.atleast_2d(self.T_view_0[:3, 3]))
        points.append(np.zeros((1, 3)))
        if hasattr(self, "plane_points"):
            points.append(self.plane_points)
        allpoints = np.vstack(points)
        return allpoints.min(axis=0) - self.axis_length, allpoints.max(axis=0) + self.axis_length


def set_equal_limits(ax, low: np.ndarray, high: np.ndarray) -> None:
    """Equal scale on x, y, z around the box [low, high] [m]."""
    centre = (low + high) / 2.0
    half = float((high - low).max()) / 2.0
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1), zoom=0.92)


def style_axes(ax, frame: str) -> None:
    """Axis labels naming the frame the coordinates are in."""
    sub = "base" if frame == "base" else "0"
    for setter, axis in ((ax.set_xlabel, "x"), (ax.set_ylabel, "y"), (ax.set_zlabel, "z")):
        setter(rf"${axis}_{{\mathrm{{{sub}}}}}$ [m]", labelpad=2)
    ax.tick_params(labelsize=7, pad=0)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))


def draw_robot(robot: Robot, q, *, frame: str = "base", ax=None, plane: Plane | None = None,
               show_frames: bool = True, title: str | None = None, view=(22.0, -58.0)):
    """Draw ``robot`` at configuration ``q`` (n,) [m | rad] with its frames (the seed's
    plotTransforms check), in Σ_base (``frame="base"``) or Σ_0 (``frame="0"``).

    Returns the matplotlib Figure; its :class:`RobotArtist` is ``fig.robot_artist``.
    """
    if frame not in FRAMES:
        raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
    q = np.asarray(q, dtype=float)
    if ax is None:
        fig = plt.figure(figsize=(5.2, 5.2))
        ax = fig.add_subplot(projection="3d")
        fig.subplots_adjust(left=0.0, right=0.96, bottom=0.02, top=0.9)
    fig = ax.figure
    ax.view_init(elev=view[0], azim=view[1])  # first: the frame labels are placed for the view
    artist = RobotArtist(ax, robot, frame=frame, show_frames=show_frames, plane=plane)
    artist.update(q)
    set_equal_limits(ax, *artist.extent(q))
    style_axes(ax, frame)
    values = ", ".join(f"{j.name} = {v:.3g} {'m' if j.kind == 'prismatic' else 'rad'}"
                       for j, v in zip(robot.joints, q, strict=True))
    ax.set_title(title or f"{robot.name} in {frame_label(frame)}\n{values}", fontsize=10)
    fig.robot_artist = artist
    return fig
