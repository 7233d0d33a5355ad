"""Many runs of one scenario that differ only in numbers, in one pass (MuJoCo's ``rollout`` shape).

    table = armlab.rollout("a6_pd_none", {"controller.reference.value[1]": np.linspace(0, 1.5, 1000),
                                          "simulation.t_final": 0.1})

Each key of the batch is a field path of the scenario file (``docs/sweeps.md``), each value a
number or one number per run.  The runs share their structure — controller, robot, signals,
step and duration — so the scenario is set up once, for the first run, and every other run
differs from it only in the numbers the compiled loop reads.  Where each field's value lands
is found by *probing*: the scenario is built again with the field at other values of its
column, and the compiled inputs (the controller's and environment's parameter arrays, the
plant's model, x(0), the torque limits) that change must hold exactly that value (a copy: a gain,
a set point, a stiffness, a limit, q0).  A controller field whose value reaches its
parameters through a computation (a mass of its model: the inertias about the joints), or a
mass of the plant simulated by the numeric kernels, has each run's controller or plant built
from the file and its whole buffer written (a run that differs in structure, another compiled
model, is simulated on its own).  Any other field computed into the inputs or that changes
their structure (a duration, another robot) is not batched: :class:`RolloutUnsupported` says
which and why, and ``armlab sweep`` runs such a sweep run by run.

Checks: every run's values pass the same checks as a scenario file's, applied once per distinct
value of each field (the object of the file that holds the field, built with that value:
``armlab.sweep.plan``); a value that fails makes its runs
``invalid`` with the one-line message, the others run.  Each thread owns its copies of the
inputs and its scratch (one ``work`` array, the loop's data), restored before each run, so every
run computes exactly what its own scenario would: its row of metrics is the single-run path's
to the last bit (``tests/test_rollout.py``), measured by the same ``armlab.sweep.metrics``.
A thread runs its runs :data:`CHUNK` at a time (fewer for long logs) in one compiled call
(``armlab.simulation.loop.rk4_batch``: restore, write the run's numbers, run), which releases
the GIL, then measures them together.
"""

from __future__ import annotations

import math
import os
import threading
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from armlab.errors import FieldPathError, RolloutUnsupported, SweepFileError
from armlab.sweep.fields import assign
from armlab.sweep.metrics import METRIC_NAMES, measure_runs
from armlab.sweep.plan import BatchPlan

__all__ = ["RolloutUnsupported", "rollout"]

CHUNK = 256
"""Most runs a thread computes before measuring them together (see ``_run_part``)."""
CHUNK_BYTES = 4 * 2**20
"""And at most this much log: a chunk's logs stay in the cache while they are measured."""


def _columns(batch: dict, source) -> tuple[list[str], np.ndarray]:
    if not isinstance(batch, dict) or not batch:
        raise SweepFileError(source, "batch", "expected {field path: a number or one number per run}")
    fields, columns, n = [], [], None
    for field, values in batch.items():
        if not isinstance(field, str):
            raise SweepFileError(source, "batch", f"{field!r} is not a field path")
        array = np.asarray(values, dtype=float) if not isinstance(values, str) else None
        if array is None or array.ndim > 1:
            raise SweepFileError(source, field, "expected a number or a 1-D sequence of numbers "
                                                "(one per run)")
        if array.ndim == 1:
            if n is not None and array.size != n:
                raise SweepFileError(source, field, f"has {array.size} values, {fields[0]} {n}")
            n = array.size
        fields.append(field)
        columns.append(array)
    n = 1 if n is None else n
    if n == 0:
        raise SweepFileError(source, fields[0], "no runs")
    return fields, np.stack([np.broadcast_to(c, (n,)) for c in columns], axis=1).astype(float)


def rollout(scenario, batch: dict, *, threads: int | None = None, allow_outside: bool = False,
            keep_results: bool = False) -> dict:
    """Run ``scenario`` (a bundled name, a scenario file, or ``(plant, controller[, settings])``
    with settings the keyword arguments of ``armlab.simulate``: ``armlab.sweep.objects``) once
    per row of ``batch`` (see the module docstring) and return the sweep table's columns:
    ``run``, one column per field, ``status`` ("ok", "diverged", "invalid"), ``diagnosis`` and every metric of
    ``armlab.sweep.metrics`` (NumPy arrays, or lists for the texts).  ``threads`` (default: the
    number of cores) run the compiled loop side by side.  ``keep_results`` adds ``results``,
    each run's :class:`~armlab.simulation.SimulationResult` (None for an invalid run); without
    it no trajectory outlives its run's metrics."""
    plan = _plan(scenario, batch, allow_outside)
    fields, columns = plan.fields, plan.columns
    n_runs = columns.shape[0]
    out = {"run": np.arange(n_runs)}
    for j, field in enumerate(fields):
        out[field] = columns[:, j].copy()
    status, diagnosis = ["invalid"] * n_runs, [plan.invalid.get(i, "") for i in range(n_runs)]
    metrics = {name: np.full(n_runs, math.nan) for name in METRIC_NAMES}
    results = [None] * n_runs
    if plan.base_values is not None:
        threads = max(1, min(threads or os.cpu_count() or 1, n_runs))
        parts = [list(range(t, n_runs, threads)) for t in range(threads)]
        with ThreadPoolExecutor(max_workers=threads) as pool:
            outcomes = pool.map(lambda part: _run_part(plan, part, keep_results), parts)
            for part, (statuses, diagnoses, values, kept) in zip(parts, outcomes, strict=True):
                for i, state, why, result in zip(part, statuses, diagnoses, kept, strict=True):
                    status[i], diagnosis[i], results[i] = state, why, result
                for name in METRIC_NAMES:
                    metrics[name][part] = values[name]
    out["status"], out["diagnosis"] = status, diagnosis
    out.update(metrics)
    if keep_results:
        for i, result in enumerate(results):
            if result is not None:
                # A batched run's result is made with the first run's set-up: its meta gets the
                # run's own controller (its gains, its reference, its model's name).
                result.meta["controller"] = plan.scenario_of(columns[i]).controller.describe()
        out["results"] = results
    return out


def _plan(scenario, batch: dict, allow_outside: bool) -> BatchPlan:
    """The batch's plan: over a scenario file, or over (plant, controller[, settings])."""
    from armlab.scenarios import read_scenario_toml, scenario_path

    if isinstance(scenario, tuple):
        from armlab.sweep.objects import ObjectPlan

        if len(scenario) not in (2, 3):
            raise SweepFileError("rollout", "scenario", "expected (plant, controller[, settings])")
        plant, controller, settings = (*scenario, {}) if len(scenario) == 2 else scenario
        fields, columns = _columns(batch, f"({getattr(plant, 'name', 'plant')}, {type(controller).__name__})")
        return ObjectPlan(plant, controller, settings, fields, columns)
    source = scenario_path(scenario) if not hasattr(scenario, "source") else Path(scenario.source)
    table = read_scenario_toml(source)
    fields, columns = _columns(batch, source)
    for field in fields:
        try:
            assign(dict(table), field, 0.0, set())
        except FieldPathError as error:
            raise SweepFileError(source, field, str(error)) from None
    return BatchPlan(source, table, fields, columns, allow_outside)


def _run_part(plan: BatchPlan, runs: list[int], keep_results: bool) -> tuple:
    """(statuses, diagnoses, {metric: (len(runs),)}, results or Nones) of ``runs``, checked and
    run on this thread's own copies of the inputs; the runs that end ok are measured together
    from their logs."""
    from armlab.simulation import loop

    setup, inputs = plan.setup, plan.inputs
    cbuf, cparams = inputs["controller"].copy()
    ebuf, eparams = inputs["environment"].copy()
    buffers = {"controller": cbuf, "environment": ebuf, "plant": inputs["plant"].copy(),
               "x0": inputs["x0"].copy(), "lim": inputs["lim"].copy(), "dist": inputs["dist"].copy()}
    bases = {"controller": inputs["controller"].base, "environment": inputs["environment"].base,
             **{name: inputs[name] for name in ("plant", "x0", "lim", "dist")}}
    fn, work, (cparams, cfunctions), (eparams, efunctions) = loop.bind(setup, cparams, eparams)
    core = loop.core_address("rk4")
    fset, iset = setup.settings()
    size = setup.outputs().size
    names = ("controller", "environment", "plant", "x0", "lim", "dist")     # loop.rk4_batch's order
    targets, base = tuple(buffers[name] for name in names), tuple(bases[name] for name in names)
    patch = [(names.index(name), offset, j) for j, field in enumerate(plan.patches)
             for name, offsets in field for offset in offsets.tolist()]
    computed = [(names.index(root), bases[root].size) for root in plan.computed_roots()]
    width = sum(length for _, length in computed)
    if computed:
        # Each run's whole controller buffer or plant model, built from its file, as extra
        # columns of the values; written first, so the copied fields land over them (with the
        # same numbers).
        column, extra = plan.columns.shape[1], []
        for target, length in computed:
            extra += [(target, k, column + k) for k in range(length)]
            column += length
        patch = extra + patch
    patch_target, patch_offset, patch_column = (np.array([p[k] for p in patch], dtype=np.int64)
                                                for k in range(3))
    x = np.empty_like(buffers["x0"])
    # Measured CHUNK runs (at most CHUNK_BYTES of logs) at a time: their logs stay in the cache
    # (10 µs a 100-step run measured by 256, 50 µs by 3000), and a batch holds that much per
    # thread whatever its length (a 1 s A7 sweep: 0.75 s by 256 runs, 0.66 s by 13).
    chunk_runs = max(1, min(CHUNK, CHUNK_BYTES // (8 * size)))
    logs, ends = np.empty((chunk_runs, size)), np.empty((chunk_runs, 4), dtype=np.int64)
    lim_column = [(offset, j) for target, offset, j in patch if target == names.index("lim")]
    statuses, diagnoses, kept = [], [], []
    values_of = {name: [] for name in METRIC_NAMES}
    for first in range(0, len(runs), chunk_runs):
        # Checked here, on the worker threads: this Python overlaps the other threads' loops.
        part = runs[first:first + chunk_runs]
        problems = [plan.problem(i) for i in part]
        alone, numbers = {}, []             # runs that differ in structure; the computed buffers
        if computed:
            for k, i in enumerate(part):
                if not problems[k]:
                    vector, problems[k] = plan.computed_numbers(i)
                    if vector is None and not problems[k]:
                        alone[i] = _run_alone(plan, i, keep_results)
                    elif vector is not None:
                        numbers.append(vector)
        chunk = np.asarray([i for i, why in zip(part, problems, strict=True) if not why and i not in alone],
                           dtype=np.int64)
        values = plan.columns[chunk]
        if computed:
            values = np.hstack([values, np.reshape(numbers, (len(chunk), width))])
        values = np.ascontiguousarray(values)
        loop.rk4_batch(core, fn, cparams, cfunctions, eparams, efunctions, targets, base, work, fset, iset,
                       setup.q_lo, setup.q_hi, x, patch_target, patch_offset, patch_column, values, logs,
                       ends)
        limits = np.repeat(bases["lim"][None, :], len(chunk), axis=0)
        for offset, j in lim_column:
            limits[:, offset] = values[:, j]
        ran = _measured(plan, logs[:len(chunk)], limits, [tuple(row) for row in ends[:len(chunk)].tolist()],
                        keep_results)
        batched = np.array([not why and i not in alone for i, why in zip(part, problems, strict=True)],
                           dtype=bool)
        place = iter(range(len(chunk)))
        columns = {name: np.full(len(part), math.nan) for name in METRIC_NAMES}
        for k, (i, why) in enumerate(zip(part, problems, strict=True)):
            if why:
                statuses.append("invalid")
                diagnoses.append(why)
                kept.append(None)
            elif i in alone:
                state, reason, measured, result = alone[i]
                statuses.append(state)
                diagnoses.append(reason)
                kept.append(result)
                for name in METRIC_NAMES:
                    columns[name][k] = measured[name]
            else:
                r = next(place)
                statuses.append(ran[0][r])
                diagnoses.append(ran[1][r])
                kept.append(ran[3][r])
        for name in METRIC_NAMES:
            columns[name][batched] = ran[2][name]
            values_of[name].append(columns[name])
    metrics = {name: np.concatenate(parts) if parts else np.zeros(0) for name, parts in values_of.items()}
    return statuses, diagnoses, metrics, kept


def _run_alone(plan, i: int, keep_results: bool) -> tuple:
    """(status, diagnosis, {metric: value}, result or None) of run ``i`` simulated on its own,
    as its scenario file alone would run it (its controller's parameters differ in structure
    from the batch's, or its plant has a closed form on disk: another compiled model)."""
    from armlab.simulation import SimulationDiverged

    try:
        result = plan.scenario_of(plan.columns[i]).run()
    except SimulationDiverged as error:
        result = error.result
    return result.status, result.diagnosis, measure_runs([result])[0], result if keep_results else None


def _measured(plan, logs, limits, ends, keep_results: bool):
    """(statuses, diagnoses, {metric: (N,)}, results or Nones) of the runs whose logs and ends
    (status, rows, step, joint) are given; the whole, finite ones measured together."""
    setup = plan.setup
    n = len(ends)
    whole = np.array([status == 0 and rows == setup.rows for status, rows, _, _ in ends], dtype=bool)
    whole &= np.isfinite(logs).all(axis=1)
    statuses, diagnoses, kept = ["ok"] * n, [""] * n, [None] * n
    metrics = {name: np.full(n, math.nan) for name in METRIC_NAMES}
    if whole.any() and not keep_results:
        chosen = np.flatnonzero(whole)
        for name, column in _measure_logs(plan, logs[chosen], limits[chosen]).items():
            metrics[name][chosen] = column
    for r, (status, rows, step, joint) in enumerate(ends):
        if whole[r] and not keep_results:
            continue
        result = _result(plan, logs[r].copy(), limits[r], status, rows, step, joint)
        statuses[r], diagnoses[r] = result.status, result.diagnosis
        kept[r] = result if keep_results else None
        for name, value in measure_runs([result])[0].items():
            metrics[name][r] = value
    return statuses, diagnoses, metrics, kept


def _result(plan, out, limit, status, rows, step, joint):
    """The run's :class:`SimulationResult`, as ``armlab.simulate`` returns it."""
    from armlab.simulation.simulator import _finish

    setup = plan.setup
    meta = {"scenario": plan.scenario.name, "source": str(plan.source)}
    if plan.truth is not None:
        meta["true_parameters"] = plan.truth
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = _finish(setup, setup.result(setup.views(out), rows, "rk4", meta), status, step, joint,
                         "return")
    result.meta["torque_limit"] = limit.tolist()      # this run's, if batched
    return result


def _measure_logs(plan, logs, limits) -> dict:
    """{metric: (N,)} of whole, finite runs from their flat logs (N, size), as ``measure`` of
    each run's result would give them (``armlab.sweep.metrics.measure_alike``; a metric the
    runs have no signal for is left out: NaN)."""
    from armlab.simulation import loop_memory
    from armlab.sweep.metrics import measure_alike

    setup = plan.setup
    R = setup.rows
    columns = loop_memory.log_columns(setup.n, setup.k, setup.layout)

    def block(start, width):
        return np.ascontiguousarray(logs[:, R * start:R * (start + width)].reshape(logs.shape[0], R, width))

    signals, start = {}, columns["sig"].start
    for signal in setup.signals:
        signals[signal.name] = block(start, signal.width)
        start += signal.width
    cmd, _, h_e = (int(flag) for flag in setup.layout[:3])
    if cmd:
        signals["tau_cmd"] = block(columns["tau_cmd"].start, setup.n)
    if h_e:
        signals["h_e"] = block(columns["h_e"].start, 6)
    tau = block(columns["tau"].start, setup.n)
    z = block(columns["z"].start, setup.k)
    t = logs[0, :R].copy()
    return measure_alike(t, tau, limits, signals, z, True, plan.truth)


# ------------------------------------------------------------------------------ sweeps
SIGNALS = "__signals__"
"""The key of a row's (and a chunk's) decimated signals, stored apart from the table."""


def decimated(result, names, every: int, index: int) -> dict:
    """{column: samples} of every ``every``-th sample of the signals ``names`` of a run:
    ``run``, ``t`` and one column ``<signal>.<label>`` per component (a signal the run did not
    log, such as ``tau_cmd`` without a torque limit, has no columns)."""
    keep = slice(0, None, every)
    t = np.asarray(result.t)[keep]
    columns = {"run": np.full(t.size, index, dtype=np.int64), "t": t}
    for name in names:
        data = getattr(result, name) if name in ("q", "qd", "qdd", "tau", "z") else result.signals.get(name)
        if data is None:
            continue
        data = np.asarray(data)[keep]
        for k, label in enumerate(result.labels.get(name, ())[:data.shape[1]] or range(data.shape[1])):
            columns[f"{name}.{label}"] = np.ascontiguousarray(data[:, k])
    return columns


_UNBATCHED: dict[str, RolloutUnsupported] = {}
"""Per sweep fingerprint, why its runs are set up one by one (found once per process)."""
_PLANS: dict[str, BatchPlan] = {}
"""Per sweep fingerprint, the plan of its first chunk, which the later chunks of the process
share (:meth:`BatchPlan.for_columns`); the last few sweeps only."""
_PLANS_LOCK = threading.Lock()


def batch_problem(spec, runs) -> str:
    """'' if the sweep's ``runs`` can run as one batch, else why not (one line)."""
    try:
        _sweep_plan(spec, runs)
    except RolloutUnsupported as error:
        return str(error)
    return ""


def _sweep_plan(spec, runs):
    """(plan, parameters of each run, {run position: derived-field problem}, positions of the
    runs the plan holds) of a sweep's ``runs``."""
    from armlab.sweep.fields import _is_field

    known = _UNBATCHED.get(spec.fingerprint())
    if known is not None:
        raise known
    values = [spec.parameters(i) for i in runs]
    fields = [key for key in values[0] if _is_field(key)]
    table = dict(spec.scenario_table)
    copied = {id(table)}
    for key, value in spec.fixed:
        assign(table, key, value, copied)
    columns = np.array([[row[key] for key in fields] for row in values], dtype=float).reshape(len(values),
                                                                                              len(fields))
    derived = {}
    for r, row in enumerate(values):
        for key, expression in spec.derived:
            if not math.isfinite(row[key]):
                derived[r] = f"{spec.source}: derived.{key}: {expression!r} gives no finite number"
                break
    if not fields:
        raise RolloutUnsupported(spec.source, "sweep", "no field varies")
    keep = [r for r in range(len(values)) if r not in derived]
    known = _PLANS.get(spec.fingerprint())
    plan = known.for_columns(columns[keep]) if known is not None and known.fields == fields else None
    if plan is not None:
        return plan, values, derived, keep
    try:
        plan = BatchPlan(Path(spec.scenario_file), table, fields, columns[keep], spec.allow_outside)
    except RolloutUnsupported as error:
        # Another chunk's values may change the structure where these did not: only a refusal
        # that does not depend on the values is kept for the process.
        if "different places" not in str(error):
            _UNBATCHED[spec.fingerprint()] = error
        raise
    if plan.base_values is not None:
        with _PLANS_LOCK:
            _PLANS[spec.fingerprint()] = plan
            while len(_PLANS) > 8:
                _PLANS.pop(next(iter(_PLANS)))
    return plan, values, derived, keep


def sweep_rows(spec, runs) -> list[dict] | None:
    """The table rows of the sweep's ``runs`` (``armlab.sweep.runner.run_one``'s, to the bit)
    computed as one batch, or None when they cannot be (their structure differs)."""
    runs = list(runs)
    try:
        plan, values, derived, keep = _sweep_plan(spec, runs)
    except RolloutUnsupported:
        return None
    rows = []
    for r, (i, row) in enumerate(zip(runs, values, strict=True)):
        rows.append({"run": i, **row, "status": "invalid", "diagnosis": derived.get(r, ""),
                     **dict.fromkeys(METRIC_NAMES, math.nan)})
    if plan.base_values is None:
        for k, r in enumerate(keep):
            rows[r]["diagnosis"] = plan.invalid[k]
        return rows
    keep_results = bool(spec.signals)
    statuses, diagnoses, metrics, kept = _run_part(plan, list(range(len(keep))), keep_results)
    for k, r in enumerate(keep):
        row = rows[r]
        row.update({name: float(metrics[name][k]) for name in METRIC_NAMES})
        row["status"], row["diagnosis"] = statuses[k], diagnoses[k]
        if keep_results and kept[k] is not None:
            row[SIGNALS] = decimated(kept[k], spec.signals, spec.signals_every, row["run"])
    return rows
