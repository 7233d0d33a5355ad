"""A robot's :class:`~armlab.model.robot.RobotArrays` packed into two flat arrays.

Calling a compiled function from Python costs about 0.1–0.2 µs per array argument to unbox;
the 18 arrays of ``RobotArrays`` plus the 17 of a dynamics workspace would cost far more than
the dynamics itself.  The public functions therefore pass flat arrays and rebuild the named
tuple of views inside compiled code with :func:`unpack_robot` (no copy, no allocation).

The views are made by :func:`buffer_view`, which writes the shape and strides of a C-contiguous
view directly: ``data[o:o + k].reshape(shape)`` would call numba's general reshape helper,
about 30 ns each, i.e. ~1 µs for the ~30 views of a robot and a workspace — more than a
3-joint inverse dynamics.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic
from numba.np.arrayobj import make_array, populate_array

from armlab.model.robot import RobotArrays

# Float fields of RobotArrays in packing order (joint_type travels separately as int64).
FLOAT_FIELDS = RobotArrays._fields[1:]


def pack_robot(m: RobotArrays) -> tuple[np.ndarray, np.ndarray]:
    """(joint_type (n,) int64, data (k,) float64) holding every field of ``m``.

    The arrays stay writeable (but are never written) so that the kernels see the same array
    types as with ``robot.arrays`` and compile once.
    """
    data = np.concatenate([np.asarray(getattr(m, name), dtype=float).ravel() for name in FLOAT_FIELDS])
    joint_type = np.ascontiguousarray(m.joint_type, dtype=np.int64)
    return joint_type, data


@intrinsic
def buffer_view(typingctx, buf, offset, shape, dtype):
    """``buffer_view(buf, offset, shape, dtype)``: the C-contiguous array of ``shape`` (an int or
    a tuple of ints) and ``dtype`` (``np.float64`` or ``np.int64``) whose first element is
    ``buf[offset]``; it shares ``buf``'s memory (a view, like a slice).  Compiled code only;
    the caller guarantees that the view lies inside ``buf`` (1-D, C-contiguous, 8-byte items)."""
    if not (isinstance(buf, types.Array) and buf.ndim == 1 and buf.layout == "C"
            and buf.dtype.bitwidth == 64 and isinstance(dtype, types.NumberClass)
            and dtype.dtype.bitwidth == 64):
        return None
    if isinstance(shape, types.Integer):
        dims = (shape,)
    elif isinstance(shape, types.BaseTuple) and all(isinstance(t, types.Integer) for t in shape):
        dims = tuple(shape)
    else:
        return None
    result = types.Array(dtype.dtype, len(dims), "C")

    def codegen(context, builder, sig, args):
        buf_value, offset_value, shape_value, _ = args
        source = make_array(sig.args[0])(context, builder, buf_value)
        view = make_array(result)(context, builder)
        tupled = isinstance(sig.args[2], types.BaseTuple)
        values = cgutils.unpack_tuple(builder, shape_value) if tupled else [shape_value]
        shapes = [context.cast(builder, v, t, types.intp) for v, t in zip(values, dims, strict=True)]
        itemsize = context.get_constant(types.intp, 8)
        strides, stride = [], itemsize
        for extent in reversed(shapes):
            strides.insert(0, stride)
            stride = builder.mul(stride, extent)
        start = builder.gep(source.data, [context.cast(builder, offset_value, sig.args[1], types.intp)])
        data = builder.bitcast(start, context.get_data_type(result.dtype).as_pointer())
        populate_array(view, data=data, shape=shapes, strides=strides, itemsize=itemsize,
                       meminfo=source.meminfo, parent=source.parent)
        return impl_ret_borrowed(context, builder, result, view._getvalue())

    return result(buf, offset, shape, dtype), codegen


def _borrow(context, builder, typ, value):
    """``value`` of numba type ``typ`` with every array's reference to its owner cleared."""
    if isinstance(typ, types.Array):
        view = make_array(typ)(context, builder, value)
        view.meminfo = context.get_constant_null(types.MemInfoPointer(types.voidptr))
        view.parent = context.get_constant_null(types.pyobject)
        return view._getvalue()
    if isinstance(typ, types.BaseTuple):
        for i, member in enumerate(typ):
            if _holds_arrays(member):
                item = builder.extract_value(value, i)
                value = builder.insert_value(value, _borrow(context, builder, member, item), i)
    return value


def _holds_arrays(typ) -> bool:
    return isinstance(typ, types.Array) or (
        isinstance(typ, types.BaseTuple) and any(_holds_arrays(t) for t in typ))


@intrinsic
def borrowed(typingctx, value):
    """``borrowed(value)``: ``value`` (an array, or a (named) tuple of arrays, numbers and such
    tuples) whose arrays no longer reference their owners: the same memory, but numba's
    reference counting skips them, and, their owner being a constant null, the compiler
    removes the counting code altogether (an atomic increment and decrement, or at least a
    test and a branch, for every array taken out of a tuple or passed on).

    For compiled code that runs inside a call whose caller keeps the owners alive until it
    returns (the simulation loop and the functions it calls, the plant kernels): such arrays
    and their views must never be returned, stored or outlive that call."""
    def codegen(context, builder, sig, args):
        return _borrow(context, builder, sig.args[0], args[0])

    return value(value), codegen


@njit(cache=True, inline="always")
def unpack_robot(joint_type, data):
    """The :class:`RobotArrays` whose float arrays are views into ``data`` (see pack_robot).

    Inlined into its caller so that the views are reference-counted as the caller is (see
    ``workspace_from_buffer`` in :mod:`armlab.kernels.dynamics`)."""
    n = joint_type.shape[0]
    f = np.float64
    o = 0
    tree_R = buffer_view(data, o, (n, 3, 3), f)
    o += 9 * n
    tree_p = buffer_view(data, o, (n, 3), f)
    o += 3 * n
    offset = buffer_view(data, o, n, f)
    o += n
    tool_R = buffer_view(data, o, (3, 3), f)
    o += 9
    tool_p = buffer_view(data, o, 3, f)
    o += 3
    base_R = buffer_view(data, o, (3, 3), f)
    o += 9
    base_p = buffer_view(data, o, 3, f)
    o += 3
    mass = buffer_view(data, o, n, f)
    o += n
    com = buffer_view(data, o, (n, 3), f)
    o += 3 * n
    inertia = buffer_view(data, o, (n, 3, 3), f)
    o += 9 * n
    gear_ratio = buffer_view(data, o, n, f)
    o += n
    rotor_inertia = buffer_view(data, o, n, f)
    o += n
    viscous = buffer_view(data, o, n, f)
    o += n
    coulomb = buffer_view(data, o, n, f)
    o += n
    q_min = buffer_view(data, o, n, f)
    o += n
    q_max = buffer_view(data, o, n, f)
    o += n
    gravity = buffer_view(data, o, 3, f)
    return RobotArrays(joint_type, tree_R, tree_p, offset, tool_R, tool_p, base_R, base_p, mass,
                       com, inertia, gear_ratio, rotor_inertia, viscous, coulomb, q_min, q_max,
                       gravity)
