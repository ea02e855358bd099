"""Dataset files: round trip, bad rows reported by line, raw signals tared, splits by trial."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasp_ctrl.config.sensor_layout import CHANNEL_NAMES
from grasp_ctrl.learning.dataset import (
    RAW_COLUMNS,
    Dataset,
    DatasetError,
    header,
    read_csv,
    read_dataset,
    write_csv,
)
from grasp_ctrl.learning.splits import split_by_trials


def _dataset(n_trials: dict[str, int], rng: np.random.Generator, per_trial: tuple[int, int] = (5, 40)) -> Dataset:
    parts = []
    for source, k in n_trials.items():
        for i in range(k):
            n = int(rng.integers(*per_trial))
            proj = source == "planar-pushing"
            parts.append(
                Dataset(
                    trial_id=np.full(n, f"{source}-{i}"),
                    source=np.full(n, source),
                    t=np.arange(n) * 0.01,
                    tared=rng.normal(0, 100, (n, 44)),
                    f_sensor=rng.normal(0, 1, (n, 3)) + [0, 0, 3],
                    projected=np.full(n, proj),
                    r_world_sensor=np.repeat(np.eye(3)[None], n, axis=0),
                )
            )
    return Dataset.concat(parts)


def test_csv_round_trip(tmp_path: Path) -> None:
    ds = _dataset({"rigid-ft": 2, "planar-pushing": 2}, np.random.default_rng(0))
    path = tmp_path / "d.csv"
    write_csv(path, ds)
    back, bad = read_csv(path)
    assert bad == []
    np.testing.assert_array_equal(back.trial_id, ds.trial_id)
    np.testing.assert_allclose(back.tared, ds.tared, rtol=1e-5, atol=1e-3)
    np.testing.assert_allclose(back.f_sensor, ds.f_sensor, rtol=1e-5)
    np.testing.assert_array_equal(back.projected, ds.projected)


def test_bad_rows_are_reported_by_line_not_dropped(tmp_path: Path) -> None:
    ds = _dataset({"rigid-ft": 1}, np.random.default_rng(1), (10, 11))
    path = tmp_path / "d.csv"
    write_csv(path, ds)
    lines = path.read_text().splitlines()
    cols = lines[3].split(",")
    cols[1] = "rigid"  # line 4: unknown source
    lines[3] = ",".join(cols)
    cols = lines[6].split(",")
    cols[5] = "nan"  # line 7: a signal is NaN
    lines[6] = ",".join(cols)
    lines[8] = lines[8] + ",extra"  # line 9: field count
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(DatasetError) as exc:
        read_csv(path)
    msg = str(exc.value)
    assert "3 bad row(s)" in msg and "line 4: source" in msg and "line 7: e3" in msg and "line 9" in msg
    kept, bad = read_csv(path, on_bad="skip")
    assert [w for w, _ in bad] == [4, 7, 9]
    assert len(kept) == len(ds) - 3


def test_projected_rows_need_a_rotation(tmp_path: Path) -> None:
    path = tmp_path / "d.csv"
    cols = ["trial_id", "source", "t", *CHANNEL_NAMES, "fx", "fy", "fz", "projected"]
    path.write_text(
        ",".join(cols) + "\n" + ",".join(["a", "planar-pushing", "0"] + ["0"] * 44 + ["1", "0", "0", "1"]) + "\n"
    )
    with pytest.raises(DatasetError, match="line 2: projected label needs"):
        read_csv(path)


RAW_HEADER = ["trial_id", "source", "t", *RAW_COLUMNS, "fx", "fy", "fz", "projected"]


def _raw_trial_rows(trial: str, base: float, n_tare: int, n_press: int, label: str = "2") -> list[list[str]]:
    """n_tare contact-free rows (label 0 0 0), then a press: electrodes drop 500, pdc rises 100."""
    rows = []
    for i in range(n_tare + n_press):
        pressed = i >= n_tare
        signals = [base - 500.0 if pressed else base] * 44
        signals[19] = base + 100.0 if pressed else base  # pdc
        f = ["0", "0", label] if pressed else ["0", "0", "0"]
        rows.append([trial, "rigid-ft", f"{(i - n_tare) * 0.01:.2f}"] + [str(v) for v in signals] + f + ["0"])
    return rows


def _write(path: Path, rows: list[list[str]], head: list[str] = RAW_HEADER) -> Path:
    path.write_text("\n".join(",".join(r) for r in [head] + rows) + "\n")
    return path


@pytest.mark.parametrize("on_bad", ["raise", "skip"])
def test_raw_file_tares_on_its_leading_zero_label_rows(tmp_path: Path, on_bad: str) -> None:
    # regression: zero-label tare rows were rejected as bad rows; skipping them tared on the presses
    path = _write(tmp_path / "raw.csv", _raw_trial_rows("a", 3000.0, 12, 30) + _raw_trial_rows("b", 2000.0, 10, 25))
    ds, bad = read_csv(path, on_bad=on_bad)
    assert bad == []
    for trial, n_press in (("a", 30), ("b", 25)):
        tared = ds.tared[ds.trial_id == trial]
        assert len(tared) == n_press - 9  # contact gate: pdc > 10 for 10 rows
        np.testing.assert_allclose(tared[:, 0], -500.0)  # baseline = the tare rows, not the presses
        np.testing.assert_allclose(tared[:, 19], 100.0)
    assert np.all(np.linalg.norm(ds.f_sensor, axis=1) > 0)
    np.testing.assert_allclose(ds.t[ds.trial_id == "b"][0], 0.09)


def test_raw_file_needs_ten_tare_rows_per_trial(tmp_path: Path) -> None:
    path = _write(tmp_path / "raw.csv", _raw_trial_rows("a", 3000.0, 12, 30) + _raw_trial_rows("short", 2000.0, 6, 30))
    with pytest.raises(DatasetError, match=r"trial 'short' \(line 44\): 6 contact-free tare row\(s\).*at least 10"):
        read_csv(path)
    assert len(read_csv(path, min_tare_rows=5)[0]) == 2 * 21


def test_raw_stream_rows_without_force_or_label_are_not_samples(tmp_path: Path) -> None:
    rows = _raw_trial_rows("a", 3000.0, 10, 30)
    rows[10 + 15][-4:-1] = ["0", "0", "0"]  # released for one row: gate stays on, not a sample
    rows[10 + 16][-4:-1] = ["", "", ""]  # no label known: not a sample
    ds, _ = read_csv(_write(tmp_path / "raw.csv", rows))
    assert len(ds) == 21 - 2
    # an unlabelled first stream row ends the tare window (it may be in contact)
    rows = _raw_trial_rows("b", 3000.0, 10, 30)
    rows[3][-4:-1] = ["", "", ""]
    with pytest.raises(DatasetError, match="3 contact-free tare row"):
        read_csv(_write(tmp_path / "raw2.csv", rows))


def test_tared_file_still_rejects_zero_and_missing_labels(tmp_path: Path) -> None:
    head = ["trial_id", "source", "t", *CHANNEL_NAMES, "fx", "fy", "fz", "projected"]
    rows = [
        ["a", "rigid-ft", "0"] + ["1"] * 44 + ["0", "0", "0", "0"],
        ["a", "rigid-ft", "0"] + ["1"] * 44 + ["", "", "", "0"],
    ]
    with pytest.raises(DatasetError, match="line 2: fx, fy, fz: a non-zero force label.*line 3: fx: a number"):
        read_csv(_write(tmp_path / "t.csv", rows, head))


def test_missing_columns_named(tmp_path: Path) -> None:
    path = tmp_path / "d.csv"
    path.write_text("trial_id,source,t\n")
    with pytest.raises(DatasetError, match="missing column"):
        read_csv(path)
    assert header()[:3] == ["trial_id", "source", "t"]


def test_parquet_reader(tmp_path: Path) -> None:
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    ds = _dataset({"ball-ft": 2}, np.random.default_rng(2))
    cols = {"trial_id": ds.trial_id.tolist(), "source": ds.source.tolist(), "t": ds.t.tolist()}
    for j, name in enumerate(CHANNEL_NAMES):
        cols[name] = ds.tared[:, j].tolist()
    for j, name in enumerate(("fx", "fy", "fz")):
        cols[name] = ds.f_sensor[:, j].tolist()
    cols["projected"] = [0] * len(ds)
    cols["fx"][3] = float("inf")
    pq.write_table(pa.table(cols), tmp_path / "d.parquet")
    with pytest.raises(DatasetError, match="row 4: fx"):
        read_dataset(tmp_path / "d.parquet")


@settings(max_examples=30, deadline=None)
@given(
    counts=st.fixed_dictionaries({s: st.integers(0, 25) for s in ("rigid-ft", "ball-ft", "planar-pushing")}),
    seed=st.integers(0, 10_000),
    test_n=st.integers(1, 300),
)
def test_split_never_leaks_a_trial(counts: dict[str, int], seed: int, test_n: int) -> None:
    if sum(counts.values()) == 0:
        return
    ds = _dataset(counts, np.random.default_rng(seed))
    sp = split_by_trials(ds, seed=seed, test_per_source=test_n)
    sets = [set(ds.trial_id[ix]) for ix in (sp.train, sp.val, sp.test)]
    assert not (sets[0] & sets[1]) and not (sets[0] & sets[2]) and not (sets[1] & sets[2])
    assert len(np.intersect1d(sp.train, sp.val)) == 0
    for source in ds.sources():
        assert np.sum(ds.source[sp.test] == source) <= test_n
        n_trials = counts[source]
        if n_trials >= 3:  # every split gets whole trials of each source
            for ix in (sp.train, sp.val, sp.test):
                assert np.any(ds.source[ix] == source)
    # train + val contain whole trials (every sample of those trials)
    for ix in (sp.train, sp.val):
        for trial in set(ds.trial_id[ix]):
            assert np.sum(ds.trial_id[ix] == trial) == np.sum(ds.trial_id == trial)


def test_split_fractions_on_many_trials() -> None:
    ds = _dataset({"rigid-ft": 200}, np.random.default_rng(5))
    sp = split_by_trials(ds, test_per_source=1500)
    assert 0.75 < len(sp.train) / len(ds) < 0.85
    assert 0.05 < len(sp.val) / len(ds) < 0.15
