"""Small items of the hostile-input sweep, each with the input that found it.

A full disk names the file and the resume command; a record slot taken by a directory is
refused on resume before any trial runs; ``tune --storage`` leaves another program's SQLite
database alone; the fork server's temporary folders left by a SIGKILL are removed by a later
command; ``run --threads`` is bounded; ``bench --json`` is checked before measuring; a huge
oracle scale is refused instead of overflowing the tick log. Trials are stubbed where the
trial itself does not matter.
"""

from __future__ import annotations

import errno
import os
import sqlite3
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from grasp_ctrl.cli import build_parser, main
from grasp_ctrl.errors import PolicyError
from grasp_ctrl.files.storage import record_path, temp_path, ticks_path
from grasp_ctrl.trials.episode import runner as episode_runner
from grasp_ctrl.trials.runs import series

POLICY = "oracle"
DISK_FULL = "No space left on device"


def _stub_trials(monkeypatch: pytest.MonkeyPatch, fail: Callable[[int], None] = lambda k: None) -> None:
    """Trials that take no time: a record (and a one-line tick log); ``fail(k)`` may raise in trial k."""

    def fake_trial_fn(hand: Any, policies: Any, settings: Any = None, threads: int = 1, **_kw: Any) -> Any:
        def run(p: str, obj: Any, k: int, seed: int, log: Path | None) -> dict[str, Any]:
            fail(k)
            if log is not None:
                Path(log).write_text("t,state\n")
            return {"object": obj.name, "policy": p, "trial": k, "seed": seed, "success": True, "reason": None}

        return run

    monkeypatch.setattr(episode_runner, "sim_trial_fn", fake_trial_fn)


def _run_args(run_dir: Path, tick_logs: bool = False) -> list[str]:
    args = ["run", "--backend", "mock", "--objects", "lego", "--trials", "2", "--jobs", "1", "--quiet"]
    return [*args, "--policy", POLICY, "--out", str(run_dir), *([] if tick_logs else ["--no-tick-logs"])]


def _one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    return lines[0]


# 1. A full disk names the file it failed to write and the command that continues the run.


@pytest.mark.parametrize("named", ["nothing", "the temporary file"])
def test_a_full_disk_names_the_record_and_the_resume_command(tmp_path, monkeypatch, capsys, named):
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    real_write = series.write_json

    def full_at_trial_1(path: Path, doc: Any) -> None:
        if path.name == "trial_001.json":  # write() names no file; open() names the temporary one
            raise OSError(errno.ENOSPC, DISK_FULL, *([] if named == "nothing" else [str(temp_path(path))]))
        real_write(path, doc)

    monkeypatch.setattr(series, "write_json", full_at_trial_1)
    assert main(_run_args(run_dir)) == 1
    line = _one_error_line(capsys)
    assert f"{record_path(run_dir, POLICY, 'lego', 1)}: {DISK_FULL}" in line
    assert f"1 of 2 trials are recorded in {run_dir}; continue with: grasp-ctrl run --resume {run_dir}" in line
    assert ".tmp" not in line


def test_a_full_disk_in_a_trial_names_its_tick_log(tmp_path, monkeypatch, capsys):
    def full(k: int) -> None:
        if k == 1:  # pyarrow's write() through the tick log's file names no file
            raise OSError(errno.ENOSPC, "Error writing bytes to file. Detail: [errno 28] No space left on device")

    _stub_trials(monkeypatch, full)
    run_dir = tmp_path / "run"
    assert main(_run_args(run_dir, tick_logs=True)) == 1
    line = _one_error_line(capsys)
    assert line.startswith(f"grasp-ctrl: error: {ticks_path(run_dir, POLICY, 'lego', 1)}: {DISK_FULL}; ")
    assert f"continue with: grasp-ctrl run --resume {run_dir}" in line


def test_a_full_disk_before_the_run_started_says_nothing_was_recorded(tmp_path, monkeypatch, capsys):
    _stub_trials(monkeypatch)
    monkeypatch.setattr(series, "sync_manifest", _raise(OSError(errno.ENOSPC, DISK_FULL)))
    run_dir = tmp_path / "run"
    assert main(_run_args(run_dir)) == 1
    line = _one_error_line(capsys)
    assert f"{run_dir / 'run.json'}: {DISK_FULL}" in line and "nothing was recorded" in line
    assert not run_dir.exists()


def _raise(exc: BaseException) -> Callable[..., None]:
    def fail(*_a: Any, **_kw: Any) -> None:
        raise exc

    return fail


# 2. A record (or tick log) replaced by a directory: resume names it and runs nothing.


def test_resume_refuses_a_record_replaced_by_a_directory(tmp_path, monkeypatch, capsys):
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_run_args(run_dir)) == 0
    capsys.readouterr()
    record = record_path(run_dir, POLICY, "lego", 1)
    record.unlink()
    record.mkdir()
    (record / "keep.txt").write_text("x")
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 2
    line = _one_error_line(capsys)
    assert line == (
        f"grasp-ctrl: error: {record}: a directory, not a trial record; move it out of the run and resume again"
    )
    assert (record / "keep.txt").read_text() == "x" and record_path(run_dir, POLICY, "lego", 0).is_file()
    record.joinpath("keep.txt").unlink()
    record.rmdir()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 0  # moved away: the trial runs again
    assert record.is_file()


def test_resume_refuses_a_tick_log_replaced_by_a_directory(tmp_path, monkeypatch, capsys):
    _stub_trials(monkeypatch)
    run_dir = tmp_path / "run"
    assert main(_run_args(run_dir, tick_logs=True)) == 0
    capsys.readouterr()
    record_path(run_dir, POLICY, "lego", 1).unlink()
    log = ticks_path(run_dir, POLICY, "lego", 1)
    log.unlink()
    log.mkdir()
    assert main(["run", "--resume", str(run_dir), "--quiet"]) == 2
    assert f"{log}: a directory, not a tick log" in _one_error_line(capsys)


# 3. tune --storage: another program's SQLite database is refused before Optuna opens it.


def _sqlite(path: Path, *statements: str) -> Path:
    with sqlite3.connect(path) as db:
        for sql in statements:
            db.execute(sql)
    return path


def _tables(path: Path) -> list[str]:
    with sqlite3.connect(path) as db:
        return sorted(r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'"))


def _tune(storage: Path) -> list[str]:
    return ["tune", "--backend", "mock", "--object", "lego", "--param", "tau_n=1.0:3.5", "--budget", "1"] + [
        "--trials",
        "1",
        "--storage",
        f"sqlite:///{storage}",
    ]


def test_tune_refuses_another_programs_sqlite_database(tmp_path, monkeypatch, capsys):
    from grasp_ctrl.trials.tuning import study_defaults

    # past the checks the study would open: the test stops there instead of running a trial
    monkeypatch.setattr(study_defaults, "require_optuna", _raise(AssertionError("the storage was not refused")))
    db = _sqlite(tmp_path / "inventory.db", "CREATE TABLE parts (id INTEGER, name TEXT)")
    assert main(_tune(db)) == 2
    line = _one_error_line(capsys)
    assert str(db) in line and "'parts'" in line
    assert _tables(db) == ["parts"]  # untouched


@pytest.mark.parametrize(
    "tables",
    [
        [],  # a new, empty database
        ["CREATE TABLE studies (id INTEGER)", "CREATE TABLE trials (id INTEGER)", "CREATE TABLE version_info (v INT)"],
    ],
)
def test_an_empty_file_or_an_optuna_storage_passes(tmp_path, tables):
    from grasp_ctrl.trials.tuning.study_defaults import check_storage

    db = _sqlite(tmp_path / "study.db", *tables)
    check_storage(f"sqlite:///{db}")
    empty = tmp_path / "empty.db"
    empty.write_bytes(b"")
    check_storage(f"sqlite:///{empty}")


def test_tune_refuses_a_file_that_is_not_sqlite(tmp_path):
    from grasp_ctrl.errors import UsageError
    from grasp_ctrl.trials.tuning.study_defaults import check_storage

    notes = tmp_path / "notes.db"
    notes.write_text("not a database, just some text that is long enough to have a header\n" * 4)
    with pytest.raises(UsageError, match="not a SQLite database"):
        check_storage(f"sqlite:///{notes}")
    assert notes.read_text().startswith("not a database")


# 4. The fork server's folders left by a SIGKILL go once their process is gone.


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_stale_fork_server_folders_are_removed_live_ones_stay(tmp_path, monkeypatch):
    from grasp_ctrl.trials.runs.workers import remove_stale_folders

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    dead = tmp_path / f"grasp_ctrl_forkserver_{_dead_pid()}_abc123"
    dead.mkdir()
    (dead / "python").write_text("#!/bin/sh\n")
    pymp = tmp_path / "pymp-dead0001"  # multiprocessing's folder, noted in ours
    pymp.mkdir()
    (dead / "pymp").write_text(str(pymp))
    other_pymp = tmp_path / "pymp-someone"  # not noted by a dead command: not ours to judge
    other_pymp.mkdir()
    live = tmp_path / f"grasp_ctrl_forkserver_{os.getpid()}_def456"
    live.mkdir()
    not_a_folder = tmp_path / "grasp_ctrl_forkserver_1_file"
    not_a_folder.write_text("x")
    assert sorted(remove_stale_folders()) == sorted([str(dead), str(pymp)])
    assert not dead.exists() and not pymp.exists()
    assert live.is_dir() and other_pymp.is_dir() and not_a_folder.is_file()


def test_a_note_outside_the_temporary_folder_is_not_followed(tmp_path, monkeypatch):
    from grasp_ctrl.trials.runs.workers import remove_stale_folders

    root = tmp_path / "tmp"
    root.mkdir()
    elsewhere = tmp_path / "pymp-precious"
    elsewhere.mkdir()
    dead = root / f"grasp_ctrl_forkserver_{_dead_pid()}_x"
    dead.mkdir()
    (dead / "pymp").write_text(str(elsewhere))
    assert remove_stale_folders(str(root)) == [str(dead)]
    assert elsewhere.is_dir()


def test_the_launcher_folder_carries_the_pid_and_clears_stale_ones(tmp_path, monkeypatch):
    from grasp_ctrl.trials.runs.workers import launcher_folder

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    stale = tmp_path / f"grasp_ctrl_forkserver_{_dead_pid()}_old"
    stale.mkdir()
    folder = Path(launcher_folder())
    assert folder.parent == tmp_path and folder.name.startswith(f"grasp_ctrl_forkserver_{os.getpid()}_")
    assert folder.is_dir() and not stale.exists()


# 5. run --threads is bounded (1 to 1024, as the other commands' --threads).


def test_run_threads_has_an_upper_bound(capsys):
    parser = build_parser()
    assert parser.parse_args(["run"]).threads == 1
    assert parser.parse_args(["run", "--threads", "1024"]).threads == 1024
    with pytest.raises(SystemExit) as exc:
        parser.parse_args(["run", "--threads", "1000000"])
    assert exc.value.code == 2
    assert "--threads: an integer >= 1 and <= 1024 (got 1000000)" in capsys.readouterr().err


# 6. bench --json: the path is checked before anything is measured.


@pytest.fixture
def no_measuring(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    from grasp_ctrl.bench import runner

    calls: list[Any] = []
    monkeypatch.setattr(runner, "run_figures", lambda *a, **kw: calls.append(a) or {})
    return calls


@pytest.mark.parametrize("where", ["a directory", "a missing folder"])
def test_bench_refuses_a_bad_json_path_before_measuring(tmp_path, capsys, no_measuring, where):
    target = tmp_path if where == "a directory" else tmp_path / "missing" / "bench.json"
    assert main(["bench", "--json", str(target)]) == 2
    assert "--json" in _one_error_line(capsys)
    assert no_measuring == []


def test_bench_refuses_an_unwritable_folder_before_measuring(tmp_path, monkeypatch, capsys, no_measuring):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    real_access = os.access

    def access(path: Any, mode: int, **kw: Any) -> bool:  # root writes any folder: it is told
        return not (Path(path) == folder and mode & os.W_OK) and real_access(path, mode, **kw)

    monkeypatch.setattr(os, "access", access)
    try:
        assert main(["bench", "--json", str(folder / "bench.json")]) == 2
    finally:
        folder.chmod(0o700)
    assert "not writable" in _one_error_line(capsys) and no_measuring == []


def test_bench_json_to_a_good_path_still_measures(tmp_path, no_measuring):
    out = tmp_path / "bench.json"
    out.write_text("old\n")  # replaced, as every --json output is
    assert main(["bench", "--json", str(out), "--quiet"]) == 0
    assert no_measuring and '"figures": {}' in out.read_text()


# 7. A huge oracle scale overflowed the tick log's float32 columns (numpy's RuntimeWarning
# beside the results): refused; the largest one allowed logs without a warning.


def test_an_oracle_scale_beyond_the_limit_is_refused(tmp_path, capsys):
    from grasp_ctrl.sim.oracle import MAX_SCALE, parse_oracle

    assert parse_oracle(f"oracle:scale={MAX_SCALE:g}") == MAX_SCALE
    with pytest.raises(PolicyError, match="at most"):
        parse_oracle("oracle:scale=1e300")
    args = ["run", "--backend", "mock", "--objects", "lego", "--trials", "1", "--out", str(tmp_path / "r")]
    assert main([*args, "--quiet", "--policy", "oracle:scale=1e300"]) == 2
    assert "oracle:scale=1e300" in _one_error_line(capsys)


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_the_largest_oracle_scale_logs_without_a_warning(tmp_path, hand, objects):
    from grasp_ctrl.loop.ticklog import read_tick_log
    from grasp_ctrl.sim.oracle import MAX_SCALE

    log = tmp_path / "ticks.parquet"
    run = episode_runner.sim_trial_fn(hand, [f"oracle:scale={MAX_SCALE:g}"], backend="mock")
    run(f"oracle:scale={MAX_SCALE:g}", objects["lego"], 0, 0, log)
    _header, cols = read_tick_log(log)
    assert all(bool(abs(v).max() < 3.4e38) for k, v in cols.items() if k.endswith("_grip_n"))
