"""``armlab sweep FILE --out DIR``: run a sweep file, write its Parquet table and its plots."""

from __future__ import annotations

import sys


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "sweep", help="run a sweep or Monte Carlo file over a scenario (see docs/sweeps.md)",
        description="Run every run of the sweep FILE (a bundled sweep name or a sweep .toml file) and "
                    "write one row per run (parameters, status, metrics) to the Parquet dataset "
                    "DIR/runs.  Runs locally by default: a process per core from 2000 runs on, else a "
                    "thread per core for long runs and one thread for short ones (choose with "
                    "--threads or --processes), "
                    "on a Dask cluster with --scheduler "
                    "or --workers.  An interrupted sweep started again with the same --out resumes "
                    "where it stopped.")
    parser.add_argument("sweep", metavar="FILE", nargs="?", help="bundled sweep name or sweep .toml file")
    parser.add_argument("--out", metavar="DIR", help="output folder (default: sweeps/<name>)")
    parser.add_argument("--threads", type=int, metavar="N", help="N local threads")
    parser.add_argument("--processes", type=int, metavar="N",
                        help="N local worker processes instead of threads (for many short runs)")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="start a local Dask cluster of N worker processes")
    parser.add_argument("--scheduler", metavar="ADDRESS", help="run on the Dask cluster at ADDRESS")
    parser.add_argument("--overwrite", action="store_true", help="discard results already in --out")
    parser.add_argument("--plot", action="store_true", help="draw the sweep's plots into DIR/plots")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--list", action="store_true", help="list the bundled sweeps")
    parser.add_argument("--allow-outside", action="store_true",
                        help="let the sweep file name a scenario file outside its folder, and that "
                             "scenario robot files outside its own")
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.errors import CommandError, SchedulerAddressError
    from armlab.sweep import bundled_sweep_names, load_sweep, sweep

    if args.list:
        for name in bundled_sweep_names():
            spec = load_sweep(name)
            print(f"{name:<28} {spec.n_runs:>6} runs  {spec.title}")
        return 0
    if args.sweep is None:
        raise CommandError("FILE: give a sweep file or a bundled sweep name (--list shows them)")
    spec = load_sweep(args.sweep, allow_outside=args.allow_outside)
    if args.plot:
        from armlab.viz.sweeps import check_plots

        check_plots(spec)  # a bad [[plot]] table is reported before the runs, not after
    out = args.out or f"sweeps/{spec.name}"
    try:
        outcome = sweep(spec, out, threads=args.threads, processes=args.processes, workers=args.workers,
                        scheduler=args.scheduler, overwrite=args.overwrite, progress=not args.quiet,
                        log=sys.stderr)
    except SchedulerAddressError as error:
        raise CommandError(f"--scheduler: {error.reason}") from None
    counts = ", ".join(f"{n} {status}" for status, n in sorted(outcome.counts.items()))
    print(f"{spec.name}: {outcome.n_runs} runs ({counts}) in {outcome.seconds:.1f} s on {outcome.executor}")
    print(f"wrote {out}/runs (Parquet, one row per run)")
    if args.plot:
        from armlab.viz.sweeps import plot_sweep

        paths = plot_sweep(spec, out)
        for path in paths:
            print(f"wrote {path}")
        if not paths:
            print(f"armlab sweep: note: no plots: no run of {spec.name} gave a metric", file=sys.stderr)
    return 0
