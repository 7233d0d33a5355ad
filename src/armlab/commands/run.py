"""``armlab run SCENARIO``: simulate a scenario, write its data and optionally its scope plots."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

from armlab.simulation.results import FORMATS


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "run", help="run a scenario (see `armlab scenarios`) and write its data and scopes",
        description="Simulate SCENARIO (a bundled scenario name or a scenario .toml file), print a "
                    "summary and write <name>.npz and <name>.csv (and with --plot the scope PNGs) "
                    "into --out.  A diverged run keeps its data up to the divergence; the exit "
                    "code is then 1.")
    parser.add_argument("scenario", metavar="SCENARIO", help="bundled scenario name or .toml file")
    parser.add_argument("--out", metavar="DIR", default="runs", help="output folder (default: runs)")
    parser.add_argument("--plot", action="store_true", help="also draw the scopes as PNG")
    parser.add_argument("--t-final", type=float, metavar="T", help="simulate T seconds instead")
    parser.add_argument("--method", choices=("rk4", "adaptive"), help="override the integrator")
    parser.add_argument("--format", default="npz,csv", metavar="LIST",
                        help=f"comma-separated data formats among {', '.join(f[1:] for f in FORMATS)} "
                             "(default: npz,csv)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.errors import ArmlabError

    formats = [f.strip() for f in args.format.split(",") if f.strip()]
    for fmt in formats:
        if f".{fmt}" not in FORMATS:
            raise ArmlabError(f"--format: unknown format {fmt!r} (use npz, csv, parquet)")
    result, written = run_scenario(args.scenario, out_dir=args.out, formats=formats, plot=args.plot,
                                   t_final=args.t_final, method=args.method, progress=sys.stderr)
    final = ", ".join(f"{label} {value:+.4g}" for label, value in
                      zip(result.labels["q"], result.q[-1], strict=True))
    print(f"{result.meta['scenario']}: {len(result.t)} samples to t = {result.t[-1]:g} s; final q: {final}")
    if "q_err" in result.signals:
        worst = abs(result.signals["q_err"][-1]).max()
        print(f"final |q_err| max: {worst:.3g}")
    for path in written:
        print(f"wrote {path}")
    if result.status != "ok":
        print(f"armlab run: {result.diagnosis}", file=sys.stderr)
        return 1
    return 0


def run_scenario(name_or_path, *, out_dir=None, formats=("npz", "csv"), plot=False, t_final=None,
                 method=None, progress=None):
    """Run a scenario; returns ``(result, written_paths)``.

    ``out_dir``: where ``<name>.<format>`` (and with ``plot`` the scope PNGs) go; nothing is
    written when it is None.  A diverged run is kept (``result.status == "diverged"``) and its
    data written like any other.  ``progress``: a text stream for a start/finish line.
    """
    # Imported here: building the command-line parser does not load the simulator.
    from armlab.scenarios import ScenarioFileError, load_scenario
    from armlab.simulation import SimulationDiverged

    scenario = load_scenario(name_or_path)
    if out_dir is not None:
        # Checked before the run, so a long simulation is not lost to a bad --out.
        out_dir = Path(out_dir)
        if out_dir.exists() and not out_dir.is_dir():
            raise ScenarioFileError(out_dir, "--out", "exists and is not a directory")
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise ScenarioFileError(out_dir, "--out", f"cannot be created ({error.strerror})") from None
    if t_final is not None and not (math.isfinite(t_final) and t_final > 0):
        raise ScenarioFileError(scenario.source or scenario.name, "--t-final",
                                f"must be a positive finite time, got {t_final!r}")
    duration = t_final if t_final is not None else scenario.simulation["t_final"]
    if progress is not None:
        print(f"running {scenario.name}: {duration:g} s of simulated time, "
              f"dt = {scenario.simulation['dt']:g} s ...", file=progress, flush=True)
    start = time.perf_counter()
    try:
        result = scenario.run(t_final=t_final, method=method)
    except SimulationDiverged as error:
        result = error.result
    if progress is not None:
        print(f"  done in {time.perf_counter() - start:.2f} s wall time"
              f"{' — ' + result.diagnosis if result.status != 'ok' else ''}", file=progress, flush=True)
    written = []
    if out_dir is not None:
        written = [result.save(out_dir / f"{scenario.name}.{fmt}") for fmt in formats]
        if plot:
            # Matplotlib is imported only when a plot is asked for.
            from armlab.viz.scopes import plot_scopes

            written += plot_scopes(result, out_dir, formats=("png",))
    return result, written
