"""The visual shapes of a robot file (URDF ``<visual>``, MJCF geoms), placed on the bodies of
the robot built from it (:class:`~armlab.model.robot.Visual`, V1): for drawing only.

:func:`place_visuals` takes the tree :mod:`armlab.model.urdf_io` reads (yourdfpy's links, or
the same records :mod:`armlab.model.mjcf_io` makes of a compiled MJCF) and the pose of each
link in the body that carries it.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from armlab.model.references import ASSET_LIMIT, folder_of, is_under, problem, urdf_mesh_path
from armlab.model.robot import Visual
from armlab.model.shapes import primitive_mesh


def _primitive(geometry) -> tuple[str, np.ndarray] | None:
    """(kind, dimensions) of a ``<box>`` (sides), ``<cylinder>`` (radius, length) or ``<sphere>``
    (radius) geometry, an attribute not given as NaN; None for other geometries."""
    for kind, names in (("box", ("size",)), ("cylinder", ("radius", "length")), ("sphere", ("radius",))):
        shape = getattr(geometry, kind, None)
        if shape is not None:
            values = [getattr(shape, name, None) for name in names]
            return kind, np.concatenate([np.full(3 if kind == "box" else 1, np.nan) if v is None
                                         else np.ravel(np.asarray(v, dtype=float)) for v in values])
    return None


def place_visuals(path, links: dict, body_of: dict, pose_in_body: dict, *,
                  allow_outside: bool = False) -> tuple[list[Visual], list[str], list[str], list[str]]:
    """The ``<visual>`` shapes of the file's links placed on the robot's bodies (V1), the mesh
    references that name no file, the primitives left out for a size that is not positive, and
    the mesh references left out by the rule of :mod:`armlab.model.references` (outside the
    file's folder unless ``allow_outside``; not a regular file; larger than its limit).

    A link's ``pose_in_body`` already folds the fixed joints (and locked side branches) between
    it and the body that carries it, so a shape sits at ``pose_in_body · <visual><origin>``.
    Mesh names are resolved by :func:`armlab.model.references.urdf_mesh_path` (``package://``,
    ``file://``, paths relative to the file's folder).  A ``<box>``, ``<cylinder>`` or
    ``<sphere>`` becomes its triangles (:func:`armlab.model.shapes.primitive_mesh`, centred at
    the origin, axis z); a geometry that carries ``triangles`` (vertices, faces) — an MJCF
    geom as MuJoCo compiled it, from :mod:`armlab.model.mjcf_io` — is kept as it is.
    """
    folder = Path(os.path.abspath(path)).parent
    root = folder_of(path)
    visuals, missing, unsized, refused = [], [], [], []
    for link_name, body in body_of.items():
        for visual in getattr(links[link_name], "visuals", None) or ():
            geometry = visual.geometry
            if geometry is None:
                continue
            origin = np.eye(4) if visual.origin is None else np.asarray(visual.origin, dtype=float)
            pose = pose_in_body[link_name] @ origin
            triangles, primitive = getattr(geometry, "triangles", None), _primitive(geometry)
            if primitive is not None:
                kind, dimensions = primitive
                if not np.all(dimensions > 0):   # NaN too: an attribute not given
                    unsized.append(f"{link_name}: {kind}")
                    continue
                triangles = primitive_mesh(kind, dimensions)
            if triangles is not None:
                visuals.append(Visual(body=body, pose=pose, part=link_name, vertices=triangles[0],
                                      faces=triangles[1]))
                continue
            mesh = getattr(geometry, "mesh", None)
            if mesh is None or not mesh.filename:
                continue
            resolved = urdf_mesh_path(mesh.filename, folder)
            if resolved is not None and not allow_outside and not is_under(resolved, root):
                refused.append(f"{link_name}: {mesh.filename} (outside the robot file's folder)")
                continue
            reason = None if resolved is None else problem(resolved, ASSET_LIMIT)
            if reason is not None:
                refused.append(f"{link_name}: {mesh.filename} ({reason})")
                continue
            if resolved is None or not resolved.is_file():
                missing.append(f"{link_name}: {mesh.filename}")
                continue
            scale = np.ones(3) if mesh.scale is None else np.broadcast_to(
                np.asarray(mesh.scale, dtype=float), (3,))
            visuals.append(Visual(body=body, pose=pose, mesh=os.path.realpath(resolved), scale=scale,
                                  part=link_name))
    return visuals, missing, unsized, refused
