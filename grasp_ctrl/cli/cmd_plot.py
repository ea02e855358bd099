"""``plot``: a trial's force traces as a PNG."""

from __future__ import annotations

import argparse
from pathlib import Path

NAME = "plot"
HELP = "save a trial's fingertip force traces (with state bands) as PNG"
DESCRIPTION = (
    "Plot the estimated force of every fingertip (x, y, z; on the mock also the true force, dashed) "
    "over time from a trial's tick log, with the controller states shaded. TRIAL is "
    "trial_NNN.json or trial_NNN_ticks.parquet (or the .csv of older runs) in a run directory. Needs matplotlib (the plot extra)."
)
ORDER = 4


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("trial", metavar="TRIAL", help="trial_NNN.json or trial_NNN_ticks.parquet (or the .csv of older runs)")
    p.add_argument("--out", default=None, metavar="FILE", help="PNG path (default: trial_NNN_forces.png beside it)")
    p.add_argument("--frame", choices=("sensor", "world"), default="sensor", help="force frame (default sensor)")


def _paths(trial: Path) -> tuple[Path, Path]:
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.trials.ticklog import LEGACY_TICKS_SUFFIX, TICKS_SUFFIX

    name = trial.name
    for suffix in (TICKS_SUFFIX, LEGACY_TICKS_SUFFIX, ".json"):
        if name.endswith(suffix):
            stem = name[: -len(suffix)]
            break
    else:
        raise UsageError(f"{trial}: give a trial_NNN.json or trial_NNN{TICKS_SUFFIX}")
    ticks = trial.with_name(f"{stem}{TICKS_SUFFIX}")
    if not ticks.is_file() and trial.with_name(f"{stem}{LEGACY_TICKS_SUFFIX}").is_file():
        ticks = trial.with_name(f"{stem}{LEGACY_TICKS_SUFFIX}")
    if not ticks.is_file():
        raise UsageError(f"{ticks}: no tick log (was the run made with --no-tick-logs?)")
    return ticks, trial.with_name(f"{stem}.json")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.trials.plots import force_traces
    from grasp_ctrl.trials.records import read_record

    ticks, record = _paths(Path(args.trial))
    title = None
    if record.is_file():
        rec, _ = read_record(record)
        if rec is not None:
            outcome = "success" if rec["success"] else f"failed: {rec['reason']}"
            title = f"{rec['policy']} / {rec['object']} / trial {rec['trial']} (seed {rec['seed']}): {outcome}"
    out = Path(args.out) if args.out else ticks.with_name(ticks.name.split("_ticks.")[0] + "_forces.png")
    force_traces(ticks, out, args.frame, title)
    print(f"plot: {out}")
    return 0
