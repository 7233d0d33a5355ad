"""Closed-loop responses the theory predicts, drawn over a run's own signals.

A controller designed to impose linear error dynamics

    M ë + D ė + K e = f(t)                                                            (L)

(computed torque, A7: M = I, f = 0; impedance, A12: M = M_d, f = h_A) has a response that
depends only on the gains, the initial state (e(0), ė(0)) and the forcing; plotted over the
logged error it shows where the run follows its design and where it leaves it (saturation, a
wrong model, a wrong wrench).  Beside it, the Lyapunov function of the 1-DoF Slotine–Li law
(A8), whose decrease is that law's proof.
"""

from __future__ import annotations

import numpy as np

COMPUTED_TORQUE = ("JointInverseDynamics",)
"""Controllers (``meta["controller"]["type"]``) whose errors obey (L) with M = I, f = 0."""

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


def designed_error(result) -> np.ndarray | None:
    """q̃(t) (N, n) of the designed loop q̃̈ + K_D q̃̇ + K_P q̃ = 0 from the run's initial error,
    for a computed-torque run that logged q̃ and q̃̇ (None otherwise)."""
    controller = result.meta.get("controller")
    controller = controller if isinstance(controller, dict) else {}
    if controller.get("type") not in COMPUTED_TORQUE or not {"q_err", "qd_err"} <= set(result.signals):
        return None
    kp, kd = controller.get("kp"), controller.get("kd")
    error, rate = result.signals["q_err"], result.signals["qd_err"]
    if kp is None or kd is None or error.shape != rate.shape:
        return None
    n = error.shape[1]
    try:
        K, D = (np.broadcast_to(np.asarray(g, dtype=float), (n, n)) if np.ndim(g) == 2
                else np.diag(np.broadcast_to(np.asarray(g, dtype=float), (n,))) for g in (kp, kd))
    except ValueError:
        return None
    return linear_response(np.eye(n), D, K, np.asarray(result.t), error[0], rate[0])


def lyapunov_function(result) -> dict[str, np.ndarray] | None:
    """V = ½ I σ² + ½ π̃ᵀ Γ⁻¹ π̃ (π̃ = π̂ − π) of a run of the 1-DoF Slotine–Li law (C6), with
    its two terms: ``{"V", "kinetic", "parameters"}`` (N,) [J]; None for other runs.

    I and π are the plant's true parameters (``meta["true_parameters"]``), Γ the controller's
    adaptation gain and π̂ its state; a plant with terms outside Y π (the wrong plants) makes
    V a function that may grow.
    """
    controller = result.meta.get("controller")
    true_values = result.meta.get("true_parameters")
    if not (isinstance(controller, dict) and controller.get("type") == "SlotineLi1DoF"):
        return None
    if true_values is None or "sigma" not in result.signals or "gamma" not in controller:
        return None
    true_values = np.asarray(true_values, dtype=float)
    gamma = np.asarray(controller["gamma"], dtype=float)
    if gamma.ndim == 1:
        gamma = np.diag(gamma)
    if true_values.shape != (3,) or gamma.shape != (3, 3) or result.z.shape[1] != 3:
        return None
    sigma = result.signals["sigma"][:, 0]
    error = result.z - true_values
    kinetic = 0.5 * true_values[0] * sigma**2
    parameters = 0.5 * np.einsum("ij,jk,ik->i", error, np.linalg.inv(gamma), error)
    return {"V": kinetic + parameters, "kinetic": kinetic, "parameters": parameters}
