"""Sweeps at scale: runs per second per core, local threads and Dask processes against one
thread, and the driver's memory against the number of runs.

The sweep (:data:`SWEEP`): the A7 high-gain step shortened to :data:`T_FINAL` (100 RK4 steps
of 1 ms), ω_n drawn uniformly in [5, 40] rad/s for each run (K_P = ω_n², K_D = 2ω_n), every
run measured and written to Parquet as ``armlab sweep`` does.

* **one thread**: :data:`SINGLE_RUNS` runs on ``threads=1`` (the steady per-run rate; a
  tenth of the sweep keeps ``make bench`` within minutes);
* **threads**: :data:`RUNS` runs on every core (``threads=None``);
* **Dask**: :data:`RUNS` runs on a local ``dask.distributed`` cluster of one single-threaded
  worker process per core (skipped with a message without the ``cluster`` extra).

Per core: rate / (cores × one-thread rate); target ≥ 0.9 on every executor.  The driver's
memory: its resident set sampled while the sweep runs, at 10 % and at 100 % of the runs;
target: flat (it grows by less than :data:`FLAT_MB` MB while nine tenths of the runs pass).
Before anything is timed, :func:`check_agreement` checks that every executor writes the same
table, bit for bit (also run by the test suite on a few runs).

Run: ``python benchmarks/bench_sweep.py`` or ``make bench``.  ``ARMLAB_BENCH_SWEEP_RUNS``
changes :data:`RUNS`.
"""

from __future__ import annotations

import math
import os
import tempfile
import threading
import time
from pathlib import Path

RUNS = int(os.environ.get("ARMLAB_BENCH_SWEEP_RUNS", 100_000))
SINGLE_RUNS = max(RUNS // 10, 100)
T_FINAL = 0.1
FLAT_MB = 20.0
TARGET = 0.9

SWEEP = """
title = "benchmark: A7 step, random ω_n"
scenario = "a7_id_high_gain"
seed = 5
runs = {runs}
chunk_size = {chunk}
[set]
"simulation.t_final" = {t_final}
[random]
omega_n = {{ uniform = [5, 40] }}
[derived]
"controller.kp" = "omega_n**2"
"controller.kd" = "2*omega_n"
"""


def spec_of(folder, runs, chunk=200, t_final=T_FINAL, name="bench"):
    from armlab.sweep import load_sweep_file

    path = Path(folder) / f"{name}.toml"
    path.write_text(SWEEP.format(runs=runs, chunk=chunk, t_final=t_final), encoding="utf-8")
    return load_sweep_file(path)


def dask_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("distributed") is not None


def _resident_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


class Memory:
    """The driver's resident set [MB] sampled every 50 ms with the fraction of chunk files
    written: ``at(0.1)`` is the first sample once a tenth of the chunks were written."""

    def __init__(self, runs_folder: Path, chunks: int):
        self.folder, self.chunks, self.samples = runs_folder, chunks, []
        self.first = None  # (chunks written, time) when the first chunk file appeared
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._sample, daemon=True)

    def _sample(self):
        while not self.stop.wait(0.05):
            done = len(list(self.folder.glob("part-*.parquet"))) if self.folder.is_dir() else 0
            self.samples.append((done / self.chunks, _resident_mb()))
            if done and self.first is None:
                self.first = (done, time.perf_counter())

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()
        self.samples.append((1.0, _resident_mb()))

    def at(self, fraction: float) -> float:
        return next(mb for done, mb in self.samples if done >= fraction)


def check_agreement(runs=8, dask=True) -> list[str]:
    """The table of one sweep, bit for bit the same on one thread, on every core with another
    chunking, and (``dask`` and installed) on a two-process Dask cluster; returns the
    executors compared."""
    from armlab.sweep import read_results, sweep

    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        reference = read_results(sweep(spec_of(folder, runs, chunk=1, t_final=0.02, name="one"),
                                       folder / "one", threads=1).folder)
        compared = ["1 thread"]
        others = [("threads", dict(threads=None), 3)]
        if dask and dask_available():
            others.append(("dask", dict(workers=2), 2))
        for name, executor, chunk in others:
            spec = spec_of(folder, runs, chunk=chunk, t_final=0.02, name=name)
            table = read_results(sweep(spec, folder / name, **executor).folder)
            # pandas' equals: NaN (a metric a run does not have) equals NaN in the same place.
            if not table.to_pandas().equals(reference.to_pandas()):
                raise AssertionError(f"sweep on {name}: its table differs from the one-thread table")
            compared.append(name)
        return compared


def timed(spec, folder, **executor):
    from armlab.sweep import sweep

    out = Path(folder) / f"out-{time.time_ns()}"
    with Memory(out / "runs", spec.n_chunks) as memory:
        start = time.perf_counter()
        outcome = sweep(spec, out, **executor)
        seconds = time.perf_counter() - start
    end = time.perf_counter()
    if outcome.counts.get("ok") != spec.n_runs:
        raise AssertionError(f"benchmark sweep: {outcome.counts}")
    # The steady rate: the runs after the first chunk file, over the time after it (without
    # the start of a cluster and the first loading of the compiled code in each worker).
    chunks, at = memory.first
    steady = math.nan
    if end > at and chunks < spec.n_chunks:
        steady = (spec.n_runs - chunks * spec.chunk_size) / (end - at)
    return seconds, steady, memory


def main():
    from armlab.sweep import sweep

    cores = os.cpu_count() or 1
    print("agreement (tables bit for bit):", ", ".join(check_agreement()))
    with tempfile.TemporaryDirectory() as folder:
        warm = spec_of(folder, 2 * cores, chunk=1, name="warm")
        sweep(warm, Path(folder) / "warm", threads=None)          # load the compiled code once
        single_spec, spec = spec_of(folder, SINGLE_RUNS, name="single"), spec_of(folder, RUNS, name="all")
        one, steady_1, _ = timed(single_spec, folder, threads=1)
        rows = [("1 thread", SINGLE_RUNS, one, SINGLE_RUNS / one, steady_1, None)]
        executors = [(f"{cores} threads", dict(threads=None))]
        if dask_available():
            executors.append((f"Dask, {cores} processes", dict(workers=cores)))
        else:
            print("Dask side skipped: dask.distributed is not installed (pip install 'armlab[cluster]')")
        for name, executor in executors:
            seconds, steady, memory = timed(spec, folder, **executor)
            rows.append((name, RUNS, seconds, RUNS / seconds, steady, memory))
    print(f"\nSweep: A7 step of {T_FINAL:g} s (100 RK4 steps), random ω_n, metrics and Parquet, "
          f"{cores} cores")
    print("  per core = steady rate / (cores × one thread's steady rate); steady: after the first chunk")
    print(f"  {'executor':<22}{'runs':>8}{'wall [s]':>10}{'runs/s':>9}{'steady':>9}{'per core':>10}"
          f"{'driver MB at 10 %':>19}{'at 100 %':>10}")
    for name, runs, seconds, rate, steady, memory in rows:
        per_core = steady / (1 if memory is None else cores) / steady_1
        mem = "" if memory is None else f"{memory.at(0.1):>19.0f}{memory.at(1.0):>10.0f}"
        print(f"  {name:<22}{runs:>8}{seconds:>10.1f}{rate:>9.0f}{steady:>9.0f}{per_core:>10.2f}{mem}")
    for name, _, _, _, steady, memory in rows[1:]:
        per_core = steady / cores / steady_1
        growth = memory.at(1.0) - memory.at(0.1)
        print(f"  {name}: {per_core:.2f} per core (target ≥ {TARGET}: "
              f"{'met' if per_core >= TARGET else 'NOT met'}); driver memory "
              f"{growth:+.0f} MB from 10 % to 100 % of the runs "
              f"({'flat' if growth < FLAT_MB else 'NOT flat'})")


if __name__ == "__main__":
    main()
