"""``armlab run SCENARIO``: simulate a scenario, write its data and optionally its scope plots."""

from __future__ import annotations

import sys

from armlab.results import FORMATS


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "run", help="run a scenario (see `armlab scenarios`) and write its data and scopes",
        description="Simulate SCENARIO (a bundled scenario name or a scenario .toml file), print a "
                    "summary and write <name>.npz and <name>.csv (and with --plot the scope PNGs) "
                    "into --out.  A diverged run keeps its data up to the divergence; the exit "
                    "code is then 1.")
    parser.add_argument("scenario", metavar="SCENARIO", help="bundled scenario name or .toml file")
    parser.add_argument("--out", metavar="DIR", default="runs", help="output folder (default: runs)")
    parser.add_argument("--plot", action="store_true", help="also draw the scopes as PNG")
    parser.add_argument("--t-final", type=float, metavar="T", help="simulate T seconds instead")
    parser.add_argument("--method", choices=("rk4", "adaptive"), help="override the integrator")
    parser.add_argument("--format", default="npz,csv", metavar="LIST",
                        help=f"comma-separated data formats among {', '.join(f[1:] for f in FORMATS)} "
                             "(default: npz,csv)")
    parser.set_defaults(func=run)


def run(args) -> int:
    from armlab.errors import ArmlabError
    from armlab.scenarios.runner import run_scenario

    formats = [f.strip() for f in args.format.split(",") if f.strip()]
    for fmt in formats:
        if f".{fmt}" not in FORMATS:
            raise ArmlabError(f"--format: unknown format {fmt!r} (use npz, csv, parquet)")
    result, written, note = run_scenario(args.scenario, out_dir=args.out, formats=formats,
                                         plot=args.plot, t_final=args.t_final, method=args.method,
                                         progress=sys.stderr)
    final = ", ".join(f"{label} {value:+.4g}" for label, value in
                      zip(result.labels["q"], result.q[-1], strict=True))
    print(f"{result.meta['scenario']}: {len(result.t)} samples to t = {result.t[-1]:g} s; final q: {final}")
    if "q_err" in result.signals:
        worst = abs(result.signals["q_err"][-1]).max()
        print(f"final |q_err| max: {worst:.3g}")
    for path in written:
        print(f"wrote {path}")
    if note:
        print(note)
    if result.status != "ok":
        print(f"armlab run: {result.diagnosis}", file=sys.stderr)
        return 1
    return 0
