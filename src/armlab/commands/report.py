"""``armlab report [--robot prp] [--out DIR] [--quick]``: the whole seed as one HTML file."""

from __future__ import annotations

import argparse
import os

from armlab.commands import add_allow_outside_argument, add_tip_argument


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "report", help="write the HTML report of the seed project (A1–A15), offline",
        description="Derive A1–A5, run every bundled scenario of the robot (A6–A15), and write "
                    "DIR/report.html with formulas, scope plots, measured numbers and an animation, and "
                    "an interactive 3-D view of every run in DIR/view3d (with plotly installed). "
                    "Nothing is loaded from a network: the report opens offline.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--robot", default="prp", help="bundled robot name or robot file")
    add_tip_argument(parser)
    add_allow_outside_argument(parser)
    parser.add_argument("--out", default="report", help="output directory")
    parser.add_argument("--quick", action="store_true",
                        help="a fast preview: the first scenario of each assignment, runs shortened, "
                             "their main scopes alone, no animation (the numbers are those of the "
                             "short runs)")
    parser.add_argument("--no-animation", action="store_true", help="leave out the GIF")
    parser.add_argument("--no-views", action="store_true",
                        help="leave out the interactive 3-D views (pages in DIR/view3d, need plotly)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar and no warnings")
    parser.add_argument("--sweep", action="append", default=[], metavar="DIR",
                        help="add the page of the sweep written to DIR by `armlab sweep` (repeatable)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.errors import CommandError
    from armlab.files import check_writable_folder

    try:
        # Before minutes of runs: a report that cannot be written is said at once.
        check_writable_folder(args.out)
    except OSError as error:
        raise CommandError(f"--out: {args.out}: {error.strerror or 'cannot be written'}") from None
    from armlab.robots import load_robot
    from armlab.viz.report import build_report

    robot = load_robot(args.robot, tip=args.tip, allow_outside=args.allow_outside)
    # --quiet: ``armlab.cli`` silences this process's warnings; the full report's workers are
    # spawned interpreters, which take their filter from the environment.
    saved = os.environ.get("PYTHONWARNINGS")
    if args.quiet:
        os.environ["PYTHONWARNINGS"] = "ignore"
    try:
        path = build_report(robot, args.out, quick=args.quick, show_progress=not args.quiet,
                            animation=not (args.no_animation or args.quick), sweeps=args.sweep,
                            views=not args.no_views)
    finally:
        if saved is None:
            os.environ.pop("PYTHONWARNINGS", None)
        else:
            os.environ["PYTHONWARNINGS"] = saved
    print(path)
    return 0
