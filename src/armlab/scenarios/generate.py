"""Joint-space experiments of the course generated for any arm (A6 PD + gravity, A7 computed
torque), written as ordinary scenario files.

The seed's A6–A8 scenarios are written for the PRP: their goals, gains and durations are the
PRP's.  For another arm the same experiments need numbers of its own, chosen here from its
description:

* two poses q_a (start) and q_b (goal) inside the joint limits (10 % of each finite span away
  from them) where the arm is far from singular: σ_min(J)/σ_max(J) ≥ 0.05 for the geometric
  Jacobian J at q_a, q_b and along the straight line between them.  q_a is the middle of the
  limits (0 for a revolute joint without them), moved by seeded random draws until well
  conditioned; q_b = q_a + Δ, Δ_i = 0.3 rad (revolute) or 0.05 m (prismatic) towards the
  middle of the free range;
* A6, joint PD with online gravity compensation (C1) regulating q_a → q_b: per joint
  K_P,i = b_i ω_i², K_D,i = 2 b_i ω_i with b_i = B_ii(q_b), so each joint alone would be
  critically damped with its own inertia; by La Salle's argument (A6) the goal is reached with
  zero error whatever the coupling — up to the dead zone |q̃_i| ≤ F_s,i / K_P,i that Coulomb
  friction leaves a PD.  So ω_i = max(5 rad/s, √(F_s,i / (0.01 |Δ_i| b_i))): the dead zone is
  at most 1 % of the step (ω_i is capped at 0.2/dt, and the description then says so);
* A7, computed torque (C2) tracking quintic via points q_a → q_b → q_a: K_P = ω² I,
  K_D = 2ω I with ω = 10 rad/s, the model equal to the plant: the error stays at round-off;
* for a 6-joint arm, the full pose x = [p; φ] in Σ_0 (Euler angles ZYZ, or RPY when ZYZ's
  middle angle comes within 0.3 rad of its singularity at either pose) from x_a = x(q_a) to
  the goal x_b = x(q_b):  A9, operational-space PD with gravity compensation,
  K_P = Λ_A ω², K_D = 2 Λ_A ω with Λ_A the operational-space inertia (D8) of x at q_b and
  ω = 5 rad/s, raised (as for A6) until Coulomb friction's dead zone |B⁻¹F_s|/ω² is below 1 %
  of the step (the error vanishes, A9's Lyapunov argument); A10, operational-space inverse dynamics with
  K_P = 25 s⁻², K_D = 10 s⁻¹ (x̃ follows x̃̈ + 10 x̃̇ + 25 x̃ = 0 to the goal).
  The environments of A11–A15 (where the end effector meets a plane) are not generated.

The files name the arm as given (a bundled or zoo name, or the absolute path of its file) and
its tip, so ``armlab run FILE`` and the report run them like any scenario.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from armlab.errors import ReportError
from armlab.model.robot import Robot

CONDITION = 0.05
"""Smallest σ_min/σ_max of the geometric Jacobian accepted along the generated motions."""
PD_OMEGA = 5.0
CT_OMEGA = 10.0


def _box(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """Joint ranges the poses are drawn from: the limits pulled in by 10 % of their span;
    ±π (revolute) or ±0.5 m (prismatic) where a joint has none."""
    arrays = robot.arrays
    prismatic = arrays.joint_type == 1
    default = np.where(prismatic, 0.5, np.pi)
    lo = np.where(np.isfinite(arrays.q_min), arrays.q_min, -default)
    hi = np.where(np.isfinite(arrays.q_max), arrays.q_max, default)
    lo, hi = np.maximum(lo, -default * 2), np.minimum(hi, default * 2)
    margin = 0.1 * (hi - lo)
    return lo + margin, hi - margin


def _conditioned(robot: Robot, q) -> bool:
    from armlab.kinematics import geometric_jacobian

    sigma = np.linalg.svd(geometric_jacobian(robot, q, frame="0"), compute_uv=False)
    sigma = sigma[:min(robot.n, 6)]
    return sigma[-1] >= CONDITION * sigma[0]


def course_poses(robot: Robot, seed: int = 0, tries: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """(q_a, q_b) of the module docstring; :class:`ReportError` when no pair is found."""
    lo, hi = _box(robot)
    step = np.where(robot.arrays.joint_type == 1, 0.05, 0.3)
    rng = np.random.default_rng(seed)
    for attempt in range(tries):
        q_a = 0.5 * (lo + hi) if attempt == 0 else rng.uniform(lo, hi)
        direction = np.where(q_a <= 0.5 * (lo + hi), 1.0, -1.0)
        q_b = np.clip(q_a + direction * step, lo, hi)
        if all(_conditioned(robot, q_a + s * (q_b - q_a)) for s in np.linspace(0.0, 1.0, 6)):
            return q_a, q_b
    raise ReportError(f"{robot.name}: no well-conditioned pair of poses inside the joint limits "
                      f"found in {tries} seeded draws")


def _vector(values) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def _matrix(rows) -> str:
    return "[" + ", ".join(_vector(row) for row in rows) + "]"


def _friction_note(robot: Robot) -> str:
    if np.any(robot.arrays.coulomb > 0):
        return ("  Coulomb friction leaves a dead zone where J_Aᵀ K_P x̃ balances F_s (ω raised so that "
                "it stays below 1 % of the joint step).")
    return ""


def _string(text: str) -> str:
    """A TOML basic string (JSON's string escapes are TOML's)."""
    return json.dumps(str(text), ensure_ascii=False)


def _header(title, assignment, description, plant, tip) -> str:
    lines = [f"title = {_string(title)}", f"assignment = {_string(assignment)}",
             f"description = {_string(description)}", f"plant = {_string(plant)}"]
    if tip:
        lines.append(f"plant_tip = {_string(tip)}")
    return "\n".join(lines) + "\n"


def generated_scenarios(robot: Robot, plant: str, out_dir: str | Path, *, tip: str | None = None,
                        seed: int = 0) -> list[Path]:
    """Write the A6 and A7 scenario files of ``robot`` into ``out_dir``; returns their paths.

    ``plant`` is how the files name the arm (a bundled or zoo name, or a file path), ``tip``
    its end-effector link for a branched URDF/MJCF tree.
    """
    from armlab.dynamics import inertia_matrix

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    q_a, q_b = course_poses(robot, seed)
    b = np.diag(inertia_matrix(robot, q_b))
    dt = 0.001
    coulomb = robot.arrays.coulomb
    omega = np.maximum(PD_OMEGA, np.sqrt(coulomb / (0.01 * np.abs(q_b - q_a) * b)))
    capped = omega > 0.2 / dt
    omega = np.minimum(omega, 0.2 / dt)
    dead_zone = coulomb / (b * omega ** 2)
    friction_note = ""
    if np.any(coulomb > 0):
        friction_note = (f"  Coulomb friction leaves a dead zone |q̃_i| ≤ F_s,i/K_P,i ≤ {dead_zone.max():.3g}"
                         + (" (gains capped by the step)" if capped.any() else "") + ".")
    stem = "".join(c if c.isalnum() else "_" for c in robot.name).strip("_") or "arm"
    paths = []

    pd = out_dir / f"a6_{stem}_pd_gravity.toml"
    pd.write_text(_header(f"A6 — PD with online gravity compensation on {robot.name}", "A6",
                          f"Regulation q_a → q_b (poses inside the limits, σ_min/σ_max(J) ≥ {CONDITION}); "
                          "K_P,i = B_ii(q_b) ω_i², K_D,i = 2 B_ii(q_b) ω_i, ω_i = "
                          f"{_vector(np.round(omega, 3))} rad/s: the error goes to zero (A6's La Salle "
                          "argument)." + friction_note, plant, tip)
                  + f"\n[simulation]\nt_final = 6.0\ndt = {dt!r}\nq0 = {_vector(q_a)}\n"
                  + '\n[controller]\ntype = "joint_pd_gravity"\ncompensation = "online"\n'
                  + f"kp = {_vector(b * omega ** 2)}\nkd = {_vector(2 * b * omega)}\n"
                  + f'\n[controller.reference]\ntype = "constant"\nvalue = {_vector(q_b)}\n',
                  encoding="utf-8")
    paths.append(pd)

    ct = out_dir / f"a7_{stem}_computed_torque.toml"
    via = "[" + ", ".join(_vector(q) for q in (q_a, q_b, q_a)) + "]"
    ct.write_text(_header(f"A7 — computed torque on {robot.name}: quintic via points", "A7",
                          f"Tracking q_a → q_b → q_a (quintic, 2 s each) with an exact model; "
                          f"K_P = ω² I, K_D = 2ω I, ω = {CT_OMEGA:g} rad/s: the error stays at round-off.",
                          plant, tip)
                  + f"\n[simulation]\nt_final = 5.0\ndt = 0.001\nq0 = {_vector(q_a)}\n"
                  + '\n[controller]\ntype = "joint_inverse_dynamics"\n'
                  + f"kp = {CT_OMEGA ** 2!r}\nkd = {2 * CT_OMEGA!r}\n"
                  + '\n[controller.reference]\ntype = "via_points"\ntimes = [0.0, 2.0, 4.0]\n'
                  + f"values = {via}\n",
                  encoding="utf-8")
    paths.append(ct)
    if robot.n == 6:
        paths += _task_scenarios(robot, plant, tip, stem, q_a, q_b, out_dir)
    return paths


def _euler_for(robot: Robot, poses) -> str:
    """ZYZ unless its middle angle comes within 0.3 rad of 0 or π at one of the poses."""
    from armlab.kinematics import forward_kinematics
    from armlab.spatial import euler_from_matrix

    for q in poses:
        theta = euler_from_matrix(forward_kinematics(robot, q, "0")[:3, :3], "zyz")[1]
        if min(abs(np.sin(theta)), 1.0) < np.sin(0.3):
            return "rpy"
    return "zyz"


def _task_scenarios(robot, plant, tip, stem, q_a, q_b, out_dir) -> list[Path]:
    from armlab.kinematics import forward_kinematics
    from armlab.operational_space import operational_space_dynamics
    from armlab.spatial import euler_from_matrix

    euler = _euler_for(robot, (q_a, q_b))
    T_a, T_b = forward_kinematics(robot, q_a, "0"), forward_kinematics(robot, q_b, "0")
    phi_a = euler_from_matrix(T_a[:3, :3], euler)
    phi_b = euler_from_matrix(T_b[:3, :3], euler)
    phi_b = phi_a + np.angle(np.exp(1j * (phi_b - phi_a)))  # the triple nearest the start's
    goal = np.concatenate([T_b[:3, 3], phi_b])
    # Λ_A of x at the goal: K_P = Λ_A ω², K_D = 2 Λ_A ω make the linearised closed loop
    # Λ_A x̃̈ + K_D x̃̇ + K_P x̃ = 0 critically damped in every direction there.
    Lambda = operational_space_dynamics(robot, q_b, np.zeros(robot.n), euler=euler, frame="0").inertia
    Lambda = 0.5 * (Lambda + Lambda.T)
    # In joint terms the stiffness is J_Aᵀ K_P J_A = ω² B(q_b): Coulomb friction then leaves a
    # dead zone |B⁻¹ F_s| / ω², kept below 1 % of the step as for A6 (ω ≤ 0.2/dt).
    from armlab.dynamics import inertia_matrix

    creep = np.abs(np.linalg.solve(inertia_matrix(robot, q_b), robot.arrays.coulomb)).max()
    omega = min(max(PD_OMEGA, np.sqrt(creep / (0.01 * np.abs(q_b - q_a).max()))), 0.2 / 0.001)
    common = (f"\n[simulation]\nt_final = 6.0\ndt = 0.001\nq0 = {_vector(q_a)}\n"
              f'\n[controller]\ntype = "{{type}}"\nframe = "base"\neuler = "{euler}"\n'
              f"angle_reference = {_vector(phi_a)}\ntask = [0, 1, 2, 3, 4, 5]\n{{gains}}"
              f"\n[controller.reference]\ntimes = [0]\nposes = [{_vector(goal)}]\n")
    goal_text = (f"goal x_b = x(q_b) in Σ_0 ({euler.upper()} angles), from x_a = x(q_a); poses inside the "
                 f"limits with σ_min/σ_max(J) ≥ {CONDITION}")
    pd = out_dir / f"a9_{stem}_operational_pd.toml"
    pd.write_text(_header(f"A9 — operational-space PD with gravity compensation on {robot.name}", "A9",
                          f"τ = g + J_Aᵀ(K_P x̃ − K_D J_A q̇) on the full pose; {goal_text}; K_P = "
                          f"Λ_A ω², K_D = 2 Λ_A ω, ω = {omega:.4g} rad/s, Λ_A at q_b: "
                          "the error vanishes." + _friction_note(robot), plant, tip)
                  + common.format(type="operational_pd",
                                  gains=f"kp = {_matrix(Lambda * omega ** 2)}\n"
                                        f"kd = {_matrix(2 * Lambda * omega)}\n"),
                  encoding="utf-8")
    idyn = out_dir / f"a10_{stem}_operational_inverse_dynamics.toml"
    idyn.write_text(_header(f"A10 — operational-space inverse dynamics on {robot.name}", "A10",
                            f"τ = B J_A⁻¹(ẍ_d + K_D x̃̇ + K_P x̃ − J̇_A q̇) + n on the full pose; {goal_text}; "
                            "x̃ follows x̃̈ + 10 x̃̇ + 25 x̃ = 0.", plant, tip)
                    + common.format(type="operational_inverse_dynamics", gains="kp = 25.0\nkd = 10.0\n"),
                    encoding="utf-8")
    return [pd, idyn]
