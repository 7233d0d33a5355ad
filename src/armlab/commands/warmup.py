"""``armlab warmup``: compile the kernels every simulation shares, ahead of the first result."""

from __future__ import annotations

import sys
import time

from armlab.commands import add_tip_argument


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "warmup", help="compile the shared kernels into numba's disk cache (once per machine)",
        description="Compile the kernels every simulation shares (dynamics, the simulation loop, "
                    "kinematics, references, task-space kernels) for a robot, so that the first "
                    "run comes from numba's disk cache.  Optional: any run compiles what it "
                    "misses itself.")
    parser.add_argument("robot", metavar="ROBOT", nargs="?", default="prp",
                        help="bundled robot name or robot file (default: prp)")
    add_tip_argument(parser)
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.robots import load_robot
    from armlab.warmup import warmup

    robot = load_robot(args.robot, tip=args.tip)
    start = time.perf_counter()
    warmup(robot)
    print(f"warmed up for {robot.name} ({robot.n} joints) in {time.perf_counter() - start:.1f} s",
          file=sys.stderr)
    return 0
