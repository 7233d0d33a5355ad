"""Rendering of derivation sections: Unicode text, LaTeX, Markdown (with LaTeX math), MathML.

Symbols are printed with their display names: ``thetadot_2`` → θ̇₂ / ``\\dot{\\theta}_{2}``,
``m_Link4`` → m_Link4 / ``m_{Link4}``.  With ``numeric`` the exact rationals of the robot's
values are shown as decimals.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import sympy as sp
from sympy.printing.conventions import split_super_sub
from sympy.printing.mathml import mathml
from sympy.printing.pretty.pretty_symbology import pretty_symbol

if TYPE_CHECKING:  # a section displays itself with this module's printers
    from armlab.symbolic.sections import Section

FORMATS = ("text", "latex", "markdown")


def _numeric(expr, numeric: bool):
    """Decimal display of numbers: every non-integer rational with ``numeric``, else only the
    decimal fractions of the robot file (981/100 → 9.81), keeping ½, ⅓… exact."""
    table = {}
    for r in expr.atoms(sp.Rational):
        if r.is_Integer:
            continue
        q = int(r.q)
        decimal = q == 10 ** (len(str(q)) - 1)
        if numeric or decimal:
            table[r] = sp.Float(r, 6) if numeric else sp.Float(str(sp.N(r, 15)), 15)
    return expr.xreplace(table) if table else expr


def to_latex(expr, *, numeric: bool = False) -> str:
    """LaTeX of one expression (matrices as pmatrix, equations with =)."""
    expr = _numeric(expr, numeric)
    return sp.latex(expr, mat_delim="(", mat_str="matrix", mul_symbol=None)


def to_text(expr, *, numeric: bool = False) -> str:
    """Unicode 2-D rendering of one expression."""
    return sp.pretty(_numeric(expr, numeric), use_unicode=True, wrap_line=False)


def display_symbols(expr):
    """``expr`` with every symbol renamed to its display form (θ̇₂ spelled 'θ̇_2'), for printers
    that take names literally (MathML)."""
    table = {}
    for symbol in expr.free_symbols:
        name, sups, subs = split_super_sub(symbol.name)
        shown = pretty_symbol(name)
        if subs:
            shown += "_" + "".join(subs)
        if sups:
            shown += "^" + "".join(sups)
        table[symbol] = sp.Symbol(shown, **symbol.assumptions0)
    return expr.xreplace(table)


def to_mathml(expr, *, numeric: bool = False) -> str:
    """Presentation MathML of one expression (for an offline HTML report)."""
    return mathml(display_symbols(_numeric(sp.sympify(expr), numeric)), printer="presentation")


def render(sections: list[Section], fmt: str = "text", *, numeric: bool = False,
           heading: str = "") -> str:
    """The sections as one document in ``fmt`` ("text", "latex" or "markdown")."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r} (use {', '.join(FORMATS)})")
    out: list[str] = []
    if heading:
        out.append({"text": heading + "\n" + "=" * len(heading),
                    "latex": rf"\section*{{{heading}}}",
                    "markdown": f"# {heading}"}[fmt])
    for section in sections:
        title = f"{section.key} — {section.title}"
        if fmt == "text":
            out.append(f"\n{title}\n{'-' * len(title)}")
            for item in section.items:
                body = to_text(item.expr, numeric=numeric)
                joiner = "\n" if "\n" in body else " "
                out.append(f"{item.label} ={joiner}{body}\n")
            out.extend(f"({note})" for note in section.notes)
        elif fmt == "latex":
            out.append(rf"\subsection*{{{_latex_text(title)}}}")
            for item in section.items:
                out.append(rf"\[ {_equation(item, numeric)} \]")
            out.extend(rf"\noindent {_latex_text(note)}\par" for note in section.notes)
        else:
            out.append(f"\n## {title}\n")
            for item in section.items:
                out.append(f"{item.label}:\n\n$$ {_equation(item, numeric)} $$\n")
            out.extend(f"*{note}*\n" for note in section.notes)
    return "\n".join(out).strip() + "\n"


def _equation(item, numeric: bool) -> str:
    """``label = expr`` in LaTeX; an equation item (IK branch) is shown as it is."""
    body = to_latex(item.expr, numeric=numeric)
    return body if isinstance(item.expr, sp.Equality) else f"{item.tex} = {body}"


def _latex_text(text: str) -> str:
    """Unicode prose made safe for LaTeX text mode (Greek and sub/superscripts as math)."""
    replacements = {"Σ": r"$\Sigma$", "θ": r"$\theta$", "φ": r"$\phi$", "ψ": r"$\psi$",
                    "ϑ": r"$\vartheta$", "τ": r"$\tau$", "ω": r"$\omega$", "ℒ": r"$\mathcal{L}$",
                    "—": "---", "–": "--", "₀": r"$_0$", "_": r"\_", "q̇": r"$\dot q$",
                    "ẋ": r"$\dot x$", "−": "-", "≡": r"$\equiv$", "&": r"\&", "%": r"\%"}
    for key, value in replacements.items():
        text = text.replace(key, value)
    return text
