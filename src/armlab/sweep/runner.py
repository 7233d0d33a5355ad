"""Running a sweep: chunks of runs on local threads or on a Dask cluster, rows to Parquet.

A chunk (``SweepSpec.chunk_runs``) is the smallest unit of work and of storage; a task runs
some consecutive chunks as one batch (:func:`run_chunks`, as many as take about
:data:`TASK_SECONDS`, :func:`batch_size`) and its rows are written as one file.  Each run's
values depend on the sweep and the run index only, so the table is the same, bit for bit,
whichever executor, number of workers, task sizes or order of completion produced it.  The
driver keeps a bounded number of tasks in flight and writes each finished task at once
(``armlab.sweep.store``): its memory does not grow with the number of runs.

Executors:

* local processes (``processes=N``): a pool of N spawned worker processes, nothing shared;
  each loads the compiled code from numba's disk cache once.  For many short runs.
* local threads (``threads=N``; with no executor chosen, below :data:`PROCESS_RUNS` runs: one
  per core for long runs, one for short ones, :func:`default_executor`).  The compiled loop
  releases the GIL, so the runs of different threads overlap; each run's set-up (reading its
  tables, the controller's parameters, the metrics) is Python and holds it.
* Dask (``scheduler="tcp://host:8786"`` for a running cluster, or ``workers=N`` to start a
  local cluster of N single-threaded worker processes).  A worker loads the compiled loop and
  laws from numba's disk cache the first time it needs them and keeps them for every later
  task.  A task lost with its worker is run again elsewhere by Dask; its chunks are written
  once, by the driver, when a result arrives.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import time
from dataclasses import dataclass

from armlab.errors import ArmlabError, SchedulerAddressError, SweepFileError
from armlab.sweep.address import address_problem
from armlab.sweep.metrics import METRIC_NAMES, measure
from armlab.sweep.rollout import SIGNALS, batch_problem, decimated, sweep_rows
from armlab.sweep.spec import SweepSpec, load_sweep
from armlab.sweep.store import SweepStore, read_results


def run_one(spec: SweepSpec, index: int) -> dict:
    """The table row of run ``index``: parameters, status, diagnosis and metrics."""
    from armlab.scenarios import scenario_from_table
    from armlab.simulation import SimulationDiverged

    values, table = spec.table(index)
    row = {"run": index, **values, "status": "ok", "diagnosis": "", **dict.fromkeys(METRIC_NAMES, math.nan)}
    for key, expression in spec.derived:
        if not math.isfinite(values[key]):
            return {**row, "status": "invalid",
                    "diagnosis": f"{spec.source}: derived.{key}: {expression!r} gives no finite number"}
    try:
        result = scenario_from_table(table, spec.scenario_file, allow_outside=spec.allow_outside).run()
    except SimulationDiverged as error:
        result = error.result
    except (ArmlabError, ValueError, ArithmeticError) as error:
        return {**row, "status": "invalid", "diagnosis": " ".join(str(error).split())}
    row.update(measure(result))
    row["status"], row["diagnosis"] = result.status, result.diagnosis
    if spec.signals:
        row[SIGNALS] = decimated(result, spec.signals, spec.signals_every, index)
    return row


def run_chunk(spec: SweepSpec, chunk: int) -> dict[str, list]:
    """The rows of chunk ``chunk`` as columns ``{name: [values]}``."""
    return run_chunks(spec, range(chunk, chunk + 1))


def run_chunks(spec: SweepSpec, chunks: range) -> dict[str, list]:
    """The rows of the consecutive ``chunks`` as columns ``{name: [values]}``, their runs set
    up as one batch when they differ only in numbers (``armlab.sweep.rollout``; the same rows
    as one by one: a batch's set-up costs ~2.4 ms whatever its size, 1000 1 s A7 runs 0.51 ms
    a run in batches of 25, 0.42 ms in batches of 125)."""
    names = ("run", *spec.parameter_names, "status", "diagnosis", *METRIC_NAMES)
    columns = {name: [] for name in names}
    signals = []
    runs = range(spec.chunk_runs(chunks[0]).start, spec.chunk_runs(chunks[-1]).stop)
    rows = sweep_rows(spec, runs)
    if rows is None:
        rows = [run_one(spec, index) for index in runs]
    for row in rows:
        for name in names:
            columns[name].append(row[name])
        if SIGNALS in row:
            signals.append(row[SIGNALS])
    if spec.signals:
        columns[SIGNALS] = _concatenate(signals)
    return columns


def _concatenate(parts: list[dict]) -> dict:
    """One column set of the runs' signal columns; a column some runs lack is NaN there."""
    import numpy as np

    names = list(dict.fromkeys(name for part in parts for name in part))
    return {name: np.concatenate([part[name] if name in part else np.full(part["t"].size, np.nan)
                                  for part in parts]) if parts else np.zeros(0) for name in names}


@dataclass(frozen=True)
class SweepOutcome:
    """What a finished (or interrupted) sweep left in ``folder``."""

    folder: str
    n_runs: int
    counts: dict
    executor: str
    seconds: float

    def table(self):
        """The results (``pyarrow.Table``, one row per run, sorted by run)."""
        return read_results(self.folder)

    def to_pandas(self):
        return self.table().to_pandas()


def _progress(total: int, initial: int, label: str, enabled: bool):
    """The sweep's bar on stderr (rate and ETA); in a log, a line every 10 s."""
    from armlab.progress import progress_bar

    return progress_bar(total, enabled=enabled, log_every=10.0, initial=initial, unit="run", desc=label,
                        smoothing=0.1)


def _local(spec, store, pending, threads, bar, processes=None) -> dict:
    """Tasks on a local pool: ``processes`` worker processes (spawned, so each starts clean
    and loads the compiled code from the disk cache once) if given, else ``threads`` threads."""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, ThreadPoolExecutor, wait

    counts = {}
    if processes:
        threads = processes
        pool = ProcessPoolExecutor(max_workers=processes, mp_context=multiprocessing.get_context("spawn"))
    else:
        pool = ThreadPoolExecutor(max_workers=threads)
    with pool:
        queue, running = list(reversed(pending)), set()
        seconds_per_chunk = None
        try:
            while queue or running:
                while queue and len(running) < 2 * threads:
                    chunks = next_task(queue, batch_size(len(pending), threads, seconds_per_chunk))
                    running.add(pool.submit(run_task, spec, chunks))
                done, running = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    chunks, seconds, columns = future.result()
                    seconds_per_chunk = seconds / len(chunks)
                    _store(store, chunks, columns, counts, bar)
        except BaseException:
            for future in running:
                future.cancel()
            raise
    return counts


def _store(store, chunks, columns, counts, bar):
    store.write(chunks, columns, columns.pop(SIGNALS, None))
    for status in columns["status"]:
        counts[status] = counts.get(status, 0) + 1
    bar.update(len(columns["run"]))


LOCAL_CLUSTER_CONFIG = {
    # Without the workers' statistical profiler (a stack sample of the task's thread every
    # 10 ms, for the dashboard's profile page): on runs whose set-up is Python it cost ~4 %
    # of a 50 000-run sweep (24.2 s against 23.3 s on two workers, alternating).
    "distributed.worker.profile.enabled": False,
    # Without the fixed malloc trim threshold Dask gives its worker processes (64 kB, which
    # returns freed memory to the system at once, and turns off glibc's adaptive thresholds):
    # every run's arrays are then fresh pages from the system.  Ten chunks of 25 1 s A7 runs
    # in one process, median of 15: 0.124-0.130 s without it, 0.137-0.147 s with it.  A
    # sweep's memory is bounded by its tasks in flight, not by what malloc keeps.
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
}
"""The Dask settings of a local cluster a sweep starts (``workers=``); a cluster of your own
runs as fast with the same (``dask.config.set`` before it starts, or the environment
variables of ``docs/sweeps.md``)."""


def _dask_client(scheduler, workers, source, from_file: bool):
    """(client, local cluster or None).  A scheduler address that cannot be used — malformed
    (``junk``, ``[::1``), of a kind Dask does not speak (``http://``) or cannot use here
    (``tls://`` without a security context, ``ucx://`` without UCX), or unreachable — is bad
    input: a :class:`SweepFileError` on ``cluster.scheduler`` when the sweep file gave it, a
    :class:`SchedulerAddressError` when the caller did."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise SweepFileError(source, "cluster", "a Dask executor needs dask.distributed "
                                                 "(pip install 'armlab[cluster]')") from None
    if scheduler:
        # The address is checked before Dask sees it: a client Dask failed to make on a
        # malformed address can leave its event-loop thread behind, and the next client of
        # the process then waits for a loop that never starts.
        problem = address_problem(scheduler)
        try:
            if problem is None:
                return Client(scheduler, timeout="20s"), None
        except (ValueError, TypeError, ImportError, OSError) as error:
            # Dask reports these as plain exceptions of the address's parser or connector.
            problem = " ".join(str(error).split()) or type(error).__name__
        reason = f"cannot use the Dask scheduler {scheduler!r}: {problem}"
        if from_file:
            raise SweepFileError(source, "cluster.scheduler", reason) from None
        raise SchedulerAddressError(reason) from None
    import dask

    with dask.config.set(LOCAL_CLUSTER_CONFIG):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0")
    return Client(cluster), cluster


@contextlib.contextmanager
def _quiet_shutdown():
    """Dask's warnings while a cluster shuts down ("Worker process still alive after 4.0
    seconds, killing": a worker process slow to exit on a loaded machine, which its nanny then
    ends) say nothing about the sweep, whose rows are written by then: its loggers are held to
    errors for the shutdown."""
    loggers = [logging.getLogger(name) for name in ("distributed", "distributed.nanny")]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)


TASK_SECONDS = 0.25
"""How long a task should compute.  Whatever its size, a task costs a batch set-up (~2.4 ms),
a Parquet file written by the driver (~2 ms) and on Dask about 3.5 ms of the driver's CPU
(client and scheduler, on the same cores as the workers when the cluster is local) and a
round trip, so a task runs as many consecutive chunks as fill about this time (1000 1 s A7
runs in 40 chunks on two Dask workers: 0.24 s of driver CPU in 40 tasks of one chunk, 0.11 s
in 8 tasks)."""


TASKS_PER_THREAD = 2
"""And no task runs more than an even share of the sweep among this many tasks per worker
thread: the last tasks end close together, and an interrupted sweep loses at most that share.
(Two rather than four: 1000 1 s A7 runs on two running Dask workers, 0.35-0.38 s against
0.41-0.42 s, the tasks' fixed costs paid half as often.)"""


def batch_size(chunks: int, threads: int, seconds_per_chunk: float | None) -> int:
    """How many consecutive chunks of a sweep of ``chunks`` the next task runs: one while
    no chunk has been timed, then as many as take :data:`TASK_SECONDS`, at most
    1/(:data:`TASKS_PER_THREAD` × ``threads``) of the sweep."""
    if seconds_per_chunk is None:
        return 1
    share = -(-chunks // (TASKS_PER_THREAD * max(1, threads)))
    by_time = int(TASK_SECONDS / seconds_per_chunk) if seconds_per_chunk > 0 else share
    return max(1, min(by_time, share))


def next_task(queue: list[int], size: int) -> range:
    """Up to ``size`` consecutive chunks taken from the end of ``queue`` (pending chunks in
    descending order: the next is last); a gap left by a resumed sweep ends a task."""
    first = last = queue.pop()
    while last - first + 1 < size and queue and queue[-1] == last + 1:
        last = queue.pop()
    return range(first, last + 1)


def run_task(spec: SweepSpec, chunks: range) -> tuple[range, float, dict]:
    """(``chunks``, seconds computing, :func:`run_chunks`'s columns): a task, on a thread, a
    process or a Dask worker; the result names its chunks, so the driver remembers nothing
    per task."""
    start = time.perf_counter()
    columns = run_chunks(spec, chunks)
    return chunks, time.perf_counter() - start, columns


def _dask(spec, store, pending, client, bar) -> dict:
    from distributed import as_completed

    counts = {}
    # The sweep travels inside each task (a sweep pickles to a few kB): a future or scattered
    # copy of it would sit on one worker, and the scheduler, keeping tasks next to their data,
    # gave that worker most of the tasks (1000 1 s A7 runs on two workers: 0.45 against 0.28 s
    # of CPU, and with fewer tasks all of them); scattered data is also lost with its worker.
    threads = max(1, sum(client.nthreads().values()))
    queue = list(reversed(pending))
    fingerprint = spec.fingerprint()
    seconds_per_chunk = None

    def submit():
        chunks = next_task(queue, batch_size(len(pending), threads, seconds_per_chunk))
        return client.submit(run_task, spec, chunks, pure=False,
                             key=f"armlab-sweep-{fingerprint}-{chunks[0]}-{time.time_ns()}")

    # Two tasks a worker thread in flight: a worker finds its next task waiting.
    stream = as_completed([submit() for _ in range(min(2 * threads, len(queue)))])
    for future in stream:
        chunks, seconds, columns = future.result()
        # The latest task's pace sizes the next (a worker's first task, which loads the
        # compiled code, only makes the next few smaller).
        seconds_per_chunk = seconds / len(chunks)
        _store(store, chunks, columns, counts, bar)
        future.release()
        if queue:
            stream.add(submit())
    return counts


PROCESS_RUNS = 2000
"""From this many runs on, a sweep with no executor chosen runs on one local process per core.

Each run's set-up and metrics are Python (about 0.55 ms for a 100-step PD run, against
0.05 ms in the compiled loop) and hold the GIL; processes do not share it.  A spawned process
costs about a second before its first run (importing armlab, loading the compiled code),
which a sweep of a few hundred runs does not earn back (100-step PD runs of the PRP on two
cores: 500 runs 1.2 s on two processes, 0.46 s on one thread; 6000 runs 3.05 s against
3.9 s)."""

THREAD_JOINT_STEPS = 3000
"""Joint-steps (steps × joints) of a run from which a sweep with no executor chosen runs on a
thread per core rather than on one.

The threads overlap only in the compiled loops; the set-ups, which hold the GIL, run one at
a time, and threads that wait for it cost more than they overlap when the loop is short
(PRP PD runs on two cores, ms a run on one thread / on two: 300 joint-steps 0.64 / 0.91,
1500 0.94 / 1.13, 3000 1.20 / 1.13, 6000 1.73 / 1.25, 12000 2.70 / 2.03)."""


def _say_how_runs_run(spec: SweepSpec, log) -> None:
    """One line: whether the runs of a chunk run as one batch, or why each is set up on its own
    (judged on the first runs; a chunk of one run is always its own batch)."""
    problem = batch_problem(spec, range(min(spec.n_runs, 64)))
    print(f"{spec.name}: each run set up on its own ({problem})" if problem else
          f"{spec.name}: the runs of each chunk run as one batch (armlab.rollout)", file=log, flush=True)


def default_executor(spec: SweepSpec) -> tuple[int, int | None]:
    """(threads, processes) of a sweep with no executor chosen: a thread per core when its
    runs run as batches (``armlab.sweep.rollout``: the compiled loop of a whole chunk releases
    the GIL; 10⁵ 100-step A6 runs, 2 cores: 14176 runs/s on two threads, 11836 on two
    processes); else one local process per core from :data:`PROCESS_RUNS` runs on (on a
    machine with several cores), else local threads — one per core for runs of
    :data:`THREAD_JOINT_STEPS` joint-steps or more (those of the first run), one for shorter
    runs."""
    cores = os.cpu_count() or 1
    if cores > 1 and spec.n_runs > 1 and not batch_problem(spec, range(min(spec.n_runs, 64))):
        return cores, None
    if cores > 1 and spec.n_runs >= PROCESS_RUNS:
        return cores, cores
    return (cores if joint_steps(spec) >= THREAD_JOINT_STEPS else 1), None


def joint_steps(spec: SweepSpec) -> int:
    """Steps × joints of the sweep's first run (:data:`THREAD_JOINT_STEPS` if it cannot be
    built: its row will say why)."""
    from armlab.scenarios import scenario_from_table

    try:
        scenario = scenario_from_table(spec.table(0)[1], spec.scenario_file,
                                       allow_outside=spec.allow_outside)
        settings = scenario.simulation
        return scenario.plant.n * round(float(settings["t_final"]) / float(settings["dt"]))
    except (ArmlabError, ValueError, ArithmeticError, LookupError, TypeError):
        return THREAD_JOINT_STEPS


def sweep(spec, out, *, threads: int | None = None, processes: int | None = None,
          workers: int | None = None, scheduler: str | None = None, overwrite: bool = False,
          progress: bool = False,
          log=None) -> SweepOutcome:
    """Run the sweep ``spec`` (a :class:`SweepSpec` or a sweep file) into the folder ``out``.

    Executor: ``scheduler`` (a Dask scheduler address) or ``workers`` (start a local Dask
    cluster of that many processes), else — and unless the file's ``[cluster]`` table says
    otherwise — ``processes`` local worker processes, or ``threads`` local threads.  With none
    of them: one local process per core from :data:`PROCESS_RUNS` runs on, else local threads,
    one per core for long runs and one for short ones (:func:`default_executor`).  Chunks
    already in ``out``
    from an interrupted run of the same sweep are kept (``overwrite`` starts afresh).
    ``progress`` shows a progress bar on stderr; ``log`` (a text stream) gets the executor's
    description and the Dask dashboard address.
    """
    if not isinstance(spec, SweepSpec):
        spec = load_sweep(spec)
    cluster = dict(spec.cluster)
    from_file = scheduler is None and workers is None and threads is None and processes is None
    if from_file:
        scheduler, workers = cluster.get("scheduler"), cluster.get("workers")
        threads, processes = cluster.get("threads"), cluster.get("processes")
    if scheduler is None and workers is None and threads is None and processes is None:
        threads, processes = default_executor(spec)
    for name, value in (("threads", threads), ("processes", processes), ("workers", workers)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
            raise SweepFileError(spec.source, f"cluster.{name}",
                                 f"expected a positive integer, got {value!r}")
    if scheduler is not None and not isinstance(scheduler, str):
        raise SweepFileError(spec.source, "cluster.scheduler", f"expected an address, got {scheduler!r}")
    store = SweepStore(out, spec)
    completed = store.open(overwrite=overwrite)
    pending = [c for c in range(spec.n_chunks) if c not in completed]
    done_runs = sum(len(spec.chunk_runs(c)) for c in completed)
    start = time.perf_counter()
    if not pending:
        executor, counts = "nothing left to run", {}
    elif scheduler or workers:
        client, local_cluster = _dask_client(scheduler, workers, spec.source, from_file)
        executor = f"dask {client.scheduler.address}"
        try:
            if log is not None:
                print(f"{spec.name}: {spec.n_runs} runs in {spec.n_chunks} chunks on {executor} "
                      f"({sum(client.nthreads().values())} worker threads); "
                      f"dashboard {client.dashboard_link}",
                      file=log, flush=True)
                _say_how_runs_run(spec, log)
            bar = _progress(spec.n_runs, done_runs, spec.name, progress)
            try:
                counts = _dask(spec, store, pending, client, bar)
            finally:
                bar.close()
        finally:
            with _quiet_shutdown():
                client.close()
                if local_cluster is not None:
                    local_cluster.close()
    else:
        threads = threads or os.cpu_count() or 1
        executor = (f"{processes} local processes" if processes
                    else f"{threads} local thread{'s' if threads > 1 else ''}")
        if log is not None:
            print(f"{spec.name}: {spec.n_runs} runs in {spec.n_chunks} chunks on {executor}", file=log,
                  flush=True)
            _say_how_runs_run(spec, log)
        bar = _progress(spec.n_runs, done_runs, spec.name, progress)
        try:
            counts = _local(spec, store, pending, threads, bar, processes)
        finally:
            bar.close()
    if completed:
        counts["resumed"] = done_runs
    return SweepOutcome(folder=str(out), n_runs=spec.n_runs, counts=counts, executor=executor,
                        seconds=time.perf_counter() - start)
