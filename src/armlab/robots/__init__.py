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


def load_robot(name_or_path: str | Path, *, tip: str | None = None,
               lock: dict | None = None, allow_outside: bool = False) -> Robot:
    """A robot by name or file.

    ``name_or_path``: a bundled robot (``"prp"``, see :func:`bundled_robot_names`), an arm of an
    installed description package (``"ur5"``, see :mod:`armlab.robots.zoo`), or a robot file:
    ``.toml`` (armlab's format), ``.urdf``, or MuJoCo's ``.xml``/``.mjcf`` (needs ``mujoco``).
    ``tip``: the link (URDF) or body (MJCF) carrying the end effector, for files whose tree
    branches; a zoo robot has its own, which ``tip`` replaces.  ``lock``: joint name → value at
    which a moving joint off the chain is locked (default 0 within its limits).
    ``allow_outside``: a URDF/MJCF file may name files (includes, meshes, textures) outside its
    own folder (:mod:`armlab.model.references`); a zoo arm's files always may (they come from
    an installed package, whose meshes sit beside its URDF folder).
    """
    text = str(name_or_path)
    if text in bundled_robot_names():
        _no_tree_options(text, tip, lock)
        return load_robot_toml(bundled_robot_path(text))
    from armlab.robots import zoo

    if text in zoo.ZOO:
        from armlab.model.urdf_io import load_urdf

        robot = load_urdf(zoo.zoo_path(text), tip=tip or zoo.ZOO[text].tip, lock=lock, name=text,
                          allow_outside=True)
        return robot.replace(description=zoo.ZOO[text].description,
                             notes=(f"from {zoo.provenance(text)}", *robot.notes))
    path = Path(text)
    suffix = path.suffix.lower()
    if suffix == ".urdf":
        from armlab.model.urdf_io import load_urdf

        return load_urdf(path, tip=tip, lock=lock, allow_outside=allow_outside)
    if suffix in (".xml", ".mjcf"):
        from armlab.model.mjcf_io import load_mjcf

        return load_mjcf(path, tip=tip, lock=lock, allow_outside=allow_outside)
    if suffix == ".toml":
        _no_tree_options(text, tip, lock)
        return load_robot_toml(path)
    raise RobotFileError(text, "name", f"not a bundled robot ({', '.join(bundled_robot_names())}), "
                         f"a zoo robot ({', '.join(zoo.zoo_names())}) nor a .toml, .urdf or "
                         ".xml (MJCF) file")


def robot_reference(robot: Robot) -> tuple[str, str | None]:
    """(plant, plant_tip): how a scenario file names ``robot`` so that it loads it back — a
    bundled or zoo name, else the absolute path of its file, with the tip a URDF/MJCF tree needs."""
    from armlab.robots import zoo

    if robot.name in bundled_robot_names() and not robot.tip:
        return robot.name, None
    if robot.name in zoo.ZOO:
        return robot.name, (robot.tip if robot.tip != zoo.ZOO[robot.name].tip else None)
    return str(Path(robot.source).resolve()), robot.tip or None


def _no_tree_options(text: str, tip, lock) -> None:
    """armlab's robot files describe a serial chain: there is no tip to choose."""
    for option, value in (("tip", tip), ("lock", lock)):
        if value:
            raise RobotFileError(text, option, "applies to URDF and MJCF files only (an armlab "
                                 "robot file describes one serial chain)")
