"""Sweeps at scale: runs per second per core, local threads and Dask processes against one
thread, and the driver's memory against the number of runs.

The sweep (:data:`SWEEP`): the A6 PD regulation without gravity compensation shortened to
:data:`T_FINAL` (100 RK4 steps of 1 ms), joint 2's set point drawn uniformly in [0, π/2] for
each run, every run measured and written to Parquet as ``armlab sweep`` does.

* **one thread**: :data:`SINGLE_RUNS` runs on ``threads=1`` (the steady per-run rate; a
  tenth of the sweep keeps ``make bench`` within minutes);
* **threads**: :data:`RUNS` runs on a thread per core (``threads=`` the number of cores);
* **processes**: :data:`RUNS` runs on one spawned local process per core (``processes=``);
* **Dask**: :data:`RUNS` runs on a local ``dask.distributed`` cluster of one single-threaded
  worker process per core (skipped with a message without the ``cluster`` extra);
* **MuJoCo** (the ``bench`` extra; skipped with a message without it): the same runs as
  ``mujoco.rollout`` batches of :data:`MUJOCO_BATCH` on one thread and on every core — the
  PRP from armlab's URDF export, the PD as MuJoCo position actuators (force
  k_p (ctrl − q) − k_v q̇, the same law), RK4 at 1 ms, each run's set point its control.
  MuJoCo computes the trajectories only (no metrics, no table), so its rate is an upper bound
  of what a sweep built on it would reach.  Its trajectories are first checked against
  armlab's (:func:`check_mujoco`, to 1e-9).

* **A7**: :data:`A7_RUNS` runs of the A7 via-point tracking shortened to 1 s, ω_n drawn per run
  (:data:`A7_SWEEP`), on one thread, a thread per core and Dask — a cluster the sweep starts,
  and a running cluster whose workers have run the sweep's code once (target ≥ 0.9 per core);
  best of :data:`A7_REPEATS` but for the new cluster.  Beside it, without a target
  (:func:`a7_context`): one running worker, and :data:`A7_LONG_RUNS` runs on a worker per core.

Per core: rate / (cores × one-thread rate); target ≥ 0.9 on every executor.  The driver's
memory: its resident set sampled while the sweep runs, at 10 % and at 100 % of the runs;
target: flat (it grows by less than :data:`FLAT_MB` MB while nine tenths of the runs pass), on
each executor's :data:`RUNS` runs and on :data:`MEMORY_RUNS` runs on a thread per core.
Before anything is timed, :func:`check_agreement` checks that every executor writes the same
table, bit for bit (also run by the test suite on a few runs).

Run: ``python benchmarks/bench_sweep.py`` or ``make bench``.  ``ARMLAB_BENCH_SWEEP_RUNS``
changes :data:`RUNS`, ``ARMLAB_BENCH_A7_RUNS`` :data:`A7_RUNS`, ``ARMLAB_BENCH_A7_REPEATS``
:data:`A7_REPEATS`, ``ARMLAB_BENCH_MEMORY_RUNS`` :data:`MEMORY_RUNS`.
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
title = "benchmark: A6 PD regulation, random q_des of joint 2"
scenario = "a6_pd_none"
seed = 5
runs = {runs}
chunk_size = {chunk}
[set]
"simulation.t_final" = {t_final}
[random]
"controller.reference.value[1]" = {{ uniform = [0, 1.5707963267948966] }}
"""
MUJOCO_BATCH = 5000
MEMORY_RUNS = int(os.environ.get("ARMLAB_BENCH_MEMORY_RUNS", 1_000_000))
MEMORY_CHUNK = 2000
A7_RUNS = int(os.environ.get("ARMLAB_BENCH_A7_RUNS", 1000))
A7_REPEATS = int(os.environ.get("ARMLAB_BENCH_A7_REPEATS", 3))
A7_LONG_RUNS = 10 * A7_RUNS
A7_SWEEP = """
title = "benchmark: A7 via-point tracking of 1 s, random natural frequency"
scenario = "a7_id_via_points"
seed = 7
runs = {runs}
chunk_size = {chunk}
[set]
"simulation.t_final" = 1.0
[random]
omega_n = {{ uniform = [4, 12] }}
[derived]
"controller.kp" = "omega_n**2"
"controller.kd" = "2*omega_n"
"""


def spec_of(folder, runs, chunk=200, t_final=T_FINAL, name="bench", text=SWEEP):
    from armlab.sweep import load_sweep_file

    path = Path(folder) / f"{name}.toml"
    path.write_text(text.format(runs=runs, chunk=chunk, t_final=t_final), encoding="utf-8")
    return load_sweep_file(path)


def dask_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("distributed") is not None


def _resident_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def chunks_written(runs_folder: Path) -> int:
    from armlab.sweep.store import chunks_of

    names = [path.name for path in runs_folder.glob("part-*.parquet")] if runs_folder.is_dir() else []
    return sum(len(chunks_of(name) or ()) for name in names)


class Memory:
    """The driver's resident set [MB] sampled every 10 ms with the fraction of chunks written
    (a file holds a task's chunks): ``at(0.1)`` is the first sample once a tenth of the chunks
    were written."""

    def __init__(self, runs_folder: Path, chunks: int):
        self.folder, self.chunks, self.samples = runs_folder, chunks, []
        self.first = None  # (chunks written, time) when the first file appeared
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._sample, daemon=True)

    def _sample(self):
        while not self.stop.wait(0.01):
            done = chunks_written(self.folder)
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


def mujoco_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("mujoco") is not None


def mujoco_model(folder, spec):
    """The sweep's plant and PD law as a MuJoCo model: armlab's URDF export of the plant, one
    position actuator per joint with the controller's k_p and k_d, RK4 at the scenario's dt."""
    import mujoco
    import numpy as np

    from armlab.model.urdf_io import save_urdf
    from armlab.scenarios import scenario_from_table

    scenario = scenario_from_table(spec.table(0)[1], spec.scenario_file)
    mj = mujoco.MjSpec.from_file(str(save_urdf(scenario.plant, Path(folder) / "plant.urdf")))
    gains = [np.diag(np.atleast_2d(getattr(scenario.controller, name))) for name in ("kp", "kd")]
    for joint, kp, kd in zip(mj.joints, *gains, strict=True):
        actuator = mj.add_actuator()
        actuator.target, actuator.trntype = joint.name, mujoco.mjtTrn.mjTRN_JOINT
        actuator.set_to_position(kp=float(kp), kv=float(kd))
    model = mj.compile()
    model.opt.timestep = float(scenario.simulation["dt"])
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    return model, scenario


def set_points(spec, runs: range):
    """Each run's set point (``controller.reference.value``, as the sweep writes it): its
    MuJoCo control."""
    import numpy as np

    return np.array([spec.table(i)[1]["controller"]["reference"]["value"] for i in runs], dtype=float)


def mujoco_rollout(model, spec, control, threads: int):
    """q (runs × steps × nq) by ``mujoco.rollout`` of the runs whose set points are ``control``."""
    import mujoco
    import mujoco.rollout
    import numpy as np

    data = [mujoco.MjData(model) for _ in range(threads)]
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x0 = np.zeros(mujoco.mj_stateSize(model, kind))
    mujoco.mj_getState(model, data[0], x0, kind)
    steps = round(float(spec.fixed[0][1]) / model.opt.timestep)
    state, _ = mujoco.rollout.rollout(model, data if threads > 1 else data[0], x0[None],
                                      control[:, None, :], nstep=steps)
    return state[:, :, 1:1 + model.nq]


def check_mujoco(runs=3) -> float:
    """MuJoCo's trajectories of the first ``runs`` runs against armlab's, to OTHER_ALGORITHM."""
    import numpy as np

    from agreement import OTHER_ALGORITHM, assert_close
    from armlab.scenarios import scenario_from_table

    with tempfile.TemporaryDirectory() as folder:
        spec = spec_of(folder, runs)
        model, _ = mujoco_model(folder, spec)
        theirs = mujoco_rollout(model, spec, set_points(spec, range(runs)), threads=1)
        ours = np.array([scenario_from_table(spec.table(i)[1], spec.scenario_file).run().q[1:]
                         for i in range(runs)])
    return assert_close(theirs, ours, OTHER_ALGORITHM, "MuJoCo's rollout vs armlab's runs")


def time_mujoco(spec, threads: int) -> float:
    """Seconds for every run of ``spec`` by ``mujoco.rollout`` in batches of MUJOCO_BATCH."""
    with tempfile.TemporaryDirectory() as folder:
        model, _ = mujoco_model(folder, spec)
        controls = [set_points(spec, range(first, min(first + MUJOCO_BATCH, spec.n_runs)))
                    for first in range(0, spec.n_runs, MUJOCO_BATCH)]
        start = time.perf_counter()
        for control in controls:
            mujoco_rollout(model, spec, control, threads)
        return time.perf_counter() - start


def rollout_batch(spec, runs: range) -> dict:
    """The batch of :func:`armlab.rollout` for the sweep's runs: joint 2's set points."""
    import numpy as np

    key = "controller.reference.value[1]"
    return {key: np.array([spec.parameters(i)[key] for i in runs]), "simulation.t_final": T_FINAL}


def time_rollout(spec, cores: int) -> list[tuple[int, float]]:
    """[(threads, seconds)] of ``armlab.rollout`` over the sweep's runs on 1 and ``cores`` threads."""
    from armlab.sweep.rollout import rollout

    batch = rollout_batch(spec, range(spec.n_runs))
    rollout(spec.scenario_file, rollout_batch(spec, range(8)), threads=cores)      # compiled once
    timings = []
    for threads in sorted({1, cores}):
        start = time.perf_counter()
        table = rollout(spec.scenario_file, batch, threads=threads)
        timings.append((threads, time.perf_counter() - start))
        assert table["status"].count("ok") == spec.n_runs
    return timings


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
        others = [("threads", dict(threads=2), 3)]
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


def a7_case(folder, cores: int) -> list[tuple[str, float, float]]:
    """[(executor, wall seconds, steady runs/s)] of :data:`A7_RUNS` runs of the 1 s A7 sweep
    (:data:`A7_SWEEP`: ω_n drawn per run, K_P = ω_n², K_D = 2ω_n) on one thread, on a thread
    per core and (installed) on Dask with a worker process per core: a cluster started by the
    sweep (``workers=``) and a running one (``scheduler=``, its workers having run the sweep's
    code once, as a cluster kept for many sweeps has).  A sweep of 1000 such runs lasts about
    half a second, where this machine's pace varies by 10-20 % from one to the next: each
    executor but the new cluster (whose start dominates) runs it :data:`A7_REPEATS` times and
    keeps its best steady rate."""
    from armlab.sweep import sweep

    warm = spec_of(folder, 2 * cores, chunk=1, name="a7-warm", text=A7_SWEEP)
    sweep(warm, Path(folder) / "a7-warm", threads=cores)
    spec = spec_of(folder, A7_RUNS, chunk=max(1, A7_RUNS // 40), name="a7", text=A7_SWEEP)

    def best(name, **executor):
        runs = [timed(spec, folder, **executor)[:2] for _ in range(A7_REPEATS)]
        return (name, *max(runs, key=lambda run: run[1]))

    rows = [best("1 thread", threads=1), best(f"{cores} threads", threads=cores)]
    if dask_available():
        rows.append((f"Dask, {cores} new processes", *timed(spec, folder, workers=cores)[:2]))
        import dask
        from distributed import LocalCluster

        from armlab.sweep.runner import LOCAL_CLUSTER_CONFIG

        # Set up as armlab's own local cluster (LOCAL_CLUSTER_CONFIG), as docs/sweeps.md advises.
        with dask.config.set(LOCAL_CLUSTER_CONFIG), \
                LocalCluster(n_workers=cores, threads_per_worker=1, processes=True,
                             dashboard_address=None) as cluster:
            sweep(warm, Path(folder) / "a7-warm-dask", scheduler=cluster.scheduler_address)
            rows.append(best(f"Dask, {cores} running workers", scheduler=cluster.scheduler_address))
    return rows


def a7_context(folder, cores: int, one_thread: float) -> list[tuple[str, int, float, float]]:
    """Where the Dask figure of :func:`a7_case` loses, beside it (no target of their own):
    [(executor, workers, steady runs/s, the one-thread steady rate it is compared with)].

    * one running worker, which leaves a core to the driver, the scheduler and the nannies, as
      the one-thread sweep leaves one to its driver thread (``one_thread``: a7_case's rate);
    * :data:`A7_LONG_RUNS` runs (ten times as many) on one thread and on a running cluster of a
      worker per core: the costs a sweep pays once (its client, its first and last tasks)
      weigh a tenth as much."""
    import dask
    from distributed import LocalCluster

    from armlab.sweep import sweep
    from armlab.sweep.runner import LOCAL_CLUSTER_CONFIG

    warm = spec_of(folder, 2 * cores, chunk=1, name="a7-warm", text=A7_SWEEP)
    spec = spec_of(folder, A7_RUNS, chunk=max(1, A7_RUNS // 40), name="a7", text=A7_SWEEP)
    long = spec_of(folder, A7_LONG_RUNS, chunk=max(1, A7_LONG_RUNS // 40), name="a7-long", text=A7_SWEEP)
    long_one = timed(long, folder, threads=1)[1]
    rows = []
    for workers, sweeps in ((1, [spec]), (cores, [long])):
        with dask.config.set(LOCAL_CLUSTER_CONFIG), \
                LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                             dashboard_address=None) as cluster:
            sweep(warm, Path(folder) / f"a7-warm-context-{workers}", scheduler=cluster.scheduler_address)
            for run in sweeps:
                best = max(timed(run, folder, scheduler=cluster.scheduler_address)[1]
                           for _ in range(A7_REPEATS if run is spec else 2))
                rows.append((f"Dask, {workers} running worker{'s' * (workers > 1)}, {run.n_runs} runs",
                             workers, best, one_thread if run is spec else long_one))
    rows.insert(1, (f"1 thread, {A7_LONG_RUNS} runs", 1, long_one, long_one))
    return rows


def memory_case(folder, cores: int):
    """(wall seconds, :class:`Memory`) of :data:`MEMORY_RUNS` runs of the A6 sweep on a thread
    per core (what ``armlab sweep`` picks for it), in chunks of :data:`MEMORY_CHUNK`: the
    driver's memory from 10 % to 100 % of a million runs."""
    spec = spec_of(folder, MEMORY_RUNS, chunk=MEMORY_CHUNK, name="memory")
    seconds, _, memory = timed(spec, folder, threads=cores)
    return seconds, memory


def main():
    from armlab.sweep import sweep

    cores = os.cpu_count() or 1
    print("agreement (tables bit for bit):", ", ".join(check_agreement()))
    with tempfile.TemporaryDirectory() as folder:
        warm = spec_of(folder, 2 * cores, chunk=1, name="warm")
        sweep(warm, Path(folder) / "warm", threads=cores)         # load the compiled code once
        # Chunks of at most 200 runs and at least 20 chunks: a steady rate after the first.
        single_spec = spec_of(folder, SINGLE_RUNS, chunk=min(200, max(1, SINGLE_RUNS // 20)), name="single")
        spec = spec_of(folder, RUNS, chunk=min(200, max(1, RUNS // 20)), name="all")
        one, steady_1, _ = timed(single_spec, folder, threads=1)
        rows = [("1 thread", SINGLE_RUNS, one, SINGLE_RUNS / one, steady_1, None)]
        executors = [(f"{cores} threads", dict(threads=cores)), (f"{cores} processes", dict(processes=cores))]
        if dask_available():
            executors.append((f"Dask, {cores} processes", dict(workers=cores)))
        else:
            print("Dask side skipped: dask.distributed is not installed (pip install 'armlab[cluster]')")
        for name, executor in executors:
            seconds, steady, memory = timed(spec, folder, **executor)
            rows.append((name, RUNS, seconds, RUNS / seconds, steady, memory))
        rollout_rows = time_rollout(spec, cores)
        a7_rows = a7_case(folder, cores)
        a7_context_rows = a7_context(folder, cores, a7_rows[0][2]) if dask_available() else []
        million_seconds, million = memory_case(folder, cores)
        mujoco_rows = []
        if mujoco_available():
            print(f"MuJoCo agreement: max |Δq| {check_mujoco():.2g}")
            for threads in (1, cores):
                seconds = time_mujoco(spec, threads)
                mujoco_rows.append((f"MuJoCo rollout, {threads} thread{'s' * (threads > 1)}", seconds))
        else:
            print("MuJoCo side skipped: mujoco is not installed (pip install 'armlab[bench]')")
    print(f"\nSweep: A6 PD regulation of {T_FINAL:g} s (100 RK4 steps), random q_des of joint 2, "
          "metrics and Parquet, "
          f"{cores} cores")
    print("  per core = steady rate / (cores × one thread's steady rate); steady: after the first chunk")
    print(f"  {'executor':<22}{'runs':>8}{'wall [s]':>10}{'runs/s':>9}{'steady':>9}{'per core':>10}"
          f"{'driver MB at 10 %':>19}{'at 100 %':>10}")
    for name, runs, seconds, rate, steady, memory in rows:
        per_core = steady / (1 if memory is None else cores) / steady_1
        mem = "" if memory is None else f"{memory.at(0.1):>19.0f}{memory.at(1.0):>10.0f}"
        print(f"  {name:<22}{runs:>8}{seconds:>10.1f}{rate:>9.0f}{steady:>9.0f}{per_core:>10.2f}{mem}")
    for name, seconds in mujoco_rows:
        threads = 1 if "1 thread" in name else cores
        print(f"  {name:<22}{RUNS:>8}{seconds:>10.1f}{RUNS / seconds:>9.0f}{'':>9}"
              f"{RUNS / seconds / threads / steady_1:>10.2f}   (trajectories only; per one armlab thread)")
    mujoco_rates = {1 if "1 thread" in name else cores: RUNS / seconds for name, seconds in mujoco_rows}
    print("\nBatched rollout (armlab.rollout: the same runs, each value checked, metrics, no Parquet "
          "table), against MuJoCo's rollout on as many threads (trajectories only)")
    for threads, seconds in rollout_rows:
        rate = RUNS / seconds
        versus = (f"{rate / mujoco_rates[threads]:.2f} × MuJoCo's (target ≥ 5)" if threads in mujoco_rates
                  else "MuJoCo not run")
        print(f"  {threads} thread{'s' * (threads > 1)}: {RUNS} runs in {seconds:.1f} s, {rate:.0f} runs/s, "
              f"{versus}")
    if len(rollout_rows) == 2:
        print(f"  {cores} threads / 1 thread: {rollout_rows[0][1] / rollout_rows[1][1]:.2f} (target ≥ 1.8)")
    for name, _, _, _, steady, memory in rows[1:]:
        per_core = steady / cores / steady_1
        growth = memory.at(1.0) - memory.at(0.1)
        print(f"  {name}: {per_core:.2f} per core (target ≥ {TARGET}: "
              f"{'met' if per_core >= TARGET else 'NOT met'}); driver memory "
              f"{growth:+.0f} MB from 10 % to 100 % of the runs "
              f"({'flat' if growth < FLAT_MB else 'NOT flat'})")
    growth = million.at(1.0) - million.at(0.1)
    print(f"\nDriver memory over {MEMORY_RUNS} runs of the same sweep on {cores} threads "
          f"({million_seconds:.0f} s, {MEMORY_RUNS / million_seconds:.0f} runs/s): "
          f"{million.at(0.1):.0f} MB at 10 %, {million.at(1.0):.0f} MB at 100 %, {growth:+.0f} MB "
          f"({'flat' if growth < FLAT_MB else 'NOT flat'})")
    print(f"\nSweep: {A7_RUNS} runs of the A7 via-point tracking shortened to 1 s, random ω_n, metrics "
          "and Parquet (steady: after the first chunk)")
    a7_one = a7_rows[0][2]
    for name, seconds, steady in a7_rows:
        workers = 1 if name == "1 thread" else cores
        per_core = steady / workers / a7_one
        target = "" if workers == 1 else (f"; target ≥ {TARGET}: "
                                          f"{'met' if per_core >= TARGET else 'NOT met'}")
        print(f"  {name:<22}{seconds:>6.2f} s wall, steady {steady:>6.0f} runs/s, "
              f"{per_core:.3f} per core{target}")
    if a7_context_rows:
        print("  where Dask loses (no target): a core left for the driver, or ten times the runs")
    for name, workers, steady, one in a7_context_rows:
        print(f"  {name:<44} steady {steady:>6.0f} runs/s, {steady / workers / one:.3f} per core "
              f"(against one thread's {one:.0f} runs/s)")


if __name__ == "__main__":
    main()
