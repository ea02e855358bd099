"""Reading a command's processes from /proc (Linux), for the interrupt and cleanup tests: a
command started in a new session, and every process of that session."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from conftest import sigint_as_at_a_terminal

ROOT = Path(__file__).resolve().parents[1]


def start_command(args: list[str], folder: Path, cwd: Path = ROOT) -> subprocess.Popen:
    """``python launch.py ARGS`` in a new session (its own process group, SIGINT as at a terminal,
    no stdin), its output in ``folder``/stdout.txt and stderr.txt."""
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "stdout.txt", "w") as stdout, open(folder / "stderr.txt", "w") as stderr:
        return subprocess.Popen(
            [sys.executable, str(ROOT / "launch.py"), *args],
            cwd=cwd,
            env=dict(os.environ, PYTHONPATH=str(ROOT)),
            start_new_session=True,
            preexec_fn=sigint_as_at_a_terminal,
            stdin=subprocess.DEVNULL,
            stdout=stdout,
            stderr=stderr,
        )


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
