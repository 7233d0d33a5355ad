"""armlab: modelling and control of robot manipulators.

Conventions (frames, twist and wrench ordering, Euler angles, units): ``docs/notation.md``.
"""

from armlab.kinematics import forward_kinematics, geometric_jacobian, link_frames
from armlab.model import Robot, RobotFileError
from armlab.model.urdf_io import load_urdf as load_urdf
from armlab.model.urdf_io import save_urdf as save_urdf
from armlab.model.urdf_io import to_urdf as to_urdf
from armlab.robots import bundled_robot_names, load_robot

__version__ = "0.1.0"

__all__ = [
    "Robot", "RobotFileError", "bundled_robot_names", "forward_kinematics",
    "geometric_jacobian", "link_frames", "load_robot",
]
