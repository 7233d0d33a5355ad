"""A time budget for symbolic work, enforced by the operating system.

SymPy's cost is not predictable from a robot's size alone: a 3-joint arm with round numbers
derives in seconds, the same arm with non-round DH and inertial parameters (exact rationals
with many digits, twist angles that are not multiples of π/12) makes ``solve`` and ``expand``
run for many minutes.  So budgeted work runs in a forked child process that sends its results
back one by one as it finds them; once a part's seconds are spent the child (and any child of
its own) is killed, and the caller keeps what arrived.

Why a process and not an exception raised into the working thread: an asynchronous exception
(``PyThreadState_SetAsyncExc``) waits for the end of the C call the thread is in, and one that
lands inside a lock's bookkeeping (an import in progress, a condition variable) leaves the
lock taken for good.  A killed process leaves nothing behind.

Where ``fork`` is not available (Windows) the work runs in the caller's process, unbounded.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

PARENT_CHECK = 1.0
"""Seconds between two checks, in the child, that its parent still lives (a child whose parent
was killed ends instead of running on)."""


def bounded_parts(parts: list[str], work: Callable[[str, Callable[[Any], None]], None],
                  seconds: float | None, load: Callable[[bytes], Any] = pickle.loads,
                  ) -> Iterator[tuple[str, str, Any]]:
    """Run ``work(part, emit)`` for each of ``parts`` in turn, each for at most ``seconds``.

    Yields ``(part, "item", value)`` for each ``emit(value)`` of the work (``value`` pickled in
    the child, unpickled here by ``load``), ``(part, "done", None)`` when a part ended and
    ``(part, "exceeded", None)`` when its time ran out; the parts after an exceeded one are
    run in a new child.  An exception of the work is raised here.  ``seconds=None``: no limit,
    and no child process."""
    if seconds is not None and not seconds > 0:
        raise ValueError(f"a budget must be a positive number of seconds, got {seconds!r}")
    if seconds is None or "fork" not in multiprocessing.get_all_start_methods():
        for part in parts:
            yield from ((part, "item", value) for value in _collected(work, part))
            yield part, "done", None
        return
    remaining = list(parts)
    while remaining:
        exceeded = yield from _one_child(remaining, work, seconds, load)
        if exceeded is None:
            return
        yield exceeded, "exceeded", None
        remaining = remaining[remaining.index(exceeded) + 1:]


def call_within(seconds: float | None, function: Callable[..., Any], *args,
                load: Callable[[bytes], Any] = pickle.loads) -> tuple[bool, Any]:
    """``(True, function(*args))``, or ``(False, None)`` when it did not return within
    ``seconds`` (it is then killed).  The value comes back pickled, unpickled by ``load``."""
    value = None
    for _, kind, payload in bounded_parts(["call"], lambda _, emit: emit(function(*args)), seconds, load):
        if kind == "item":
            value = payload
        elif kind == "exceeded":
            return False, None
    return True, value


def _collected(work, part) -> list:
    values = []
    work(part, values.append)
    return values


def _one_child(parts, work, seconds, load):
    """Run ``parts`` in one forked child; yields their events and returns the part whose time
    ran out (None when all ended)."""
    reader, writer = multiprocessing.Pipe(duplex=False)
    pid = os.fork()
    if pid == 0:  # the child: never returns into the caller's code
        try:
            reader.close()
            _child(parts, work, writer)
        finally:
            os._exit(0)
    try:
        os.setpgid(pid, pid)  # as the child does: whichever runs first, the group exists
    except OSError:  # the child has done it (or has ended already)
        pass
    writer.close()
    current, deadline = None, None
    try:
        while True:
            wait = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            if current is not None and not reader.poll(wait):
                return current
            try:
                kind, payload = reader.recv()
            except EOFError:
                raise ChildProcessError(f"the symbolic work of {current or parts[0]} ended without "
                                        f"its results ({_ended(pid)})") from None
            if kind == "start":
                current, deadline = payload, time.monotonic() + seconds
            elif kind == "item":
                yield current, "item", load(payload)
            elif kind == "end":
                yield current, "done", None
                current, deadline = None, None
            elif kind == "error":
                raise pickle.loads(payload)
            else:  # "finished"
                return None
    finally:
        reader.close()
        _kill(pid)


def _child(parts, work, writer) -> None:
    os.setpgid(0, 0)  # its own group: a kill reaches the children it starts (call_within inside)
    parent = os.getppid()

    def watch_parent():
        while True:
            time.sleep(PARENT_CHECK)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch_parent, daemon=True).start()
    try:
        for part in parts:
            writer.send(("start", part))
            work(part, lambda value: writer.send(("item", pickle.dumps(value))))
            writer.send(("end", part))
        writer.send(("finished", None))
    except BaseException as error:  # noqa: BLE001 — handed to the parent, which raises it
        try:
            message = pickle.dumps(error)
        except Exception:  # noqa: BLE001 — an exception that does not pickle: its text
            message = pickle.dumps(RuntimeError(f"{type(error).__name__}: {error}"))
        writer.send(("error", message))
    finally:
        writer.close()


def _ended(pid: int) -> str:
    _, status = os.waitpid(pid, 0)
    return f"exit code {os.waitstatus_to_exitcode(status)}"


def _kill(pid: int) -> None:
    """Kill the child and the children it started, and reap it."""
    try:
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):  # not yet its own group: the child alone
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:  # reaped already (by _ended)
        pass
