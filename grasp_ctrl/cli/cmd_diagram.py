"""``diagram``: the controller's state machine as Mermaid text, or as SVG/PNG."""

from __future__ import annotations

import argparse
from pathlib import Path

from grasp_ctrl.files.safe_write import check_output, write_output  # noqa: F401

NAME = "diagram"
HELP = "print the controller state machine as a Mermaid diagram (or draw it as SVG/PNG)"
DESCRIPTION = (
    "Print a controller's state machine as a Mermaid stateDiagram: every transition with its guard "
    "condition, and the failure reason of every edge into fault. With --out FILE.svg or FILE.png the "
    "diagram is drawn instead (needs matplotlib, the plot extra); any other --out gets the Mermaid text."
)
ORDER = 60
PICTURE_SUFFIXES = (".svg", ".png")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from grasp_ctrl.controller.registry import controller_names

    p.add_argument("--out", metavar="FILE", help="write to FILE instead of standard output (.svg/.png: a picture)")
    p.add_argument(
        "--controller",
        choices=controller_names(),
        default="paper",
        help="the controller whose state machine to draw (default: paper, the paper's; grip_load adds "
        "the preshape and load states)",
    )
    p.add_argument(
        "--hand",
        metavar="FILE",
        help="with the hand file's own choices of the controller's settings ([controllers.NAME]) in the guards' words",
    )


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.controller.diagram import draw, mermaid
    from grasp_ctrl.controller.registry import settings_for

    hand = None
    if args.hand:
        from grasp_ctrl.config.hand import load_hand

        hand = load_hand(args.hand)
    settings = settings_for(args.controller, hand)
    if args.out and Path(args.out).suffix.lower() in PICTURE_SUFFIXES:
        print(f"diagram: {draw(Path(args.out), settings)}")
        return 0
    text = mermaid(settings)
    if args.out:
        write_output(check_output(args.out, "--out"), text + "\n")
    else:
        print(text)
    return 0
