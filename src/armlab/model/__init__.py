"""Robot descriptions: joints, links, inertials, motors, friction; TOML and URDF files."""

from armlab.model.inertia import box_inertia, cylinder_inertia, sphere_inertia, steiner
from armlab.model.robot import (
    DHRow,
    Friction,
    Inertial,
    Joint,
    Link,
    Motor,
    Robot,
    RobotArrays,
    Visual,
)
from armlab.model.toml_io import RobotFileError, load_robot_toml, robot_from_dict

__all__ = [
    "DHRow", "Friction", "Inertial", "Joint", "Link", "Motor", "Robot", "RobotArrays",
    "RobotFileError", "Visual", "box_inertia", "cylinder_inertia", "load_robot_toml",
    "robot_from_dict", "sphere_inertia", "steiner",
]
