"""Indirect calls: compiled code calling a compiled kernel through its machine address.

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

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from armlab.errors import IndirectCallError

__all__ = ["call_bool", "call_float", "call_int", "call_none", "call_status", "kernel_address",
           "stack_address"]


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
