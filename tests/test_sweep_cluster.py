"""Sweeps on a real ``dask.distributed`` cluster of two worker processes on this machine.

Needs the ``cluster`` extra (``pip install 'armlab[cluster]'``: dask[distributed]); skipped
with a message without it.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed", reason="dask.distributed is not installed (the 'cluster' extra)")
pd = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")

from distributed import Client, LocalCluster  # noqa: E402

from armlab.sweep import load_sweep_file, read_results, sweep  # noqa: E402

SRC = Path(__file__).resolve().parents[1] / "src"

SWEEP = """
scenario = "a7_id_high_gain"
chunk_size = {chunk}
[set]
"simulation.t_final" = {t_final}
[grid]
omega_n = {{ linspace = [5, 40, {count}] }}
"simulation.torque_limit" = {{ values = [20, 1e6] }}
[derived]
"controller.kp" = "omega_n**2"
"controller.kd" = "2*omega_n"
"""


@pytest.fixture(scope="module")
def cluster():
    # The worker processes import armlab as this process does.
    os.environ["PYTHONPATH"] = os.pathsep.join([str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])
    import dask

    from armlab.sweep.runner import LOCAL_CLUSTER_CONFIG

    # Set up as docs/sweeps.md advises for a cluster of one's own.
    with dask.config.set(LOCAL_CLUSTER_CONFIG), \
            LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0") as local:
        yield local


def spec_of(tmp_path, name, chunk=3, t_final=0.05, count=6):
    path = tmp_path / f"{name}.toml"
    path.write_text(SWEEP.format(chunk=chunk, t_final=t_final, count=count), encoding="utf-8")
    return load_sweep_file(path)


def test_dask_table_equals_the_thread_pool_table(tmp_path, cluster):
    threads = sweep(spec_of(tmp_path, "threads", chunk=5), tmp_path / "threads", threads=2)
    dask = sweep(spec_of(tmp_path, "dask", chunk=2), tmp_path / "dask", scheduler=cluster.scheduler_address)
    assert dask.executor.startswith("dask ") and dask.counts == threads.counts == {"ok": 12}
    pd.testing.assert_frame_equal(read_results(dask.folder).to_pandas(),
                                  read_results(threads.folder).to_pandas(),
                                  check_exact=True)


def test_chunks_batched_into_dask_tasks_give_the_same_table(tmp_path, cluster, monkeypatch):
    """A Dask task runs as many chunks as fill ``TASK_SECONDS`` (one until a chunk was timed), at
    most a ``TASKS_PER_THREAD``-th share per thread; each chunk is still written once, and the
    table is the thread pool's, bit for bit."""
    from armlab.sweep import runner

    assert runner.batch_size(500, 2, None) == 1
    assert runner.batch_size(500, 2, runner.TASK_SECONDS / 10) == 10              # by time
    assert runner.batch_size(500, 2, runner.TASK_SECONDS / 1000) == 125            # 500 / (2 × 2)
    assert runner.batch_size(500, 2, 10 * runner.TASK_SECONDS) == 1
    assert runner.batch_size(500, 2, 0.0) == 125
    monkeypatch.setattr(runner, "TASK_SECONDS", 1e9)
    monkeypatch.setattr(runner, "TASKS_PER_THREAD", 1)
    sizes, size_of = [], runner.batch_size

    def recording(*args):
        sizes.append(size_of(*args))
        return sizes[-1]

    monkeypatch.setattr(runner, "batch_size", recording)
    spec = spec_of(tmp_path, "batched", chunk=1)
    dask = sweep(spec, tmp_path / "dask", scheduler=cluster.scheduler_address)
    dask_sizes = list(sizes)
    threads = sweep(spec_of(tmp_path, "threads", chunk=1), tmp_path / "threads", threads=2)
    assert dask.counts == {"ok": 12}
    pd.testing.assert_frame_equal(read_results(dask.folder).to_pandas(),
                                  read_results(threads.folder).to_pandas(), check_exact=True)
    # Four first tasks of one chunk (two per worker thread), then half of the 12 chunks a task
    # (the last task takes the 2 chunks left); a file a task, every chunk in one of them.
    assert dask_sizes == [1, 1, 1, 1, 6, 6], dask_sizes
    files = sorted(path.name for path in (tmp_path / "dask" / "runs").glob("part-*.parquet"))
    assert files == ["part-000000.parquet", "part-000001.parquet", "part-000002.parquet",
                     "part-000003.parquet", "part-000004-000009.parquet", "part-000010-000011.parquet"]


def test_the_local_cluster_leaves_mallocs_trim_threshold_to_glibc(monkeypatch):
    """Dask gives its worker processes MALLOC_TRIM_THRESHOLD_=65536 unless told otherwise; the
    cluster a sweep starts does not (its runs are 8-12 % faster with glibc's own threshold)."""
    from armlab.sweep import runner

    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)  # as in a fresh process
    client, local = runner._dask_client(None, 1, "sweep.toml", from_file=False)
    try:
        seen = client.run(os.environ.get, "MALLOC_TRIM_THRESHOLD_")
        fixed = client.run(os.environ.get, "OMP_NUM_THREADS")  # Dask's other settings stay
    finally:
        client.close()
        local.close()
    assert list(seen.values()) == [None] and list(fixed.values()) == ["1"], (seen, fixed)


def test_a_worker_killed_mid_sweep_loses_no_run(tmp_path, cluster):
    spec = spec_of(tmp_path, "killed", chunk=1, t_final=0.6, count=12)
    reference = read_results(sweep(spec, tmp_path / "reference", threads=2).folder).to_pandas()
    out = tmp_path / "out"
    with Client(cluster) as client:
        victim = next(iter(client.run(os.getpid).values()))
    outcome, failure = [], []

    def driver():
        try:
            outcome.append(sweep(spec, out, scheduler=cluster.scheduler_address))
        except BaseException as error:  # reported by the assertion below
            failure.append(error)

    thread = threading.Thread(target=driver)
    thread.start()
    deadline = time.monotonic() + 240
    while len(list((out / "runs").glob("part-*.parquet"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.01)
    written_before = len(list((out / "runs").glob("part-*.parquet")))
    os.kill(victim, signal.SIGKILL)
    thread.join(timeout=600)
    assert not failure, failure
    assert written_before < spec.n_chunks, "the worker was killed after the sweep had finished"
    table = read_results(out).to_pandas()
    assert list(table["run"]) == list(range(spec.n_runs))
    pd.testing.assert_frame_equal(table, reference, check_exact=True)


def test_benchmark_agreement_includes_dask():
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import bench_sweep

    assert bench_sweep.check_agreement(runs=4) == ["1 thread", "threads", "dask"]


def test_a_workers_sweep_prints_nothing_of_dasks_shutdown(tmp_path, capfd, monkeypatch):
    """A worker slow to exit makes its nanny log "Worker process still alive after 4.0 seconds,
    killing" during the shutdown (seen on a loaded machine); forced here by a shutdown that
    logs it as the nanny does.  A successful sweep prints its result only."""
    import logging

    os.environ["PYTHONPATH"] = os.pathsep.join([str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])
    original = LocalCluster.close

    def slow_close(self, *args, **kwargs):
        logging.getLogger("distributed.nanny").warning("Worker process still alive after 4.0 seconds, "
                                                       "killing")
        return original(self, *args, **kwargs)

    class Seen(logging.Handler):
        def __init__(self):
            super().__init__()
            self.messages = []

        def emit(self, record):
            self.messages.append(record.getMessage())

    seen = Seen()   # what reaches the loggers' handlers (Dask's own prints to stderr)
    nanny = logging.getLogger("distributed.nanny")
    nanny.addHandler(seen)
    monkeypatch.setattr(LocalCluster, "close", slow_close)
    try:
        spec = spec_of(tmp_path, "quiet", count=2)
        outcome = sweep(spec, tmp_path / "out", workers=2, progress=False)
    finally:
        nanny.removeHandler(seen)
    assert outcome.counts == {"ok": 4}
    out, err = capfd.readouterr()
    assert not [m for m in seen.messages if "still alive" in m] and "still alive" not in out + err
    assert nanny.getEffectiveLevel() < logging.ERROR  # restored after the shutdown
