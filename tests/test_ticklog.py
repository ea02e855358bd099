"""The columnar tick log: every column, its precision, atomic write, readers."""

from __future__ import annotations

import numpy as np
import pytest

from grasp_ctrl.controller.snapshot import Command, Snapshot
from grasp_ctrl.loop.ticklog import TickLog, read_tick_log, rounded_float32, tick_columns

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
    )
    return {
        "index_fx_sensor": f[0, 0],
        "thumb_true_fz_sensor": f[1, 2] * 1.1,
        "q2": snap.q[2],
        "index_raw_pdc": raw[0, 19],
        "object_z_world": 0.001 * k,
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
