"""The loop's shared kernels compiled by a second process while this one compiles the run's own.

With empty caches, the first compiled simulation of a machine compiles one kernel after the
other under numba's compiler lock.  Measured on a 2-core machine (a random 3-joint arm under
computed torque): the plant's RNEA 2.9 s and forward dynamics 2.3 s, the controller's entry
2.0 s, the fixed-step loop ``rk4_core`` 2.3 s and the kinetic energy of its divergence check
1.3 s.  The last two are the same for every robot and every controller
(:func:`armlab.simulation.loop.compile_loop_kernels`): a second Python process compiles them
into numba's disk cache while this one compiles the others, and this one then loads them
(``benchmarks/bench_startup.py``, case (c)).

:func:`start` spawns that process (``python -m armlab.precompile loop <marker>``), at most
once per process, and only when

* numba's disk cache holds no index of ``rk4_core`` (beside its source, or under
  ``NUMBA_CACHE_DIR``: where ``armlab.caches`` looks for armlab's cache files), and no earlier
  process has tried: a marker file in armlab's cache folder (``compiled/``), named after
  numba's version, numba's cache folder, the Python version and the stamps of the kernels'
  sources (numba's own cache is invalidated by those stamps), for a numba cache kept
  elsewhere;
* no other process is compiling them now: a lock file beside the marker (one older than
  :data:`STALE_LOCK` seconds was left by a process that died, and is taken over);
* this process may use two CPUs or more, and ``ARMLAB_COMPILE_AHEAD`` is not ``0``.

The second process writes the marker when it ends, whether it compiled everything or not
(what it missed is compiled where it is needed, as before), so a machine tries once.
:func:`wait` — the loop calls it before it takes the shared kernels — waits for that process
at most :data:`WAIT` seconds.  Nothing else changes: a kernel missing from the disk cache is
compiled where it is needed, whoever was meant to compile it.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

# Seconds after which a lock file is taken for the remains of a process that died.
STALE_LOCK = 300.0
# Seconds :func:`wait` waits for the second process (it needs ~5 s on an idle 2-core machine).
WAIT = 120.0
# The sources of the kernels compiled ahead (numba invalidates their cache when these change).
_SOURCES = ("loop.py", "../kernels/plant.py")

_LOCK = threading.Lock()
_started = False
_helper: subprocess.Popen | None = None


def _usable_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:          # not on Linux
        return os.cpu_count() or 1


def marker_path() -> Path:
    """The marker of the kernels compiled ahead for this numba cache (see the module)."""
    import numba

    from armlab.specialise.closed_form import cache_dir

    here = Path(__file__).resolve().parent
    key = [numba.__version__, str(numba.config.CACHE_DIR), sys.version.split()[0]]
    for name in _SOURCES:
        info = (here / name).stat()
        key.append(f"{info.st_mtime_ns}:{info.st_size}")
    digest = hashlib.sha256("|".join(key).encode()).hexdigest()[:20]
    return cache_dir() / "compiled" / f"loop-kernels-{digest}"


def _loop_in_numba_cache() -> bool:
    """Whether numba's disk cache holds an index of ``rk4_core`` (it may be stale: then the
    kernels compile here, as without this module)."""
    import numba

    pattern = "loop.rk4_core-*.nbi"
    if numba.config.CACHE_DIR:
        return any(Path(numba.config.CACHE_DIR).rglob(pattern))
    return any((Path(__file__).resolve().parent / "__pycache__").glob(pattern))


def _take_lock(lock: Path) -> bool:
    """Create ``lock`` (only one process can); take over one left by a dead process."""
    for _ in range(2):
        try:
            os.close(os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644))
            return True
        except FileExistsError:
            try:
                if time.time() - lock.stat().st_mtime < STALE_LOCK:
                    return False
                lock.unlink()
            except FileNotFoundError:
                pass
        except OSError:                 # a cache folder that cannot be written: no second process
            return False
    return False


def start() -> bool:
    """Spawn the second process if the module's conditions hold; whether it was spawned."""
    global _started, _helper
    with _LOCK:
        if _started:
            return False
        _started = True
        if os.environ.get("ARMLAB_COMPILE_AHEAD", "1") == "0" or _usable_cpus() < 2:
            return False
        try:
            marker = marker_path()
            if marker.exists() or _loop_in_numba_cache():
                return False
            marker.parent.mkdir(parents=True, exist_ok=True)
        except OSError:
            return False
        if not _take_lock(marker.with_suffix(".lock")):
            return False
        try:
            # The program is armlab.precompile's (``loop``); it finds the modules this process
            # found.
            path = os.pathsep.join(entry for entry in sys.path if entry)
            _helper = subprocess.Popen([sys.executable, "-m", "armlab.precompile", "loop", str(marker)],
                                       env={**os.environ, "PYTHONPATH": path}, stdin=subprocess.DEVNULL,
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                       start_new_session=True)
        except OSError:
            marker.with_suffix(".lock").unlink(missing_ok=True)
            return False
        return True


def wait() -> None:
    """Wait for the second process this process spawned, if any (at most :data:`WAIT` s)."""
    global _helper
    with _LOCK:
        helper, _helper = _helper, None
    if helper is not None:
        try:
            helper.wait(WAIT)
        except subprocess.TimeoutExpired:
            pass                        # it goes on; what it has not written is compiled here


def finish(marker: str) -> None:
    """The second process's last act, whatever happened before: write the marker and release
    the lock."""
    marker_file = Path(marker)
    marker_file.touch()
    marker_file.with_suffix(".lock").unlink(missing_ok=True)
