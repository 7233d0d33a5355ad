"""Numbers that describe a closed-loop response, from its sampled signal alone.

Definitions (each over one component e(t) sampled at times t; "the window" is the last
``WINDOW`` = 5 % of the run):

* final value e_∞ — the mean of e over the window;
* oscillation — the RMS of e − e_∞ over the window, and its peak-to-peak range: a steady state
  is the pair (mean, oscillation), so that a limit cycle is not read as a small error;
* settling time (band b = 2 %) — the first time after which |e − e_∞| ≤ b · max_t |e − e_∞|
  for the rest of the run: settling into a band around the final value, whatever that value
  is (a constant offset settles); ``None`` if the last sample is outside the band;
* overshoot — how far e goes past e_∞ on the side opposite to its start, in % of the initial
  distance |e(t_0) − e_∞| (0 for a monotone response); defined for step responses only, where
  e starts at its largest distance from e_∞ (``None`` otherwise, e.g. a velocity error);
* time at a limit — the share of samples with |τ| at the limit (within 1e-9 relative).
"""

from __future__ import annotations

import numpy as np

WINDOW = 0.05
BAND = 0.02
FORCE_REFERENCES = ("f_d", "f_des", "h_d", "h_des", "f_ref")
"""Names of the logged signals that carry a desired contact force, the first one present wins."""


def tail_slice(t: np.ndarray, fraction: float = WINDOW) -> slice:
    """The samples of the last ``fraction`` of the time span (at least one)."""
    start = t[-1] - fraction * (t[-1] - t[0])
    first = int(np.searchsorted(t, start, side="left"))
    return slice(min(first, t.size - 1), None)


def steady_state(t: np.ndarray, e: np.ndarray, fraction: float = WINDOW) -> tuple[float, float, float]:
    """(final value e_∞, RMS oscillation, peak-to-peak) of ``e`` over the last ``fraction``."""
    window = np.asarray(e[tail_slice(t, fraction)], dtype=float)
    mean = float(np.mean(window))
    return mean, float(np.sqrt(np.mean((window - mean) ** 2))), float(np.ptp(window))


def settling_time(t: np.ndarray, e: np.ndarray, band: float = BAND, fraction: float = WINDOW) -> float | None:
    """Time [s] after which ``e`` stays within ``band`` × max|e − e_∞| of its final value e_∞;
    ``None`` if the last sample is still outside.  ``t[0]`` for a constant signal."""
    final, _, _ = steady_state(t, e, fraction)
    deviation = np.abs(np.asarray(e, dtype=float) - final)
    peak = float(np.nanmax(deviation))
    if peak == 0.0:
        return float(t[0])
    outside = np.flatnonzero(deviation > band * peak)
    if outside.size == 0:
        return float(t[0])
    last = int(outside[-1])
    if last == t.size - 1:
        return None
    return float(t[last + 1])


def overshoot(t: np.ndarray, e: np.ndarray, fraction: float = WINDOW) -> float | None:
    """Overshoot [%] of ``e`` past its final value, relative to its initial distance from it;
    ``None`` unless e starts at its largest distance from the final value (a step response:
    a signal that starts at rest, like a velocity error, has no overshoot to speak of)."""
    final, _, _ = steady_state(t, e, fraction)
    start = float(e[0]) - final
    if start == 0.0 or abs(start) < float(np.max(np.abs(np.asarray(e, dtype=float) - final))) * (1 - 1e-9):
        return None
    beyond = -np.sign(start) * (np.asarray(e, dtype=float) - final)
    return 100.0 * max(0.0, float(np.max(beyond))) / abs(start)


def time_at_limit(tau: np.ndarray, limit: float) -> float:
    """Share [%] of the samples of ``tau`` at ``|limit|`` (saturated)."""
    return 100.0 * float(np.mean(np.abs(tau) >= abs(limit) * (1.0 - 1e-9)))
