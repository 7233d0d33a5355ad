"""Where a batch's numbers go: the first valid run of a batch set up once, and each field's
value located in its compiled inputs by probing (``armlab.sweep.rollout``).

The compiled inputs of a run are its controller's and environment's parameter tuples, whose
float64 arrays are made views of one flat buffer each (:class:`_Flat`), the plant's model, x(0),
the torque limits and the disturbance.  A field is probed by building the scenario again with
the field at two other values of its column: every input that changes must hold exactly that
value (a copy), in the same places for both, and nothing else of the set-up (its length,
logging, signals, integer parameters) may change; else :class:`RolloutUnsupported` names the
field and why.  The exceptions: a controller field that changes the controller's parameters
alone, through a computation (a mass of its model), and a plant mass that changes the plant's
model alone (numeric kernels) are *computed*: each run's controller or plant is built from the
file (:meth:`BatchPlan.computed_numbers`) and its whole buffer written.
Each value of a run is checked once per distinct value by building the object
of the scenario file that holds it (:meth:`BatchPlan.problem`).
"""

from __future__ import annotations

import copy
import inspect
import itertools
import math
import warnings
from pathlib import Path

import numpy as np

from armlab.errors import ArmlabError, RolloutUnsupported
from armlab.sweep.fields import assign


def _leaves(value, floats: list, others: list):
    """The float64 arrays of a (named) tuple of parameters, depth first, into ``floats``; every
    other leaf (int arrays, numbers) into ``others`` (what must not change between runs)."""
    if isinstance(value, tuple):
        for item in value:
            _leaves(item, floats, others)
    elif isinstance(value, np.ndarray) and value.dtype == np.float64:
        floats.append(value)
    else:
        others.append(value)


def _rebuilt(value, views: list):
    """``value`` with its float64 arrays replaced, in :func:`_leaves` order, by ``views``."""
    if isinstance(value, tuple):
        items = [_rebuilt(item, views) for item in value]
        return type(value)(*items) if hasattr(value, "_fields") else tuple(items)
    if isinstance(value, np.ndarray) and value.dtype == np.float64:
        return views.pop(0)
    return value


class _Flat:
    """A parameter tuple whose float64 arrays are views of one flat buffer (same shapes, write
    flags and numba types), so that a run's numbers are written at offsets of that buffer."""

    def __init__(self, params):
        floats, self.others = [], []
        _leaves(params, floats, self.others)
        self.shapes = [(a.shape, a.flags.writeable) for a in floats]
        self.base = np.concatenate([a.ravel() for a in floats]) if floats else np.zeros(0)
        self.params = params

    def copy(self):
        """(buffer, params viewing it): one thread's own copy."""
        buffer = self.base.copy()
        views, start = [], 0
        for shape, writeable in self.shapes:
            size = int(np.prod(shape, dtype=np.int64))
            view = buffer[start:start + size].reshape(shape)
            view.flags.writeable = writeable
            views.append(view)
            start += size
        return buffer, _rebuilt(self.params, views)


def _structure(value) -> list:
    """What of a leaf decides the compiled code and must be equal between runs."""
    if isinstance(value, np.ndarray):
        return [value.dtype.str, value.shape, value.tobytes()]
    return [type(value).__name__, value]


_SIMULATE_DEFAULTS: dict | None = None


def _simulate_arguments(scenario) -> dict:
    """The keyword arguments ``armlab.simulate`` receives from ``scenario``, defaults filled in."""
    global _SIMULATE_DEFAULTS
    from armlab.simulation.simulator import simulate

    if _SIMULATE_DEFAULTS is None:
        _SIMULATE_DEFAULTS = {name: p.default for name, p in inspect.signature(simulate).parameters.items()
                              if p.default is not inspect.Parameter.empty}
    return {**_SIMULATE_DEFAULTS, **scenario.simulation}


CHECKED_VALUES = 10_000
"""Most (field, value) checks a plan remembers: a grid's few values are checked once for the
whole sweep, while drawn values, all distinct, would otherwise pile up in the plan that a
sweep's chunks share (the driver's memory grew by 119 MB over 10⁶ drawn A6 runs)."""


class BatchPlan:
    """The first valid run set up, and where each field's value lands in its inputs."""

    def __init__(self, source: Path, table: dict, fields: list[str], columns: np.ndarray,
                 allow_outside: bool):
        self.source, self.table, self.fields, self.allow_outside = source, table, fields, allow_outside
        self.columns = columns                          # (N, F)
        self.invalid: dict[int, str] = {}
        self._checked: dict[tuple[int, float], str] = {}
        self._holders: dict = {}
        self.computed: dict[int, str] = {}  # field -> the input it reaches through a computation
        self.unprobed: set[int] = set()     # fields of one value in every valid run: not located
        first = self._first_valid()
        self.base_values = columns[first] if first is not None else None
        if first is None:
            return
        self.scenario, self.setup, self.inputs = self._build(self.base_values)
        self._holders = {j: self._holder(j) for j in range(len(fields))}
        self.truth = None
        from armlab.control.adaptive import SlotineLi1DoF, link1_parameters

        if isinstance(self.scenario.controller, SlotineLi1DoF):
            # What Scenario.run adds for the adaptive metrics: the plant's [I, F, G].
            self.truth = link1_parameters(self.scenario.plant).tolist()
        self.patches = [self._probe(j) for j in range(len(fields))]
        taken = {}
        for j, patch in enumerate(self.patches):
            for buffer, offsets in patch:
                for offset in offsets.tolist():
                    other = taken.setdefault((buffer, offset), j)
                    if other != j:
                        raise RolloutUnsupported(source, fields[j], f"lands where {fields[other]} does")
        if self.truth is not None and (any(name == "plant" for patch in self.patches for name, _ in patch)
                                       or "plant" in self.computed.values()):
            raise RolloutUnsupported(source, "plant", "the adaptive metrics compare with the plant's own "
                                     "parameters: a batch of plants runs one by one")

    def for_columns(self, columns: np.ndarray) -> BatchPlan | None:
        """This plan over other runs of the same fields (another chunk of a sweep): the set-up,
        the located fields and the checks made so far are shared, so a chunk costs its runs
        alone (the A7 1 s sweep's chunk of 16 runs: 15 ms, a third of it set-up and probing).
        None if a field this plan could not locate (one value in all its runs) takes another
        value there: that chunk needs its own plan."""
        if self.base_values is None or any(np.any(columns[:, j] != self.base_values[j])
                                           for j in self.unprobed):
            return None
        plan = copy.copy(self)
        plan.columns, plan.invalid = columns, {}
        return plan

    # ------------------------------------------------------------------ building and checks
    def scenario_of(self, values):
        from armlab.scenarios import scenario_from_table

        data = dict(self.table)
        copied = {id(data)}
        for field, value in zip(self.fields, values, strict=True):
            assign(data, field, float(value), copied)
        return scenario_from_table(data, self.source, allow_outside=self.allow_outside)

    def _build(self, values):
        from armlab.simulation.simulator import _Setup

        scenario = self.scenario_of(values)
        kw = _simulate_arguments(scenario)
        if kw["method"] != "rk4" or kw["control_period"] is not None:
            raise RolloutUnsupported(self.source, "simulation.method", "a batch runs RK4 with continuous "
                                     "control (the adaptive method and sampled control run one by one)")
        from armlab.scenarios import ScenarioFileError
        from armlab.simulation import SimulationError

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                setup = _Setup(scenario.plant, scenario.controller, kw["q0"], kw["qd0"], kw["t_final"],
                               kw["dt"], None, kw["torque_limit"], list(scenario.disturbance) or None,
                               scenario.environment, kw["log_every"], kw["limit_margin"],
                               kw["max_kinetic_energy"], kw["dynamics"], kw["joint_limits"])
        except SimulationError as error:
            # As Scenario.run says it: the field as the file writes it.
            field, _, reason = str(error).partition(": ")
            raise ScenarioFileError(scenario.source or scenario.name, f"simulation.{field}", reason) from None
        if setup.python_law is not None:
            raise RolloutUnsupported(self.source, "controller", "a law in plain Python runs one by one")
        cparams = scenario.controller.params()
        inputs = {"controller": _Flat(cparams), "environment": _Flat(setup.eparams),
                  "plant": setup.plant.packed.copy(), "x0": setup.x0.copy(), "lim": setup.lim.copy(),
                  "dist": setup.dist.copy()}
        return scenario, setup, inputs

    def _check(self, j: int, value: float) -> str:
        """'' if field ``j`` may take ``value`` in the first valid run, else why: the checks of
        the object of the scenario file that holds the field (its class, with the annotations
        of its fields), built again with that value; a ``[simulation]`` field, which the
        simulator checks too, builds the whole scenario and its simulation."""
        key = (j, value)
        known = self._checked.get(key)
        if known is None:
            values = self.columns[0].copy() if self.base_values is None else self.base_values.copy()
            values[j] = value
            holder = self._holders.get(j) if self.base_values is not None else None
            if holder is None:
                known = _problem(lambda: self._build(values))
            else:
                known = _problem(lambda: holder(float(value)))
            if len(self._checked) >= CHECKED_VALUES:
                self._checked.clear()
            self._checked[key] = known
        return known

    def _holder(self, j: int):
        """A function building, with field ``j`` at a value, the innermost object of the scenario
        that holds it (a controller, its reference, an environment), or None."""
        from armlab.control.base import Controller, Environment
        from armlab.model.robot import Robot
        from armlab.registry import scenario_types
        from armlab.scenarios.tables import _choose, _fields, arguments, build, construct, read
        from armlab.sweep.fields import _segments

        parts = _segments(self.fields[j])
        bases = {"controller": Controller, "environment": Environment}
        if len(parts) < 2 or parts[0] not in bases or not isinstance(self.table.get(parts[0]), dict):
            return None
        base, node, depth = bases[parts[0]], self.table[parts[0]], 1
        while depth < len(parts) - 1 and isinstance(parts[depth], str):
            cls = _choose(base, node, self.source, ".".join(map(str, parts[:depth]))).cls
            hint = _fields(cls).get(parts[depth], (None,))[0]
            child = node.get(parts[depth])
            if not (isinstance(hint, type) and scenario_types(hint) and isinstance(child, dict)):
                break
            base, node, depth = hint, child, depth + 1
        where = ".".join(map(str, parts[:depth]))
        rest = ".".join(str(p) if isinstance(p, str) else f"[{p}]" for p in parts[depth:]).replace(".[", "[")
        plant, tip = self.table.get("plant"), self.table.get("plant_tip")

        def holder(value):
            table = dict(node)
            assign(table, rest, value, {id(table)})
            return build(base, table, self.source, where, plant=plant, plant_tip=tip,
                         allow_outside=self.allow_outside)

        key = parts[depth] if depth < len(parts) else None
        declaration = _choose(base, node, self.source, where)
        hint = _fields(declaration.cls).get(key, (None,))[0]
        if key not in node or hint is None or hint is Robot or declaration.poses:
            return holder
        # The holder's other fields read once (a value is checked with them at the first valid
        # run's, as the full build above would read them), its own field read per value: the
        # same messages at a tenth of the cost (a reference's expressions and the robot are not
        # read again; 2000 distinct gains of the A7 sweep took 0.2 s of its 0.6 s).
        known: dict = {}

        def fast_holder(value):
            if not known:
                known.update(arguments(declaration, node, self.source, where, plant, tip, self.allow_outside,
                                       skip=key))
            entry = {key: node[key]}
            assign(entry, rest, value, {id(entry)})
            given = dict(known)
            given[key] = read(hint, entry[key], self.source, f"{where}.{key}", plant, tip)
            return construct(declaration, given, self.source, where)

        return fast_holder

    def _first_valid(self):
        """Index of the first run whose values all pass (each run's problem kept in ``invalid``)."""
        for i, row in enumerate(self.columns):
            bad = next((j for j, v in enumerate(row) if not math.isfinite(v)), None)
            if bad is not None:
                self.invalid[i] = (f"{self.source}: {self.fields[bad]}: {float(row[bad])!r} is not a "
                                   "finite number")
                continue
            problem = _problem(lambda row=row: self.scenario_of(row))
            if not problem:
                return i
            self.invalid[i] = problem
        return None

    def problem(self, i: int) -> str:
        """'' if run ``i``'s values pass their checks, else the first field's message (in field
        order, as the scenario loader meets them)."""
        known = self.invalid.get(i)
        if known is not None:
            return known
        for j, value in enumerate(self.columns[i].tolist()):
            if not math.isfinite(value):
                return f"{self.source}: {self.fields[j]}: {value!r} is not a finite number"
            if j in self.computed:
                continue                # checked by building the run's object (computed_numbers)
            problem = self._check(j, value)
            if problem:
                return problem
        return ""

    # ------------------------------------------------------------------ probing
    def _flat_inputs(self, inputs) -> dict:
        return {"controller": inputs["controller"].base, "environment": inputs["environment"].base,
                "plant": inputs["plant"], "x0": inputs["x0"], "lim": inputs["lim"], "dist": inputs["dist"]}

    def _probe(self, j: int) -> list[tuple[str, np.ndarray]]:
        """[(buffer, offsets)] where field ``j``'s value is copied (module docstring)."""
        field = self.fields[j]
        column = self.columns[:, j]
        others = [float(v) for v in np.unique(column[np.isfinite(column)]) if v != self.base_values[j]]
        valid = (v for v in others if not self._check(j, v))      # checked lazily: two are enough
        others = list(itertools.islice(valid, 2))
        if not others:
            self.unprobed.add(j)
            return []                                   # one value in every valid run
        base = self._flat_inputs(self.inputs)
        patch = None
        for value in others:
            values = self.base_values.copy()
            values[j] = value
            _, setup, inputs = self._build(values)
            reason = self._same_structure(setup, inputs)
            if reason:
                raise RolloutUnsupported(self.source, field, reason)
            found = []
            for name, probe in self._flat_inputs(inputs).items():
                offsets = np.flatnonzero(probe != base[name])
                if offsets.size and not (np.all(probe[offsets] == value)
                                         and np.all(base[name][offsets] == self.base_values[j])):
                    root, reason = self._computed_root(j, inputs)
                    if root is None:
                        raise RolloutUnsupported(self.source, field, reason)
                    self.computed[j] = root
                    return []
                if offsets.size:
                    found.append((name, offsets))
            where = [(name, offsets.tolist()) for name, offsets in found]
            if patch is not None and [(name, offsets.tolist()) for name, offsets in patch] != where:
                raise RolloutUnsupported(self.source, field, "lands in different places for different values")
            patch = found
        return patch

    # ------------------------------------------------------------------ computed fields
    def _computed_root(self, j: int, inputs) -> tuple[str | None, str]:
        """(the input, '') that field ``j`` (probed to ``inputs``) reaches through a computation,
        when a run's value of it can be built alone: "controller" for a field of the file's
        controller that changes nothing but its parameters; "plant" for a mass of the plant
        (``plant_link_mass.<link>``) that changes nothing but the plant's model, read by the
        numeric kernels (a closed form holds the numbers it was made for).  Else (None, why not)."""
        from armlab.sweep.fields import _segments

        base = self._flat_inputs(self.inputs)
        changed = {name for name, probe in self._flat_inputs(inputs).items() if np.any(probe != base[name])}
        root = _segments(self.fields[j])[0]
        if (root == "controller" and isinstance(self.table.get("controller"), dict)
                and changed == {"controller"}):
            return "controller", ""
        if root == "plant_link_mass" and changed == {"plant"}:
            if self.setup.dynamics == "numeric":
                return "plant", ""
            return None, "the first run's plant runs a closed form, made for its own masses: runs one by one"
        return None, ("its value reaches the compiled inputs through a computation (not as a copy) outside "
                      "the controller's parameters and the plant's masses: runs one by one")

    def computed_roots(self) -> list[str]:
        """The inputs that computed fields reach, in the order of :meth:`computed_numbers`."""
        return [root for root in ("controller", "plant") if root in self.computed.values()]

    def computed_numbers(self, i: int) -> tuple[np.ndarray | None, str]:
        """(the buffers of :meth:`computed_roots` for run ``i``, concatenated, '') built from the
        scenario file with all of the run's fields of each, as the scenario loader builds them;
        (None, why) if a build refuses a value; (None, '') if the run differs in structure from
        the first valid run (another compiled law or model, or a plant whose closed form is on
        disk): that run runs on its own."""
        parts = []
        for root in self.computed_roots():
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    part = self._controller_buffer(i) if root == "controller" else self._plant_model(i)
            except (ArmlabError, ValueError, ArithmeticError) as error:
                return None, " ".join(str(error).split())
            if part is None:
                return None, ""
            parts.append(part)
        return np.concatenate(parts), ""

    def _run_table(self, i: int, key: str) -> dict:
        """The file's table ``key`` with run ``i``'s values of the fields under it."""
        data = {key: dict(self.table.get(key, {}))}
        copied = {id(data), id(data[key])}
        for j, field in enumerate(self.fields):
            if field.startswith(key + "."):
                assign(data, field, float(self.columns[i, j]), copied)
        return data[key]

    def _controller_buffer(self, i: int) -> np.ndarray | None:
        from armlab.control.base import Controller
        from armlab.scenarios.tables import build

        built = build(Controller, self._run_table(i, "controller"), self.source, "controller",
                      plant=self.table.get("plant"), plant_tip=self.table.get("plant_tip"),
                      allow_outside=self.allow_outside)
        flat, first = _Flat(built.params()), self.inputs["controller"]
        if flat.shapes != first.shapes or [_structure(v) for v in flat.others] != [
                _structure(v) for v in first.others]:
            return None
        return flat.base

    def _plant_model(self, i: int) -> np.ndarray | None:
        from armlab.scenarios.tables import robot
        from armlab.specialise import plant_kernels

        plant = robot(self.table["plant"], self._run_table(i, "plant_link_mass"), self.source, "plant",
                      self.table.get("plant_tip"), self.allow_outside)
        kind = plant_kernels(plant, _simulate_arguments(self.scenario)["dynamics"])[0]
        if kind != "numeric" or plant.packed.shape != self.inputs["plant"].shape:
            return None
        return plant.packed

    def _same_structure(self, setup, inputs) -> str:
        first = self.setup
        if (setup.n_steps, setup.log_every, setup.rows, setup.k, setup.sig_width) != (
                first.n_steps, first.log_every, first.rows, first.k, first.sig_width):
            return "changes the run's length, logging or signals"
        if (not np.array_equal(setup.layout, first.layout)
                or type(setup.controller) is not type(first.controller)):
            return "changes what the run logs"
        for name in ("controller", "environment"):
            mine, theirs = inputs[name], self.inputs[name]
            if mine.shapes != theirs.shapes or [_structure(v) for v in mine.others] != [
                    _structure(v) for v in theirs.others]:
                return f"changes the structure of the {name}'s parameters"
        for name in ("plant", "x0", "lim", "dist"):
            if inputs[name].shape != self.inputs[name].shape:
                return f"changes the size of {name}"
        return ""


def _problem(build) -> str:
    """'' if ``build()`` succeeds, else its one-line message (as a sweep's invalid run says)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            build()
    except (ArmlabError, ValueError, ArithmeticError) as error:
        return " ".join(str(error).split())
    return ""
