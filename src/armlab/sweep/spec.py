"""Sweep files: which scenario, which of its fields vary, over which values (``docs/sweeps.md``).

A sweep file is TOML::

    title = "A7: settling time against ω_n, with and without saturation"
    scenario = "a7_id_high_gain"     # bundled name, or a .toml file relative to this file
    seed = 1                         # random draws (see below)
    runs = 200                       # draws per grid point; only with [random]
    chunk_size = 16                  # runs per task and per Parquet file (default: automatic)

    [set]                            # literal values of fields, the same in every run
    "simulation.t_final" = 1.0

    [grid]                           # cartesian product of axes
    omega_n = { linspace = [5, 60, 12] }            # a bare name: a variable
    "simulation.torque_limit" = { values = [20, inf] }   # a dotted field path

    [zip]                            # axes of one length, varied together (one more product axis)

    [random]                         # seeded draws
    mismatch = { uniform = [-0.3, 0.3] }            # also normal = [μ, σ], log_uniform = [a, b]
    delta = { normal = [0, 0.1], within = [-0.2, 0.2] }   # truncated; also lognormal = [μ, σ] of ln x

    [derived]                        # fields computed from the variables of each run
    "controller.kp" = "omega_n**2"
    "controller.kd" = "2*omega_n"

A field path names a key of the scenario file as tables joined by dots, with ``[i]`` for an
element of an array: ``controller.kp``, ``controller.model_link_mass.link4`` (the controller's
model apart from the plant's: model mismatch), ``plant_link_mass.link4``, ``simulation.q0[1]``,
``controller.reference.value[2]``, ``environment.stiffness[1]``, ``simulation.torque_limit``.
Each run's values are written into a copy of the scenario's tables, which the scenario loader
reads with its own field readers: a value it refuses makes that run ``invalid`` with the
loader's one-line message; it never stops the sweep.

Runs are numbered i = 0 … N−1 with N = (product of the grid axis lengths) × (zip length) ×
``runs``; the grid's last axis varies fastest, then the zip, then the draw.  The random values
of run i come from ``numpy.random.SeedSequence(seed, spawn_key=(i,))`` in the order the
``[random]`` table lists them: they depend on the sweep seed and the run index only, never on
the executor, the workers or the chunking.  Every problem of the file is one line
``<file>: <field>: <what is wrong>`` (:class:`SweepFileError`).

This module reads the file and holds the checked :class:`SweepSpec`; an axis and its draws are
:mod:`armlab.sweep.axes`, field paths and their writing into a scenario's tables
:mod:`armlab.sweep.fields`.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armlab.errors import ArmlabError, FieldPathError, ScenarioFileError, SweepFileError
from armlab.model.toml_io import evaluate_expression
from armlab.sweep.axes import MAX_RUNS, Axis, _count, _grid_axis, _random_axis, draw_value
from armlab.sweep.fields import _PATH, _is_field, assign

TOP_KEYS = {"title", "description", "scenario", "seed", "runs", "chunk_size", "set", "grid", "zip", "signals",
            "random", "derived", "plot", "cluster"}


@dataclass(frozen=True)
class SweepSpec:
    """A checked sweep file.  ``scenario_table`` is the scenario's parsed TOML (each run edits a
    copy), ``scenario_file`` its path (messages, relative robot files)."""

    name: str
    title: str
    description: str
    source: str
    scenario_file: str
    scenario_table: dict
    seed: int
    draws: int
    chunk_size: int
    fixed: tuple[tuple[str, object], ...]
    grid: tuple[Axis, ...]
    zipped: tuple[Axis, ...]
    random: tuple[Axis, ...]
    derived: tuple[tuple[str, str], ...]
    plots: tuple[dict, ...] = ()
    cluster: tuple[tuple[str, object], ...] = ()
    signals: tuple[str, ...] = ()
    signals_every: int = 10
    allow_outside: bool = False   # robot files outside the scenario's folder may be read

    # ------------------------------------------------------------------ size and layout
    @property
    def zip_length(self) -> int:
        return len(self.zipped[0].values) if self.zipped else 1

    @property
    def n_runs(self) -> int:
        return math.prod(len(a.values) for a in self.grid) * self.zip_length * self.draws

    @property
    def n_chunks(self) -> int:
        return -(-self.n_runs // self.chunk_size)

    def chunk_runs(self, chunk: int) -> range:
        return range(chunk * self.chunk_size, min((chunk + 1) * self.chunk_size, self.n_runs))

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The table's parameter columns: every swept axis, then every derived field."""
        return tuple(a.key for a in self.grid + self.zipped + self.random) + tuple(k for k, _ in self.derived)

    def fingerprint(self) -> str:
        """A digest of everything that decides the runs and their chunks (resume checks it)."""
        text = json.dumps([self.scenario_table, self.seed, self.draws, self.chunk_size, self.fixed,
                           [(a.key, a.values, a.kind, a.bounds, *(() if a.within is None else (a.within,)))
                            for a in self.grid + self.zipped + self.random],
                           self.derived, [len(self.grid), len(self.zipped)], self.signals,
                           self.signals_every], sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    # ------------------------------------------------------------------ one run
    def parameters(self, index: int) -> dict:
        """{column: value} of run ``index``: its axis values and derived fields (a derived
        expression that fails gives NaN; the run is then invalid, see :meth:`table`)."""
        if not 0 <= index < self.n_runs:
            raise IndexError(f"run {index} of a sweep of {self.n_runs}")
        values = {}
        rest, draw = divmod(index, self.draws)
        rest, position = divmod(rest, self.zip_length)
        for axis in reversed(self.grid):
            rest, k = divmod(rest, len(axis.values))
            values[axis.key] = axis.values[k]
        values = dict(reversed(values.items()))
        for axis in self.zipped:
            values[axis.key] = axis.values[position]
        if self.random:
            rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(index,)))
            for axis in self.random:
                values[axis.key] = draw_value(rng, axis)
        del draw  # the draw number only selects the seed, through the run index
        variables = {k: v for k, v in values.items() if not _is_field(k) and isinstance(v, float)}
        for key, expression in self.derived:
            try:
                values[key] = evaluate_expression(expression, variables)
            except (ValueError, ArithmeticError, TypeError):
                values[key] = math.nan
        return values

    def table(self, index: int) -> tuple[dict, dict]:
        """(parameters, scenario table) of run ``index``: a copy of the scenario's tables with
        the fixed and swept field values written in."""
        values = self.parameters(index)
        # A shallow copy, and copies of each table and array on the way to an assigned field:
        # what is assigned never reaches the shared scenario table (much cheaper than a deep copy).
        data = dict(self.scenario_table)
        copied: set[int] = {id(data)}
        for key, value in self.fixed:
            assign(data, key, value, copied)
        for key, value in values.items():
            if _is_field(key):
                assign(data, key, value, copied)
        return values, data


# ---------------------------------------------------------------------- reading the file

def _key(key, file, where) -> str:
    if not (_PATH.fullmatch(key)):
        raise SweepFileError(file, where, "expected a variable name or a field path such as "
                                          "controller.kp or environment.stiffness[1]")
    return key


def _table(data, name, file) -> dict:
    value = data.get(name, {})
    if not isinstance(value, dict):
        raise SweepFileError(file, name, "expected a table")
    return value


def read_sweep_toml(path: Path) -> dict:
    """The parsed TOML of a sweep file (a regular file of bounded size, ``armlab.inputs``)."""
    from armlab.inputs import read_input_toml

    return read_input_toml(path, SweepFileError)


def load_sweep_file(path, *, allow_outside: bool = False) -> SweepSpec:
    """Read and check a sweep file (see the module docstring).  A scenario file it names, and
    the robot files that scenario names, must lie under the folder of the file that names them
    unless ``allow_outside`` (:mod:`armlab.model.references`)."""
    from armlab.model.references import is_under
    from armlab.scenarios import read_scenario_toml, scenario_path

    path = Path(path)
    data = read_sweep_toml(path)
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise SweepFileError(path, unknown[0], f"unknown key (use {', '.join(sorted(TOP_KEYS))})")
    if "scenario" not in data:
        raise SweepFileError(path, "scenario", "missing")
    if not isinstance(data["scenario"], str):
        raise SweepFileError(path, "scenario", f"expected a scenario name or file, got {data['scenario']!r}")
    try:
        name = data["scenario"]
        relative = path.parent / name
        scenario_file = scenario_path(relative if name.endswith(".toml") and not Path(name).is_absolute()
                                      else name)
        if name.endswith(".toml") and not allow_outside and not is_under(scenario_file,
                                                                         path.absolute().parent.resolve()):
            raise SweepFileError(path, "scenario", f"the scenario file {name!r} lies outside the sweep "
                                 "file's folder (allow_outside=True or --allow-outside reads it)")
        scenario_table = read_scenario_toml(scenario_file)
    except ScenarioFileError as error:
        raise SweepFileError(path, "scenario", str(error)) from None
    for key in ("title", "description"):
        if not isinstance(data.get(key, ""), str):
            raise SweepFileError(path, key, "expected a string")
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise SweepFileError(path, "seed", f"expected an integer ≥ 0, got {seed!r}")
    random_table = _table(data, "random", path)
    if "runs" in data and not random_table:
        raise SweepFileError(path, "runs", "draws need a [random] table")
    if random_table and "runs" not in data:
        raise SweepFileError(path, "runs", "missing: the number of random draws")
    draws = _count(data.get("runs", 1), path, "runs")
    grid = tuple(_grid_axis(_key(k, path, f"grid.{k}"), v, path, f"grid.{k}")
                 for k, v in _table(data, "grid", path).items())
    zipped = tuple(_grid_axis(_key(k, path, f"zip.{k}"), v, path, f"zip.{k}")
                   for k, v in _table(data, "zip", path).items())
    if len({len(a.values) for a in zipped}) > 1:
        raise SweepFileError(path, "zip", "its axes must have one length, got "
                             + ", ".join(f"{a.key}: {len(a.values)}" for a in zipped))
    random = tuple(_random_axis(_key(k, path, f"random.{k}"), v, path, f"random.{k}")
                   for k, v in random_table.items())
    fixed = tuple((_key(k, path, f"set.{k}"), v) for k, v in _table(data, "set", path).items())
    for key, _ in fixed:
        if not _is_field(key):
            raise SweepFileError(path, f"set.{key}", "expected a field path such as simulation.t_final")
    derived = []
    for key, expression in _table(data, "derived", path).items():
        _key(key, path, f"derived.{key}")
        if not _is_field(key):
            raise SweepFileError(path, f"derived.{key}", "expected a field path such as controller.kp")
        if not isinstance(expression, str):
            raise SweepFileError(path, f"derived.{key}", "expected an expression string of the variables")
        derived.append((key, expression))
    keys = [a.key for a in grid + zipped + random] + [k for k, _ in fixed] + [k for k, _ in derived]
    seen = set()
    for key in keys:
        if key in seen:
            raise SweepFileError(path, key, "is set twice")
        seen.add(key)
    runs_total = math.prod(len(a.values) for a in grid) * (len(zipped[0].values) if zipped else 1) * draws
    if runs_total > MAX_RUNS:
        raise SweepFileError(path, "grid", f"{runs_total} runs: more than {MAX_RUNS}")
    chunk_size = _count(data.get("chunk_size", default_chunk_size(runs_total)), path, "chunk_size")
    plots = data.get("plot", [])
    if not isinstance(plots, list) or not all(isinstance(p, dict) for p in plots):
        raise SweepFileError(path, "plot", "expected an array of tables [[plot]]")
    signals, every = _signals(_table(data, "signals", path), path)
    cluster = _table(data, "cluster", path)
    for key, value in cluster.items():
        if key not in ("scheduler", "workers", "threads", "processes"):
            raise SweepFileError(path, f"cluster.{key}",
                                 "unknown key (use processes, scheduler, threads, workers)")
        if key == "scheduler" and not isinstance(value, str):
            raise SweepFileError(path, "cluster.scheduler", f"expected an address, got {value!r}")
        if key != "scheduler":
            _count(value, path, f"cluster.{key}")
    spec = SweepSpec(name=path.stem, title=data.get("title", path.stem),
                     description=data.get("description", ""),
                     source=str(path), scenario_file=str(scenario_file), scenario_table=scenario_table,
                     seed=seed, draws=draws, chunk_size=chunk_size, fixed=fixed, grid=grid, zipped=zipped,
                     random=random, derived=tuple(derived), plots=tuple(plots),
                     signals=signals, signals_every=every,
                     cluster=tuple(cluster.items()), allow_outside=allow_outside)
    _check_against_scenario(spec, path)
    return spec


BASE_SIGNALS = ("q", "qd", "qdd", "tau", "z")


def _signals(table: dict, path) -> tuple[tuple[str, ...], int]:
    """The ``[signals]`` table: ``names`` (signals of each run to keep) and ``every`` (keep
    every m-th sample)."""
    unknown = sorted(set(table) - {"names", "every"})
    if unknown:
        raise SweepFileError(path, f"signals.{unknown[0]}", "unknown key (use every, names)")
    if not table:
        return (), 10
    names = table.get("names")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise SweepFileError(path, "signals.names",
                             "expected an array of signal names such as [\"q\", \"tau\"]")
    if len(set(names)) != len(names):
        raise SweepFileError(path, "signals.names", "names a signal twice")
    return tuple(names), _count(table.get("every", 10), path, "signals.every", high=10**6)


def default_chunk_size(n_runs: int) -> int:
    """Runs per chunk when the file does not say: about 64 chunks, from 1 to 256 runs each
    (a function of the sweep only, so that a resumed sweep finds the same chunks)."""
    return max(1, min(256, -(-n_runs // 64)))


def _check_against_scenario(spec: SweepSpec, path: Path) -> None:
    """Every field path fits the scenario's tables, every derived expression names known
    variables, and the scenario's loader knows every swept key (checked on run 0, whose
    values may still be refused: that run is then invalid, not the file)."""
    from armlab.scenarios import scenario_from_table

    variables = {a.key for a in spec.grid + spec.zipped + spec.random if not a.is_field}
    for key, expression in spec.derived:
        try:
            evaluate_expression(expression, dict.fromkeys(variables, 1.0))
        except (ValueError, SyntaxError) as error:
            raise SweepFileError(path, f"derived.{key}",
                                 f"cannot evaluate {expression!r} ({error})") from None
        except ArithmeticError:
            pass
    where = {a.key: f"grid.{a.key}" for a in spec.grid} | {a.key: f"zip.{a.key}" for a in spec.zipped}
    where |= {a.key: f"random.{a.key}" for a in spec.random} | {k: f"set.{k}" for k, _ in spec.fixed}
    where |= {k: f"derived.{k}" for k, _ in spec.derived}
    for key, label in where.items():
        if _is_field(key):
            try:
                assign(copy.deepcopy(spec.scenario_table), key, 0.0)
            except FieldPathError as error:
                raise SweepFileError(path, label, f"does not fit {spec.scenario_file}: {error}") from None
    if spec.n_runs == 0:
        raise SweepFileError(path, "grid", "no runs (an axis is empty)")
    try:
        _, table = spec.table(0)
        scenario = scenario_from_table(table, spec.scenario_file, allow_outside=spec.allow_outside)
    except ScenarioFileError as error:
        for key, label in where.items():
            if _is_field(key) and error.reason.startswith(("unknown key", "no such link")) and (
                    error.field == key or key.startswith(error.field + ".")):
                raise SweepFileError(path, label,
                                     f"the scenario has no such field ({error.reason})") from None
        return
    except (ArmlabError, FieldPathError):
        return
    known = set(BASE_SIGNALS) | {s.name for s in scenario.controller.signals()}
    known |= {"tau_cmd", "tau_dist", "h_e"}  # logged when a run has a limit, disturbances, contact
    for name in spec.signals:
        if name not in known:
            raise SweepFileError(path, "signals.names", f"{name!r} is not a signal of this scenario "
                                                        f"(use {', '.join(sorted(known))})")


def _bundled_files() -> dict[str, Path]:
    from importlib import resources

    folder = Path(str(resources.files("armlab.sweep"))) / "files"
    return {path.stem: path for path in sorted(folder.glob("*.toml"))}


def bundled_sweep_names() -> list[str]:
    """Names of the sweep files shipped with armlab."""
    return sorted(_bundled_files())


def sweep_path(name_or_path) -> Path:
    """A bundled sweep's file by name, else ``name_or_path`` as a .toml file."""
    text = str(name_or_path)
    bundled = _bundled_files()
    if text in bundled:
        return bundled[text]
    path = Path(text)
    if path.suffix.lower() != ".toml":
        raise SweepFileError(text, "name", "not a bundled sweep (see `armlab sweep --list`) nor a .toml file")
    return path


def load_sweep(name_or_path, *, allow_outside: bool = False) -> SweepSpec:
    """A bundled sweep by name or a sweep file, read and checked (``allow_outside`` as for
    :func:`load_sweep_file`)."""
    return load_sweep_file(sweep_path(name_or_path), allow_outside=allow_outside)
