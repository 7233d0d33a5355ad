"""The scopes of what no other figure draws: the Jacobian's singular values, on a log axis with
the warning threshold when σ_min comes near it (``singular_values``), and every remaining
logged signal and the controller state, one panel per signal and unit (``signals``).
"""

from __future__ import annotations

import numpy as np

from armlab.viz.scope_model import ACTUAL, LIMIT, Panel, Scope, _Run, _unit_label, pretty, trace_style

SINGULAR_VALUE_NAMES = ("jacobian_sv", "singular_values", "sv", "sigma_j", "jacobian_singular_values")


def _is_singular_value_group(name: str) -> bool:
    return name.lower() in SINGULAR_VALUE_NAMES or "singular" in name.lower()


# ----------------------------------------------------------------------------- singular values


def singular_warning(controller: dict) -> float:
    """The σ_min below which the task controller of this description warns (its own value,
    else the task controllers' default)."""
    from armlab.control.task_space import TaskController

    value = controller.get("singular_warning", TaskController.singular_warning)
    return float(value)


def _singular_value_scopes(run: _Run) -> list[Scope]:
    scopes = []
    for name in run.result.signals:
        if not _is_singular_value_group(name) or name in run.used:
            continue
        data = run.groups[name]
        panel = Panel(_unit_label("σ_i(J)", run.units[name][0] if run.units[name] else ""))
        for k, label in enumerate(run.labels[name]):
            panel.curves.append((pretty(label), run.t, data[:, k], trace_style(k)))
        run.used.add(name)
        if data.shape[1] and np.any(np.isfinite(data)):
            # σ_min as the controller's warning reads it: the k-th value of a k-component task.
            task = run.controller.get("task")
            k = len(task) if isinstance(task, list) and task else data.shape[1]
            column = min(k, data.shape[1]) - 1
            smallest = data[:, column]
            index = int(np.nanargmin(smallest))
            threshold = singular_warning(run.controller)
            panel.note = f"min σ_min = {smallest[index]:.3g}\nat t = {run.t[index]:.3g} s"
            if smallest[index] < 5.0 * threshold and np.nanmin(data) > 0.0:
                panel.log = True
                warning = dict(color=LIMIT, lw=1.1, ls="--", label="warning threshold")
                panel.hlines.append((threshold, warning))
                panel.note += f"\n(warning below {threshold:g})"
        scopes.append(Scope("singular_values", "singular values of the Jacobian", [panel]))
    return scopes


# ----------------------------------------------------------------------------- the rest


def _unit_blocks(units: tuple) -> list[tuple[str, list[int]]]:
    """The columns of a group by unit, in order of first appearance."""
    blocks: dict[str, list[int]] = {}
    for k, unit in enumerate(units):
        blocks.setdefault(unit, []).append(k)
    return list(blocks.items())


def _signal_panels(run: _Run, name: str, data: np.ndarray, state: bool) -> list[Panel]:
    """One panel per unit of group ``name``, its traces named by their components (the
    controller state's by its own component names, e.g. ∫fx, ∫fy, ∫fz)."""
    labels, units = run.labels[name], run.units[name]
    panels = []
    blocks = _unit_blocks(units)
    for unit, columns in blocks:
        title = "controller state" if state else name
        if len(columns) == 1 and data.shape[1] > 1:
            # A unit's only column of a wider group (g_comp's θ2): the label names the joint.
            title = f"{title} {labels[columns[0]]}"
        elif len(blocks) > 1 and not state and sum(len(labels[k]) for k in columns) <= 12:
            # A signal split by unit (a pose: x, y, z in m, φ1…φ3 in rad) names its components
            # when they are short (the legend names them too; the state's by its own labels).
            title = f"{title} ({', '.join(labels[k] for k in columns)})"
        panel = Panel(_unit_label(title, unit))
        for j, k in enumerate(columns):
            # A one-column signal is the signal itself (σ, not the name of its joint).
            entry = pretty(name) if data.shape[1] == 1 and not state else pretty(labels[k])
            style = trace_style(j) if len(columns) > 1 else dict(color=ACTUAL, lw=1.3)
            panel.curves.append((entry, run.t, data[:, k], style))
        panels.append(panel)
    return panels


def _signal_scopes(run: _Run) -> list[Scope]:
    result = run.result
    panels = []
    for name in result.signals:
        if name not in run.used:
            panels += _signal_panels(run, name, run.groups[name], state=False)
    has_state = result.z.shape[1] > 0 and "z" not in run.used
    if has_state:
        panels += _signal_panels(run, "z", result.z, state=True)
    if not panels:
        return []
    title = "other logged signals and the controller state" if has_state else "other logged signals"
    return [Scope("signals", title, panels)]
