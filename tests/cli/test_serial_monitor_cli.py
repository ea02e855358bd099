"""``launch.py sensors``: the live monitor against the emulator, recording, Ctrl-C, errors."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import sigint_as_at_a_terminal

from grasp_ctrl.cli import main
from grasp_ctrl.tactile_link.recorder import HEADER

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="the emulator needs POSIX pseudo-terminals")
REPO = Path(__file__).resolve().parents[2]


def read_rows(path: Path) -> list[list[str]]:
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def test_monitor_records_every_frame_and_shows_contact(tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setenv("GRASP_CTRL_POLICIES", str(tmp_path / "no_policies"))
    rec = tmp_path / "rec.csv"
    assert main(["sensors", "--emulate", "--seconds", "2.2", "--record", str(rec), "--refresh", "0.5"]) == 0
    out, err = capsys.readouterr()
    assert "note: no force column" in err
    assert "fz N" not in out
    for name in ("index", "middle", "ring", "thumb"):
        assert f"  {name} " in out
    assert " yes " in out  # the synthetic presses start after the tare window
    rows = read_rows(rec)
    assert tuple(rows[0]) == HEADER and len(HEADER) == 47
    body = rows[1:]
    assert all(len(r) == 47 for r in body)
    # no faults injected: per fingertip, consecutive sequence numbers from 0, increasing t_recv
    for finger in "0123":
        seqs = [int(r[2]) for r in body if r[1] == finger]
        ts = [float(r[0]) for r in body if r[1] == finger]
        assert seqs == list(range(len(seqs))) and len(seqs) >= 200
        assert ts == sorted(ts)
    assert f"recorded {len(body)} frames" in out


def test_monitor_shows_force_when_the_policy_loads(tmp_path, capsys, monkeypatch) -> None:
    pol = tmp_path / "policies"
    pol.mkdir()
    (pol / "analytic_test.json").write_text(
        json.dumps(
            {
                "kind": "analytic",
                "name": "analytic_test",
                "sensor_type": "biotac",
                "gains_n_per_count": [0.01, 0.01, 0.01],
            }
        )
    )
    monkeypatch.setenv("GRASP_CTRL_POLICIES", str(pol))
    assert main(["sensors", "--emulate", "--seconds", "2.0", "--policy", "analytic_test", "--refresh", "0.5"]) == 0
    out = capsys.readouterr().out
    assert "fz N" in out
    rows = [
        ln.split()
        for ln in out.splitlines()
        if ln.startswith("  ") and ln.split()[:1] and ln.split()[0] in ("index", "middle", "ring", "thumb")
    ]
    in_contact = [r for r in rows if r[2] == "yes"]
    assert in_contact and all(float(r[9]) > 0 for r in in_contact)  # |f| of a pad press
    assert all(r[6:] == ["-"] * 4 for r in rows if r[2] == "no")


def test_explicit_missing_policy_is_a_one_line_error(capsys, tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("GRASP_CTRL_POLICIES", str(tmp_path))
    assert main(["sensors", "--emulate", "--seconds", "0.1", "--policy", "nope"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "policy 'nope'" in err


def test_missing_port_is_a_one_line_error(capsys, tmp_path) -> None:
    assert main(["sensors", "--port", str(tmp_path / "ttyACM9"), "--seconds", "0.1"]) == 1
    err = capsys.readouterr().err
    assert err.strip().endswith(")") and "ttyACM9: cannot open" in err and "Traceback" not in err


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--seconds", "-1"], "--seconds"),
        (["--emulate", "--port", "/dev/x"], "--port and --emulate"),
        (["--emulate-corrupt", "0.1"], "need --emulate"),
        (["--hand", "/nonexistent/hand.toml"], "hand.toml"),
    ],
)
def test_bad_arguments(argv, needle, capsys) -> None:
    assert main(["sensors", *argv]) == 2
    assert needle in capsys.readouterr().err


def test_ctrl_c_closes_the_recording_cleanly(tmp_path) -> None:
    rec = tmp_path / "rec.csv"
    env = dict(os.environ, PYTHONPATH=str(REPO), GRASP_CTRL_POLICIES=str(tmp_path))
    proc = subprocess.Popen(
        [sys.executable, str(REPO / "launch.py"), "sensors", "--emulate", "--record", str(rec)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        preexec_fn=sigint_as_at_a_terminal,
    )
    try:
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and (not rec.exists() or rec.stat().st_size < 40_000):
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=10)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    assert "stopped (Ctrl-C)" in out
    rows = read_rows(rec)
    assert len(rows) > 100 and all(len(r) == 47 for r in rows)
    assert rec.read_text().endswith("\n")
    assert f"recorded {len(rows) - 1} frames" in out


def test_an_existing_recording_is_kept_unless_forced_and_a_bad_port_never_touches_it(tmp_path, capsys) -> None:
    rec = tmp_path / "rec.csv"
    rec.write_text("earlier recording\n" * 4205)
    before = rec.read_bytes()
    assert main(["sensors", "--port", str(tmp_path / "ttyACM9"), "--record", str(rec), "--seconds", "0.1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--record" in err[0] and "--force" in err[0]
    assert rec.read_bytes() == before
    # --force, but the port fails at once: the file is opened only after the ports, so it stays whole
    argv = ["sensors", "--port", str(tmp_path / "ttyACM9"), "--record", str(rec), "--seconds", "0.1", "--force"]
    assert main(argv) == 1
    assert "ttyACM9: cannot open" in capsys.readouterr().err
    assert rec.read_bytes() == before


def test_record_is_never_the_emulate_from_input_even_with_force(tmp_path, capsys) -> None:
    src = tmp_path / "press.csv"
    src.write_text("pdc," + ",".join(f"e{i}" for i in range(1, 20)) + "\n" + "2000," + ",".join(["3000"] * 19) + "\n")
    before = src.read_bytes()
    (tmp_path / "sub").mkdir()
    link = tmp_path / "link.csv"
    link.symlink_to(src)
    hard = tmp_path / "hard.csv"
    os.link(src, hard)
    cases = [(src, ()), *((same, ("--force",)) for same in (src, tmp_path / "sub" / ".." / "press.csv", link, hard))]
    for same, force in cases:
        argv = ["sensors", "--emulate", "--emulate-from", str(src), "--record", str(same), *force, "--seconds", "0.1"]
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--emulate-from" in err[0], (same, err)
        assert src.read_bytes() == before
