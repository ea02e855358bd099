"""One-line errors name the flag the user typed and what to try instead."""

from __future__ import annotations

from grasp_ctrl.cli import main


def test_tune_names_its_own_flag(capsys):
    assert main(["tune", "--object", "nope", "--param", "tau=2", "--trials", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--object: unknown object 'nope'" in err[0] and "--objects" not in err[0]


def test_a_wrong_servo_port_lists_the_ports_found(tmp_path, capsys):
    missing = tmp_path / "ttyNOPE"
    assert main(["hand-check", "--port", str(missing)]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(missing) in err[0]
    assert "no such file or directory" in err[0] and "[Errno" not in err[0]
    assert "serial ports found:" in err[0] or "no serial ports found" in err[0]
