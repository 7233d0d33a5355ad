"""The numbers of a sampled response (``armlab.metrics``), compiled: one pass per component of
every run, the GIL released, so that a sweep's threads measure their runs side by side.

For each run r and component c of e (N, R, k) sampled at t (R,), the window being samples
``first`` … R − 1 (the last 5 % of the run, ``armlab.metrics.tail_slice``), n_w its count:

    e_∞         = e_0 + (1/n_w) Σ_window (e − e_0)             final value (e_0 the window's
                                                             first sample: a constant's is exact)
    rms         = √((1/n_w) Σ_window (e − e_∞)²)             oscillation about it
    peak_to_peak = max_window e − min_window e
    deviation   = max_t |e − e_∞|                            (NaN if a sample is NaN)
    settling    = t[i + 1], i the last sample with |e − e_∞| > band · peak,
                  peak = max_t |e − e_∞| over the finite samples; t[0] if there is none or
                  peak = 0; NaN if i is the last sample
    overshoot   = 100 · max(0, max_t −sgn(s) (e − e_∞)) / |s| [%], s = e(t_0) − e_∞, for a step
                  response (s ≠ 0 and |s| ≥ deviation · (1 − 1e-9)); NaN otherwise

Sums run sample by sample in time order; maxima propagate NaN as NumPy's ``max`` does.  Every
caller, one run or a batch, measures with these kernels, so a run measured with others gets
the bits it gets alone.
"""

from __future__ import annotations

import math

from numba import njit

FINAL, RMS, PEAK_TO_PEAK, DEVIATION, SETTLING, OVERSHOOT = range(6)


@njit(cache=True, inline="always")
def _max(a, b):
    """max(a, b), NaN if either is NaN (NumPy's ``max``)."""
    if math.isnan(a) or math.isnan(b):
        return math.nan
    return a if a > b else b


@njit(cache=True, inline="always")
def _min(a, b):
    if math.isnan(a) or math.isnan(b):
        return math.nan
    return a if a < b else b


@njit(cache=True, nogil=True)
def response_into(t, e, first, band, out):
    """out[r, c, :] = (e_∞, rms, peak_to_peak, deviation, settling, overshoot) of e[r, :, c]
    (module docstring); t (R,), e (N, R, k), out (N, k, 6)."""
    runs, samples, k = e.shape
    count = samples - first
    for r in range(runs):
        for c in range(k):
            # The mean about the window's first sample: a constant's mean is then exactly
            # that constant (a plain sum rounds it, leaving a deviation of an ulp to settle).
            origin = e[r, first, c]
            total = 0.0
            for i in range(first, samples):
                total += e[r, i, c] - origin
            final = origin + total / count
            squares = 0.0
            high = low = e[r, first, c]
            for i in range(first, samples):
                d = e[r, i, c] - final
                squares += d * d
                high, low = _max(high, e[r, i, c]), _min(low, e[r, i, c])
            deviation = -math.inf
            peak = -math.inf                      # over the finite samples (NumPy's nanmax)
            for i in range(samples):
                d = abs(e[r, i, c] - final)
                deviation = _max(deviation, d)
                if not math.isnan(d) and d > peak:
                    peak = d
            if peak == -math.inf:
                peak = math.nan                   # no finite sample
            last = -1
            for i in range(samples):
                if abs(e[r, i, c] - final) > band * peak:
                    last = i
            if last < 0 or peak == 0.0:
                settling = t[0]
            elif last == samples - 1:
                settling = math.nan
            else:
                settling = t[last + 1]
            start = e[r, 0, c] - final
            overshoot = math.nan
            if start != 0.0 and not (abs(start) < deviation * (1.0 - 1e-9)):
                sign = math.nan if math.isnan(start) else (1.0 if start > 0.0 else -1.0)
                beyond = -math.inf
                for i in range(samples):
                    beyond = _max(beyond, -sign * (e[r, i, c] - final))
                overshoot = 100.0 * (beyond if beyond > 0.0 else 0.0) / abs(start)
            out[r, c, FINAL] = final
            out[r, c, RMS] = math.sqrt(squares / count)
            out[r, c, PEAK_TO_PEAK] = high - low
            out[r, c, DEVIATION] = deviation
            out[r, c, SETTLING] = settling
            out[r, c, OVERSHOOT] = overshoot


@njit(cache=True, nogil=True)
def error_size_into(e, out):
    """out[r] = (√((1/R) Σ_t ‖e(t)‖²), max_t max_c |e_c(t)|) of run r of e (N, R, k)."""
    runs, samples, k = e.shape
    for r in range(runs):
        total = 0.0
        largest = -math.inf
        for i in range(samples):
            row = 0.0
            for c in range(k):
                row += e[r, i, c] * e[r, i, c]
                largest = _max(largest, abs(e[r, i, c]))
            total += row
        out[r, 0] = math.sqrt(total / samples)
        out[r, 1] = largest


@njit(cache=True, nogil=True)
def peak_into(x, out):
    """out[r] = max_t max_c |x_c(t)| of run r of x (N, R, n)."""
    runs, samples, n = x.shape
    for r in range(runs):
        largest = -math.inf
        for i in range(samples):
            for c in range(n):
                largest = _max(largest, abs(x[r, i, c]))
        out[r] = largest


@njit(cache=True, nogil=True)
def saturated_into(tau, limits, out):
    """out[r] = the number of samples of run r at which some |τ_c| ≥ limit_c (1 − 1e-9);
    tau (N, R, n), limits (N, n) (inf: none)."""
    runs, samples, n = tau.shape
    for r in range(runs):
        count = 0
        for i in range(samples):
            for c in range(n):
                if abs(tau[r, i, c]) >= limits[r, c] * (1.0 - 1e-9):
                    count += 1
                    break
        out[r] = count
