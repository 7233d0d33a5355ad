"""armlab robots and controllers as python-control systems (``control.nlsys``), and their
linearisation as a ``control.StateSpace``.

Needs the optional extra ``control`` (``pip install armlab[control]``, python-control 0.10).

The plant alone (:func:`plant_system`), with state x = [q; q̇] (2n,), input τ (n,) and output x:

    ẋ = [q̇; q̈],   B(q) q̈ = τ − C q̇ − F_v q̇ − F_s sgn q̇ − g(q) − Jᵀ h_e                    (D5)

The closed loop (:func:`closed_loop_system`): the plant under an armlab controller (C0), state
x = [q; q̇; z] (2n + k,), input the joint disturbance τ_d (n,) of (S1), output x:

    τ = h(t, q, q̇, z, h_e),   ż = f(t, q, q̇, z, h_e),
    B q̈ + C q̇ + F_v q̇ + F_s sgn q̇ + g = τ + τ_d − Jᵀ h_e                                  (S1)

h_e comes from the ``environment`` (free space: 0) at the plant's end-effector pose and twist
in Σ_0, as in ``armlab.simulate``.  The controller's compiled law, the environment's law and the
plant's forward dynamics are the ones the simulator runs; only torque saturation, sampled
control and the simulator's own disturbance terms are left out (τ_d is the input instead).

:func:`linearize` differentiates such a system about an equilibrium or a point of a trajectory
(x, u, t) by Richardson-refined central differences, ``A = ∂f/∂x``, ``B = ∂f/∂u``.
"""

from __future__ import annotations

import numpy as np

from armlab.control.base import Controller, Environment
from armlab.dynamics import forward_dynamics
from armlab.errors import InputError, ProtocolError
from armlab.kinematics import forward_kinematics, geometric_jacobian


def _control():
    try:
        import control
    except ImportError:
        raise ImportError("the python-control bridge needs python-control: "
                          "pip install 'armlab[control]'") from None
    return control


def _contact_wrench(plant, environment, t, q, qd, eparams) -> np.ndarray | None:
    """h_e (6,) [N, N·m] the end effector exerts on ``environment``, None in free space."""
    if environment is None:
        return None
    T = forward_kinematics(plant, q, frame="0")
    v_e = geometric_jacobian(plant, q, frame="0") @ qd
    h_e = np.zeros(6)
    type(environment).law(float(t), np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]),
                          np.ascontiguousarray(v_e), eparams, h_e)
    return h_e


def _labels(robot, stem: str) -> list[str]:
    return [f"{stem}[{joint.name}]" for joint in robot.joints]


def plant_system(plant, *, environment: Environment | None = None, name: str | None = None):
    """The plant as a ``control.NonlinearIOSystem``: state and output [q; q̇], input τ (D5)."""
    control = _control()
    n = plant.n
    eparams = environment.params() if environment is not None else None

    def update(t, x, u, params):
        q, qd = x[:n], x[n:]
        h_e = _contact_wrench(plant, environment, t, q, qd, eparams)
        return np.concatenate([qd, forward_dynamics(plant, q, qd, np.asarray(u, dtype=float), h_e)])

    states = _labels(plant, "q") + _labels(plant, "qd")
    system = control.nlsys(update, None, inputs=_labels(plant, "tau"), states=states, outputs=states,
                           name=name or plant.name)
    system.armlab_plant = plant  # for linearize's check of the Coulomb term
    return system


class LawEvaluator:
    """A controller's compiled law called from Python: ``(τ, ż) = evaluator(t, q, q̇, z, h_e)``.

    ``params()`` is built once, as in a simulation; every call writes fresh output arrays.
    """

    def __init__(self, controller: Controller):
        if not isinstance(controller, Controller):
            raise ProtocolError(f"controller: {type(controller).__name__} is not an armlab Controller")
        self.controller = controller
        self.law = controller.law_function()
        self.params = controller.params()
        self.n = controller.n
        self.k = np.asarray(controller.initial_state()).size
        self.s = sum(signal.width for signal in controller.signals())

    def __call__(self, t, q, qd, z, h_e=None):
        tau, zdot, signals = np.zeros(self.n), np.zeros(self.k), np.zeros(self.s)
        h_e = np.zeros(6) if h_e is None else np.ascontiguousarray(h_e, dtype=float)
        self.law(float(t), np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(qd, dtype=float),
                 np.ascontiguousarray(z, dtype=float), h_e, self.params, tau, zdot, signals)
        return tau, zdot


def closed_loop_system(plant, controller: Controller, *, environment: Environment | None = None,
                       name: str | None = None):
    """The plant under ``controller`` as a ``control.NonlinearIOSystem``: state and output
    [q; q̇; z], input the joint disturbance τ_d (S1).  The controller holds its own model (it
    may differ from ``plant``)."""
    control = _control()
    n = plant.n
    if controller.n != n:
        raise ProtocolError(f"controller: its model has {controller.n} joints, the plant {n}")
    law = LawEvaluator(controller)
    eparams = environment.params() if environment is not None else None

    def update(t, x, u, params):
        q, qd, z = x[:n], x[n:2 * n], x[2 * n:]
        h_e = _contact_wrench(plant, environment, t, q, qd, eparams)
        tau, zdot = law(t, q, qd, z, h_e)
        qdd = forward_dynamics(plant, q, qd, tau + np.asarray(u, dtype=float), h_e)
        return np.concatenate([qd, qdd, zdot])

    labels = controller.state_labels()
    z_names = list(labels) if len(labels) == law.k else [f"z{i}" for i in range(law.k)]
    states = _labels(plant, "q") + _labels(plant, "qd") + z_names
    system = control.nlsys(update, None, inputs=_labels(plant, "tau_d"), states=states, outputs=states,
                           name=name or f"{plant.name} under {type(controller).__name__}")
    system.armlab_plant = plant  # for linearize's check of the Coulomb term
    return system


def initial_state(plant, controller: Controller, q, qd=None) -> np.ndarray:
    """The closed loop's state [q; q̇; z(0)] for joint positions ``q`` and velocities ``qd``."""
    qd = np.zeros(plant.n) if qd is None else np.asarray(qd, dtype=float)
    return np.concatenate([np.asarray(q, dtype=float), qd, np.asarray(controller.initial_state(), float)])


def linearize(system, x, u=None, t: float = 0.0, *, step: float = 1e-3):
    """The linear model ``control.StateSpace(A, B, C, D)`` of ``system`` (a ``control.nlsys``
    with output = state, as made here) about the state ``x``, input ``u`` (default 0) and time
    ``t``:

        δẋ = A δx + B δu,   A = ∂f/∂x,  B = ∂f/∂u,  C = I,  D = 0.

    Each column is a central difference of half-width h = ``step`` · max(1, |x_i|) refined by
    one Richardson step, (4 D(h/2) − D(h)) / 3: its error is O(h⁴), against O(h²) for the
    plain central difference, so h can stay large where rounding would dominate.  At an
    equilibrium (f(x, u, t) = 0) this is the linearisation; at a point of a trajectory, the
    linear time-varying model frozen at ``t``.

    Coulomb friction F_s sgn q̇ has no derivative at q̇ = 0: a difference across it is
    F_s / h, a step-size artefact (fastest pole ∝ 1/``step``).  For a system made here, a
    joint with F_s ≠ 0 whose |q̇_i| is below its difference width h is refused
    (``InputError``): linearise at a velocity away from zero, or a plant without F_s (the
    stiction then holds the joint; the linear model of its sliding is the one without it).
    """
    control = _control()
    x = np.asarray(x, dtype=float)
    u = np.zeros(system.ninputs) if u is None else np.asarray(u, dtype=float)
    _check_coulomb(getattr(system, "armlab_plant", None), x, step)

    def column(point, i, f):
        def central(h):
            plus, minus = point.copy(), point.copy()
            plus[i] += h
            minus[i] -= h
            return (f(plus) - f(minus)) / (2.0 * h)

        h = step * max(1.0, abs(point[i]))
        return (4.0 * central(0.5 * h) - central(h)) / 3.0

    def of_state(xv):
        return np.asarray(system.dynamics(t, xv, u), dtype=float)

    def of_input(uv):
        return np.asarray(system.dynamics(t, x, uv), dtype=float)

    A = np.column_stack([column(x, i, of_state) for i in range(x.size)])
    B = np.column_stack([column(u, i, of_input) for i in range(u.size)]) if u.size else np.zeros((x.size, 0))
    return control.ss(A, B, np.eye(x.size), np.zeros((x.size, u.size)),
                      inputs=system.input_labels, states=system.state_labels,
                      outputs=system.output_labels, name=f"{system.name} linearised")


def _check_coulomb(plant, x: np.ndarray, step: float) -> None:
    """Refuse a difference stencil that crosses the sgn q̇ of a joint with Coulomb friction."""
    if plant is None:
        return
    n = plant.n
    coulomb = np.asarray(plant.arrays.coulomb, dtype=float)
    for i, joint in enumerate(plant.joints):
        qd = float(x[n + i])
        if coulomb[i] != 0 and abs(qd) < step * max(1.0, abs(qd)):
            unit = "N" if joint.kind == "prismatic" else "N·m"
            raise InputError(
                f"linearize: joint {joint.name} of {plant.name} has Coulomb friction F_s = {coulomb[i]:g} "
                f"{unit} and q̇ = {qd:g} within the difference step {step:g}: F_s sgn q̇ has no derivative "
                "at q̇ = 0 (the result would be a step-size artefact); linearise at |q̇| > step or without F_s")
