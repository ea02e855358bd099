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
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
    else:
        print(text)
    return 0
