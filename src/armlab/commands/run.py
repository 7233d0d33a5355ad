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
                    "summary and write <name>.npz and <name>.csv (with --plot the scope PNGs, with "
                    "--diagram the block diagram of its closed loop) "
                    "into --out.  A run that diverges, is stopped by its step budget or is "
                    "interrupted (Ctrl-C) keeps its data up to then, marked so in the files.  "
                    "Exit code 0 when the run ends as its scenario expects (expect = \"diverged\" "
                    "for an experiment whose point is to diverge), 3 when it does not, 130 after "
                    "Ctrl-C (see `armlab --help`).")
    parser.add_argument("scenario", metavar="SCENARIO", help="bundled scenario name or .toml file")
    parser.add_argument("--out", metavar="DIR", default="runs", help="output folder (default: runs)")
    parser.add_argument("--plot", action="store_true", help="also draw the scopes as PNG")
    parser.add_argument("--diagram", action="store_true",
                        help="also draw the block diagram of the closed loop as <name>_loop.png")
    parser.add_argument("--t-final", type=float, metavar="T", help="simulate T seconds instead")
    parser.add_argument("--method", choices=("rk4", "adaptive"), help="override the integrator")
    parser.add_argument("--quiet", action="store_true", help="no progress lines and no warnings")
    parser.add_argument("--allow-outside", action="store_true",
                        help="let the scenario name robot files outside its folder, and those name "
                             "files outside theirs (meshes, included MJCF files)")
    parser.add_argument("--format", default="npz,csv", metavar="LIST",
                        help=f"comma-separated data formats among {', '.join(f[1:] for f in FORMATS)} "
                             "(default: npz,csv)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.cli import DIVERGED, INTERRUPTED, OK
    from armlab.errors import CommandError

    formats = [f.strip() for f in args.format.split(",") if f.strip()]
    for fmt in formats:
        if f".{fmt}" not in FORMATS:
            raise CommandError(f"--format: unknown format {fmt!r} (use npz, csv, parquet)")
    result, written = run_scenario(args.scenario, out_dir=args.out, formats=formats, plot=args.plot,
                                   diagram=args.diagram, t_final=args.t_final, method=args.method,
                                   progress=None if args.quiet else sys.stderr,
                                   allow_outside=args.allow_outside)
    final = ", ".join(f"{label} {value:+.4g}" for label, value in
                      zip(result.labels["q"], result.q[-1], strict=True))
    print(f"{result.meta['scenario']}: {len(result.t)} samples to t = {result.t[-1]:g} s; final q: {final}")
    if "q_err" in result.signals:
        worst = abs(result.signals["q_err"][-1]).max()
        print(f"final |q_err| max: {worst:.3g}")
    for path in written:
        print(f"wrote {path}")
    if result.meta.get("dynamics_fallback") and not args.quiet:
        print(f"armlab run: note: the numeric dynamics ran: {result.meta['dynamics_fallback']}",
              file=sys.stderr)
    if result.status == "interrupted":
        print(f"armlab run: {result.diagnosis}", file=sys.stderr)
        return INTERRUPTED
    expected = result.meta.get("expect", "ok")
    if result.status != "ok":
        note = " (as expected)" if result.status == expected else ""
        print(f"armlab run: {result.diagnosis}{note}", file=sys.stderr)
    elif expected != "ok":
        print(f"armlab run: the scenario expects the run to end {expected}, it ran to the end",
              file=sys.stderr)
    return OK if result.status == expected else DIVERGED


def run_scenario(name_or_path, *, out_dir=None, formats=("npz", "csv"), plot=False, diagram=False,
                 t_final=None, method=None, progress=None, allow_outside=False):
    """Run a scenario; returns ``(result, written_paths)``.

    ``out_dir``: where ``<name>.<format>`` (with ``plot`` the scope PNGs, with ``diagram`` the
    block diagram ``<name>_loop.png``, :mod:`armlab.viz.loop_diagram`) go; nothing is
    written when it is None.  It is checked for writing before the run and created after it.
    A run that diverged, was stopped by its step budget or was interrupted by Ctrl-C is kept
    (``result.status`` says which) and its data written like any other.  ``progress``: a text
    stream for a start/finish line.  ``allow_outside``: the scenario may name robot files
    outside its folder (:func:`armlab.scenarios.load_scenario`).
    """
    # Imported here: building the command-line parser does not load the simulator.
    from armlab.errors import SimulationInterrupted
    from armlab.files import check_writable_folder
    from armlab.scenarios import ScenarioFileError, load_scenario
    from armlab.simulation import SimulationDiverged

    scenario = load_scenario(name_or_path, allow_outside=allow_outside)
    if t_final is not None and not (math.isfinite(t_final) and t_final > 0):
        raise ScenarioFileError(scenario.source or scenario.name, "--t-final",
                                f"must be a positive finite time, got {t_final!r}")
    if out_dir is not None:
        # Checked before the run, so that a long simulation is not lost to a bad --out; the
        # folder itself is made only once there is something to write into it.
        out_dir = Path(out_dir)
        try:
            check_writable_folder(out_dir)
        except OSError as error:
            raise ScenarioFileError(out_dir, "--out", error.strerror or "cannot be written") from None
    duration = t_final if t_final is not None else scenario.simulation["t_final"]
    if progress is not None:
        print(f"running {scenario.name}: {duration:g} s of simulated time, "
              f"dt = {scenario.simulation['dt']:g} s ...", file=progress, flush=True)
    start = time.perf_counter()
    try:
        result = scenario.run(t_final=t_final, method=method)
    except (SimulationDiverged, SimulationInterrupted) as error:
        result = error.result
    seconds = time.perf_counter() - start
    written = []
    if out_dir is not None:
        try:
            out_dir.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise ScenarioFileError(out_dir, "--out", f"cannot be created ({error.strerror})") from None
        written = [result.save(out_dir / f"{scenario.name}.{fmt}") for fmt in formats]
        if plot:
            # Matplotlib is imported only when a plot is asked for.
            from armlab.viz.scopes import plot_scopes

            written += plot_scopes(result, out_dir, formats=("png",))
        if diagram:
            from armlab.viz.diagram_drawing import write_diagram

            written.append(write_diagram(scenario, out_dir / f"{scenario.name}_loop.png"))
    if progress is not None:
        # Said once the data is safely written (a full disk fails the write, not this line).
        print(f"  done in {seconds:.2f} s wall time"
              f"{' — ' + result.diagnosis if result.status != 'ok' else ''}", file=progress, flush=True)
    return result, written
