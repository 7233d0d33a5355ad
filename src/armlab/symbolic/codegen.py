"""Code generation: closed-form B, C, g, FK and J compiled with numba, drop-in for the kernels.

The expressions are turned into Python by SymPy's own printer (``sympy.lambdify`` with
common-subexpression elimination, ``cse=True``) and compiled by ``numba.njit``; nothing is
assembled from strings here.  Each generated kernel has the signature of its numeric twin in
``armlab.kernels.dynamics`` / ``armlab.kernels.kinematics`` and writes into the caller's
output.  The robot's numbers are inside the formulas, so ``m`` is accepted and unused; ``ws``
(a ``DynamicsWorkspace``) lends ``L``, ``t2`` and ``Ic`` as scratch to ``rnea_into`` and
``forward_dynamics_into``.  The generated functions are compiled per process (they have no
source file for numba's cache):

    mass_matrix_into(m, ws, q, B_out)                 B(q), (n, n)
    coriolis_matrix_into(m, ws, q, qd, C_out)         C(q, q̇), (n, n), Christoffel (D4)
    gravity_into(m, ws, q, g_out)                     g(q), (n,)
    rnea_into(m, ws, q, qd, qdd, gravity_scale, h_e, tau_out)   τ of (D1)
    forward_dynamics_into(m, ws, q, qd, tau, h_e, qdd_out)      q̈ of (D1), Cholesky (D5)
    forward_kinematics_kernel(m, q, T_out)            T_0e, (4, 4)
    jacobian_kernel(m, q, J_out)                      geometric J in Σ_0, (6, n)

so a robot can be simulated through its closed form, and the numeric kernels can be checked
against an independent derivation.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
import sympy as sp

from armlab.kernels.linalg import cholesky_solve_inplace
from armlab.model.robot import Robot
from armlab.symbolic.energy import inertia_matrix
from armlab.symbolic.kinematics import end_effector_pose, geometric_jacobian
from armlab.symbolic.lagrange import coriolis_matrix, gravity_vector
from armlab.symbolic.model import SymbolicRobot, symbolic_robot


def _entries(M: sp.Matrix):
    """(rows, cols, exprs) of the structurally non-zero entries, each a float expression."""
    rows, cols, exprs = [], [], []
    for r in range(M.rows):
        for c in range(M.cols):
            e = M[r, c]
            if e != 0:
                rows.append(r)
                cols.append(c)
                exprs.append(sp.Float(e) if e.is_Number else e)
    return np.array(rows, dtype=np.int64), np.array(cols, dtype=np.int64), exprs


def compile_matrix(M: sp.Matrix, arguments: list[list[sp.Symbol]]):
    """A compiled ``write(*vectors, out)`` filling ``out`` (shape of M) with M's entries.

    ``arguments`` lists the symbol vectors in call order (e.g. ``[q]`` or ``[q, qd]``).
    Free symbols of M outside ``arguments`` are an error (substitute the numbers first).
    """
    M = sp.Matrix(M)
    known = {s for vector in arguments for s in vector}
    unknown = M.free_symbols - known
    if unknown:
        raise ValueError(f"expression has symbols without values: {sorted(map(str, unknown))}")
    rows, cols, exprs = _entries(M)
    count = len(exprs)
    if count == 0:
        if len(arguments) == 1:
            @numba.njit
            def write_zero1(a, out):
                out[:] = 0.0
            return write_zero1

        @numba.njit
        def write_zero2(a, b, out):
            out[:] = 0.0
        return write_zero2
    evaluate = numba.njit(sp.lambdify([list(v) for v in arguments], tuple(exprs),
                                      modules="math", cse=True, docstring_limit=0))
    if len(arguments) == 1:
        @numba.njit
        def write1(a, out):
            out[:] = 0.0
            values = evaluate(a)
            for k in range(count):
                out[rows[k], cols[k]] = values[k]
        return write1

    @numba.njit
    def write2(a, b, out):
        out[:] = 0.0
        values = evaluate(a, b)
        for k in range(count):
            out[rows[k], cols[k]] = values[k]
    return write2


class ClosedFormKernels(NamedTuple):
    """Compiled closed-form kernels of one robot (signatures: module docstring) and the
    symbolic robot they came from."""

    mass_matrix_into: object
    coriolis_matrix_into: object
    gravity_into: object
    rnea_into: object
    forward_dynamics_into: object
    forward_kinematics_kernel: object
    jacobian_kernel: object
    symbolic: SymbolicRobot


def closed_form_kernels(robot: Robot | SymbolicRobot, *, B=None, C=None, g=None) -> ClosedFormKernels:
    """Compile the closed-form model of ``robot`` (numbers substituted for its parameters).

    B, C, g default to the Lagrange derivation of A2–A3; pass other forms (e.g. the compact
    Newton–Euler ones of :func:`armlab.symbolic.compact.compact_dynamics`) for large robots.
    """
    given = any(M is not None for M in (B, C, g))
    if isinstance(robot, SymbolicRobot):
        sr = robot
    else:
        # Given forms carry the robot file's symbols, whose values the symbolic twin knows.
        sr = symbolic_robot(robot, numeric=not given)
    values = sr.numeric_substitution()
    q, qd = list(sr.q), list(sr.qd)
    n = sr.n

    def numeric(M):
        return sp.Matrix(M).xreplace(values)

    B = numeric(inertia_matrix(sr) if B is None else B)
    C = numeric(coriolis_matrix(sr) if C is None else C)
    g = numeric(gravity_vector(sr) if g is None else g)
    write_B = compile_matrix(B, [q])
    write_C = compile_matrix(C, [q, qd])
    write_g = compile_matrix(g.reshape(n, 1), [q])
    write_T = compile_matrix(numeric(end_effector_pose(sr)), [q])
    write_J = compile_matrix(numeric(geometric_jacobian(sr)), [q])
    viscous = np.array([float(j.viscous.xreplace(values)) for j in sr.joints])
    coulomb = np.array([float(j.coulomb.xreplace(values)) for j in sr.joints])

    @numba.njit
    def mass_matrix_into(m, ws, q, B_out):
        write_B(q, B_out)

    @numba.njit
    def coriolis_matrix_into(m, ws, q, qd, C_out):
        write_C(q, qd, C_out)

    @numba.njit
    def gravity_into(m, ws, q, g_out):
        write_g(q, g_out.reshape((g_out.shape[0], 1)))

    @numba.njit
    def forward_kinematics_kernel(m, q, T_out):
        write_T(q, T_out)

    @numba.njit
    def jacobian_kernel(m, q, J_out):
        write_J(q, J_out)

    @numba.njit
    def _bias(ws, q, qd, h_e, out):
        """C q̇ + F_v q̇ + F_s sgn q̇ + g + Jᵀ h_e into ``out``; uses ws.L and ws.t1."""
        write_C(q, qd, ws.L)
        write_g(q, out.reshape((n, 1)))
        for i in range(n):
            acc = 0.0
            for k in range(n):
                acc += ws.L[i, k] * qd[k]
            v = qd[i]
            acc += viscous[i] * v
            if v > 0.0:
                acc += coulomb[i]
            elif v < 0.0:
                acc -= coulomb[i]
            out[i] += acc

    @numba.njit
    def _add_wrench(ws, q, h_e, out):
        nonzero = False
        for k in range(6):
            if h_e[k] != 0.0:
                nonzero = True
        if nonzero:
            J = ws.Ic.reshape(-1)[: 6 * n].reshape((6, n))
            write_J(q, J)
            for i in range(n):
                acc = 0.0
                for k in range(6):
                    acc += J[k, i] * h_e[k]
                out[i] += acc

    @numba.njit
    def rnea_into(m, ws, q, qd, qdd, gravity_scale, h_e, tau_out):
        write_g(q, ws.t2.reshape((n, 1)))
        _bias(ws, q, qd, h_e, tau_out)
        _add_wrench(ws, q, h_e, tau_out)
        write_B(q, ws.L)
        for i in range(n):
            acc = 0.0
            for k in range(n):
                acc += ws.L[i, k] * qdd[k]
            tau_out[i] += acc - (1.0 - gravity_scale) * ws.t2[i]

    @numba.njit
    def forward_dynamics_into(m, ws, q, qd, tau, h_e, qdd_out):
        _bias(ws, q, qd, h_e, qdd_out)
        _add_wrench(ws, q, h_e, qdd_out)
        for k in range(n):
            qdd_out[k] = tau[k] - qdd_out[k]
        write_B(q, ws.L)
        return cholesky_solve_inplace(ws.L, qdd_out)

    return ClosedFormKernels(mass_matrix_into, coriolis_matrix_into, gravity_into, rnea_into,
                             forward_dynamics_into, forward_kinematics_kernel, jacobian_kernel, sr)


def closed_form_torque(robot: Robot | SymbolicRobot):
    """A compiled ``tau_into(q, qd, qdd, tau_out)`` of the inverse dynamics in one formula:

        τ = B(q) q̈ + C(q, q̇) q̇ + g(q) + F_v q̇ + F_s sgn q̇                     (D1, h_e = 0)

    B q̈ + C q̇ + g is one SymPy vector, lambdified with common subexpressions, so the compiled
    code is the scalar arithmetic a person would write by hand (no matrices are filled).
    It allocates nothing and can be called from other compiled loops.  q, qd, qdd, tau_out (n,)
    [m | rad, /s, /s², N | N·m].
    """
    sr = robot if isinstance(robot, SymbolicRobot) else symbolic_robot(robot, numeric=True)
    values = sr.numeric_substitution()
    q, qd = list(sr.q), list(sr.qd)
    qdd = list(sp.symbols(f"qdd0:{sr.n}", real=True))
    B, C, g = (sp.Matrix(M).xreplace(values)
               for M in (inertia_matrix(sr), coriolis_matrix(sr), gravity_vector(sr)))
    tau = B * sp.Matrix(qdd) + C * sp.Matrix(qd) + g.reshape(sr.n, 1)
    exprs = tuple(sp.Float(e) if e.is_Number else e for e in tau)
    evaluate = numba.njit(
        sp.lambdify([q, qd, qdd], exprs, modules="math", cse=True, docstring_limit=0))
    viscous = np.array([float(j.viscous.xreplace(values)) for j in sr.joints])
    coulomb = np.array([float(j.coulomb.xreplace(values)) for j in sr.joints])
    n = sr.n

    @numba.njit
    def tau_into(q, qd, qdd, tau_out):
        rigid = evaluate(q, qd, qdd)
        for i in range(n):
            v = qd[i]
            friction = viscous[i] * v
            if v > 0.0:
                friction += coulomb[i]
            elif v < 0.0:
                friction -= coulomb[i]
            tau_out[i] = rigid[i] + friction

    return tau_into
