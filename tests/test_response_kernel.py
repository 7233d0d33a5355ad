"""The compiled response kernels (``armlab.kernels.response``) against the definitions of
``armlab.metrics`` written out in NumPy, vectorised over components (an independent
implementation: pairwise sums, boolean masks), on step responses, oscillations, constants and
signals with NaN; and the sweep's metrics of a run measured alone and with others, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.metrics import BAND, WINDOW, response, tail_slice


def numpy_response(t, e, band=BAND, fraction=WINDOW):
    """The six numbers of every column of e (R, k), as the module docstring defines them."""
    rows = np.ascontiguousarray(e.T)
    window = rows[:, tail_slice(t, fraction)]
    final = np.mean(window, axis=1)
    rms = np.sqrt(np.mean((window - final[:, None]) ** 2, axis=1))
    peak_to_peak = np.max(window, axis=1) - np.min(window, axis=1)
    offset = rows - final[:, None]
    deviation = np.abs(offset)
    largest = np.max(deviation, axis=1)
    with np.errstate(invalid="ignore"):
        peak = np.array([np.nan if np.all(np.isnan(d)) else np.nanmax(d) for d in deviation])
        outside = deviation > band * peak[:, None]
    last = rows.shape[1] - 1 - np.argmax(outside[:, ::-1], axis=1)
    settled = np.where(last == rows.shape[1] - 1, np.nan, t[np.minimum(last + 1, t.size - 1)])
    settled = np.where((peak == 0.0) | ~outside.any(axis=1), float(t[0]), settled)
    start = rows[:, 0] - final
    with np.errstate(invalid="ignore", divide="ignore"):
        step = (start != 0.0) & ~(np.abs(start) < largest * (1 - 1e-9))
        beyond = np.max(-np.sign(start)[:, None] * offset, axis=1)
        over = 100.0 * np.where(beyond > 0.0, beyond, 0.0) / np.abs(start)
    return final, rms, peak_to_peak, largest, settled, np.where(step, over, np.nan)


def signals(seed: int):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 2.0, 801)
    decay = rng.uniform(1.0, 6.0)
    columns = [
        rng.uniform(-1, 1) * np.exp(-decay * t) * np.cos(rng.uniform(2, 12) * t),        # step, overshoot
        rng.uniform(0.1, 1) * np.exp(-decay * t) + rng.uniform(-0.1, 0.1),                # monotone, offset
        0.01 * np.sin(rng.uniform(20, 40) * t),                                           # limit cycle
        np.full(t.size, rng.uniform(-1, 1)),                                              # constant
        np.where(t > 1.0, 1.0, 0.0) * rng.uniform(0.5, 1.5),                              # starts at rest
    ]
    return t, np.stack(columns, axis=1)


@pytest.mark.parametrize("seed", range(8))
def test_the_kernel_gives_the_numpy_definitions(seed):
    t, e = signals(seed)
    got = response(t, e)
    for name, mine, theirs in zip(got._fields, got, numpy_response(t, e), strict=True):
        np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-12, err_msg=name)
    # One component alone is that column of the many.
    one = response(t, e[:, 0])
    assert all(np.array_equal(a[:1], b[:1], equal_nan=True) for a, b in zip(one, got, strict=True))


def test_nan_samples_propagate_as_numpy_does():
    t, e = signals(3)
    e[100, 0] = np.nan                  # outside the window: the deviation and overshoot see it
    e[-1, 1] = np.nan                   # inside it: the final value is NaN
    e[:, 2] = np.nan                    # no finite sample at all
    got = response(t, e)
    for name, mine, theirs in zip(got._fields, got, numpy_response(t, e), strict=True):
        np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-12, err_msg=name)
    assert np.isnan(got.deviation[0]) and np.isnan(got.final[1]) and got.settling_time[2] == t[0]


def test_a_run_measured_with_others_gets_its_own_bits():
    from armlab.sweep.metrics import measure_alike

    t, e = signals(5)
    runs = np.stack([e, 0.5 * e[::-1], e + 0.1])                         # (3, R, 5)
    tau = np.stack([e[:, :3] * 7, e[:, :3] * 5, -e[:, :3]])
    limits = np.array([[1.0, 2.0, np.inf]] * 3)
    together = measure_alike(t, tau, limits, {"q_err": runs}, np.zeros((3, t.size, 0)), True)
    for r in range(3):
        alone = measure_alike(t, tau[r:r + 1].copy(), limits[r:r + 1].copy(), {"q_err": runs[r:r + 1].copy()},
                              np.zeros((1, t.size, 0)), True)
        for name, column in together.items():
            assert np.array_equal(column[r:r + 1], alone[name], equal_nan=True), name
    # The sizes against their definitions.
    np.testing.assert_allclose(together["rms_error"], np.sqrt(np.mean(np.sum(runs ** 2, axis=2), axis=1)),
                               rtol=1e-12)
    assert np.array_equal(together["max_error"], np.abs(runs).reshape(3, -1).max(axis=1))
    assert np.array_equal(together["peak_torque"], np.abs(tau).reshape(3, -1).max(axis=1))
    step = t[1] - t[0]
    at_limit = (np.abs(tau) >= limits[:, None, :] * (1 - 1e-9)).any(axis=2)
    assert np.array_equal(together["saturation_time"], step * at_limit.sum(axis=1))
