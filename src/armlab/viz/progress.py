"""A one-line progress bar on stderr for long report runs (no dependency)."""

from __future__ import annotations

import sys
import time


class Progress:
    """``[#####.....]  3/20  12.4 s  running a7_step`` redrawn in place on a terminal, one line
    per step otherwise (logs, CI).  ``enabled=False`` prints nothing."""

    def __init__(self, total: int, *, stream=None, enabled: bool = True, width: int = 24):
        self.total, self.done, self.width = max(total, 1), 0, width
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.start = time.perf_counter()
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def _line(self, what: str) -> str:
        filled = int(self.width * self.done / self.total)
        bar = "#" * filled + "." * (self.width - filled)
        elapsed = time.perf_counter() - self.start
        return f"[{bar}] {self.done:>3}/{self.total}  {elapsed:6.1f} s  {what}"

    def step(self, what: str) -> None:
        """Announce the step about to run."""
        if not self.enabled:
            return
        line = self._line(what)
        if self.tty:
            self.stream.write("\r" + line[:160].ljust(160))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def advance(self) -> None:
        self.done += 1

    def close(self, message: str = "done") -> None:
        if not self.enabled:
            return
        self.done = self.total
        line = self._line(message)
        self.stream.write(("\r" + line[:160].ljust(160) + "\n") if self.tty else line + "\n")
        self.stream.flush()
