"""The seed's course A6–A15 for any serial arm: scenario files generated from its own model.

:func:`course_scenarios` writes, for a robot, one scenario file per experiment of the seed's
assignments (the same format as the bundled ones, so each can be read, edited and run with
``armlab run FILE``), choosing what the PRP's files fix by hand:

* **poses** — a start q_s and a goal q_g drawn (seeded) from the central half of every joint's
  range, 5–30 cm apart, q_s at least 3 cm above q_g along the surface normal, the pair whose
  position Jacobian J_P (Σ_0) is best conditioned along the joint-space line between them
  (an arm of fewer than three joints, which gets no task-space experiment, may take a
  singular pair); the orientation a pose carries is written in the Euler convention ("zyz"
  or "rpy") whose singularity is farther along that line (:func:`euler_convention`);
* **gains from the dynamics** — laws that cancel the dynamics (A7, A10, A12–A15) take
  ω_n = 5 rad/s, ζ = 1 per unit mass (K_P = ω_n², K_D = 2ζω_n, the seed's numbers); PD laws
  (A6, A9, A11) scale them by the inertia they act on: K_P,i = B_ii(q_g) ω_n² in joint space
  (at least 1.5 α, the gravity-gradient bound of :func:`armlab.theory.gravity_gradient_bound`),
  K_P = λ_max(B_P) ω_n² in task space with B_P = (J_P B⁻¹ J_Pᵀ)⁻¹ at q_g, raised where the
  arm's Coulomb friction F_s would leave more than a 1 mm / 1 mrad dead band (the PD laws do
  not compensate friction: at rest K_P q̃ balances a static friction |τ_f,i| ≤ F_s,i), with
  K_D for ζ = 1 on the inertia (K_D = 2√(K_P B));
* **joint damping of the self-motion** — on an arm of n > 3 joints the task-space PD laws (A9,
  A11) damp only the three task velocities (V̇ = −q̇ᵀJ_PᵀK_D J_P q̇ vanishes on the n − 3
  directions of self-motion), so they get K_q,i = (ω_n/2) B_ii(q_g) (τ … − K_q q̇, C9): the
  self-motion's velocity then decays at K_q,i/B_ii = ω_n/2, and the task loop, critically
  damped by K_D, gains about (ω_n/2) B_P of damping (ζ = 1.25), whose slow pole is also ω_n/2.
  With K_q = c B, the slower of the two rates, min(c, ω_n(1 + u − √((1 + u)² − 1))) with
  u = c/(2ω_n), is largest at c = ω_n/2 (damping less leaves the self-motion slow, more the task);
* **the step** — 1 ms, or 1 ms / k (k = 2^a 5^b) for a PD law whose loop linearised at rest,
  B δq̈ + (F_v + D) δq̇ + K δq = 0, has a mode |λ| > 1000 1/s on the line from q_s to q_g, so
  that |λ| dt ≤ 1, well inside RK4's stability region (to 2.78 on the negative real axis):
  the PD laws leave the plant's viscous friction F_v and the raised gains on light wrists
  (the xArm7's B_77 = 1.4·10⁻⁴ kg·m² with F_v = 2 N·m·s/rad: |λ| ≈ 2·10⁴ 1/s, dt = 50 µs),
  where the laws that cancel the dynamics (A7, A10, A12–A15) leave 5–10 rad/s;
* **durations** — A9 and A11 run 10 s (their slowest task mode decays at about ω_n/2), the
  others 5–10 s; A12 starts at rest on the surface (q_g): its spring also pulls, and from q_s
  it would yank the end effector at 300–3000 m/s²; on an arm of n > 3 joints A9 and A11 run
  with the joint stops (``joint_limits = "stop"``): the self-motion, damped by K_q and held by
  no stiffness, swings on the transient's reaction torques (the so100's 20 g jaw, whose axis
  passes through the end point, runs 0.16–0.19 rad past its limit in A9 and A11 without them);
* **the environment** — a plane through the end effector's position at q_g, normal to gravity
  (a table under the tool; normal n = −g/|g|, pointing into free space), pushed 1 cm into by
  the compliance and impedance references, pressed on with f_d = −0.5 n N by the force laws;
  A11, A14 and A15 a wall that only pushes (E4; A11's as stiff as its controller, so the
  compromise x_e = (K_P + K)⁻¹(K_P x_d + K x_r), K = k n nᵀ, lands half-way), A12 a spring along
  n (the seed's model), from rest on the surface.

Task-space experiments control the three position components (x, y, z in Σ_0); on an arm of
n ≠ 3 joints the laws that invert J_P use damped least squares (λ = 10⁻³).  An arm of fewer
than three joints gets the joint-space experiments only, and :func:`course_scenarios` says why.
Every number written is a float printed by ``repr``: nothing of the robot file reaches the
scenario text except its reference, quoted by :func:`toml_string`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from armlab.dynamics import gravity_torque, inertia_matrix
from armlab.errors import InputError
from armlab.files import write_text
from armlab.kinematics import forward_kinematics, geometric_jacobian
from armlab.model.robot import Robot
from armlab.spatial import euler_from_matrix
from armlab.theory import gravity_gradient_bound

OMEGA = 5.0           # [rad/s] natural frequency of every designed loop, ζ = 1
SPRING = 1e4          # [N/m] A12 surface stiffness along n (A11's is the controller's K_P)
WALL = 1e3            # [N/m] A14–A15 wall stiffness (the seed's)
PUSH = 0.01           # [m] how far the A11–A13 references go into the surface
FORCE = 0.5           # [N] |f_d| of A14–A15 (the seed's)
DAMPING = 1e-3        # damped least squares of J_P on arms of n ≠ 3 joints
DEAD_BAND = 1e-3      # [rad | m] PD laws leave |q̃_i| ≤ F_s,i / K_P,i under Coulomb friction F_s
WRONG_MODEL = 0.8     # A8's initial estimates: every link's mass and inertia × this (at 0.5 the
                      # UR10's light wrist leaves RK4's reach at 1 ms as π̂ adapts)
SEED = 20261202
DT = 1e-3             # [s] the RK4 step of every experiment whose loop allows it
# |λ| dt of the fastest mode of a PD loop: RK4 is stable to 2.785 on the negative real axis and
# 2.83 on the imaginary one; 1 leaves a factor 2.8 for what the linearisation leaves out.
RK4_REACH = 1.0


def toml_string(text: str) -> str:
    """A TOML basic string holding ``text`` exactly (JSON's escaping is valid TOML)."""
    return json.dumps(text, ensure_ascii=False)


def _value(value) -> str:
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(f"not a finite number: {number!r}")
        return repr(number)
    return "[" + ", ".join(_value(v) for v in value) + "]"


def to_toml(document: dict) -> str:
    """TOML text of ``document``: top-level keys, then tables (one level of nesting each)."""
    lines, tables = [], []
    for key, value in document.items():
        (tables if isinstance(value, dict) else lines).append((key, value))
    out = [f"{key} = {_value(value)}" for key, value in lines]

    def table(name, body):
        out.append("")
        out.append(f"[{name}]")
        nested = []
        for key, value in body.items():
            if isinstance(value, dict):
                nested.append((key, value))
            else:
                out.append(f"{key} = {_value(value)}")
        for key, value in nested:
            table(f"{name}.{key}", value)

    for key, value in tables:
        table(key, value)
    return "\n".join(out) + "\n"


def _box(robot: Robot) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's range: its limits, or ±π (revolute) / ±0.2 m (prismatic) when unlimited."""
    lo, hi = robot.arrays.q_min.copy(), robot.arrays.q_max.copy()
    for i, joint in enumerate(robot.joints):
        span = math.pi if joint.kind == "revolute" else 0.2
        lo[i] = lo[i] if math.isfinite(lo[i]) else -span
        hi[i] = hi[i] if math.isfinite(hi[i]) else span
    return lo, hi


def _position(robot, q):
    return forward_kinematics(robot, q, frame="0")[:3, 3]


def _sigma_min(robot, q) -> float:
    return float(np.linalg.svd(geometric_jacobian(robot, q, frame="0")[:3], compute_uv=False)[-1])


def choose_poses(robot: Robot, normal: np.ndarray, *, candidates: int = 400, seed: int = SEED):
    """(q_s, q_g): the pair of the module docstring, or raise ``InputError`` saying why none.

    An arm of fewer than three joints gets the joint-space experiments only, which invert no
    Jacobian: its pair may be singular (the zoo's double pendulum ends on its second joint's
    axis, so its J_P has rank 1 everywhere); the best conditioned admissible pair is still
    preferred."""
    lo, hi = _box(robot)
    rng = np.random.default_rng(seed)
    qs = lo + (0.25 + 0.5 * rng.random((candidates, robot.n))) * (hi - lo)
    sigma = np.array([_sigma_min(robot, q) for q in qs])
    positions = np.array([_position(robot, q) for q in qs])
    order = np.argsort(-sigma)[: max(20, candidates // 10)]
    best, best_score = None, 0.0 if robot.n >= 3 else -math.inf
    for g in order:
        height = (positions - positions[g]) @ normal
        distance = np.linalg.norm(positions - positions[g], axis=1)
        for s in order:
            if s == g or height[s] < 0.03 or not 0.05 <= distance[s] <= 0.3:
                continue
            path = [_sigma_min(robot, qs[s] + u * (qs[g] - qs[s])) for u in np.linspace(0, 1, 11)]
            score = min(path)
            if score > best_score:
                best, best_score = (qs[s], qs[g]), score
    if best is None:
        regular = " with a regular J_P along the way" if robot.n >= 3 else ""
        raise InputError(f"{robot.name}: no start and goal 5–30 cm apart with the start 3 cm above "
                         f"the goal{regular} were found in the central half of the joint ranges")
    return best


def euler_convention(rotations) -> str:
    """The supported Euler convention (``spatial.EULER_CONVENTIONS``) farther from its
    representation singularity over ``rotations``: ZYZ is singular where
    sin ϑ = hypot(r13, r23) = 0 (the tool's z axis along Σ_0's), RPY where
    cos ϑ = hypot(r11, r21) = 0 (the tool's x axis along Σ_0's z); a tie keeps the seed's ZYZ."""
    zyz = min(math.hypot(R[0, 2], R[1, 2]) for R in rotations)
    rpy = min(math.hypot(R[0, 0], R[1, 0]) for R in rotations)
    return "zyz" if zyz >= rpy else "rpy"


def fastest_mode(robot: Robot, path, loop) -> float:
    """The largest |λ| [1/s] over ``path`` (poses q) of the PD loop linearised at rest,

        B(q) δq̈ + (F_v + D(q)) δq̇ + K(q) δq = 0,   (K, D) = ``loop(q)`` (n × n),

    λ the eigenvalues of [[0, I], [−B⁻¹K, −B⁻¹(F_v + D)]].  Left out: ∂g/∂q (below K_P/1.5 by
    the gain rule, or compensated), C q̇ (zero at rest) and Coulomb friction (not a linear mode)."""
    n, viscous, fastest = robot.n, np.diag(robot.arrays.viscous), 0.0
    for q in path:
        K, D = loop(q)
        B = inertia_matrix(robot, q)
        A = np.block([[np.zeros((n, n)), np.eye(n)],
                      [-np.linalg.solve(B, K), -np.linalg.solve(B, viscous + D)]])
        fastest = max(fastest, float(np.abs(np.linalg.eigvals(A)).max()))
    return fastest


def time_step(fastest: float) -> float:
    """DT / k with ``fastest`` · dt ≤ RK4_REACH, k ≥ 1 the smallest of the form 2^a 5^b: dt is a
    short decimal (0.5, 0.25, 0.2, 0.1 … ms) and every t_final, a whole number of
    milliseconds, stays a whole number of steps."""
    need = fastest * DT / RK4_REACH
    if not math.isfinite(need):
        raise InputError(f"the fastest mode of a PD loop is not finite ({fastest!r} 1/s): "
                         "no step can hold it")
    k = min(2**a * 5**b for a in range(40) for b in range(20) if 2**a * 5**b >= need)
    return DT / k


def _surface(stiffness: float, normal: np.ndarray) -> list[list[float]]:
    """The 6 × 6 stiffness of a spring that resists only along ``normal`` (E2)."""
    K = np.zeros((6, 6))
    K[:3, :3] = stiffness * np.outer(normal, normal)
    return K.tolist()


class _Plan:
    """The choices of the module docstring for one robot, and the scenario files made of them."""

    def __init__(self, robot: Robot, reference: str, seed: int, tip: str | None = None):
        self.robot, self.reference, self.tip, n = robot, reference, tip, robot.n
        gravity = np.asarray(robot.gravity, dtype=float)
        norm = np.linalg.norm(gravity)
        self.normal = -gravity / norm if norm > 0 else np.array([0.0, 0.0, 1.0])
        self.q_s, self.q_g = choose_poses(robot, self.normal, seed=seed)
        self.path = [self.q_s + u * (self.q_g - self.q_s) for u in np.linspace(0.0, 1.0, 11)]
        self.B = inertia_matrix(robot, self.q_g)
        self.coulomb = np.asarray(robot.arrays.coulomb, dtype=float)
        # K_P,i above 1.5 α, the gravity-gradient bound (H2): option 3 (g(q_des)) is then
        # globally stable and option 2 (no compensation) has a single equilibrium.
        self.alpha = gravity_gradient_bound(robot)
        inertia = np.diag(self.B)
        self.joint_kp = np.maximum.reduce([inertia * OMEGA**2, self.coulomb / DEAD_BAND,
                                           np.full(n, 1.5 * self.alpha)])
        self.joint_kd = 2 * np.sqrt(self.joint_kp * inertia)
        self.where = (f"on {robot.name}: start q_s = {np.round(self.q_s, 4).tolist()}, "
                      f"goal q_g = {np.round(self.q_g, 4).tolist()}")
        self.files: dict[str, str] = {}
        self.skipped: list[str] = []

    def add(self, name, assignment, title, description, simulation, controller, environment=None,
            loop=None):
        """One scenario file; ``loop(q)`` → (K, D) of a PD law sets its step (:func:`time_step`)."""
        dt = DT
        if loop is not None:
            fastest = fastest_mode(self.robot, self.path, loop)
            dt = time_step(fastest)
            if dt < DT:
                description += (f"; dt = {dt * 1e3:.4g} ms, so that the fastest mode of the loop "
                                f"linearised at rest, |λ| = {fastest:.4g} 1/s, has |λ| dt ≤ {RK4_REACH:g} "
                                "(RK4 is stable to 2.78)")
        document = {"title": title, "assignment": assignment,
                    "description": f"{description} ({self.where})", "plant": self.reference,
                    "simulation": {"dt": dt, **simulation}, "controller": controller}
        if self.tip:
            document["plant_tip"] = self.tip
        if environment is not None:
            document["environment"] = environment
        self.files[f"{name}.toml"] = to_toml(document)

    def joint_space(self):
        """A6 (the three compensation options), A7 (tracking, the seed's mismatch), A8."""
        robot, q_s, q_g = self.robot, self.q_s, self.q_g
        goal = {"type": "constant", "value": q_g}
        for option, text in (("online", "g(q) computed online"), ("none", "no gravity compensation"),
                             ("desired", "g(q_des)")):
            self.add(f"a06_pd_{option}", "A6", f"A6 — PD with {text}",
                     "Joint PD, K_P,i = max(B_ii(q_g) ω_n², F_s,i / 1 mrad, 1.5 α), K_D,i = 2√(K_P,i B_ii), "
                     f"ω_n = 5 rad/s, α = {self.alpha:.4g} the largest ‖∂g/∂q‖ (option 3's gain condition)"
                     + ("; without compensation it settles where K_P q̃ = g(q)" if option == "none" else ""),
                     {"t_final": 6.0, "q0": q_s},
                     {"type": "joint_pd_gravity", "compensation": option, "kp": self.joint_kp,
                      "kd": self.joint_kd, "reference": goal},
                     loop=lambda q: (np.diag(self.joint_kp), np.diag(self.joint_kd)))
        via = {"type": "via_points", "times": [0.5, 2.5], "values": [q_s, q_g]}
        self.add("a07_id_via_points", "A7", "A7 — inverse dynamics (computed torque) from start to goal",
                 "τ = B y + n with ω_n = 5 rad/s, ζ = 1: a rest-to-rest quintic tracked exactly",
                 {"t_final": 5.0, "q0": q_s},
                 {"type": "joint_inverse_dynamics", "kp": OMEGA**2, "kd": 2 * OMEGA, "reference": via})
        # The link whose mass gravity feels most at the goal (the seed's link 4 on the PRP).
        g = gravity_torque(robot, q_g)

        def felt(link):
            lighter = robot.with_link_mass(link.name, 0.8 * link.inertial.mass)
            return np.linalg.norm(gravity_torque(lighter, q_g) - g)
        link = max((link for link in robot.links if link.inertial.mass > 0), key=felt)
        self.add("a07_id_mismatch", "A7", f"A7 — inverse dynamics, Ĉ and ĝ with {link.name} 20 % light",
                 "The seed's mismatch on this arm: n̂ computed with 0.8 × the mass of the link gravity loads "
                 "most, B̂ exact; the steady-state error is the equilibrium B K_P q̃ = g − ĝ",
                 {"t_final": 10.0, "q0": q_s},
                 {"type": "joint_inverse_dynamics", "kp": OMEGA**2, "kd": 2 * OMEGA, "reference": goal,
                  "bias_model_link_mass": {link.name: 0.8 * link.inertial.mass}})
        if robot.arrays.rotor_inertia.any() or self.coulomb.any():
            self.skipped.append("A8: Slotine–Li estimates neither rotor inertia nor Coulomb friction, "
                                "which this arm has")
            return
        lo, hi = _box(robot)
        sine = {"type": "sinusoid", "center": q_g, "amplitude": 0.05 * (hi - lo), "omega": 1.0}
        # As the seed's A8 (π̂(0) ≠ π): the estimates start from a model whose links weigh
        # WRONG_MODEL × theirs (inertias alike), else there is nothing to adapt.
        wrong = {link.name: WRONG_MODEL * link.inertial.mass
                 for link in robot.links if link.inertial.mass > 0}
        self.add("a08_adaptive_sine", "A8", "A8 — Slotine–Li adaptive control on a sinusoid",
                 f"Every link's 11 parameters adapted, starting from a model whose links weigh "
                 f"{WRONG_MODEL:g} × theirs (the seed's wrong initial estimates): the tracking error "
                 "falls as π̂ adapts",
                 {"t_final": 10.0, "q0": q_g},
                 {"type": "slotine_li", "kd": 2 * self.joint_kd, "lam": OMEGA, "gamma": 0.1,
                  "reference": sine, "model_link_mass": wrong})

    def task_space(self):
        """A9–A12, A14, A15 on the position task."""
        robot, q_s, q_g, n, normal = self.robot, self.q_s, self.q_g, self.robot.n, self.normal
        p_s, p_g = _position(robot, q_s), _position(robot, q_g)
        # Orientation is not part of the task, but a pose carries one: the goal's own, in the
        # convention farther from its singularity along the way (the run passes through the
        # orientations between the start's and the goal's).
        euler = euler_convention([forward_kinematics(robot, q, frame="0")[:3, :3] for q in self.path])
        angles = euler_from_matrix(forward_kinematics(robot, q_g, frame="0")[:3, :3], euler).tolist()

        def poses(times, *positions):
            return {"times": times, "poses": [[*p, *angles] for p in positions], "euler": euler}
        J = geometric_jacobian(robot, q_g, frame="0")[:3]
        heavy = float(np.linalg.eigvalsh(np.linalg.inv(J @ np.linalg.solve(self.B, J.T))).max())
        # The task force joint friction can hold at rest, at worst: |J_P⁺ᵀ| F_s.
        held = float(np.linalg.norm(np.abs(np.linalg.pinv(J).T) @ self.coulomb))
        kp = max(heavy * OMEGA**2, held / DEAD_BAND)
        kd = 2 * math.sqrt(kp * heavy)
        damping = {} if n == 3 else {"damping": DAMPING}
        # K_q for the self-motion of the module docstring (n > 3 only: the PRP's files stay the seed's).
        joint_damping = 0.5 * OMEGA * np.diag(self.B)
        self_motion = {} if n <= 3 else {"joint_damping": joint_damping}
        law = "τ = g + J_Pᵀ(K_P p̃ − K_D J_P q̇)" + ("" if n <= 3 else " − K_q q̇")
        said = "" if n <= 3 else (f"; K_q = (ω_n/2) B_ii(q_g) = {np.round(joint_damping, 4).tolist()} "
                                  "damps the self-motion the 3-D task leaves free, the joint stops keep "
                                  "it in range")
        task = {"frame": "base", "task": [0, 1, 2], "euler": euler, "angle_reference": angles}
        kq = np.diag(joint_damping) if n > 3 else np.zeros((n, n))

        def task_loop(stiffness):
            """(K, D) in joint space of the task-space PD laws: K_P (and the surface) and K_D
            act through J_P, K_q on the joints."""
            def loop(q):
                J = geometric_jacobian(robot, q, frame="0")[:3]
                return J.T @ stiffness @ J, kd * J.T @ J + kq
            return loop
        # The PD laws' slowest task mode decays at about ω_n/2 (measured 1.9–2.5 1/s): 10 s bring
        # the 5–30 cm from start to goal below 10⁻⁸ m where 6 s left up to 10⁻⁵ m.
        # The self-motion swings on the reaction torques of the transient, damped by K_q alone (no
        # stiffness holds it): the arm's joint stops (S4) keep it in range, as on the real arm
        # (the so100's 20 g jaw, its J_P column zero, runs 0.16–0.19 rad past its limit without them).
        settle = {"t_final": 10.0, "q0": q_s, **({} if n <= 3 else {"joint_limits": "stop"})}
        start = {"t_final": 6.0, "q0": q_s}
        self.add("a09_pd_goal", "A9", "A9 — operational-space PD with gravity compensation to the goal",
                 f"{law}, K_P = {kp:.4g} N/m (λ_max(B_P) ω_n², or what holds the "
                 f"arm's Coulomb friction to 1 mm){said}", settle,
                 {"type": "operational_pd", **task, "kp": kp, "kd": kd, **self_motion,
                  "reference": poses([0.0], p_g)}, loop=task_loop(kp * np.eye(3)))
        self.add("a10_id_via_poses", "A10", "A10 — operational-space inverse dynamics along a straight line",
                 "Rest-to-rest quintic along the straight line from start to goal, tracked exactly "
                 "(ω_n = 5 rad/s, ζ = 1)" + ("" if n == 3 else "; damped least squares, λ = 1e-3"),
                 {"t_final": 5.0, "q0": q_s},
                 {"type": "operational_inverse_dynamics", **task, **damping, "kp": OMEGA**2, "kd": 2 * OMEGA,
                  "reference": poses([0.5, 3.0], p_s, p_g)})
        into = poses([0.0], p_g - PUSH * normal)
        # A wall as stiff as the controller along its normal: the compromise lands half-way.  A
        # wall, not the seed's spring: from q_s, 3–30 cm off the surface, a spring that also pulls
        # drew the end effector in with up to 50 N (UR5) before the two met.
        self.add("a11_compliance", "A11", "A11 — compliance control against the surface",
                 f"PD + g towards a point 1 cm inside a wall as stiff as the controller (k = K_P = "
                 f"{kp:.4g} N/m along the normal): it settles half-way, at "
                 f"x_e = (K_P + K)⁻¹(K_P x_d + K x_r){said}",
                 settle, {"type": "compliance", **task, "kp": kp, "kd": kd, **self_motion, "reference": into},
                 {"type": "planar_wall", "point": p_g, "normal": normal, "stiffness": kp},
                 loop=task_loop(kp * (np.eye(3) + np.outer(normal, normal))))
        # A12 starts on the surface: the spring also pulls (the seed's model), and from q_s, 3–30 cm
        # above it, K = 10⁴ N/m would yank the end effector at 300–3000 m/s² (M_d = 1 kg).
        self.add("a12_impedance_regulation", "A12", "A12 — impedance control against the surface",
                 "M_d p̃̈ + K_D p̃̇ + K_P p̃ = h_A with M_d = 1 kg, K_P = 25 N/m, K_D = 10 N·s/m, from rest "
                 "on the surface (q_g)", {"t_final": 6.0, "q0": q_g},
                 {"type": "impedance", **task, "frame": "desired", **damping, "mass": 1.0,
                  "kp": OMEGA**2, "kd": 2 * OMEGA, "reference": into},
                 {"type": "spring", "stiffness": _surface(SPRING, normal), "rest_position": p_g})
        force = {"final": -FORCE * normal, "duration": 0.5}
        wall = {"type": "planar_wall", "point": p_g, "normal": normal, "stiffness": WALL, "damping": 5.0}
        loop = {**damping, "kp": 100.0, "kd": 20.0, "kf": 1e-4, "ki": 2e-3, "force": force}
        self.add("a14_force_inner_position", "A14", "A14 — force control with an inner position loop",
                 f"f_d = {FORCE:g} N into the wall (K_F = 1e-4 m/N, K_I = 2e-3 m/(N·s), inner loop "
                 "ω_n = 10 rad/s): the integral action reaches f_d", start,
                 {"type": "force", "inner": "position", **loop, "x_F0": p_g}, wall)
        self.add("a15_parallel_contact", "A15", "A15 — parallel force/position control on the wall",
                 f"x_d on the wall, f_d = {FORCE:g} N into it: f_e = f_d along the normal, x_e = x_d along "
                 "the wall", start,
                 {"type": "parallel_force_position", **loop, "reference": poses([0.0], p_g)}, wall)
        self.skipped.append("A13: admittance control is generated for the PRP only")


def course_scenarios(robot: Robot, reference: str, *, seed: int = SEED,
                     tip: str | None = None) -> tuple[dict[str, str], list[str]]:
    """({file name: scenario text}, [why an assignment is left out]) for ``robot``, named in the
    files by ``reference`` (a bundled name or a path the scenarios can load it from) and
    ``tip`` (``plant_tip``, for a URDF/MJCF tree; see :func:`armlab.robots.robot_reference`)."""
    plan = _Plan(robot, reference, seed, tip)
    plan.joint_space()
    if robot.n < 3:
        plan.skipped.append(f"A9–A15: a {robot.n}-joint arm cannot hold a 3-D position task")
    else:
        plan.task_space()
    return plan.files, plan.skipped


def write_course(robot: Robot, reference: str, folder, *, seed: int = SEED,
                 tip: str | None = None) -> tuple[list[Path], list[str]]:
    """Write :func:`course_scenarios` into ``folder`` (created); (paths, skipped)."""
    files, skipped = course_scenarios(robot, reference, seed=seed, tip=tip)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, text in files.items():
        paths.append(write_text(folder / name, text))
    return paths, skipped
