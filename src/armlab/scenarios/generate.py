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
  K_D = 2ω I with ω = 10 rad/s, the model equal to the plant: the error stays at round-off.

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
    return paths
