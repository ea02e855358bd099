"""``compare``: the paper's Fig. 6 table for a run, and a grouped bar chart."""

from __future__ import annotations

import argparse
from pathlib import Path

NAME = "compare"
HELP = "success rate per object per policy (the paper's Fig. 6) as a table and bar chart"
DESCRIPTION = (
    "Print the success rate of every policy on every object of RUN_DIR, plus 'all', and the paired "
    "counts (same seeded trials) of where one policy succeeded and the other failed. With matplotlib "
    "(the plot extra) also save a grouped bar chart PNG (default RUN_DIR/compare.png)."
)
ORDER = 3


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", metavar="RUN_DIR", help="a directory written by 'run'")
    p.add_argument(
        "--png", default=None, metavar="FILE", help="where to save the bar chart (default RUN_DIR/compare.png)"
    )
    p.add_argument("--no-plot", action="store_true", help="print the table only")
    p.add_argument("--title", default=None, help="chart title")


def run(args: argparse.Namespace) -> int:
    import importlib.util
    import sys

    from grasp_ctrl.files.safe_write import IMAGE_FORMATS, check_output
    from grasp_ctrl.trials.analysis.compare import fig6_table, format_paired, ordered_names, paired_counts
    from grasp_ctrl.trials.runs.scoring import report_problems, score_run

    run_dir = Path(args.run_dir)
    if not args.no_plot:  # before any work: a bad --png is one line, and never a run's own file
        check_output(args.png or run_dir / "compare.png", "--png", run_dirs=[run_dir], formats=IMAGE_FORMATS)
    scored = score_run(run_dir)
    report_problems(scored)
    print(fig6_table(scored.summary, scored.policies, scored.objects))
    pols, _ = ordered_names(scored.summary, scored.policies, scored.objects)
    for other in pols[1:]:
        print(format_paired(paired_counts(scored.records, pols[0], other)))
    if args.no_plot:
        return 0
    if args.png is None and importlib.util.find_spec("matplotlib") is None:
        print("no chart: matplotlib is not installed (pip install -e '.[plot]')", file=sys.stderr)
        return 0
    from grasp_ctrl.trials.analysis.plots import comparison_chart

    png = Path(args.png) if args.png else scored.run_dir / "compare.png"
    comparison_chart(scored.summary, png, scored.policies, scored.objects, args.title)
    print(f"chart: {png}")
    return 0
