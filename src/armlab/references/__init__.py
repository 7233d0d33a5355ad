"""References: joint-space trajectories q_des(t) (:mod:`~armlab.references.joint`, seed
A6–A8) and task-space poses and forces (:mod:`~armlab.references.task`, A9–A15)."""

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

__all__ = ["Constant", "ForceReference", "JointReference", "PoseReference", "Ramp",
           "ReferenceSpecError", "Sinusoid", "SquareWaveAcceleration", "TaskReferenceError",
           "ViaPoints", "force_reference_into", "path_singular_values", "pose_reference_into",
           "reference_into"]
