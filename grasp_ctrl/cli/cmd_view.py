"""``view``: open MuJoCo's viewer on the scene of one object (``--backend mujoco``)."""

from __future__ import annotations

import argparse
import os
import sys

from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

NAME = "view"
HELP = "look at the MuJoCo scene of one object (hand at its start pose) in MuJoCo's viewer"
DESCRIPTION = (
    "Builds the scene that 'run --backend mujoco' uses for OBJECT (hand file, object profile, seed) and "
    "opens MuJoCo's interactive viewer on it (needs a display). The hand holds its open "
    "posture above the object; the simulation runs in the viewer. Without a display: a clear message, or "
    "--save-xml FILE to write the scene's MJCF for another machine."
)
ORDER = 40


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.cli._common_options import add_hand_file, add_object_file
    from grasp_ctrl.rigs.registry import REFERENCE_WORLD

    p.add_argument(
        "--backend", choices=(REFERENCE_WORLD,), default=REFERENCE_WORLD, help="the world to show (only mujoco)"
    )
    p.add_argument("--object", required=True, metavar="NAME", help="an object of the object file")
    add_hand_file(p, resolved=False)
    add_object_file(p, resolved=False)
    p.add_argument("--seed", type=int, default=0, metavar="S", help="draws the placement jitter (default 0)")
    p.add_argument("--save-xml", default=None, metavar="FILE", help="write the scene's MJCF here (no display needed)")


def has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) or sys.platform in ("darwin", "win32")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from grasp_ctrl.config.hand import load_hand
    from grasp_ctrl.config.objects import load_objects
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.files.paths import default_hand_file, default_objects_file
    from grasp_ctrl.sim.mujoco.world import MuJoCoWorld

    hand = load_hand(Path(args.hand or default_hand_file()))
    objects = load_objects(Path(args.object_file or default_objects_file()), hand.name)
    if args.object not in objects:
        raise UsageError(f"--object: no object {args.object!r} (known: {', '.join(objects)})")
    world = MuJoCoWorld(hand, objects[args.object], args.seed)
    if args.save_xml:
        write_output(check_output(args.save_xml, "--save-xml"), world.scene.xml)
        print(f"scene: {args.save_xml}")
    if not has_display():
        if not args.save_xml:
            print(
                "view: no display (DISPLAY is not set), so MuJoCo's viewer cannot open here; run it on a machine "
                "with a screen, or write the scene with --save-xml FILE and open it with "
                "'python -m mujoco.viewer --mjcf FILE'",
                file=sys.stderr,
            )
            return 2
        return 0
    import mujoco.viewer

    mujoco.viewer.launch(world.model, world.data)
    return 0
