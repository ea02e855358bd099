"""Reading a command's processes from /proc (Linux), for the interrupt and cleanup tests: a
command started in a new session, and every process of that session."""

from __future__ import annotations

import signal
from dataclasses import dataclass
from pathlib import Path


@dataclass
class Proc:
    pid: int
    ppid: int
    state: str
    cmdline: str


def session(sid: int) -> dict[int, Proc]:
    """The live (not zombie) processes of session ``sid``."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] not in ("Z", "X") and int(fields[3]) == sid:  # state, ppid, pgrp, session
            found[int(entry.name)] = Proc(int(entry.name), int(fields[1]), fields[0], cmdline.strip()[:160])
    return found


def handlers_installed(pid: int) -> bool:
    """Whether the command has installed its SIGTERM handler (cli.main's first step)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    caught = next(line for line in status.splitlines() if line.startswith("SigCgt:"))
    return bool(int(caught.split()[1], 16) & (1 << (signal.SIGTERM - 1)))
