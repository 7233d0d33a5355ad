"""The engine's boundary with numba: the one module that knows addresses, calling conventions and
reference counts.  Nothing else in armlab imports ``numba.core`` or ``numba.np`` or writes LLVM.

Each piece is here because numba's documented API (``jit``, ``cfunc``, ``carray``, first-class
functions) does not give it at a cost users feel; the measurement that justifies it is in its
docstring:

* **Indirect calls** (:func:`kernel_address`, ``call_*``, :func:`stack_address`): compiled code
  calling a compiled kernel through its machine address, so that one cached loop calls any
  law, environment or plant kernel without linking (and recompiling) them into itself.
* **Borrowed arrays** (:func:`borrowed`): arrays whose owner the caller keeps alive, handed on
  without numba's reference counting (measured: an A7 run 6.2–7.6 ms with it, 58.6–69.6 ms
  without it, the same trajectory).
* **Views into one buffer** (:func:`buffer_view`): the C-contiguous view of a slice of a flat
  array, without numba's general reshape (~30 ns a view, ~1 µs for the ~30 views of a robot and
  its workspace, more than a 3-joint inverse dynamics).
* **Functions beside their tuple** (:func:`with_functions`): a parameter tuple that holds a
  compiled function (the computed-torque law's inverse dynamics) crosses from Python with
  ``None`` in the function's place and the function in a tuple of its own, and is put together
  again in compiled code; each function's :func:`native_address` travels in an int64 array
  beside the tuple.  numba's dispatcher types a tuple of arrays and numbers from a
  fingerprint computed in C, but a tuple holding a function in Python, item by item: a call
  with 15 arrays and a function in one tuple costs 120 µs, with the function beside it 16 µs
  (the A7 law's parameters, on every ``simulate``); (address, function) pairs cost 33 µs to
  type, the functions alone 9 µs.
* **Parked parameters** (:func:`park`): a parameter tuple copied once into bytes the caller
  keeps, so that a compiled function called from Python many times (the adaptive
  integrator's right-hand side) takes its address instead of the tuple and its functions
  (the A7 run on SciPy's RK45 101.8 → 28.3 ms).
* **Functions called in numba's own convention** (:class:`NativeFunction`): a kernel in a
  law's parameters (the computed-torque law's inverse dynamics) as a first-class function
  value (numba's documented ``WrapperAddressProtocol``) that compiled code calls at the
  kernel's own address instead of through a C wrapper: :func:`with_functions` writes that
  address into the value's ``jit_addr``, the slot numba's lowering calls when it is set and
  fills only for its own dispatchers, whose type would make the law compile per robot
  (measured: the Puma560's 10 s computed-torque run 17.5–17.6 ms through a ``cfunc``, 16.0 ms
  so; the PRP's within its noise).  Its numba type is made once, registered with numba's
  documented ``typeof_impl`` (numba's own typeof of the protocol builds it anew at every call).
  With the addresses in an array, ``simulate``'s set-up on the A7 run went 405 → 330 µs.

Indirect calls
--------------
Why.  When one numba function calls another, numba links the callee's LLVM module into the
caller's and optimises and compiles the whole again.  A simulation loop that calls a control
law, which calls the RNEA, plus the plant's forward dynamics and kinematics, therefore
recompiled all of them for every law (about 20 s each), and a loop that received the law as a
function argument could not be cached on disk at all (the argument's type belongs to one
process).  Calling through an address keeps every kernel compiled once, in its own cached
module, and lets one cached loop call any law, environment or plant model:

    address = kernel_address(rnea_into, (arrays_type, workspace_type, ...), types.none)
    call_none(address, (m, ws, q, qd, qdd, 1.0, h_e, tau))                   # compiled code

The call is the one numba's own lowering makes for a first-class function (its calling
convention, through ``call_conv.call_function``) for the argument types as the caller sees them,
so the types the address was compiled for must be the caller's, exactly (same dtypes,
dimensions and tuple structure; array layout does not change the convention).  Exceptions
raised by the callee propagate to the caller as in a direct call.
"""

from __future__ import annotations

import numba.experimental.function_type  # noqa: F401  (registers numba's typeof of NativeFunction)
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic, typeof_impl
from numba.np.arrayobj import make_array, populate_array

from armlab.errors import IndirectCallError

__all__ = ["NativeFunction", "borrowed", "buffer_view", "call_bool", "call_float", "call_int", "call_none",
           "call_status", "kernel_address", "native_address", "park", "stack_address", "with_functions"]


def _indirect_call(restype):
    """An intrinsic ``call(address, args_tuple) -> restype``: the call numba's own lowering makes
    for a first-class function given its compiled address (``call_conv.call_function`` with the
    status check that propagates the callee's exception)."""

    @intrinsic
    def call(typingctx, address, args):
        if not isinstance(address, types.Integer) or not isinstance(args, types.BaseTuple):
            return None
        signature = restype(address, args)

        def codegen(context, builder, sig, llargs):
            address_value, packed = llargs
            argtypes = list(args.types)
            values = [builder.extract_value(packed, i) for i in range(len(argtypes))]
            conv = context.call_conv
            pointer_type = conv.get_function_type(restype, argtypes).as_pointer()
            callee = builder.bitcast(builder.inttoptr(address_value, ir.IntType(8).as_pointer()),
                                     pointer_type)
            status, result = conv.call_function(builder, callee, restype, argtypes, values)
            with cgutils.if_unlikely(builder, status.is_error):
                conv.return_status_propagate(builder, status)
            return result

        return signature, codegen

    return call


@intrinsic
def stack_address(typingctx, value):
    """Address (int64) of a copy of ``value`` in the calling function's stack frame, valid
    until that function returns: how a cached, type-independent loop hands a parameter tuple
    to a trampoline compiled for the tuple's type, which reads it back as ``pointer[0]``
    (argument type ``types.CPointer(tuple_type)``; a pointer and an int64 are passed alike)."""
    def codegen(context, builder, sig, args):
        slot = cgutils.alloca_once_value(builder, args[0])
        return builder.ptrtoint(slot, ir.IntType(64))

    return types.int64(value), codegen


@intrinsic
def park(typingctx, value, buffer):
    """``park(value, buffer)``: the number of bytes ``value`` takes, and ``value`` copied into
    ``buffer`` (a C-contiguous uint8 array) if it has that many.  A parameter tuple parked
    once is read back through ``buffer``'s address as through :func:`stack_address`'s, for as
    long as the caller keeps ``buffer`` and what the tuple references (arrays, functions)
    alive: the adaptive integrator's right-hand side, called from Python at every stage, then
    takes two addresses instead of the parameters and their functions, which numba types and
    unboxes in Python at every call (measured: the A7 10 s run on SciPy's RK45 at armlab's
    default tolerances 101.8 → 28.3 ms, on Radau 987 → 415 ms, the same trajectories)."""
    if not (isinstance(buffer, types.Array) and buffer.ndim == 1 and buffer.layout == "C"
            and buffer.dtype == types.uint8):
        return None

    def codegen(context, builder, sig, args):
        value, buf = args
        llty = context.get_value_type(sig.args[0])
        size = ir.Constant(ir.IntType(64), context.get_abi_sizeof(llty))
        array = make_array(sig.args[1])(context, builder, buf)
        with builder.if_then(builder.icmp_signed(">=", array.nitems, size)):
            builder.store(value, builder.bitcast(array.data, llty.as_pointer()))
        return size

    return types.int64(value, buffer), codegen


call_none = _indirect_call(types.none)
call_bool = _indirect_call(types.boolean)
call_float = _indirect_call(types.float64)
call_int = _indirect_call(types.int64)
call_status = _indirect_call(types.UniTuple(types.int64, 4))

_ADDRESSES: dict = {}
# The same lookups by identity, for callers that pass the same argument-type tuple every time
# (a module constant): hashing numba types costs microseconds a lookup, on every simulation.
_BY_IDENTITY: dict = {}


def kernel_address(dispatcher, argtypes: tuple, restype) -> int:
    """Machine address of ``dispatcher`` compiled for ``argtypes`` (compiled or loaded from
    numba's disk cache on first use; remembered for the process).

    The address is the one numba's first-class functions call (the compile result's function
    in numba's calling convention, the ``jit_addr`` of a ``FunctionType`` value).
    ``restype`` is the return type the caller's ``call_*`` expects: the caller reserves room
    for exactly that, so a function returning anything else (a law ending in ``return tau``)
    is refused here instead of overwriting the caller's stack."""
    known = _BY_IDENTITY.get((id(dispatcher), id(argtypes)))
    if known is not None and known[0] is dispatcher and known[1] is argtypes:
        return known[2]
    key = (dispatcher, tuple(argtypes))
    address = _ADDRESSES.get(key)
    if address is None:
        argtypes = tuple(argtypes)
        dispatcher.compile(argtypes)          # numba's own lock; a no-op once compiled or cached
        result = dispatcher.overloads[argtypes]
        returned = result.signature.return_type
        if returned != restype:
            name = getattr(dispatcher, "__qualname__", None) or dispatcher.py_func.__qualname__
            raise IndirectCallError(f"{name}: returns {returned}, its caller expects {restype}")
        address = result.library.get_pointer_to_function(result.fndesc.llvm_func_name)
        _ADDRESSES[key] = address
    _BY_IDENTITY[(id(dispatcher), id(argtypes))] = (dispatcher, argtypes, address)
    return address


class NativeFunction(types.WrapperAddressProtocol):
    """The jit-compiled ``dispatcher`` as a first-class function of ``signature`` (numba's
    ``WrapperAddressProtocol``) that compiled code calls in numba's own calling convention
    once :func:`with_functions` has put it in a parameter tuple (elsewhere through the C
    wrapper numba compiles beside it, as a ``cfunc``); callable from Python.  See the module
    docstring."""

    def __init__(self, dispatcher, signature):
        self.dispatcher = dispatcher
        self._signature = signature
        self._addresses = None
        self.numba_type = types.FunctionType(signature)

    def signature(self):
        return self._signature

    def _compiled(self) -> tuple[int, int]:
        """(C wrapper, numba-convention function) addresses, compiled or loaded on first use."""
        if self._addresses is None:
            args, restype = tuple(self._signature.args), self._signature.return_type
            native = kernel_address(self.dispatcher, args, restype)
            result = self.dispatcher.overloads[args]
            wrapper = result.library.get_pointer_to_function(result.fndesc.llvm_cfunc_wrapper_name)
            self._addresses = (wrapper, native)
        return self._addresses

    def __wrapper_address__(self) -> int:
        return self._compiled()[0]

    def native_address(self) -> int:
        return self._compiled()[1]

    def __call__(self, *args):
        return self.dispatcher(*args)

    def __repr__(self):
        return f"NativeFunction({self.dispatcher.__name__}, {self._signature})"


@typeof_impl.register(NativeFunction)
def _typeof_native_function(value, context):
    """Its type, made once: numba's own typeof of a ``WrapperAddressProtocol`` builds a new
    ``FunctionType`` from the signature at every call of a dispatcher that receives it (6 µs a
    function, measured outside the dispatcher; the A7 law holds two)."""
    return value.numba_type


def native_address(function) -> int:
    """The address :func:`with_functions` writes into the value of ``function`` (a compiled
    function of a parameter tuple): its numba-convention one for a :class:`NativeFunction`, 0
    (numba calls the C wrapper) for anything else, a ``cfunc`` say."""
    return function.native_address() if isinstance(function, NativeFunction) else 0


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


def _filled_type(values, functions, start: int):
    """(``values``' tuple type with its ``none`` items, depth first, replaced by the types of
    ``functions[start:]``, the index of the next function)."""
    members, i = [], start
    for member in values:
        if isinstance(member, types.NoneType):
            if i >= len(functions):
                raise IndirectCallError("with_functions: more None items than functions")
            members.append(functions[i])
            i += 1
        elif isinstance(member, types.BaseTuple):
            inner, i = _filled_type(member, functions, i)
            members.append(inner)
        else:
            members.append(member)
    return types.BaseTuple.from_types(members), i


def _with_native_address(context, builder, function_type, value, address):
    """The first-class function ``value`` with ``address`` as its ``jit_addr`` (numba's own
    member, see :class:`NativeFunction`) unless it is 0."""
    function = cgutils.create_struct_proxy(function_type)(context, builder, value=value)
    pointer = builder.inttoptr(address, function.jit_addr.type)
    function.jit_addr = builder.select(cgutils.is_null(builder, address), function.jit_addr, pointer)
    return function._getvalue()


def _fill(context, builder, typ, value, result, functions, start: int):
    """(the LLVM value of type ``result`` made of ``value`` (of ``typ``) with the LLVM
    (function, address) pairs ``functions[start:]`` in its ``none`` items, the index of the
    next function)."""
    out, i = context.get_constant_undef(result), start
    for k, member in enumerate(typ):
        if isinstance(member, types.NoneType):
            item = _with_native_address(context, builder, result[k], *functions[i])
            i += 1
        elif isinstance(member, types.BaseTuple):
            inner = builder.extract_value(value, k)
            item, i = _fill(context, builder, member, inner, result[k], functions, i)
        else:
            item = builder.extract_value(value, k)
        out = builder.insert_value(out, item, k)
    return out, i


@intrinsic
def with_functions(typingctx, crossed, functions):
    """``with_functions((values, addresses), functions)``: the tuple ``values`` (nested tuples
    too) with its ``None`` items, depth first, replaced by the compiled functions of the tuple
    ``functions``, in order, the function i with ``addresses[i]`` (its :func:`native_address`)
    written in: the parameter tuple as the law sees it (see the module docstring, and
    ``armlab.control.entry.crossing``, which makes both, for the Python side).  The result
    holds references of its own to the arrays of ``values``, as numba's functions return them
    (none to count when ``values`` is :func:`borrowed`, as in the loop's entries)."""
    if not (isinstance(crossed, types.BaseTuple) and len(crossed) == 2
            and isinstance(crossed[0], types.BaseTuple) and isinstance(functions, types.BaseTuple)):
        return None
    address_type = crossed[1]
    if not (isinstance(address_type, types.Array) and address_type.dtype == types.int64
            and address_type.ndim == 1 and address_type.layout == "C"):
        raise IndirectCallError("with_functions: (values, addresses) with addresses an int64 array")
    if not all(isinstance(f, types.FunctionType) for f in functions):
        raise IndirectCallError("with_functions: functions are first-class functions")
    result, used = _filled_type(crossed[0], tuple(functions), 0)
    if used != len(functions):
        raise IndirectCallError("with_functions: more functions than None items")

    def codegen(context, builder, sig, args):
        value, packed = args
        plain_type = sig.args[0][0]
        addresses = make_array(sig.args[0][1])(context, builder, builder.extract_value(value, 1)).data
        items = [(builder.extract_value(packed, i), builder.load(cgutils.gep(builder, addresses, i)))
                 for i in range(len(sig.args[1]))]
        # A new reference to what ``values`` holds (nothing to count when it is borrowed).
        filled = _fill(context, builder, plain_type, builder.extract_value(value, 0), sig.return_type,
                       items, 0)[0]
        return impl_ret_borrowed(context, builder, sig.return_type, filled)

    return result(crossed, functions), codegen
