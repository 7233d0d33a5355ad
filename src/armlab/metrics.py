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
* time at a limit — the share of samples with |τ| at the limit (within 1e-9 relative);
* zero to rounding — a component whose magnitude stays below ``ROUNDING`` = 1e-10 (SI units)
  over the whole run: floating-point residue, not a response (no quantity of the seed's
  experiments is that small), so none of the numbers above is computed on it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

WINDOW = 0.05
BAND = 0.02
ROUNDING = 1e-10
"""[SI] a signal whose magnitude stays below this over a run is zero to rounding."""
FORCE_REFERENCES = ("f_d", "f_des", "h_d", "h_des", "f_ref")
"""Names of the logged signals that carry a desired contact force, the first one present wins."""


def tail_slice(t: np.ndarray, fraction: float = WINDOW) -> slice:
    """The samples of the last ``fraction`` of the time span (at least one)."""
    start = t[-1] - fraction * (t[-1] - t[0])
    first = int(np.searchsorted(t, start, side="left"))
    return slice(min(first, t.size - 1), None)


class Response(NamedTuple):
    """The numbers of the module docstring for each component of a response (arrays of k)."""

    final: np.ndarray           # e_∞, the mean over the window
    rms: np.ndarray             # RMS oscillation about e_∞ over the window
    peak_to_peak: np.ndarray    # max − min over the window
    deviation: np.ndarray       # max_t |e − e_∞| over the whole run
    settling_time: np.ndarray   # [s]; NaN where the last sample is outside the band
    overshoot: np.ndarray       # [%]; NaN where e does not start at its largest distance


def response(t: np.ndarray, e: np.ndarray, band: float = BAND, fraction: float = WINDOW) -> Response:
    """The :class:`Response` of every column of ``e`` ((R,) or (R, k)) sampled at ``t``, by the
    compiled kernel every caller shares (``armlab.kernels.response``: a sweep measures its
    runs with it too, so each gets the bits it gets alone)."""
    from armlab.kernels.response import response_into

    e = np.asarray(e, dtype=float)
    runs = np.ascontiguousarray(e.reshape(1, e.shape[0], -1))             # (1, R, k)
    out = np.empty((1, runs.shape[2], 6))
    response_into(np.ascontiguousarray(t, dtype=float), runs, tail_slice(t, fraction).start, band, out)
    return Response(*(out[0, :, i].copy() for i in range(6)))


def _component(e) -> np.ndarray:
    """``e`` as one component, (R,); several are measured with :func:`response`."""
    e = np.asarray(e, dtype=float)
    if e.ndim != 1:
        raise ValueError(f"expected one component, shape (R,), got {e.shape}: use response() for several")
    return e


def steady_state(t: np.ndarray, e: np.ndarray, fraction: float = WINDOW) -> tuple[float, float, float]:
    """(final value e_∞, RMS oscillation, peak-to-peak) of ``e`` over the last ``fraction``."""
    r = response(t, _component(e), fraction=fraction)
    return float(r.final[0]), float(r.rms[0]), float(r.peak_to_peak[0])


def settling_time(t: np.ndarray, e: np.ndarray, band: float = BAND, fraction: float = WINDOW) -> float | None:
    """Time [s] after which ``e`` stays within ``band`` × max|e − e_∞| of its final value e_∞;
    ``None`` if the last sample is still outside.  ``t[0]`` for a constant signal."""
    value = float(response(t, _component(e), band, fraction).settling_time[0])
    return None if np.isnan(value) else value


def overshoot(t: np.ndarray, e: np.ndarray, fraction: float = WINDOW) -> float | None:
    """Overshoot [%] of ``e`` past its final value, relative to its initial distance from it;
    ``None`` unless e starts at its largest distance from the final value (a step response:
    a signal that starts at rest, like a velocity error, has no overshoot to speak of)."""
    value = float(response(t, _component(e), fraction=fraction).overshoot[0])
    return None if np.isnan(value) else value


def time_at_limit(tau: np.ndarray, limit: float) -> float:
    """Share [%] of the samples of ``tau`` at ``|limit|`` (saturated)."""
    return 100.0 * float(np.mean(np.abs(tau) >= abs(limit) * (1.0 - 1e-9)))


def at_rounding(e: np.ndarray) -> np.ndarray:
    """Per column of ``e`` ((R,) or (R, k)): True where every finite sample is below
    :data:`ROUNDING` in magnitude (a column with no finite sample is not)."""
    e = np.asarray(e, dtype=float).reshape(len(e), -1)
    finite = np.isfinite(e)
    largest = np.max(np.where(finite, np.abs(e), 0.0), axis=0)
    return finite.any(axis=0) & (largest < ROUNDING)
