"""Command line: ``python launch.py COMMAND ...`` == ``grasp-ctrl COMMAND ...``.

Each command lives in its own module ``grasp_ctrl/cli/cmd_<name>.py`` exposing
``NAME``, ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``; they are
discovered here, so adding a command touches no shared file. With no
arguments the main job runs (``run`` with its defaults).
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import signal
import sys
import threading
from collections.abc import Sequence
from types import ModuleType
from typing import Any

from grasp_ctrl.cli._ranges import apply_ranges
from grasp_ctrl.errors import SIGNALLED, GraspCtrlError, Terminated

PROG = "grasp-ctrl"


def _command_modules(only: str | None = None) -> list[ModuleType]:
    """Every command's module; ``only``: just that command's (``cmd_<name>.py``, its NAME's
    dashes as underscores) when there is one, so a command loads no other's imports."""
    names = [info.name for info in pkgutil.iter_modules(__path__) if info.name.startswith("cmd_")]
    if only is not None and f"cmd_{only.replace('-', '_')}" in names:
        names = [f"cmd_{only.replace('-', '_')}"]
    mods = [importlib.import_module(f"{__name__}.{name}") for name in names]
    return sorted(mods, key=lambda m: getattr(m, "ORDER", 100))


class _OneLineErrorParser(argparse.ArgumentParser):
    """argparse prints usage + error and exits 2; keep that, never a traceback."""


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command line; ``command``: only that command's subparser where it names one (what
    it parses is the same, and no other command's module is imported)."""
    parser = _OneLineErrorParser(
        prog=PROG,
        description=(
            "Tactile force-feedback lift-and-place grasping. With no command, runs the main "
            "job: 5 lift-and-place trials per default object in the MuJoCo world."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in _command_modules(command):
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=getattr(mod, "DESCRIPTION", mod.HELP))
        mod.add_arguments(p)
        apply_ranges(mod.NAME, p)  # every number flag checked for type and range (cli/_ranges.py)
        p.set_defaults(_run=mod.run)
    return parser


_signalled = SIGNALLED  # SIGINT / SIGTERM received during this command (errors.py)


def _raise_terminated(signum: int, frame: object) -> None:
    _signalled.append(signum)
    raise Terminated()


def _raise_interrupted(signum: int, frame: object) -> None:
    _signalled.append(signum)
    raise KeyboardInterrupt()


def main(argv: Sequence[str] | None = None) -> int:
    # SIGTERM takes Ctrl-C's path: hardware stops safely, the run stays resumable. Both are
    # noted, because an interrupt inside an extension module's import can surface as another
    # error (numpy's ImportError, say): after a signal any exception is the interrupt's.
    handlers = None
    if threading.current_thread() is threading.main_thread():
        handlers = (signal.signal(signal.SIGTERM, _raise_terminated), signal.signal(signal.SIGINT, _raise_interrupted))
    _signalled.clear()
    status = None
    try:
        status = _main(argv)
        if _signalled and status not in (130, 143):  # an interrupt something swallowed (an ImportError, say)
            print(f"{PROG}: interrupted", file=sys.stderr)
            return 143 if _signalled[-1] == signal.SIGTERM else 130
        return status
    except BaseException as exc:
        if not (isinstance(exc, KeyboardInterrupt) or _signalled) or isinstance(exc, SystemExit):
            raise
        print(f"{PROG}: interrupted", file=sys.stderr)  # before a command started (loading the commands, say)
        terminated = isinstance(exc, Terminated) or (_signalled and _signalled[-1] == signal.SIGTERM)
        return 143 if terminated else 130
    finally:
        if _signalled:
            _quiet_half_built_finalizers()
        _stop_processes(everything=status != 0 or bool(_signalled))
        if handlers is not None:
            signal.signal(signal.SIGTERM, handlers[0])
            signal.signal(signal.SIGINT, handlers[1])


def _quiet_half_built_finalizers() -> None:
    """After an interrupt: a signal that lands inside ``multiprocessing.util.Finalize``'s constructor
    leaves a finalizer without its key, and when its object dies the finalizer raises AttributeError,
    which Python prints as "Exception ignored in: <Finalize object, dead>" with a traceback. Only
    that report is dropped; every other unraisable exception still reaches the default hook."""
    default = sys.unraisablehook

    def hook(unraisable: Any) -> None:
        target = type(unraisable.object)
        if (
            isinstance(unraisable.exc_value, AttributeError)
            and target.__module__ == "multiprocessing.util"
            and target.__name__ == "Finalize"
        ):
            return
        default(unraisable)

    sys.unraisablehook = hook


def _stop_processes(everything: bool) -> None:
    """None of the command's processes outlives it: the fork server and the resource tracker are
    stopped and reaped, and ``everything`` (after an interrupt or an error) any worker pool still
    open too; a signal meanwhile is only noted. Nothing to do unless the command started
    worker processes (then process_cleanup is loaded)."""
    cleanup = sys.modules.get("grasp_ctrl.trials.runs.process_cleanup")
    if cleanup is not None and everything:
        cleanup.stop_all()
    elif cleanup is not None:
        cleanup.stop_idle_helpers()


def _main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:
        argv = ["run"]
    parser = build_parser(argv[0])
    bad = next((a for a in argv if "\x00" in a), None)
    if bad is not None:  # no file or name can hold one; open() would raise deep inside
        print(f"{PROG}: error: argument {bad!r}: contains a NUL character", file=sys.stderr)
        return 2
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse printed its usage and one error line (or the help)
        return exc.code if isinstance(exc.code, int) else 2
    if not getattr(args, "_run", None):
        parser.print_help()
        return 2
    args._argv = list(argv)  # the command as given (tune --write records it in the object file)
    try:
        return int(args._run(args) or 0)
    except GraspCtrlError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return exc.exit_status
    except KeyboardInterrupt as exc:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 143 if isinstance(exc, Terminated) else 130
    except BrokenPipeError:
        # Output piped into e.g. `head`: not an error of ours.
        sys.stderr.close()
        return 0
    except OSError as exc:
        # A file the user named cannot be written or read (a directory, no such folder,
        # no permission, disk full): one line, not a traceback.
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"{PROG}: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 1
