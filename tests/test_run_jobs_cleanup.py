"""`run --jobs N` leaves no process behind on Ctrl-C or when a worker dies.

The command runs in its own session, as from a terminal; Ctrl-C is SIGINT to
its whole process group, as a terminal sends it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import sigint_as_at_a_terminal

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")


def _session(sid: int) -> dict[int, int]:
    """pid -> parent pid of the live processes in session ``sid``."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] != "Z" and int(fields[3]) == sid:  # state, ppid, pgrp, session
            found[int(entry.name)] = int(fields[1])
    return found


def _start(out: Path, trials: int = 4) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen(
        [
            sys.executable,
            str(ROOT / "launch.py"),
            "run",
            "--backend",
            "mock",
            "--objects",
            "chips_can,lego,cleanser",
            "--trials",
            str(trials),
            "--jobs",
            "2",
            "--out",
            str(out),
            "--quiet",
        ],
        cwd=ROOT,
        env=env,
        start_new_session=True,
        preexec_fn=sigint_as_at_a_terminal,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for_records(proc: subprocess.Popen, out: Path, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while not list(out.glob("trials/*/*/trial_*.json")):
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < timeout, "no trial finished"
        time.sleep(0.1)


def _assert_session_empty(sid: int) -> None:
    t0 = time.monotonic()
    while _session(sid) and time.monotonic() - t0 < 10.0:
        time.sleep(0.1)
    assert _session(sid) == {}, "processes left behind"


def test_ctrl_c_stops_every_worker(tmp_path):
    out = tmp_path / "run"
    proc = _start(out, trials=30)  # long enough that it cannot finish before the Ctrl-C on a busy host
    _wait_for_records(proc, out)
    assert len(_session(proc.pid)) >= 3  # the command, its fork server and workers
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "continue with: grasp-ctrl run --resume" in err and "Traceback" not in err
    _assert_session_empty(proc.pid)


def test_a_dead_worker_is_a_one_line_error_and_the_rest_stop(tmp_path):
    out = tmp_path / "run"
    proc = _start(out, trials=30)  # 12 trials can all end between the first record and the kill on a busy host
    _wait_for_records(proc, out)
    procs = _session(proc.pid)
    # Workers are forked from the fork server: their parent is not the command itself.
    workers = [pid for pid, parent in procs.items() if pid != proc.pid and parent != proc.pid]
    assert workers, procs
    os.kill(workers[0], signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    lines = err.strip().splitlines()
    assert proc.returncode == 1 and len(lines) == 1, err
    assert "worker process ended abruptly" in lines[0] and "--resume" in lines[0]
    _assert_session_empty(proc.pid)


def _interrupt_after(delay_s: float, sig: int, tmp_path: Path, when_run_dir: bool = False) -> tuple[int, str, int]:
    out = tmp_path / "run"
    proc = _start(out, trials=30)
    if when_run_dir:  # the moment the run directory appears: the worker pool is starting
        t0 = time.monotonic()
        while not (out / "run.json").exists() and proc.poll() is None and time.monotonic() - t0 < 120.0:
            time.sleep(0.01)
    time.sleep(delay_s)
    os.killpg(proc.pid, sig)
    _, err = proc.communicate(timeout=60)
    _assert_session_empty(proc.pid)
    return proc.returncode, err, proc.pid


@pytest.mark.parametrize("delay_s", [0.1, 0.3, 0.6])
def test_an_early_ctrl_c_leaves_no_traceback_and_no_process(tmp_path, delay_s):
    """Ctrl-C while the command, its fork server or its workers are still importing."""
    code, err, _ = _interrupt_after(delay_s, signal.SIGINT, tmp_path)
    assert code == 130, err
    assert "Traceback" not in err and "Error" not in err, err


@pytest.mark.parametrize("delay_s", [0.0, 0.5, 1.5])
def test_ctrl_c_while_the_workers_start_leaves_no_traceback_and_no_process(tmp_path, delay_s):
    code, err, _ = _interrupt_after(delay_s, signal.SIGINT, tmp_path, when_run_dir=True)
    assert code == 130, err
    assert "Traceback" not in err and "Error" not in err, err
    assert "continue with: grasp-ctrl run --resume" in err


@pytest.mark.parametrize("delay_s", [0.3, 2.0])
def test_sigterm_stops_like_ctrl_c(tmp_path, delay_s):
    code, err, _ = _interrupt_after(delay_s, signal.SIGTERM, tmp_path, when_run_dir=delay_s > 1.0)
    assert code == 143, err
    assert "Traceback" not in err, err


def test_an_interrupt_swallowed_by_an_optional_import_still_ends_the_command(monkeypatch, capsys):
    """An interrupt inside an extension module's import can surface as an ImportError, which an
    optional import (numba's) takes for a missing package: the run went on and exited 0 (seen
    once: test_sigterm_stops_like_ctrl_c[0.3] got 0, not 143). The noted signal is raised again
    there, and main() reports it however the command ended."""
    import grasp_ctrl.cli as cli
    from grasp_ctrl.errors import SIGNALLED, Terminated, reraise_interrupt

    SIGNALLED.clear()
    reraise_interrupt()  # nothing noted: nothing raised
    SIGNALLED.append(signal.SIGTERM)
    with pytest.raises(Terminated):
        reraise_interrupt()
    SIGNALLED.clear()

    def swallowed(argv):
        SIGNALLED.append(signal.SIGTERM)  # as the handler does, then something swallows it
        return 0

    monkeypatch.setattr(cli, "_main", swallowed)
    assert cli.main(["run"]) == 143
    assert capsys.readouterr().err.strip() == "grasp-ctrl: interrupted"
