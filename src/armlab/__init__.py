"""armlab: modelling and control of robot manipulators.

Conventions (frames, twist and wrench ordering, Euler angles, units): ``docs/notation.md``.
"""

from armlab.control.interaction import AdmittanceControl as AdmittanceControl
from armlab.control.interaction import ComplianceControl as ComplianceControl
from armlab.control.interaction import ForceControl as ForceControl
from armlab.control.interaction import ImpedanceControl as ImpedanceControl
from armlab.control.interaction import ParallelForcePosition as ParallelForcePosition
from armlab.control.task_space import OperationalInverseDynamics as OperationalInverseDynamics
from armlab.control.task_space import OperationalPD as OperationalPD
from armlab.dynamics import coriolis_matrix as coriolis_matrix
from armlab.dynamics import forward_dynamics as forward_dynamics
from armlab.dynamics import gravity_torque as gravity_torque
from armlab.dynamics import inertia_matrix as inertia_matrix
from armlab.dynamics import inverse_dynamics as inverse_dynamics
from armlab.dynamics import kinetic_energy as kinetic_energy
from armlab.dynamics import potential_energy as potential_energy
from armlab.environment import FreeSpace as FreeSpace
from armlab.environment import PlanarWall as PlanarWall
from armlab.environment import Spring as Spring
from armlab.inverse_kinematics import UnreachableTargetError as UnreachableTargetError
from armlab.inverse_kinematics import inverse_kinematics as inverse_kinematics
from armlab.kinematics import analytic_jacobian as analytic_jacobian
from armlab.kinematics import forward_kinematics, geometric_jacobian, link_frames
from armlab.kinematics import jacobian_dot_qd as jacobian_dot_qd
from armlab.kinematics import pose_vector as pose_vector
from armlab.model import Robot, RobotFileError
from armlab.model.urdf_io import load_urdf as load_urdf
from armlab.model.urdf_io import save_urdf as save_urdf
from armlab.model.urdf_io import to_urdf as to_urdf
from armlab.operational_space import operational_space_dynamics as operational_space_dynamics
from armlab.results import SimulationResult as SimulationResult
from armlab.robots import bundled_robot_names, load_robot
from armlab.simulation import SimulationDiverged as SimulationDiverged
from armlab.simulation import simulate as simulate
from armlab.simulation import simulate_batch as simulate_batch
from armlab.spatial import RepresentationSingularityError as RepresentationSingularityError
from armlab.task_references import ForceReference as ForceReference
from armlab.task_references import PoseReference as PoseReference

__version__ = "0.1.0"

__all__ = [
    "Robot", "RobotFileError", "bundled_robot_names", "forward_kinematics",
    "geometric_jacobian", "link_frames", "load_robot",
]
