"""Property tests of the dataset reader: whatever the file holds, the result is a valid
Dataset or one clean one-line DatasetError, never a traceback."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from grasp_ctrl.config.sensor_layout import CHANNEL_NAMES
from grasp_ctrl.learning.dataset import (
    LABEL_COLUMNS,
    RAW_COLUMNS,
    ROTATION_COLUMNS,
    SOURCES,
    Dataset,
    DatasetError,
    read_csv,
)

SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _read(content: bytes, on_bad: str, min_tare_rows: int = 10) -> Dataset | None:
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "data.csv"
        path.write_bytes(content)
        try:
            ds, bad = read_csv(path, min_tare_rows=min_tare_rows, on_bad=on_bad)
        except DatasetError as exc:
            msg = str(exc)
            assert msg and "\n" not in msg and "Traceback" not in msg
            return None
    _assert_valid(ds)
    assert all(isinstance(w, int) and isinstance(m, str) and "\n" not in m for w, m in bad)
    return ds


def _assert_valid(ds: Dataset) -> None:
    n = len(ds)
    assert n > 0
    assert ds.tared.shape == (n, 44) and ds.f_sensor.shape == (n, 3) and ds.r_world_sensor.shape == (n, 3, 3)
    assert ds.trial_id.shape == ds.source.shape == ds.projected.shape == (n,)
    assert np.isfinite(ds.tared).all() and np.isfinite(ds.f_sensor).all() and np.isfinite(ds.t).all()
    assert np.all(np.linalg.norm(ds.f_sensor, axis=1) > 0)
    assert set(ds.source) <= set(SOURCES)
    assert all(t.strip() for t in ds.trial_id)
    r = ds.r_world_sensor
    assert np.allclose(np.einsum("nij,nkj->nik", r, r), np.eye(3), atol=1e-3)


@SETTINGS
@given(content=st.binary(max_size=400), on_bad=st.sampled_from(["raise", "skip"]))
def test_arbitrary_bytes(content: bytes, on_bad: str) -> None:
    _read(content, on_bad)


@SETTINGS
@given(text=st.text(max_size=300), on_bad=st.sampled_from(["raise", "skip"]))
def test_header_then_arbitrary_text(text: str, on_bad: str) -> None:
    head = ",".join(["trial_id", "source", "t", *RAW_COLUMNS, *LABEL_COLUMNS, "projected"])
    _read((head + "\n" + text).encode("utf-8", "surrogatepass"), on_bad)


# cells: plausible numbers most of the time, hostile text otherwise
HOSTILE = st.sampled_from(
    [
        "",
        " ",
        "nan",
        "NaN",
        "inf",
        "-inf",
        "1e400",
        "-1e308",
        "1e308",
        "0x10",
        "1_0",
        "\x00",
        '"',
        '""',
        "a,b",
        "\u00e9",
        "\ufeff1",
        "1e-320",
        "True",
        "None",
        "--1",
    ]
)
NUMBER = st.one_of(st.integers(-5000, 5000).map(str), st.floats(allow_nan=True, allow_infinity=True).map(repr))
CELL = st.one_of(NUMBER, NUMBER, NUMBER, HOSTILE, st.text(max_size=6))


@st.composite
def _structured_rows(draw: st.DrawFn) -> tuple[list[str], list[list[str]]]:
    signals = list(draw(st.sampled_from([RAW_COLUMNS, CHANNEL_NAMES])))
    head = ["trial_id", "source", "t", *signals, *LABEL_COLUMNS, "projected"]
    if draw(st.booleans()):
        head += list(ROTATION_COLUMNS)
    if draw(st.booleans()):  # a column missing or repeated
        k = draw(st.integers(0, len(head) - 1))
        head = head[:k] + head[k + 1 :] if draw(st.booleans()) else head + [head[k]]
    n_rows = draw(st.integers(0, 30))
    trials = draw(st.lists(st.sampled_from(["a", "b", " ", "c\nd"]), min_size=1, max_size=3))
    rows = []
    for _ in range(n_rows):
        row = [draw(st.sampled_from(trials)), draw(st.sampled_from([*SOURCES, "rigid", ""]))]
        row += [draw(CELL) for _ in range(len(head) - 2)]
        labels = [head.index(c) for c in LABEL_COLUMNS if c in head]
        if labels and draw(st.booleans()):  # many contact-free "0 0 0" rows
            for j in labels:
                row[j] = "0"
        if "projected" in head and draw(st.booleans()):
            row[head.index("projected")] = draw(st.sampled_from(["0", "1", "2"]))
        if draw(st.integers(0, 9)) == 0:  # wrong field count
            row = row[:-1] if draw(st.booleans()) else row + ["x"]
        rows.append(row)
    return head, rows


def _csv_text(head: list[str], rows: list[list[str]]) -> bytes:
    def cell(c: str) -> str:
        return '"' + c.replace('"', '""') + '"' if any(ch in c for ch in ',"\n\r') else c

    return ("\n".join(",".join(cell(c) for c in r) for r in [head] + rows) + "\n").encode("utf-8", "surrogatepass")


@SETTINGS
@given(table=_structured_rows(), on_bad=st.sampled_from(["raise", "skip"]), min_tare=st.integers(1, 12))
def test_hostile_cells_in_a_plausible_table(
    table: tuple[list[str], list[list[str]]], on_bad: str, min_tare: int
) -> None:
    _read(_csv_text(*table), on_bad, min_tare)


@SETTINGS
@given(
    base=st.floats(0, 4000),
    noise=st.floats(0, 50),
    n_tare=st.integers(10, 30),
    n_press=st.integers(0, 40),
    drop=st.floats(20, 800),
    seed=st.integers(0, 2**16),
)
def test_valid_raw_trial_is_tared_on_its_tare_rows(
    base: float, noise: float, n_tare: int, n_press: int, drop: float, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    raw = base + noise * rng.standard_normal((n_tare + n_press, 44))
    raw[n_tare:, :19] -= drop
    raw[n_tare:, 19] += drop
    head = ["trial_id", "source", "t", *RAW_COLUMNS, *LABEL_COLUMNS, "projected"]
    rows = []
    for i in range(n_tare + n_press):
        label = ["0", "0", "0"] if i < n_tare else ["0.1", "-0.2", "3"]
        rows.append(["tr", "ball-ft", repr(i / 100)] + [repr(float(v)) for v in raw[i]] + label + ["0"])
    ds = _read(_csv_text(head, rows), "raise")
    tared = raw - raw[:n_tare].mean(axis=0)
    above = tared[n_tare:, 19] > 10
    expected = [i for i in range(n_press) if i >= 9 and above[i - 9 : i + 1].all()]
    if not expected:
        assert ds is None
        return
    assert ds is not None
    np.testing.assert_allclose(ds.tared, tared[n_tare:][expected], rtol=0, atol=1e-9)
