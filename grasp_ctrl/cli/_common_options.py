"""The options several commands share, one spelling and one form each (docs/trials.md, "Common options").

Each builder adds its option under the canonical name; an older spelling stays as a hidden alias
(``hidden_alias``): it parses to the same destination and value, prints nothing new and is not
shown by ``--help``, so existing scripts keep working.

| option | form | builder |
|---|---|---|
| ``--hand FILE`` | a hand file (TOML) | ``add_hand_file`` |
| ``--object-file FILE`` (alias ``--objects-file``) | an object file (TOML) | ``add_object_file`` |
| ``--objects a,b|all`` | names separated by commas, or all | ``add_object_list`` |
| ``--controller NAME`` | one of the registry's controllers | ``add_controller`` |
| ``--jobs N``, ``--executor local|ray``, ``--address ADDR`` | where trials run | ``add_jobs_options`` |
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

HAND_DEFAULT = "hand_configs/leap_hand.toml"
OBJECT_FILE_DEFAULT = "hand_configs/objects.toml"
OBJECT_FILE_ALIASES = ("--objects-file",)  # lift-capacity's and grasp-contacts' older spelling
EXECUTORS = ("local", "ray")


def hidden_alias(p: Any, dest: str, *flags: str, **kwargs: Any) -> argparse.Action:
    """``flags`` as another spelling of the option stored in ``dest`` (add it after that option): the same
    value, no default of its own (the canonical option's stays), not shown by ``--help``."""
    return p.add_argument(*flags, dest=dest, default=argparse.SUPPRESS, help=argparse.SUPPRESS, **kwargs)


def add_hand_file(p: Any, *, resolved: bool = True, help: str | None = None) -> None:
    """``--hand FILE``. ``resolved``: the default is the default hand file's path (else None: the
    command picks it, e.g. run's preset, or a run's run.json)."""
    default: str | None = None
    if resolved:
        from grasp_ctrl.files.paths import default_hand_file

        default = str(default_hand_file())
    p.add_argument(
        "--hand", default=default, metavar="FILE", help=help or f"hand config TOML (default: {HAND_DEFAULT})"
    )


def add_object_file(p: Any, *, resolved: bool = True, help: str | None = None) -> None:
    """``--object-file FILE`` (hidden alias ``--objects-file``), stored in ``object_file``.
    ``resolved``: the default is the default object file's path (else None: the command resolves it)."""
    default: str | None = None
    if resolved:
        from grasp_ctrl.files.paths import default_objects_file

        default = str(default_objects_file())
    p.add_argument(
        "--object-file",
        default=default,
        metavar="FILE",
        help=help or f"object profiles TOML (default: {OBJECT_FILE_DEFAULT})",
    )
    hidden_alias(p, "object_file", *OBJECT_FILE_ALIASES, metavar="FILE")


class _CommaJoined(argparse.Action):
    """``--objects a b`` (the old space-separated form) as ``"a,b"``, the spec every command reads."""

    def __call__(self, parser: Any, namespace: Any, values: Any, option_string: str | None = None) -> None:
        words = [values] if isinstance(values, str) else list(values or [])
        setattr(namespace, self.dest, ",".join(words))


def add_object_list(p: Any, *, words: bool = False, help: str | None = None) -> None:
    """``--objects a,b|all``: names separated by commas, or ``all``; stored as that text (None when
    not given: the object file's default_set), for ``trials.runs.selection.select_objects``.
    ``words``: also names separated by spaces (``--objects a b``, lift-capacity's older form), joined
    with commas."""
    text = help or "objects, separated by commas, or all (default: the object file's default_set)"
    if words:
        p.add_argument(
            "--objects",
            nargs="+",
            action=_CommaJoined,
            default=None,
            metavar="a,b|all",
            help=text + "; or NAME NAME ...",
        )
    else:
        p.add_argument("--objects", default=None, metavar="a,b|all", help=text)


def add_controller(p: Any, *, default_note: str = "", more: str = "") -> None:
    """``--controller NAME``, one of the registry's controllers (argparse refuses any other name in
    its one-line error). ``default_note``: added to the default's note; ``more``: a sentence after."""
    from grasp_ctrl.controller.registry import DEFAULT_CONTROLLER, controller_names

    note = f"; {default_note}" if default_note else ""
    p.add_argument(
        "--controller",
        default=None,
        choices=controller_names(),
        help=f"the lift-and-place controller, one of {', '.join(controller_names())} (default: {DEFAULT_CONTROLLER}{note})"
        + (f". {more}" if more else ""),
    )


def add_jobs_options(
    p: Any,
    *,
    jobs_default: int | None,
    jobs_help: str,
    executor_help: str,
    address_help: str = "with --executor ray: a running Ray cluster (e.g. 10.0.0.5:6379 or 'auto')",
    executors: Sequence[str] = EXECUTORS,
) -> None:
    """``--jobs N``, ``--executor local|ray`` and ``--address ADDR``: where a command's trials (or
    models) run. ``jobs_default`` None: the command chooses (run: one per core)."""
    p.add_argument("--jobs", type=int, default=jobs_default, metavar="N", help=jobs_help)
    p.add_argument("--executor", choices=tuple(executors), default="local", help=executor_help)
    p.add_argument("--address", default=None, metavar="ADDR", help=address_help)
