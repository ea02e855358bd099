"""``plot``: a trial at a glance as a PNG, its force traces per axis, or an animated replay."""

from __future__ import annotations

import argparse
from pathlib import Path

NAME = "plot"
HELP = "save a trial's forces, release signal, heights and states as PNG (or an animated replay)"
DESCRIPTION = (
    "Plot one trial from its tick log: per fingertip the normal and tangential force, estimated and "
    "(on the mock) true, with tau; the release fingertip's force on the object along +z with the "
    "release threshold; the object's and palm's heights; the controller's states as labelled bands and "
    "the moment it ended (done, or fault with its reason). --xyz plots the force components instead; "
    "--animate OUT.gif writes a replay (hand, object, force arrows per fingertip). TRIAL is "
    "trial_NNN.json or trial_NNN_ticks.parquet (or the .csv of older runs) in a run directory. "
    "--rrd OUT.rrd writes a Rerun recording instead (hand links, object, force arrows, states, "
    "series; open it with 'rerun OUT.rrd'; the viz extra), the PNG as well only with --out. "
    "Needs matplotlib (the plot extra) for the PNG and GIF. What could not be loaded (a record or run.json "
    "that does not read, a hand file gone or changed since the run) is a note on stderr; a tick log without "
    "a column the plot needs, or with NaN in it, is an error naming the file and the column."
)
ORDER = 4


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import add_hand_file

    p.add_argument("trial", metavar="TRIAL", help="trial_NNN.json or trial_NNN_ticks.parquet")
    p.add_argument(
        "--out",
        default=None,
        metavar="FILE",
        help="PNG path (default: trial_NNN.png, or trial_NNN_forces.png with --xyz, beside it)",
    )
    p.add_argument("--xyz", action="store_true", help="the estimated force components fx, fy, fz per fingertip instead")
    p.add_argument(
        "--frame",
        choices=("sensor", "world"),
        default="sensor",
        help="with --xyz: the force components' frame (default sensor)",
    )
    p.add_argument(
        "--animate",
        default=None,
        metavar="OUT.gif",
        help="also write an animated replay: hand pose, object, force arrows per fingertip",
    )
    p.add_argument("--fps", type=float, default=12.0, metavar="N", help="replay frames per second (default 12)")
    p.add_argument(
        "--frames",
        type=int,
        default=None,
        metavar="N",
        help="replay: at most N frames, evenly spaced over the trial (default 100)",
    )
    p.add_argument(
        "--rrd",
        default=None,
        metavar="OUT.rrd",
        help="write a Rerun recording of the trial (the viz extra): hand links, object pose, "
        "estimated and true force arrows, controller states, grips/tau/release series; "
        "the PNG is then written only with --out",
    )
    add_hand_file(p, resolved=False, help="replay: the trial's hand file (default: the one in the run's run.json)")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.files.safe_write import IMAGE_FORMATS, check_output
    from grasp_ctrl.trials.analysis.plots import force_traces
    from grasp_ctrl.trials.analysis.trial_plot import trial_figure
    from grasp_ctrl.trials.analysis.trial_view import hand_for_replay, load_trial, print_notes

    check_output(args.out, "--out", formats=IMAGE_FORMATS)
    check_output(args.animate, "--animate", formats=("gif",))
    view = load_trial(Path(args.trial))
    print_notes(view.notes)  # a record or run.json that did not load, a hand file changed since the run
    stem = view.ticks_path.name.split("_ticks.")[0]
    if args.rrd is not None:
        from grasp_ctrl.trials.analysis.rerun_log import require_rerun, write_recording

        require_rerun()
        hand = hand_for_replay(view, Path(args.hand) if args.hand else None)
        print(f"recording: {write_recording(view, hand, Path(args.rrd))}  (open: rerun {args.rrd})")
        if args.out is None and not args.animate:
            return 0
    if args.xyz:
        out = Path(args.out) if args.out else view.ticks_path.with_name(f"{stem}_forces.png")
        force_traces(view.ticks_path, out, args.frame, view.title())
    else:
        out = Path(args.out) if args.out else view.ticks_path.with_name(f"{stem}.png")
        trial_figure(view, out)
    print(f"plot: {out}")
    if args.animate:
        from grasp_ctrl.trials.analysis.replay import MAX_FRAMES, animate

        hand = hand_for_replay(view, Path(args.hand) if args.hand else None)
        print(f"replay: {animate(view, hand, Path(args.animate), fps=args.fps, max_frames=args.frames or MAX_FRAMES)}")
    return 0
