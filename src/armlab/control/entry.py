"""The law ABI: how the simulation loop hands a controller's law its inputs and outputs.

A controller's law (``armlab.control.base``) reads q, q̇, z, h_e and writes τ, ż and its
signals.  The loop keeps all of them in its one scratch array ``work``; :func:`law_views`
gives the views, in the order of the law's arguments around ``params``.

Every compiled law defined at module level gets an *entry*, the function the loop calls: a
call that receives the loop's scratch array and three sizes instead of seven arrays and the
parameter tuple by value (:func:`generated_entry`), and calls the law, or holds it when the
law is declared ``njit(inline="always")`` as the joint-space laws are (a small law's run
1.4–1.9 times faster so, a task-space or interaction law's 7–13 % slower:
``docs/python-laws.md``).  The entry is generated, always the same three lines::

    @njit(cache=True)
    def entry(cp, law, t, work, n, k, s):
        q, qd, z, h_e, tau_out, zdot_out, signals_out = law_views(borrowed(work), n, k, s)
        law_function(t, q, qd, z, h_e, borrowed(cp[0]), tau_out, zdot_out, signals_out)

into a module of armlab's cache folder (``law_entries``; ``armlab.specialise.generated_module``)
whose name hashes the law's source file and the sources the law may inline (armlab's kernels,
controllers and references): numba caches the entry beside it, and an edit of any of those
files makes a new entry rather than loading one that inlined the old law.  A law that cannot
be imported by name (made inside a function, typed into an interpreter or a notebook) has no
entry: the loop then calls it through its address (:func:`law_trampoline`),
with the same results.

What a law's parameters may hold (arrays, numbers, compiled functions and tuples of those)
is checked in Python, in one line (:func:`check_params`), before numba sees them.  The
parameters cross from Python into the loop's shared functions as plain tuples
(:func:`plain_params`: why, in ``armlab.simulation.loop``), with each compiled function in them
taken out and passed beside its tuple (:func:`crossing`), to be put back in compiled code
(``armlab.kernels.boundary.with_functions``).
"""

from __future__ import annotations

import functools
import hashlib
import sys
import threading
from pathlib import Path

import numpy as np
from numba import njit, typeof, types

from armlab.errors import ProtocolError
from armlab.kernels.boundary import borrowed, buffer_view, call_none, native_address
from armlab.specialise.closed_form import generated_module


@njit(cache=True, inline="always")
def law_views(work, n, k, s):
    """(q, qd, z, h_e, tau_out, zdot_out, signals_out): the scratch views a law reads and
    writes, in the order of its arguments around ``params``.

    They lie first in ``work``, in this order, whatever the rest of the scratch layout (the
    law ABI, which the generated entries inline: the hash of their sources includes this
    file)."""
    f = np.float64
    return (buffer_view(work, 0, n, f), buffer_view(work, n, n, f), buffer_view(work, 2 * n, k, f),
            buffer_view(work, 2 * n + k, 6, f), buffer_view(work, 2 * n + k + 6, n, f),
            buffer_view(work, 3 * n + k + 6, k, f), buffer_view(work, 3 * n + 2 * k + 6, s, f))


@njit(cache=True)
def law_trampoline(cp, law, t, work, n, k, s):
    """The entry of a law without its own: the law at ``law`` called with the parameter
    tuple at ``cp`` (a CPointer to it) on the scratch views of ``work``."""
    work = borrowed(work)
    q, qd, z, h_e, tau_out, zdot_out, signals_out = law_views(work, n, k, s)
    call_none(law, (t, q, qd, z, h_e, borrowed(cp[0]), tau_out, zdot_out, signals_out))


def law_entry_types(cparams_type) -> tuple:
    """Argument types of a law entry (``law_trampoline`` or a generated one) for parameters
    of numba type ``cparams_type``."""
    i64 = types.int64
    return (types.CPointer(cparams_type), i64, types.float64, types.float64[::1], i64, i64, i64)


def plain_params(params):
    """``params`` with every NamedTuple in it (nested ones too) as a plain tuple of the same
    fields, the same objects: what the loop's shared functions receive."""
    if isinstance(params, tuple):
        return tuple(plain_params(value) for value in params)
    return params


def crossing(params) -> tuple[tuple, tuple]:
    """``params`` as the loop's entries (``rk4_run`` …) receive it from Python:
    ``((values, addresses), functions)``, ``values`` its plain tuple (:func:`plain_params`)
    with None in place of each compiled function, ``functions`` those functions, depth first,
    and ``addresses`` (int64) the ``native_address`` of each (0 but for a ``NativeFunction``);
    ``with_functions`` puts them back in compiled code.  numba's dispatcher types the first
    from a fingerprint computed in C and only the functions in Python
    (``armlab.kernels.boundary``: 16 µs a call instead of 120 µs for the A7 law's; with each
    address beside its function in a pair, 33 µs, 9 µs so)."""
    functions, addresses = [], []

    def strip(value):
        if isinstance(value, tuple):
            return tuple(strip(item) for item in value)
        if isinstance(value, (np.ndarray, np.generic, bool, int, float)):
            return value
        functions.append(value)
        addresses.append(native_address(value))
        return None

    values = strip(params)
    return (values, np.array(addresses, dtype=np.int64)), tuple(functions)


def check_params(params, what: str = "params") -> None:
    """The compiled loop takes ``params`` as a tuple (or NamedTuple) of arrays, numbers,
    compiled functions (numba's ``cfunc``, first-class function values) and such tuples; a
    list, a dict or another object is refused here in one line (numba's own typing error is
    forty)."""
    if not isinstance(params, tuple):
        hint = " (write tuple(...) or a NamedTuple)" if isinstance(params, list) else ""
        raise ProtocolError(f"{what}: a {type(params).__name__}, but a law's params must be a tuple "
                            f"or NamedTuple of arrays and numbers{hint}")
    names = getattr(params, "_fields", None) or [str(i) for i in range(len(params))]
    for name, value in zip(names, params, strict=True):
        if isinstance(value, tuple):
            check_params(value, f"{what}.{name}")
        elif isinstance(value, np.ndarray):
            if value.dtype.hasobject:
                raise ProtocolError(f"{what}.{name}: an array of Python objects; use a numeric array")
        elif not (isinstance(value, (bool, int, float, np.number, np.bool_)) or is_compiled_function(value)):
            raise ProtocolError(f"{what}.{name}: a {type(value).__name__}; params hold arrays, numbers, "
                                "compiled functions (cfunc) and tuples of those")


_FUNCTION_CLASSES: set = set()     # Python classes whose values numba types as functions


def is_compiled_function(value) -> bool:
    """Whether numba takes ``value`` as a first-class function (a ``cfunc``), its class
    remembered (``typeof`` costs ~5 µs of a short run's set-up)."""
    if type(value) in _FUNCTION_CLASSES:
        return True
    try:
        function = isinstance(typeof(value), types.FunctionType)
    except ValueError:      # typeof: no numba type
        return False
    if function:
        _FUNCTION_CLASSES.add(type(value))
    return function


_NUMBA_REASONS = ("No implementation of function", "Unknown attribute", "Cannot unify", "Invalid use of",
                  "non-precise type", "Untyped global name", "Cannot determine Numba type",
                  "NameError", "has no attribute", "Cannot type")


def compile_problem(name: str, error: Exception) -> str:
    """One line saying why numba could not compile the law of controller class ``name``: the
    first line of its typing error that names a reason, with the law's source line."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    named = [line for line in lines if any(key in line for key in _NUMBA_REASONS)]
    reason = named[0] if named else (lines[-1] if lines else "")
    where = next((line for line in lines if line.startswith("File ")), "")
    where = f" ({where})" if where else ""
    return (f"{name}.law does not compile for its params: {reason}{where}; a law reads arrays, numbers "
            "and tuples of those, and writes into tau_out, zdot_out and signals_out")


_TEMPLATE = '''\
"""The loop entry of {module}.{name}, generated by armlab.control.entry (see there)."""
from numba import njit

from armlab.control.entry import law_views
from armlab.kernels.boundary import borrowed
from {module} import {name} as law_function


@njit(cache=True)
def entry(cp, law, t, work, n, k, s):
    q, qd, z, h_e, tau_out, zdot_out, signals_out = law_views(borrowed(work), n, k, s)
    law_function(t, q, qd, z, h_e, borrowed(cp[0]), tau_out, zdot_out, signals_out)
'''

_PACKAGE = Path(__file__).resolve().parents[1]            # armlab/
# What a law may inline besides its own module: the kernels, the controllers and references.
_INLINED_SOURCES = ("kernels", "control", "references")
ENTRY_FOLDER = "law_entries"    # of armlab's cache folder
_ENTRIES: dict = {}
_LOCK = threading.Lock()


@functools.cache
def _armlab_digest() -> bytes:
    digest = hashlib.sha256(_TEMPLATE.encode())
    for folder in _INLINED_SOURCES:
        for path in sorted((_PACKAGE / folder).glob("*.py")):
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
    return digest.digest()


def _importable(law) -> tuple[str, str, Path] | None:
    """(module, name, source file) of a law that its module holds under its own name."""
    python = getattr(law, "py_func", None)
    if python is None:
        return None
    module_name, name = python.__module__, python.__name__
    module = sys.modules.get(module_name)
    source = getattr(module, "__file__", None)
    if (module is None or module_name == "__main__" or source is None or python.__qualname__ != name
            or getattr(module, name, None) is not law or not name.isidentifier()
            or not all(part.isidentifier() for part in module_name.split("."))):
        return None
    return module_name, name, Path(source)


def generated_entry(law):
    """The loop entry of the compiled ``law`` (module docstring), generated and imported on its
    first use in a process, or None for a law that cannot be imported by name."""
    known = _ENTRIES.get(law)
    if known is not None or law in _ENTRIES:
        return known
    with _LOCK:
        if law not in _ENTRIES:
            _ENTRIES[law] = _generate(law)
    return _ENTRIES[law]


def _generate(law):
    found = _importable(law)
    if found is None:
        return None
    module, name, source = found
    try:
        law_source = source.read_bytes()
    except OSError:
        return None
    digest = hashlib.sha256(_armlab_digest() + module.encode() + b"." + name.encode() + law_source)
    generated = generated_module(f"armlab_law_entry_{digest.hexdigest()[:24]}",
                                 _TEMPLATE.format(module=module, name=name), ENTRY_FOLDER)
    return generated.entry
