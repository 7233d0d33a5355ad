"""The public dynamics wrappers' fast path: input handling, fresh outputs, no dependence on
earlier calls, and the buffer views it is built on.

The reference results come from the published kernels called with the robot's own
``robot.arrays`` and a fresh workspace, or from NumPy (for the views), never from the
wrapper under test.
"""

from __future__ import annotations

import numpy as np
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
from armlab.kernels.dynamics import make_workspace, rnea_into
from armlab.kernels.packed import buffer_view


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
