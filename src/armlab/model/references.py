"""The files a robot file names — MJCF ``<include>``, mesh, texture, height-field and skin files,
URDF meshes — and the rule they follow before anything opens them.

Robot files travel between people (description packages, a colleague's model), so what they
name is checked like the robot file itself:

* **where**: a referenced file must lie under the robot file's own folder F (after resolving
  ``..``, symbolic links and the ``package://`` and ``file://`` forms):

      realpath(reference) ∈ realpath(F)/…                                               (R1)

  An absolute path, a ``..`` that climbs out of F, a ``file://`` URL or a ``package://`` name
  that resolves outside F is refused unless the caller widens the rule (``allow_outside=True``
  of :func:`armlab.load_urdf`, :func:`armlab.model.mjcf_io.load_mjcf`, :func:`armlab.load_robot`; the
  command line's ``--allow-outside``).  The arms of installed description packages
  (:mod:`armlab.robots.zoo`) are read with the rule widened: their meshes sit in sibling
  folders of the package, which the user installed;
* **what**: a regular file (a FIFO would block its reader forever, a device such as
  ``/dev/zero`` never ends) of at most a bounded size (:data:`XML_LIMIT` for an included MJCF
  file, :data:`ASSET_LIMIT` for a mesh, texture or other asset).

The check runs before the file is opened by armlab or by the library reading the robot
(MuJoCo's compiler); MuJoCo then opens the same path itself, so a file swapped for a FIFO in
between is outside what a check can prevent (armlab's own reads open without blocking,
:mod:`armlab.inputs`).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from armlab.errors import RobotFileError
from armlab.inputs import URDF_LIMIT, file_kind, size_text

XML_LIMIT = URDF_LIMIT
"""Largest MJCF file read, the main file or an included one [bytes] (16 MiB)."""

ASSET_LIMIT = 64 * 1024 * 1024
"""Largest mesh, texture or other asset file a robot file may name [bytes] (64 MiB)."""

OUTSIDE_HINT = "allow_outside=True or --allow-outside reads it"


def folder_of(path) -> Path:
    """F of (R1): the real folder of the robot file ``path`` (symbolic links resolved)."""
    return Path(os.path.realpath(os.path.abspath(path))).parent


def is_under(candidate, folder: Path) -> bool:
    """(R1): ``candidate``, resolved, lies in ``folder`` or below it."""
    real = os.path.realpath(candidate)
    return os.path.commonpath([real, str(folder)]) == str(folder)


def problem(candidate, limit: int) -> str | None:
    """Why ``candidate`` cannot be read (not a regular file, larger than ``limit``), or None
    when it can, or when it does not exist (its reader then says so)."""
    try:
        info = os.stat(candidate)
    except (FileNotFoundError, NotADirectoryError):   # nothing there: the reader says so
        return None
    except (OSError, ValueError) as error:
        return f"cannot be read ({getattr(error, 'strerror', None) or error})"
    if not stat.S_ISREG(info.st_mode):
        return f"is {file_kind(info.st_mode)}, not a regular file"
    if info.st_size > limit:
        return f"is {size_text(info.st_size)}, more than the {size_text(limit)} read at most"
    return None


def check_reference(path, field: str, name: str, candidate, limit: int, folder: Path,
                    allow_outside: bool) -> None:
    """Raise ``RobotFileError(path, field, …)`` unless the file ``candidate`` (named ``name`` in
    the robot file ``path``) follows (R1) and is a readable regular file within ``limit``."""
    if not allow_outside and not is_under(candidate, folder):
        raise RobotFileError(path, field, f"{name!r} lies outside the robot file's folder "
                                          f"({OUTSIDE_HINT})")
    reason = problem(candidate, limit)
    if reason is not None:
        raise RobotFileError(path, field, f"{name!r} {reason}")


def urdf_mesh_path(filename: str, urdf_folder: Path) -> Path | None:
    """The file a URDF ``<mesh filename>`` names, the first of its candidates that exists (the
    last one when none does), or None for a URL armlab does not read (``http://`` …).

    * ``package://NAME/REST``: ROS resolves NAME through its package index, which armlab does
      not have; as ``yourdfpy`` and Pinocchio do without it, the candidates are ``A/NAME/REST``
      and ``A/REST`` for the URDF's folder A and each folder above it (the package is the
      folder named NAME that holds the URDF, or sits beside a folder that does);
    * ``file://PATH``: PATH;
    * any other name: a path, relative to the URDF's folder unless absolute.
    """
    if filename.startswith("package://"):
        rest = filename[len("package://"):]
        package, _, inner = rest.partition("/")
        candidates = []
        for above in (urdf_folder, *urdf_folder.parents):
            candidates += [above / package / inner, above / inner] if inner else [above / package]
        return next((c for c in candidates if os.path.lexists(c)), candidates[0])
    if filename.startswith("file://"):
        return Path(filename[len("file://"):])
    if "://" in filename:
        return None
    return urdf_folder / filename
