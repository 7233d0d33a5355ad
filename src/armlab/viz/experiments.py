"""The report's experiments, discovered from the scenario registry."""

from __future__ import annotations


def discover(robot, *, quick: bool = False) -> list:
    """Every registered scenario of ``robot`` as a report Experiment."""
    try:
        import armlab.scenarios  # noqa: F401
    except ImportError:
        return []
    return []


def registry_names(robot_name: str) -> list[str]:
    """Names of the registered scenarios of the robot named ``robot_name``."""
    return []
