"""``RUN_DIR/run.lock``: one writer per run directory.

The lock file is created exclusively and holds the owner's pid, host and
start time. A second ``run`` or ``run --resume`` on the same directory is
refused while the owner lives; a lock whose process is gone (same host) is
stale and is taken over with a warning. The lock is removed when the owner
finishes, fails or is interrupted.
"""

from __future__ import annotations

import json
import os
import socket
import time
from collections.abc import Callable
from pathlib import Path

from grasp_ctrl.errors import UsageError
from grasp_ctrl.files.json_limits import JsonFileError, read_json
from grasp_ctrl.files.storage import LOCK_FILE

MAX_LOCK_BYTES = 64 * 1024
MAX_PID = 2**31 - 1  # pid_t


def pid_alive(pid: int) -> bool:
    if not 0 < pid <= MAX_PID:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    except OSError:
        return False
    return True


class RunLock:
    def __init__(self, run_dir: Path, warn: Callable[[str], None] | None = None) -> None:
        self.path = Path(run_dir) / LOCK_FILE
        self.warn = warn or (lambda msg: None)
        self.held = False

    def _owner(self) -> dict[str, object] | None:
        """The lock's owner, or None when the file is unreadable or not a lock of ours (garbage,
        a pid that no process can have, an absurd size or depth)."""
        try:
            doc = read_json(self.path, max_bytes=MAX_LOCK_BYTES)
        except JsonFileError:
            return None
        if not isinstance(doc, dict):
            return None
        pid = doc.get("pid")
        if not (isinstance(pid, int) and not isinstance(pid, bool) and 0 < pid <= MAX_PID):
            return None
        return doc

    def acquire(self) -> RunLock:
        me = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.strftime("%Y-%m-%dT%H:%M:%S")}
        for _ in range(3):
            try:
                fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                owner = self._owner()
                pid = owner.get("pid") if owner else None
                host = owner.get("host") if owner else None
                if owner is None:
                    # being written right now, or garbage: look again before judging
                    time.sleep(0.05)
                    owner = self._owner()
                    pid = owner.get("pid") if owner else None
                    host = owner.get("host") if owner else None
                if isinstance(pid, int) and host == me["host"] and pid == os.getpid():
                    raise UsageError(f"{self.path.parent}: this process already writes this run") from None
                if isinstance(pid, int) and host == me["host"] and not pid_alive(pid):
                    self.warn(f"{self.path}: stale lock of process {pid} (no longer running); taking it over")
                    self.path.unlink(missing_ok=True)
                    continue
                if owner is None:
                    self.warn(f"{self.path}: unreadable lock file; taking it over")
                    self.path.unlink(missing_ok=True)
                    continue
                where = f"process {pid}" + (f" on {host}" if host != me["host"] else "")
                raise UsageError(
                    f"{self.path.parent} is in use by {where} (since {owner.get('started', '?')}); "
                    f"wait for it to finish, or delete {self.path} if that process is gone"
                ) from None
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                json.dump(me, fh)
                fh.flush()
                os.fsync(fh.fileno())
            self.held = True
            return self
        raise UsageError(f"{self.path}: could not take the run lock")

    def release(self) -> None:
        if not self.held:
            return
        owner = self._owner()
        if owner is None or owner.get("pid") == os.getpid():
            self.path.unlink(missing_ok=True)
        self.held = False

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()
