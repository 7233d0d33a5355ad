"""Small allocation-free dense linear algebra for compiled code: 3-vector products and the
k × n task systems of the operational-space laws (exact inverse or damped least squares,
singular values).  Every function writes only its stated outputs and scratch.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# The dynamics kernels' one fast-math liberty (FMA contraction, docs/notation.md): the Cholesky
# solve of their forward dynamics is compiled as it was beside them.
_CONTRACT = njit(cache=True, fastmath={"contract"})

# A pivot below this makes a square task system singular (task_solve_into returns False).
SINGULAR_PIVOT = 1e-12


@njit(cache=True)
def cross_into(a, b, out):
    """out (3,) ← a × b (a, b may alias out)."""
    x = a[1] * b[2] - a[2] * b[1]
    y = a[2] * b[0] - a[0] * b[2]
    z = a[0] * b[1] - a[1] * b[0]
    out[0], out[1], out[2] = x, y, z


@njit(cache=True)
def matvec3(A, v, out):
    """out (3,) ← A v for A (3, 3) (v may alias out)."""
    x = A[0, 0] * v[0] + A[0, 1] * v[1] + A[0, 2] * v[2]
    y = A[1, 0] * v[0] + A[1, 1] * v[1] + A[1, 2] * v[2]
    z = A[2, 0] * v[0] + A[2, 1] * v[1] + A[2, 2] * v[2]
    out[0], out[1], out[2] = x, y, z


@njit(cache=True)
def matTvec3(A, v, out):
    """out (3,) ← Aᵀ v for A (3, 3) (v may alias out)."""
    x = A[0, 0] * v[0] + A[1, 0] * v[1] + A[2, 0] * v[2]
    y = A[0, 1] * v[0] + A[1, 1] * v[1] + A[2, 1] * v[2]
    z = A[0, 2] * v[0] + A[1, 2] * v[1] + A[2, 2] * v[2]
    out[0], out[1], out[2] = x, y, z


@njit(cache=True)
def solve_square_inplace(A, b):
    """b ← A⁻¹ b by Gaussian elimination with partial pivoting; A (k, k) is overwritten.

    Returns the smallest absolute pivot (0 means singular; b is then left unsolved)."""
    k = b.shape[0]
    smallest = np.inf
    for col in range(k):
        pivot = col
        for r in range(col + 1, k):
            if abs(A[r, col]) > abs(A[pivot, col]):
                pivot = r
        if abs(A[pivot, col]) < smallest:
            smallest = abs(A[pivot, col])
        if A[pivot, col] == 0.0:
            return 0.0
        if pivot != col:
            for c in range(k):
                A[col, c], A[pivot, c] = A[pivot, c], A[col, c]
            b[col], b[pivot] = b[pivot], b[col]
        for r in range(col + 1, k):
            factor = A[r, col] / A[col, col]
            for c in range(col, k):
                A[r, c] -= factor * A[col, c]
            b[r] -= factor * b[col]
    for r in range(k - 1, -1, -1):
        acc = b[r]
        for c in range(r + 1, k):
            acc -= A[r, c] * b[c]
        b[r] = acc / A[r, r]
    return smallest


@_CONTRACT
def cholesky_solve_inplace(A, b):
    """b ← A⁻¹ b for symmetric positive-definite A (n, n), overwriting A's lower triangle with
    its Cholesky factor L (A = L Lᵀ).  Returns False if A is not positive definite."""
    n = b.shape[0]
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= A[j, k] * A[j, k]
        if d <= 0.0:
            return False
        d = np.sqrt(d)
        A[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= A[i, k] * A[j, k]
            A[i, j] = s / d
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= A[i, k] * b[k]
        b[i] = s / A[i, i]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, n):
            s -= A[k, i] * b[k]
        b[i] = s / A[i, i]
    return True


@njit(cache=True)
def task_solve_into(A, rhs, damping, G, y_out):
    """y with A y = rhs for the (k, n) task matrix A (T5).

        damping = 0 and k = n:  y = A⁻¹ rhs                       (exact inverse)
        otherwise:              y = (AᵀA + λ² I)⁻¹ Aᵀ rhs,  λ = damping   (damped least squares)

    ``G`` (n, n) scratch.  Returns False if the system is singular (y_out is then zero).
    """
    k, n = A.shape
    if damping == 0.0 and k == n:
        for r in range(k):
            y_out[r] = rhs[r]
            for c in range(n):
                G[r, c] = A[r, c]
        if solve_square_inplace(G, y_out) < SINGULAR_PIVOT:
            for r in range(n):
                y_out[r] = 0.0
            return False
        return True
    for r in range(n):
        acc = 0.0
        for i in range(k):
            acc += A[i, r] * rhs[i]
        y_out[r] = acc
        for c in range(n):
            acc = 0.0
            for i in range(k):
                acc += A[i, r] * A[i, c]
            G[r, c] = acc
        G[r, r] += damping * damping
    if not cholesky_solve_inplace(G, y_out):
        for r in range(n):
            y_out[r] = 0.0
        return False
    return True


@njit(cache=True)
def singular_values_into(A, G, sv_out):
    """Singular values of A (k, n), descending, into sv_out (n,); G (n, n) scratch.

    Cyclic Jacobi rotations on G = AᵀA (symmetric), σ_i = √λ_i(G).
    """
    k, n = A.shape
    for r in range(n):
        for c in range(n):
            acc = 0.0
            for i in range(k):
                acc += A[i, r] * A[i, c]
            G[r, c] = acc
    for _sweep in range(50):
        off = 0.0
        for r in range(n):
            for c in range(r + 1, n):
                off += G[r, c] * G[r, c]
        if off < 1e-30:
            break
        for p in range(n):
            for q in range(p + 1, n):
                if G[p, q] == 0.0:
                    continue
                theta = (G[q, q] - G[p, p]) / (2.0 * G[p, q])
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + np.sqrt(theta * theta + 1.0))
                cs = 1.0 / np.sqrt(t * t + 1.0)
                sn = t * cs
                for r in range(n):
                    grp, grq = G[r, p], G[r, q]
                    G[r, p] = cs * grp - sn * grq
                    G[r, q] = sn * grp + cs * grq
                for c in range(n):
                    gpc, gqc = G[p, c], G[q, c]
                    G[p, c] = cs * gpc - sn * gqc
                    G[q, c] = sn * gpc + cs * gqc
    for i in range(n):
        sv_out[i] = np.sqrt(max(G[i, i], 0.0))
    for i in range(n):
        for j in range(i + 1, n):
            if sv_out[j] > sv_out[i]:
                sv_out[i], sv_out[j] = sv_out[j], sv_out[i]


@njit(cache=True)
def det3(A):
    """Determinant of the top-left (3, 3) block of A."""
    return (A[0, 0] * (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
            - A[0, 1] * (A[1, 0] * A[2, 2] - A[1, 2] * A[2, 0])
            + A[0, 2] * (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]))
