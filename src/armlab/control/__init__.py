"""Controllers: the protocol (``base``), the joint-space laws of seed assignments A6–A8
(``joint_space``, ``adaptive``) and the task-space and interaction laws of A9–A15
(``task_space``, ``interaction``)."""

from armlab.control.adaptive import SlotineLi, SlotineLi1DoF
from armlab.control.base import Controller, Environment, ProtocolError, Signal
from armlab.control.joint_space import JointInverseDynamics, JointPDGravity

__all__ = ["Controller", "Environment", "JointInverseDynamics", "JointPDGravity", "ProtocolError",
           "Signal", "SlotineLi", "SlotineLi1DoF"]
