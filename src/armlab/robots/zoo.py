"""Arms of installed robot-description packages, loaded by name (``load_robot("ur5")``).

The files are not armlab's: they come, unchanged, from a package the user installs
(``pip install armlab[zoo]``).  Each entry names the package, the file inside it and the link
that carries the end effector (``tip``): side branches (grippers, fingers, heads, other arms)
are locked and lumped by the loader, and ``robot.notes`` says so.  Nothing is downloaded: a
name whose package is not installed gets a one-line error that says what to install.

The package read is ``example-robot-data`` (URDF, the Pinocchio/Crocoddyl benchmark robots),
whose files live under ``share/example-robot-data/robots`` of its ``cmeel.prefix``, located
through ``importlib.metadata`` (the public record of what pip installed).  MuJoCo Menagerie's
package on PyPI holds no model files (it downloads them on first use), so it is not part of
the offline zoo; its MJCF files load by path once on disk.
"""

from __future__ import annotations

import importlib.metadata
from dataclasses import dataclass
from pathlib import Path

from armlab.errors import RobotFileError


@dataclass(frozen=True)
class ZooEntry:
    """A robot of a description package: ``file`` inside the package's data folder."""

    name: str
    package: str
    file: str
    tip: str | None
    description: str


_ERD = "example-robot-data"

ZOO: dict[str, ZooEntry] = {entry.name: entry for entry in [
    ZooEntry("ur3", _ERD, "ur_description/urdf/ur3_robot.urdf", "tool0", "Universal Robots UR3, 6R"),
    ZooEntry("ur5", _ERD, "ur_description/urdf/ur5_robot.urdf", "tool0", "Universal Robots UR5, 6R"),
    ZooEntry("ur10", _ERD, "ur_description/urdf/ur10_robot.urdf", "tool0",
             "Universal Robots UR10, 6R"),
    ZooEntry("panda", _ERD, "panda_description/urdf/panda.urdf", "panda_hand_tcp",
             "Franka Emika Panda, 7R, fingers locked"),
    ZooEntry("kinova", _ERD, "kinova_description/robots/kinova.urdf", "j2s6s200_end_effector",
             "Kinova Jaco j2s6s200, 6R"),
    ZooEntry("talos_left_arm", _ERD, "talos_data/robots/talos_left_arm.urdf",
             "gripper_left_base_link", "PAL Talos left arm, 6R, gripper locked"),
    ZooEntry("baxter_left_arm", _ERD, "baxter_description/urdf/baxter.urdf", "left_gripper",
             "Rethink Baxter left arm, 7R, head, right arm and fingers locked"),
    ZooEntry("xarm7", _ERD, "xarm_description/urdf/xarm7.urdf", "link_eef", "UFACTORY xArm7, 7R"),
    ZooEntry("z1", _ERD, "z1_description/urdf/z1.urdf", "gripperStator",
             "Unitree Z1, 6R, gripper locked"),
    ZooEntry("so100", _ERD, "so_arm_description/urdf/so100.urdf", None,
             "SO-ARM100, 5R and the jaw joint"),
    ZooEntry("double_pendulum", _ERD, "double_pendulum_description/urdf/double_pendulum.urdf",
             None, "double pendulum, 2R"),
]}


def zoo_names() -> list[str]:
    return sorted(ZOO)


def _package_root(package: str) -> Path | None:
    """The folder holding the package's robot files, or None when it is not installed."""
    try:
        dist = importlib.metadata.distribution(package)
    except importlib.metadata.PackageNotFoundError:
        return None
    marker = "share/example-robot-data/robots/"
    for file in dist.files or ():
        text = str(file).replace("\\", "/")
        if marker in text:
            return Path(str(dist.locate_file(text[:text.index(marker) + len(marker)])))
    return None


def installed(entry: ZooEntry) -> bool:
    root = _package_root(entry.package)
    return root is not None and (root / entry.file).is_file()


def zoo_path(name: str) -> Path:
    """The file of zoo robot ``name``; a one-line error when its package is not installed."""
    entry = ZOO[name]
    root = _package_root(entry.package)
    if root is None:
        raise RobotFileError(name, "name", f"is a robot of the package {entry.package!r}, which is "
                             f"not installed (pip install {entry.package})")
    path = root / entry.file
    if not path.is_file():
        raise RobotFileError(name, "name", f"{entry.package} "
                             f"{importlib.metadata.version(entry.package)} has no {entry.file}")
    return path


def provenance(name: str) -> str:
    entry = ZOO[name]
    version = importlib.metadata.version(entry.package)
    return f"{entry.package} {version}: {entry.file}" + (f", tip {entry.tip}" if entry.tip else "")
