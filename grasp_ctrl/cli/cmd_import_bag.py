"""``import-bag``: BioTac recordings of ROS bags into the tactile recording format."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

NAME = "import-bag"
HELP = "read biotac_sensors/BioTacHand messages of ROS 1/ROS 2 bags into a tactile recording (the ros extra)"
DESCRIPTION = (
    "Reads the biotac_sensors/BioTacHand messages of a ROS 1 .bag, a ROS 2 .db3 or .mcap file or a ROS 2 "
    "bag folder and writes them as a tactile recording (the CSV of sensors --record: t_recv = header stamp, "
    "finger = bt_position, seq = the frame's number per fingertip, the 44 raw counts). With --wrench TOPIC "
    "(geometry_msgs/WrenchStamped or Wrench, e.g. a force/torque sensor) each bag is one trial and every "
    "frame gets the force at its time (fx, fy, fz, N, in the wrench's frame) and its direction (nx, ny, nz): "
    "evaluate-direction and calibrate (direction-only) read the file, sensors --emulate --emulate-from "
    "replays it in any case. Details: docs/ros_bags.md."
)
ORDER = 74


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("bags", nargs="+", metavar="BAG", help="a .bag, .db3 or .mcap file, or a ROS 2 bag folder")
    p.add_argument("--out", required=True, metavar="RECORDING.csv", help="the recording (or - for standard output)")
    p.add_argument(
        "--topic", metavar="TOPIC", help="the BioTacHand topic (default: the bag's only one, e.g. /biotac_pub)"
    )
    p.add_argument(
        "--wrench",
        metavar="TOPIC",
        help="label every frame with this WrenchStamped/Wrench topic's force at its time (one trial per bag)",
    )
    p.add_argument(
        "--finger",
        type=int,
        metavar="POS",
        help="only the BioTac at this bt_position (needed with --wrench when the bag has several)",
    )
    p.add_argument(
        "--min-force",
        type=float,
        default=None,
        metavar="N",
        help="with --wrench: the force in N a frame needs for its own direction label (default 0.2; "
        "weaker frames take the nearest strong frame's)",
    )
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.bags import require_ros
    from grasp_ctrl.bags.import_ import DEFAULT_MIN_FORCE_N, import_bags
    from grasp_ctrl.bags.recording import write_recording
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.safe_write import check_new_file, check_output, destination

    require_ros()
    if args.min_force is not None and args.wrench is None:
        raise UsageError("--min-force: only with --wrench")
    min_force = DEFAULT_MIN_FORCE_N if args.min_force is None else args.min_force
    if min_force <= 0:
        raise UsageError(f"--min-force: a force > 0 N (got {min_force:g})")
    if args.finger is not None and not 0 <= args.finger <= 65535:
        raise UsageError(f"--finger: a bt_position 0..65535 (got {args.finger})")
    out = Path(args.out)
    check_output(out, "--out", formats=("csv",))
    check_new_file(out, "--out", args.force)
    bags = [Path(b) for b in args.bags]
    for bag in bags:
        if bag.resolve() == out.resolve():
            raise UsageError(f"--out {out}: that is a bag being read")
    imported = import_bags(bags, args.topic, args.wrench, args.finger, min_force)
    write_recording(out, imported.recording)
    # a recording on this process's standard output (or another of its descriptors) owns it: lines to stderr
    say = sys.stderr if destination(out, "--out").kind in ("stdout", "fd") else sys.stdout
    for s in imported.bags:
        print(s.line(), file=say)
    print(f"recording: {out}: {len(imported.recording)} frames", file=say)
    if destination(out, "--out").is_stream:
        return 0
    if args.wrench is not None:
        print(
            f"(grasp-ctrl evaluate-direction --data {out}; grasp-ctrl calibrate --data {out} --policy NAME --out NEW)",
            file=say,
        )
    else:
        print(f"(replay: grasp-ctrl sensors --emulate --emulate-from {out})", file=say)
    return 0
