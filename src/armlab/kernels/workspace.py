"""The scratch workspace of the dynamics kernels (``armlab.kernels.dynamics``).

One float64 buffer holds every scratch array, so a caller allocates once (or lends a slice of
its own buffer, as the simulation loop does: a robot's data, ``armlab.kernels.plant``) and the kernels never
allocate.  Every kernel writes the scratch it reads first, so a workspace can serve any
sequence of calls; two threads must not share one.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from armlab.kernels.boundary import borrowed, buffer_view


class DynamicsWorkspace(NamedTuple):
    """Scratch arrays of the dynamics kernels for an n-joint robot (all float64).

    ``R`` (n, 3, 3), ``p`` (n, 3): J_i in J_{i−1} at the current q.  ``w``, ``wd``, ``a``,
    ``f``, ``mu`` (n, 3): angular velocity, angular acceleration, origin acceleration, force
    and moment of link i, in J_i.  ``Ic`` (n, 3, 3), ``hc`` (n, 3), ``mc`` (n,): composite
    inertia about J_i's origin, first moment, mass.  ``L`` (n, n): Cholesky factor.
    ``v1``, ``v2``, ``t1``, ``t2``, ``zero`` (n,): vectors (``zero`` stays 0).
    ``R0`` (3, 3): rotation of the last joint frame in Σ_0.
    ``no_wrench`` (6,): stays 0, the h_e of an RNEA without a wrench.
    """

    R: np.ndarray
    p: np.ndarray
    w: np.ndarray
    wd: np.ndarray
    a: np.ndarray
    f: np.ndarray
    mu: np.ndarray
    Ic: np.ndarray
    hc: np.ndarray
    mc: np.ndarray
    L: np.ndarray
    v1: np.ndarray
    v2: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    zero: np.ndarray
    R0: np.ndarray
    no_wrench: np.ndarray


@njit(cache=True)
def workspace_size(n):
    """Number of float64 entries of a workspace for n joints (see :func:`workspace_from_buffer`)."""
    return 45 * n + n * n + 15


# Inlined into its caller so that the views are reference-counted as the caller is: a
# separately compiled helper inherits the reference-counting flag of whichever caller compiles
# it first (numba's flag inheritance), and the one machine-code version would then be wrong for
# the other kind of caller (missing increfs: freed memory; extra increfs: leaks).
@njit(cache=True, inline="always")
def workspace_from_buffer(buf, n):
    """A :class:`DynamicsWorkspace` whose arrays are views into ``buf`` (workspace_size(n),);
    one allocation serves every scratch array.  ``buf`` must be zero where ``zero`` and
    ``no_wrench`` lie."""
    d = np.float64
    o = 0
    R = buffer_view(buf, o, (n, 3, 3), d)
    o += 9 * n
    p = buffer_view(buf, o, (n, 3), d)
    o += 3 * n
    w = buffer_view(buf, o, (n, 3), d)
    o += 3 * n
    wd = buffer_view(buf, o, (n, 3), d)
    o += 3 * n
    a = buffer_view(buf, o, (n, 3), d)
    o += 3 * n
    f = buffer_view(buf, o, (n, 3), d)
    o += 3 * n
    mu = buffer_view(buf, o, (n, 3), d)
    o += 3 * n
    Ic = buffer_view(buf, o, (n, 3, 3), d)
    o += 9 * n
    hc = buffer_view(buf, o, (n, 3), d)
    o += 3 * n
    mc = buffer_view(buf, o, n, d)
    o += n
    L = buffer_view(buf, o, (n, n), d)
    o += n * n
    v1 = buffer_view(buf, o, n, d)
    o += n
    v2 = buffer_view(buf, o, n, d)
    o += n
    t1 = buffer_view(buf, o, n, d)
    o += n
    t2 = buffer_view(buf, o, n, d)
    o += n
    zero = buffer_view(buf, o, n, d)
    o += n
    R0 = buffer_view(buf, o, (3, 3), d)
    o += 9
    no_wrench = buffer_view(buf, o, 6, d)
    return DynamicsWorkspace(R, p, w, wd, a, f, mu, Ic, hc, mc, L, v1, v2, t1, t2, zero, R0, no_wrench)


@njit(cache=True, inline="always")
def rest_of(buf, n):
    """``(zero, t1, no_wrench)`` of ``workspace_from_buffer(buf, n)`` alone, borrowed: the zero
    vector, a scratch vector the RNEA leaves alone and the zero wrench, for a caller that needs
    no other view of the workspace (its tail: t1, t2, zero, R0, no_wrench).  The ~18 views of
    the whole workspace cost compile time: the RNEA's wrapper a computed-torque law calls
    compiled in 1.0 s with them, 0.4 s without."""
    buf = borrowed(buf)
    size = workspace_size(n)
    zero = size - 15 - n
    return (buffer_view(buf, zero, n, np.float64), buffer_view(buf, zero - 2 * n, n, np.float64),
            buffer_view(buf, size - 6, 6, np.float64))


@njit(cache=True, inline="always")
def no_wrench_of(buf, n):
    """``workspace_from_buffer(buf, n).no_wrench`` alone, borrowed (:func:`rest_of`)."""
    return rest_of(buf, n)[2]


@njit(cache=True)
def make_workspace(n):
    """A :class:`DynamicsWorkspace` for an n-joint robot (one zeroed buffer)."""
    return workspace_from_buffer(np.zeros(workspace_size(n)), n)
