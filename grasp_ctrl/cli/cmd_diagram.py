"""``diagram``: print the controller's state machine as Mermaid."""

from __future__ import annotations

import argparse

NAME = "diagram"
HELP = "print the controller state machine as a Mermaid diagram"
ORDER = 60


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", metavar="FILE", help="write to FILE instead of standard output")


def run(args: argparse.Namespace) -> int:
    from grasp_ctrl.controller.diagram import mermaid

    text = mermaid()
    if args.out:
        from grasp_ctrl.trials.storage import write_text_atomic

        write_text_atomic(args.out, text + "\n")
    else:
        print(text)
    return 0
