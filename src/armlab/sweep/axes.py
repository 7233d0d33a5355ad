"""Swept quantities: an :class:`Axis` (a variable or a field path with its grid values or its
distribution), read and checked from its entry in a sweep file's ``[grid]``, ``[zip]`` or
``[random]`` table, and the seeded draw of a random one (:func:`draw_value`: inverse CDF, so
that a truncated draw too depends on the seed and the run index only).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr, ndtri

from armlab.errors import SweepFileError
from armlab.model.toml_io import evaluate_expression
from armlab.sweep.fields import _is_field

GRID_KINDS = ("values", "linspace", "geomspace")
RANDOM_KINDS = ("uniform", "normal", "log_uniform", "lognormal")
# A truncation's interval must hold at least this probability of its distribution: below it the
# inverse CDF of the draw has no digits left (and the file has surely a typo).
MIN_TRUNCATED_MASS = 1e-9
MAX_RUNS = 10**9
MAX_AXIS = 10**6
"""The longest grid axis (its values are held in memory; a sweep's runs are not)."""


@dataclass(frozen=True)
class Axis:
    """One swept quantity: a variable (bare name) or a field path, with its grid values or its
    distribution (``kind`` one of GRID_KINDS / RANDOM_KINDS)."""

    key: str
    values: tuple = ()
    kind: str = "values"
    bounds: tuple[float, float] = (0.0, 0.0)
    within: tuple[float, float] | None = None   # truncation [low, high] of a normal or lognormal

    @property
    def is_field(self) -> bool:
        return "." in self.key or "[" in self.key


def draw_value(rng: np.random.Generator, axis: Axis) -> float:
    """One draw of ``axis``'s distribution from ``rng``.

    uniform [a, b]: a + (b − a) u;  normal [μ, σ]: μ + σ z;  log_uniform [a, b]: exp of a uniform
    draw in [ln a, ln b];  lognormal [μ, σ]: exp(μ + σ z), μ and σ those of ln x.  Truncated to
    ``within`` = [l, h] (normal, lognormal) by the inverse CDF, one uniform u per draw:

        z = Φ⁻¹(Φ(α) + u (Φ(β) − Φ(α))),  α = (l − μ)/σ,  β = (h − μ)/σ      (ln l, ln h for lognormal)

    exact (no rejection), so a truncated draw too depends on the seed and the run index only.
    """
    a, b = axis.bounds
    if axis.kind == "uniform":
        return float(rng.uniform(a, b))
    if axis.kind == "log_uniform":
        return float(np.exp(rng.uniform(np.log(a), np.log(b))))
    if axis.within is None:
        z = float(rng.normal(a, b))
    else:
        low, high = _standard_interval(axis)
        z = a + b * float(ndtri(rng.uniform(ndtr(low), ndtr(high))))
    x = float(np.exp(z)) if axis.kind == "lognormal" else z
    if axis.within is not None:
        x = min(max(x, axis.within[0]), axis.within[1])   # rounding must not leave [l, h]
    return x


def _standard_interval(axis: Axis) -> tuple[float, float]:
    """The truncation ``within`` of a normal or lognormal axis in standard units (α, β)."""
    (mu, sigma), (low, high) = axis.bounds, axis.within
    if axis.kind == "lognormal":
        with np.errstate(divide="ignore"):
            low, high = float(np.log(low)), float(np.log(high))
    return (low - mu) / sigma, (high - mu) / sigma


def _number(value, file, where) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise SweepFileError(file, where, f"expected a number, got {value!r}")
    if isinstance(value, str):
        try:
            return evaluate_expression(value, {})
        except (ValueError, ArithmeticError, SyntaxError) as error:
            raise SweepFileError(file, where, f"cannot evaluate {value!r} ({error})") from None
    return float(value)


def _count(value, file, where, low=1, high=MAX_RUNS) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise SweepFileError(file, where, f"expected an integer from {low} to {high}, got {value!r}")
    return value


def _quoting_hint(spec) -> str:
    """A dotted path written without quotes is read by TOML as nested tables."""
    if isinstance(spec, dict) and any(isinstance(v, dict) for v in spec.values()):
        return ' (write a field path in quotes: "controller.kp" = { … })'
    return ""


def _grid_axis(key, spec, file, where) -> Axis:
    if not isinstance(spec, dict) or len(spec) != 1 or next(iter(spec)) not in GRID_KINDS:
        raise SweepFileError(file, where,
                             f"expected one of {{ {' | '.join(f'{k} = […]' for k in GRID_KINDS)} }}"
                              + _quoting_hint(spec))
    kind, raw = next(iter(spec.items()))
    if not isinstance(raw, list) or not raw:
        raise SweepFileError(file, f"{where}.{kind}", "expected a non-empty array")
    if kind == "values":
        if all(isinstance(v, str) for v in raw) and not all(_evaluates(v) for v in raw):
            if _is_field(key):
                return Axis(key, tuple(raw))  # choices of a text field ("online", "none")
            raise SweepFileError(file, f"{where}.values", "a variable takes numbers")
        return Axis(key, tuple(_number(v, file, f"{where}.values[{i}]") for i, v in enumerate(raw)))
    if len(raw) != 3:
        raise SweepFileError(file, f"{where}.{kind}", "expected [first, last, count]")
    first, last = (_number(v, file, f"{where}.{kind}") for v in raw[:2])
    count = _count(raw[2], file, f"{where}.{kind}[2]", high=MAX_AXIS)
    if not (math.isfinite(first) and math.isfinite(last)):
        raise SweepFileError(file, f"{where}.{kind}", "first and last must be finite")
    if kind == "geomspace" and (first <= 0 or last <= 0):
        raise SweepFileError(file, f"{where}.{kind}", "first and last must be positive")
    with np.errstate(over="ignore", invalid="ignore"):
        values = np.linspace(first, last, count) if kind == "linspace" else np.geomspace(first, last, count)
    if not np.all(np.isfinite(values)):
        # last - first beyond the float range (±1.8e308): the spacing is not a number.
        raise SweepFileError(file, f"{where}.{kind}", f"last - first = {last:g} - {first:g} overflows")
    return Axis(key, tuple(float(v) for v in values))


def _evaluates(text: str) -> bool:
    try:
        evaluate_expression(text, {})
    except (ValueError, ArithmeticError, SyntaxError):
        return False
    return True


def _random_axis(key, spec, file, where) -> Axis:
    kinds = [k for k in spec if k in RANDOM_KINDS] if isinstance(spec, dict) else []
    others = [k for k in spec if k not in RANDOM_KINDS and k != "within"] if isinstance(spec, dict) else []
    if len(kinds) != 1 or others:
        raise SweepFileError(file, where,
                             f"expected one of {{ {' | '.join(f'{k} = [a, b]' for k in RANDOM_KINDS)} }}"
                             " (a normal or lognormal may add within = [low, high])" + _quoting_hint(spec))
    kind, raw = kinds[0], spec[kinds[0]]
    if not isinstance(raw, list) or len(raw) != 2:
        raise SweepFileError(file, f"{where}.{kind}", "expected [a, b]")
    a, b = (_number(v, file, f"{where}.{kind}") for v in raw)
    if not (math.isfinite(a) and math.isfinite(b)):
        raise SweepFileError(file, f"{where}.{kind}", "bounds must be finite")
    if kind == "uniform" and not a < b:
        raise SweepFileError(file, f"{where}.{kind}", f"expected a < b, got [{a:g}, {b:g}]")
    # NumPy draws a + (b − a)·u and μ + σ·z: a width or a spread that overflows gives no number.
    if kind == "uniform" and not math.isfinite(b - a):
        raise SweepFileError(file, f"{where}.{kind}", f"b − a overflows ([{a:g}, {b:g}])")
    if kind == "normal" and not math.isfinite(abs(a) + 40.0 * b):
        raise SweepFileError(file, f"{where}.{kind}", f"μ and σ of [{a:g}, {b:g}] give draws beyond "
                                                      "the range of a float")
    if kind == "normal" and not b > 0:
        raise SweepFileError(file, f"{where}.{kind}", f"σ must be positive, got {b:g}")
    if kind == "log_uniform" and not 0 < a < b:
        raise SweepFileError(file, f"{where}.{kind}", f"expected 0 < a < b, got [{a:g}, {b:g}]")
    if kind == "lognormal" and not (b > 0 and abs(a) + 40.0 * b < 700.0):
        raise SweepFileError(file, f"{where}.{kind}", f"expected σ > 0 and exp(μ ± 40σ) within the range of "
                                                      f"a float, got [{a:g}, {b:g}]")
    if "within" not in spec:
        return Axis(key, (), kind, (a, b))
    return Axis(key, (), kind, (a, b), _truncation(Axis(key, (), kind, (a, b)), spec["within"], file,
                                                   f"{where}.within"))


def _truncation(axis: Axis, raw, file, where) -> tuple[float, float]:
    """The checked ``within = [low, high]`` of a normal or lognormal ``axis``: low < high (either
    may be ±inf; a lognormal's low ≥ 0), holding at least :data:`MIN_TRUNCATED_MASS` of it."""
    if axis.kind not in ("normal", "lognormal"):
        raise SweepFileError(file, where, f"only a normal or a lognormal is truncated (a {axis.kind}'s "
                                          "own bounds say where it lies)")
    if not isinstance(raw, list) or len(raw) != 2:
        raise SweepFileError(file, where, "expected [low, high]")
    low, high = (_number(v, file, where) for v in raw)
    if math.isnan(low) or math.isnan(high) or not low < high:
        raise SweepFileError(file, where, f"expected low < high, got [{low:g}, {high:g}]")
    if axis.kind == "lognormal" and low < 0:
        raise SweepFileError(file, where, f"a lognormal draw is positive: low must be ≥ 0, got {low:g}")
    alpha, beta = _standard_interval(Axis(axis.key, (), axis.kind, axis.bounds, (low, high)))
    mass = float(ndtr(beta) - ndtr(alpha))
    if not mass >= MIN_TRUNCATED_MASS:
        raise SweepFileError(file, where, f"[{low:g}, {high:g}] holds {mass:.2g} of the distribution's "
                                          f"probability (at least {MIN_TRUNCATED_MASS:g} needed)")
    return low, high
