"""The ``armlab`` command line: a thin dispatcher over ``armlab.commands``.

Every subcommand is a module of :mod:`armlab.commands` listed in :data:`COMMANDS`.  Errors
armlab reports on purpose (:class:`~armlab.errors.ArmlabError`) and unreadable files reach the
user as one line on stderr with exit code 2, never as a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from armlab import __version__
from armlab.errors import ArmlabError

COMMANDS = (
    "robots",
    "derive",
    "demo",
    "scenarios",
    "course",
    "run",
    "report",
)
"""Modules of ``armlab.commands``, in the order ``armlab --help`` lists them."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="armlab",
        description="Modelling and control of robot manipulators (kinematics, dynamics, "
                    "symbolic derivations, simulation).")
    parser.add_argument("--version", action="version", version=f"armlab {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"armlab.commands.{name}").register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``armlab`` with ``argv`` (``sys.argv[1:]`` by default); returns the exit code."""
    # The command line only writes pictures to files: matplotlib's file backend, whatever the
    # user's default (the library never chooses one).  Read when matplotlib is first imported.
    os.environ["MPLBACKEND"] = "Agg"
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(args.func(args) or 0)
    except ArmlabError as error:
        print(f"armlab {args.command}: error: {error}", file=sys.stderr)
    except BrokenPipeError:
        # The reader of our output went away (`armlab scenarios | head`): not an error.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as error:
        where = f" {error.filename}" if error.filename else ""
        print(f"armlab {args.command}: error:{where}: {error.strerror or error}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
