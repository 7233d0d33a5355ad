"""A runnable experiment: what a scenario file describes (``armlab.scenarios``), loaded."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from armlab.control.adaptive import SlotineLi1DoF
from armlab.control.base import Controller, Environment
from armlab.errors import ScenarioFileError
from armlab.model.robot import Robot


@dataclass(frozen=True)
class Scenario:
    """A runnable experiment: plant, controller, disturbances, environment and simulation
    settings."""

    name: str
    title: str
    assignment: str
    description: str
    plant: Robot
    controller: Controller
    disturbance: tuple = ()
    simulation: dict = field(default_factory=dict)
    source: str = ""
    environment: Environment | None = None
    expect: Literal["ok", "diverged"] = "ok"
    """How the run should end: "ok" (to t_final) or "diverged" (an experiment whose point is
    the divergence); ``armlab run`` exits with 0 when it does (``result.meta["expect"]``)."""

    def run(self, *, t_final: float | None = None, method: str | None = None, **overrides):
        """Simulate this scenario (``armlab.simulate``); ``t_final``/``method`` shorten or switch it."""
        from armlab.simulation import SimulationError

        settings = dict(self.simulation)
        if t_final is not None:
            settings["t_final"] = float(t_final)
        if method is not None:
            settings["method"] = method
        settings.update(overrides)
        meta = {"scenario": self.name, "title": self.title, "assignment": self.assignment,
                "description": self.description, "source": self.source, "expect": self.expect}
        try:
            return self._simulate(settings, meta)
        except SimulationError as error:
            # simulate names the argument ("q0: …"); the user wrote it in [simulation].
            field, _, reason = str(error).partition(": ")
            raise ScenarioFileError(self.source or self.name, f"simulation.{field}", reason) from None

    def _simulate(self, settings: dict, meta: dict):
        """Simulate; a controller with a ``check`` of its run (the task-space controllers warn
        of a near-singular task Jacobian) checks it afterwards, also a diverged run."""
        from armlab.simulation import SimulationDiverged, simulate

        if isinstance(self.controller, SlotineLi1DoF):
            # What the seed plots but the controller cannot know: the plant's [I, F, G].
            from armlab.control.adaptive import link1_parameters

            meta["true_parameters"] = link1_parameters(self.plant).tolist()
        check = getattr(self.controller, "check", None)
        try:
            result = simulate(self.plant, self.controller, disturbance=list(self.disturbance) or None,
                              environment=self.environment, meta=meta, **settings)
        except SimulationDiverged as error:
            if check is not None:
                check(error.result)
            raise
        if check is not None:
            check(result)
        return result
