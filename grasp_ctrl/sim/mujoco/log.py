"""MuJoCo's warnings go to the run directory or nowhere, never to ``./MUJOCO_LOG.TXT``.

Left alone, MuJoCo appends every warning (``Nan, Inf or huge value in QACC ...``) to
``MUJOCO_LOG.TXT`` in the current directory and prints it. ``install()`` routes them
through a handler instead: each is kept in ``messages`` (the last ``KEEP``), and
appended to ``LOG_NAME`` in the folder given to ``set_log_dir`` (a run directory), if any.
"""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

LOG_NAME = "MUJOCO_LOG.TXT"
KEEP = 100
messages: list[str] = []
_log_dir: Path | None = None
_installed = False


def _handler(msg: Any) -> None:
    text = msg.decode(errors="replace") if isinstance(msg, bytes) else str(msg)
    messages.append(text)
    del messages[:-KEEP]
    if _log_dir is not None and _log_dir.is_dir():
        with contextlib.suppress(OSError), open(_log_dir / LOG_NAME, "a", encoding="utf-8") as fh:
            fh.write(f"WARNING: {text}\n")


def install(mujoco: Any) -> None:
    """Route ``mujoco``'s warnings through the handler (once per process)."""
    global _installed
    if not _installed:
        mujoco.set_mju_user_warning(_handler)
        _installed = True


def set_log_dir(folder: Path | None) -> None:
    """Where the warnings of this process go from now on (None: nowhere)."""
    global _log_dir
    _log_dir = None if folder is None else Path(folder)
