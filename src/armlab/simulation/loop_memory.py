"""The simulation loop's memory: its scratch array and its flat log (``armlab.simulation.loop``).

The scratch memory is one flat array ``work`` (:func:`work_size`): the law's views first, in
the order of its arguments (``law_views`` of ``armlab.control.entry``, the law ABI), then the
loop's own (:func:`scratch_views`), the plant's data last (:func:`plant_data`).

The log is one flat array ``out`` of R rows: the logged quantities (:func:`log_columns`) lie
one after the other, each a C-ordered (R, width) block, so that Python takes every one as a
view (no copy, :func:`log_views`); the loop writes row j of every block at once
(:func:`log_row`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from armlab.control.entry import law_views
from armlab.kernels.boundary import buffer_view
from armlab.kernels.workspace import workspace_size


def work_size(n: int, k: int, s: int) -> int:
    """Length of the flat scratch array for n joints, k controller states, s signal columns;
    its last ``workspace_size(n)`` entries are the plant's data."""
    m = 2 * n + k
    # workspace_size's own Python body: the one formula of the plant's data, without a
    # dispatcher call.
    return 7 * n + 2 * k + s + 6 + 9 + 3 + 6 + 5 * m + 18 * n + workspace_size.py_func(n)


def zdot_slice(n: int, k: int) -> slice:
    """Where ż of the last stage lies in the scratch array (see :func:`law_views`)."""
    start = 3 * n + k + 6
    return slice(start, start + k)


def log_layout(widths, cmd: bool, dist: bool, h_e: bool) -> np.ndarray:
    """The int64 ``layout`` of :func:`log_row`: whether the commanded torque (saturation), the
    disturbance and the contact wrench are logged (each only when the run has one: else they
    are τ, 0 and 0, and a third of a joint-space log), then the signals' ``widths``."""
    return np.array([int(cmd), int(dist), int(h_e), *widths], dtype=np.int64)


def log_columns(n: int, k: int, layout) -> dict:
    """Column ranges of the logged quantities, in order: t, q, qd, qdd, tau, z, sig, tau_cmd,
    tau_dist, h_e (the last three of width 0 when ``layout`` says they are not logged).  In
    the flat log of R rows, quantity c is the (R, width) block starting at R · c.start
    (:func:`log_views`)."""
    cmd, dist, h_e = (int(flag) for flag in layout[:3])
    s = int(sum(layout[3:]))
    widths = (("t", 1), ("q", n), ("qd", n), ("qdd", n), ("tau", n), ("z", k), ("sig", s),
              ("tau_cmd", cmd * n), ("tau_dist", dist * n), ("h_e", h_e * 6))
    columns, start = {}, 0
    for name, width in widths:
        columns[name] = slice(start, start + width)
        start += width
    return columns


def log_views(out: np.ndarray, n: int, k: int, layout) -> dict:
    """The (R, width) views of every logged quantity in the flat log ``out`` (``layout`` of
    :func:`log_layout`); "sig" is the tuple of the signals' (R, w) views: the signal block
    holds one C-ordered block per signal (:func:`log_row`), so that every signal of a result
    is a view too."""
    columns = log_columns(n, k, layout)
    widths = [int(w) for w in layout[3:]]
    rows = out.shape[0] // columns["h_e"].stop
    views = {name: out[rows * c.start:rows * c.stop].reshape(rows, c.stop - c.start)
             for name, c in columns.items()}
    block, start, signals = views["sig"].reshape(-1), 0, []
    for width in widths:
        signals.append(block[rows * start:rows * (start + width)].reshape(rows, width))
        start += width
    views["sig"] = tuple(signals)
    return views


@njit(cache=True, inline="always")
def scratch_views(work, n, k, s):
    """The named scratch views of ``work`` (see :func:`work_size`): the law's first
    (:func:`law_views`), then the loop's own, the plant's data last (:func:`plant_data`)."""
    f = np.float64
    m = 2 * n + k
    q, qd, z, h_e, tau_c, zdot, sig = law_views(work, n, k, s)
    o = 3 * n + 2 * k + 6 + s
    tau_a = buffer_view(work, o, n, f)
    o += n
    tau_d = buffer_view(work, o, n, f)
    o += n
    tau_p = buffer_view(work, o, n, f)
    o += n
    R_0e = buffer_view(work, o, (3, 3), f)
    o += 9
    p_0e = buffer_view(work, o, 3, f)
    o += 3
    v_e = buffer_view(work, o, 6, f)
    o += 6
    qdd = buffer_view(work, o, n, f)
    o += n
    xt = buffer_view(work, o, m, f)
    o += m
    K = buffer_view(work, o, (4, m), f)
    o += 4 * m
    meas = buffer_view(work, o, 18 * n, f)
    return (q, qd, z, tau_c, tau_a, tau_d, tau_p, h_e, zdot, sig, R_0e, p_0e, v_e, qdd, xt, K, meas,
            plant_data(work, n))


@njit(cache=True, inline="always")
def plant_data(work, n):
    """The plant's data: the last ``workspace_size(n)`` entries of ``work``."""
    size = workspace_size(n)
    return buffer_view(work, work.shape[0] - size, size, np.float64)


@njit(cache=True, inline="always")
def log_offsets(n, k, s, out, layout):
    """Where the blocks of the flat log ``out`` begin (:func:`log_columns`), once per run:
    (R, w_cmd, w_dist, w_he, then the first index of q, q̇, q̈, τ, z, the signals, τ_cmd, τ_d
    and h_e)."""
    w_cmd, w_dist, w_he = layout[0] * n, layout[1] * n, layout[2] * 6
    R = out.shape[0] // (1 + 4 * n + k + s + w_cmd + w_dist + w_he)
    return (R, w_cmd, w_dist, w_he, R, R * (1 + n), R * (1 + 2 * n), R * (1 + 3 * n), R * (1 + 4 * n),
            R * (1 + 4 * n + k), R * (1 + 4 * n + k + s), R * (1 + 4 * n + k + s + w_cmd),
            R * (1 + 4 * n + k + s + w_cmd + w_dist))


@njit(cache=True, inline="always")
def log_row(row, t, x, n, sc, out, layout, at):
    """Row ``row`` of the flat log ``out`` (blocks of :func:`log_columns`, beginning at ``at``
    of :func:`log_offsets`) from x and stage k₁.

    ``layout`` = [cmd, dist, h_e, w_0, w_1, …] (:func:`log_layout`): whether τ_cmd, τ_d and h_e
    are logged, then the width of each signal; the signal block holds one (R, w_j) block per
    signal (:func:`log_views`)."""
    tau_c, tau_a, tau_d, h_e, sig, qdd = sc[3], sc[4], sc[5], sc[7], sc[9], sc[13]
    k = sc[2].shape[0]
    R, w_cmd, w_dist, w_he = at[0], at[1], at[2], at[3]
    out[row] = t
    q_at, qd_at, qdd_at, tau_at = at[4] + row * n, at[5] + row * n, at[6] + row * n, at[7] + row * n
    for i in range(n):
        out[q_at + i] = x[i]
        out[qd_at + i] = x[n + i]
        out[qdd_at + i] = qdd[i]
        out[tau_at + i] = tau_a[i]
    cmd_at, dist_at, he_at = at[10] + row * w_cmd, at[11] + row * w_dist, at[12] + row * w_he
    for i in range(w_cmd):
        out[cmd_at + i] = tau_c[i]
    for i in range(w_dist):
        out[dist_at + i] = tau_d[i]
    z_at = at[8] + row * k
    for i in range(k):
        out[z_at + i] = x[2 * n + i]
    start = 0
    for j in range(3, layout.shape[0]):
        width = layout[j]
        sig_at = at[9] + R * start + row * width
        for i in range(width):
            out[sig_at + i] = sig[start + i]
        start += width
    for i in range(w_he):
        out[he_at + i] = h_e[i]
