"""``armlab derive``: the seed's symbolic derivations A1–A5 for a robot, section by section."""

from __future__ import annotations

from armlab.commands import add_tip_argument


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
    parser.add_argument("--frame", choices=("0", "base"), default="0",
                        help="frame of the kinematic results and task coordinates (default: 0)")
    parser.add_argument("--format", dest="fmt", choices=("text", "latex", "markdown"), default="text",
                        help="output format (default: text)")
    parser.add_argument("--numeric", action="store_true",
                        help="substitute the parameter values instead of keeping symbols")
    parser.add_argument("--only", choices=("A1", "A2", "A3", "A4", "A5"),
                        help="derive a single assignment")
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.robots import load_robot

    robot = load_robot(args.robot, tip=args.tip)
    # SymPy (seconds to import) only once the robot file has been read without error.
    from armlab.symbolic import derive, render

    sections = derive(robot, frame=args.frame, numeric=args.numeric, only=args.only)
    heading = f"{robot.name}: symbolic model" + (" (numeric parameters)" if args.numeric else "")
    print(render(sections, args.fmt, numeric=args.numeric, heading=heading), end="")
    return 0
