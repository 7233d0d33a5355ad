"""``make bench``: run every ``benchmarks/bench_*.py`` module's ``main()`` in one process.

Each module prints its own tables (side-by-side timings and ratios).  A module that fails is
reported in one line and the others still run; the exit status is non-zero if any failed.
"""

from __future__ import annotations

import importlib.util
import sys
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent


def modules() -> list[Path]:
    return sorted(HERE.glob("bench_*.py"))


def run(path: Path) -> bool:
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    start = time.perf_counter()
    print(f"\n######## {path.name} ########", flush=True)
    try:
        spec.loader.exec_module(module)
        module.main()
    except Exception as error:
        traceback.print_exc()
        print(f"{path.name}: failed: {error}", flush=True)
        return False
    print(f"({path.name}: {time.perf_counter() - start:.1f} s)", flush=True)
    return True


def main(argv=None) -> int:
    selected = set(argv if argv is not None else sys.argv[1:])
    paths = [p for p in modules() if not selected or p.stem in selected or p.name in selected]
    failures = [p.name for p in paths if not run(p)]
    if failures:
        print(f"\nfailed: {', '.join(failures)}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
