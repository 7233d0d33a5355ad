"""Indirect calls of compiled kernels (armlab.kernels.boundary) and the loop's scratch layout."""

import sys

import numpy as np
import pytest
from numba import cfunc, njit, typeof, types

import armlab
from armlab.control import entry
from armlab.kernels.boundary import (
    NativeFunction,
    borrowed,
    call_float,
    call_int,
    call_none,
    kernel_address,
    stack_address,
    with_functions,
)
from armlab.kernels.plant import forward_dynamics_packed, kinetic_energy_packed, make_data
from armlab.kernels.workspace import no_wrench_of, rest_of, workspace_from_buffer
from armlab.simulation import loop, loop_memory

VEC = types.float64[::1]


@njit(cache=False)
def _energy_through(address, model, data, q, qd):
    return call_float(address, (model, data, q, qd))


@njit(cache=False)
def _forward_through(address, model, data, q, qd, tau, h_e, out):
    return call_int(address, (model, data, q, qd, tau, h_e, out))


def test_indirect_calls_return_what_direct_calls_return():
    robot = armlab.load_robot("puma560")
    rng = np.random.default_rng(3)
    q, qd, tau = rng.normal(size=(3, robot.n))
    h_e = rng.normal(size=6)
    model, data = robot.packed, make_data(robot.n)
    energy = _energy_through(kernel_address(kinetic_energy_packed, (VEC,) * 4, types.float64), model, data,
                             q, qd)
    assert energy == armlab.kinetic_energy(robot, q, qd)
    out = np.zeros(robot.n)
    forward = kernel_address(forward_dynamics_packed, (VEC,) * 7, types.int64)
    status = _forward_through(forward, model, data, q, qd, tau, h_e, out)
    assert status == 0
    np.testing.assert_array_equal(out, armlab.forward_dynamics(robot, q, qd, tau, h_e=h_e))
    # A wrong length comes back as the kernel's status, memory untouched.
    assert _forward_through(forward, model, data, q[:2], qd, tau, h_e, out) == 1


@njit(cache=False)
def _divide(a, b, out):
    out[0] = a[0] // b[0]


@njit(cache=False)
def _divide_through(address, a, b, out):
    call_none(address, (a, b, out))
    return out[0]


def test_an_exception_in_the_callee_reaches_the_caller():
    vec_i = types.int64[::1]
    address = kernel_address(_divide, (vec_i, vec_i, vec_i), types.none)
    out = np.zeros(1, dtype=np.int64)
    assert _divide_through(address, np.array([7]), np.array([2]), out) == 3
    with pytest.raises(ZeroDivisionError):
        _divide_through(address, np.array([7]), np.array([0]), out)


@njit(cache=False)
def _read_back(pointer):
    values, scale = pointer[0]
    return values[1] * scale


@njit(cache=False)
def _through_the_stack(address, params):
    return call_float(address, (stack_address(params),))


def test_a_parameter_tuple_crosses_as_a_stack_address():
    params = (np.array([1.0, 2.5, 4.0]), 3.0)
    address = kernel_address(_read_back, (types.CPointer(typeof(params)),), types.float64)
    assert _through_the_stack(address, params) == 7.5


@njit(cache=False)
def _scratch_extent(work, n, k, s):
    views = loop_memory.scratch_views(work, n, k, s)
    loops_last, plant, zdot = views[-2], views[-1], views[8]
    start = (plant.ctypes.data - work.ctypes.data) // 8
    return ((loops_last.ctypes.data - work.ctypes.data) // 8 + loops_last.size, start,
            start + plant.size, (zdot.ctypes.data - work.ctypes.data) // 8)


@pytest.mark.parametrize("n, k, s", [(1, 0, 0), (3, 12, 7), (6, 2, 30)])
def test_the_scratch_views_fill_the_scratch_array_exactly(n, k, s):
    work = np.zeros(loop_memory.work_size(n, k, s))
    loops_end, plant_start, end, zdot_start = _scratch_extent(work, n, k, s)
    assert loops_end == plant_start                      # the plant's data follows, no overlap
    assert end == work.size
    assert zdot_start == loop_memory.zdot_slice(n, k).start   # where the adaptive path reads ż


@pytest.mark.parametrize("flags, extra", [((1, 1, 1), [3, 3, 6]), ((0, 0, 0), [0, 0, 0]),
                                          ((1, 0, 1), [3, 0, 6])])
def test_the_log_columns_cover_what_a_row_writes(flags, extra):
    columns = loop_memory.log_columns(3, 2, loop_memory.log_layout([2, 3], *flags))
    widths = [c.stop - c.start for c in columns.values()]
    assert widths == [1, 3, 3, 3, 3, 2, 5] + extra
    assert list(columns.values())[0].start == 0
    assert all(a.stop == b.start for a, b in zip(list(columns.values()), list(columns.values())[1:]))


def test_a_law_that_is_not_compiled_runs_in_python_and_a_non_function_is_refused_by_name():
    from dataclasses import dataclass

    from armlab.control.base import Controller, ProtocolError, Signal
    from armlab.simulation import simulate

    def plain_law(t, q, qd, z, h_e, params, tau_out, zdot_out, signals_out):
        tau_out[:] = 0.0

    @dataclass(frozen=True)
    class Plain(Controller):
        model: object
        law = plain_law

        def params(self):
            return (np.zeros(1),)

        def signals(self):
            return (Signal.joint("none", self.model, "position"),)

    robot = armlab.load_robot("prp")
    # A plain-Python law runs in the Python loop (armlab.simulation.python_loop).
    result = simulate(robot, Plain(robot), q0=np.zeros(3), t_final=0.01, dt=1e-3)
    assert result.meta["law"] == "python" and np.all(result.tau == 0.0)

    class NotALaw(Plain):
        law = 3

    with pytest.raises(ProtocolError, match="NotALaw.law: 3 is not a function"):
        simulate(robot, NotALaw(robot), q0=np.zeros(3), t_final=0.01, dt=1e-3)


@njit(cache=False)
def _returns_something(a):
    a[0] = 1.0
    return a


def test_a_callee_returning_the_wrong_type_is_refused_before_any_call():
    from armlab.kernels.boundary import IndirectCallError

    with pytest.raises(IndirectCallError, match="returns array.*expects none"):
        kernel_address(_returns_something, (VEC,), types.none)


def test_parameter_type_keys_tell_apart_what_numba_types_differently():
    key = loop._type_key
    assert key((np.zeros(3), 1.0)) == key((np.ones(3), 2.0))
    assert key((np.zeros(3),)) != key((np.zeros(3, dtype=np.float32),))
    assert key((np.zeros(3),)) != key((np.zeros((3, 1))[:, 0].copy(order="F")[::2],))
    assert key((1,)) != key((2**63,))                  # int64 vs uint64
    assert key((_divide,)) != key((_read_back,))       # compiled functions: typeof
    record = np.zeros(2, dtype=[("a", "f8"), ("b", "f8")])
    other = np.zeros(2, dtype=[("a", "f8"), ("c", "i8")])
    assert key((record,)) != key((other,))


@njit(cache=False)
def _scale_borrowed(values, pair, factor):
    a, (b, c) = borrowed((values, pair))
    for i in range(a.shape[0]):
        a[i] *= factor
    b[0] = c[1] + factor
    return a.sum() + b[0]


def test_borrowed_arrays_are_the_same_memory():
    values, b, c = np.arange(3.0), np.zeros(2), np.array([5.0, 7.0])
    total = _scale_borrowed(values, (b, c), 2.0)
    np.testing.assert_array_equal(values, [0.0, 2.0, 4.0])   # written through the borrowed view
    assert b[0] == 9.0 and total == 15.0


@cfunc("float64(float64)", cache=False)
def _plus_one(x):
    return x + 1.0


@cfunc("float64(float64)", cache=False)
def _twice(x):
    return 2.0 * x


@njit(cache=False)
def _through_crossing(values, functions, x):
    params = with_functions(borrowed(values), functions)
    first, (scale, second), arrays = params
    return second(first(x)) * scale + arrays[0][1]


def test_functions_cross_beside_their_tuple_and_are_put_back_in_order():
    """crossing takes each compiled function out of a (nested) parameter tuple, depth first;
    with_functions puts them back: the same numba type as the whole tuple, the same calls."""
    a = np.array([0.5, 0.25])
    params = (_plus_one, (3.0, _twice), (a, a))
    values, functions = entry.crossing(params)
    assert values[0] == (None, (3.0, None), (a, a)) and functions == (_plus_one, _twice)
    assert values[1].dtype == np.int64 and values[1].tolist() == [0, 0]
    assert values[0][2][0] is a
    assert _through_crossing(values, functions, 1.0) == 2.0 * 2.0 * 3.0 + 0.25
    swapped = (_twice, (3.0, _plus_one), (a, a))
    assert _through_crossing(*entry.crossing(swapped), 1.0) == (2.0 + 1.0) * 3.0 + 0.25

    @njit(cache=False)
    def filled_type(values, functions):
        return with_functions(values, functions)

    before = sys.getrefcount(a)
    for _ in range(3):
        filled = filled_type(values, functions)        # back in Python: its own references
        assert np.shares_memory(filled[2][0], a) and filled[0] is not None
    del filled
    assert sys.getrefcount(a) == before
    (signature,) = filled_type.nopython_signatures
    assert signature.return_type == typeof(entry.plain_params(params))
    (plain, addresses), functions = entry.crossing((1.0, np.int64(2), True, a))
    assert plain == (1.0, np.int64(2), True, a) and addresses.shape == (0,) and functions == ()


def test_with_functions_refuses_counts_that_do_not_match():
    @njit(cache=False)
    def filled(values, functions):
        return with_functions(values, functions)

    none = np.zeros(2, dtype=np.int64)
    with pytest.raises(Exception, match="more None items than functions"):
        filled(((None, None), none), (_plus_one,))
    with pytest.raises(Exception, match="more functions than None items"):
        filled(((1.0, None), none), (_plus_one, _twice))
    with pytest.raises(Exception, match="addresses an int64 array"):
        filled(((None,), np.zeros(1)), (_plus_one,))
    with pytest.raises(Exception, match="functions are first-class functions"):
        filled(((None,), none), (1.0,))


@njit(cache=False)
def _cube(x):
    return x * x * x


class _DecoyWrapper(NativeFunction):
    """A NativeFunction whose C wrapper is another function's: a call that reaches the C
    wrapper returns x + 1, one in numba's own convention x³."""

    def __wrapper_address__(self):
        return _plus_one.address


def test_a_native_function_is_called_at_its_own_address():
    """crossing puts a NativeFunction's numba-convention address beside it and with_functions
    writes it into the value, so compiled code calls the kernel itself and not the C wrapper
    (as it does a cfunc, whose address is 0); from Python it calls the kernel."""
    cube = _DecoyWrapper(_cube, types.float64(types.float64))
    a = np.array([0.5, 0.25])
    values, functions = entry.crossing((cube, (3.0, _twice), (a, a)))
    assert functions == (cube, _twice) and values[1].tolist() == [cube.native_address(), 0]
    assert cube.native_address() != 0
    # second(first(x)) * scale + a[1] with first = x³ (not x + 1), second = 2x
    assert _through_crossing(values, functions, 2.0) == 2.0 * 8.0 * 3.0 + 0.25
    assert cube(3.0) == 27.0
    plain = NativeFunction(_cube, types.float64(types.float64))
    assert _through_crossing(*entry.crossing((plain, (1.0, _twice), (a, a))), 2.0) == 16.25



def test_a_native_function_is_typed_once_and_as_numba_types_its_signature():
    """numba's own typeof of a WrapperAddressProtocol builds the type from the signature at
    every dispatch (~6 µs); a NativeFunction's typeof returns the type made with it, the type
    numba would make."""
    from numba.extending import typeof_impl

    from armlab.kernels import boundary

    assert typeof_impl.dispatch(NativeFunction) is boundary._typeof_native_function
    signature = types.float64(types.float64)
    cube = NativeFunction(_cube, signature)
    assert typeof(cube) is cube.numba_type
    assert typeof(cube) == types.FunctionType(signature) == typeof(NativeFunction(_cube, signature))


@njit(cache=False)
def _read_back_law(pointer, x):
    first, (scale, second), arrays = pointer[0]
    return second(first(x)) * scale + arrays[0][1]


@njit(cache=False)
def _through_an_address(address, pointer, x):
    return call_float(address, (pointer, x))


def test_a_parked_parameter_tuple_reads_back_through_its_address():
    """loop.parked copies the tuple as the law sees it (its functions put back, a
    NativeFunction's own address written in) into bytes whose address a law reads as it reads
    a stack copy; park says how many bytes it needs and writes nothing into fewer."""
    cube = NativeFunction(_cube, types.float64(types.float64))
    a = np.array([0.5, 0.25])
    params = (cube, (3.0, _twice), (a, a))
    values, functions = entry.crossing(params)
    size = loop.park_params(values, functions, np.zeros(0, dtype=np.uint8))
    small = np.full(size - 1, 7, dtype=np.uint8)
    assert loop.park_params(values, functions, small) == size and (small == 7).all()
    buffer = loop.parked(values, functions)
    assert buffer.dtype == np.uint8 and buffer.size == size
    _with_functions_type(values, functions)
    (signature,) = _with_functions_type.nopython_signatures
    pointer_type = types.CPointer(signature.return_type)
    address = kernel_address(_read_back_law, (pointer_type, types.float64), types.float64)
    # second(first(x)) * scale + a[1] with first = x³ (the kernel, not its C wrapper), second = 2x
    assert _through_an_address(address, buffer.ctypes.data, 2.0) == 2.0 * 8.0 * 3.0 + 0.25


@njit(cache=False)
def _with_functions_type(values, functions):
    return with_functions(values, functions)


@njit(cache=False)
def _no_wrench_both_ways(buf, n):
    whole = workspace_from_buffer(buf, n).no_wrench
    alone = no_wrench_of(buf, n)
    return whole.ctypes.data == alone.ctypes.data and whole.shape == alone.shape


@pytest.mark.parametrize("n", [1, 3, 7])
def test_the_zero_wrench_alone_is_the_workspaces_own(n):
    from armlab.kernels.workspace import workspace_size

    assert _no_wrench_both_ways(np.zeros(workspace_size(n)), n)


@njit(cache=False)
def _rest_both_ways(buf, n):
    whole = workspace_from_buffer(buf, n)
    zero, scratch, no_wrench = rest_of(buf, n)
    return (whole.zero.ctypes.data == zero.ctypes.data and whole.zero.shape == zero.shape
            and whole.t1.ctypes.data == scratch.ctypes.data and whole.t1.shape == scratch.shape
            and whole.no_wrench.ctypes.data == no_wrench.ctypes.data
            and whole.no_wrench.shape == no_wrench.shape)


@pytest.mark.parametrize("n", [1, 3, 7])
def test_the_tail_views_alone_are_the_workspaces_own(n):
    from armlab.kernels.workspace import workspace_size

    assert _rest_both_ways(np.zeros(workspace_size(n)), n)
