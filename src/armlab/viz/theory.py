"""Closed-loop responses the theory predicts, drawn over a run's own signals.

A controller designed to impose linear error dynamics

    M ë + D ė + K e = f(t)                                                            (L)

(computed torque, A7: M = I, f = 0; impedance, A12: M = M_d, f = h_A) has a response that
depends only on the gains, the initial state (e(0), ė(0)) and the forcing; plotted over the
logged error it shows where the run follows its design and where it leaves it (saturation, a
wrong model, a wrong wrench).
"""

from __future__ import annotations

import numpy as np

UNIFORM = 1e-6  # relative spread of the time steps below which a grid counts as uniform


def uniform_grid(t: np.ndarray) -> bool:
    """True for at least two equally spaced, increasing samples (what ``lsim`` integrates on)."""
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return False
    steps = np.diff(t)
    return bool(steps.min() > 0.0 and np.ptp(steps) <= UNIFORM * steps.mean())


def linear_response(M, D, K, t, e0, v0, forcing=None) -> np.ndarray | None:
    """The solution e(t) (N, k) of (L) on the samples ``t`` (N,) from e(0) = ``e0`` and
    ė(0) = ``v0`` (k,), ``forcing`` f (N, k) taken linear between samples (None: f = 0).

    Exact for that forcing (SciPy's ``lsim`` integrates the state-space form with the matrix
    exponential of one step).  None when ``t`` is not a uniform grid or a value is not finite.
    """
    from scipy.signal import StateSpace, lsim

    M, D, K = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (M, D, K))
    e0, v0 = np.asarray(e0, dtype=float), np.asarray(v0, dtype=float)
    k = e0.size
    t = np.asarray(t, dtype=float)
    if not uniform_grid(t) or M.shape != (k, k) or D.shape != (k, k) or K.shape != (k, k):
        return None
    values = [M, D, K, e0, v0] + ([np.asarray(forcing)] if forcing is not None else [])
    if not all(np.all(np.isfinite(v)) for v in values):
        return None
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((k, k)), np.eye(k)], [-Minv @ K, -Minv @ D]])
    B = np.vstack([np.zeros((k, k)), Minv])
    C = np.hstack([np.eye(k), np.zeros((k, k))])
    U = np.zeros((t.size, k)) if forcing is None else np.asarray(forcing, dtype=float)
    _, e, _ = lsim(StateSpace(A, B, C, np.zeros((k, k))), U, t - t[0], X0=np.concatenate([e0, v0]))
    return np.asarray(e, dtype=float).reshape(t.size, k)


def initial_rate(t: np.ndarray, e: np.ndarray) -> np.ndarray:
    """ė(t0) of sampled signals e (N, k) by the second-order one-sided difference."""
    if t.size < 3:
        return (e[1] - e[0]) / (t[1] - t[0])
    h = t[1] - t[0]
    return (-3.0 * e[0] + 4.0 * e[1] - e[2]) / (2.0 * h)
