"""Robot-specialised dynamics of any size, by partial evaluation of the numeric kernels.

With the robot's numbers m fixed, every branch of the joint-frame kernels of
``armlab.kernels.dynamics`` (joint type, rotor present, wrench present, loop bounds) is
decided, so each kernel is a straight-line program in its state arguments.  Running the
kernels' Python bodies (``.py_func``) on numpy *object* arrays — the robot's numbers as plain
floats, q, q̇, q̈, h_e as named :class:`_Value`\\ s — records that program, one arithmetic
operation per line (``t17 = t3 * t9``), while what is known is folded away:

    c ∘ c' → its float (the same IEEE operation the kernel would do),
    x·0 → 0,  x·1 → x,  x·(−1) → −x,  x ± 0 → x,  0 − x → −x,  x/1 → x,
    −x is a sign carried with the value (a − (−b) is written a + b: negation is exact),
    a repeated operation on the same operands reuses its first result,
    lines that reach no output are dropped.

Entries of the robot's numbers that are rounding residue of its construction (cos(π/2) =
6.1e-17, not 0) are set to 0 first (``SNAP``).  The DH geometry's zeros and ones and a
massless link's terms therefore generate no code, and
there remains one implementation of each law: the numeric kernels.  A branch on a traced
value (``if v > 0.0``) raises :class:`TracedBranch`; the two that exist are handled here:
Coulomb friction is written out per joint (the kernels trace a frictionless copy of the
robot), and the wrench term is traced on its own (its run-time test, ``_has_wrench``, is taken
as true while tracing).

The module has the interface of the model-and-data kernels (``armlab.kernels.plant``):

    inverse_dynamics(model, data, q, qd, qdd, tau_out)
        τ = RNEA(q, q̇, q̈) + F_v q̇ + F_s sgn q̇                                  (D1, h_e = 0)
    forward_dynamics(model, data, q, qd, tau, h_e, qdd_out) -> 0 | 1 wrong length | 2 B not PD
        B(q) q̈ = τ − RNEA(q, q̇, 0) − F_v q̇ − F_s sgn q̇ − Jᵀ(q) h_e              (D1, D5)
        B from the CRBA (D2); Jᵀ h_e = RNEA(q, 0, 0) with gravity off and h_e on (the
        recursion is linear in h_e, and with q̇ = q̈ = 0, g_0 = 0 nothing else is left), only
        evaluated when h_e ≠ 0; the LDLᵀ solve of the Lagrange modules, whose entries
        B_ij ≡ 0 generate no code
    kinetic_energy(model, data, q, qd) -> T = ½ q̇ᵀ B(q) q̇                     (D6)
    mass_matrix(model, data, q, B_out) -> 0 | 1 wrong length  B(q) by the CRBA  (D2)
    checked_inverse_dynamics(model, data, q, qd, qdd, tau_out) -> 0 | 1 wrong length

The model and data are ignored (the numbers are in the code).  ``armlab.specialise.closed_form``
writes the module to its cache folder, compiles it with numba (``cache=True``) and checks it
against the numeric RNEA before use.
"""

from __future__ import annotations

import math
import types

import numpy as np

from armlab.kernels import dynamics as _dynamics
from armlab.model.robot import Robot, RobotArrays

# No text of the robot file enters the source (its name could close the docstring and run
# code): the module is named by the key, a hex digest, alone.
HEADER = '''"""Dynamics of a robot specialised to its numbers by armlab.specialise.traced (the numeric
kernels partially evaluated).  Key {key}.  Do not edit: regenerated when the robot, the kernels
or the generator change."""
import math

from numba import njit


'''
# Products feeding sums may be fused into one multiply-add (one rounding instead of two: results
# move in the last bit): the code is long chains of them, and the forward dynamics of a 6-joint
# arm runs ~15% faster.
DECORATOR = "@njit(cache=True, fastmath={'contract'})"
# Entries of a rotation, a position, a centre of mass or an off-diagonal inertia product that
# are this small relative to the rest of their link's block are rounding residue of the
# model's construction (cos(π/2) = 6.1e-17, not 0): they are set to 0 (±1 for rotations)
# before tracing so that the structure folds.  The results move by about this relative amount.
SNAP = 1e-14


class TracedBranch(TypeError):
    """The traced code took a decision on a value that is only known at run time."""


class _Tape:
    """The straight-line program being recorded: lines (name, text, names it reads)."""

    def __init__(self):
        self.lines: list[tuple[str, str, tuple[str, ...]]] = []
        self.memo: dict[tuple[str, str, str], str] = {}

    def input(self, name: str, text: str) -> _Value:
        self.lines.append((name, text, ()))
        return _Value(self, name)

    def op(self, symbol: str, a, b, negative: bool) -> _Value:
        """±(|a| symbol |b|); ``a``, ``b`` are (text, name or None) of magnitudes."""
        if symbol in "+*" and b[0] < a[0]:
            a, b = b, a                       # commutative: one line for a∘b and b∘a
        key = (symbol, a[0], b[0])
        name = self.memo.get(key)
        if name is None:
            name = self.memo[key] = f"t{len(self.memo)}"
            deps = tuple(x[1] for x in (a, b) if x[1] is not None)
            self.lines.append((name, f"{a[0]} {symbol} {b[0]}", deps))
        return _Value(self, name, negative)

    def call(self, function: str, x: _Value, negative: bool) -> _Value:
        key = (function, x.name, "")
        name = self.memo.get(key)
        if name is None:
            name = self.memo[key] = f"t{len(self.memo)}"
            self.lines.append((name, f"{function}({x.name})", (x.name,)))
        return _Value(self, name, negative)


def _parts(x) -> tuple[bool, tuple[str, str | None]]:
    """(negative?, (text, name read)) of a value's magnitude."""
    if isinstance(x, _Value):
        return x.negative, (x.name, x.name)
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"non-finite robot number {x} in the traced dynamics")
    return math.copysign(1.0, x) < 0.0, (repr(abs(x)), None)


def _tape(a, b) -> _Tape:
    return a.tape if isinstance(a, _Value) else b.tape


def _add(a, b):
    known_a, known_b = not isinstance(a, _Value), not isinstance(b, _Value)
    if known_a and known_b:
        return a + b
    if known_a and a == 0.0:
        return b
    if known_b and b == 0.0:
        return a
    (na, ta), (nb, tb) = _parts(a), _parts(b)
    if na == nb:                             # ±(|a| + |b|)
        return _tape(a, b).op("+", ta, tb, na)
    if nb:                                   # |a| − |b|
        return _tape(a, b).op("-", ta, tb, False)
    return _tape(a, b).op("-", tb, ta, False)


def _mul(a, b):
    known_a, known_b = not isinstance(a, _Value), not isinstance(b, _Value)
    if known_a and known_b:
        return a * b
    for c, x, known in ((a, b, known_a), (b, a, known_b)):
        if known:
            if c == 0.0:
                return 0.0   # x finite: the states a robot is simulated in
            if c == 1.0:
                return x
            if c == -1.0:
                return -x
    (na, ta), (nb, tb) = _parts(a), _parts(b)
    return _tape(a, b).op("*", ta, tb, na != nb)


def _div(a, b):
    known_a, known_b = not isinstance(a, _Value), not isinstance(b, _Value)
    if known_a and known_b:
        return a / b
    if known_b and abs(b) == 1.0:
        return a if b > 0.0 else -a
    if known_a and a == 0.0:
        return 0.0
    (na, ta), (nb, tb) = _parts(a), _parts(b)
    return _tape(a, b).op("/", ta, tb, na != nb)


class _Value:
    """A number known only at run time: the name of the line computing its magnitude and a
    sign.  Arithmetic records lines on the tape; numpy calls ``.cos()``/``.sin()`` for
    ``np.cos``/``np.sin`` of an object; comparisons and truth tests raise."""

    __slots__ = ("tape", "name", "negative")
    __hash__ = None

    def __init__(self, tape: _Tape, name: str, negative: bool = False):
        self.tape, self.name, self.negative = tape, name, negative

    def __neg__(self):
        return _Value(self.tape, self.name, not self.negative)

    def __pos__(self):
        return self

    def __add__(self, other):
        return _add(self, other)

    def __radd__(self, other):
        return _add(other, self)

    def __sub__(self, other):
        return _add(self, -other)

    def __rsub__(self, other):
        return _add(other, -self)

    def __mul__(self, other):
        return _mul(self, other)

    def __rmul__(self, other):
        return _mul(other, self)

    def __truediv__(self, other):
        return _div(self, other)

    def __rtruediv__(self, other):
        return _div(other, self)

    # cos is even and sin odd, exactly, in IEEE libm implementations: the sign stays outside.
    def cos(self):
        return self.tape.call("math.cos", self, False)

    def sin(self):
        return self.tape.call("math.sin", self, self.negative)

    def _branch(self, *_):
        raise TracedBranch(f"a branch on the run-time value {self.name}: handle it explicitly")

    __bool__ = __lt__ = __le__ = __gt__ = __ge__ = __eq__ = __ne__ = _branch

    def __repr__(self):
        return ("-" if self.negative else "") + self.name


def _text(x) -> str:
    """Source of a value: its (signed) name or its constant."""
    return repr(x) if isinstance(x, _Value) else repr(float(x))


def _minus(x) -> str:
    """`` - x`` as source (empty for 0)."""
    if not isinstance(x, _Value):
        return "" if x == 0.0 else (f" - {float(x)!r}" if x > 0.0 else f" + {-float(x)!r}")
    return f" {'+' if x.negative else '-'} {x.name}"


def _zero(x) -> bool:
    return not isinstance(x, _Value) and x == 0.0


def _live(lines, roots: set[str]) -> tuple[list[str], set[str]]:
    """Source of the lines some root depends on (in order), and every name they read."""
    needed, kept = set(roots), []
    for name, text, deps in reversed(lines):
        if name in needed:
            needed.update(deps)
            kept.append(f"    {name} = {text}")
    return kept[::-1], needed


def _names(values) -> set[str]:
    return {v.name for v in values if isinstance(v, _Value)}


def _snapped(arrays: RobotArrays) -> RobotArrays:
    """The robot's numbers as object arrays of Python floats, rounding residue removed (SNAP)."""
    fields = {}
    for name, value in zip(arrays._fields, arrays, strict=True):
        if name == "joint_type":
            fields[name] = np.asarray(value)
            continue
        value = np.array(value, dtype=float)
        if name in ("tree_R", "tree_p", "com", "inertia", "tool_R", "tool_p", "gravity"):
            per_link = name in ("tree_R", "tree_p", "com", "inertia")
            blocks = np.abs(value.reshape(len(value) if per_link else 1, -1))
            small = (blocks <= SNAP * blocks.max(axis=1, keepdims=True)).reshape(value.shape)
            if name == "inertia":          # principal moments are never residue
                small &= ~np.eye(3, dtype=bool)
            value[small] = 0.0
            if name.endswith("_R"):
                unit = np.abs(np.abs(value) - 1.0) <= SNAP
                value[unit] = np.sign(value[unit])
        fields[name] = np.array(value.tolist(), dtype=object)
    return RobotArrays(**fields)


def _python_kernels() -> dict:
    """The dynamics kernels as plain Python functions calling each other's Python bodies (a
    kernel's ``py_func`` alone would still call the compiled helpers, which refuse objects).
    The wrench test answers True: a traced wrench is known only at run time."""
    namespace = dict(vars(_dynamics))
    for name, value in list(namespace.items()):
        body = getattr(value, "py_func", None)
        if isinstance(body, types.FunctionType):
            namespace[name] = types.FunctionType(body.__code__, namespace, body.__name__,
                                                 body.__defaults__, body.__closure__)
    namespace["_has_wrench"] = lambda h_e: True
    return namespace


def _objects(shape) -> np.ndarray:
    return np.full(shape, 0.0, dtype=object)


class _Tracer:
    """The Python kernels over one robot's numbers and scratch arrays of objects."""

    def __init__(self, robot: Robot):
        self.n = robot.n
        self.m = _snapped(robot.arrays)
        # Friction is written out per joint (its sign test is a run-time branch).
        self.rigid = self.m._replace(viscous=_objects(self.n), coulomb=_objects(self.n))
        self.kernels = _python_kernels()
        self.rnea_kernel, self.crba = self.kernels["rnea_inline"], self.kernels["mass_matrix_into"]
        # The field shapes of the kernels' own workspace, whatever its layout.
        workspace = _dynamics.make_workspace(self.n)
        self.ws = type(workspace)(*(_objects(a.shape) for a in workspace))

    def inputs(self, tape: _Tape, array: str, prefix: str, count: int) -> np.ndarray:
        values = [tape.input(f"{prefix}{i}", f"{array}[{i}]") for i in range(count)]
        out = _objects(count)
        out[:] = values
        return out

    def mass_matrix(self, q) -> np.ndarray:
        """B(q) by the CRBA."""
        B = _objects((self.n, self.n))
        self.crba(self.m, self.ws, q, B)
        return B

    def rnea(self, q, qd, qdd, gravity_scale, h_e=None) -> np.ndarray:
        """RNEA without friction (the wrench term only with ``h_e``).  The joint transforms
        are traced anew: the tape's memo returns the lines it has already."""
        tau = _objects(self.n)
        self.rnea_kernel(self.rigid, self.ws, q, qd, qdd, gravity_scale, h_e, tau)
        return tau


def _friction(arrays: RobotArrays) -> tuple[list[str], list[str]]:
    """(lines f{i} = F_v q̇_i + F_s sgn q̇_i, the term ' + f{i}' or '' per joint), as
    the numeric kernels compute them (sgn(0) = 0)."""
    lines, terms = [], []
    for i, (viscous, coulomb) in enumerate(zip(arrays.viscous, arrays.coulomb, strict=True)):
        viscous, coulomb = float(viscous), float(coulomb)
        parts = ([f"{viscous!r}*qd[{i}]"] if viscous else []) + (
            [f"({coulomb!r} if qd[{i}] > 0.0 else (-{coulomb!r} if qd[{i}] < 0.0 else 0.0))"]
            if coulomb else [])
        if parts:
            lines.append(f"    f{i} = " + " + ".join(parts))
        terms.append(f" + f{i}" if parts else "")
    return lines, terms


def _ldl_solve(n: int, zero, rhs: list[str]) -> list[str]:
    """Lines solving B x = rhs by B = L D Lᵀ (L unit lower), B's entries in ``b{i}_{j}``;
    ``zero(i, j)`` says B_ij ≡ 0.  Writes x{i}; returns 2 if a pivot D_j ≤ 0."""
    lines = []
    nonzero_L = {}
    for j in range(n):
        terms = [f"L{j}_{k}*L{j}_{k}*D{k}" for k in range(j) if nonzero_L.get((j, k))]
        lines.append(f"    D{j} = b{j}_{j}" + "".join(f" - {t}" for t in terms))
        lines.append(f"    if not D{j} > 0.0:\n        return 2")
        for i in range(j + 1, n):
            products = [f"L{i}_{k}*L{j}_{k}*D{k}" for k in range(j)
                        if nonzero_L.get((i, k)) and nonzero_L.get((j, k))]
            if zero(i, j) and not products:
                continue
            nonzero_L[(i, j)] = True
            head = "0.0" if zero(i, j) else f"b{i}_{j}"
            lines.append(f"    L{i}_{j} = ({head}" + "".join(f" - {t}" for t in products) + f") / D{j}")
    for i in range(n):
        terms = [f"z{k}*L{i}_{k}" for k in range(i) if nonzero_L.get((i, k))]
        lines.append(f"    z{i} = {rhs[i]}" + "".join(f" - {t}" for t in terms))
    for i in range(n - 1, -1, -1):
        terms = [f"x{k}*L{k}_{i}" for k in range(i + 1, n) if nonzero_L.get((k, i))]
        lines.append(f"    x{i} = z{i} / D{i}" + "".join(f" - {t}" for t in terms))
    return lines


def mass_matrix_lines(n: int, body: list[str], entries: list[str]) -> list[str]:
    """``mass_matrix(model, data, q, B_out)``: ``body`` computes the n² row-major ``entries``."""
    return ["@njit(cache=True)", "def mass_matrix(model, data, q, B_out):",
            '    """B(q) (D2); 1 for a wrong length."""',
            f"    if q.shape[0] != {n} or B_out.shape[0] != {n} or B_out.shape[1] != {n}:",
            "        return 1", *body,
            *[f"    B_out[{i}, {j}] = {entries[n * i + j]}" for i in range(n) for j in range(n)],
            "    return 0"]


def checked_inverse_lines(n: int) -> list[str]:
    """``checked_inverse_dynamics``: the module's ``inverse_dynamics`` after a length check."""
    return ["@njit(cache=True)",
            "def checked_inverse_dynamics(model, data, q, qd, qdd, tau_out):",
            '    """inverse_dynamics for calls from Python; 1 for a wrong length."""',
            f"    if (q.shape[0] != {n} or qd.shape[0] != {n} or qdd.shape[0] != {n}"
            f" or tau_out.shape[0] != {n}):",
            "        return 1",
            "    inverse_dynamics(model, data, q, qd, qdd, tau_out)",
            "    return 0"]


def traced_source(robot: Robot, *, key: str) -> str:
    """Source of the module (interface in the module docstring) for ``robot``."""
    n = robot.n
    tracer = _Tracer(robot)
    friction, plus_f = _friction(robot.arrays)
    zeros = _objects(n)

    # Inverse dynamics.
    tape = _Tape()
    q, qd = tracer.inputs(tape, "q", "q", n), tracer.inputs(tape, "qd", "qd", n)
    qdd = tracer.inputs(tape, "qdd", "qdd", n)
    tau = tracer.rnea(q, qd, qdd, 1.0)
    body, _ = _live(tape.lines, _names(tau))
    inverse = [DECORATOR, "def inverse_dynamics(model, data, q, qd, qdd, tau_out):",
               '    """τ = B q̈ + C q̇ + g + F_v q̇ + F_s sgn q̇ (D1, h_e = 0)."""', *body, *friction,
               *[f"    tau_out[{i}] = {_text(tau[i])}{plus_f[i]}" for i in range(n)]]

    # Forward dynamics: B and the bias always, Jᵀ h_e in its own block.
    tape = _Tape()
    q, qd = tracer.inputs(tape, "q", "q", n), tracer.inputs(tape, "qd", "qd", n)
    B = tracer.mass_matrix(q)
    bias = tracer.rnea(q, qd, zeros, 1.0)
    # Jᵀ h_e on a tape of its own: its lines run only when h_e ≠ 0, so none of the main body
    # may reuse them (nothing is traced after it).
    main, tape.lines = tape.lines, []
    h_e = tracer.inputs(tape, "h_e", "h", 6)
    wrench = tracer.rnea(q, zeros, zeros, 0.0, h_e)
    block = tape.lines
    lower = [(i, j) for i in range(n) for j in range(i + 1)]
    block_lines, needed = _live(block, _names(wrench))
    main_lines, _ = _live(main, needed | _names(bias) | _names(B[i, j] for i, j in lower))
    wrench_lines = [f"    {line}" for line in block_lines] + [
        f"        r{i} -= {_text(wrench[i])}" for i in range(n) if not _zero(wrench[i])]
    forward = [DECORATOR, "def forward_dynamics(model, data, q, qd, tau, h_e, qdd_out):",
               '    """q̈ of B q̈ = τ − C q̇ − g − F_v q̇ − F_s sgn q̇ − Jᵀ h_e (D1, D5); 1 for a wrong'
               ' length, 2 if B is not PD."""',
               f"    if (q.shape[0] != {n} or qd.shape[0] != {n} or tau.shape[0] != {n}"
               f" or h_e.shape[0] != 6 or qdd_out.shape[0] != {n}):",
               "        return 1",
               *main_lines,
               # A diagonal entry ≡ 0 is still written: the solve then returns 2 (not PD).
               *[f"    b{i}_{j} = {_text(B[i, j])}" for i, j in lower if i == j or not _zero(B[i, j])],
               *friction,
               *[f"    r{i} = tau[{i}]{_minus(bias[i])}{plus_f[i].replace('+', '-')}" for i in range(n)]]
    if len(wrench_lines) > len(block_lines):
        forward += ["    if (h_e[0] != 0.0 or h_e[1] != 0.0 or h_e[2] != 0.0 or h_e[3] != 0.0"
                    " or h_e[4] != 0.0 or h_e[5] != 0.0):", *wrench_lines]
    forward += [*_ldl_solve(n, lambda i, j: _zero(B[i, j]), [f"r{i}" for i in range(n)]),
                *[f"    qdd_out[{i}] = x{i}" for i in range(n)], "    return 0"]

    # Kinetic energy ½ q̇ᵀ B q̇ = ½ Σ_i q̇_i (B_ii q̇_i + 2 Σ_{j<i} B_ij q̇_j).
    tape = _Tape()
    q, qd = tracer.inputs(tape, "q", "q", n), tracer.inputs(tape, "qd", "qd", n)
    B = tracer.mass_matrix(q)
    total = 0.0
    for i in range(n):
        row = B[i, i] * qd[i]
        for j in range(i):
            row = row + 2.0 * (B[i, j] * qd[j])
        total = total + qd[i] * row
    energy = 0.5 * total
    body, _ = _live(tape.lines, _names([energy]))
    kinetic = [DECORATOR, "def kinetic_energy(model, data, q, qd):",
               '    """T = ½ q̇ᵀ B q̇ (D6) [J]; NaN for a wrong length."""',
               f"    if q.shape[0] != {n} or qd.shape[0] != {n}:", "        return math.nan",
               *body, f"    return {_text(energy)}"]
    # B(q) on its own.
    tape = _Tape()
    q = tracer.inputs(tape, "q", "q", n)
    B = tracer.mass_matrix(q)
    entries = [B[i, j] for i in range(n) for j in range(n)]
    body, _ = _live(tape.lines, _names(entries))
    mass = mass_matrix_lines(n, body, [_text(value) for value in entries])
    return (HEADER.format(key=key) + "\n".join(inverse) + "\n\n\n" + "\n".join(forward)
            + "\n\n\n" + "\n".join(kinetic) + "\n\n\n" + "\n".join(mass) + "\n\n\n"
            + "\n".join(checked_inverse_lines(n)) + "\n")
