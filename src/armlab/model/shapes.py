"""The primitive shapes of robot files as polygons and triangles, for drawing only.

Each shape is centred at the origin of its own frame with its axis along z, as URDF
(``<box size>``, ``<cylinder radius length>``, ``<sphere radius>``), MJCF geoms and armlab's
inertia shapes place them:

* box of sides (a, b, c): the 8 corners (±a/2, ±b/2, ±c/2), 6 quadrilaterals;
* cylinder of radius r and length L: rings of ``segments`` points (r cos φ, r sin φ, ±L/2),
  side quadrilaterals and two cap polygons;
* sphere of radius r: the points r (sin θ cos φ, sin θ sin φ, cos θ) of a latitude–longitude
  grid (θ in ``segments``/2 steps, so the equator θ = π/2 is a grid line), quadrilaterals;
* ellipsoid of semi-axes (a, b, c): the unit sphere's points scaled by diag(a, b, c);
* capsule of radius r and cylinder length L: the sphere's upper half moved up by L/2, its lower
  half down by L/2, joined by the cylinder's sides.

Every point lies on the shape's surface, so a drawing never sits off the shape it draws.
:func:`triangulate` turns the (convex) polygons into triangles.
"""

from __future__ import annotations

import numpy as np

SEGMENTS = 24
"""Points around a cylinder's or capsule's circle."""

SPHERE_SEGMENTS = 12
"""Points around a sphere's equator (half as many steps from pole to pole)."""


def box_faces(size) -> list[np.ndarray]:
    """The 6 faces (4, 3) of the box of sides ``size`` (a, b, c) [m]."""
    a, b, c = np.asarray(size, dtype=float) / 2.0
    v = np.array([[x, y, z] for x in (-a, a) for y in (-b, b) for z in (-c, c)])
    quads = [(0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5)]
    return [v[list(quad)] for quad in quads]


def _ring(radius: float, segments: int) -> np.ndarray:
    angle = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    return np.column_stack((radius * np.cos(angle), radius * np.sin(angle), np.zeros_like(angle)))


def _sides(radius: float, length: float, segments: int) -> list[np.ndarray]:
    ring = _ring(radius, segments)
    bottom, top = ring - [0, 0, length / 2], ring + [0, 0, length / 2]
    return [np.array([bottom[k], bottom[k + 1], top[k + 1], top[k]]) for k in range(segments)]


def cylinder_faces(radius: float, length: float, segments: int = SEGMENTS) -> list[np.ndarray]:
    """The side quadrilaterals and the two caps of the cylinder of ``radius`` and ``length`` [m]."""
    ring = _ring(radius, segments)[:-1]
    return [*_sides(radius, length, segments), ring - [0, 0, length / 2], ring + [0, 0, length / 2]]


def sphere_faces(radius: float, segments: int = SPHERE_SEGMENTS) -> list[np.ndarray]:
    """The quadrilaterals (4, 3) of the latitude–longitude grid on the sphere of ``radius`` [m],
    the northern hemisphere's first."""
    lat = np.linspace(0.0, np.pi, segments // 2 + 1)
    lon = np.linspace(0.0, 2.0 * np.pi, segments + 1)

    def point(a, b):
        return radius * np.array([np.sin(a) * np.cos(b), np.sin(a) * np.sin(b), np.cos(a)])

    return [np.array([point(lat[i], lon[j]), point(lat[i], lon[j + 1]),
                      point(lat[i + 1], lon[j + 1]), point(lat[i + 1], lon[j])])
            for i in range(len(lat) - 1) for j in range(segments)]


def ellipsoid_faces(radii) -> list[np.ndarray]:
    """The quadrilaterals of the ellipsoid of semi-axes ``radii`` (a, b, c) [m]."""
    return [face * np.asarray(radii, dtype=float) for face in sphere_faces(1.0)]


def capsule_faces(radius: float, length: float, segments: int = SEGMENTS) -> list[np.ndarray]:
    """The quadrilaterals of the capsule of ``radius`` whose cylinder is ``length`` long [m]."""
    caps = sphere_faces(radius, segments)
    half = len(caps) // 2   # segments/2 latitude bands, the upper half first
    lift = np.array([0.0, 0.0, length / 2])
    return ([face + lift for face in caps[:half]] + _sides(radius, length, segments)
            + [face - lift for face in caps[half:]])


def triangulate(faces) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (T, 3) of convex polygons ``faces`` (each (k, 3)): each
    face as a fan from its first vertex."""
    vertices, triangles, start = [], [], 0
    for face in faces:
        k = face.shape[0]
        vertices.append(face)
        triangles += [(start, start + a, start + a + 1) for a in range(1, k - 1)]
        start += k
    return np.vstack(vertices), np.array(triangles, dtype=np.int64).reshape(-1, 3)


def primitive_mesh(kind: str, dimensions) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a primitive: ``"box"`` (sides a, b, c), ``"cylinder"`` and
    ``"capsule"`` (radius, cylinder length), ``"sphere"`` (radius), ``"ellipsoid"`` (semi-axes)."""
    d = [float(v) for v in np.ravel(dimensions)]
    faces = {"box": lambda: box_faces(d), "cylinder": lambda: cylinder_faces(*d),
             "capsule": lambda: capsule_faces(*d), "sphere": lambda: sphere_faces(*d),
             "ellipsoid": lambda: ellipsoid_faces(d)}
    if kind not in faces:
        raise ValueError(f"unknown primitive {kind!r} (box, cylinder, capsule, sphere, ellipsoid)")
    return triangulate(faces[kind]())
