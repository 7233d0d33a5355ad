"""Bundled robot files and ``load_robot``."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from armlab.model.robot import Robot
from armlab.model.toml_io import RobotFileError, load_robot_toml


def bundled_robot_names() -> list[str]:
    """Names of the robots shipped with armlab (``armlab robots``)."""
    folder = resources.files(__name__)
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def bundled_robot_path(name: str) -> Path:
    return Path(str(resources.files(__name__).joinpath(f"{name}.toml")))


def load_robot(name_or_path: str | Path) -> Robot:
    """A bundled robot by name (``"prp"``) or a robot file (``.toml`` or ``.urdf``)."""
    text = str(name_or_path)
    if text in bundled_robot_names():
        return load_robot_toml(bundled_robot_path(text))
    path = Path(text)
    if path.suffix.lower() == ".urdf":
        from armlab.model.urdf_io import load_urdf

        return load_urdf(path)
    if path.suffix.lower() == ".toml":
        return load_robot_toml(path)
    raise RobotFileError(text, "name", f"not a bundled robot ({', '.join(bundled_robot_names())}) "
                         "nor a .toml or .urdf file")
