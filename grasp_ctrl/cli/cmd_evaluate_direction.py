"""``evaluate-direction``: force-direction agreement on real BioTac recordings."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

if TYPE_CHECKING:
    import numpy as np

NAME = "evaluate-direction"
HELP = "angle between estimated force directions and labelled plate normals on real BioTac data"
DESCRIPTION = (
    "Tares each trial on its first frames, gates contact (tared pdc > threshold for N frames), estimates "
    "a force direction and reports the angle to the labelled plate normal (median, 75th, 90th percentile, "
    "degrees) after fitting one fixed rotation (and label sign) on one long trial and testing on the "
    "other, both ways, and pooled over both folds' test frames (the README's figure). Estimators: policy:NAME (any policy, e.g. policy:icra19_official), analytic "
    "(Lin et al., relative gains fitted with the rotation), analytic-unit (gains 1,1,1), surface-normal."
)
ORDER = 70

DEFAULT_ESTIMATORS = "policy:icra19_official,analytic,surface-normal"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--data", required=True, help="robotic_finger_tidy.csv (../shared/data/robotic_finger/)")
    p.add_argument(
        "--skip-bad-rows",
        action="store_true",
        help="plate-normal recordings: leave out rows that are short, not numbers, out of range or "
        "with a non-unit normal (counted on stderr) instead of stopping at the first",
    )
    p.add_argument(
        "--estimators", default=DEFAULT_ESTIMATORS, help=f"comma-separated list (default: {DEFAULT_ESTIMATORS})"
    )
    p.add_argument(
        "--trials",
        default="paper",
        help="'paper' (the two long trials, default) or comma-separated trial ids (at least two)",
    )
    p.add_argument("--tare-frames", type=int, default=50, help="frames at the start of a trial used as baseline")
    p.add_argument("--threshold", type=float, default=10.0, help="contact gate: tared pdc above this (counts)")
    p.add_argument("--frames", type=int, default=10, help="contact gate: for this many consecutive frames")
    p.add_argument(
        "--min-pdc",
        type=float,
        default=0.0,
        help="also require tared pdc >= this (drops post-release drift frames; default 0)",
    )
    p.add_argument("--threads", type=int, default=1, help="onnxruntime threads")
    p.add_argument("--json", metavar="FILE", help="also write the results as JSON")


def _estimator(spec: str, threads: int) -> tuple[str, Callable[[np.ndarray], np.ndarray] | None]:
    from grasp_ctrl.estimators.registry import load_policy
    from grasp_ctrl.evaluation import direction as d

    if spec.startswith("policy:"):
        return spec, d.policy_directions(load_policy(spec.split(":", 1)[1], None, threads))
    if spec == "analytic":
        return spec, None
    if spec == "analytic-unit":
        from grasp_ctrl.estimators.analytic import electrode_normal_sums

        return spec, electrode_normal_sums
    if spec == "surface-normal":
        return spec, d.surface_normal_directions
    raise UsageError(f"--estimators: unknown estimator {spec!r} (policy:NAME, analytic, analytic-unit, surface-normal)")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.evaluation.direction import evaluate, gate_trial, pooled_percentiles
    from grasp_ctrl.evaluation.robotic_finger import read_trials

    if args.tare_frames < 1 or args.frames < 1:
        raise UsageError("--tare-frames and --frames must be >= 1")
    trials = read_trials(Path(args.data), skip_bad_rows=args.skip_bad_rows)
    if args.trials == "paper":
        chosen = [t for t in trials if t.in_paper]
    else:
        ids = [s.strip() for s in args.trials.split(",") if s.strip()]
        known = {t.trial_id: t for t in trials}
        unknown = [i for i in ids if i not in known]
        if unknown:
            raise UsageError(f"--trials: unknown trial id {unknown[0]!r}")
        chosen = [known[i] for i in ids]
    if len(chosen) < 2:
        raise UsageError("--trials: at least two trials are needed (fit on one, test on another)")
    samples = [gate_trial(t, args.tare_frames, args.threshold, args.frames, args.min_pdc) for t in chosen]
    for s in samples:
        if len(s.tared) < 10:
            raise UsageError(f"trial {s.trial_id}: only {len(s.tared)} frames in contact")
    specs = [s.strip() for s in args.estimators.split(",") if s.strip()]
    if not specs:
        raise UsageError("--estimators: at least one estimator")
    estimators = [_estimator(spec, args.threads) for spec in specs]  # fail before printing anything
    all_results = []
    pooled = {}
    w = max([28] + [len(name) for name, _ in estimators])
    print(f"{'estimator':{w}s} {'train -> test':44s} {'n_test':>7s} {'median':>7s} {'p75':>7s} {'p90':>7s}  deg")
    for name, fn in estimators:
        results = evaluate(name, samples, fn)
        for r in results:
            all_results.append(r)
            pc = r.percentiles
            extra = f"  gains {['%.3g' % g for g in r.gains]}" if r.gains else ""
            print(
                f"{name:{w}s} {r.train + ' -> ' + r.test:44s} {r.n_test:7d} {pc[50]:7.1f} {pc[75]:7.1f} {pc[90]:7.1f}"
                f"  label sign {r.label_sign:+.0f}{extra}"
            )
        n, pc = pooled_percentiles(results)
        pooled[name] = {"n_test": n, "median_deg": pc[50], "p75_deg": pc[75], "p90_deg": pc[90]}
        label = f"pooled, {len(results)} folds" if len(results) != 2 else "pooled, both folds"
        print(f"{name:{w}s} {label:44s} {n:7d} {pc[50]:7.1f} {pc[75]:7.1f} {pc[90]:7.1f}")
    if args.json:
        doc = {
            "data": str(args.data),
            "gate": {
                "tare_frames": args.tare_frames,
                "threshold": args.threshold,
                "frames": args.frames,
                "min_pdc": args.min_pdc,
            },
            "results": [
                {
                    "estimator": r.estimator,
                    "train": r.train,
                    "test": r.test,
                    "n_train": r.n_train,
                    "n_test": r.n_test,
                    "median_deg": r.percentiles[50],
                    "p75_deg": r.percentiles[75],
                    "p90_deg": r.percentiles[90],
                    "label_sign": r.label_sign,
                    "gains": r.gains,
                }
                for r in all_results
            ],
            "pooled": pooled,
        }

        write_output(check_output(args.json, "--json"), json.dumps(doc, indent=2) + "\n")
    return 0
