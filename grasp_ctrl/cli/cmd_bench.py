"""``bench``: performance figures (docs/design.md 5.6)."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import check_output, destination, write_output

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
    out = check_json(args.json)
    results = run_figures(only, quick=args.quick, progress=not args.quiet)
    print(f"machine: {machine_description()}")
    width = max([32, *map(len, results)])
    print(f"{'figure':{width}s} {'median':>12s} {'p99':>12s}  unit")
    for name, fig in results.items():
        print(f"{name:{width}s} {fig.median:12.4g} {fig.p99:12.4g}  {fig.unit}")
    if out is not None:
        doc = {
            "machine": machine_description(),
            "figures": {n: {"median": f.median, "p99": f.p99, "unit": f.unit} for n, f in results.items()},
        }
        write_output(out, json.dumps(doc, indent=2) + "\n")
    return 0


def check_json(path: str | None) -> Path | None:
    """``--json`` checked before the first figure is measured (minutes on a slow machine), not
    after: a directory, a folder that does not exist or cannot be written is one line now."""
    out = check_output(path, "--json")
    if out is None or destination(out, "--json").is_stream:
        return out  # a stream (-, a device, a FIFO) is written as it is
    folder = out.parent
    if not folder.is_dir():
        raise UsageError(f"--json {out}: {folder}: no such folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise UsageError(f"--json {out}: {folder}: not writable")
    return out
