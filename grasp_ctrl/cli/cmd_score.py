"""``score``: recompute a run's summary from its per-trial records."""

from __future__ import annotations

import argparse
from pathlib import Path

NAME = "score"
HELP = "recompute a run's summary from its per-trial records"
DESCRIPTION = (
    "Recompute the run summary (docs/design.md 5.2) from RUN_DIR/trials/*/*/trial_NNN.json. Unreadable, "
    "truncated or inconsistent record files are named on stderr and skipped. Notes on stderr when "
    "trials are missing or the result differs from the run's own summary.json."
)
ORDER = 2


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", metavar="RUN_DIR", help="a directory written by 'run'")
    p.add_argument("--json", default=None, metavar="FILE", help="write the summary JSON here")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.files.safe_write import check_output, write_output
    from grasp_ctrl.files.storage import strict_json_text
    from grasp_ctrl.trials.runs.scoring import report_problems, score_run
    from grasp_ctrl.trials.runs.summary import format_table

    check_output(args.json, "--json", run_dirs=[Path(args.run_dir)])
    scored = score_run(Path(args.run_dir))
    report_problems(scored)
    print(format_table(scored.summary))
    if args.json:
        write_output(args.json, strict_json_text(scored.summary))  # as summary.json: strict JSON
        print(f"summary: {args.json}")
    return 0
