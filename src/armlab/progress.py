"""Progress bars of the long commands (``armlab report``, ``armlab sweep``): tqdm's, on stderr.

On a terminal the bar is tqdm's own, redrawn in place.  On any other stream (a log file, a CI
log) tqdm would redraw it with carriage returns, one ever-growing line that a log shows as a
blur; there each display is a line of its own instead, written when the caller refreshes the
bar (``set_postfix_str``: one line per step of a report) and at most every ``log_every``
seconds of updates (a sweep's runs).  A disabled bar (``--quiet``) prints nothing.
"""

from __future__ import annotations

import math
import sys

from tqdm import tqdm

__all__ = ["finish", "progress_bar"]


class _LogLines(tqdm):
    """tqdm on a stream that is not a terminal: each display a new line, none cleared."""

    def display(self, msg=None, pos=None):
        # tqdm's documented hook for another front end.  An empty message is tqdm clearing its
        # bar (closing with leave=False): a log keeps the lines it has.
        if msg == "":
            return False
        self.fp.write(f"{self if msg is None else msg}\n")
        self.fp.flush()
        return True

    def clear(self, nolock=False):
        # tqdm.write() clears every bar before it writes and redraws it after: in a log the
        # redraw alone would repeat the line, and there is nothing to clear.
        pass

    def close(self):
        # The final state once, without the empty line tqdm's own close adds after it.
        if not self.disable and self.leave is not False:
            self.leave = False
            self.display()
        super().close()


def progress_bar(total: int, *, enabled: bool = True, stream=None, log_every: float = math.inf,
                 **options) -> tqdm:
    """A tqdm bar of ``total`` steps on ``stream`` (stderr); ``options`` go to tqdm (``desc``,
    ``unit``, ``initial``, …).  ``log_every``: seconds between the lines that updates alone
    write when the stream is not a terminal (default: none, only refreshes write)."""
    stream = sys.stderr if stream is None else stream
    if not enabled:
        return tqdm(total=total, disable=True)
    if getattr(stream, "isatty", lambda: False)():
        return tqdm(total=total, file=stream, **options)
    return _LogLines(total=total, file=stream, mininterval=log_every, miniters=1, ascii=True, **options)


def finish(bar: tqdm, message: str) -> None:
    """Close ``bar`` at its total with ``message`` as its last postfix."""
    bar.set_postfix_str(message, refresh=False)
    if bar.total is not None and bar.n < bar.total:
        bar.update(bar.total - bar.n)
    bar.close()
