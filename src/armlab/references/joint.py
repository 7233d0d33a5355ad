"""Desired trajectories q_des(t), q̇_des(t), q̈_des(t), evaluated by one compiled kernel.

A reference is a small frozen dataclass; its ``data`` is a flat float64 array (kind, size,
then the kind's numbers) read by :func:`reference_into`, so a controller's compiled law can
evaluate any reference without being recompiled for it.  Every reference is defined for all
t (constant before its start and after its end where that applies).

Kinds (notation table, C-tags of ``docs/notation.md``):

* :class:`Constant`            q_des = q_c                                                  (R1)
* :class:`ViaPoints`           rest-to-rest quintic between consecutive points (t_j, q_j):
  q_des = q_j + (q_{j+1} − q_j) s(u),  s(u) = 10u³ − 15u⁴ + 6u⁵,  u = (t − t_j)/(t_{j+1} − t_j)
  (zero velocity and acceleration at every point: the seed's steps, made smooth)          (R2)
* :class:`Sinusoid`            q_des = q_c + A sin(ω t + φ)                                 (R3)
* :class:`Ramp`                q_des = q_0 + v (t − t_0) from t_0 until q_end is reached    (R4)
* :class:`SquareWaveAcceleration`  q̈_des = +A on the first half of each period P, −A on the
  second; q̇_des(0) = −A P/4 so the velocity is a zero-mean triangle wave and
  q_des = q_c − A P τ/4 + A τ²/2 (τ = t mod P < P/2), a periodic wave of amplitude A P²/32
  about q_c (seed A8 case 2)                                                               (R5)
* piecewise polynomials (``armlab.references.trajectories``: trapezoidal velocity profiles,
  linear segments with parabolic blends, cubic and quintic splines): on [t_j, t_{j+1})
  q_des = Σ_k c_jk (t − t_j)^k, k ≤ 5, held at its first and last value outside the breaks (R8)
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from armlab.errors import ReferenceSpecError
from armlab.registry import scenario_type

CONSTANT, VIA_POINTS, SINUSOID, RAMP, SQUARE_ACCEL, PIECEWISE = 0, 1, 2, 3, 4, 5
PIECEWISE_ORDER = 6  # coefficients per piece and joint: degree ≤ 5


# Inlined into the law that evaluates the reference (four times a step): there the reference
# data is borrowed (armlab.kernels.boundary), and the reference-counting code folds away, which
# it cannot in a separately compiled function (~1 ms of a 10 s PRP run at 1 kHz).
kernel = njit(cache=True, inline="always")


@kernel
def quintic(u):
    """s(u), s'(u), s''(u) of the rest-to-rest quintic (R2), u ∈ [0, 1]."""
    u2 = u * u
    u3 = u2 * u
    return (10.0 * u3 - 15.0 * u3 * u + 6.0 * u3 * u2,
            30.0 * u2 - 60.0 * u3 + 30.0 * u3 * u,
            60.0 * u - 180.0 * u2 + 120.0 * u3)


@kernel
def reference_into(ref, t, q_des, qd_des, qdd_des):
    """Evaluate the reference ``ref`` (a ``JointReference.data`` array) at time t [s].

    Writes q_des, qd_des, qdd_des (n,) [m | rad, /s, /s²] following (R1)–(R5).
    """
    kind = int(ref[0])
    n = int(ref[1])
    if kind == CONSTANT:
        for i in range(n):
            q_des[i] = ref[2 + i]
            qd_des[i] = 0.0
            qdd_des[i] = 0.0
    elif kind == VIA_POINTS:
        # ref = [kind, n, count, times (count), values (count × n)], indexed in place: slices
        # and 2n + 1 divisions cost half of this branch, which runs four times a step.
        count = int(ref[2])
        if t <= ref[3]:
            j, s, sd, sdd = 0, 0.0, 0.0, 0.0
        elif t >= ref[2 + count]:
            j, s, sd, sdd = count - 2, 1.0, 0.0, 0.0
        else:
            j = 0
            while t >= ref[4 + j]:
                j += 1
            rate = 1.0 / (ref[4 + j] - ref[3 + j])
            s, sd, sdd = quintic((t - ref[3 + j]) * rate)
            sd, sdd = sd * rate, sdd * (rate * rate)        # d/dt and d²/dt² of s(u(t))
        first = 3 + count + j * n
        for i in range(n):
            a = ref[first + i]
            delta = ref[first + n + i] - a
            q_des[i] = a + delta * s
            qd_des[i] = delta * sd
            qdd_des[i] = delta * sdd
    elif kind == SINUSOID:
        for i in range(n):
            center, amp, omega, phase = ref[2 + i], ref[2 + n + i], ref[2 + 2 * n + i], ref[2 + 3 * n + i]
            arg = omega * t + phase
            q_des[i] = center + amp * np.sin(arg)
            qd_des[i] = amp * omega * np.cos(arg)
            qdd_des[i] = -amp * omega * omega * np.sin(arg)
    elif kind == RAMP:
        t0 = ref[2 + 3 * n]
        for i in range(n):
            start, slope, end = ref[2 + i], ref[2 + n + i], ref[2 + 2 * n + i]
            elapsed = t - t0
            if elapsed <= 0.0:
                q_des[i], qd_des[i] = start, 0.0
            elif slope == 0.0 or elapsed >= (end - start) / slope:
                q_des[i], qd_des[i] = end, 0.0
            else:
                q_des[i], qd_des[i] = start + slope * elapsed, slope
            qdd_des[i] = 0.0
    elif kind == PIECEWISE:
        # ref = [kind, n, m, breaks (m + 1), coefficients (m × n × 6, ascending powers)].
        m = int(ref[2])
        first_break, last_break = ref[3], ref[3 + m]
        if t <= first_break:
            j, tau, hold = 0, 0.0, True
        elif t >= last_break:
            j, tau, hold = m - 1, last_break - ref[2 + m], True
        else:
            lo, hi = 0, m - 1                 # bisection: a spline may have many pieces
            while lo < hi:
                mid = (lo + hi + 1) // 2
                if ref[3 + mid] <= t:
                    lo = mid
                else:
                    hi = mid - 1
            j, tau, hold = lo, t - ref[3 + lo], False
        base = 4 + m + j * n * PIECEWISE_ORDER
        for i in range(n):
            c = base + i * PIECEWISE_ORDER
            value, rate, curvature = 0.0, 0.0, 0.0
            for k in range(PIECEWISE_ORDER - 1, -1, -1):   # Horner, with the two derivatives
                curvature = curvature * tau + 2.0 * rate
                rate = rate * tau + value
                value = value * tau + ref[c + k]
            q_des[i] = value
            qd_des[i] = 0.0 if hold else rate
            qdd_des[i] = 0.0 if hold else curvature
    else:
        for i in range(n):
            center, amp, period = ref[2 + i], ref[2 + n + i], ref[2 + 2 * n + i]
            tau = t - period * np.floor(t / period)
            v0 = -amp * period / 4.0
            half = 0.5 * period
            if tau < half:
                q_des[i] = center + v0 * tau + 0.5 * amp * tau * tau
                qd_des[i] = v0 + amp * tau
                qdd_des[i] = amp
            else:
                s = tau - half
                q_des[i] = center + (v0 + amp * half) * s - 0.5 * amp * s * s
                qd_des[i] = v0 + amp * half - amp * s
                qdd_des[i] = -amp


def _vector(value, n: int | None, field: str) -> np.ndarray:
    array = np.atleast_1d(np.asarray(value, dtype=float))
    if array.ndim != 1 or (n is not None and array.shape[0] not in (1, n)):
        raise ReferenceSpecError(f"{field}: expected {n or 'a vector of'} values, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ReferenceSpecError(f"{field}: values must be finite")
    return array if n is None or array.shape[0] == n else np.full(n, array[0])


def _times_and_values(times, values) -> tuple[np.ndarray, np.ndarray]:
    """(times (m,), values (m, n)) of a reference through points: strictly increasing times,
    at least two, one finite row of values per time."""
    times = _vector(times, None, "times")
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[0] != times.shape[0]:
        raise ReferenceSpecError(f"values: expected shape ({times.shape[0]}, n) matching times, "
                                 f"got {values.shape}")
    if times.shape[0] < 2 or np.any(np.diff(times) <= 0):
        raise ReferenceSpecError("times: need at least two strictly increasing times")
    if not np.all(np.isfinite(values)):
        raise ReferenceSpecError("values: values must be finite")
    return times, values


class JointReference:
    """Base of the references: ``data`` for the compiled kernel, ``n``, ``evaluate``."""

    @property
    def n(self) -> int:
        return int(self.data[1])

    @cached_property
    def data(self) -> np.ndarray:
        array = np.ascontiguousarray(self._data(), dtype=float)
        array.setflags(write=False)
        return array

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q_des, qd_des, qdd_des at the times ``t`` (scalar → (n,), (N,) → (N, n))."""
        times = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((3, times.shape[0], self.n))
        for k, tk in enumerate(times):
            reference_into(self.data, tk, out[0, k], out[1, k], out[2, k])
        if np.ndim(t) == 0:
            return out[0, 0], out[1, 0], out[2, 0]
        return out[0], out[1], out[2]

    def describe(self) -> dict:
        out = {"type": type(self).__name__}
        for key, value in vars(self).items():
            if key != "data":
                out[key] = np.asarray(value).tolist()
        return out


@scenario_type("constant")
@dataclass(frozen=True, eq=False)
class Constant(JointReference):
    """q_des = value (R1); ``value`` (n,) [m | rad]."""

    value: np.ndarray

    def _data(self):
        value = _vector(self.value, None, "value")
        return np.concatenate([[CONSTANT, value.shape[0]], value])


@scenario_type("via_points")
@dataclass(frozen=True, eq=False)
class ViaPoints(JointReference):
    """Quintic rest-to-rest motion through ``values`` (m, n) reached at ``times`` (m,) (R2)."""

    times: np.ndarray
    values: np.ndarray

    def _data(self):
        times, values = _times_and_values(self.times, self.values)
        return np.concatenate([[VIA_POINTS, values.shape[1], times.shape[0]], times, values.ravel()])


@scenario_type("sinusoid")
@dataclass(frozen=True, eq=False)
class Sinusoid(JointReference):
    """q_des = center + amplitude sin(omega t + phase) (R3); per joint, scalars broadcast."""

    center: np.ndarray
    amplitude: np.ndarray
    omega: np.ndarray
    phase: np.ndarray = 0.0

    def _data(self):
        center = _vector(self.center, None, "center")
        n = center.shape[0]
        parts = [_vector(getattr(self, f), n, f) for f in ("amplitude", "omega", "phase")]
        return np.concatenate([[SINUSOID, n], center, *parts])


@scenario_type("ramp")
@dataclass(frozen=True, eq=False)
class Ramp(JointReference):
    """q_des from ``start`` at ``t_start`` with ``slope`` [/s] until ``end`` (R4)."""

    start: np.ndarray
    slope: np.ndarray
    end: np.ndarray
    t_start: float = 0.0

    def _data(self):
        start = _vector(self.start, None, "start")
        n = start.shape[0]
        slope, end = _vector(self.slope, n, "slope"), _vector(self.end, n, "end")
        moving = slope != 0.0
        if np.any((end[moving] - start[moving]) / slope[moving] < 0):
            raise ReferenceSpecError("slope: a ramp must head from start towards end")
        return np.concatenate([[RAMP, n], start, slope, end, [float(self.t_start)]])


@scenario_type("square_wave_acceleration")
@dataclass(frozen=True, eq=False)
class SquareWaveAcceleration(JointReference):
    """q̈_des = ±amplitude, a square wave of ``period`` P [s] about ``center`` (R5)."""

    center: np.ndarray
    amplitude: np.ndarray
    period: np.ndarray

    def _data(self):
        center = _vector(self.center, None, "center")
        n = center.shape[0]
        amplitude, period = _vector(self.amplitude, n, "amplitude"), _vector(self.period, n, "period")
        if np.any(period <= 0):
            raise ReferenceSpecError("period: must be positive")
        return np.concatenate([[SQUARE_ACCEL, n], center, amplitude, period])

