"""``run``: lift-and-place trials (objects x policies x trials) and the run summary."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

NAME = "run"
HELP = "run lift-and-place trials and score them (the main job)"
DESCRIPTION = (
    "Run lift-and-place trials: every policy runs the same trials (same seeds) on every object. "
    "Writes per-trial records and tick logs under --out and prints a per-object success table."
)
ORDER = 1


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.estimators.registry import DEFAULT_POLICY
    from grasp_ctrl.paths import default_hand_file, default_objects_file

    p.add_argument("--hand", default=str(default_hand_file()), metavar="FILE",
                   help="hand config TOML (default: hand_configs/leap_hand.toml)")
    p.add_argument("--object-file", default=str(default_objects_file()), metavar="FILE",
                   help="object profiles TOML (default: hand_configs/objects.toml)")
    p.add_argument("--backend", choices=("mock", "dynamixel"), default="mock",
                   help="mock: simulated hand, sensors and objects (default); dynamixel: the real hand")
    p.add_argument("--objects", default=None, metavar="a,b|all",
                   help="objects to run (default: the object file's default_set)")
    p.add_argument("--policy", nargs="+", action="extend", metavar="NAME|PATH",
                   help=f"force estimator(s): a name in policies/, a path to a policy .json/.onnx, "
                        f"or on the mock 'oracle' / 'oracle:scale=K' (default: {DEFAULT_POLICY}); repeatable")
    p.add_argument("--trials", type=int, default=5, metavar="N", help="trials per object and policy (default 5)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="base random seed (default 0)")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="run directory for logs (default: runs/<date>-<time>-seed<S>)")
    p.add_argument("--json", default=None, metavar="FILE", help="also write the run summary JSON here")
    p.add_argument("--threads", type=int, default=1, metavar="N", help="inference threads per policy (default 1)")
    p.add_argument("--no-tick-logs", action="store_true", help="skip the per-tick CSV logs (faster)")
    p.add_argument("--quiet", action="store_true", help="no per-trial progress lines")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.estimators.registry import DEFAULT_POLICY
    from grasp_ctrl.trials.runner import run_series
    from grasp_ctrl.trials.selection import load_hand_file, select_objects
    from grasp_ctrl.trials.summary import format_table

    if args.trials < 1:
        raise UsageError("--trials: must be at least 1")
    if args.threads < 1:
        raise UsageError("--threads: must be at least 1")
    if args.backend != "mock":
        raise UsageError("--backend dynamixel: the real-hand trial runner is not available yet; use hand-check to test a hand")
    hand = load_hand_file(args.hand)
    objects = select_objects(args.object_file, args.objects)
    policies = args.policy or [DEFAULT_POLICY]
    if len(set(policies)) != len(policies):
        raise UsageError("--policy: each policy once")
    run_dir = Path(args.out) if args.out else Path("runs") / f"{time.strftime('%Y%m%d-%H%M%S')}-seed{args.seed}"
    summary = run_series(
        hand, objects, policies, args.trials, args.seed, run_dir,
        progress=not args.quiet, tick_logs=not args.no_tick_logs, threads=args.threads,
    )
    print(format_table(summary))
    print(f"logs: {run_dir}")
    if args.json:
        Path(args.json).write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
        print(f"summary: {args.json}")
    return 0
