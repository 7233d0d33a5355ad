"""Compile ahead the kernels every simulation shares: ``armlab warmup``, and the report's two halves.

numba compiles each kernel once per machine and keeps it in its disk cache; a process that
needs a kernel another process has already written loads it in milliseconds.  A cold machine
therefore pays the compile once, on its first simulation.  ``armlab warmup`` (:func:`warmup`)
pays it ahead, explicitly, so that the first result a user asks for comes from the cache.

Two processes that start simulations at the same time, however, both compile the kernels they
share (the RNEA alone takes seconds): half the first minute of a report on two cores went into
compiling the same code twice.  The two halves below are disjoint and of similar size, so the
report's two workers build them side by side and every later simulation loads them:

* :func:`dynamics_kernels` — the numeric dynamics (RNEA, CRBA, g, bias, the packed plant and
  the public functions) and the closed forms of the given robots (derived, compiled, checked);
* :func:`loop_and_task_kernels` — the simulation loop (``armlab.simulation.loop``), the
  plant's kinematics, joint references, and the task-space kernels of the operational-space
  and interaction controllers.

Each half calls the kernels with arguments of the types the controllers pass them (a robot's
``RobotArrays`` and workspaces, C-contiguous float64 arrays, int64 codes), so the compiled
versions are the ones the laws link.  Results of these calls are discarded.  A kernel missed
here is not an error: it compiles on first use, as it always would.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from armlab.control.task_space import log_pose_signals
from armlab.kernels.task_space import log_task_signals
from armlab.model.robot import Robot

_VEC = types.float64[::1]


def dynamics_kernels(robots: list[Robot], closed_forms: bool = True) -> None:
    """Compile the dynamics kernels and (with ``closed_forms``) the closed forms of ``robots``
    (see the module)."""
    from armlab import dynamics
    from armlab.kernels import dynamics as kernels
    from armlab.kernels.boundary import kernel_address
    from armlab.kernels.plant import forward_dynamics_packed, kinetic_energy_packed
    from armlab.specialise import ClosedFormUnavailable, closed_form_module

    for robot in robots if closed_forms else ():
        try:
            closed_form_module(robot)  # derivation, compile and check against the RNEA
        except ClosedFormUnavailable:
            pass  # the simulation falls back to the numeric kernels compiled below
    robot = robots[0]
    n = robot.n
    m, ws = robot.arrays, kernels.make_workspace(n)
    q, qd, out, h_e = np.full(n, 0.1), np.full(n, 0.2), np.zeros(n), np.zeros(6)
    dynamics.inverse_dynamics(robot, q, qd, q)
    dynamics.inverse_dynamics(robot, q, qd, q, h_e=np.ones(6))
    kernels.gravity_into(m, ws, q, out)
    kernels.bias_into(m, ws, q, qd, h_e, out)
    kernels.mass_matrix_into(m, ws, q, np.zeros((n, n)))
    kernel_address(forward_dynamics_packed, (_VEC,) * 7, types.int64)
    kernel_address(kinetic_energy_packed, (_VEC,) * 4, types.float64)


def loop_and_task_kernels(robot: Robot) -> None:
    """Compile the simulation loop, kinematics, references and task-space kernels."""
    from armlab.kernels import task_space as task
    from armlab.kernels.linalg import task_solve_into
    from armlab.references.joint import Constant, reference_into
    from armlab.references.task import PoseReference, pose_reference_into
    from armlab.simulation.loop import compile_shared

    compile_shared()
    n = robot.n
    q, qd = np.full(n, 0.1), np.full(n, 0.2)
    # Controllers pass copies of a reference's (read-only) data: writeable arrays.
    reference_into(np.array(Constant(q).data), 0.0, np.zeros(n), np.zeros(n), np.zeros(n))
    k = min(3, n)
    ws = task.task_workspace(n, k)
    rows = np.arange(k, dtype=np.int64)
    pose_reference_into(np.array(PoseReference.constant(np.zeros(3), np.eye(3)).data), 0.0, ws.frame)
    task.measure_into(robot.arrays, q, qd, ws)
    angles = np.zeros(3)
    for mode in (task.RELATIVE, task.ABSOLUTE):
        task.task_error_into(mode, ws.frame, 0, angles, qd, ws)
        phi = ws.x_e[3:] if mode == task.RELATIVE else ws.angles
        task.wrench_in_task_into(mode, 0, ws.frame, phi, np.zeros(6), ws.mat[0], ws.T, ws.w6, ws.h_task)
    task.position_error_into(ws.frame, qd, ws)
    task.select_rows_into(rows, ws.JA, ws.A)
    task_solve_into(ws.A, ws.rhs, 0.1, ws.G, ws.y)
    _log_task_signals(ws, rows, np.zeros(64 + 2 * n))


@njit(cache=True)
def _log_task_signals(ws, rows, signals):
    """The task-space laws' logging call, compiled: there the start index that
    ``log_pose_signals`` returns is typed as a literal, so a call from Python (an int64)
    compiles another version of ``log_task_signals`` than the one the laws link."""
    log_task_signals(ws, rows, signals, log_pose_signals(ws, signals))


def warmup(robot: Robot) -> None:
    """Compile (or load from numba's cache) both halves for ``robot``, one after the other:
    what ``armlab warmup`` does.  Closed forms are left out: they are opt-in
    (``dynamics="closed_form"``), and a symbolic derivation is not bounded for every arm."""
    dynamics_kernels([robot], closed_forms=False)
    loop_and_task_kernels(robot)
