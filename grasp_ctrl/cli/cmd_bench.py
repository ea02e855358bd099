"""``bench``: performance figures (docs/design.md 5.6)."""

from __future__ import annotations

import argparse
import json

from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

NAME = "bench"
HELP = "measure the performance figures (docs/design.md 5.6)"
ORDER = 50


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--only", metavar="NAME,...", help="comma-separated figure names (default: all)")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    p.add_argument("--quick", action="store_true", help="fewer repetitions (a smoke test, not a measurement)")
    p.add_argument("--list", action="store_true", help="list the figure names and exit")
    p.add_argument("--quiet", action="store_true", help="no progress line (shown only on a terminal anyway)")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.bench.runner import all_figures, machine_description, run_figures

    if args.list:
        for name in all_figures():
            print(name)
        return 0
    only = [n.strip() for n in args.only.split(",") if n.strip()] if args.only else None
    results = run_figures(only, quick=args.quick, progress=not args.quiet)
    print(f"machine: {machine_description()}")
    print(f"{'figure':32s} {'median':>12s} {'p99':>12s}  unit")
    for name, fig in results.items():
        print(f"{name:32s} {fig.median:12.4g} {fig.p99:12.4g}  {fig.unit}")
    if args.json:
        doc = {
            "machine": machine_description(),
            "figures": {n: {"median": f.median, "p99": f.p99, "unit": f.unit} for n, f in results.items()},
        }

        write_output(check_output(args.json, "--json"), json.dumps(doc, indent=2) + "\n")
    return 0
