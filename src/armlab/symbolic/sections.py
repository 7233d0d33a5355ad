"""The seed's chain A1–A5 as structured data: sections of (label, SymPy expression) items.

:func:`derive` is what ``armlab derive`` prints and what a report renders (for instance as
MathML with :func:`armlab.symbolic.render.to_mathml`).  Every label exists as Unicode text
(``Item.label``) and as LaTeX (``Item.tex``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import sympy as sp

from armlab.model.robot import Robot
from armlab.symbolic import energy, kinematics, lagrange, newton_euler, operational
from armlab.symbolic.budget import bounded_parts, call_within
from armlab.symbolic.compact import compact_dynamics
from armlab.symbolic.model import SymbolicRobot, symbolic_robot
from armlab.symbolic.simplify import compact_matrix, count_ops

ASSIGNMENTS = ("A1", "A2", "A3", "A4", "A5")
TITLES = {
    "A1": "DH tables, direct and inverse kinematics, Jacobians",
    "A2": "Steiner, inertia tensors, partial Jacobians, kinetic and potential energy, B(q)",
    "A3": "Lagrangian, equations of motion, C(q, q̇) by Christoffel symbols, g(q)",
    "A4": "Recursive Newton–Euler; B, C q̇, g from NE and their identity with Lagrange",
    "A5": "Dynamic model in operational space",
}
_SUB = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")


class Item(tuple):
    """One result, a ``(label, expr)`` pair (Unicode label, SymPy object) that also carries
    its LaTeX label as ``tex``."""

    def __new__(cls, label: str, expr, tex: str = ""):
        item = super().__new__(cls, (label, expr))
        item.tex = tex or label
        return item

    @property
    def label(self) -> str:
        return self[0]

    @property
    def expr(self):
        return self[1]


@dataclass
class Section:
    """One assignment's results.  ``complete`` is False when its ``budget`` [s] ran out (a
    note then says what was skipped)."""

    key: str
    title: str
    items: list[Item] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    complete: bool = True
    budget: float | None = field(default=None, repr=False)

    def add(self, label: str, expr, tex: str) -> None:
        if isinstance(expr, sp.MatrixBase):
            expr = sp.ImmutableMatrix(expr)
        self.items.append(Item(label, sp.sympify(expr), tex))

    @property
    def assignment(self) -> int:
        """The seed assignment number (1 for A1, …)."""
        return int(self.key[1:])

    def pairs(self) -> list[tuple[str, sp.Basic]]:
        """[(label, expr), …]."""
        return [(item.label, item.expr) for item in self.items]

    def _repr_html_(self) -> str:
        """The section in a notebook: each item as presentation MathML (``armlab.display``)."""
        from armlab.display import section_html
        from armlab.symbolic.render import to_mathml

        return section_html(self, to_mathml)

    def _repr_latex_(self) -> str:
        """The section as LaTeX display math, one aligned row per item."""
        from armlab.symbolic.render import _equation

        rows = r" \\ ".join("& " + _equation(item, False) for item in self.items)
        return rf"$$\begin{{aligned}} {rows} \end{{aligned}}$$"


def _T(i, j) -> tuple[str, str]:
    """Label of T_i^j (frame i seen from frame j) in Unicode and LaTeX."""
    return f"T{str(i).translate(_SUB)}^{j}", f"T_{{{i}}}^{{{j}}}"


def _a1(s: Section, sr: SymbolicRobot, frame: str) -> Section:
    """A1 in Σ_0 and, for ``frame="base"``, in Σ_base as well (as the seed does: its later
    assignments use the Σ_0 results): transforms, inverse kinematics and Jacobians of each."""
    K = kinematics
    # Σ_0 first: the seed's later assignments all use it.
    frames = ("0", "base") if frame == "base" else ("0",)
    for table_frame in ("0", "base"):
        table = K.dh_table(sr, table_frame)
        if table is not None and (table_frame == "0" or sr.base_dh is not None):
            where = "Σ₀" if table_frame == "0" else "Σ_base"
            s.add(f"DH table from {where} (a, α, d, θ)", table,
                  rf"\text{{DH}}_{{\Sigma_{{{table_frame}}}}}\;(a,\ \alpha,\ d,\ \theta)")
    if sr.base != sp.eye(4):
        s.add("T₀^base", sr.base, r"T_{0}^{\mathrm{base}}")
    for i, A in enumerate(K.relative_transforms(sr), start=1):
        label, tex = _T(i, i - 1)
        s.add(label, A, tex)
    for f in frames:
        for i, T in enumerate(K.link_transforms(sr, f), start=1):
            if i == 1 and f == "0":
                continue  # T_1^0 is the first relative transform above
            label, tex = _T(i, f)
            s.add(label, T, tex.replace("{base}", r"{\mathrm{base}}"))
        if sr.tool != sp.eye(4):
            label, tex = _T("e", f)
            s.add(label, K.end_effector_pose(sr, f), tex.replace("{base}", r"{\mathrm{base}}"))
        else:
            s.notes.append(f"Σ_e = Σ_{sr.n}: the end-effector pose is T{str(sr.n).translate(_SUB)}^{f}.")
    for f in frames:
        _a1_in_frame(s, sr, f, IK_SHARE / len(frames))
    return s


def _a1_in_frame(s: Section, sr: SymbolicRobot, frame: str, ik_share: float) -> None:
    """A1's inverse kinematics and Jacobians in Σ_``frame``, each labelled with its frame."""
    K = kinematics
    where = r"\mathrm{base}" if frame == "base" else "0"
    solutions = _inverse_kinematics(s, sr, frame, ik_share)
    for k, branch in enumerate(solutions or [], start=1):
        lhs = sp.Matrix(list(branch))
        s.add(f"IK branch {k} (p_e = (p_x, p_y, p_z) in Σ_{frame})",
              sp.Eq(lhs, sp.Matrix(list(branch.values())), evaluate=False),
              rf"\text{{IK, branch {k}}}\ (\Sigma_{{{where}}})")
    if sr.n <= 3 and solutions == []:
        s.notes.append(f"No closed-form inverse kinematics found for the position equations in Σ_{frame}.")
    s.add(f"J (geometric, Σ_{frame})", K.geometric_jacobian(sr, frame), rf"J^{{{where}}}")
    if _large(sr):
        J_A, T_inv = K.analytical_jacobian_formula(sr, frame)
        if "T(φ)⁻¹ (ZYZ)" not in [item.label for item in s.items]:  # the same in both frames
            s.add("T(φ)⁻¹ (ZYZ)", T_inv, r"T^{-1}(\phi)")
        s.add(f"J_A = blockdiag(I, T(φ)⁻¹) J (Σ_{frame})", J_A, rf"J_A^{{{where}}}")
        return
    J_A, phi = K.analytical_jacobian(sr, frame)
    s.add(f"φ_e (ZYZ of R_e in Σ_{frame})", phi, rf"\phi_e^{{{where}}}")
    s.add(f"J_A (analytical, ZYZ, Σ_{frame})", J_A, rf"J_A^{{{where}}}")


def _inverse_kinematics(s: Section, sr: SymbolicRobot, frame: str,
                        share: float | None = None) -> list[dict] | None:
    """The closed-form position IK in Σ_``frame`` within ``share`` (default :data:`IK_SHARE`)
    of the section's budget (SymPy's polynomial solver is the step whose cost explodes first);
    None, with a note, past it."""
    share = IK_SHARE if share is None else share
    seconds = None if s.budget is None else max(share * s.budget, 0.1)
    finished, solutions = call_within(seconds, kinematics.position_inverse_kinematics, sr, frame,
                                      load=load_unevaluated)
    if finished:
        return solutions
    s.notes.append(f"Closed-form inverse kinematics skipped: SymPy's polynomial solver did not finish "
                   f"within {seconds:.3g} s (its share of the A1 budget) on the position equations "
                   f"in Σ_{frame}; use armlab's numeric IK.")
    return None


def load_unevaluated(data: bytes):
    """Unpickle SymPy objects as they were built: a pickled ``Mul(-1, Add(…))`` left unevaluated
    on purpose (to print −(…)) would otherwise come back evaluated, its sign distributed."""
    import pickle

    with sp.evaluate(False):
        return pickle.loads(data)


IK_SHARE = 0.4
"""Share of A1's budget that the closed-form inverse kinematics may use, so that the Jacobians
after it are still derived when the solver gives up (split evenly between Σ_0 and Σ_base when
A1 is derived in both)."""

DEFAULT_BUDGET = 60.0
"""Seconds of wall-clock time each assignment of :func:`derive` may take by default: the
bundled robots need at most a few (the PRP about 2 s per assignment, the Puma560 about 6), an
arm with non-round parameters can take hours."""

LARGE = 3
"""Robots with more joints than this take the recursive route (:mod:`compact`) for B, C, g
and skip the per-link energies, the Lagrange ≡ NE proof and A5, whose expressions explode."""


def _large(sr: SymbolicRobot) -> bool:
    return sr.n > LARGE


@lru_cache(maxsize=8)
def _compact(sr: SymbolicRobot):
    return compact_dynamics(sr)


def _a2(s: Section, sr: SymbolicRobot) -> Section:
    E = energy
    lhs, rhs, difference = E.steiner_identity()
    s.add("I_C + m Sᵀ(r) S(r)", lhs, r"I_C + m S^T(r) S(r)")
    s.add("I_C + m (rᵀr I − r rᵀ)", rhs, r"I_C + m (r^T r I_3 - r r^T)")
    s.add("difference", difference, r"\Delta")
    for i, link in enumerate(sr.links):
        k = i + 1
        shape = f" ({link.shape})" if link.shape else ""
        sub = str(k).translate(_SUB)
        s.add(f"I_C{sub} — {link.name}{shape}, axes of Σ{sub}", link.inertia, rf"I_{{C_{{{k}}}}}")
        s.add(f"I_O{sub} — about Σ{sub}'s origin (Steiner)", E.inertia_about_origin(sr, i),
              rf"I_{{O_{{{k}}}}}")
    for i, p in enumerate(E.com_positions(sr), start=1):
        s.add(f"p_C{i}".translate(_SUB) + " (Σ₀)", p, rf"p_{{C_{{{i}}}}}")
    for i, (J_P, J_O) in enumerate(E.partial_jacobians(sr), start=1):
        s.add(f"J_P^ℓ{i}".translate(_SUB), J_P, rf"J_P^{{\ell_{{{i}}}}}")
        s.add(f"J_O^ℓ{i}".translate(_SUB), J_O, rf"J_O^{{\ell_{{{i}}}}}")
    if _large(sr):
        B = _compact(sr).B
        s.add("B(q)", B, r"B(q)")
        for i, U in enumerate(E.potential_energies(sr), start=1):
            s.add(f"U_ℓ{i}".translate(_SUB), U, rf"\mathcal{{U}}_{{\ell_{{{i}}}}}")
        s.notes.append(f"{sr.n} joints: B by Newton–Euler over a polynomial ring (N3), the "
                       f"per-link energies are not expanded; count_ops(B) = {count_ops(B)}")
        return s
    links, rotors = E.kinetic_energies(sr)
    for i, T in enumerate(links, start=1):
        s.add(f"T_ℓ{i}".translate(_SUB), T, rf"\mathcal{{T}}_{{\ell_{{{i}}}}}")
    for i, T in enumerate(rotors, start=1):
        if T != 0:
            s.add(f"T_m{i}".translate(_SUB), T, rf"\mathcal{{T}}_{{m_{{{i}}}}}")
    s.add("T", E.kinetic_energy(sr), r"\mathcal{T}")
    B = E.inertia_matrix(sr)
    s.add("B(q)", B, r"B(q)")
    for i, U in enumerate(E.potential_energies(sr), start=1):
        s.add(f"U_ℓ{i}".translate(_SUB), U, rf"\mathcal{{U}}_{{\ell_{{{i}}}}}")
    s.add("U", E.potential_energy(sr), r"\mathcal{U}")
    s.notes.append(f"count_ops(B) = {count_ops(B)}")
    return s


def _a3(s: Section, sr: SymbolicRobot) -> Section:
    L = lagrange
    if _large(sr):
        result = _compact(sr)
        s.add("C(q, q̇)", result.C, r"C(q, \dot q)")
        s.add("g(q)", result.g, r"g(q)")
        s.notes.append(f"{sr.n} joints: C = ½ ∂(C q̇)/∂q̇ and g from Newton–Euler over a polynomial "
                       f"ring (N3); count_ops: B {result.ops['B']}, C {result.ops['C']}, "
                       f"g {result.ops['g']}, all three with shared subexpressions {result.ops_cse}")
        return s
    s.add("ℒ = T − U", L.lagrangian(sr), r"\mathcal{L}")
    s.add("τ = d/dt(∂ℒ/∂q̇)ᵀ − (∂ℒ/∂q)ᵀ + F_v q̇ + F_s sgn q̇", L.equations_of_motion(sr), r"\tau")
    C, g = L.coriolis_matrix(sr), L.gravity_vector(sr)
    s.add("C(q, q̇)", C, r"C(q, \dot q)")
    s.add("g(q)", g, r"g(q)")
    N, symmetric_part = L.skew_check(sr)
    s.add("N = Ḃ − 2C", N, r"N = \dot B - 2C")
    s.add("N + Nᵀ", symmetric_part, r"N + N^T")
    s.notes.append(f"count_ops: B {count_ops(energy.inertia_matrix(sr))}, C {count_ops(C)}, "
                   f"g {count_ops(g)}")
    return s


def _a4(s: Section, sr: SymbolicRobot) -> Section:
    N = newton_euler
    for i, A in enumerate(kinematics.relative_transforms(sr), start=1):
        label, tex = _T(i, i - 1)
        s.add(label, A, tex)
    if _large(sr):
        result = _compact(sr)
        s.add("B = ∂τ/∂q̈", result.B, r"B = \partial\tau/\partial\ddot q")
        s.add("C q̇", compact_matrix(result.C * sr.qd, kinematics.angles(sr)), r"C\dot q")
        s.add("g = τ(q, 0, 0; g₀)", result.g, r"g = NE(q, 0, 0; g_0)")
        s.notes.append(f"{sr.n} joints: one Newton–Euler pass over a polynomial ring gives τ, read off "
                       "as B, C q̇, g (N3); the symbolic identity with Lagrange is proven on smaller "
                       "arms (tests).")
        return s
    full = N.full_equations(sr)
    for i in range(sr.n):
        k = i + 1
        s.add(f"ω{k}^{k}".translate(_SUB), full.omega[i], rf"\omega_{{{k}}}^{{{k}}}")
        s.add(f"ω̇{k}^{k}".translate(_SUB), full.omega_dot[i], rf"\dot\omega_{{{k}}}^{{{k}}}")
        s.add(f"p̈_C{k}^{k} − g₀".translate(_SUB), full.acc_com[i], rf"\ddot p_{{C_{{{k}}}}}^{{{k}}} - g_0")
        s.add(f"f{k}^{k}".translate(_SUB), full.force[i], rf"f_{{{k}}}^{{{k}}}")
    s.add("τ = NE(q, q̇, q̈; g₀)", full.tau, r"\tau = NE(q, \dot q, \ddot q; g_0)")
    B_ne, Cqd_ne, g_ne = N.inertia_matrix_ne(sr), N.coriolis_vector_ne(sr), N.gravity_vector_ne(sr)
    s.add("B = [NE(q, 0, e_i; 0)]", B_ne, r"B = [NE(q, 0, e_i; 0)]_i")
    s.add("C q̇ = NE(q, q̇, 0; 0)", Cqd_ne, r"C\dot q = NE(q, \dot q, 0; 0)")
    s.add("g = NE(q, 0, 0; g₀)", g_ne, r"g = NE(q, 0, 0; g_0)")
    ang = kinematics.angles(sr)
    s.add("B_NE − B_Lagrange", compact_matrix(B_ne - energy.inertia_matrix(sr), ang),
          r"B_{NE} - B_{\mathcal{L}}")
    s.add("(C q̇)_NE − C_Christoffel q̇",
          compact_matrix(Cqd_ne - lagrange.coriolis_matrix(sr) * sr.qd, ang),
          r"(C\dot q)_{NE} - C_{\mathcal{L}}\dot q")
    s.add("g_NE − g_Lagrange", compact_matrix(g_ne - lagrange.gravity_vector(sr), ang),
          r"g_{NE} - g_{\mathcal{L}}")
    s.add("τ_NE − τ_Lagrange", compact_matrix(full.tau - lagrange.equations_of_motion(sr), ang),
          r"\tau_{NE} - \tau_{\mathcal{L}}")
    s.notes.append("Quantities of link i in its frame Σ_i; the base accelerates by −g₀, so p̈_C − g₀ "
                   "is shown.")
    return s


def _a5(s: Section, sr: SymbolicRobot, frame: str) -> Section:
    T_A, _ = operational.euler_rate_matrix()
    s.add("T_A(φ) (ZYZ)", T_A, r"T_A(\phi)")
    if _large(sr):
        s.notes.append(f"{sr.n} joints: B_A = J_A⁻ᵀ B J_A⁻¹ needs the symbolic inverse of a "
                       f"{sr.n}×{sr.n} J_A; evaluate it numerically (armlab's operational-space "
                       "functions) instead.")
        return s
    model = operational.operational_model(sr, frame)
    if model is None:
        s.notes.append("The task rows do not give a square, generically invertible J_A.")
        return s
    labels = [operational.TASK_LABELS[k] for k in model.rows]
    s.notes.append(f"Task coordinates x = ({', '.join(labels)}) in Σ_{frame}: the rows of J_A that "
                   "a robot with this many joints can control.")
    s.add("J_A (task rows)", model.J_A, r"J_A")
    s.add("J_A⁻¹", model.J_inv, r"J_A^{-1}")
    s.add("T_A (task rows)", model.T_A, r"T_A")
    for symbol, value in model.definitions.items():
        s.add(str(symbol), value, sp.latex(symbol))
    s.add("B_A = J_A⁻ᵀ B J_A⁻¹", model.named["B_A"], r"B_A")
    s.add("C_A ẋ = J_A⁻ᵀ C q̇ − B_A J̇_A q̇", model.named["C_A_xd"], r"C_A \dot x")
    s.add("g_A = J_A⁻ᵀ g", model.named["g_A"], r"g_A")
    s.notes.append("b_ij, h_i = (C q̇)_i and g_i are the non-constant entries of B, C q̇ and g "
                   "(A2, A3); substituting them gives the full expressions.")
    return s


def derive(robot: Robot | SymbolicRobot, *, frame: str = "0", numeric: bool = False,
           only: str | None = None, budget: float | None = DEFAULT_BUDGET) -> list[Section]:
    """The A1–A5 derivations of ``robot`` (or just ``only``) as :class:`Section` objects.

    ``frame`` ("0" or "base") is the frame of the task coordinates of A5 and of the kinematic
    results of A1: with "base" A1 has its transforms, inverse kinematics and Jacobians in Σ_0
    and in Σ_base, each labelled with its frame (the seed computes both and uses Σ_0's in
    every later assignment).  Dynamics are always written with g_0 and velocities in Σ_0.
    ``numeric`` substitutes the parameter values.  Results are cached per symbolic robot, so
    deriving A3 after A2 reuses B.

    ``budget`` is the wall-clock time [s] each assignment may take (None: no limit).  An
    assignment stopped by it keeps the results derived so far, is marked ``complete=False``
    and says in one note what was skipped and why; the next assignment starts afresh.
    """
    if frame not in kinematics.FRAMES:
        raise ValueError(f"frame must be 'base' or '0', got {frame!r}")
    if only is not None and only not in ASSIGNMENTS:
        raise ValueError(f"unknown assignment {only!r} (use {', '.join(ASSIGNMENTS)})")
    if budget is not None and not budget > 0:
        raise ValueError(f"budget must be a positive number of seconds or None, got {budget!r}")
    sr = robot if isinstance(robot, SymbolicRobot) else symbolic_robot(robot, numeric=numeric)
    builders = {"A1": lambda s: _a1(s, sr, frame), "A2": lambda s: _a2(s, sr), "A3": lambda s: _a3(s, sr),
                "A4": lambda s: _a4(s, sr), "A5": lambda s: _a5(s, sr, frame)}
    keys = [only] if only else list(ASSIGNMENTS)
    sections = {key: Section(key, TITLES[key], budget=budget) for key in keys}

    def build(key, emit):
        """In the worker: the section's results and notes, sent one by one as they come."""
        streamed = _Streamed(key, TITLES[key], notes=_Notes(emit), budget=budget)
        streamed.emit = emit
        builders[key](streamed)

    for key, kind, value in bounded_parts(keys, build, budget, load=load_unevaluated):
        s = sections[key]
        if kind == "item":
            label, expr, tex, note = value
            if note is None:
                s.items.append(Item(label, expr, tex))
            else:
                s.notes.append(note)
        elif kind == "exceeded":
            s.complete = False
            where = f"after {s.items[-1].label}" if s.items else "before its first result"
            s.notes.append(f"{key} stopped after its budget of {budget:g} s, {where} ({len(s.items)} "
                           f"results): the rest of {key} is skipped, SymPy's expressions for this arm's "
                           f"parameters grow too large; every numeric result is computed without them.")
    return list(sections.values())


class _Notes(list):
    """A section's notes that are also sent on as they are written."""

    def __init__(self, emit):
        super().__init__()
        self.emit = emit

    def append(self, note: str) -> None:
        super().append(note)
        self.emit((None, None, None, note))


class _Streamed(Section):
    """A section being derived in a budget's worker: each result and note is sent to the
    caller as soon as it exists, so that a section stopped by its budget keeps them."""

    emit = None

    def add(self, label: str, expr, tex: str) -> None:
        super().add(label, expr, tex)
        item = self.items[-1]
        self.emit((item.label, item.expr, item.tex, None))
