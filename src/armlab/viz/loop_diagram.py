"""The block diagram of a scenario's closed loop (the seed's "My Simulink model"), read from
its objects.

:func:`loop_diagram` turns a :class:`~armlab.scenarios.Scenario` into a :class:`LoopDiagram`:
a forward path of :class:`Block` s from the reference to the sensors,

    reference → law blocks (with their gains) → [zero-order hold] → [saturation]
              → [Σ with the disturbance τ_d] → plant (↔ environment) → sensors,

and the measured signals (q, q̇, x_e = k(q), h_e …) that run back from the sensors to the
blocks that read them.  The law blocks come from the controller's class and fields (its
gains, its model, its compensation or inner loop), the hold from ``control_period``, the
saturation from ``torque_limit``, the disturbance and environment blocks from the scenario's
terms; nothing is drawn per scenario.  A controller class it does not know is one block
``τ = h(t, y, z)`` named by its class.  :mod:`armlab.viz.diagram_drawing` draws it.
Equation tags (C1 …, E2 …) are those of ``docs/notation.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from armlab.control.adaptive import SlotineLi, SlotineLi1DoF
from armlab.control.interaction import (
    AdmittanceControl,
    ComplianceControl,
    ForceControl,
    ImpedanceControl,
    ParallelForcePosition,
)
from armlab.control.joint_space import JointInverseDynamics, JointPDGravity
from armlab.control.task_space import COMPONENT_LABELS, OperationalInverseDynamics, OperationalPD
from armlab.simulation.environment import FreeSpace, PlanarWall, Spring

Q, QD, X, XD, H = "q", "q̇", "x_e = k(q)", "ẋ_e = J(q) q̇", "h_e"
"""The measured signals a law block may read: joint encoders, the direct kinematics computed
from them, the wrist force sensor."""
SIGNAL_ORDER = (Q, QD, X, XD, H)


@dataclass(frozen=True)
class Block:
    """One block: ``kind`` (reference, sum, law, hold, saturation, plant, environment,
    disturbance, sensors), a ``title`` and ``lines`` of detail (gains, values); ``reads`` the
    measured signals fed back into it; ``output`` the label of the arrow that leaves it;
    ``above`` a block that feeds it from above (a second reference, the disturbance, the
    environment), ``exchange`` when that block also reads this one's output (the environment
    reads the pose and returns the wrench)."""

    kind: str
    title: str
    lines: tuple[str, ...] = ()
    reads: tuple[str, ...] = ()
    output: str = ""
    above: Block | None = None
    above_label: str = ""
    exchange: str = ""


@dataclass(frozen=True)
class LoopDiagram:
    """A closed loop: its ``title``, the forward path ``blocks`` and the measured ``signals``
    (in lane order) that the sensors feed back."""

    title: str
    blocks: tuple[Block, ...]
    signals: tuple[str, ...] = field(default=())


def diagram_text(diagram: LoopDiagram) -> str:
    """Every text the drawing of ``diagram`` shows: its blocks' titles and lines, the blocks
    above them and the labels of the arrows (where "x̃ in Σ_d (T1–T4)" names its tags)."""
    parts = [diagram.title]
    for block in diagram.blocks:
        parts += [block.title, *block.lines, block.output, block.above_label, block.exchange]
        if block.above is not None:
            parts += [block.above.title, *block.above.lines, block.above.output]
    return " ".join(part for part in parts if part)


# ----------------------------------------------------------------------------- numbers


def number(value: float) -> str:
    """A gain or setting as printed: 4 significant digits, a true minus sign."""
    text = f"{float(value):.4g}".replace("-", "−")
    return text.replace("e+0", "e").replace("e−0", "e−").replace("e+", "e")


def vector(values) -> str:
    return "(" + ", ".join(number(v) for v in np.ravel(values)) + ")"


def gain(name: str, value, labels=None) -> str:
    """``K_P = 900 I``, ``K_P = diag(25, 0.5, 10)`` or ``K_P: 3 × 3 full`` for a scalar, a
    diagonal or a full gain; ``labels`` name the components of a task gain."""
    matrix = np.atleast_2d(np.asarray(value, dtype=float))
    if matrix.size == 1:
        return f"{name} = {number(matrix[0, 0])}"
    if matrix.shape[0] != matrix.shape[1]:
        return f"{name} = {vector(matrix)}"
    diagonal = np.diag(matrix)
    if np.count_nonzero(matrix - np.diag(diagonal)) == 0:
        if np.all(diagonal == diagonal[0]):
            return f"{name} = {number(diagonal[0])} I{_subscript(matrix.shape[0])}"
        return f"{name} = diag{vector(diagonal)}"
    return f"{name}: {matrix.shape[0]} × {matrix.shape[0]} full"


def _subscript(n: int) -> str:
    return str(n).translate(str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉"))


def _task_labels(task) -> str:
    names = [COMPONENT_LABELS[i].replace("phi", "φ") for i in task]
    return ", ".join(names)


# ----------------------------------------------------------------------------- references


def _joint_reference(reference) -> Block:
    described = reference.describe()
    kind = str(described.pop("type", type(reference).__name__))
    details = []
    for key, value in described.items():
        flat = np.ravel(np.asarray(value, dtype=object))
        if flat.size <= 4 and all(isinstance(v, (int, float)) for v in flat):
            details.append(f"{key} = {vector(flat) if flat.size > 1 else number(flat[0])}")
        else:
            details.append(f"{key}: {flat.size} numbers")
    return Block("reference", f"q_des(t): {_words(kind)}", tuple(details[:3]), output="q_des, q̇_des, q̈_des")


def _words(name: str) -> str:
    """``SquareWaveAcceleration`` → ``square wave acceleration``."""
    out = "".join(" " + c.lower() if c.isupper() else c for c in name).strip()
    return out.replace("_", " ")


def _pose_reference(reference, name: str = "x_d") -> Block:
    count = reference.times.shape[0]
    if count == 1:
        lines = (f"p_d = {vector(reference.positions[0])} m", "constant")
    else:
        lines = (f"{count} via poses, t = {number(reference.times[0])} … {number(reference.times[-1])} s",
                 "quintic between them")
    return Block("reference", f"{name}(t): pose Σ_d", lines, output=f"{name}, ẋ_d, ẍ_d")


def _force_reference(force) -> Block:
    lines = [f"f_d → {vector(force.final)} N"]
    if force.duration > 0:
        lines.append(f"quintic over {number(force.duration)} s from t = {number(force.start)} s")
    elif np.any(np.asarray(force.initial) != 0):
        lines.append(f"step at t = {number(force.start)} s from {vector(force.initial)} N")
    return Block("reference", "f_d(t): desired force", tuple(lines), output="f_d")


# ----------------------------------------------------------------------------- control laws


def model_difference(model, plant) -> str:
    """How the controller's ``model`` differs from the ``plant``: "model = plant", the link
    masses that differ ("link4 0.16 kg (plant 0.2)"), or another robot's name."""
    if model is plant:
        return "model = plant"
    masses = {link.name: link.inertial.mass for link in plant.links}
    ours = {link.name: link.inertial.mass for link in model.links}
    if set(masses) != set(ours) or model.n != plant.n:
        return f"model {model.name} (plant {plant.name})"
    changed = [f"{name} {number(ours[name])} kg (plant {number(masses[name])})"
               for name in masses if ours[name] != masses[name]]
    return "model: " + ", ".join(changed) if changed else "model = plant"


def _model_line(controller, plant) -> tuple[str, ...]:
    return (model_difference(controller.model, plant),)


def _joint_pd(c: JointPDGravity, plant) -> list[Block]:
    gravity = {"online": ("+ ĝ(q)", (Q, QD)), "desired": ("+ ĝ(q_des)", (QD,)), "none": ("", (QD,))}
    term, reads = gravity[c.compensation]
    lines = [gain("K_P", c.kp), gain("K_D", c.kd)]
    lines += [f"gravity {c.compensation}: {term[2:] if term else 'ĝ = 0'}"] + list(_model_line(c, plant))
    return [Block("sum", "Σ", reads=(Q,), output="q̃ = q_des − q"),
            Block("law", f"PD + gravity (C1)\nτ = K_P q̃ − K_D q̇ {term}".rstrip(), tuple(lines), reads=reads,
                  output="τ")]


def _joint_inverse_dynamics(c: JointInverseDynamics, plant) -> list[Block]:
    model = _model_line(c, plant)
    if c.bias_model is not None:
        model = ("B̂: " + model[0], "n̂: " + model_difference(c.bias_model, plant))
    return [Block("sum", "Σ", reads=(Q, QD), output="q̃, q̃̇"),
            Block("law", "outer loop (C2)\ny = q̈_des + K_D q̃̇ + K_P q̃", (gain("K_P", c.kp), gain("K_D", c.kd)),
                  output="y"),
            Block("law", "inner loop (C2)\nτ = B̂(q) y + n̂(q, q̇)", model, reads=(Q, QD), output="τ")]


def _slotine_li(c, plant) -> list[Block]:
    one = isinstance(c, SlotineLi1DoF)
    lam = gain("Λ", c.lam)
    estimate = (f"π̂(0) = {vector(c.initial_estimate)}",) if one else ("π̂(0) from the model",)
    return [Block("sum", "Σ", reads=(Q, QD), output="q̃, q̃̇"),
            Block("law", "reference velocity (C4)\nq̇_r = q̇_des + Λ q̃\nσ = q̇_r − q̇", (lam,), reads=(QD,),
                  output="σ, q̇_r, q̈_r"),
            Block("law", "adaptation (C5)\ndπ̂/dt = Γ Yᵀ σ", (gain("Γ", c.gamma), *estimate), reads=(Q,),
                  output="π̂, σ, q̇_r, q̈_r"),
            Block("law", "adaptive law (C5)\nτ = Y(q, q̇, q̇_r, q̈_r) π̂\n     + K_D σ", (gain("K_D", c.kd),),
                  reads=(Q, QD), output="τ")]


def _task_gains(c, kp="K_P", kd="K_D") -> tuple[str, ...]:
    described = c.describe()
    return (gain(kp, described["kp"]), gain(kd, described["kd"]), f"task: {_task_labels(c.task)}")


def _error_sum(c, rate: bool = True) -> Block:
    """x̃ (and x̃̇ when the law reads it) in the controller's frame."""
    where = "in Σ_d (T1–T4)" if c.frame == "desired" else "in Σ_0 (T6)"
    if rate:
        return Block("sum", "Σ", reads=(X, XD), output=f"x̃, x̃̇ {where}")
    return Block("sum", "Σ", reads=(X,), output=f"x̃ {where}")


def _operational_pd(c: OperationalPD, plant) -> list[Block]:
    compliance = isinstance(c, ComplianceControl)
    tag, name = ("C11", "compliance") if compliance else ("C9", "PD + gravity")
    lines = list(_task_gains(c))
    damping = c.describe()["joint_damping"]
    if np.any(np.asarray(damping) != 0):
        lines.append(gain("K_q", damping))
    # The PD damps J_s q̇ (C9, C11): it reads q̇, not the task-space rate x̃̇.
    return [_error_sum(c, rate=False),
            Block("law", f"{name} ({tag})\nτ = g(q) + J_sᵀ(K_P x̃ − K_D J_s q̇) − K_q q̇", tuple(lines),
                  reads=(Q, QD), output="τ")]


def _damping_line(c) -> tuple[str, ...]:
    return (f"damped least squares λ = {number(c.damping)}",) if c.damping else ()


def _operational_inverse_dynamics(c: OperationalInverseDynamics, plant) -> list[Block]:
    return [_error_sum(c),
            Block("law", "outer loop (C10)\nJ_s y = ẍ_d + K_D x̃̇ + K_P x̃\n          − J̇_A q̇",
                  _task_gains(c) + _damping_line(c), reads=(Q, QD), output="y"),
            Block("law", "inner loop\nτ = B(q) y + n(q, q̇)", _model_line(c, plant), reads=(Q, QD),
                  output="τ")]


def _impedance(c: ImpedanceControl, plant) -> list[Block]:
    mass = gain("M_d", c.mass)
    return [_error_sum(c),
            Block("law", "impedance (C12)\nJ y = M_d⁻¹(K_D x̃̇ + K_P x̃ − h_A)\n      + c",
                  (mass, *_task_gains(c)) + _damping_line(c), reads=(Q, QD, H), output="y"),
            Block("law", "inner loop\nτ = B(q) y + n(q, q̇) + Jᵀ h_e", _model_line(c, plant), reads=(Q, QD, H),
                  output="τ")]


def _admittance(c: AdmittanceControl, plant) -> list[Block]:
    outer = (gain("M_t", c.mass_t), gain("K_Dt", c.kd_t), gain("K_Pt", c.kp_t))
    return [Block("law", "admittance (C13)\nM_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e^d", outer, reads=(H,),
                  output="Σ_t"),
            Block("sum", "Σ", reads=(X, XD), output="x̃_t, x̃̇_t"),
            Block("law", "inner motion loop (C13)\nJ y = K_D x̃̇_t + K_P x̃_t + c",
                  _task_gains(c) + _damping_line(c), reads=(Q, QD), output="y"),
            Block("law", "inner loop\nτ = B(q) y + n(q, q̇) + Jᵀ h_e", _model_line(c, plant), reads=(Q, QD, H),
                  output="τ")]


def _force(c, plant) -> list[Block]:
    parallel = isinstance(c, ParallelForcePosition)
    tag = "C15" if parallel else "C14"
    blocks = [Block("sum", "Σ", reads=(H,), output="f_d − f_e"),
              Block("law", f"force regulator ({tag})\nx_F = K_F (f_d − f_e)\n      + K_I ∫(f_d − f_e) dt",
                    (gain("K_F", c.kf), gain("K_I", c.ki)), output="x_F")]
    motion = (gain("M_d", c.mass), gain("K_P", c.kp), gain("K_D", c.kd)) + _damping_line(c)
    if parallel:
        blocks.append(Block("sum", "Σ", reads=(X, XD), output="x̃ + x_F", above=_pose_reference(c.reference),
                            above_label="x_d"))
        law = "position loop (C15)\nJ y = M_d⁻¹(K_D x̃̇ + K_P (x̃ + x_F))\n      + c"
    elif c.inner == "position":
        blocks.append(Block("sum", "Σ", reads=(X, XD), output="x_F − x_e"))
        law = "inner position loop (C14)\nJ y = M_d⁻¹(K_P (x_F − x_e) − K_D ẋ_e)\n      + c"
    else:
        # K_P x_F − K_D ẋ_e adds a position to a velocity through different gains: no Σ of them.
        law = "inner velocity loop (C14)\nJ y = M_d⁻¹(K_P x_F − K_D ẋ_e) + c"
    reads = (Q, QD, XD) if not parallel and c.inner == "velocity" else (Q, QD)
    blocks.append(Block("law", law, motion, reads=reads, output="y"))
    blocks.append(Block("law", "inner loop\nτ = B(q) y + n(q, q̇) + Jᵀ h_e", _model_line(c, plant),
                        reads=(Q, QD, H), output="τ"))
    return blocks


# More specific classes first: ComplianceControl is an OperationalPD.
LAWS = ((JointPDGravity, _joint_pd), (JointInverseDynamics, _joint_inverse_dynamics),
        ((SlotineLi1DoF, SlotineLi), _slotine_li), (OperationalPD, _operational_pd),
        (ImpedanceControl, _impedance), (AdmittanceControl, _admittance),
        (OperationalInverseDynamics, _operational_inverse_dynamics),
        ((ForceControl, ParallelForcePosition), _force))


def _reference(controller) -> Block | None:
    if isinstance(controller, (ForceControl, ParallelForcePosition)):
        return _force_reference(controller.force)
    reference = getattr(controller, "reference", None)
    if reference is None:
        return None
    if hasattr(reference, "times") and hasattr(reference, "rotations"):
        return _pose_reference(reference)
    if hasattr(reference, "describe"):
        return _joint_reference(reference)
    return None


def law_blocks(controller, plant) -> list[Block]:
    """The reference and law blocks of ``controller`` (its class and fields)."""
    for classes, blocks in LAWS:
        if isinstance(controller, classes):
            law = blocks(controller, plant)
            break
    else:
        law = [Block("law", f"{type(controller).__name__}\nτ = h(t, y, z)", reads=(Q, QD), output="τ")]
    reference = _reference(controller)
    return [reference, *law] if reference is not None else law


# ----------------------------------------------------------------------------- the rest of the loop


def _environment(environment) -> Block | None:
    if environment is None or isinstance(environment, FreeSpace):
        return None
    if isinstance(environment, Spring):
        stiffness = np.asarray(environment.stiffness)  # (6, 6), in Σ_r
        lines = (gain("K", stiffness), f"rest o_r = {vector(environment.rest_position)} m")
        return Block("environment", "spring (E2, E3)\nh_e = K x_r,e", lines)
    if isinstance(environment, PlanarWall):
        lines = (f"k = {number(environment.stiffness)} N/m, d = {number(environment.damping)} N·s/m",
                 f"through {vector(environment.point)}, n = {vector(environment.normal)}")
        return Block("environment", "wall (E4), pushes only\nf_e = (k δ + d δ̇) n, δ > 0", lines)
    return Block("environment", f"environment {type(environment).__name__}")


def _disturbance(terms, stops: bool) -> Block:
    lines = ["joint stops (S4) beyond the joint limits"] if stops else []
    for term in terms:
        described = term.describe() if hasattr(term, "describe") else {"type": type(term).__name__}
        kind = _words(str(described.pop("type", type(term).__name__)))
        values = ", ".join(f"{key} {vector(value) if np.size(value) > 1 else number(np.ravel(value)[0])}"
                           for key, value in described.items()
                           if np.asarray(value).dtype.kind in "fiu" and np.size(value) <= 3)
        lines.append(f"{kind}: {values}" if values else kind)
    return Block("disturbance", "disturbance τ_d (S2)", tuple(lines))


def _plant_block(plant, environment: Block | None, settings: dict, disturbed: bool) -> Block:
    inputs = "τ" + (" + τ_d" if disturbed else "") + (" − Jᵀ(q) h_e" if environment is not None else "")
    method = settings.get("method", "rk4")
    step = f", dt = {number(settings['dt'])} s" if "dt" in settings else ""
    joints = f"{plant.n} joint{'s' if plant.n > 1 else ''}"
    return Block("plant", f"plant {plant.name} (S1)\nB(q) q̈ + C q̇ + F q̇ + g(q)\n    = {inputs}",
                 (f"{joints}, {method}{step}",), output="q, q̇",
                 above=environment, above_label="h_e", exchange="x_e" if environment is not None else "")


def loop_diagram(scenario) -> LoopDiagram:
    """The block diagram of ``scenario``'s closed loop (see the module docstring)."""
    controller, plant, settings = scenario.controller, scenario.plant, dict(scenario.simulation)
    blocks = law_blocks(controller, plant)
    period = settings.get("control_period")
    if period is not None:
        blocks.append(Block("hold", "zero-order hold (S3)", (f"T_c = {number(period)} s",), output="τ"))
    limit = settings.get("torque_limit")
    if limit is not None and np.any(np.isfinite(limit)):
        values = np.broadcast_to(np.asarray(limit, dtype=float), (plant.n,))
        text = number(values[0]) if np.all(values == values[0]) else vector(values)
        blocks.append(Block("saturation", "saturation", (f"|τ_i| ≤ {text} N·m / N",), output="τ"))
    stops = settings.get("joint_limits") == "stop"
    disturbed = bool(scenario.disturbance) or stops
    if disturbed:
        blocks.append(Block("sum", "Σ", output="τ + τ_d", above=_disturbance(scenario.disturbance, stops),
                            above_label="τ_d"))
    environment = _environment(scenario.environment)
    blocks.append(_plant_block(plant, environment, settings, disturbed))
    read = {signal for block in blocks for signal in block.reads}
    signals = tuple(s for s in SIGNAL_ORDER if s in read)
    sensed = ["encoders: q, q̇"]
    if X in read or XD in read:
        sensed.append("direct kinematics k(q), J(q)")
    if H in read:
        sensed.append("force sensor: h_e")
    blocks.append(Block("sensors", "sensors", tuple(sensed)))
    law = next((b.title.split("\n")[0] for b in blocks if b.kind == "law"), type(controller).__name__)
    title = f"{scenario.name}: {type(controller).__name__}, {law}"
    return LoopDiagram(title, tuple(blocks), signals)
