"""A time budget for one piece of symbolic work, enforced from outside it.

SymPy's cost is not predictable from a robot's size alone: a 3-joint arm with round numbers
derives in seconds, the same arm with non-round DH and inertial parameters (exact rationals
with many digits, twist angles that are not multiples of π/12) makes ``solve`` and ``expand``
run for many minutes.  So every derivation step runs inside a :class:`Budget`: a watchdog
thread raises :class:`BudgetExceeded` in the working thread once its seconds are spent
(``PyThreadState_SetAsyncExc``, the mechanism behind Ctrl-C in a thread), and the caller
records in one line what was skipped and why.

:class:`BudgetExceeded` (``armlab.errors``) derives from ``BaseException`` so that SymPy's own ``except
Exception`` blocks do not swallow it; an exception that lands where Python cannot propagate
it (a finalizer) is sent again every :data:`RESEND` seconds until the block has ended.
"""

from __future__ import annotations

import ctypes
import threading
import time

from armlab.errors import BudgetExceeded

RESEND = 0.25
"""Seconds between two deliveries of the same expired budget (see the module docstring)."""

_set_async_exc = ctypes.pythonapi.PyThreadState_SetAsyncExc
_set_async_exc.argtypes = (ctypes.c_ulong, ctypes.py_object)


class Budget:
    """``with Budget(20.0, "A1"):`` runs the block for at most about 20 s of wall-clock time,
    then raises :class:`BudgetExceeded` inside it.  ``seconds=None`` means no limit.

    ``elapsed`` holds the block's duration once it has ended; ``exceeded`` says whether it was
    stopped.  Budgets nest: an inner one that outlasts its outer one is stopped by the outer.
    """

    def __init__(self, seconds: float | None, what: str = ""):
        if seconds is not None and not seconds > 0:
            raise ValueError(f"a budget must be a positive number of seconds, got {seconds!r}")
        self.seconds, self.what = seconds, what
        self.elapsed = 0.0
        self.exceeded = False
        self._lock = threading.Lock()
        self._done = threading.Event()
        self._fired = False
        self._signal = type("BudgetExceeded", (BudgetExceeded,), {"budget": self})

    def __enter__(self) -> Budget:
        self._thread = threading.get_ident()
        self._started = time.perf_counter()
        if self.seconds is not None:
            threading.Thread(target=self._watch, daemon=True, name="armlab-budget").start()
        return self

    def _watch(self) -> None:
        if self._done.wait(self.seconds):
            return
        while True:
            with self._lock:
                if self._done.is_set():
                    return
                self._fired = True
                _set_async_exc(self._thread, self._signal)
            if self._done.wait(RESEND):
                return

    def __exit__(self, kind, error, traceback) -> bool:
        # The budget may expire while this very method runs: retry until the watchdog has
        # been told to stop, then withdraw any exception it queued but Python has not raised.
        while True:
            try:
                with self._lock:
                    self._done.set()
                    if self._fired:
                        _set_async_exc(self._thread, ctypes.py_object())  # NULL: withdraw
                break
            except BudgetExceeded:
                continue
        self.elapsed = time.perf_counter() - self._started
        if kind is self._signal:
            self.exceeded = True
            return True
        return False
