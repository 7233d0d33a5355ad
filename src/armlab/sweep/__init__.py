"""Sweeps and Monte Carlo runs of a scenario: a sweep file, an executor, a Parquet table.

``armlab.sweep(FILE_OR_SPEC, out=DIR)`` (``armlab sweep FILE --out DIR``) runs every
combination a sweep file asks for (``armlab.sweep.spec``) on local threads or a Dask cluster
(``armlab.sweep.runner``), measures each run (``armlab.sweep.metrics``) and writes one row per
run to a resumable Parquet dataset (``armlab.sweep.store``).  Bundled sweep files live in
``files/`` (``armlab sweep --list``).  Format and definitions: ``docs/sweeps.md``.
"""

from armlab.sweep.runner import SweepOutcome, run_chunk, run_one, sweep
from armlab.sweep.spec import SweepSpec, bundled_sweep_names, load_sweep, load_sweep_file, sweep_path
from armlab.sweep.store import read_results, read_signals

__all__ = ["SweepOutcome", "SweepSpec", "bundled_sweep_names", "load_sweep", "load_sweep_file",
           "read_results", "read_signals",
           "run_chunk", "run_one", "sweep", "sweep_path"]
