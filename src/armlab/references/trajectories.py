"""Joint trajectories as piecewise polynomials (R8): trapezoidal velocity profiles, linear
segments with parabolic blends through via points, cubic and quintic splines.

Each class is a :class:`~armlab.references.joint.JointReference` whose ``data`` is one
piecewise polynomial, evaluated by the compiled ``reference_into`` like every other reference,
so every joint-space controller follows it unchanged:

    q_des(t) = Σ_{k=0..5} c_jk (t − t_j)^k   on [t_j, t_{j+1}),   q̇_des, q̈_des its derivatives  (R8)

held at its first value before t_0 and at its last value after t_m (with zero velocity and
acceleration there: every trajectory here starts and ends at rest).

* :class:`Trapezoidal` — straight joint-space motion from ``start`` to ``end``: all joints on
  one time law s(t) ∈ [0, 1] with constant acceleration, cruise at constant velocity,
  constant deceleration (a triangle when the cruise speed is never reached); the fastest
  such motion within every joint's ``v_max`` and ``a_max`` (Siciliano et al. §4.2.1).
* :class:`BlendedViaPoints` — linear segments between via points joined by parabolic blends
  of duration ``blend`` (Siciliano et al. §4.2.2, "linear polynomials with parabolic blends"):
  the path passes near, not through, the interior via points; it starts at rest at
  ``values[0]`` at ``times[0]`` and ends at rest at ``values[-1]`` at ``times[-1]``.
* :class:`Spline` — interpolating spline through every via point: cubic (``degree=3``,
  clamped: zero velocity at both ends; C²) or quintic (``degree=5``, zero velocity and
  acceleration at both ends; C⁴), by SciPy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.errors import ReferenceSpecError
from armlab.references.joint import PIECEWISE, PIECEWISE_ORDER, JointReference, _times_and_values, _vector
from armlab.registry import scenario_type


def piecewise_data(breaks, coefficients) -> np.ndarray:
    """The ``data`` of a piecewise polynomial: ``breaks`` (m + 1,) [s] strictly increasing,
    ``coefficients`` (m, n, d) in ascending powers of (t − t_j), d ≤ 6."""
    breaks = np.asarray(breaks, dtype=float)
    coefficients = np.asarray(coefficients, dtype=float)
    m, n, degree = coefficients.shape
    padded = np.zeros((m, n, PIECEWISE_ORDER))
    padded[:, :, :degree] = coefficients
    return np.concatenate([[PIECEWISE, n, m], breaks, padded.ravel()])


@scenario_type("trapezoidal")
@dataclass(frozen=True, eq=False)
class Trapezoidal(JointReference):
    """Rest-to-rest straight joint motion ``start`` → ``end`` (n,) [m | rad] from ``t_start``
    [s], trapezoidal velocity within ``v_max`` [m/s | rad/s] and ``a_max`` [m/s² | rad/s²]
    (per joint or one for all).  All joints share the time law, so the path is a straight
    line in joint space; ``duration`` is the shortest that keeps every joint in its limits."""

    start: np.ndarray
    end: np.ndarray
    v_max: np.ndarray
    a_max: np.ndarray
    t_start: float = 0.0

    def profile(self) -> tuple[float, float, float]:
        """(T, t_b, a): duration [s], blend (acceleration) time [s] and acceleration [1/s²] of
        the normalised time law s(t) ∈ [0, 1]."""
        start = _vector(self.start, None, "start")
        n = start.shape[0]
        distance = np.abs(_vector(self.end, n, "end") - start)
        v_max, a_max = _vector(self.v_max, n, "v_max"), _vector(self.a_max, n, "a_max")
        if np.any(v_max <= 0) or np.any(a_max <= 0):
            raise ReferenceSpecError("v_max, a_max: must be positive")
        if not np.isfinite(self.t_start):
            raise ReferenceSpecError("t_start: must be finite")
        moving = distance > 0
        if not np.any(moving):
            return 0.0, 0.0, 0.0
        # |Δ_i| ṡ ≤ v_max_i and |Δ_i| s̈ ≤ a_max_i for every joint.
        speed = float(np.min(v_max[moving] / distance[moving]))
        accel = float(np.min(a_max[moving] / distance[moving]))
        if speed * speed / accel >= 1.0:        # the cruise speed is never reached: a triangle
            blend = float(np.sqrt(1.0 / accel))
            return 2.0 * blend, blend, accel
        blend = speed / accel
        return 1.0 / speed + blend, blend, accel

    @property
    def duration(self) -> float:
        return self.profile()[0]

    def _data(self):
        start = _vector(self.start, None, "start")
        delta = _vector(self.end, start.shape[0], "end") - start
        T, tb, a = self.profile()
        t0 = float(self.t_start)
        if T == 0.0:
            return piecewise_data([t0, t0 + 1.0], start[None, :, None])
        v = a * tb
        # s on [0, t_b): a τ²/2;  [t_b, T − t_b): s_b + v τ;  [T − t_b, T]: 1 − s_b + v τ − a τ²/2.
        sb = 0.5 * a * tb * tb
        pieces = [(0.0, [0.0, 0.0, 0.5 * a]), (tb, [sb, v, 0.0]), (T - tb, [1.0 - sb, v, -0.5 * a])]
        pieces = [piece for piece, following in zip(pieces, [tb, T - tb, T], strict=True)
                  if following - piece[0] > 1e-12 * T]
        breaks = [t0 + begin for begin, _ in pieces] + [t0 + T]
        coefficients = np.array([[[q0 * (k == 0) + d * c for k, c in enumerate(law)]
                                  for q0, d in zip(start, delta, strict=True)] for _, law in pieces])
        return piecewise_data(breaks, coefficients)


@scenario_type("blended_via_points")
@dataclass(frozen=True, eq=False)
class BlendedViaPoints(JointReference):
    """Linear segments through ``values`` (m, n) at ``times`` (m,) [s], joined by parabolic
    blends of ``blend`` [s] centred on the interior times (the path passes near those via
    points, at constant velocity between them); from rest at ``values[0]`` at ``times[0]`` to
    rest at ``values[-1]`` at ``times[-1]`` (the first and last blends lie inside).

    Blends may not overlap: every interior gap must be at least ``blend``, the first and the
    last at least 1.5 ``blend``."""

    times: np.ndarray
    values: np.ndarray
    blend: float

    def _data(self):
        times, values = _times_and_values(self.times, self.values)
        b = float(self.blend)
        if not (np.isfinite(b) and b > 0):
            raise ReferenceSpecError(f"blend: must be a positive duration [s], got {self.blend!r}")
        # Knots of the polyline: the end points moved in by b/2, so that the end blends (from
        # and to rest) start at times[0] and end at times[-1].
        knots = times.copy()
        knots[0] += 0.5 * b
        knots[-1] -= 0.5 * b
        gaps = np.diff(knots)
        if np.any(gaps < b * (1.0 - 1e-12)):
            raise ReferenceSpecError(f"blend: {b:g} s is too long for the via times: consecutive blends "
                                     "would overlap (need gaps ≥ blend inside, ≥ 1.5 blend at the ends)")
        velocities = np.vstack([np.zeros(values.shape[1]), np.diff(values, axis=0) / gaps[:, None],
                                np.zeros(values.shape[1])])        # before, between, after the knots
        breaks, coefficients = [], []
        for j, (knot, value) in enumerate(zip(knots, values, strict=True)):
            v_in, v_out = velocities[j], velocities[j + 1]
            begin = knot - 0.5 * b
            # Parabola over [knot − b/2, knot + b/2]: the incoming line plus (v_out − v_in)(τ)²/(2b).
            breaks.append(begin)
            coefficients.append(np.column_stack([value - 0.5 * b * v_in, v_in, (v_out - v_in) / (2.0 * b)]))
            end = knot + 0.5 * b
            if j + 1 < len(knots) and knots[j + 1] - 0.5 * b - end > 1e-12 * (times[-1] - times[0]):
                breaks.append(end)                                  # the straight part
                coefficients.append(np.column_stack([value + 0.5 * b * v_out, v_out, np.zeros_like(v_out)]))
        breaks.append(times[-1])
        return piecewise_data(breaks, np.array(coefficients))


@scenario_type("spline")
@dataclass(frozen=True, eq=False)
class Spline(JointReference):
    """Interpolating spline through ``values`` (m, n) at ``times`` (m,) [s]: cubic
    (``degree=3``, zero velocity at both ends, C²) or quintic (``degree=5``, zero velocity
    and acceleration at both ends, C⁴), computed by SciPy."""

    times: np.ndarray
    values: np.ndarray
    degree: int = 3

    def _data(self):
        from math import factorial

        from scipy.interpolate import CubicSpline, make_interp_spline

        times, values = _times_and_values(self.times, self.values)
        if self.degree == 3:
            spline = CubicSpline(times, values, bc_type="clamped")
        elif self.degree == 5:
            rest = [(1, np.zeros(values.shape[1])), (2, np.zeros(values.shape[1]))]
            spline = make_interp_spline(times, values, k=5, bc_type=(rest, rest))
        else:
            raise ReferenceSpecError(f"degree: must be 3 (cubic) or 5 (quintic), got {self.degree!r}")
        # One polynomial per interval between distinct knots; its Taylor coefficients at the
        # interval's start, c_k = q⁽ᵏ⁾(t_j)/k! (a knot evaluates on the interval to its right).
        breaks = np.unique(spline.x if self.degree == 3 else spline.t)
        coefficients = np.stack([spline(breaks[:-1], nu=k) / factorial(k) for k in range(self.degree + 1)],
                                axis=-1)
        return piecewise_data(breaks, coefficients)
