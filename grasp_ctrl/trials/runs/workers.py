"""Where the worker processes of ``run --jobs N`` (and ``tune --jobs N``) come from.

Workers are forked from a fork server that has imported the trial code and
loaded the compiled kernels (worker_preload.py), so each starts at once; where
there is no fork server (Windows) they are spawned. Never forked from the
command's own process: no inherited inference sessions or threads.

Ctrl-C is the command's to handle, not the workers': a terminal sends SIGINT to
the whole process group, and a fork server or worker interrupted while importing
numba or scipy would print a traceback and leave the pool half-built. So the fork
server starts with SIGINT ignored (its workers inherit that), and the command
stops the workers itself (runner._stop_workers).
"""

from __future__ import annotations

import atexit
import contextlib
import multiprocessing
import os
import shlex
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Iterator
from typing import Any

PRELOAD = ["grasp_ctrl.trials.runs.worker_preload"]


def worker_context() -> Any:
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        _start_forkserver_without_sigint()
        return ctx
    return multiprocessing.get_context("spawn")


def _start_forkserver_without_sigint() -> None:
    """Start the fork server now with SIGINT ignored from its first instruction: it is launched
    through a two-line shell script (``trap '' INT; exec python ...``); an ignored signal stays
    ignored across exec, Python then installs no KeyboardInterrupt handler, and the workers the
    server forks keep the disposition. This process's own handling is never touched, so no
    Ctrl-C is lost meanwhile. Where no POSIX shell exists, the server starts as Python starts it."""
    from multiprocessing import forkserver, spawn

    shell = shutil.which("sh")
    if shell is None or not hasattr(os, "fork"):
        forkserver.ensure_running()
        return
    python = spawn.get_executable()
    python = os.fsdecode(python) if python is not None else sys.executable
    folder = tempfile.mkdtemp(prefix="grasp_ctrl_forkserver_")
    # The shell opens the script after the exec returns: it goes when this command exits.
    atexit.register(shutil.rmtree, folder, True)
    launcher = os.path.join(folder, "python")
    with open(launcher, "w", encoding="utf-8") as fh:
        fh.write(f"#!{shell}\ntrap '' INT\nexec {shlex.quote(python)} \"$@\"\n")
    os.chmod(launcher, 0o700)
    if not _runs(launcher):  # a temporary folder mounted noexec, say
        forkserver.ensure_running()
        return
    spawn.set_executable(launcher)
    try:
        forkserver.ensure_running()
    finally:
        spawn.set_executable(python)


def _runs(launcher: str) -> bool:
    import subprocess

    try:
        return subprocess.run([launcher, "-c", "pass"], timeout=30, capture_output=True).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


@contextlib.contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends, then raise them as usual. Around
    starting a worker: an interrupt inside ``Process.start`` would leave a forked worker
    the pool never recorded, so never stopped. (A signal mask would not do: any thread,
    an inference pool's say, may take the signal, and Python then raises it in the main
    thread wherever it is; a Python handler always runs in the main thread.)"""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum: int, frame: object) -> None:
        held.append(signum)

    old_int = signal.signal(signal.SIGINT, hold)
    old_term = signal.signal(signal.SIGTERM, hold)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old_int)
        signal.signal(signal.SIGTERM, old_term)
        if held:
            signal.raise_signal(held[0])


def ignore_interrupts() -> None:
    """In a worker: Ctrl-C belongs to the command (for spawned workers, which do not
    inherit the fork server's mask)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
