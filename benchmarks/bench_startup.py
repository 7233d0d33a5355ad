"""Fresh processes: the time to the first result, beside MuJoCo's.

Every figure is the time of a whole subprocess (interpreter start, imports, loading, the run):
its wall time and its CPU time (user + system, all threads), the best of several processes.
"Filled caches" include Python's own bytecode cache (kept in a folder of the benchmark's, see
:func:`environment`): without it every process compiles each module it imports from source,
numba's import alone then takes several times longer; (a) shows both.

* **(a) Filled caches**: ``armlab run a7_id_via_points`` (the A7 computed-torque run, 10 s at
  1 kHz, RK4; its data written as .npz) against MuJoCo's fresh process for the same run: the
  PRP loaded from armlab's URDF export, RK4 at 1 kHz, the same computed torque
  τ = B(q) y + n(q, q̇) in a Python control callback (``mujoco.set_mjcb_control``, called at
  every RK4 stage as armlab's law is).  Target (issue 14): armlab ≤ 2× MuJoCo.  The row names
  the plant kernels armlab's run used: the scenario's "auto" takes the PRP's generated module
  when one is on disk (in ``make bench`` the scripts before this one make it), else the numeric
  kernels.  Beside it the
  floor of any numba program (import numba, call one cached compiled function) and MuJoCo's
  cheaper run with the torque computed once per step and held over its RK4 stages.
* **(b)** ``import armlab`` (CPU) above ``import numba``; target ≤ 0.5 s.  Beside it the
  whole public API (every name of ``armlab.__all__`` touched) above ``import numba``.
* **(c) Empty caches** (a new ``NUMBA_CACHE_DIR`` and ``ARMLAB_CACHE_DIR`` for each process;
  Python's bytecode cached):
  the first A7 result (target ≤ 15 s, one process); a 3-joint and a 7-joint arm with ordinary
  random parameters (:func:`random_arm`), their first ``armlab.simulate`` (targets ≤ 15 s each).
  One process each (a second would find its caches filled); a process still running after
  :data:`TIMEOUT` seconds is stopped and shown as such.

MuJoCo is a benchmark-only dependency (``pip install -e ".[bench]"``, which ``make bench``
does); without it, its side is skipped with a message.  Before anything is timed, MuJoCo's
trajectory is checked against armlab's (:func:`check_mujoco`, also run by the test suite when
MuJoCo is installed).

Run: ``python benchmarks/bench_startup.py`` or ``make bench``.
"""

from __future__ import annotations

import importlib.util
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from agreement import OTHER_ALGORITHM, assert_close

HERE = Path(__file__).resolve().parent
TIMEOUT = 240.0
BEST_OF = 3
IMPORT_BEST_OF = 5
T_FINAL, DT = 10.0, 1e-3
SCENARIO = "a7_id_via_points"

ARMLAB_CLI = "import sys; from armlab.cli import main; sys.exit(main())"
"""What the ``armlab`` console script runs (``[project.scripts]``), with this interpreter."""

MUJOCO_RUN = '''
import json, math, sys, time
spec = json.loads(sys.argv[1])
import mujoco
import numpy as np

model = mujoco.MjModel.from_xml_path(spec["urdf"])
model.opt.timestep = spec["dt"]
model.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
data = mujoco.MjData(model)
times, values = spec["times"], np.array(spec["values"])
kp, kd, n = spec["kp"], spec["kd"], model.nv
y, tau = np.zeros(n), np.zeros(n)


def reference(t):
    """Rest-to-rest quintics through the via points (q_des, q̇_des, q̈_des)."""
    if t <= times[0]:
        return values[0], 0.0, 0.0
    if t >= times[-1]:
        return values[-1], 0.0, 0.0
    j = 0
    while t >= times[j + 1]:
        j += 1
    span = times[j + 1] - times[j]
    u = (t - times[j]) / span
    delta = values[j + 1] - values[j]
    return (values[j] + delta * (u ** 3 * (10.0 - 15.0 * u + 6.0 * u * u)),
            delta * (u * u * (30.0 - 60.0 * u + 30.0 * u * u) / span),
            delta * (u * (60.0 - 180.0 * u + 120.0 * u * u) / (span * span)))


def computed_torque(m, d):
    q_des, qd_des, qdd_des = reference(d.time)
    np.add(qdd_des + kd * (qd_des - d.qvel), kp * (q_des - d.qpos), out=y)
    mujoco.mj_mulM(m, d, tau, y)
    d.qfrc_applied[:] = tau + d.qfrc_bias


steps = round(spec["t_final"] / spec["dt"])
q = np.empty((steps + 1, n))
q[0] = data.qpos
start = time.perf_counter()
if spec["hold"]:
    # The torque computed once per step and held over its four RK4 stages.
    for k in range(steps):
        mujoco.mj_forward(model, data)
        computed_torque(model, data)
        mujoco.mj_step(model, data)
        q[k + 1] = data.qpos
else:
    mujoco.set_mjcb_control(computed_torque)
    for k in range(steps):
        mujoco.mj_step(model, data)
        q[k + 1] = data.qpos
    mujoco.set_mjcb_control(None)
print(json.dumps({"q": q[::100].tolist(), "run": time.perf_counter() - start}))
'''
"""MuJoCo's side of (a), a whole program; argument: a JSON spec (URDF path, reference, gains,
t_final, dt, hold: the torque computed once per step instead of at every RK4 stage); prints
every 100th q and the seconds of the loop alone."""

NUMBA_FLOOR = '''
import sys
sys.path.insert(0, sys.argv[1])
from numba_floor import one
one(1.0)
'''

FIRST_SIMULATE = '''
import sys
sys.path.insert(0, sys.argv[1])
from bench_startup import first_simulate
first_simulate(int(sys.argv[2]))
'''


class Timed:
    """Wall and CPU seconds of one subprocess, its stdout, or the timeout it ran into."""

    def __init__(self, wall, cpu, stdout="", timed_out=False):
        self.wall, self.cpu, self.stdout, self.timed_out = wall, cpu, stdout, timed_out

    def text(self, what="wall"):
        seconds = self.wall if what == "wall" else self.cpu
        return f"> {TIMEOUT:.0f} s (stopped)" if self.timed_out else f"{seconds:.2f} s"


def run_process(args, env=None, timeout=TIMEOUT) -> Timed:
    """Run ``args``; raise on failure (with its stderr), return its times."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        done = subprocess.run(args, capture_output=True, text=True, env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        return Timed(timeout, float("nan"), timed_out=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, args[:4]))} … failed:\n{done.stderr[-3000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return Timed(wall, cpu, done.stdout)


def best_of(count, args, env=None) -> Timed:
    """The best wall and the best CPU time of ``count`` processes (the last one's stdout)."""
    runs = [run_process(args, env) for _ in range(count)]
    return Timed(min(r.wall for r in runs), min(r.cpu for r in runs), runs[-1].stdout)


# --------------------------------------------------------------------- the arms of (c)
def random_arm(n: int, seed: int = 0):
    """An n-joint revolute arm with ordinary, non-round random parameters, built with armlab's
    Python API: standard DH rows (a 0.1–0.5 m, d 0–0.3 m, α one of 0, ±π/2, θ offset random),
    each link a box of 0.5–5 kg from joint i to joint i+1 with its centre of mass off the box's
    centre by up to 1 cm."""
    from armlab.model import DHRow, Inertial, Joint, Link, Robot, box_inertia

    rng = np.random.default_rng(seed)
    joints, links = [], []
    for i in range(n):
        a, d = rng.uniform(0.1, 0.5), rng.uniform(0.0, 0.3)
        row = DHRow(a=a, alpha=rng.choice([0.0, np.pi / 2, -np.pi / 2]), d=d, theta=rng.uniform(-0.5, 0.5))
        joints.append(Joint.from_dh(f"q{i + 1}", "revolute", row))
        mass = rng.uniform(0.5, 5.0)
        size = [a, rng.uniform(0.04, 0.1), rng.uniform(0.04, 0.1)]
        com = np.array([-a / 2, 0.0, 0.0]) + rng.uniform(-0.01, 0.01, 3)
        links.append(Link(f"link{i + 1}", Inertial(mass=mass, com=com, inertia=box_inertia(mass, size))))
    return Robot(name=f"random{n}", joints=tuple(joints), links=tuple(links))


def first_simulate(n: int, t_final: float = T_FINAL, dynamics: str | None = None) -> None:
    """Build :func:`random_arm` (n) and simulate it once under computed torque to a via point,
    ``t_final`` at 1 kHz (RK4), with armlab's default dynamics unless ``dynamics`` names one;
    prints the final q.  The whole of (c)'s random-arm process."""
    import armlab
    from armlab.control.joint_space import JointInverseDynamics
    from armlab.references.joint import ViaPoints

    robot = random_arm(n)
    goal = np.linspace(0.3, -0.3, n)
    choice = {} if dynamics is None else {"dynamics": dynamics}
    controller = JointInverseDynamics(robot, ViaPoints([0.5, 2.5], [np.zeros(n), goal]), 25.0, 10.0, **choice)
    result = armlab.simulate(robot, controller, q0=np.zeros(n), t_final=t_final, dt=DT, **choice)
    if result.status != "ok":
        raise RuntimeError(f"random{n}: {result.status}")
    print(json.dumps({"q_final": result.q[-1].tolist(), "dynamics": result.meta.get("dynamics")}))


# ------------------------------------------------------------------------------ MuJoCo
def mujoco_available() -> bool:
    return importlib.util.find_spec("mujoco") is not None


def mujoco_spec(folder, t_final=T_FINAL, hold=False) -> str:
    """The JSON argument of :data:`MUJOCO_RUN`: the A7 plant as URDF in ``folder``, its
    reference and gains (read from the scenario, as armlab's side reads them)."""
    from armlab.model.urdf_io import save_urdf
    from armlab.scenarios import load_scenario

    scenario = load_scenario(SCENARIO)
    controller = scenario.controller
    urdf = save_urdf(scenario.plant, Path(folder) / "prp.urdf")
    return json.dumps({"urdf": str(urdf), "times": np.asarray(controller.reference.times, float).tolist(),
                       "values": np.asarray(controller.reference.values, float).tolist(),
                       "kp": float(controller.kp[0, 0]), "kd": float(controller.kd[0, 0]),
                       "t_final": t_final, "dt": DT, "hold": hold})


def check_mujoco(t_final=T_FINAL) -> float:
    """MuJoCo's trajectory (every 100th sample) against armlab's A7 run of ``t_final``, to
    :data:`OTHER_ALGORITHM`: the same plant, reference, law and integrator on both sides.
    Returns the largest difference."""
    from armlab.scenarios import load_scenario

    with tempfile.TemporaryDirectory() as folder:
        out = run_process([sys.executable, "-c", MUJOCO_RUN, mujoco_spec(folder, t_final)])
    theirs = np.array(json.loads(out.stdout)["q"])
    ours = load_scenario(SCENARIO).run(t_final=t_final).q[::100]
    return assert_close(theirs, ours, OTHER_ALGORITHM, "MuJoCo's A7 trajectory vs armlab's")


# ----------------------------------------------------------------------------- figures
def environment(bytecode: str, **extra) -> dict:
    """The environment of a measured process: this one's, with Python's bytecode cache kept in
    the folder ``bytecode`` (``PYTHONPYCACHEPREFIX``: the benchmark writes nothing into the
    installation and reads no bytecode from it) and written there even where this process runs
    with ``PYTHONDONTWRITEBYTECODE``; ``extra`` added."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return dict(env, PYTHONPYCACHEPREFIX=bytecode, **extra)


def armlab_run_args(out_dir) -> list[str]:
    return [sys.executable, "-c", ARMLAB_CLI, "run", SCENARIO, "--out", str(out_dir), "--format", "npz"]


def numba_floor(env) -> Timed:
    """Import numba and call one compiled function from its disk cache (filled first)."""
    with tempfile.TemporaryDirectory() as folder:
        Path(folder, "numba_floor.py").write_text(
            "from numba import njit\n\n\n@njit(cache=True)\ndef one(x):\n    return x + 1.0\n")
        args = [sys.executable, "-c", NUMBA_FLOOR, folder]
        run_process(args, env)
        return best_of(BEST_OF, args, env)


def run_dynamics(out) -> str:
    """The plant kernels armlab's run in folder ``out`` used, from its file's header: "auto"
    takes the robot's generated module only once one is on disk (else the numeric kernels),
    so the figure of (a) depends on what ran on the machine before."""
    with np.load(Path(out) / f"{SCENARIO}.npz", allow_pickle=False) as data:
        return json.loads(str(data["header"]))["meta"]["dynamics"]


def fresh_processes(env, specs):
    """armlab's A7 process, numba's floor and MuJoCo's process for each of ``specs``, best of
    :data:`BEST_OF` each after one process that fills the caches; and the kernels armlab ran."""
    with tempfile.TemporaryDirectory() as out:
        run_process(armlab_run_args(out), env)
        ours = best_of(BEST_OF, armlab_run_args(out), env)
        dynamics = run_dynamics(out)
    theirs = []
    for spec in specs:
        mujoco = [sys.executable, "-c", MUJOCO_RUN, spec]
        run_process(mujoco, env)
        theirs.append(best_of(BEST_OF, mujoco, env))
    return ours, numba_floor(env), theirs, dynamics


def filled_caches_case(bytecode):
    """(a): armlab's and MuJoCo's fresh processes for the A7 run, with Python's bytecode cache
    (what a user has from the second process on), then without it for comparison.  Beside
    MuJoCo's same run, its run with the torque held over each step (a cheaper program, not the
    same trajectory) for scale."""
    print(f"\n(a) Fresh process, filled caches: `armlab run {SCENARIO}` (10 s at 1 kHz, RK4, "
          f"computed torque; best of {BEST_OF}, wall and CPU time)")
    available = mujoco_available()
    if not available:
        print("  MuJoCo is not installed (pip install -e '.[bench]'): its side is skipped")
    else:
        print(f"  MuJoCo's trajectory agrees with armlab's: max |q − q_armlab| {check_mujoco():.1e}")
    with tempfile.TemporaryDirectory() as folder, tempfile.TemporaryDirectory() as none:
        specs = [mujoco_spec(folder), mujoco_spec(folder, hold=True)] if available else []
        labels = ["MuJoCo: import, load the URDF, the same run",
                  "MuJoCo, torque held over each step (not the same run)"]
        settings = (("Python bytecode cached", environment(bytecode)),
                    ("no Python bytecode cache", environment(none, PYTHONDONTWRITEBYTECODE="1")))
        for title, env in settings:
            ours, floor, theirs, dynamics = fresh_processes(env, specs)
            print(f"  {title}:")
            rows = [(f"armlab run {SCENARIO} --format npz ({dynamics} kernels)", ours),
                    ("floor of any numba program (import numba, one cached call)", floor)]
            rows += [(f"{label} (its loop {json.loads(timed.stdout)['run']:.2f} s)", timed)
                     for label, timed in zip(labels, theirs, strict=False)]
            for label, timed in rows:
                print(f"    {label:72s} {timed.wall:6.2f} s {timed.cpu:6.2f} s CPU")
            if theirs:
                same, held = theirs
                wall, cpu = ours.wall / same.wall, ours.cpu / same.cpu
                print(f"    armlab / MuJoCo, same run: {wall:.2f}× wall, {cpu:.2f}× CPU (target ≤ 2×: "
                      f"{'met' if max(wall, cpu) <= 2 else 'NOT met'}); numba's floor alone "
                      f"{floor.wall / same.wall:.2f}× wall, {floor.cpu / same.cpu:.2f}× CPU; "
                      f"armlab / MuJoCo with held torque {ours.wall / held.wall:.2f}× wall, "
                      f"{ours.cpu / held.cpu:.2f}× CPU")


def import_case(bytecode):
    """(b): CPU of ``import armlab`` above ``import numba``."""
    env = environment(bytecode)
    touch_all = "import armlab\nfor name in armlab.__all__: getattr(armlab, name)"
    numba_cpu, armlab_cpu, whole = (best_of(IMPORT_BEST_OF, [sys.executable, "-c", code], env).cpu
                                    for code in ("import numba", "import armlab", touch_all))
    print(f"\n(b) Import CPU time, fresh process, Python bytecode cached (best of {IMPORT_BEST_OF}): "
          f"import numba {numba_cpu:.2f} s")
    above = armlab_cpu - numba_cpu
    print(f"  import armlab: {armlab_cpu:.2f} s, {above:+.2f} s above numba "
          f"(target ≤ 0.5 s: {'met' if above <= 0.5 else 'NOT met'})")
    print(f"  import armlab and touch every name of armlab.__all__: {whole:.2f} s, "
          f"{whole - numba_cpu:+.2f} s above numba")


def empty_caches_case(bytecode):
    """(c): first results with empty numba and armlab caches, one process each."""
    print(f"\n(c) Fresh process, empty caches (new NUMBA_CACHE_DIR and ARMLAB_CACHE_DIR; Python "
          f"bytecode cached), one process each, stopped after {TIMEOUT:.0f} s")
    print(f"  {'first result of':64s} {'wall':>16s} {'CPU':>9s}  target")
    cases = [(f"armlab run {SCENARIO} --format npz", None, 15.0),
             ("random 3-joint arm: armlab.simulate, 10 s at 1 kHz", 3, 15.0),
             ("random 7-joint arm: armlab.simulate, 10 s at 1 kHz", 7, 15.0)]
    for label, n, target in cases:
        with (tempfile.TemporaryDirectory() as numba_cache, tempfile.TemporaryDirectory() as armlab_cache,
              tempfile.TemporaryDirectory() as out):
            env = environment(bytecode, NUMBA_CACHE_DIR=numba_cache, ARMLAB_CACHE_DIR=armlab_cache)
            args = (armlab_run_args(out) if n is None
                    else [sys.executable, "-c", FIRST_SIMULATE, str(HERE), str(n)])
            timed = run_process(args, env)
        kind = "" if n is None or timed.timed_out else f" ({json.loads(timed.stdout)['dynamics']})"
        verdict = "met" if not timed.timed_out and timed.wall <= target else "NOT met"
        cpu = "" if timed.timed_out else f"{timed.cpu:.2f} s"
        print(f"  {label + kind:64s} {timed.text():>16s} {cpu:>9s}  ≤ {target:g} s wall: {verdict}")


def main():
    with tempfile.TemporaryDirectory() as bytecode:
        filled_caches_case(bytecode)
        import_case(bytecode)
        empty_caches_case(bytecode)


if __name__ == "__main__":
    main()
