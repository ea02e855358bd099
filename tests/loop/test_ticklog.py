"""The columnar tick log: every column, its precision, atomic write, readers."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.loop.ticklog import TickLog, raw_frame_columns, read_tick_log, rounded_float32, tick_columns

FINGERS = ["index", "thumb"]


def _tick(log: TickLog, k: int, rng: np.random.Generator) -> dict[str, float]:
    f = rng.normal(0, 2, (2, 3))
    snap = Snapshot(
        t=0.01 * k,
        q=rng.normal(0, 1, 3),
        p_palm_world=np.array([0.0, 0.001 * k, 0.2]),
        tare_ready=True,
        in_contact=np.array([k % 2 == 0, False]),
        f_sensor=f,
        f_hand=f,
        f_world=f,
        grip_n=np.hypot(f[:, 0], f[:, 1]),
    )
    raw = rng.integers(0, 4096, (2, 44)).astype(float)
    current = rng.normal(0, 0.3, 3)
    log.append(
        "ramp" if k % 3 else "lift",
        snap,
        Command(q_goal=snap.q + 0.1, p_palm_world=np.array([0, 0, 0.25])),
        raw - 1000.0,
        true_f_sensor=f * 1.1,
        object_z=0.001 * k,
        table_force=1.5,
        raw=raw,
        grip_target_n=2.0,
        current_a=current,
    )
    return {
        "index_fx_sensor": f[0, 0],
        "thumb_true_fz_sensor": f[1, 2] * 1.1,
        "q2": snap.q[2],
        "index_raw_pdc": raw[0, 19],
        "object_z_world": 0.001 * k,
        "current1": current[1],
    }


def test_every_column_round_trips_within_its_precision(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "trial_000_ticks.parquet"
    log = TickLog(path, FINGERS, 3, truth=True)
    expect = [_tick(log, k, rng) for k in range(2500)]  # more than one buffer chunk
    log.close()
    log.close()  # closing twice is harmless
    assert not list(tmp_path.glob("*.tmp"))
    header, cols = read_tick_log(path)
    assert header == tick_columns(FINGERS, 3, truth=True)
    assert len(cols["t"]) == 2500 and cols["t"][-1] == pytest.approx(24.99)
    assert list(cols["state"][:3]) == ["lift", "ramp", "ramp"]
    assert list(cols["index_contact"][:2]) == [1.0, 0.0]
    for name in expect[0]:
        want = np.array([e[name] for e in expect])
        np.testing.assert_allclose(cols[name], want, rtol=1.6e-5, atol=1e-30)


def test_rounding_keeps_nan_inf_and_the_relative_error_bound():
    x = np.array([np.nan, np.inf, -np.inf, 0.0, -0.0, 1.0, 3.14159265, -2.5e-7, 4095.0, 1e30])
    r = rounded_float32(x)
    assert np.isnan(r[0]) and r[1] == np.inf and r[2] == -np.inf
    np.testing.assert_allclose(r[3:], x[3:], rtol=1.6e-5)
    assert r[5] == 1.0 and r[8] == 4095.0  # short mantissas stay exact


def test_pandas_reads_it(tmp_path):
    pd = pytest.importorskip("pandas")
    path = tmp_path / "t_ticks.parquet"
    log = TickLog(path, FINGERS, 3, truth=False)
    _tick(log, 0, np.random.default_rng(1))
    log.close()
    frame = pd.read_parquet(path)
    assert list(frame.columns) == tick_columns(FINGERS, 3, truth=False) and len(frame) == 1


def test_a_file_that_is_not_a_tick_log_is_a_usage_error(tmp_path):
    from grasp_ctrl.errors import UsageError

    bad = tmp_path / "x_ticks.parquet"
    bad.write_bytes(b"not parquet")
    with pytest.raises(UsageError, match="x_ticks.parquet"):
        read_tick_log(bad)


def test_currents_are_the_hands_and_nan_where_it_reported_none(tmp_path):
    path = tmp_path / "c_ticks.parquet"
    log = TickLog(path, FINGERS, 3, truth=False)
    rng = np.random.default_rng(2)
    for k in range(4):
        _tick(log, k, rng)
    log.set_current(np.array([0.25, -1.5, 0.0]))  # replaces the last row's
    log.set_current(np.ones(4))  # another length: ignored, the log is no place to fail a trial
    log.append("done", *_row(rng), raw=None)  # no currents, no frame
    log.close()
    header, cols = read_tick_log(path)
    assert [c for c in header if c.startswith("current")] == ["current0", "current1", "current2"]
    assert [cols[f"current{j}"][3] for j in range(3)] == [0.25, -1.5, 0.0]
    assert all(np.isnan(cols[f"current{j}"][4]) for j in range(3)) and np.isfinite(cols["current0"][:4]).all()


def _row(rng: np.random.Generator) -> tuple:
    """(snapshot, command, tared) of one tick, for ``TickLog.append``."""
    f = rng.normal(0, 2, (2, 3))
    snap = Snapshot(
        t=1.0,
        q=rng.normal(0, 1, 3),
        p_palm_world=np.zeros(3),
        tare_ready=True,
        in_contact=np.array([True, False]),
        f_sensor=f,
        f_hand=f,
        f_world=f,
        grip_n=np.zeros(2),
    )
    return snap, Command(q_goal=snap.q, p_palm_world=np.zeros(3)), np.zeros((2, 44))


def test_raw_frames_keep_every_channel_as_counts_beside_the_summary(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    rng = np.random.default_rng(3)
    path = tmp_path / "r_ticks.parquet"
    log = TickLog(path, FINGERS, 3, truth=True, raw_frames=True)
    frames = rng.integers(0, 4096, (2100, 2, 44))  # more than one buffer chunk
    for k, frame in enumerate(frames):
        snap, cmd, tared = _row(rng)
        log.append("lift", snap, cmd, tared, np.zeros((2, 3)), raw=None if k == 7 else frame.astype(float))
    log.close()
    table = pq.read_table(path)
    assert table.column_names == tick_columns(FINGERS, 3, truth=True, raw_frames=True)
    summary = set(tick_columns(FINGERS, 3, truth=True))
    assert summary < set(table.column_names)  # the summary stays, whatever reads it
    added = [c for c in table.column_names if c not in summary]
    assert len(added) == 2 * 42 and all(table.schema.field(c).type == pa.uint16() for c in added)
    header, cols = read_tick_log(path)
    for i, f in enumerate(FINGERS):
        names = raw_frame_columns(f)
        assert names[:2] == [f"{f}_raw_e1", f"{f}_raw_e2"] and names[-1] == f"{f}_raw_tac" and len(names) == 44
        got = np.stack([cols[c] for c in names], axis=1)
        assert np.isnan(got[7]).all()  # a tick without a frame: null, read as NaN
        keep = np.arange(len(frames)) != 7
        assert np.array_equal(got[keep], frames[keep, i])
    plain = tmp_path / "p_ticks.parquet"
    log = TickLog(plain, FINGERS, 3, truth=True)
    snap, cmd, tared = _row(rng)
    log.append("lift", snap, cmd, tared, np.zeros((2, 3)), raw=frames[0].astype(float))
    log.close()
    assert read_tick_log(plain)[0] == tick_columns(FINGERS, 3, truth=True) and "index_raw_e1" not in summary


def _damage(path, how: str) -> str:
    """Damage a tick log at ``path`` one way; returns what the one-line error must say."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)

    def with_column(name: str, values) -> pa.Table:
        return table.set_column(table.column_names.index(name), name, values)

    if how == "truncated":
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
        return "not a whole Parquet file"
    if how == "foreign":
        pq.write_table(pa.table({"time": [0.0, 0.01], "value": [1.0, 2.0]}), path)
        return "no 't' and 'state' columns"
    if how == "foreign_with_t":
        pq.write_table(pa.table({"t": [0.0, 0.01], "state": ["a", "b"], "x": [1, 2]}), path)
        return "no fingertip force column"
    if how == "missing":
        table = table.drop(["thumb_fz_world"])
    elif how == "joint_gap":
        table = table.drop(["q1", "q_goal1"])
    elif how == "nan":
        q = table.column("q1").to_numpy().copy()
        q[3] = np.nan
        table = with_column("q1", pa.array(q))
    elif how == "inf":
        f = table.column("index_fx_sensor").to_numpy().copy()
        f[2] = np.inf
        table = with_column("index_fx_sensor", pa.array(f))
    elif how == "strings":
        table = with_column("palm_z_world", pa.array(["high"] * len(table)))
    elif how == "null_state":
        states = table.column("state").to_pylist()
        states[1] = None
        table = with_column("state", pa.array(states, type=pa.string()))
    pq.write_table(table, path)
    return {
        "missing": "no column 'thumb_fz_world'",
        "joint_gap": "no column 'q1'",
        "nan": "column 'q1' is NaN (or empty) at row 3",
        "inf": "column 'index_fx_sensor' is infinite at row 2",
        "strings": "column 'palm_z_world' holds string, not numbers",
        "null_state": "column 'state' is empty at row 1",
    }[how]


DAMAGES = ("truncated", "foreign", "foreign_with_t", "missing", "joint_gap", "nan", "inf", "strings", "null_state")


@pytest.mark.parametrize("how", DAMAGES)
def test_a_foreign_or_damaged_log_is_one_line_naming_the_file_and_column(tmp_path, capsys, how):
    """The reader checks the columns and finite values every reader needs (plot, replays,
    bags), so no command gets a traceback from a damaged log."""
    from grasp_ctrl.cli import main
    from grasp_ctrl.errors import UsageError

    path = tmp_path / "trial_000_ticks.parquet"
    log = TickLog(path, FINGERS, 3, truth=True)
    rng = np.random.default_rng(4)
    for k in range(6):
        _tick(log, k, rng)
    log.close()
    read_tick_log(path)  # whole, it reads
    says = _damage(path, how)
    with pytest.raises(UsageError) as info:
        read_tick_log(path)
    assert str(path) in str(info.value) and says in str(info.value)
    commands = [["plot", str(path), "--out", str(tmp_path / "p.png")]]
    if importlib.util.find_spec("mcap_ros2") is not None:
        commands.append(["export-bag", str(path), "--out", str(tmp_path / "t.mcap"), "--force"])
    for argv in commands:
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(path) in err[0] and says in err[0], (argv, err)
