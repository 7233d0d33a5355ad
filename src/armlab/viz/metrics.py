"""The report's metric tables, measured on a :class:`SimulationResult`.

The definitions (final value and oscillation over the last 5 % of the run, settling into a
2 % band around the final value, overshoot) are those of :mod:`armlab.metrics`, printed in the
report from its docstring.  Rows, per component:

* every error signal ``*_err``: steady state (mean and RMS oscillation over the window), its
  settling time, its overshoot, and the RMS over the second half of the run (the regime of a
  periodic reference);
* peak |τ_i| and the share of the run spent at the saturation limit;
* final contact wrench (window mean) and its error against the desired force;
* final parameter estimates against the true values;
* the theory's predictions (:func:`armlab.theory.predictions`) beside the measured value.

A diverged run has no metrics: its last samples (10¹⁶ rad, 10⁸³ N·m) describe the blow-up,
not the loop; the report prints its diagnosis instead.  A component that stays at rounding
level over the run (``armlab.metrics.at_rounding``) reads "zero to rounding", never an
overshoot or a settling time of its floating-point residue.  A run driven by a periodic
reference or disturbance has no steady state: its errors get their RMS and peak over the
second half only.

Each metric is a :class:`Metric` row (quantity, component, value, unit) for the report's tables.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab.metrics import (
    FORCE_REFERENCES,
    ROUNDING,
    WINDOW,
    at_rounding,
    response,
    tail_slice,
    time_at_limit,
)
from armlab.viz.scope_model import pretty


@dataclass(frozen=True)
class Metric:
    """One measured number: ``quantity`` of ``component``, ``value`` in ``unit`` (text if not
    a number, e.g. "not settled")."""

    quantity: str
    component: str
    value: float | str
    unit: str = ""
    digits: int = 3

    def formatted(self) -> str:
        if isinstance(self.value, str):
            return self.value
        if self.value == 0.0:
            return "0"
        magnitude = abs(self.value)
        if 1e-3 <= magnitude < 1e4:
            return f"{self.value:.{self.digits}g}"
        return f"{self.value:.{self.digits - 1}e}"


ZERO_TO_ROUNDING = "zero to rounding"
EQUILIBRIUM_DIGITS = 4  # significant digits of equilibria and contact forces
PERIODIC_REFERENCES = ("Sinusoid", "SquareWaveAcceleration")
PERIODIC_DISTURBANCES = ("SinusoidalTorque",)


def periodic(result) -> bool:
    """True for a run driven by a periodic reference (R3, R5) or a sinusoidal disturbance."""
    controller = result.meta.get("controller")
    reference = controller.get("reference") if isinstance(controller, dict) else None
    if isinstance(reference, dict) and reference.get("type") in PERIODIC_REFERENCES:
        return True
    terms = result.meta.get("disturbance") or []
    return any(isinstance(term, dict) and term.get("type") in PERIODIC_DISTURBANCES for term in terms)


def _error_rows(t: np.ndarray, name: str, data: np.ndarray, labels, units, cyclic: bool) -> list[Metric]:
    """The rows of one error signal (see the module docstring)."""
    rows = []
    half = slice(t.size // 2, None)
    r = response(t, data)
    rounding = at_rounding(data)
    what = pretty(name)
    for k, label in enumerate(labels):
        unit, component = units[k], pretty(label)
        rms = Metric(f"RMS {what} (2nd half)", component, float(np.sqrt(np.mean(data[half, k] ** 2))), unit)
        if rounding[k]:
            first = f"RMS {what} (2nd half)" if cyclic else f"steady-state {what} (mean, last 5 %)"
            rows.append(Metric(first, component, ZERO_TO_ROUNDING))
            continue
        if cyclic:
            rows += [rms, Metric(f"peak |{what}| (2nd half)", component, float(np.max(np.abs(data[half, k]))),
                                 unit)]
            continue
        rows.append(Metric(f"steady-state {what} (mean, last 5 %)", component, float(r.final[k]), unit))
        rows.append(Metric(f"oscillation of {what} (RMS, last 5 %)", component, float(r.rms[k]), unit))
        ts = float(r.settling_time[k])
        settled = not np.isnan(ts)
        rows.append(Metric(f"settling time (2 % band about the final value) of {what}",
                           component, ts if settled else "not settled", "s" if settled else ""))
        if not np.isnan(r.overshoot[k]):
            rows.append(Metric(f"overshoot of {what}", component, float(r.overshoot[k]), "%"))
        rows.append(rms)
    return rows


def measure(result, predicted=()) -> list[Metric]:
    """Every metric of the module docstring that ``result`` has the signals for; ``predicted``
    the :class:`armlab.theory.Prediction` s of its scenario."""
    if result.status == "diverged":
        return []
    t = np.asarray(result.t)
    tail = tail_slice(t, WINDOW)
    half = slice(t.size // 2, None)
    rows: list[Metric] = []
    cyclic = periodic(result)
    for name, data in result.signals.items():
        if name.endswith("_err"):
            rows += _error_rows(t, name, data, result.labels[name], result.units[name], cyclic)
    limit = result.meta.get("torque_limit")
    limits = None if limit is None else np.broadcast_to(np.asarray(limit, dtype=float), (result.n,))
    for k, label in enumerate(result.labels["tau"]):
        unit = result.units["tau"][k]
        if at_rounding(result.tau[:, k])[0]:
            rows.append(Metric("peak |τ|", pretty(label), ZERO_TO_ROUNDING))
        else:
            rows.append(Metric("peak |τ|", pretty(label), float(np.max(np.abs(result.tau[:, k]))), unit))
        if limits is not None and np.isfinite(limits[k]):
            rows.append(Metric("time at the torque limit", pretty(label),
                               time_at_limit(result.tau[:, k], limits[k]), "%"))
    if "h_e" in result.signals:
        h = result.signals["h_e"]
        ref = next((r for r in FORCE_REFERENCES if r in result.signals), None)
        for k, label in enumerate(result.labels["h_e"]):
            final = float(np.mean(h[tail, k]))
            desired = None
            if ref is not None and k < result.signals[ref].shape[1]:
                desired = float(np.mean(result.signals[ref][tail, k]))
            if abs(final) < 1e-9 and not desired:
                continue
            rows.append(Metric("final contact wrench h_e", label, final, result.units["h_e"][k],
                               digits=EQUILIBRIUM_DIGITS))
            if desired is not None:
                rows.append(Metric(f"final force error {ref} − h_e", label, desired - final,
                                   result.units["h_e"][k]))
    for name, data in result.signals.items():
        if not name.endswith("_hat"):
            continue
        truth = result.signals.get(name[:-4] + "_true")
        true_values = result.meta.get("true_parameters")
        for k, label in enumerate(result.labels[name]):
            unit = result.units[name][k]
            rows.append(Metric(f"final estimate {pretty(name)}", pretty(label), float(data[-1, k]), unit))
            if truth is not None:
                rows.append(Metric("true value", pretty(label), float(truth[-1, k]), unit))
            elif true_values is not None and k < len(true_values):
                rows.append(Metric("true value", pretty(label), float(true_values[k]), unit))
    z_labels = tuple(result.labels.get("z", ()))
    true_values = result.meta.get("true_parameters")
    if z_labels and all(label.endswith("_hat") for label in z_labels):
        for k, label in enumerate(z_labels):
            unit = result.units["z"][k]
            rows.append(Metric("final estimate", pretty(label), float(result.z[-1, k]), unit))
            if true_values is not None and len(true_values) == len(z_labels):
                rows.append(Metric("true value", pretty(label), float(true_values[k]), unit))
        regressor = result.signals.get("Y")
        if true_values is not None and regressor is not None and regressor.shape[1] == len(z_labels):
            mismatch = np.sum(regressor * (result.z - np.asarray(true_values, dtype=float)), axis=1)
            rows.append(Metric("RMS Y(π̂ − π) (2nd half)", "", float(np.sqrt(np.mean(mismatch[half] ** 2))),
                               result.units["tau"][0]))
    rows += _rest_distance(result, tail)
    for prediction in predicted:
        try:
            run = None if prediction.measured is None else prediction.measured(result)
        except (KeyError, IndexError):   # a run stopped early may lack what is measured
            run = None
        for k, label in enumerate(prediction.labels):
            unit = prediction.units[k]
            theory = float(prediction.values[k])
            rows.append(_equilibrium(f"{prediction.quantity}, theory", pretty(label), theory, unit))
            if run is not None:
                rows.append(_equilibrium(f"{prediction.quantity}, run", pretty(label), float(run[k]), unit))
    return rows


def _equilibrium(quantity: str, component: str, value: float, unit: str) -> Metric:
    """A predicted or measured equilibrium value: to :data:`EQUILIBRIUM_DIGITS` significant
    digits (−0.1998 m, 1.996 N: where the seed's point is a small offset from a round
    number), "zero to rounding" for a nonzero residue (an exact 0 stays 0)."""
    if value != 0.0 and abs(value) < ROUNDING:
        return Metric(quantity, component, ZERO_TO_ROUNDING)
    return Metric(quantity, component, value, unit, digits=EQUILIBRIUM_DIGITS)


def _rest_distance(result, tail: slice) -> list[Metric]:
    """The final distance of p_e from a spring's rest plane (through o_r, normal to its
    stiffest translational direction n, oriented as Σ_r's), in mm: the compliance the seed
    shows (0.2 mm) is too small for a position in m."""
    environment = result.meta.get("environment")
    if not (isinstance(environment, dict) and "p" in result.signals and "rest_position" in environment):
        return []
    stiffness = np.asarray(environment.get("stiffness", ()), dtype=float)
    if stiffness.shape != (6, 6) or not np.any(stiffness[:3, :3]):
        return []
    values, vectors = np.linalg.eigh(stiffness[:3, :3])
    rotation = np.asarray(environment.get("rest_rotation", np.eye(3)), dtype=float)
    normal = rotation @ vectors[:, int(np.argmax(values))]
    normal *= np.sign(normal[np.argmax(np.abs(normal))])  # towards +x, +y or +z of Σ_0, the closest
    final = np.mean(result.signals["p"][tail], axis=0)
    distance = 1e3 * float(normal @ (final - np.asarray(environment["rest_position"], dtype=float)))
    axis = "xyz"[int(np.argmax(np.abs(normal)))]
    aligned = np.isclose(np.abs(normal).max(), 1.0)
    label = f"n = +{axis}_0" if aligned else f"n = {np.round(normal, 3).tolist()}"
    return [Metric(f"final p_e − o_r along the spring's stiff direction ({label})", "p_e", distance, "mm",
                   digits=EQUILIBRIUM_DIGITS)]
