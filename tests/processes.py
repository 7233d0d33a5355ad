"""A child process that cannot outlive its allowance, for the tests that start browsers.

``subprocess.run(..., capture_output=True, timeout=T)`` is not bounded: on expiry it kills the
direct child only, then reads the pipes to their end, and a browser's own children (Chromium's
renderer and GPU processes, Firefox's content processes) hold those pipes open for as long as
they live — the call then waits forever.  Here the child leads its own process group, its output
goes to files instead of pipes, and on expiry the whole group is killed.
"""

from __future__ import annotations

import os
import signal
import subprocess
import tempfile


def run_bounded(command: list[str], timeout: float, **popen) -> subprocess.CompletedProcess:
    """Run ``command`` for at most ``timeout`` seconds; its stdout and stderr as text.

    Raises :class:`subprocess.TimeoutExpired` (with what it printed so far) once the process
    group has been killed."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        process = subprocess.Popen(command, stdout=out, stderr=err, start_new_session=True, **popen)
        try:
            process.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
            raise subprocess.TimeoutExpired(command, timeout, output=_read(out), stderr=_read(err)) from None
        finally:
            # Children the browser left behind once it exited (they are never a test's result).
            try:
                os.killpg(process.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        return subprocess.CompletedProcess(command, process.returncode, _read(out), _read(err))


def _read(file) -> str:
    file.seek(0)
    return file.read().decode("utf-8", errors="replace")
