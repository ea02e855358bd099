"""One-line errors name the flag the user typed and what to try instead."""

from __future__ import annotations

from grasp_ctrl.cli import main


def test_tune_names_its_own_flag(capsys):
    assert main(["tune", "--object", "nope", "--param", "tau=2", "--trials", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--object: unknown object 'nope'" in err[0] and "--objects" not in err[0]


def test_tune_refuses_a_trial_count_beyond_the_run_files_bound_at_once(capsys):
    """Each trial's seed is planned before the first trial: a huge count would hang, not fail."""
    argv = ["tune", "--object", "lego", "--param", "tau_n=2", "--backend", "mock", "--trials", "9" * 30]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--trials: from 1 to 100000" in err[0]


def test_run_and_tune_give_the_same_seed_message(tmp_path, capsys):
    for argv in (
        ["run", "--backend", "mock", "--seed", "-1", "--out", str(tmp_path / "run")],
        ["tune", "--object", "lego", "--param", "tau_n=2", "--backend", "mock", "--seed", "-1"],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--seed: an integer from 0 to 2**63-1 (got -1)" in err[0]
    assert not (tmp_path / "run").exists()


def test_a_wrong_servo_port_lists_the_ports_found(tmp_path, capsys):
    missing = tmp_path / "ttyNOPE"
    assert main(["hand-check", "--port", str(missing)]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(missing) in err[0]
    assert "no such file or directory" in err[0] and "[Errno" not in err[0]
    assert "serial ports found:" in err[0] or "no serial ports found" in err[0]
