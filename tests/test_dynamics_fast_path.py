"""The public dynamics wrappers' fast path: input handling, fresh outputs, no dependence on
earlier calls, and the buffer views it is built on.

The reference results come from the published kernels called with the robot's own
``robot.arrays`` and a fresh workspace, or from NumPy (for the views), never from the
wrapper under test.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from numba import njit

import armlab
from armlab.dynamics import (
    coriolis_matrix,
    forward_dynamics,
    gravity_torque,
    inertia_matrix,
    inverse_dynamics,
)
from armlab.kernels.boundary import buffer_view
from armlab.kernels.dynamics import (
    coriolis_matrix_into,
    forward_dynamics_into,
    gravity_into,
    make_workspace,
    mass_matrix_into,
    rnea_into,
)


@pytest.fixture(scope="module")
def prp():
    return armlab.load_robot("prp_actuated")


def _state(n, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.3, 0.3, (3, n))


def _kernel_tau(robot, q, qd, qdd, h_e=None):
    tau = np.empty(robot.n)
    rnea_into(robot.arrays, make_workspace(robot.n), np.ascontiguousarray(q, dtype=float),
              np.ascontiguousarray(qd, dtype=float), np.ascontiguousarray(qdd, dtype=float), 1.0,
              np.zeros(6) if h_e is None else np.asarray(h_e, dtype=float), tau)
    return tau


def test_every_input_kind_gives_the_kernel_result(prp):
    q, qd, qdd = _state(prp.n, 1)
    expected = _kernel_tau(prp, q, qd, qdd)
    readonly = q.copy()
    readonly.flags.writeable = False
    strided = np.empty(2 * prp.n)
    strided[::2] = q
    kinds = {
        "contiguous": q,
        "list": q.tolist(),
        "tuple": tuple(q),
        "read-only": readonly,
        "strided": strided[::2],
    }
    for kind, value in kinds.items():
        np.testing.assert_allclose(inverse_dynamics(prp, value, qd, qdd), expected, rtol=1e-14,
                                   atol=1e-14, err_msg=kind)
    # Other dtypes are converted, not reinterpreted.
    single = q.astype(np.float32)
    np.testing.assert_allclose(inverse_dynamics(prp, single, qd, qdd),
                               _kernel_tau(prp, single.astype(float), qd, qdd), rtol=1e-14)
    as_int = np.array([0, 1, 0])
    np.testing.assert_allclose(inverse_dynamics(prp, as_int, qd, qdd),
                               _kernel_tau(prp, as_int.astype(float), qd, qdd), rtol=1e-14)


def _unaligned(values):
    """``values`` as float64 at an address that is not a multiple of 8."""
    raw = np.zeros(8 * len(values) + 1, dtype=np.uint8)
    view = raw[1:].view(np.float64)
    view[:] = values
    assert not view.flags.aligned
    return view


def _lookalikes(v):
    """Inputs equal to ``v`` that a call skipping numba's type check could misread: each must
    be converted, never reinterpreted."""
    strided = np.empty(2 * v.size)
    strided[::2] = v
    readonly = v.copy()
    readonly.flags.writeable = False
    return {
        "contiguous": v,
        "list": v.tolist(),
        "read-only": readonly,
        "strided": strided[::2],
        "reversed twice": v[::-1].copy()[::-1],
        "unaligned": _unaligned(v),
        "big-endian": v.astype(">f8"),
        "float32": v.astype(np.float32),
        "int64": np.round(v * 10).astype(np.int64),
        "uint64": np.round(np.abs(v) * 10).astype(np.uint64),
        "pandas Series": pd.Series(v),
        "ndarray subclass": v.view(_Tagged),
    }


class _Tagged(np.ndarray):
    """An honest ndarray subclass (astropy's Quantity and NumPy's memmap are such)."""


class _LyingRank(np.ndarray):
    """A subclass whose ndim property misreports its rank."""

    @property
    def ndim(self):
        return 1


class _LyingDtype(np.ndarray):
    """A subclass whose dtype property misreports its items."""

    @property
    def dtype(self):
        return np.dtype(np.float64)


def test_every_function_converts_lookalike_inputs(prp):
    """Every public function and route, each vector argument in turn replaced by a lookalike,
    against the kernels called with robot.arrays (the value converted by NumPy)."""
    n = prp.n
    q, qd, qdd = _state(n, 5)
    h_e = np.array([1.0, -2.0, 0.5, 0.1, 0.0, -0.3])
    ws, m = make_workspace(n), prp.arrays

    def kernel(name, a):
        a = [np.array(x, dtype=float) for x in a]
        if name == "tau":
            return _kernel_tau(prp, *a[:3])
        if name == "tau_h":
            return _kernel_tau(prp, *a)
        out = np.empty((n, n) if name in ("B", "C") else n)
        {"B": lambda: mass_matrix_into(m, ws, a[0], out),
         "g": lambda: gravity_into(m, ws, a[0], out),
         "C": lambda: coriolis_matrix_into(m, ws, a[0], a[1], out),
         "qdd": lambda: forward_dynamics_into(m, ws, a[0], a[1], a[2], np.zeros(6), out),
         "qdd_h": lambda: forward_dynamics_into(m, ws, *a, out)}[name]()
        return out

    calls = {
        "tau": (lambda a: inverse_dynamics(prp, *a), [q, qd, qdd]),
        "tau_h": (lambda a: inverse_dynamics(prp, *a), [q, qd, qdd, h_e]),
        "B": (lambda a: inertia_matrix(prp, *a), [q]),
        "g": (lambda a: gravity_torque(prp, *a), [q]),
        "C": (lambda a: coriolis_matrix(prp, *a), [q, qd]),
        "qdd": (lambda a: forward_dynamics(prp, *a), [q, qd, qdd]),
        "qdd_h": (lambda a: forward_dynamics(prp, *a), [q, qd, qdd, h_e]),
    }
    for name, (call, args) in calls.items():
        for position in range(len(args)):
            for kind, value in _lookalikes(args[position]).items():
                used = list(args)
                used[position] = value
                np.testing.assert_allclose(call(used), kernel(name, used), rtol=1e-13, atol=1e-13,
                                           err_msg=f"{name}, argument {position}: {kind}")


@pytest.mark.parametrize("shape", [(1, 3), (3, 1), (), (1, 1, 3)])
def test_arrays_of_another_rank_are_refused_by_name(prp, shape):
    """A float64 array of the right size but not 1-D never reaches the machine code (its
    unboxing would write a shape of another rank)."""
    bad = np.zeros(shape) if shape else np.float64(0.0)
    z = np.zeros(prp.n)
    for call, name in ((lambda: inertia_matrix(prp, bad), "q"), (lambda: gravity_torque(prp, bad), "q"),
                       (lambda: inverse_dynamics(prp, z, bad, z), "qd"),
                       (lambda: coriolis_matrix(prp, z, bad), "qd"),
                       (lambda: forward_dynamics(prp, z, z, bad), "tau"),
                       (lambda: inverse_dynamics(prp, z, z, z, h_e=np.zeros((1, 6))), "h_e"),
                       (lambda: inertia_matrix(prp, bad, dynamics="closed_form"), "q")):
        with pytest.raises(ValueError, match=name):
            call()


def test_outputs_are_fresh_and_calls_independent(prp):
    q, qd, qdd = _state(prp.n, 2)
    first = inverse_dynamics(prp, q, qd, qdd)
    kept = first.copy()
    # Interleave every function, another robot and a wrench; the first result must neither be
    # overwritten nor change when recomputed.
    other = armlab.load_robot("puma560")
    q6, qd6, qdd6 = _state(other.n, 3)
    inverse_dynamics(other, q6, qd6, qdd6, h_e=np.ones(6))
    inertia_matrix(prp, -q)
    coriolis_matrix(prp, qd, q)
    gravity_torque(prp, qdd)
    forward_dynamics(prp, q, -qd, np.ones(prp.n), h_e=np.arange(6.0))
    inverse_dynamics(prp, q, qd, qdd, h_e=np.arange(6.0), gravity=False)
    second = inverse_dynamics(prp, q, qd, qdd)
    np.testing.assert_array_equal(first, kept)
    np.testing.assert_array_equal(second, kept)
    assert second is not first and not np.shares_memory(first, second)
    B1, B2 = inertia_matrix(prp, q), inertia_matrix(prp, q)
    assert not np.shares_memory(B1, B2)


def test_wrench_and_gravity_switch_take_the_full_path(prp):
    q, qd, qdd = _state(prp.n, 4)
    h_e = np.array([1.0, -2.0, 0.5, 0.1, 0.0, -0.3])
    np.testing.assert_allclose(inverse_dynamics(prp, q, qd, qdd, h_e=list(h_e)),
                               _kernel_tau(prp, q, qd, qdd, h_e), rtol=1e-13, atol=1e-13)
    without = inverse_dynamics(prp, q, qd, qdd, gravity=False)
    np.testing.assert_allclose(inverse_dynamics(prp, q, qd, qdd) - without,
                               gravity_torque(prp, q), rtol=1e-12, atol=1e-12)
    # Both switches at once: the wrench's Jᵀ h_e stays, g(q) goes.
    np.testing.assert_allclose(inverse_dynamics(prp, q, qd, qdd, h_e=h_e, gravity=False),
                               _kernel_tau(prp, q, qd, qdd, h_e) - gravity_torque(prp, q),
                               rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("bad, name", [(np.zeros(2), "qdd"), (np.zeros(4), "qdd"),
                                       (np.zeros((3, 1)), "qdd"), ("abc", "qdd")])
def test_wrong_vectors_are_named(prp, bad, name):
    z = np.zeros(prp.n)
    with pytest.raises(ValueError, match=name):
        inverse_dynamics(prp, z, z, bad)
    with pytest.raises(ValueError, match="tau"):
        forward_dynamics(prp, z, z, bad)
    with pytest.raises(ValueError, match="h_e"):
        inverse_dynamics(prp, z, z, z, h_e=np.zeros(5))
    with pytest.raises(ValueError, match="q"):
        inertia_matrix(prp, bad)


@njit(cache=True)
def _views(buf, n):
    return buffer_view(buf, 2, (n, 3, 3), np.float64), buffer_view(buf, 1, n, np.float64), \
        buffer_view(buf, 0, (2, n), np.int64)


def test_buffer_view_is_the_reshaped_slice():
    buf = np.arange(40.0)
    cube, line, ints = _views(buf, 3)
    np.testing.assert_array_equal(cube, buf[2:29].reshape(3, 3, 3))
    np.testing.assert_array_equal(line, buf[1:4])
    np.testing.assert_array_equal(ints, buf[:6].view(np.int64).reshape(2, 3))
    cube[0, 1, 2] = -7.0
    assert buf[2 + 5] == -7.0


@njit(cache=True)
def _workspaces_in_compiled_code(m, q, count):
    total = 0.0
    tau = np.empty(q.shape[0])
    h_e = np.zeros(6)
    for _ in range(count):
        ws = make_workspace(q.shape[0])
        rnea_into(m, ws, q, q, q, 1.0, h_e, tau)
        total += tau[0]
    return total


def test_workspaces_made_in_compiled_code_after_public_calls(prp):
    # The public wrappers run views without reference counting; compiled code that makes and
    # drops workspaces must still count their references (a wrong count frees live memory).
    q = np.array([0.1, 0.2, 0.05])
    expected = _kernel_tau(prp, q, q, q)[0]
    inverse_dynamics(prp, q, q, q)
    assert _workspaces_in_compiled_code(prp.arrays, q, 2000) == pytest.approx(2000 * expected, rel=1e-12)
    ws = make_workspace(prp.n)
    del ws
    np.testing.assert_allclose(inverse_dynamics(prp, q, q, q)[0], expected, rtol=1e-14)


def test_generated_entries_convert_lookalike_inputs():
    """The generated module's entries are called the same way: a lookalike input gives the
    result of its float64 copy, bit for bit."""
    robot = armlab.load_robot("prp")
    q, qd, qdd = _state(robot.n, 6)
    cf = "closed_form"
    for kind, value in _lookalikes(q).items():
        clean = np.array(value, dtype=float)
        np.testing.assert_array_equal(inertia_matrix(robot, value, dynamics=cf),
                                      inertia_matrix(robot, clean, dynamics=cf), err_msg=kind)
        np.testing.assert_array_equal(inverse_dynamics(robot, value, qd, qdd, dynamics=cf),
                                      inverse_dynamics(robot, clean, qd, qdd, dynamics=cf), err_msg=kind)
        np.testing.assert_array_equal(inverse_dynamics(robot, qd, qdd, value, dynamics=cf),
                                      inverse_dynamics(robot, qd, qdd, clean, dynamics=cf), err_msg=kind)
        np.testing.assert_array_equal(forward_dynamics(robot, value, qd, qdd, dynamics=cf),
                                      forward_dynamics(robot, clean, qd, qdd, dynamics=cf), err_msg=kind)
        np.testing.assert_array_equal(forward_dynamics(robot, qd, qdd, value, dynamics=cf),
                                      forward_dynamics(robot, qd, qdd, clean, dynamics=cf), err_msg=kind)


def test_subclasses_that_misreport_their_memory_are_read_by_numpy(prp):
    """ndim and dtype of a subclass may be properties: the direct call must not trust them
    (unboxing a 3-D array as a vector would write past its own memory)."""
    z = np.zeros(prp.n)
    rank = np.zeros((3, 3, 3)).view(_LyingRank)
    with pytest.raises(ValueError, match="q must have shape"):
        inertia_matrix(prp, rank)
    with pytest.raises(ValueError, match="qd must have shape"):
        inverse_dynamics(prp, z, rank, z)
    ints = np.array([1, 2, 3], dtype=np.int64).view(_LyingDtype)
    np.testing.assert_array_equal(gravity_torque(prp, ints), gravity_torque(prp, np.array([1.0, 2.0, 3.0])))


def test_a_one_joint_robot_reads_a_single_item_at_any_stride():
    """NumPy calls a one-item view C-contiguous whatever its stride (a column of a trajectory)."""
    robot = armlab.load_robot("link1")
    column = np.linspace(0.0, 1.0, 5).reshape(1, 5)[:, 3]
    assert column.strides != (8,) and column.flags.c_contiguous
    clean = column.copy()
    z = np.zeros(1)
    np.testing.assert_array_equal(gravity_torque(robot, column), gravity_torque(robot, clean))
    np.testing.assert_array_equal(inertia_matrix(robot, column), inertia_matrix(robot, clean))
    np.testing.assert_array_equal(forward_dynamics(robot, column, z, z), forward_dynamics(robot, clean, z, z))
    np.testing.assert_array_equal(inverse_dynamics(robot, column, column, column),
                                  inverse_dynamics(robot, clean, clean, clean))
    np.testing.assert_array_equal(coriolis_matrix(robot, column, column),
                                  coriolis_matrix(robot, clean, clean))
    assert armlab.potential_energy(robot, column) == armlab.potential_energy(robot, clean)
    np.testing.assert_array_equal(inertia_matrix(robot, column, dynamics="closed_form"),
                                  inertia_matrix(robot, clean, dynamics="closed_form"))
