"""``grasp-contacts``: record where the hand's grasps press its fingertips, in MuJoCo."""

from __future__ import annotations

import argparse

NAME = "grasp-contacts"
HELP = "record the fingertip contacts of oracle grasps in MuJoCo (training data for the learned policies)"
DESCRIPTION = (
    "Runs lift-and-place trials in the reference world (MuJoCo) with the true forces (the oracle) and "
    "writes, every --every control periods, each fingertip contact with the object as the BioTac model "
    "saw it: the contact point and the skin's normal there (sensor frame) and the force on the skin. "
    "fit-mock-policies, synth, train and evaluate (--grasp-contacts FILE) press simulated sensors at "
    "these contacts, so the learned policies see where this hand's grasps load a fingertip. Use seeds "
    "that no reported run uses (the default base seed, 1000, is one)."
)
ORDER = 78


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import add_hand_file, add_object_file, add_object_list
    from grasp_ctrl.sim.biotac.grasp_contacts import DEFAULT_EVERY, DEFAULT_SEED

    p.add_argument("--out", required=True, metavar="FILE.csv", help="contacts CSV to write")
    add_hand_file(p)
    add_object_file(p)
    add_object_list(p, help="objects to grasp, separated by commas, or all (default: the object file's default_set)")
    p.add_argument("--trials", type=int, default=5, help="oracle trials per object (default 5)")
    p.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"base seed of the trials (default {DEFAULT_SEED})")
    p.add_argument(
        "--every",
        type=int,
        default=DEFAULT_EVERY,
        help=f"keep the contacts of every Nth control period (default {DEFAULT_EVERY})",
    )
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")


def run(args: argparse.Namespace) -> int:
    import sys

    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.safe_write import check_new_file, check_output, write_output
    from grasp_ctrl.sim.biotac.grasp_contacts import csv_text
    from grasp_ctrl.trials.episode.contact_recorder import record_grasp_contacts
    from grasp_ctrl.trials.runs.selection import select_objects

    out = check_output(args.out, "--out", formats=("csv",))
    assert out is not None
    check_new_file(out, "--out", args.force)
    hand = load_hand(args.hand)
    objects = select_objects(args.object_file, args.objects, hand=hand.name)
    gc = record_grasp_contacts(
        hand,
        objects,
        args.trials,
        args.seed,
        args.every,
        progress=lambda line: print(line, file=sys.stderr, flush=True),
    )
    if not len(gc):
        raise UsageError("no fingertip touched an object: nothing to write")
    write_output(out, csv_text(gc))
    print(f"wrote {out}: {gc.summary()}, {args.trials} oracle trial(s) per object, seed {args.seed}")
    return 0
