"""How armlab objects show in a notebook: the HTML behind their ``_repr_html_``.

IPython (Jupyter, VS Code, nbconvert) calls ``_repr_html_`` on the value of a cell; the classes
keep that method three lines long and build their HTML here:

* :func:`robot_html` — a :class:`~armlab.model.robot.Robot`: description and provenance, the
  joint table (type, DH row a, α, d, θ, offset, limits, motor, friction), the link masses and
  centres of mass, the named parameters of its file, gravity;
* :func:`controller_html` — a controller: its law (the equation of its docstring), its gains
  and options, the model it holds, its state and logged signals;
* :func:`result_summary` — a :class:`~armlab.simulation.results.SimulationResult`: a summary
  (status, samples, duration, integrator, controller); :func:`armlab.viz.notebook.result_html`
  adds its main scope as an inline PNG;
* :func:`section_html` — a derivation section A1–A5 as presentation MathML.

Every text coming from a file (robot, joint, link and parameter names, descriptions) is
escaped with :func:`html.escape`: a robot file is untrusted, a name may hold markup.

The result's picture is drawn at the edge, by :mod:`armlab.viz.notebook` (the library never
plots); everything else here is text.
"""

from __future__ import annotations

import html
import inspect
import re

import numpy as np

STYLE = ("<style>.armlab-repr table{border-collapse:collapse;margin:4px 0 10px 0;font-size:12.5px}"
         ".armlab-repr th,.armlab-repr td{border:1px solid #ccd;padding:2px 7px;text-align:left}"
         ".armlab-repr td.num{text-align:right;font-family:monospace}"
         ".armlab-repr .law{font-family:monospace;white-space:pre;background:#f4f6f9;padding:4px 8px}"
         ".armlab-repr .note{color:#666}</style>")


def escape(text) -> str:
    """``text`` as HTML text (quotes too: it may end up inside an attribute)."""
    return html.escape(str(text), quote=True)


def number(value, digits: int = 6) -> str:
    """A number for a table: ``g`` format with ``digits`` significant digits, ±∞ as such."""
    value = float(value)
    if np.isinf(value):
        return "∞" if value > 0 else "−∞"
    return f"{value:.{digits}g}"


def array_text(value, digits: int = 4) -> str:
    """An array as compact text, rows on separate lines (for a table cell)."""
    array = np.asarray(value, dtype=float)
    if array.ndim == 0:
        return number(array, digits)
    if array.ndim == 1:
        return "[" + ", ".join(number(v, digits) for v in array) + "]"
    return "\n".join(array_text(row, digits) for row in array)


def table(headers, rows, *, numeric=frozenset(), caption: str = "") -> str:
    """An HTML table, every header and cell escaped; the columns in ``numeric`` right-aligned."""
    head = "".join(f"<th>{escape(h)}</th>" for h in headers)
    body = "".join(
        "<tr>" + "".join(f'<td class="num">{escape(c)}</td>' if k in numeric else f"<td>{escape(c)}</td>"
                         for k, c in enumerate(row)) + "</tr>"
        for row in rows)
    cap = f"<caption>{escape(caption)}</caption>" if caption else ""
    return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def block(title: str, parts: list[str]) -> str:
    return f'{STYLE}<div class="armlab-repr"><h4>{escape(title)}</h4>{"".join(parts)}</div>'


def _paragraph(label: str, text: str) -> str:
    return f"<p><b>{escape(label)}</b> {escape(text)}</p>" if text else ""


# ----------------------------------------------------------------------------- robots


def robot_html(robot) -> str:
    """The HTML of a Robot: provenance, joint table, links, parameters, gravity."""
    spec = robot.spec if isinstance(robot.spec, dict) else {}
    parts = [_paragraph("Description:", robot.description),
             _paragraph("Provenance:", spec.get("provenance", "")),
             _paragraph("Loaded from:", robot.source)]
    rows = []
    for joint in robot.joints:
        dh = joint.dh
        cells = ([number(dh.a), number(dh.alpha), number(dh.d), number(dh.theta), dh.convention]
                 if dh is not None else ["", "", "", "", "URDF"])
        rows.append([joint.name, joint.kind, *cells, number(joint.offset),
                     f"[{number(joint.limits[0])}, {number(joint.limits[1])}]",
                     number(joint.motor.gear_ratio), number(joint.motor.rotor_inertia),
                     number(joint.friction.viscous), number(joint.friction.coulomb)])
    parts.append(table(["joint", "type", "a [m]", "α [rad]", "d [m]", "θ [rad]", "DH", "offset",
                        "limits", "gear k_r", "I_m [kg·m²]", "F_v", "F_s"], rows,
                       numeric={2, 3, 4, 5, 7, 9, 10, 11, 12},
                       caption="Joints (DH row with the joint variable added to θ or d)"))
    links = [[link.name, number(link.inertial.mass), array_text(link.inertial.com),
              array_text(np.diag(link.inertial.inertia)),
              (link.inertial.shape or {}).get("type", "")] for link in robot.links]
    parts.append(table(["link", "mass [kg]", "centre of mass in Σ_i [m]", "I_C diagonal [kg·m²]", "shape"],
                       links, numeric={1}, caption="Links"))
    if robot.parameters:
        parts.append(table(["parameter", "value"],
                           [[name, number(value)] for name, value in robot.parameters.items()],
                           numeric={1}, caption="Parameters of the robot file"))
    parts.append(_paragraph("Gravity g₀ in Σ_0 [m/s²]:", array_text(robot.gravity)))
    kinds = "".join("P" if j.kind == "prismatic" else "R" for j in robot.joints)
    return block(f"Robot {robot.name} — {robot.n} joints ({kinds})", parts)


# ----------------------------------------------------------------------------- controllers


def law_text(cls) -> str:
    """The governing equation of a controller class: the indented block of its docstring (the
    lines written as ``    τ = … (C1)``), or its first paragraph when it has none."""
    doc = inspect.getdoc(cls) or ""
    blocks = re.findall(r"(?:^ {2,}\S.*\n?)+", doc, flags=re.MULTILINE)
    if blocks:
        return "\n".join(line.strip() for line in blocks[0].splitlines())
    return doc.split("\n\n")[0]


def _field_text(value) -> str:
    if hasattr(value, "joints") and hasattr(value, "name"):
        return f"Robot {value.name}"
    if isinstance(value, np.ndarray) or (isinstance(value, (list, tuple)) and value
                                         and all(isinstance(v, (int, float)) for v in value)):
        return array_text(value)
    if isinstance(value, float):
        return number(value)
    if callable(value) and hasattr(value, "__name__"):
        return f"function {value.__name__}"
    if hasattr(value, "describe"):
        described = value.describe()
        kind = described.pop("type", type(value).__name__) if isinstance(described, dict) else ""
        return f"{kind} " + ", ".join(f"{k} = {v}" for k, v in described.items()) \
            if isinstance(described, dict) else str(described)
    return str(value)


def controller_html(controller) -> str:
    """The HTML of a controller: its law, gains and options, model, state and signals."""
    import dataclasses

    cls = type(controller)
    law = getattr(cls, "law", None)
    law_name = getattr(getattr(law, "py_func", law), "__name__", "")
    parts = [f'<div class="law">{escape(law_text(cls))}</div>',
             _paragraph("Compiled law:", law_name)]
    fields = [f.name for f in dataclasses.fields(controller)] if dataclasses.is_dataclass(controller) else []
    rows = [[name, _field_text(getattr(controller, name))] for name in fields]
    parts.append(table(["parameter", "value"], rows, caption="Gains, options and model"))
    labels = controller.state_labels()
    if labels:
        parts.append(_paragraph("State z:", ", ".join(
            f"{label} [{unit}]" if unit else label
            for label, unit in zip(labels, controller.state_units(), strict=True))))
    signals = controller.signals()
    if signals:
        parts.append(_paragraph("Logged signals:", ", ".join(s.name for s in signals)))
    return block(f"Controller {cls.__name__}", parts)


# ----------------------------------------------------------------------------- results


def result_summary(result) -> list[list[str]]:
    """(item, value) rows of a result's summary."""
    meta = result.meta if isinstance(result.meta, dict) else {}
    controller = meta.get("controller", {})
    plant = meta.get("plant", {})
    rows = [["status", result.status + (f" — {result.diagnosis}" if result.diagnosis else "")],
            ["samples", str(len(result))]]
    if len(result):
        rows.append(["time [s]", f"{number(result.t[0])} … {number(result.t[-1])}"])
    rows.append(["joints", str(result.n)])
    if isinstance(plant, dict) and plant.get("name"):
        rows.append(["plant", str(plant["name"])])
    elif isinstance(plant, str):
        rows.append(["plant", plant])
    if isinstance(controller, dict) and controller.get("type"):
        rows.append(["controller", str(controller["type"])])
    for key in ("scenario", "method", "dt", "control_period", "torque_limit"):
        if key in meta and meta[key] is not None:
            rows.append([key, str(meta[key])])
    groups = ", ".join(f"{name} ({', '.join(result.labels.get(name, ()))})" for name in result.signals)
    if groups:
        rows.append(["signals", groups])
    if len(result):
        rows.append(["final q", array_text(result.q[-1])])
    return rows


# ----------------------------------------------------------------------------- derivations


def section_html(section, mathml_of) -> str:
    """The HTML of a derivation section: each item's label over its presentation MathML
    (``mathml_of(expr)``, without the ``<math>`` tag), then the section's notes."""
    parts = [f'<div><div>{escape(item.label)} =</div>'
             f'<math display="block">{mathml_of(item.expr)}</math></div>' for item in section.items]
    parts += [f'<p class="note">{escape(note)}</p>' for note in section.notes]
    return block(f"{section.key} — {section.title}", parts)
