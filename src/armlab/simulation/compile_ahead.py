"""The loop's shared kernels compiled by a second process while this one compiles the run's own.

With empty caches, the first compiled simulation of a machine compiles one kernel after the
other under numba's compiler lock.  Measured on a 2-core machine (a random 3-joint arm under
computed torque): the plant's RNEA 2.9 s and forward dynamics 2.3 s, the controller's entry
2.0 s, the fixed-step loop ``rk4_core`` 2.3 s and the kinetic energy of its divergence check
1.3 s.  The last two are the same for every robot and every controller
(:func:`armlab.simulation.loop.compile_loop_kernels`): a second Python process compiles them
into numba's disk cache while this one compiles the others, and this one then loads them:
the first A7 result with empty caches 11.9 → 7.9 s (``benchmarks/bench_startup.py``, case (c)).

:func:`start` spawns that process (``python -m armlab.precompile loop <marker>``), at most
once per process, and only when

* numba's disk cache holds no index of ``rk4_core`` (numba's file
  ``loop.rk4_core-<line>.py<version>.nbi``, beside its source or under ``NUMBA_CACHE_DIR``),
  and no earlier process has tried: a marker file in armlab's cache folder (``compiled/``),
  named after numba's version, numba's cache folder, the Python version and the stamps of the
  kernels' sources (numba invalidates its cache by those stamps).  The marker covers a numba
  cache kept elsewhere (numba's per-user folder, when the source's folder is read-only);
* no other process is compiling them now: the second process holds an exclusive ``flock`` on
  a lock file beside the marker from its start to its end (its exit, or its death, releases
  it);
* this process may use two CPUs or more, the platform has ``flock``, and
  ``ARMLAB_COMPILE_AHEAD`` is not ``0``.

The second process writes the marker when it ends, whether it compiled everything or not
(what it missed is compiled where it is needed, as before), so a machine tries once.
:func:`wait` — the loop calls it just before it takes the shared kernels — waits for that
process at most :data:`WAIT` seconds (every thread that calls it).  Nothing else changes: a
kernel missing from the disk cache is compiled where it is needed, whoever was meant to
compile it.  (A run that uses neither kernel — the adaptive integrator, a generated module's
energy — still waits for them, on a cold machine only.)
"""

from __future__ import annotations

import atexit
import hashlib
import os
import subprocess
import sys
import threading
from pathlib import Path

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


def in_numba_cache(dispatcher) -> bool:
    """Whether numba's disk cache holds an index of ``dispatcher``'s function as its source
    reads now (numba's file name carries the function's first line; the index may still be
    stale, and the kernels then compile where needed, as without this module)."""
    import numba

    function = dispatcher.py_func
    name = (f"{Path(function.__code__.co_filename).stem}.{function.__qualname__}-"
            f"{function.__code__.co_firstlineno}.py{sys.version_info[0]}{sys.version_info[1]}"
            f"{getattr(sys, 'abiflags', '')}.nbi")
    if numba.config.CACHE_DIR:
        return any(Path(numba.config.CACHE_DIR).rglob(name))
    return (Path(function.__code__.co_filename).parent / "__pycache__" / name).exists()


def start(probe) -> bool:
    """Spawn the second process if the module's conditions hold (``probe``: the loop's
    ``rk4_core``, whose cache index says whether the kernels are compiled); whether it was
    spawned."""
    global _started, _helper
    with _LOCK:
        if _started:
            return False
        _started = True
        if os.environ.get("ARMLAB_COMPILE_AHEAD", "1") == "0" or _usable_cpus() < 2:
            return False
        try:
            import fcntl
        except ImportError:             # no flock (Windows): no second process
            return False
        try:
            marker = marker_path()
            if marker.exists() or in_numba_cache(probe):
                return False
            marker.parent.mkdir(parents=True, exist_ok=True)
            lock = os.open(marker.with_suffix(".lock"), os.O_CREAT | os.O_WRONLY, 0o644)
        except OSError:                 # a cache folder that cannot be written
            return False
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            if marker.exists():         # written by a second process that has just ended
                return False
            _helper = _spawn(marker, lock)
            return True
        except OSError:                 # locked: another process is compiling them now
            return False
        finally:
            os.close(lock)              # the second process keeps its copy, and the lock


def _spawn(marker: Path, lock: int) -> subprocess.Popen:
    import numba

    # The child sees the modules and the numba cache this process sees; ``-P``: not the
    # current folder before them.
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(entry for entry in sys.path if entry)}
    if numba.config.CACHE_DIR:
        env["NUMBA_CACHE_DIR"] = str(numba.config.CACHE_DIR)
    return subprocess.Popen([sys.executable, "-P", "-m", "armlab.precompile", "loop", str(marker)],
                            env=env, pass_fds=(lock,), stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


def wait() -> None:
    """Wait for the second process this process spawned, if any (at most :data:`WAIT` s)."""
    helper = _helper
    if helper is not None:
        try:
            helper.wait(WAIT)
        except subprocess.TimeoutExpired:
            pass                        # it goes on; what it has not written is compiled here


@atexit.register
def _reap() -> None:
    """Collect the second process's exit status if it has ended (a run that failed before
    :func:`wait` never waited for it)."""
    if _helper is not None:
        _helper.poll()


def finish(marker: str) -> None:
    """The second process's last act, whatever happened before: write the marker (the lock
    is released when the process ends)."""
    Path(marker).touch()
