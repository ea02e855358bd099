"""``tune``: sweep an object's controller thresholds and rank them (mock, or real hand with labels)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

NAME = "tune"
HELP = "sweep an object's thresholds (tau, release threshold, ...) on the mock or the real hand and rank them"
DESCRIPTION = (
    "Run the same seeded trials for every combination of the --param values on one object and "
    "rank the settings by success rate, then by mean peak true grip force (lower first). With "
    "--write the best setting goes into the object file (only those lines change; the diff is shown)."
)
ORDER = 5


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.config.objects import TUNABLE
    from grasp_ctrl.estimators.registry import DEFAULT_POLICY
    from grasp_ctrl.paths import default_hand_file, default_objects_file

    p.add_argument("--object", required=True, metavar="NAME", help="the object to tune")
    p.add_argument("--param", required=True, action="append", metavar="NAME=START:STOP:STEP",
                   help=f"a threshold and its values (START:STOP:STEP with STOP included, A,B,C, or one value); "
                        f"repeat for a grid. Tunable: {', '.join(TUNABLE)} (tau and release_threshold also accepted)")
    p.add_argument("--trials", type=int, default=3, metavar="N", help="trials per setting (default 3)")
    p.add_argument("--policy", default=DEFAULT_POLICY, metavar="NAME|PATH", help=f"force estimator (default {DEFAULT_POLICY})")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="base random seed (default 0)")
    p.add_argument("--hand", default=str(default_hand_file()), metavar="FILE", help="hand config TOML")
    p.add_argument("--object-file", default=str(default_objects_file()), metavar="FILE", help="object profiles TOML")
    p.add_argument("--backend", choices=("mock", "dynamixel"), default="mock",
                   help="mock (default); dynamixel: the real hand, each trial labelled by the operator")
    p.add_argument("--port", default=None, metavar="PORT", help="dynamixel: the servo bus port")
    p.add_argument("--sensor-port", default=None, metavar="PORT", help="dynamixel: the fingertip sensors' port")
    p.add_argument("--write", action="store_true", help="write the best setting into the object file")
    p.add_argument("--json", default=None, metavar="FILE", help="write the ranked sweep as JSON")
    p.add_argument("--jobs", type=int, default=1, metavar="N",
                   help="trials in N processes at once (default 1; with --executor ray: the local instance's CPUs)")
    p.add_argument("--executor", choices=("local", "ray"), default="local",
                   help="ray: the trials as Ray tasks (the ray extra), on a local instance or --address")
    p.add_argument("--address", default=None, metavar="ADDR", help="with --executor ray: a running Ray cluster")
    p.add_argument("--quiet", action="store_true", help="no progress line (shown only on a terminal anyway)")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.trials.progress import Progress
    from grasp_ctrl.trials.runner import mock_trial_fn, parallel_trials, trial_seed
    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.trials.selection import select_objects
    from grasp_ctrl.trials.toml_edit import update_object_file
    from grasp_ctrl.trials.tune import apply_setting, format_sweep, parse_param, rank, run_sweep, settings_grid
    from grasp_ctrl.config.checks import check_objects_for_hand

    if args.backend != "mock" and args.jobs != 1:
        raise UsageError("--jobs: the real hand runs one trial at a time")
    from grasp_ctrl.trials.ray_executor import check_executor, ray_trials

    check_executor(args.executor, args.address)
    if args.backend != "mock" and args.executor != "local":
        raise UsageError("--executor ray: the real hand runs here, one trial at a time")
    if args.trials < 1:
        raise UsageError("--trials: must be at least 1")
    if args.jobs < 1:
        raise UsageError("--jobs: must be at least 1")
    if "," in args.object or args.object.strip() == "all":
        raise UsageError("--object: one object name")
    if not 0 <= args.seed < 2**63:
        raise UsageError(f"--seed: an integer from 0 to 2**63-1 (got {args.seed})")
    grid = settings_grid([parse_param(s) for s in args.param])
    hand = load_hand(args.hand)
    (obj,) = select_objects(args.object_file, args.object, flag="--object")
    # every setting of the sweep must also fit the hand (tau below its force limit, ...)
    check_objects_for_hand([apply_setting(obj, s) for s in grid], hand, f"--param ({obj.name})")
    if args.backend == "dynamixel":
        # No ground truth on the real hand: the operator labels every trial.
        from grasp_ctrl.trials.hardware import hardware_trial_fn
        from grasp_ctrl.trials.labelling import OperatorLabeller, labelled

        run_trial_fn = labelled(
            hardware_trial_fn(hand, [args.policy], None, 1, port=args.port, sensor_port=args.sensor_port),
            OperatorLabeller(),
        )
    else:
        run_trial_fn = mock_trial_fn(hand, [args.policy])

    def one(profile, k):  # type: ignore[no-untyped-def]
        return run_trial_fn(args.policy, profile, k, trial_seed(args.seed, obj.name, k), None)

    progress = Progress(len(grid) * args.trials, enabled=not args.quiet)

    def on_trial(i, setting, rec):  # type: ignore[no-untyped-def]
        rec = dict(rec, policy=", ".join(f"{k}={v:g}" for k, v in setting.items()))
        progress.trial_done(rec)

    def many(tasks):  # type: ignore[no-untyped-def]
        jobs = [(args.policy, profile, k, trial_seed(args.seed, obj.name, k), None) for _, profile, k in tasks]
        if args.executor == "ray":
            return ray_trials(args.address, args.jobs if args.jobs > 1 else None, hand, [args.policy], None, 1, jobs)
        return parallel_trials(min(args.jobs, len(jobs)), hand, [args.policy], None, 1, jobs)

    try:
        rows = rank(run_sweep(obj, grid, args.trials, one, on_trial,
                              many if args.jobs > 1 or args.executor == "ray" else None))
    finally:
        progress.close()
    current = {k: getattr(obj, k) for k in grid[0]}
    print(f"{obj.name}, policy {args.policy}, {args.trials} trials per setting, seed {args.seed} (* = current)")
    print(format_sweep(rows, current))
    best = rows[0]
    if args.json:
        doc = {"object": obj.name, "policy": args.policy, "seed": args.seed, "trials": args.trials,
               "current": current, "ranked": [r.to_json() for r in rows]}
        from grasp_ctrl.trials.storage import write_text_atomic

        write_text_atomic(args.json, json.dumps(doc, indent=2) + "\n")
    if not args.write:
        return 0
    if best.successes == 0:
        print(f"no setting succeeded; {args.object_file} left unchanged", file=sys.stderr)
        return 1
    diff = update_object_file(Path(args.object_file), obj.name, best.setting)
    print(diff.rstrip() if diff else f"{args.object_file}: the best setting is already there; unchanged")
    return 0
