"""Nothing a command started outlives it: its worker pools, the fork server and the resource tracker.

A ``--jobs N`` command has more processes than its workers: multiprocessing starts a fork
server (which forks the workers) and a resource tracker, and left to themselves both go only
once every process holding their pipes has exited; a fork server still importing the trial
code goes only after that, and a worker whose start was cut short by Ctrl-C waits for work
forever, keeping both alive. So after Ctrl-C, SIGTERM or an error the command stops them
itself and reaps them before it returns:

- ``abort_pool``: the pool's workers are killed and joined, the pool's manager thread joined;
  the fork server is frozen, every process it forked is killed (also one no pool recorded: a
  start cut short), then the server itself;
- ``stop_all``: every pool still open, the fork server, and the resource tracker, told to stop
  and reaped (the command line, on its way out after an interrupt or an error);
- ``stop_idle_helpers``: the fork server and the resource tracker after a command that ended
  normally (they would go only after it, the fork server taking its time to unload).

A second Ctrl-C meanwhile does not cut a stop short: it is held until the stop is done.
If the command itself dies at once (SIGKILL), the kernel ends the fork server and the workers
with it (Linux: the parent-death signal, ``die_with_parent``); the resource tracker, left
with no writer on its pipe, exits by itself.
"""

from __future__ import annotations

import contextlib
import gc
import os
import pickle
import signal
import sys
import threading
import time
import weakref
from pathlib import Path
from typing import Any, Protocol, cast

from grasp_ctrl.errors import interrupts_held

STOP_TIMEOUT_S = 5.0  # per step: a process that takes longer is killed
FORKSERVER_ENV = "GRASP_CTRL_FORKSERVER"  # set for the fork server: the command's pid (0: no death signal)
_PROC = Path("/proc")
_POOLS: weakref.WeakSet[Any] = weakref.WeakSet()  # the pools of this process not yet stopped


class _Lock(Protocol):
    def acquire(self, blocking: bool = ..., timeout: float = ...) -> bool: ...

    def release(self) -> None: ...


class _ForkServerState(Protocol):
    """The private state of CPython's ``multiprocessing.forkserver._forkserver`` stopped here."""

    _lock: _Lock
    _forkserver_pid: int | None
    _forkserver_alive_fd: int | None
    _forkserver_address: str | bytes | None


class _ResourceTrackerState(Protocol):
    """The private state of CPython's ``multiprocessing.resource_tracker._resource_tracker``."""

    _lock: _Lock
    _fd: int | None
    _pid: int | None


def can_find_children() -> bool:
    """Whether a process's children can be listed (Linux /proc): then a worker whose start was
    cut short is still found and stopped, so a start need not hold back Ctrl-C."""
    return (_PROC / "self" / "stat").exists()


def spawn_guard() -> contextlib.AbstractContextManager[None]:
    """Around a pool's ``submit``, which may start a worker: where an unrecorded worker could
    not be found afterwards (no /proc), Ctrl-C is held until the start is done; on Linux it
    lands at once (a fork server still importing can take seconds under load) and
    ``abort_pool`` finds the half-started worker."""
    return contextlib.nullcontext() if can_find_children() else interrupts_held()


def register_pool(pool: Any) -> None:
    """Make a worker pool known to ``stop_all`` (workers.start_pool does, as it starts one)."""
    _POOLS.add(pool)


def abort_pool(pool: Any, timeout: float = STOP_TIMEOUT_S) -> None:
    """After Ctrl-C or an error: the pool's workers are stopped now rather than waited for
    (their trials run again on resume), the pool is shut down and its manager thread joined;
    then, unless another pool of this process is open, the fork server and any worker it forked
    that the pool never recorded (a start cut short). The resource tracker is left to the
    command line (``stop_all``): this process may be a library's user, with resources of its
    own registered there."""
    with interrupts_held():
        _stop_pool(pool, timeout)
        if not _live_pools():  # another pool of this process may still need the fork server
            _stop_forkserver(timeout)


def _live_pools() -> list[Any]:
    return [p for p in list(_POOLS) if not getattr(p, "_shutdown_thread", False)]


def stop_all(timeout: float = STOP_TIMEOUT_S) -> None:
    """Every pool of this process still open, the fork server and the resource tracker; a
    signal meanwhile is only noted (the command line, on its way out after an interrupt or
    an error)."""
    with interrupts_held(reraise=False):
        for pool in list(_POOLS):
            _stop_pool(pool, timeout)
        stop_helpers(timeout)


def stop_idle_helpers(timeout: float = STOP_TIMEOUT_S) -> None:
    """The fork server and the resource tracker, unless a pool of this process still uses them
    (the command line, on its way out after a command that ended normally: they would only go
    after it, the fork server taking its time to unload what it imported)."""
    with interrupts_held(reraise=False):
        if not _live_pools():
            stop_helpers(timeout)


def _stop_pool(pool: Any, timeout: float) -> None:
    # The workers go before the pool shuts down: the shutdown lets go of the pool's queues,
    # whose semaphores a worker still starting up must find.
    # SIGKILL: the workers ignore SIGTERM (workers.py), and their trials are abandoned anyway.
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for proc in processes:
        with contextlib.suppress(Exception):
            if proc.is_alive():
                proc.kill()
    deadline = time.monotonic() + timeout
    for proc in processes:
        with contextlib.suppress(Exception):
            proc.join(timeout=max(0.0, deadline - time.monotonic()))
    manager = getattr(pool, "_executor_manager_thread", None)
    with contextlib.suppress(Exception):
        pool.shutdown(wait=False, cancel_futures=True)
    # Joined here, not at exit: at exit Python wakes the manager thread through a pipe that the
    # thread may be closing that very moment (a traceback after the one-line message).
    if manager is not None and manager is not threading.current_thread():
        manager.join(timeout=timeout)
    _POOLS.discard(pool)


def stop_helpers(timeout: float = STOP_TIMEOUT_S) -> None:
    """Stop and reap the fork server, the processes it forked and the resource tracker, if this
    process started them (a later pool starts new ones). For a process about to exit: the
    tracker, once stopped, unlinks whatever this process still registered with it, as at exit."""
    with interrupts_held():
        _stop_forkserver(timeout)
        _stop_resource_tracker(timeout)


def _stop_forkserver(timeout: float) -> None:
    if "multiprocessing.forkserver" not in sys.modules:
        return
    from multiprocessing import forkserver, util

    server = cast(_ForkServerState, forkserver._forkserver)
    if getattr(server, "_forkserver_pid", None) is None or not server._lock.acquire(timeout=timeout):
        return
    try:
        pid = server._forkserver_pid
        if pid is None:
            return
        forked: list[int] = []
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGSTOP)  # frozen, it forks no more: its children are all there is
            forked = children(pid)
            for child in forked:
                with contextlib.suppress(OSError):
                    os.kill(child, signal.SIGKILL)
            os.kill(pid, signal.SIGKILL)
        _reap(pid, timeout)
        _wait_gone(forked, timeout)
        alive_fd = server._forkserver_alive_fd
        if alive_fd is not None:
            with contextlib.suppress(OSError):
                os.close(alive_fd)
        address = server._forkserver_address
        if isinstance(address, str) and not util.is_abstract_socket_namespace(address):
            with contextlib.suppress(OSError):
                os.unlink(address)
        server._forkserver_pid = server._forkserver_alive_fd = server._forkserver_address = None
    finally:
        server._lock.release()


def _stop_resource_tracker(timeout: float) -> None:
    if "multiprocessing.resource_tracker" not in sys.modules:
        return
    from multiprocessing import resource_tracker

    tracker = cast(_ResourceTrackerState, resource_tracker._resource_tracker)
    if getattr(tracker, "_fd", None) is None or getattr(tracker, "_pid", None) is None:
        return  # not running, or started by another process
    gc.collect()  # the stopped pools' queues: their semaphores are unlinked (and unregistered) now
    if _semaphores_alive():
        return  # their unregistering would start another tracker; this one goes when we exit
    if not tracker._lock.acquire(timeout=timeout):
        return
    try:
        fd, pid = tracker._fd, tracker._pid
        if fd is None or pid is None:
            return
        tracker._fd = tracker._pid = None
        with contextlib.suppress(OSError):
            os.close(fd)  # end of its pipe: it exits once no process holds the pipe
        if not _reap(pid, timeout):
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
            _reap(pid, timeout)
    finally:
        tracker._lock.release()


def _semaphores_alive() -> bool:
    """Whether a multiprocessing semaphore of this process still waits for its finalizer."""
    synchronize = sys.modules.get("multiprocessing.synchronize")
    if synchronize is None:
        return False
    from multiprocessing import util

    cleanup = getattr(synchronize.SemLock, "_cleanup", None)
    registry = getattr(util, "_finalizer_registry", {})
    return any(getattr(f, "_callback", None) is cleanup for f in list(registry.values()))


def _reap(pid: int, timeout: float) -> bool:
    """Wait up to ``timeout`` for the child ``pid`` to end; True once it has (or was reaped)."""
    deadline = time.monotonic() + timeout
    delay = 0.001
    while True:
        try:
            done, _ = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            return True
        if done:
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(delay)
        delay = min(delay * 2, 0.05)


def _state(pid: int) -> str | None:
    """A process's state letter (``Z``: a zombie), None once it is gone."""
    try:
        stat = (_PROC / str(pid) / "stat").read_text()
    except OSError:
        return None
    return stat[stat.rindex(")") + 2 :].split(maxsplit=1)[0]


def children(pid: int) -> list[int]:
    """The live children of ``pid`` (Linux /proc; elsewhere none are found)."""
    found = []
    try:
        entries = list(_PROC.iterdir())
    except OSError:
        return []
    for entry in entries:
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] not in ("Z", "X") and int(fields[1]) == pid:
            found.append(int(entry.name))
    return found


def _wait_gone(pids: list[int], timeout: float) -> None:
    """Wait up to ``timeout`` until every process of ``pids`` has ended (a zombie has)."""
    deadline = time.monotonic() + timeout
    for pid in pids:
        while _state(pid) not in (None, "Z", "X") and time.monotonic() < deadline:
            time.sleep(0.005)


def _prctl() -> Any:
    """libc's ``prctl`` (Linux), or None."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def die_with_parent(prctl: Any = None) -> bool:
    """Ask the kernel to kill this process when the thread that started it ends (Linux
    ``PR_SET_PDEATHSIG``); False where that cannot be asked."""
    prctl = prctl or _prctl()
    if prctl is None:
        return False
    return prctl(1, int(signal.SIGKILL), 0, 0, 0) == 0  # 1: PR_SET_PDEATHSIG


def forkserver_dies_with_command() -> None:
    """In the fork server, first thing: it dies with the command that started it, and every
    worker it forks dies with the server. A command killed at once then leaves neither."""
    parent = os.environ.pop(FORKSERVER_ENV, None)
    prctl = _prctl()
    if parent is None or not parent.isdigit() or prctl is None:
        return  # not a fork server of ours, or no death signal here
    # 0: started from another thread than the main one, whose end is not the command's
    if int(parent) and die_with_parent(prctl) and os.getppid() != int(parent):
        os._exit(0)  # the command was gone before the death signal was asked for
    server = os.getpid()

    def in_worker() -> None:
        if die_with_parent(prctl) and os.getppid() != server:
            os._exit(0)
        sys.excepthook = _quiet_if_cut_short(sys.excepthook)

    os.register_at_fork(after_in_child=in_worker)


def _quiet_if_cut_short(hook: Any) -> Any:
    """In a worker just forked, for what fails before it runs: its start arrives through a pipe
    from the command, and a start that Ctrl-C cut short arrives truncated. The command stops
    the worker at once; no traceback of it should reach the terminal first."""

    def excepthook(kind: type[BaseException], value: BaseException, tb: Any) -> None:
        if not issubclass(kind, (EOFError, pickle.UnpicklingError)):
            hook(kind, value, tb)

    return excepthook
