"""Symbolic modelling with SymPy: the seed's derivations A1–A5 for any robot, as formulas and
LaTeX.

``import armlab`` does not import this package (SymPy is slow to import); use
``import armlab.symbolic``.  Entry points:

* :func:`symbolic_robot` — a robot rebuilt with its file's parameters as symbols;
* :func:`derive` — the A1–A5 chain as :class:`Section` objects (title, items of
  (label, SymPy expression)), rendered by :func:`render` as text, LaTeX or Markdown;
* :func:`compact_dynamics` — B, C, g of larger arms (Puma 560) through the recursive route.

Compiled closed forms are made by one generator, ``armlab.specialise`` (the numeric kernels
traced for the robot's numbers), not from these formulas.
"""

from armlab.symbolic.compact import CompactDynamics, compact_dynamics
from armlab.symbolic.model import SymbolicJoint, SymbolicLink, SymbolicRobot, symbolic_robot
from armlab.symbolic.render import render, to_latex, to_mathml, to_text
from armlab.symbolic.sections import ASSIGNMENTS, Item, Section, derive
from armlab.symbolic.simplify import compact, count_ops

__all__ = [
    "ASSIGNMENTS", "CompactDynamics", "Item", "Section", "SymbolicJoint", "SymbolicLink",
    "SymbolicRobot", "compact", "compact_dynamics", "count_ops",
    "derive", "render",
    "symbolic_robot", "to_latex", "to_mathml", "to_text",
]
