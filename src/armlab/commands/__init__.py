"""Subcommands of the ``armlab`` command line; one module per subcommand.

Each module exposes ``register(subparsers)``, which adds its parser and sets ``func`` (called
with the parsed arguments, returning an exit code or None).  Shared text formatting lives here.
"""

from __future__ import annotations

import numpy as np

from armlab.errors import CommandError


def add_tip_argument(parser) -> None:
    """``--tip LINK``: the end-effector link of a URDF/MJCF robot whose tree branches."""
    parser.add_argument("--tip", metavar="LINK",
                        help="link (URDF) or body (MJCF) carrying the end effector, for a robot file "
                             "whose tree branches; moving joints off the chain are locked")


def add_allow_outside_argument(parser) -> None:
    """``--allow-outside``: a robot file may name files outside its own folder."""
    parser.add_argument("--allow-outside", action="store_true",
                        help="let a URDF/MJCF robot file read files outside its own folder (included "
                             "MJCF files, meshes, textures; package://, file://, absolute paths, ..)")


def format_table(headers: list[str], rows: list[list[str]], indent: str = "") -> str:
    """Left-aligned plain-text table with a rule under the header: tabulate's "simple" format,
    every cell as given (no number parsing or realignment), no trailing blanks."""
    from tabulate import tabulate  # here, not at import: `armlab --help` formats no table

    text = tabulate([[str(c) for c in row] for row in rows], [str(h) for h in headers], tablefmt="simple",
                    stralign="left", disable_numparse=True)
    return "\n".join((indent + line).rstrip() for line in text.splitlines())


def format_number(value: float, digits: int = 4) -> str:
    """A compact number: ``digits`` decimals (three significant digits below 10^(1−digits)),
    without trailing zeros or a negative zero."""
    if np.isnan(value):
        return "nan"
    if not np.isfinite(value):
        return "inf" if value > 0 else "-inf"
    if abs(value) < 1e-12:
        # Round-off of exact zeros (cos π/2 = 6e-17) is shown as 0.
        return "0"
    if abs(value) < 10.0 ** (1 - digits):
        # Small values (rotor inertias, wrist inertias) keep their significant digits.
        return f"{value:.3g}"
    text = f"{value:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def format_matrix(matrix, indent: str = "    ", digits: int = 4) -> str:
    """Rows of a matrix, columns aligned, one line per row."""
    matrix = np.atleast_2d(np.asarray(matrix, dtype=float))
    cells = [[format_number(v, digits) for v in row] for row in matrix]
    width = max(len(c) for row in cells for c in row)
    return "\n".join(indent + "[ " + "  ".join(c.rjust(width) for c in row) + " ]" for row in cells)


def parse_vector(text: str, n: int, what: str) -> np.ndarray:
    """``"0.1, pi/3, 0.1"`` → (n,) array; expressions as in robot files (pi, sqrt, …)."""
    from armlab.model.toml_io import evaluate_expression

    parts = [p for p in text.replace(",", " ").split() if p]
    if len(parts) != n:
        raise CommandError(f"{what}: expected {n} values, got {len(parts)} ({text!r})")
    try:
        values = np.array([evaluate_expression(p, {}) for p in parts])
    except (ValueError, ArithmeticError) as error:
        raise CommandError(f"{what}: {error}") from error
    if not np.all(np.isfinite(values)):
        raise CommandError(f"{what}: expected finite values, got {text!r}")
    return values
