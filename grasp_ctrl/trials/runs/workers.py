"""Where the worker processes of ``run --jobs N`` (and ``tune --jobs N``) come from.

Workers are forked from a fork server that has imported the trial code and
loaded the compiled kernels (worker_preload.py), so each starts at once; where
there is no fork server (Windows) they are spawned. Never forked from the
command's own process: no inherited inference sessions or threads.

Ctrl-C and SIGTERM are the command's to handle, not the workers': a terminal sends
SIGINT to the whole process group (``kill -TERM -PGID`` SIGTERM), and a fork server
or worker interrupted while importing numba or scipy would print a traceback and
leave the pool half-built; a worker ended by the group's SIGTERM before the command
took its own would make the interrupt a "worker ended abruptly" error. So the fork
server starts with both ignored (its workers inherit that), and the command stops
the workers, the fork server and the resource tracker itself (process_cleanup.py),
as multiprocessing's resource tracker, which ignores both too, expects. The fork
server and its workers die with the command if it is killed outright (Linux); the
temporary folders it leaves then (the launcher's, named ``grasp_ctrl_forkserver_PID_*``,
and multiprocessing's ``pymp-*`` that it notes) are removed by the next command that
starts workers, once no process PID exists.
"""

from __future__ import annotations

import atexit
import contextlib
import multiprocessing
import os
import re
import shlex
import shutil
import signal
import stat
import sys
import tempfile
import threading
from collections.abc import Iterator
from typing import Any

from grasp_ctrl.errors import GraspCtrlError
from grasp_ctrl.trials.runs.process_cleanup import FORKSERVER_ENV, interrupts_held, register_pool

PRELOAD = ["grasp_ctrl.trials.runs.worker_preload"]


class WorkerError(GraspCtrlError):
    """A worker process of ``run --jobs N`` (or ``tune --jobs N``) died; the finished trials are on disk."""


@contextlib.contextmanager
def worker_deaths_as_errors() -> Iterator[None]:
    """A worker that died (killed, out of memory) as a WorkerError, one line for the user,
    wherever the pool finds out: a trial's result, or the next submit, when the pool broke
    between the two."""
    from concurrent.futures.process import BrokenProcessPool

    try:
        yield
    except BrokenProcessPool:
        raise WorkerError("a trial worker process ended abruptly (killed, or out of memory?)") from None


def worker_context() -> Any:
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        _start_forkserver_without_sigint()
        return ctx
    return multiprocessing.get_context("spawn")


def _start_forkserver_without_sigint() -> None:
    """Start the fork server now with SIGINT and SIGTERM ignored from its first instruction: it
    is launched through a two-line shell script (``trap '' INT TERM; exec python ...``); an
    ignored signal stays ignored across exec, Python then installs no KeyboardInterrupt handler,
    and the workers the server forks keep the dispositions. This process's own handling is never
    touched, so no Ctrl-C is lost meanwhile. Where no POSIX shell exists, the server starts as
    Python starts it."""
    from multiprocessing import spawn

    shell = shutil.which("sh")
    if shell is None or not hasattr(os, "fork"):
        _ensure_running()
        return
    python = spawn.get_executable()
    python = os.fsdecode(python) if python is not None else sys.executable
    folder = launcher_folder()
    launcher = os.path.join(folder, "python")
    with open(launcher, "w", encoding="utf-8") as fh:
        fh.write(f"#!{shell}\ntrap '' INT TERM\nexec {shlex.quote(python)} \"$@\"\n")
    os.chmod(launcher, 0o700)
    if _runs(launcher):  # it cannot from a temporary folder mounted noexec, say
        spawn.set_executable(launcher)
    try:
        _ensure_running()
    finally:
        spawn.set_executable(python)
    _note_mp_folder(folder)


FOLDER_PREFIX = "grasp_ctrl_forkserver_"
_FOLDER = re.compile(rf"^{FOLDER_PREFIX}(\d+)_")
MP_NOTE = "pymp"  # in our folder: the path of multiprocessing's own folder (the server's socket)


def launcher_folder() -> str:
    """A new temporary folder for the launcher, named after this process
    (``grasp_ctrl_forkserver_PID_RANDOM``) so that a later command can tell it is left over: a
    command killed outright (SIGKILL) runs no atexit. Those left over are removed first."""
    remove_stale_folders()
    folder = tempfile.mkdtemp(prefix=f"{FOLDER_PREFIX}{os.getpid()}_")
    # The shell opens the script after the exec returns: it goes when this command exits.
    atexit.register(shutil.rmtree, folder, True)
    return folder


def _note_mp_folder(folder: str) -> None:
    """Note multiprocessing's folder of this process (``pymp-*``, the fork server's socket) in
    ours: it too stays after a SIGKILL, and its name says nothing of its owner."""
    from multiprocessing import util

    with contextlib.suppress(OSError):
        with open(os.path.join(folder, MP_NOTE), "w", encoding="utf-8") as fh:
            fh.write(util.get_temp_dir())


def remove_stale_folders(root: str | None = None) -> list[str]:
    """Remove the launcher folders (and the ``pymp-*`` folder each notes) of commands whose
    process is gone; only this user's folders, directly in ``root`` (default: the temporary
    folder), never through a link. Returns the folders removed."""
    root = root or tempfile.gettempdir()
    try:
        entries = list(os.scandir(root))
    except OSError:
        return []
    removed = []
    for entry in entries:
        m = _FOLDER.match(entry.name)
        if m and _ours(entry.path) and not _alive(int(m.group(1))):
            noted = _noted_mp_folder(root, entry.path)
            for path in (noted, entry.path) if noted else (entry.path,):
                shutil.rmtree(path, ignore_errors=True)
                removed.append(path)
    return removed


def _ours(path: str) -> bool:
    """A real folder (not a link) of this user."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    uid = getattr(os, "getuid", lambda: st.st_uid)()
    return stat.S_ISDIR(st.st_mode) and st.st_uid == uid


def _noted_mp_folder(root: str, folder: str) -> str | None:
    """The ``pymp-*`` folder a stale launcher folder notes, if it is one of ours in ``root``."""
    try:
        with open(os.path.join(folder, MP_NOTE), encoding="utf-8") as fh:
            noted = fh.read(4096).strip()
    except (OSError, UnicodeDecodeError):
        return None
    name = os.path.basename(noted)
    same_root = os.path.realpath(os.path.dirname(noted)) == os.path.realpath(root)
    return noted if same_root and name.startswith("pymp-") and _ours(noted) else None


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (a PID 0 or out of range names no process of ours: kept)."""
    if not 0 < pid < 2**31:
        return True  # os.kill(0, ...) would mean the process group: not a name we write
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # PermissionError: another user's process
        return True
    return True


def _ensure_running() -> None:
    """Start the resource tracker and the fork server (if not running) with Ctrl-C held, so
    that both are recorded, and so stopped, whenever it lands. The fork server learns this
    process's pid, to die with it (process_cleanup.forkserver_dies_with_command): only when
    started from the main thread, as the kernel's death signal follows the starting thread."""
    from multiprocessing import forkserver

    main = threading.current_thread() is threading.main_thread()
    before = os.environ.get(FORKSERVER_ENV)
    with interrupts_held():
        os.environ[FORKSERVER_ENV] = str(os.getpid() if main else 0)
        try:
            forkserver.ensure_running()
        finally:
            if before is None:
                os.environ.pop(FORKSERVER_ENV, None)
            else:
                os.environ[FORKSERVER_ENV] = before


def _runs(launcher: str) -> bool:
    import subprocess

    try:
        return subprocess.run([launcher, "-c", "pass"], timeout=30, capture_output=True).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


def ignore_interrupts() -> None:
    """In a worker: Ctrl-C and SIGTERM belong to the command (for spawned workers, which do not
    inherit the fork server's dispositions); the command stops its workers with SIGKILL."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def start_pool(jobs: int, initializer: Any, initargs: tuple) -> Any:
    """A ProcessPoolExecutor of ``jobs`` workers forked from the fork server, known to
    ``process_cleanup.stop_all``."""
    from concurrent.futures import ProcessPoolExecutor

    ctx = worker_context()
    with interrupts_held():  # no process starts here; the pool is known before Ctrl-C lands
        pool = ProcessPoolExecutor(jobs, mp_context=ctx, initializer=initializer, initargs=initargs)
        register_pool(pool)
    return pool
