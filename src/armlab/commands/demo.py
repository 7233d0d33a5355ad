"""``armlab demo``: the seed's assignment A1 on the PRP arm — its DH tables from Σ_base and
from Σ_0 (symbolic entries and numeric values) and the forward kinematics T_3^0 and T_3^base
at the seed's pose d1 = 0.1 m, θ2 = π/3, d3 = 0.1 m — in about a second.  The whole seed is
``armlab report`` (``make demo`` runs both); ``--report`` builds it here too."""

from __future__ import annotations

import argparse

import numpy as np

from armlab.commands import (
    CommandError,
    add_allow_outside_argument,
    add_tip_argument,
    format_matrix,
    format_number,
    format_table,
    parse_vector,
)
from armlab.commands.robots import DH_HEADERS, dh_rows

SEED_POSE = np.array([0.1, np.pi / 3, 0.1])
"""The pose of the seed's A1 figures: d1 = 0.1 m, θ2 = π/3 rad, d3 = 0.1 m."""


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo", help="DH tables and forward kinematics of the PRP arm (seed A1)",
        description="Print the DH tables of a robot (default: the seed's PRP) from Σ_base and "
                    "from Σ_0, and its forward kinematics T_n^0 and T_n^base at a pose.")
    parser.add_argument("--robot", default="prp", help="bundled robot or robot file (default: prp)")
    add_tip_argument(parser)
    add_allow_outside_argument(parser)
    parser.add_argument("--q", help="joint values, e.g. '0.1, pi/3, 0.1' (default: the seed's "
                                    "pose for the PRP, zeros otherwise)")
    parser.add_argument("--report", action="store_true",
                        help="then build the HTML report of the whole seed (as `armlab report`)")
    parser.add_argument("--out", default="report", help="directory of the HTML report (default: report)")
    parser.add_argument("--quick", action="store_true", help="shortened runs in the report")
    # The tables alone are the default now; the old switch is still accepted.
    parser.add_argument("--no-report", action="store_true", help=argparse.SUPPRESS)
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.kinematics import forward_kinematics
    from armlab.robots import load_robot

    robot = load_robot(args.robot, tip=args.tip, allow_outside=args.allow_outside)
    if args.q is not None:
        q = parse_vector(args.q, robot.n, "--q")
    elif robot.n == 3 and [j.kind for j in robot.joints] == ["prismatic", "revolute", "prismatic"]:
        q = SEED_POSE
    else:
        q = np.zeros(robot.n)
    if not robot.is_dh:
        raise CommandError(f"robot {robot.name!r} is not described by DH rows; "
                           f"see 'armlab robots {args.robot}'")

    def print_tables():
        n = robot.n
        print(f"{robot.name}: {robot.description}")
        symbolic = dh_rows(robot)
        numeric = dh_rows(robot, symbolic=False, q=q)
        has_base_row = symbolic[0][0].startswith("base")
        if has_base_row:
            print("\nDH table from Σ_base (first row: the fixed transform Σ_base → Σ_0)")
            print(format_table(DH_HEADERS, symbolic, "  "))
        print("\nDH table from Σ_0")
        print(format_table(DH_HEADERS, symbolic[1:] if has_base_row else symbolic, "  "))
        values = ", ".join(f"{k} = {format_number(v, 6)}" for k, v in robot.parameters.items())
        print("\nParameters: " + values)
        pose = ", ".join(f"{j.name} = {format_number(v)}" for j, v in zip(robot.joints, q, strict=True))
        print(f"\nAt the pose {pose}:")
        print(format_table(DH_HEADERS, numeric, "  "))
        print(f"\nForward kinematics T_{n}^0 = T_e^0 (end effector in Σ_0)")
        print(format_matrix(forward_kinematics(robot, q, frame="0"), "  "))
        print(f"\nForward kinematics T_{n}^base = T_base,0 · T_{n}^0")
        print(format_matrix(forward_kinematics(robot, q, frame="base"), "  "))

    if not args.report or args.no_report:
        print_tables()
        print("\nThe whole seed (A1–A15) as one HTML page: armlab report")
        return 0
    from armlab.viz.report import build_report

    # Printed once the report's worker processes are starting: they import and compile meanwhile.
    path = build_report(robot, args.out, quick=args.quick, first=print_tables)
    print(f"\nReport of the whole seed (A1–A15 as far as armlab runs them): {path}")
    return 0
