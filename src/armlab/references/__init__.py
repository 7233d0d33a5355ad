"""References: joint-space trajectories q_des(t) (:mod:`~armlab.references.joint`, seed
A6–A8; trapezoidal, blended and spline trajectories in :mod:`~armlab.references.trajectories`)
and task-space poses and forces (:mod:`~armlab.references.task`, A9–A15)."""

from armlab.references.joint import (
    Constant,
    JointReference,
    Ramp,
    ReferenceSpecError,
    Sinusoid,
    SquareWaveAcceleration,
    ViaPoints,
    reference_into,
)
from armlab.references.task import (
    ForceReference,
    PoseReference,
    TaskReferenceError,
    force_reference_into,
    path_singular_values,
    pose_reference_into,
)
from armlab.references.trajectories import BlendedViaPoints, Spline, Trapezoidal

__all__ = ["BlendedViaPoints", "Constant", "ForceReference", "JointReference", "PoseReference", "Ramp",
           "ReferenceSpecError", "Sinusoid", "Spline", "SquareWaveAcceleration", "TaskReferenceError",
           "Trapezoidal", "ViaPoints", "force_reference_into", "path_singular_values", "pose_reference_into",
           "reference_into"]
