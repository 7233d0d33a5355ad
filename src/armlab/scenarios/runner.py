"""Run a scenario and write its data (NPZ, CSV, Parquet) and, on request, its scope plots."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

from armlab.scenarios import ScenarioFileError, load_scenario
from armlab.simulation import SimulationDiverged


def run_scenario(name_or_path, *, out_dir=None, formats=("npz", "csv"), plot=False, t_final=None,
                 method=None, progress=None):
    """Run a scenario; returns ``(result, written_paths, plot_note)``.

    ``out_dir``: where ``<name>.<format>`` (and with ``plot`` the scope PNGs) go; nothing is
    written when it is None.  A diverged run is kept (``result.status == "diverged"``) and its
    data written like any other.  ``progress``: a text stream for a start/finish line.
    """
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
    written, note = [], ""
    if out_dir is not None:
        for fmt in formats:
            written.append(result.save(out_dir / f"{scenario.name}.{fmt}"))
        if plot:
            # Plotting is an edge: imported only when asked for.
            from armlab.viz.scopes import plot_scopes

            written += plot_scopes(result, out_dir, formats=("png",))
    return result, written, note


def main(argv=None) -> int:
    """``python -m armlab.scenarios.runner NAME [OUT]`` (the CLI is ``armlab run``)."""
    argv = sys.argv[1:] if argv is None else argv
    result, written, note = run_scenario(argv[0], out_dir=argv[1] if len(argv) > 1 else None,
                                         progress=sys.stderr)
    for path in written:
        print(path)
    return 0 if result.status == "ok" else 1
