"""Dataset of labelled tactile samples: one row per sample.

Columns (CSV header or Parquet column names):

- ``trial_id`` (text), ``source`` (``rigid-ft``, ``ball-ft``, ``planar-pushing``), ``t`` (s);
- the 44 signals, either TARED under the channel names ``e1..e19, pdc, pac1..pac22, tdc, tac``
  (value - baseline, counts) or RAW under ``raw_e1 .. raw_tac``;
- ``fx, fy, fz``: force label in N, sensor frame, the force ON the sensor skin (docs/design.md 4);
- ``projected`` (0/1): only the components parallel to the support plane are trusted
  (planar pushing); then ``r00 .. r22`` (row-major R_world_sensor, the sensor orientation in
  the world, whose z axis is the support-surface normal) are required.

A TARED file holds force samples only: every row needs a non-zero label.

A RAW file holds each trial's whole stream, in time order: it starts with contact-free rows
labelled ``0 0 0`` (at least ``min_tare_rows``, default 10), whose mean is the trial's tare
baseline (``value - baseline``) and which are not samples; then the press stream. There the
paper's contact gate (tared pdc > 10 counts for 10 consecutive rows, counted from the first row
after the tare rows) and a non-zero label pick the samples; rows labelled ``0 0 0`` (no force)
or with an empty / NaN label (no label known, e.g. a static planar push) stay in the stream
for the gate but are not samples.

Extra columns are ignored. Bad rows are reported with their line number (CSV) or row number
(Parquet), never silently dropped.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grasp_ctrl.config.sensor_layout import CHANNEL_NAMES, FRAME_LEN, PDC
from grasp_ctrl.errors import GraspCtrlError
from grasp_ctrl.learning.gate import GateRule, contact_gate

SOURCES = ("rigid-ft", "ball-ft", "planar-pushing")
LABEL_COLUMNS = ("fx", "fy", "fz")
ROTATION_COLUMNS = tuple(f"r{i}{j}" for i in range(3) for j in range(3))
RAW_COLUMNS = tuple(f"raw_{c}" for c in CHANNEL_NAMES)
MAX_REPORTED = 10


class DatasetError(GraspCtrlError):
    exit_status = 2


@dataclass
class Dataset:
    trial_id: np.ndarray  # (n,) str
    source: np.ndarray  # (n,) str
    t: np.ndarray  # (n,) s
    tared: np.ndarray  # (n, 44) counts
    f_sensor: np.ndarray  # (n, 3) N
    projected: np.ndarray  # (n,) bool
    r_world_sensor: np.ndarray  # (n, 3, 3); identity where not projected

    def __len__(self) -> int:
        return len(self.t)

    def subset(self, mask_or_index: np.ndarray) -> Dataset:
        return Dataset(*(getattr(self, f)[mask_or_index] for f in _FIELDS))

    @staticmethod
    def concat(parts: Sequence[Dataset]) -> Dataset:
        return Dataset(*(np.concatenate([getattr(p, f) for p in parts]) for f in _FIELDS))

    def sources(self) -> list[str]:
        return [s for s in SOURCES if np.any(self.source == s)]


_FIELDS = ("trial_id", "source", "t", "tared", "f_sensor", "projected", "r_world_sensor")


class _Problems:
    def __init__(self, path: Path, unit: str) -> None:
        self.path = path
        self.unit = unit
        self.items: list[tuple[int, str]] = []

    def add(self, where: int, msg: str) -> None:
        self.items.append((where, msg))

    def raise_if_any(self) -> None:
        if not self.items:
            return
        shown = "; ".join(f"{self.unit} {w}: {m}" for w, m in self.items[:MAX_REPORTED])
        more = f" (and {len(self.items) - MAX_REPORTED} more)" if len(self.items) > MAX_REPORTED else ""
        raise DatasetError(f"{self.path}: {len(self.items)} bad row(s): {shown}{more}")


def _columns_spec(header: Sequence[str], path: Path) -> tuple[list[str], bool]:
    names = set(header)
    required = ["trial_id", "source", "t", *LABEL_COLUMNS, "projected"]
    missing = [c for c in required if c not in names]
    if missing:
        raise DatasetError(f"{path}: missing column(s) {', '.join(missing)}")
    if all(c in names for c in CHANNEL_NAMES):
        return list(CHANNEL_NAMES), False
    if all(c in names for c in RAW_COLUMNS):
        return list(RAW_COLUMNS), True
    absent = [c for c in CHANNEL_NAMES if c not in names]
    raise DatasetError(f"{path}: missing signal column(s) {', '.join(absent[:5])} (tared e1..tac or raw_e1..raw_tac)")


LABEL_SAMPLE, LABEL_ZERO, LABEL_NONE = 0, 1, 2  # a force label, "0 0 0" (no force), no label known


def _parse_rows(
    records: Iterable[tuple[int, dict[str, object]]],
    signal_cols: list[str],
    has_rot: bool,
    raw: bool,
    problems: _Problems,
) -> dict[str, list]:
    out: dict[str, list] = {f: [] for f in ("where", "trial_id", "source", "t", "z", "f", "kind", "proj", "r")}
    for where, rec in records:
        try:
            trial = str(rec["trial_id"]).strip()
            source = str(rec["source"]).strip()
            if not trial:
                raise ValueError("trial_id: empty")
            if source not in SOURCES:
                raise ValueError(f"source: one of {', '.join(SOURCES)} (got {source!r})")
            t = _num(rec, "t")
            z = [_num(rec, c) for c in signal_cols]
            f, kind = _label(rec, raw)
            proj_val = _num(rec, "projected")
            if proj_val not in (0.0, 1.0):
                raise ValueError(f"projected: 0 or 1 (got {rec['projected']!r})")
            proj = proj_val == 1.0
            if proj:
                if not has_rot:
                    raise ValueError("projected label needs the sensor orientation columns r00..r22")
                r = np.array([_num(rec, c) for c in ROTATION_COLUMNS]).reshape(3, 3)
                with np.errstate(all="ignore"):
                    orthonormal = np.max(np.abs(r @ r.T - np.eye(3))) <= 1e-3 and np.linalg.det(r) > 0
                if not orthonormal:
                    raise ValueError("r00..r22: not a rotation matrix")
            else:
                r = np.eye(3)
        except ValueError as exc:
            problems.add(where, str(exc))
            continue
        for key, value in (
            ("where", where),
            ("trial_id", trial),
            ("source", source),
            ("t", t),
            ("z", z),
            ("f", f),
            ("kind", kind),
            ("proj", proj),
            ("r", r),
        ):
            out[key].append(value)
    return out


def _is_missing(value: object) -> bool:
    if value is None:
        return True
    if isinstance(value, str):
        return value.strip() == "" or value.strip().lower() == "nan"
    return isinstance(value, float) and math.isnan(value)


def _label(rec: dict[str, object], raw: bool) -> tuple[list[float], int]:
    """The force label and its kind; raw files may hold "0 0 0" and unlabelled rows."""
    if raw and all(_is_missing(rec.get(c)) for c in LABEL_COLUMNS):
        return [0.0, 0.0, 0.0], LABEL_NONE
    f = [_num(rec, c) for c in LABEL_COLUMNS]
    if not any(f):
        if raw:
            return f, LABEL_ZERO
        raise ValueError("fx, fy, fz: a non-zero force label (a tared file holds force samples only)")
    return f, LABEL_SAMPLE


def _num(rec: dict[str, object], col: str) -> float:
    value: Any = rec.get(col)  # a CSV or Parquet cell: float() refuses what is not a number
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{col}: a number (got {_short(value)})") from None
    if not math.isfinite(v):
        raise ValueError(f"{col}: a finite number (got {_short(value)})")
    return v


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _build(cols: dict[str, list], raw: bool, min_tare_rows: int, path: Path, gate: GateRule) -> Dataset:
    n = len(cols["t"])
    if n == 0:
        raise DatasetError(f"{path}: no samples")
    z = np.asarray(cols["z"], dtype=float).reshape(n, FRAME_LEN)
    trial = np.asarray(cols["trial_id"], dtype=object).astype(str)
    keep = np.ones(n, dtype=bool)
    if raw:
        z, keep = _tare_and_gate(
            z, trial, np.asarray(cols["kind"]), np.asarray(cols["where"]), min_tare_rows, path, gate
        )
        if not keep.any():
            raise DatasetError(
                f"{path}: no samples (no labelled row with the contact gate on: tared pdc > "
                f"{gate.pdc_threshold:g} counts for {gate.frames} rows)"
            )
    with np.errstate(all="ignore"):
        finite = np.isfinite(z[keep]).all()
    if not finite:
        raise DatasetError(f"{path}: signals too large: not finite after taring")
    return Dataset(
        trial_id=trial[keep],
        source=np.asarray(cols["source"]).astype(str)[keep],
        t=np.asarray(cols["t"], dtype=float)[keep],
        tared=z[keep],
        f_sensor=np.asarray(cols["f"], dtype=float).reshape(n, 3)[keep],
        projected=np.asarray(cols["proj"], dtype=bool)[keep],
        r_world_sensor=np.asarray(cols["r"], dtype=float).reshape(n, 3, 3)[keep],
    )


def _tare_and_gate(
    z: np.ndarray,
    trial: np.ndarray,
    kind: np.ndarray,
    where: np.ndarray,
    min_tare_rows: int,
    path: Path,
    gate: GateRule,
) -> tuple[np.ndarray, np.ndarray]:
    """Raw rows -> (tared rows, sample mask): per trial, its leading "0 0 0" rows are the baseline."""
    tared = z.copy()
    keep = np.zeros(len(z), dtype=bool)
    for tid in dict.fromkeys(trial.tolist()):  # trials in file order
        idx = np.flatnonzero(trial == tid)
        not_tare = np.flatnonzero(kind[idx] != LABEL_ZERO)
        n_tare = int(not_tare[0]) if len(not_tare) else len(idx)
        if n_tare < min_tare_rows:
            raise DatasetError(
                f"{path}: trial {tid!r} (line {where[idx[0]]}): {n_tare} contact-free tare row(s) labelled 0 0 0 "
                f"at its start, at least {min_tare_rows} needed (raw signals are tared on them)"
            )
        with np.errstate(all="ignore"):
            tared[idx] -= z[idx[:n_tare]].mean(axis=0)
        stream = idx[n_tare:]
        keep[stream] = contact_gate(tared[stream, PDC], gate) & (kind[stream] == LABEL_SAMPLE)
    return tared, keep


def read_csv(
    path: str | Path, min_tare_rows: int = 10, on_bad: str = "raise", gate: GateRule = GateRule()
) -> tuple[Dataset, list[tuple[int, str]]]:
    """Read a dataset CSV. ``on_bad="raise"`` fails listing the bad lines; ``"skip"``
    leaves them out and returns them as (line, problem) for the caller to report."""
    p = Path(path)
    try:
        fh = p.open(newline="", encoding="utf-8-sig")
    except OSError as exc:
        raise DatasetError(f"{p}: cannot read ({exc.strerror or exc})") from None
    problems = _Problems(p, "line")
    with fh:
        reader = csv.reader(fh)
        try:
            header = [h.strip() for h in next(reader, [])]
            if not header:
                raise DatasetError(f"{p}: empty file")
            signal_cols, raw = _columns_spec(header, p)
            has_rot = all(c in header for c in ROTATION_COLUMNS)

            def records() -> Iterable[tuple[int, dict[str, object]]]:
                for row in reader:
                    if not row:
                        continue
                    if len(row) != len(header):
                        problems.add(reader.line_num, f"{len(row)} fields, the header has {len(header)}")
                        continue
                    yield reader.line_num, dict(zip(header, row))

            cols = _parse_rows(records(), signal_cols, has_rot, raw, problems)
        except UnicodeDecodeError as exc:
            raise DatasetError(
                f"{p}: not UTF-8 text (byte {exc.start} of a block near line {reader.line_num + 1})"
            ) from None
        except csv.Error as exc:
            raise DatasetError(f"{p}: line {reader.line_num}: not valid CSV ({exc})") from None
    if on_bad == "raise":
        problems.raise_if_any()
    return _build(cols, raw, min_tare_rows, p, gate), problems.items


def read_parquet(
    path: str | Path, min_tare_rows: int = 10, on_bad: str = "raise", gate: GateRule = GateRule()
) -> tuple[Dataset, list[tuple[int, str]]]:
    """Parquet with the same columns (needs pyarrow); rows are numbered from 1."""
    p = Path(path)
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise DatasetError(f"{p}: reading Parquet needs pyarrow (pip install pyarrow)") from None
    try:
        table = pq.read_table(p)
    except Exception as exc:  # pyarrow raises its own types for corrupt files
        raise DatasetError(
            f"{p}: unreadable Parquet ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})"
        ) from None
    header = [str(c) for c in table.column_names]
    signal_cols, raw = _columns_spec(header, p)
    has_rot = all(c in header for c in ROTATION_COLUMNS)
    data = table.to_pydict()
    problems = _Problems(p, "row")
    records = ((i + 1, {c: data[c][i] for c in header}) for i in range(table.num_rows))
    cols = _parse_rows(records, signal_cols, has_rot, raw, problems)
    if on_bad == "raise":
        problems.raise_if_any()
    return _build(cols, raw, min_tare_rows, p, gate), problems.items


def read_dataset(
    path: str | Path, min_tare_rows: int = 10, on_bad: str = "raise"
) -> tuple[Dataset, list[tuple[int, str]]]:
    p = Path(path)
    if p.suffix.lower() in (".parquet", ".pq"):
        return read_parquet(p, min_tare_rows, on_bad)
    return read_csv(p, min_tare_rows, on_bad)


def read_datasets(
    paths: Sequence[str | Path], min_tare_rows: int = 10, on_bad: str = "raise"
) -> tuple[Dataset, list[str]]:
    parts, notes = [], []
    for path in paths:
        ds, bad = read_dataset(path, min_tare_rows, on_bad)
        parts.append(ds)
        notes += [f"{path}: line {w}: {m}" for w, m in bad]
    return Dataset.concat(parts), notes


def header(raw: bool = False) -> list[str]:
    signals = RAW_COLUMNS if raw else CHANNEL_NAMES
    return ["trial_id", "source", "t", *signals, *LABEL_COLUMNS, "projected", *ROTATION_COLUMNS]


def _cells(values: np.ndarray) -> list[str]:
    """Shortest text that reads back to the same float (a written file trains like the arrays)."""
    return [repr(float(v)) for v in values]


@contextlib.contextmanager
def _text_output(path: str | Path) -> Iterator[io.StringIO]:
    """Collect the text, then write it as a new file (a symlink there is replaced, not followed)."""
    from grasp_ctrl.files.safe_write import write_output

    buf = io.StringIO(newline="")
    yield buf
    write_output(path, buf.getvalue())


def write_csv(path: str | Path, ds: Dataset) -> None:
    """A TARED dataset file: one row per force sample."""
    with _text_output(path) as fh:
        w = csv.writer(fh)
        w.writerow(header())
        for i in range(len(ds)):
            w.writerow(
                [ds.trial_id[i], ds.source[i], repr(float(ds.t[i]))]
                + _cells(ds.tared[i])
                + _cells(ds.f_sensor[i])
                + [int(ds.projected[i])]
                + _cells(ds.r_world_sensor[i].ravel())
            )


@dataclass
class RawTrial:
    """One trial's whole stream for a RAW file: tare rows (label 0 0 0) first, then the presses."""

    trial_id: str
    source: str
    t: np.ndarray  # (m,) s
    raw: np.ndarray  # (m, 44) counts
    f_sensor: np.ndarray  # (m, 3) N; 0 0 0 = no force, NaN = no label known
    projected: np.ndarray  # (m,) bool
    r_world_sensor: np.ndarray  # (m, 3, 3)


def write_raw_csv(path: str | Path, trials: Iterable[RawTrial]) -> None:
    with _text_output(path) as fh:
        w = csv.writer(fh)
        w.writerow(header(raw=True))
        for tr in trials:
            for i in range(len(tr.t)):
                label = tr.f_sensor[i]
                label_cells = ["", "", ""] if np.isnan(label).any() else _cells(label)
                w.writerow(
                    [tr.trial_id, tr.source, repr(float(tr.t[i]))]
                    + _cells(tr.raw[i])
                    + label_cells
                    + [int(tr.projected[i])]
                    + _cells(tr.r_world_sensor[i].ravel())
                )
