"""``synth``: write the simulated dataset (the data of ``train --synthetic``) as a dataset file."""

from __future__ import annotations

import argparse
from pathlib import Path

from grasp_ctrl.errors import UsageError

NAME = "synth"
HELP = "write simulated force samples (mock BioTac model) as a dataset CSV"
DESCRIPTION = (
    "Simulate presses of the three ground-truth sources with the mock world's BioTac model (the data of "
    "`train --synthetic N`) and write them in the dataset format of docs/learning.md: tared signals, force "
    "labels, `projected` and R_world_sensor, one row per force sample. With --raw the file holds raw "
    "signals and each trial's whole stream: 20 contact-free rows labelled 0 0 0 (the reader's tare "
    "baseline), then every frame of the press, labelled (unsolved planar-push frames unlabelled); the "
    "reader tares and gates it into the same samples. `train --data FILE --seed S` then trains exactly "
    "like `train --synthetic N --seed S` (all three sources)."
)
ORDER = 69


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--sources",
        default="mixed",
        help="mixed (default), or a comma list of rigid-ft, ball-ft, planar-pushing (always simulated "
        "in that order, so a subset holds the same trials as the full set where the order allows)",
    )
    p.add_argument("--n", type=int, required=True, metavar="N", help="at least N force samples per source")
    p.add_argument("--seed", type=int, default=0, help="simulation seed (same as train --synthetic --seed)")
    p.add_argument("--out", required=True, metavar="FILE.csv", help="dataset CSV to write")
    p.add_argument(
        "--raw",
        action="store_true",
        help="raw signals with each trial's tare rows and whole stream instead of tared samples",
    )
    p.add_argument(
        "--grasp-contacts",
        metavar="FILE",
        help="half of the ball-ft presses at these recorded grasp contacts (a grasp-contacts CSV)",
    )
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.cli._learning_args import parse_sources
    from grasp_ctrl.files.safe_write import check_new_file
    from grasp_ctrl.learning.dataset import SOURCES, Dataset, write_csv, write_raw_csv
    from grasp_ctrl.learning.synthetic import generate_trials

    chosen = set(parse_sources(args.sources))
    sources = tuple(s for s in SOURCES if s in chosen)
    if args.n < 1:
        raise UsageError(f"--n: a positive number of samples per source (got {args.n})")
    out = Path(args.out)
    if out.suffix.lower() != ".csv":
        raise UsageError(f"--out: {out}: a .csv file name expected")
    check_new_file(out, "--out", args.force)
    from grasp_ctrl.sim.biotac.grasp_contacts import load_contacts

    trials = generate_trials(args.n, seed=args.seed, sources=sources, contacts=load_contacts(args.grasp_contacts))
    samples = Dataset.concat([tr.dataset() for tr in trials if tr.keep.any()])
    try:
        if args.raw:
            rows = [tr.raw_rows() for tr in trials]
            write_raw_csv(out, rows)
            n_rows = sum(len(r.t) for r in rows)
        else:
            write_csv(out, samples)
            n_rows = len(samples)
    except OSError as exc:
        raise UsageError(f"--out: {out}: cannot write ({exc.strerror or exc})") from None
    per_source = ", ".join(f"{s} {int((samples.source == s).sum())}" for s in sources)
    kind = "raw signals, whole streams" if args.raw else "tared signals, force samples only"
    print(
        f"wrote {out}: {n_rows} rows ({kind}), {len(trials)} trials, {len(samples)} force samples "
        f"({per_source}), seed {args.seed}"
    )
    return 0
