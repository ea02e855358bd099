"""Arguments shared by the learning commands (train, evaluate)."""

from __future__ import annotations

import argparse

from grasp_ctrl.errors import UsageError


def add_data_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("data (one of)")
    g.add_argument(
        "--data", nargs="+", metavar="FILE", default=[], help="dataset CSV/Parquet file(s) (docs/learning.md: columns)"
    )
    g.add_argument(
        "--synthetic",
        type=int,
        metavar="N",
        default=0,
        help="generate N force samples per source with the mock world's BioTac model",
    )
    g.add_argument(
        "--grasp-contacts",
        metavar="FILE",
        help="with --synthetic: half of the ball-ft presses at these recorded grasp contacts (a "
        "grasp-contacts CSV: where the hand's grasps load a fingertip in MuJoCo)",
    )
    p.add_argument("--seed", type=int, default=0, help="data generation, split and initialisation seed")
    p.add_argument(
        "--tare-frames",
        type=int,
        default=10,
        help="raw signals: each trial starts with at least this many contact-free rows labelled 0 0 0, "
        "whose mean is its tare baseline",
    )
    p.add_argument(
        "--skip-bad-rows", action="store_true", help="leave bad rows out (each is reported) instead of failing"
    )
    p.add_argument("--test-per-source", type=int, default=1500, help="test samples per source (paper: 1500)")


def data_spec(args: argparse.Namespace):
    from grasp_ctrl.learning.pipeline import DataSpec

    if bool(args.data) == bool(args.synthetic):
        raise UsageError("give either --data FILE ... or --synthetic N")
    if args.synthetic < 0:
        raise UsageError(f"--synthetic: a positive number of samples (got {args.synthetic})")
    if args.grasp_contacts and not args.synthetic:
        raise UsageError("--grasp-contacts goes with --synthetic N (recorded data files already hold their presses)")
    return DataSpec(
        files=args.data,
        synthetic_per_source=args.synthetic,
        seed=args.seed,
        tare_frames=args.tare_frames,
        skip_bad=args.skip_bad_rows,
        grasp_contacts=args.grasp_contacts,
    )


def require_torch() -> None:
    try:
        import torch  # noqa: F401
    except ImportError:
        raise UsageError("this command needs torch: pip install .[train]") from None


def parse_sources(text: str) -> tuple[str, ...]:
    from grasp_ctrl.learning.dataset import SOURCES

    if text == "mixed":
        return SOURCES
    names = tuple(s.strip() for s in text.split(",") if s.strip())
    bad = [s for s in names if s not in SOURCES]
    if bad or not names:
        raise UsageError(f"--sources: mixed or a comma list of {', '.join(SOURCES)} (got {text!r})")
    return names
