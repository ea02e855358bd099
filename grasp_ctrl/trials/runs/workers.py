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

import contextlib
import multiprocessing
import signal
import threading
from typing import Any, Iterator

PRELOAD = ["grasp_ctrl.trials.runs.worker_preload"]


def worker_context() -> Any:
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        _start_forkserver_without_sigint()
        return ctx
    return multiprocessing.get_context("spawn")


def _start_forkserver_without_sigint() -> None:
    """Start the fork server now with SIGINT ignored: an ignored signal stays ignored
    across fork and exec, Python then installs no KeyboardInterrupt handler, and the
    workers the server forks keep the disposition. Meanwhile SIGINT is blocked here too
    (Linux queues a blocked signal even while it is ignored), so a Ctrl-C during the
    start reaches this process as KeyboardInterrupt once its handler is back."""
    from multiprocessing import forkserver

    if threading.current_thread() is not threading.main_thread():
        forkserver.ensure_running()   # signal handlers belong to the main thread
        return
    old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        old_handler = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            forkserver.ensure_running()
        finally:
            signal.signal(signal.SIGINT, old_handler)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)


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
