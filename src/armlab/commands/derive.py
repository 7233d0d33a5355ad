"""``armlab derive``: the seed's symbolic derivations A1–A5 for a robot, section by section."""

from __future__ import annotations

import sys
import time

from armlab.commands import add_allow_outside_argument, add_tip_argument

MAX_JOINTS = 12
"""Longest chain ``armlab derive`` takes without ``--no-limit``: the derivation costs about
30 s of CPU for six joints and grows roughly as n³ (measured: 8 s for the PRP's 3 joints, 30 s
for the Puma560's 6), so 12 joints is already ~4 min and 30 joints over an hour."""


def estimate_seconds(n: int) -> float:
    """Rough CPU time [s] of deriving A1–A5 for ``n`` joints (see :data:`MAX_JOINTS`)."""
    return 30.0 * (n / 6.0) ** 3


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "derive", help="symbolic derivations A1–A5 (kinematics, energies, Lagrange, Newton–Euler, "
                       "operational space)",
        description="Derive the robot's model symbolically with its file's parameters as symbols "
                    "(or their values with --numeric) and print it assignment by assignment: "
                    "A1 kinematics and Jacobians, A2 energies and B(q), A3 Lagrange, C and g, "
                    "A4 Newton–Euler and its identity with Lagrange, A5 operational space.")
    parser.add_argument("robot", metavar="ROBOT", help="bundled robot name or robot file (.toml/.urdf)")
    add_tip_argument(parser)
    add_allow_outside_argument(parser)
    parser.add_argument("--frame", choices=("0", "base"), default="0",
                        help="frame of the kinematic results and task coordinates; A1 with 'base' has "
                             "its results in Σ_0 and in Σ_base (default: 0)")
    parser.add_argument("--format", dest="fmt", choices=("text", "latex", "markdown"), default="text",
                        help="output format (default: text)")
    parser.add_argument("--numeric", action="store_true",
                        help="substitute the parameter values instead of keeping symbols")
    parser.add_argument("--only", choices=("A1", "A2", "A3", "A4", "A5"),
                        help="derive a single assignment")
    parser.add_argument("--quiet", action="store_true", help="no progress lines and no warnings")
    parser.add_argument("--budget", type=_seconds, default=60.0, metavar="SECONDS",
                        help="wall-clock time each assignment may take; past it the assignment keeps "
                             "what it derived and says what it skipped (default: 60; 0: no limit)")
    parser.add_argument("--no-limit", action="store_true",
                        help=f"derive a chain of more than {MAX_JOINTS} joints anyway (it may take hours)")
    parser.set_defaults(func=run)


def _seconds(text: str) -> float:
    import argparse
    import math

    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"expected a number of seconds ≥ 0, got {text!r}")
    return value


def run(args) -> int:
    from armlab.errors import CommandError
    from armlab.robots import load_robot

    robot = load_robot(args.robot, tip=args.tip, allow_outside=args.allow_outside)
    if robot.n > MAX_JOINTS and not args.no_limit:
        minutes = estimate_seconds(robot.n) / 60
        raise CommandError(f"{robot.name} has {robot.n} joints: deriving it would take about "
                           f"{minutes:.0f} min of CPU (more than {MAX_JOINTS} joints needs --no-limit)")
    # SymPy (seconds to import) only once the robot file has been read without error.
    from armlab.symbolic import derive, render

    # One assignment at a time, each announced on stderr with the time it took: the symbolic
    # work grows quickly with the joints (minutes for long chains) and must not look hung.
    sections = []
    for key in [args.only] if args.only else ["A1", "A2", "A3", "A4", "A5"]:
        if not args.quiet:
            print(f"deriving {key} for {robot.n} joints ...", end="", file=sys.stderr, flush=True)
        started = time.perf_counter()
        sections += derive(robot, frame=args.frame, numeric=args.numeric, only=key,
                           budget=args.budget or None)
        if not args.quiet:
            stopped = "" if sections[-1].complete else f" (budget of {args.budget:g} s spent, rest skipped)"
            print(f" {time.perf_counter() - started:.1f} s{stopped}", file=sys.stderr, flush=True)
    heading = f"{robot.name}: symbolic model" + (" (numeric parameters)" if args.numeric else "")
    print(render(sections, args.fmt, numeric=args.numeric, heading=heading), end="")
    return 0
