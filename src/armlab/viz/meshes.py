"""The visual shapes of a robot (its :class:`~armlab.model.robot.Visual` records: mesh files,
or triangles the loader made of primitive shapes and of MJCF meshes), read and thinned for
drawing.

Every visual's vertices are placed in the frame of the body that carries it,

    p_frame = T · diag(scale) · p                                                       (V1)

(Σ_0 for body 0, Σ_i for link i), the visuals of one body are joined into one triangle mesh,
and each body's mesh is thinned to its share of a vertex budget by vertex clustering
(:func:`decimate`): a browser redraws every vertex at every animation frame, and the visual
meshes of description packages hold tens of thousands of vertices per link (a UR5: 66 000).

Meshes are read by ``trimesh`` (STL, OBJ, PLY; COLLADA through ``pycollada``), from at most
:data:`MESH_LIMIT` bytes of a regular file (:func:`armlab.inputs.read_input_bytes`).  A mesh
that cannot be read is left out with a warning naming the file: its link is then drawn as
its inertia shape.
"""

from __future__ import annotations

import io
import os
import warnings
from functools import lru_cache
from pathlib import Path

import numpy as np

from armlab.errors import RobotFileError
from armlab.inputs import read_input_bytes
from armlab.model.references import ASSET_LIMIT

MESH_LIMIT = ASSET_LIMIT
"""Largest mesh file read [bytes] (64 MiB, the limit of every asset a robot file names)."""

MAX_VERTICES = 2400
"""Vertices of all the meshes of a robot together, at most (see :func:`body_meshes`)."""

LEAST_VERTICES = 48
"""Vertices a body's mesh keeps at least however small its share of the budget."""

BISECTIONS = 24
"""Steps of the search for the cube size of :func:`decimate` (the budget is met to 2⁻²⁴ in log h)."""


def decimate(vertices: np.ndarray, faces: np.ndarray, max_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """A mesh of at most ``max_vertices`` vertices close to (``vertices`` (V, 3), ``faces`` (F, 3)).

    Vertex clustering (Rossignac & Borrel, 1993): space is cut into cubes of side h from the
    lowest corner v_min of the mesh's box; the vertices of a cube merge into their mean,

        c(v) = ⌊(v − v_min) / h⌋,   v'_c = mean{v : c(v) = c},                          (D1)

    each triangle keeps its corners' clusters and is dropped when two of them coincide (it
    shrank to a segment or a point), and repeated triangles are dropped.  Every vertex moves
    by less than the cube's diagonal √3·h.  h is the smallest found by bisection (in log h,
    :data:`BISECTIONS` steps between L/2²⁰ and L, L the box's longest side) that leaves at most
    ``max_vertices`` clusters.  A mesh already within the budget is returned unchanged.
    """
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if max_vertices < 1:
        raise ValueError(f"max_vertices must be at least 1, got {max_vertices}")
    if len(vertices) <= max_vertices:
        return vertices, faces
    low = vertices.min(axis=0)
    extent = max(float(np.max(vertices.max(axis=0) - low)), 1e-12)
    cells_per_side = 1 << 21   # cell coordinates below 2²¹ at h ≥ L/2²⁰: one int64 key per cell

    def clusters(h: float):
        cells = np.minimum(np.floor((vertices - low) / h).astype(np.int64), cells_per_side - 1)
        keys = (cells[:, 0] * cells_per_side + cells[:, 1]) * cells_per_side + cells[:, 2]
        return np.unique(keys, return_inverse=True)

    lo, hi = np.log(extent) - 20 * np.log(2.0), np.log(extent) + 1e-9  # at hi: at most 8 cubes
    best = clusters(np.exp(lo))
    if len(best[0]) > max_vertices:
        best = clusters(np.exp(hi))
        for _ in range(BISECTIONS):
            middle = 0.5 * (lo + hi)
            found = clusters(np.exp(middle))
            if len(found[0]) <= max_vertices:
                hi, best = middle, found
            else:
                lo = middle
        if len(best[0]) > max_vertices:   # 8 cubes and a budget below 8: one cluster
            best = (np.zeros(1), np.zeros(len(vertices), dtype=np.int64))
    count_of, inverse = len(best[0]), best[1].reshape(-1)
    count = np.bincount(inverse, minlength=count_of).astype(float)
    merged = np.column_stack([np.bincount(inverse, weights=vertices[:, k], minlength=count_of)
                              for k in range(3)]) / count[:, None]
    mapped = inverse[faces]
    keep = ((mapped[:, 0] != mapped[:, 1]) & (mapped[:, 1] != mapped[:, 2])
            & (mapped[:, 0] != mapped[:, 2]))
    mapped = mapped[keep]
    # A triangle and its rotations (same corners, same side) are one triangle.
    first = np.argmin(mapped, axis=1)[:, None]
    rolled = np.take_along_axis(mapped, (first + np.arange(3)) % 3, axis=1)
    _, unique = np.unique(rolled, axis=0, return_index=True)
    return merged, mapped[np.sort(unique)]


@lru_cache(maxsize=64)
def _read(path: str, stamp: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of the mesh file ``path`` (``stamp``: its size and mtime, so an
    edited file is read again)."""
    import trimesh

    data = read_input_bytes(path, RobotFileError, MESH_LIMIT)
    loaded = trimesh.load(io.BytesIO(data), file_type=Path(path).suffix.lower().lstrip("."), force="mesh",
                          process=False)
    vertices = np.asarray(loaded.vertices, dtype=float)
    faces = np.asarray(loaded.faces, dtype=np.int64).reshape(-1, 3)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or not len(faces):
        raise ValueError("holds no triangles")
    if not np.all(np.isfinite(vertices)) or faces.min() < 0 or faces.max() >= len(vertices):
        raise ValueError("its vertices are not finite or its faces index no vertex")
    vertices.setflags(write=False)
    faces.setflags(write=False)
    return vertices, faces


def read_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) [file units] and triangles (F, 3) of a mesh file."""
    info = os.stat(path)
    return _read(str(path), (info.st_size, info.st_mtime_ns))


def body_meshes(robot, max_vertices: int = MAX_VERTICES) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """``{body: (vertices (V, 3) [m], triangles (F, 3))}`` of the bodies of ``robot`` that carry
    visuals, in the body's frame (Σ_0 for 0, Σ_i for link i; V1).

    The bodies share ``max_vertices``: each is thinned (:func:`decimate`) to a share in
    proportion to its vertex count, and to no fewer than :data:`LEAST_VERTICES`.  ``None``
    for ``max_vertices`` keeps every vertex.  A file that cannot be read is skipped with a
    ``UserWarning``.
    """
    parts: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
    for visual in getattr(robot, "visuals", ()):
        if not visual.mesh:   # triangles carried by the record: a primitive or a compiled mesh
            vertices, faces = visual.vertices, visual.faces
        else:
            try:
                vertices, faces = read_mesh(visual.mesh)
            except Exception as error:  # a broken mesh file costs its drawing, not the view
                reason = " ".join(str(error).split()) or type(error).__name__
                warnings.warn(f"{visual.mesh}: mesh: cannot be read ({reason}); link {visual.part} is "
                              "drawn as its inertia shape", stacklevel=2)
                continue
        placed = (vertices * visual.scale) @ visual.pose[:3, :3].T + visual.pose[:3, 3]
        parts.setdefault(visual.body, []).append((placed, faces))
    joined = {}
    for body, pieces in parts.items():
        offsets = np.cumsum([0] + [len(v) for v, _ in pieces[:-1]])
        joined[body] = (np.vstack([v for v, _ in pieces]),
                        np.vstack([f + offset for (_, f), offset in zip(pieces, offsets, strict=True)]))
    if max_vertices is None or not joined:
        return joined
    total = sum(len(v) for v, _ in joined.values())
    return {body: decimate(v, f, max(LEAST_VERTICES, int(max_vertices * len(v) / total)))
            for body, (v, f) in joined.items()}
