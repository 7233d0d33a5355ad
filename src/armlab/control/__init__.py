"""Controllers: the protocol (``base``) and the joint-space laws of seed assignments A6–A8."""

from armlab.control.base import Controller, Environment, ProtocolError, Signal

__all__ = ["Controller", "Environment", "ProtocolError", "Signal"]
