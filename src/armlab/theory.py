"""What the theory predicts for a closed loop, computed independently of the simulation.

Each function solves the equation the theory gives — an equilibrium, a gain bound — from the
model terms of ``armlab.dynamics`` alone, never from a run, so that a run can be checked against
it (the report prints both side by side, :func:`predictions`).

The results are tagged (H1)–(H6), at the end of a line of their bullet; the letter H is no
other set's (the notation's C, D, E, K, R, S and T of ``docs/notation.md``), so that a tag of
the report means one thing (:mod:`armlab.viz.tags`).

* Computed torque with a wrong model (A7, law C2) settles where, at rest (q̇ = 0, constant
  q_des, y = K_P q̃),

      B̂(q) K_P q̃ + n̂(q, 0) = g(q),   q = q_des − q̃                                        (H1)

  with n̂(q, 0) = ĝ(q) the controller's gravity (from its ``bias_model`` when it has one).
* PD + g(q_des) (A6 option 3, law C1) is globally asymptotically stable when
  λ_min(K_P) > α,  α ≥ ‖∂g/∂q‖ over the joint space (Tomei 1991; Siciliano et al. §8.5.2):
  :func:`gravity_gradient_bound` estimates α on a grid of the joint box.                   (H2)
* Compliance control against a spring (A11, law C11, E2) settles at
  x_e = (K_P + K)⁻¹(K_P x_d + K x_r), both stiffnesses in Σ_0's axes (K_P acts in Σ_d's or
  Σ_0's, K in Σ_r's), and presses with f = K (x_e − x_r); against a wall (E4) in contact at
  rest, the same with K = k n nᵀ and x_r its point (x_e = x_d if that is in free space).
  It is the special case of (H6) where the arm can take every pose it asks for; the report
  prints it only where it equals (H6).                                                       (H3)
  Admittance control (A13, C13) on a position task rests on it with K_P = K_Pt: the inner
  loop puts Σ_e on Σ_t, and the admittance rests where K_Pt z̃ = h_e^d.
* Force control with integral action (A14, A15) reaches f_e = f_d along Image(K): a zero final
  force error, when f_d lies in Image(K) (otherwise the integral of the rest grows without
  bound and nothing settles).                                                                (H4)
* Impedance control (A12, law C12) with an exact model imposes, on the position task in Σ_d,
  M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A, h_A = R_dᵀ f_e: the residual of that equation along a run
  is zero (measured by finite differences of the logged x̃, so O(dt²)).                    (H5)
* Compliance control at rest settles on the closed-loop statics of :mod:`armlab.statics`,
  J_sᵀ(q) K_P x̃_s(q) + ĝ(q) − g(q) = Jᵀ(q) h_e(q), at the minimum of ½ x̃ᵀK_P x̃ + U_e(q)
  that the descent from q0 reaches; it holds for any Σ_r and Σ_d, also where (H3) is wrong
  (Σ_r ∦ Σ_d, or an arm that ties its orientation to its position: the PRP turns only
  about z_0).                                                                                (H6)
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from armlab.control.gains import gain_matrix
from armlab.dynamics import gravity_torque, inertia_matrix
from armlab.model.robot import Robot


def computed_torque_equilibrium(plant: Robot, controller, q_des) -> np.ndarray:
    """q̃ = q_des − q at the rest equilibrium (H1) of ``plant`` under a
    :class:`~armlab.control.joint_space.JointInverseDynamics` ``controller``."""
    q_des = np.asarray(q_des, dtype=float)
    model = controller.model
    bias = controller.bias_model if controller.bias_model is not None else model
    kp = np.asarray(controller.kp, dtype=float)

    def residual(e):
        q = q_des - e
        return inertia_matrix(model, q) @ (kp @ e) + gravity_torque(bias, q) - gravity_torque(plant, q)

    start = np.zeros_like(q_des)
    if not np.any(residual(start)):
        # An exact model: q̃ = 0 solves (H1) exactly, where the solver would stay.  SciPy's
        # optimize package is imported only when there is something to solve (0.4 s).
        return start
    from scipy.optimize import root

    solution = root(residual, start, tol=1e-14)
    # The residual decides, not ``success``: MINPACK's hybrd reports failure ("xtol too small")
    # when it sits on the root to rounding but cannot shrink its step below tol = 1e-14.
    if not np.all(np.isfinite(solution.x)) or np.abs(residual(solution.x)).max() > 1e-9:
        raise ArithmeticError(f"no rest equilibrium found near q_des ({solution.message})")
    return solution.x


def gravity_gradient_bound(robot: Robot, points_per_joint: int = 9, step: float = 1e-6,
                           samples: int = 4000, seed: int = 0) -> float:
    """α of (H2): the largest spectral norm of ∂g/∂q (central differences) over the joint box
    (the limits, ±π for an unlimited revolute joint, ±0.5 m for an unlimited prismatic one):
    on a grid of ``points_per_joint`` values per joint when that has at most ``samples``
    points, else at ``samples`` seeded random points.  A sampled maximum: a lower estimate of
    the supremum, exact when it lies on a sample."""
    unlimited = np.array([np.pi if j.kind == "revolute" else 0.5 for j in robot.joints])
    lo = np.where(np.isfinite(robot.arrays.q_min), robot.arrays.q_min, -unlimited)
    hi = np.where(np.isfinite(robot.arrays.q_max), robot.arrays.q_max, unlimited)
    if points_per_joint ** robot.n <= samples:
        axes = [np.linspace(a, b, points_per_joint) for a, b in zip(lo, hi, strict=True)]
        points = np.array(list(itertools.product(*axes)))
    else:
        points = lo + np.random.default_rng(seed).random((samples, robot.n)) * (hi - lo)
    worst = 0.0
    for q in points:
        columns = []
        for j in range(robot.n):
            dq = np.zeros(robot.n)
            dq[j] = step
            columns.append((gravity_torque(robot, q + dq) - gravity_torque(robot, q - dq)) / (2 * step))
        worst = max(worst, float(np.linalg.norm(np.column_stack(columns), 2)))
    return worst


def compliance_equilibrium(kp, stiffness, x_d, x_r):
    """(x_e, f) of (H3) with K_P and K (3, 3) in one frame's axes (or their diagonals):
    x_e = (K_P + K)⁻¹(K_P x_d + K x_r), f = K (x_e − x_r)."""
    kp, stiffness = (np.diag(v) if np.ndim(v) == 1 else np.asarray(v, dtype=float)
                     for v in (np.asarray(kp, dtype=float), np.asarray(stiffness, dtype=float)))
    x_d, x_r = np.asarray(x_d, dtype=float), np.asarray(x_r, dtype=float)
    x_e = np.linalg.solve(kp + stiffness, kp @ x_d + stiffness @ x_r)
    return x_e, stiffness @ (x_e - x_r)


@dataclass(frozen=True)
class Prediction:
    """What the theory says of one quantity, and how to read the same quantity off a run:
    ``measured(result)`` gives the run's values (a window mean at the end, unless said), and a
    run agrees with the theory when each of them lies within ``tolerance`` (in the quantity's
    units) of ``values``: what a finite run of a fixed-step integrator leaves of the limit."""

    quantity: str
    labels: tuple[str, ...]
    values: np.ndarray
    units: tuple[str, ...]
    measured: Callable | None = None
    tolerance: float = 1e-6

    def agrees(self, result) -> bool:
        """True when the run's values lie within ``tolerance`` of the theory's."""
        if self.measured is None:
            return False
        return bool(np.all(np.abs(np.asarray(self.measured(result)) - self.values) <= self.tolerance))


@dataclass(frozen=True)
class _FinalMean:
    """A run's ``signal`` (its ``columns``) averaged over the last 5 % (``armlab.metrics``).
    A class, not a closure: predictions travel to the report's worker processes."""

    signal: str
    columns: tuple[int, ...] | None = None

    def __call__(self, result):
        from armlab.metrics import tail_slice

        data = result.signals[self.signal]
        data = data if self.columns is None else data[:, list(self.columns)]
        return np.mean(data[tail_slice(result.t)], axis=0)


@dataclass(frozen=True)
class _ImpedanceRMS:
    """The RMS over a run of the residual of (H5) for ``controller``."""

    controller: object

    def __call__(self, result):
        # The first and last two samples carry one-sided differences.
        return np.sqrt(np.mean(impedance_residual(result, self.controller)[2:-2] ** 2, axis=0))


@dataclass(frozen=True)
class _ForceErrorInImage:
    """The final mean of f_d − f_e projected on Image(K) (``projector`` (3, 3), Σ_0 axes)."""

    projector: np.ndarray

    def __call__(self, result):
        from armlab.metrics import tail_slice

        error = result.signals["f_des"] - result.signals["h_e"][:, :3]
        return self.projector @ np.mean(error[tail_slice(result.t)], axis=0)


def image_projector(environment) -> np.ndarray | None:
    """The orthogonal projector (3, 3) onto the translational Image(K) of a spring (in Σ_0's
    axes) or the normal of a wall; None in free space."""
    from armlab.simulation.environment import PlanarWall, Spring

    if isinstance(environment, PlanarWall):
        return np.outer(environment.normal, environment.normal)
    if isinstance(environment, Spring):
        R_r = environment.rest_rotation
        K = R_r @ environment.stiffness[:3, :3] @ R_r.T
        basis = np.linalg.svd(K)[0][:, np.linalg.svd(K, compute_uv=False) > 1e-12 * max(1.0, np.abs(K).max())]
        return basis @ basis.T
    return None


def impedance_residual(result, controller) -> np.ndarray:
    """(N, 3) residual of (H5) along ``result`` of an impedance ``controller`` with a constant
    pose reference: M_d x̃̈ + K_D x̃̇ + K_P x̃ − R_dᵀ f_e, x̃̇ and x̃̈ by central differences."""
    t, e = result.t, result.signals["x_err"][:, :3]
    e_dot = np.gradient(e, t, axis=0)
    e_ddot = np.gradient(e_dot, t, axis=0)
    h_A = result.signals["h_e"][:, :3] @ controller.reference.rotations[-1]
    diag = [np.diag(np.atleast_2d(np.asarray(g, dtype=float))) if np.ndim(g) == 2
            else np.broadcast_to(np.asarray(g, dtype=float), (3,))
            for g in (controller.mass, controller.kd, controller.kp)]
    return diag[0] * e_ddot + diag[1] * e_dot + diag[2] * e - h_A


# How close a run must come to each theory (its units): what a finite, fixed-step run leaves
# of the limit, measured on the bundled scenarios with margin (tests/test_metrics_theory.py).
JOINT_TOLERANCE = 1e-3          # [rad | m] rest error (H1): a7_id_mismatch, ending 1 s after its
#                                 last via point, is still 2·10⁻⁴ from it
POSITION_TOLERANCE = 1e-5       # [m] rest position (H3, H6)
FORCE_TOLERANCE = 1e-3          # [N] rest contact force (H3, H6), final force error (H4)
RESIDUAL_TOLERANCE = 1e-2       # [N] RMS of the impedance residual (H5), finite differences
CLOSED_FORM_AGREEMENT = 1e-8   # [m] (H3) is printed when it lies this close to (H6)


def _compliance_predictions(scenario) -> list[Prediction]:
    """Rest position and contact force of a compliance run (H3, or H6 where H3 does not hold)."""
    from armlab.simulation.environment import PlanarWall
    from armlab.statics import compliance_statics

    controller, env = scenario.controller, scenario.environment
    if len(controller.reference.times) != 1:
        return []   # a moving x_d has no rest point
    statics = compliance_statics(scenario.plant, controller, env, scenario.simulation["q0"])
    tag = "(H6)"
    if {0, 1, 2} <= set(controller.task):
        ref = controller.reference
        if isinstance(env, PlanarWall):
            # In contact at rest (δ̇ = 0) the wall (E4) is the spring K = k n nᵀ about its plane.
            K, R_r, x_r = np.zeros((6, 6)), np.eye(3), env.point
            K[:3, :3] = env.stiffness * np.outer(env.normal, env.normal)
        else:
            K, R_r, x_r = np.asarray(env.stiffness, dtype=float), env.rest_rotation, env.rest_position
        R_d, p_d = ref.rotations[-1], ref.positions[-1]
        kp = gain_matrix(controller.kp, 6, "kp", components=controller.task)[:3, :3]
        # Both stiffnesses in Σ_0's axes: K_P acts in Σ_d's ("desired") or Σ_0's ("base").
        R_kp = R_d if controller.frame == "desired" else np.eye(3)
        x_e, _ = compliance_equilibrium(R_kp @ kp @ R_kp.T, R_r @ K[:3, :3] @ R_r.T, p_d, x_r)
        if isinstance(env, PlanarWall) and env.normal @ (env.point - x_e) < 0.0:
            x_e = np.asarray(p_d, dtype=float)   # x_d in free space: no contact
        if np.abs(x_e - statics.p_e).max() <= CLOSED_FORM_AGREEMENT:
            tag = "(H3)"
    return [Prediction(f"equilibrium p_e {tag}", ("x", "y", "z"), statics.p_e, ("m",) * 3, _FinalMean("p"),
                       tolerance=POSITION_TOLERANCE),
            Prediction(f"equilibrium contact force f_e {tag}", ("fx", "fy", "fz"), statics.f_e, ("N",) * 3,
                       _FinalMean("h_e", (0, 1, 2)), tolerance=FORCE_TOLERANCE)]


def _admittance_predictions(scenario) -> list[Prediction]:
    """Rest position and contact force of an admittance run on a position task (H3 with K_Pt).

    At rest the inner loop has brought Σ_e onto Σ_t (an exact model, a square position task)
    and the admittance rests where K_Pt z̃ = h_e^d; on positions, z̃ = R_dᵀ(p_d − p_e), so
    K_Pt R_dᵀ(p_d − p_e) = R_dᵀ f_e — (H3) with K_P = R_d K_Pt R_dᵀ, whatever the orientation,
    as long as the environment's force depends on position alone."""
    from armlab.simulation.environment import PlanarWall

    controller, env = scenario.controller, scenario.environment
    if len(controller.reference.times) != 1 or tuple(controller.task) != (0, 1, 2):
        return []
    if isinstance(env, PlanarWall):
        K, x_r = env.stiffness * np.outer(env.normal, env.normal), env.point
    else:
        if np.any(env.stiffness[:3, 3:]):
            return []   # the force would depend on the orientation too
        K, x_r = env.rest_rotation @ env.stiffness[:3, :3] @ env.rest_rotation.T, env.rest_position
    R_d, p_d = controller.reference.rotations[-1], controller.reference.positions[-1]
    kp_t = R_d @ gain_matrix(controller.kp_t, 6, "kp_t")[:3, :3] @ R_d.T
    x_e, f = compliance_equilibrium(kp_t, K, p_d, x_r)
    if isinstance(env, PlanarWall) and env.normal @ (env.point - x_e) < 0.0:
        x_e, f = np.asarray(p_d, dtype=float), np.zeros(3)   # x_d in free space: no contact
    return [Prediction("equilibrium p_e (H3, K_P = K_Pt)", ("x", "y", "z"), x_e, ("m",) * 3, _FinalMean("p"),
                       tolerance=POSITION_TOLERANCE),
            Prediction("equilibrium contact force f_e (H3, K_P = K_Pt)", ("fx", "fy", "fz"), f, ("N",) * 3,
                       _FinalMean("h_e", (0, 1, 2)), tolerance=FORCE_TOLERANCE)]


def predictions(scenario) -> list[Prediction]:
    """The predictions of the module docstring that ``scenario`` (an
    :class:`~armlab.scenarios.Scenario`) has a theory for; empty when none applies."""
    from armlab.control.interaction import (
        AdmittanceControl,
        ComplianceControl,
        ForceControl,
        ImpedanceControl,
        ParallelForcePosition,
    )
    from armlab.control.joint_space import JointInverseDynamics
    from armlab.simulation.environment import PlanarWall, Spring

    controller, plant = scenario.controller, scenario.plant
    t_final = float(scenario.simulation.get("t_final", 0.0))
    if isinstance(controller, JointInverseDynamics):
        q_des, qd_des, _ = controller.reference.evaluate(t_final)
        if np.any(np.asarray(qd_des) != 0.0):
            return []
        e = computed_torque_equilibrium(plant, controller, q_des)
        labels = tuple(j.name for j in plant.joints)
        units = tuple("m" if j.kind == "prismatic" else "rad" for j in plant.joints)
        return [Prediction("equilibrium q̃ (H1)", labels, e, units, _FinalMean("q_err"),
                           tolerance=JOINT_TOLERANCE)]
    if isinstance(controller, ComplianceControl) and isinstance(scenario.environment, (Spring, PlanarWall)):
        return _compliance_predictions(scenario)
    if isinstance(controller, AdmittanceControl) and isinstance(scenario.environment, (Spring, PlanarWall)):
        return _admittance_predictions(scenario)
    if isinstance(controller, (ForceControl, ParallelForcePosition)) and np.any(np.asarray(controller.ki)):
        projector = image_projector(scenario.environment)
        f_d = np.asarray(controller.force.final, dtype=float)
        if projector is None or np.abs(f_d - projector @ f_d).max() > 1e-12 * max(1.0, np.abs(f_d).max()):
            # Free space, or f_d outside Image(K): the integral of the unreachable component grows
            # without bound and the arm moves with it, so there is no rest point to predict.
            return []
        return [Prediction("final force error f_d − f_e along Image(K) (H4)", ("x", "y", "z"), np.zeros(3),
                           ("N",) * 3, _ForceErrorInImage(projector), tolerance=FORCE_TOLERANCE)]
    if (isinstance(controller, ImpedanceControl) and len(controller.reference.times) == 1
            and tuple(controller.task) == (0, 1, 2) and controller.frame == "desired"):
        return [Prediction("impedance residual M_d x̃̈ + K_D x̃̇ + K_P x̃ − h_A (H5), RMS", ("x", "y", "z"),
                           np.zeros(3), ("N",) * 3, _ImpedanceRMS(controller), tolerance=RESIDUAL_TOLERANCE)]
    return []
