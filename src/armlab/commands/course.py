"""``armlab course ROBOT --out DIR``: the seed's experiments A6–A15 generated for any arm."""

from __future__ import annotations

from armlab.commands import add_allow_outside_argument, add_tip_argument


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "course", help="write the A6–A15 experiments of the seed for any robot, as scenario files",
        description="Choose a start and a goal inside the robot's joint limits and away from "
                    "singularities, gains from its dynamics and an environment plane where its "
                    "end effector meets it, and write one scenario file per seed experiment "
                    "(run each with `armlab run FILE`; `armlab report --robot ROBOT` runs them all).")
    parser.add_argument("robot", metavar="ROBOT",
                        help="bundled or zoo robot name, or robot file (.toml/.urdf/.xml)")
    add_tip_argument(parser)
    add_allow_outside_argument(parser)
    parser.add_argument("--out", default="course", help="output folder (default: course)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from pathlib import Path

    from armlab.course import write_course
    from armlab.model.references import is_under
    from armlab.robots import load_robot, robot_reference

    robot = load_robot(args.robot, tip=args.tip, allow_outside=args.allow_outside)
    reference, tip = robot_reference(robot)
    paths, skipped = write_course(robot, reference, args.out, tip=tip)
    for path in paths:
        print(path)
    for reason in skipped:
        print(f"not generated: {reason}")
    if Path(reference).suffix and not is_under(reference, Path(args.out).resolve()):
        # A scenario may name robot files under its own folder only, unless told otherwise.
        print(f"note: the scenarios name {reference}, outside {args.out}: run them with "
              "`armlab run FILE --allow-outside`")
    return 0
