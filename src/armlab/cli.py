"""The ``armlab`` command line: a thin dispatcher over ``armlab.commands``.

Every subcommand is a module of :mod:`armlab.commands` listed in :data:`COMMANDS`.  Whatever
goes wrong reaches the user as one line on stderr, never a traceback (``--debug`` or
``ARMLAB_DEBUG=1`` shows the traceback of an internal error), and the exit code says what
happened (:data:`EXIT_CODES`, also in ``armlab --help`` and the README).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback
import warnings

from armlab import __version__
from armlab.caches import repaired
from armlab.errors import ArmlabError, SimulationDiverged

COMMANDS = (
    "robots",
    "derive",
    "demo",
    "scenarios",
    "course",
    "run",
    "report",
    "sweep",
    "warmup",
)
"""Modules of ``armlab.commands``, in the order ``armlab --help`` lists them."""

OK, INTERNAL_ERROR, BAD_INPUT, DIVERGED, INTERRUPTED = 0, 1, 2, 3, 130
EXIT_CODES = {
    OK: "success (also a run that diverged as its scenario expects: expect = \"diverged\")",
    INTERNAL_ERROR: "internal error: an unexpected exception (a bug; --debug shows the traceback)",
    BAD_INPUT: "bad input or output: a file, argument or setting armlab cannot use, a file "
               "that cannot be read or written",
    DIVERGED: "the run did not end as its scenario expects: it diverged or was stopped by its "
              "step budget (its data up to then is saved), or it was expected to diverge and did not",
    INTERRUPTED: "interrupted by Ctrl-C (a run saves its data up to then, marked interrupted)",
}
"""Exit code → meaning: the contract scripts rely on."""


def _epilog() -> str:
    return "exit codes:\n" + "\n".join(f"  {code:<4} {text}" for code, text in EXIT_CODES.items())


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="armlab",
        description="Modelling and control of robot manipulators (kinematics, dynamics, "
                    "symbolic derivations, simulation).",
        epilog=_epilog(), formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"armlab {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an internal error (also ARMLAB_DEBUG=1)")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"armlab.commands.{name}").register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run ``armlab`` with ``argv`` (``sys.argv[1:]`` by default); returns the exit code
    (:data:`EXIT_CODES`)."""
    # The command line only writes pictures to files: matplotlib's file backend, whatever the
    # user's default (the library never chooses one).  Read when matplotlib is first imported.
    os.environ["MPLBACKEND"] = "Agg"
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help(sys.stderr)
        return BAD_INPUT
    prefix = f"armlab {args.command}"
    with warnings.catch_warnings():
        if getattr(args, "quiet", False):
            warnings.simplefilter("ignore")

        def one_line(message, category, filename, lineno, file=None, line=None):
            # A warning is one line too: what, not where in armlab's source it was raised.
            print(f"{prefix}: warning: {message}", file=sys.stderr)

        warnings.showwarning = one_line
        try:
            # A damaged compile cache is discarded and the command run once more (armlab.caches).
            return int(repaired(args.func, args) or 0)
        except SimulationDiverged as error:
            print(f"{prefix}: {error}", file=sys.stderr)
            return DIVERGED
        except ArmlabError as error:
            print(f"{prefix}: error: {error}", file=sys.stderr)
        except KeyboardInterrupt:
            print(f"{prefix}: interrupted", file=sys.stderr)
            return INTERRUPTED
        except BrokenPipeError:
            # The reader of our output went away (`armlab scenarios | head`): not an error.
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return OK
        except OSError as error:
            where = f" {error.filename}:" if error.filename else ""
            print(f"{prefix}: error:{where} {error.strerror or error}", file=sys.stderr)
        except MemoryError:
            print(f"{prefix}: error: out of memory", file=sys.stderr)
        except Exception as error:  # noqa: BLE001 — a bug: one line, the traceback on request
            if args.debug or os.environ.get("ARMLAB_DEBUG"):
                traceback.print_exc()
            first = (str(error).strip().splitlines() or [""])[0][:300]
            print(f"{prefix}: internal error: {type(error).__name__}: {first} (a bug in armlab: "
                  "run again with --debug for the traceback and report it)", file=sys.stderr)
            return INTERNAL_ERROR
    return BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
