"""Rendering of derivation sections: Unicode text, LaTeX, Markdown (with LaTeX math), MathML.

Symbols are printed with their display names: ``thetadot_2`` → θ̇₂ / ``\\dot{\\theta}_{2}``,
``m_Link4`` → m_Link4 / ``m_{Link4}``, ``varphi`` → φ, ``vartheta`` → ϑ.  With ``numeric`` the
exact rationals of the robot's values are shown as decimals.

MathML is written for a browser's native renderer (MathML Core): a time derivative is the
letter under a dot (``<mover accent="false"><mi>θ</mi><mo>˙</mo></mover>``), never a
combining dot, which fonts place inconsistently (over the next glyph or fused into the
letter); minus signs are U+2212.
"""

from __future__ import annotations

import html

import sympy as sp
from sympy.printing.conventions import split_super_sub
from sympy.printing.mathml import MathMLPresentationPrinter
from sympy.printing.precedence import PRECEDENCE
from sympy.printing.pretty.pretty_symbology import greek_unicode, pretty_symbol

FORMATS = ("text", "latex", "markdown")
# Greek variants SymPy's Unicode table lacks (its LaTeX printer knows them: \\varphi, \\vartheta).
GREEK_VARIANTS = {"varphi": "φ", "vartheta": "ϑ"}
# Name suffixes that put an accent over the letter before them (SymPy's LaTeX modifiers),
# longest first: ``ddot`` ends in ``dot``.  The accents are spacing characters for <mo>.
ACCENTS = {"ddot": "\u00a8", "tilde": "~", "dot": "\u02d9", "hat": "^", "bar": "\u00af"}
MINUS = "\u2212"
# [characters of the Unicode rendering] a sum wider than this, alone or as a matrix entry, is
# set on several lines (MathML Core has no line breaking); ~100 characters fill the report's
# formula column (about 900 px at its 17 px font).
WRAP = 100


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
    """Unicode 2-D rendering of one expression (φ and ϑ for ``varphi`` and ``vartheta``, which
    SymPy would spell out)."""
    expr = _numeric(expr, numeric)
    variants = {s: sp.Symbol(GREEK_VARIANTS[name] + symbol_tail(s.name, name), **s.assumptions0)
                for s in getattr(expr, "free_symbols", ())
                if (name := split_super_sub(s.name)[0]) in GREEK_VARIANTS}
    return sp.pretty(expr.xreplace(variants) if variants else expr, use_unicode=True, wrap_line=False)


def symbol_tail(full: str, base: str) -> str:
    """What follows the base name in a symbol's name (its sub- and superscripts)."""
    return full[len(base):]


def letter(name: str) -> str:
    """The character(s) a symbol's base name shows as: Greek names as letters (``varphi`` → φ,
    ``theta`` → θ), anything else as written."""
    return GREEK_VARIANTS.get(name) or greek_unicode.get(name) or name


def split_accent(name: str) -> tuple[str, str | None]:
    """``(base, accent)`` of a base name with an accent suffix (``thetadot`` → ("theta",
    "dot"), ``ddot`` → ("d", "dot"), ``dddot`` → ("d", "ddot")); ``(name, None)`` without."""
    for suffix in ACCENTS:
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)], suffix
    return name, None


def display_symbols(expr):
    """``expr`` with every symbol renamed to its Unicode display form (θ̇₂ spelled 'θ̇_2', φ for
    ``varphi``), for printers that take names literally (the Unicode text rendering)."""
    table = {}
    for symbol in expr.free_symbols:
        name, sups, subs = split_super_sub(symbol.name)
        shown = GREEK_VARIANTS.get(name) or pretty_symbol(name)
        if subs:
            shown += "_" + "".join(subs)
        if sups:
            shown += "^" + "".join(sups)
        table[symbol] = sp.Symbol(shown, **symbol.assumptions0)
    return expr.xreplace(table)


class MathMLPrinter(MathMLPresentationPrinter):
    """SymPy's presentation MathML printer with the report's symbols and signs: Greek names
    (variants included) as letters, accent suffixes as ``<mover>`` over the letter and every
    minus as U+2212 (SymPy writes the ASCII hyphen), a negated sum in parentheses (SymPy 1.14
    prints −(x + y) as −x + y).  A sum wider than ``wrap`` characters
    (the expression itself or an entry of a matrix) is broken before its + and − signs into
    left-aligned lines."""

    def __init__(self, wrap: int = WRAP):
        super().__init__()
        self._wrap = wrap
        self._breakable: set = set()  # the sums that may be broken into lines

    def _text(self, tag: str, text: str):
        element = self.dom.createElement(tag)
        element.appendChild(self.dom.createTextNode(html.escape(text, quote=False)))
        return element

    def _base(self, name: str):
        base, accent = split_accent(name)
        if accent is None:
            return self._text("mi", letter(name))
        over = self.dom.createElement("mover")
        # An over-script, not an accent: without an OpenType MATH font (the usual case) a
        # browser sets an accent on the letter's top, where a dot merges into θ or d's stem;
        # an over-script keeps a gap.
        over.setAttribute("accent", "false")
        over.appendChild(self._base(base))
        over.appendChild(self._text("mo", ACCENTS[accent]))
        return over

    def _script(self, parts: list[str]):
        if len(parts) == 1:
            return self._text("mi", letter(parts[0]))
        row = self.dom.createElement("mrow")
        for k, part in enumerate(parts):
            if k:
                row.appendChild(self._text("mo", ","))
            row.appendChild(self._text("mi", letter(part)))
        return row

    def _print_Symbol(self, sym, style="plain"):
        name, sups, subs = split_super_sub(sym.name)
        element = self._base(name)
        if subs or sups:
            tag = "msubsup" if subs and sups else "msub" if subs else "msup"
            scripted = self.dom.createElement(tag)
            scripted.appendChild(element)
            for parts in (subs, sups):
                if parts:
                    scripted.appendChild(self._script(parts))
            element = scripted
        if style == "bold":
            element.setAttribute("mathvariant", "bold")
        return element

    def _print_Mul(self, expr):
        if expr.could_extract_minus_sign() and (-expr).is_Add:
            row = self.dom.createElement("mrow")
            row.appendChild(self._text("mo", MINUS))
            row.appendChild(self.parenthesize(-expr, PRECEDENCE["Mul"]))
            return row
        return super()._print_Mul(expr)

    def _print_Add(self, expr, order=None):
        if expr not in self._breakable or _width(expr) <= self._wrap:
            return super()._print_Add(expr, order=order)
        lines: list[list] = [[]]
        used = 0
        for k, term in enumerate(self._as_ordered_terms(expr, order=order)):
            negative = k > 0 and term.could_extract_minus_sign()
            shown = -term if negative else term
            width = _width(shown) + 3
            if lines[-1] and used + width > self._wrap:
                lines.append([])
                used = 0
            if k > 0:
                lines[-1].append(self._text("mo", MINUS if negative else "+"))
            lines[-1].append(self._print(shown))
            used += width
        table = self.dom.createElement("mtable")
        table.setAttribute("columnalign", "left")
        table.setAttribute("style", "padding: 3px 0 7px")  # apart from a matrix's next entry
        for line in lines:
            row, cell, content = (self.dom.createElement(tag) for tag in ("mtr", "mtd", "mrow"))
            cell.setAttribute("style", "text-align: left")  # MathML Core ignores columnalign
            for element in line:
                content.appendChild(element)
            cell.appendChild(content)
            row.appendChild(cell)
            table.appendChild(row)
        return table

    def _spread(self, expr):
        """A wide −(a + b + …) as −a − b − … (the same sum), so that it can be broken."""
        if isinstance(expr, sp.Mul) and expr.could_extract_minus_sign() and (-expr).is_Add \
                and _width(expr) > self._wrap:
            return sp.Add(*(-term for term in (-expr).args))
        return expr

    def doprint(self, expr) -> str:
        expr = expr.applyfunc(self._spread) if isinstance(expr, sp.MatrixBase) else self._spread(expr)
        entries = list(expr) if isinstance(expr, sp.MatrixBase) else [expr]
        # By value: a matrix builds its entries anew at every access.
        self._breakable = {entry for entry in entries if isinstance(entry, sp.Add)}
        tree = self._print(expr)
        for element in [tree] * (tree.tagName == "mo") + tree.getElementsByTagName("mo"):
            for text in element.childNodes:
                if getattr(text, "data", None) == "-":
                    text.data = MINUS
        # A negative number (SymPy: <mn>-0.5</mn>) becomes a minus operator and its magnitude.
        for number in [tree] * (tree.tagName == "mn") + tree.getElementsByTagName("mn"):
            text = number.firstChild
            if text is None or not getattr(text, "data", "").startswith("-"):
                continue
            text.data = text.data[1:]
            row = self.dom.createElement("mrow")
            if number is tree:
                tree = row
            else:
                number.parentNode.replaceChild(row, number)
            row.appendChild(self._text("mo", MINUS))
            row.appendChild(number)
        return tree.toxml().encode("ascii", "xmlcharrefreplace").decode()


def _width(expr) -> int:
    """Width in characters of the Unicode rendering of ``expr`` (no wider than its plain text,
    which is measured first because it is cheap)."""
    if len(str(expr)) <= WRAP:
        return len(str(expr))
    return max(len(line) for line in sp.pretty(expr, use_unicode=True, wrap_line=False).splitlines())


def to_mathml(expr, *, numeric: bool = False) -> str:
    """Presentation MathML of one expression (for an offline HTML report)."""
    return MathMLPrinter().doprint(_numeric(sp.sympify(expr), numeric))


def render(sections: list, fmt: str = "text", *, numeric: bool = False,
           heading: str = "") -> str:
    """The sections (:class:`armlab.symbolic.sections.Section`, which display themselves with
    this module's printers: hence no import of them here) as one document in ``fmt`` ("text",
    "latex" or "markdown")."""
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
