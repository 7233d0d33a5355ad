"""``armlab scenarios``: list the bundled scenario files (one per seed experiment)."""

from __future__ import annotations

from armlab.commands import format_table


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "scenarios", help="list the bundled scenarios (seed experiments)",
        description="A table of the bundled scenarios: name, seed assignment, plant, duration and "
                    "title.  Run one with `armlab run NAME`.")
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.scenarios import bundled_scenario_names, load_scenario

    rows = []
    for name in bundled_scenario_names():
        scenario = load_scenario(name)
        rows.append([name, scenario.assignment, scenario.plant.name,
                     f"{scenario.simulation['t_final']:g} s", scenario.title])
    print(format_table(["scenario", "seed", "plant", "duration", "title"], rows))
    return 0
