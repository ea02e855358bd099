"""``export-bag``: a trial, a run's trials or a tactile recording as a ROS 2 bag (MCAP)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "export-bag"
HELP = "write a trial (or every trial of a run, or a tactile recording) as a ROS 2 bag in MCAP (the ros extra)"
DESCRIPTION = (
    "Writes the trial's tick log as a ROS 2 bag in one MCAP file, CDR-encoded standard messages at the "
    "trial's times: /joint_states and /joint_goals (sensor_msgs/JointState), /fingertips/FINGER/force_estimated "
    "and .../force_true (geometry_msgs/WrenchStamped in FINGER_sensor), /controller/state, "
    "/controller/transitions and /trial/events (std_msgs/String), /object/pose (geometry_msgs/PoseStamped), "
    "/tf (tf2_msgs/TFMessage: world, hand, every link and sensor frame of the hand file) and, where the log "
    "holds whole raw frames, /biotac_pub (biotac_sensors/BioTacHand). A run directory gives one bag per trial, "
    "OUT/POLICY/OBJECT/trial_NNN.mcap; a tactile recording (sensors --record) gives its frames on /biotac_pub. "
    "Open the bag in Foxglove (layout: docs/foxglove_trial_layout.json) or play it with 'ros2 bag play'; "
    "topics, frames and units: docs/ros_bags.md. 'export' is the policy exporter. A trial whose record is "
    "unreadable, or whose hand file is not the one the run recorded (run.json unreadable or missing, the "
    "hand file gone or edited since: its SHA-256 differs), is refused without --hand FILE or --force; "
    "what could not be loaded is a note on stderr."
)
ORDER = 6


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import add_hand_file

    p.add_argument(
        "source",
        metavar="TRIAL",
        help="trial_NNN.json or trial_NNN_ticks.parquet, a run directory, or a tactile recording CSV",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="OUT.mcap",
        help="the bag (an .mcap file, or - for standard output); for a run directory, a folder",
    )
    add_hand_file(
        p,
        resolved=False,
        help="the trials' hand file (default: the one in the run's run.json, when its SHA-256 is still the "
        "one run.json recorded)",
    )
    p.add_argument("--hand-id", default="", metavar="ID", help="a recording's BioTacHand hand_id (default: empty)")
    p.add_argument(
        "--force",
        action="store_true",
        help="overwrite existing bags; export a trial whose record is unreadable (without its events and "
        "metadata) or whose hand file is unknown or changed since the run (with that file or the default); "
        "notes say what the bag lacks",
    )


def _kind(source: Path) -> str:
    from grasp_ctrl.bags.recording import is_recording
    from grasp_ctrl.errors import UsageError

    name = source.name
    if source.is_dir():
        if (source / "run.json").is_file():
            return "run"
        raise UsageError(f"{source}: a folder without run.json; give a run directory or one trial")
    if not source.exists():
        raise UsageError(f"{source}: no such file")
    if name.endswith((".json", "_ticks.parquet", "_ticks.csv")):
        return "trial"
    if is_recording(source):
        return "recording"
    raise UsageError(
        f"{source}: not a trial (trial_NNN.json, trial_NNN_ticks.parquet), a run directory "
        "or a tactile recording (a CSV starting t_recv,finger,seq)"
    )


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.bags import export, require_ros
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.safe_write import destination
    from grasp_ctrl.trials.analysis.trial_view import print_notes

    require_ros()
    source = Path(args.source)
    kind = _kind(source)
    out = Path(args.out)
    hand_file = Path(args.hand) if args.hand else None
    if args.hand_id and kind != "recording":
        raise UsageError("--hand-id: only for a tactile recording (a trial's bag names its hand file's hand)")
    if kind == "recording" and hand_file is not None:
        raise UsageError("--hand: only for trials (a recording's bag holds its frames only)")
    if kind == "run":
        if out.suffix.lower() == ".mcap":
            raise UsageError(f"--out {out}: a run directory gives one bag per trial; give a folder")
        written = export.export_run(source, out, hand_file, force=args.force, incomplete_ok=args.force)
    else:
        export.check_bag_out(out, args.force)
        if kind == "trial":
            written = [export.export_trial(source, out, hand_file, incomplete_ok=args.force)]
        else:
            written = [export.export_recording(source, out, args.hand_id)]
    # a bag on this process's standard output (or another of its descriptors) owns it: lines to stderr
    say = sys.stderr if destination(out, "--out").kind in ("stdout", "fd") else sys.stdout
    for w in written:
        print(w.line(), file=say)
    print_notes([n for w in written for n in w.notes])  # on stderr: what the trial loader could not load
    print("(open in Foxglove with docs/foxglove_trial_layout.json, or: ros2 bag play FILE.mcap)", file=say)
    return 0
