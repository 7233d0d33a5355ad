"""``armlab report --quick`` beside ``armlab report``: the preview's share of the full time.

Both are whole processes of the command line (``--quiet``, the bundled PRP), with filled
caches: numba's compiled kernels, the A1–A5 derivations (``ARMLAB_CACHE_DIR``) and Python's
bytecode (kept in a folder of the benchmark's, as in ``bench_startup``).  One process of each
fills them; then the two alternate, :data:`TIMED` processes each, and the best wall and CPU
time of each is kept (CPU: user + system of the process and of the full report's worker
processes).  Target (issue: the quick preview): quick ≤ :data:`TARGET` × full, wall time.
The load average is printed with the times: the full report runs its scenarios in two worker
processes, so a busy machine stretches its wall time less than its CPU time suggests.

Before the ratio, the quick page is checked to be a preview of the full one: every section
of the full page (A1–A15, the definitions) is in it, and every figure it draws is one of the
full page's.

Run: ``python benchmarks/bench_report.py`` or ``make bench``.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from pathlib import Path

from bench_startup import ARMLAB_CLI, Timed, environment, run_process

TIMED = 2
TARGET = 0.25
TIMEOUT = 600.0


def report_args(out_dir, quick: bool) -> list[str]:
    return [sys.executable, "-c", ARMLAB_CLI, "report", "--quiet", "--out", str(out_dir),
            *(["--quick"] if quick else [])]


def page_parts(path: Path) -> tuple[set[str], set[str]]:
    """(sections, figures) of a report page, by their data attributes."""
    text = path.read_text(encoding="utf-8")
    sections, figures = (set(re.findall(rf'data-{key}="([^"]+)"', text)) for key in ("assignment", "figure"))
    return sections, figures


def check_preview(full: Path, quick: Path) -> tuple[int, int]:
    """Raise unless the quick page has every section of the full one and draws only figures
    the full one has; returns the figure counts (full, quick)."""
    full_sections, full_figures = page_parts(full)
    quick_sections, quick_figures = page_parts(quick)
    missing = (full_sections - {"animation"}) - quick_sections
    if missing:
        raise RuntimeError(f"the quick report lacks the sections {sorted(missing)}")
    extra = quick_figures - full_figures
    if extra:
        raise RuntimeError(f"the quick report draws figures the full one does not: {sorted(extra)}")
    return len(full_figures), len(quick_figures)


def main():
    print(f"\n`armlab report --quick` against `armlab report` (PRP, filled caches, best of {TIMED} "
          f"alternating processes each, wall and CPU time)")
    with tempfile.TemporaryDirectory() as bytecode, tempfile.TemporaryDirectory() as out:
        env = environment(bytecode)
        folders = {quick: Path(out, "quick" if quick else "full") for quick in (False, True)}
        for quick, folder in folders.items():  # fill the caches
            run_process(report_args(folder, quick), env, timeout=TIMEOUT)
        runs: dict[bool, list[Timed]] = {False: [], True: []}
        load = [os.getloadavg()[0]]
        for _ in range(TIMED):
            for quick, folder in folders.items():
                runs[quick].append(run_process(report_args(folder, quick), env, timeout=TIMEOUT))
        load.append(os.getloadavg()[0])
        figures = check_preview(folders[False] / "report.html", folders[True] / "report.html")
    best = {quick: Timed(min(r.wall for r in timed), min(r.cpu for r in timed))
            for quick, timed in runs.items()}
    full, quick = best[False], best[True]
    print(f"  load average (1 min) {load[0]:.1f} before, {load[1]:.1f} after; {os.cpu_count()} cores")
    print(f"  {'armlab report':40s} {full.wall:7.2f} s {full.cpu:7.2f} s CPU  ({figures[0]} figures)")
    print(f"  {'armlab report --quick':40s} {quick.wall:7.2f} s {quick.cpu:7.2f} s CPU  "
          f"({figures[1]} figures, every section)")
    wall, cpu = quick.wall / full.wall, quick.cpu / full.cpu
    print(f"  quick / full: {wall:.2f} wall, {cpu:.2f} CPU (target ≤ {TARGET:g} wall: "
          f"{'met' if wall <= TARGET else 'NOT met'})")


if __name__ == "__main__":
    main()
